"""LeRobot import benchmark: ``dmprs demos import`` of a LeRobot v3.0 dataset at scale.

Workload: datasets of 200 and 1,000 episodes in the v3.0 layout (50 episodes per data file, as
LeRobot writes several episodes per file; episode metadata in ``meta/episodes/...`` parquet,
tasks in ``meta/tasks.parquet``), written by ``tests/lerobot_writer.py``: 3-D float32
``observation.state`` at 50 fps, episodes of 10 to 11.8 s (about 550 frames each). Measured, each
in a fresh child process (wall time and peak RSS from ``resource.getrusage``):

* ``dmprs demos import DIR --query-field bottle_volume --out DB`` end to end (read, check, build
  and save the database of one demo per episode);
* ``dmprs.io.read_lerobot`` alone (file by file);
* what a user would otherwise write with pyarrow: the whole ``data/`` directory read as one
  table (``pyarrow.parquet.read_table``), sorted and split into one (frames, 3) array per episode.

    python benches/bench_import.py [episodes ...]

Prints a markdown table.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CHILD = r"""
import json, resource, sys, time
from pathlib import Path
kind, root, out = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[3])
t0 = time.perf_counter()
if kind == "cli":
    from dmprs.cli import main
    main(["demos", "import", str(root), "--query-field", "bottle_volume", "--out", str(out), "--no-progress"],
         standalone_mode=False)
    import dmprs
    n = len(dmprs.Database.load(out))
elif kind == "read":
    from dmprs.io import read_lerobot
    n = len(read_lerobot(root))
else:
    import numpy as np
    import pyarrow.compute as pc
    import pyarrow.parquet as pq
    table = pq.read_table(root / "data", columns=["observation.state", "episode_index", "frame_index", "timestamp"])
    ep = table.column("episode_index").to_numpy()
    order = np.lexsort((table.column("frame_index").to_numpy(), ep))
    y = pc.list_flatten(table.column("observation.state")).to_numpy().reshape(len(ep), -1)[order]
    t = table.column("timestamp").to_numpy()[order]
    ep = ep[order]
    cuts = np.flatnonzero(np.diff(ep)) + 1
    n = len([(a, b) for a, b in zip(np.split(t, cuts), np.split(y, cuts))])
seconds = time.perf_counter() - t0
print(json.dumps({"episodes": n, "seconds": seconds, "rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}))
"""

KINDS = {"cli": "`dmprs demos import` (end to end)", "read": "`dmprs.io.read_lerobot`",
         "pyarrow": "pyarrow: whole table, split by episode"}


def measure(kind: str, root: Path, tmp: Path) -> dict:
    out = tmp / f"db-{kind}-{time.monotonic_ns()}"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "python"), str(ROOT), os.environ.get("PYTHONPATH", "")])}
    res = subprocess.run([sys.executable, "-c", CHILD, kind, str(root), str(out)], capture_output=True, text=True,
                         env=env, check=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main(sizes: list[int], repeats: int = 2) -> None:
    sys.path[:0] = [str(ROOT / "python"), str(ROOT)]
    from tests.lerobot_writer import episode_states, write_v3

    print(f"python {platform.python_version()}, {os.cpu_count()} cores, {platform.machine()}; best of {repeats} "
          "(seconds) and the largest peak RSS\n")
    print("| episodes | frames | data files | reader | episodes read | time (s) | peak RSS (MB) | time vs dmprs import |")
    print("|---:|---:|---:|---|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        for n in sizes:
            root = write_v3(tmp / f"ds{n}", n, per_file=50, period=10, base_s=10.0)
            frames = sum(len(episode_states(k, 10, 10.0)) for k in range(n))
            files = len(list((root / "data").glob("**/*.parquet")))
            base = None
            for kind, label in KINDS.items():
                runs = [measure(kind, root, tmp) for _ in range(repeats)]
                assert all(r["episodes"] == n for r in runs), runs
                best = min(r["seconds"] for r in runs)
                rss = max(r["rss_mb"] for r in runs)
                base = base or best
                print(f"| {n} | {frames} | {files} | {label} | {n} | {best:.2f} | {rss:.0f} | {best / base:.2f}x |",
                      flush=True)


if __name__ == "__main__":
    main([int(a) for a in sys.argv[1:]] or [200, 1000])
