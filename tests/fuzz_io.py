"""Hostile inputs for the importers: ROS bags, LeRobot datasets, CSV / npz / query tables, and
``dmprs demos import`` end to end, in the format of ``tests/fuzz_targets.py`` (``IO_TARGETS``:
name -> (strategy, runner)).

Each strategy draws a valid recording written by the test writers (``tests/bag_writers.py``,
``tests/lerobot_writer.py``) and a way to damage it: truncation, flipped bytes, crafted
metadata.yaml / info.json, wrong dtypes, missing columns, odd stamps, non-finite values, FIFOs
and links to /dev/zero in place of files, huge declared sizes, compression bombs. The runner
writes it into a fresh temporary directory and reads it with the public API only (so the same
targets run against older versions of dmprs). A read that succeeds on input that cannot be
meant (a zero stamp among set ones, a NaN, a duplicate joint, a 2-frame episode, a FIFO, a
bomb) raises :class:`~tests.fuzz_verdicts.AcceptedGarbage`; so does a result with fewer than 3
samples, a non-finite value, or a gap in time of more than an hour; a refusal that names no file
or argument raises :class:`~tests.fuzz_verdicts.UnclearMessage`. ``tests/fuzz_tally.py`` counts
them with the other targets (``python3 -m tests.fuzz_tally 250 "ROS bag"``);

    python3 -m tests.fuzz_io --bombs

measures what each compression bomb (and a huge ``--rate``, a link to /dev/zero) costs: time,
peak RSS and temporary files.
"""

from __future__ import annotations

import functools
import io
import json
import os
import re
import struct
import tempfile
import zipfile
import zlib
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import strategies as st

import dmprs
from dmprs.errors import DmprsError
from tests.fuzz_verdicts import AcceptedGarbage, UnclearMessage

T0 = 1_700_000_000 * 10**9
BOMB_ZEROS = 96 * 2**20  # beyond the 64 MiB + 100 x compressed limit of every zstd or bz2 bag piece
BOMB_ZEROS_LZ4 = 256 * 2**20  # lz4 compresses at most 255 x: a bomb needs more zeros to pass the limit


# --- checks on what came back -------------------------------------------------------------------

def _check_trajectory(traj: Any, what: str) -> None:
    arrays = [traj.t, traj.pose] if isinstance(traj, dmprs.CartesianTrajectory) else [traj.t, traj.y]
    if len(traj.t) < 3:
        raise AcceptedGarbage(f"{what}: {len(traj.t)} samples accepted (a fit needs 3)")
    if not all(np.isfinite(a).all() for a in arrays):
        raise AcceptedGarbage(f"{what}: non-finite values accepted")
    if np.diff(traj.t).max() > 3600.0 or traj.t[-1] - traj.t[0] > 1e6:
        raise AcceptedGarbage(f"{what}: a {np.diff(traj.t).max():.3g} s gap / {traj.t[-1] - traj.t[0]:.3g} s span accepted")


def _check(out: Any, refuse: str | None) -> list[Any]:
    if refuse:
        raise AcceptedGarbage(f"accepted: {refuse}")
    items = out if isinstance(out, list) else [out]
    for k, item in enumerate(items):
        traj = getattr(item, "trajectory", item)
        if isinstance(traj, (dmprs.Trajectory, dmprs.CartesianTrajectory)):
            _check_trajectory(traj, f"result {k}")
        names = getattr(item, "names", None)
        if names and len(set(names)) != len(names):
            raise AcceptedGarbage(f"duplicate joint names accepted: {names}")
    return items


# --- damage shared by every kind of file ---------------------------------------------------------

def _flip(data: bytes, seed: int, n: int) -> bytes:
    out = bytearray(data)
    rng = np.random.default_rng(seed)
    for j in rng.integers(0, max(len(out), 1), n):
        if out:
            out[j] ^= int(rng.integers(1, 256))
    return bytes(out)


def _replace_file(path: Path, how: str, frac: float, seed: int, nflip: int) -> str | None:
    """Damages the file ``path``; returns why a read must now fail (or None if it may succeed)."""
    if how == "truncate":
        data = path.read_bytes()
        path.write_bytes(data[: int(len(data) * frac)])
    elif how == "flip":
        path.write_bytes(_flip(path.read_bytes(), seed, nflip))
    elif how == "empty":
        path.write_bytes(b"")
    elif how == "fifo":
        path.unlink()
        os.mkfifo(path)
        return f"a FIFO as {path.name}"
    elif how == "devzero":
        path.unlink()
        path.symlink_to("/dev/zero")
        return f"/dev/zero as {path.name}"
    elif how == "directory":
        path.unlink()
        path.mkdir()
        return f"a directory as {path.name}"
    elif how == "missing":
        path.unlink()
    return None


FILE_DAMAGE = ["truncate", "flip", "empty", "fifo", "devzero", "directory", "missing"]


# --- ROS bags ------------------------------------------------------------------------------------

_COMPRESSIONS = {"ros2-sqlite3": ["none", "file", "message"], "ros2-mcap": ["none", "file", "message", "storage"],
                 "ros1": ["none", "bz2", "lz4"]}
_STAMPS = ["ok", "ok", "zero-one", "all-zero", "years", "negative", "duplicate", "reversed", "huge"]
_VALUES = ["ok", "ok", "nan", "inf", "dup-names", "short-position", "empty-names"]
_META_EDITS: list[tuple[str, str]] = [
    (r"version: \d+", "version: 99"), (r"version: \d+", "version: -1"), (r"version: \d+", "version: x"),
    (r"storage_identifier: \w+", "storage_identifier: nope"),
    (r"nanoseconds_since_epoch: \d+", "nanoseconds_since_epoch: 1180591620717411303424"),
    (r"nanoseconds_since_epoch: \d+", "nanoseconds_since_epoch: -5"),
    (r"nanoseconds: \d+", "nanoseconds: -99999999999"), (r"message_count: \d+", "message_count: 99999999999999999999"),
    (r"relative_file_paths:\n  - [^\n]+", "relative_file_paths:\n  - ../../../../dev/zero"),
    (r"relative_file_paths:\n  - [^\n]+", "relative_file_paths: 7"),
    (r"compression_mode: ''", "compression_mode: file"), (r"compression_format: ''", "compression_format: lz4"),
    (r"topics_with_message_count:", "topics_with_message_count: 5\n  x:"),
    (r"serialization_format: cdr", "serialization_format: json"),
    (r"\A", "a: &a [x, x, x, x, x, x, x, x, x]\nb: &b [*a, *a, *a, *a, *a, *a, *a, *a]\nc: [*b, *b, *b, *b, *b, *b]\n"),
    (r"\A", "[" * 5000),
    (r"\A", "\xff\xfe"),
]


@st.composite
def bag_args(draw: Any) -> dict[str, Any]:
    fmt = draw(st.sampled_from(list(_COMPRESSIONS)))
    return {
        "fmt": fmt, "compression": draw(st.sampled_from(_COMPRESSIONS[fmt])),
        "n": draw(st.sampled_from([20, 20, 20, 3, 2, 1])),
        "stamps": draw(st.sampled_from(_STAMPS)), "values": draw(st.sampled_from(_VALUES)),
        "damage": draw(st.sampled_from(["none"] * 6 + ["truncate", "flip", "flip", "metadata", "metadata", "bomb",
                                                       "fifo", "devzero", "missing", "empty", "metadata-fifo"])),
        "frac": draw(st.floats(0.0, 1.0)), "seed": draw(st.integers(0, 2**32 - 1)),
        "nflip": draw(st.integers(1, 64)), "edit": draw(st.sampled_from(range(len(_META_EDITS)))),
        "call": draw(st.sampled_from(["joints", "joints", "velocities", "poses", "tf", "topics"])),
    }


def _stamp_list(a: dict[str, Any]) -> list[int]:
    n, kind = a["n"], a["stamps"]
    stamps = [T0 + k * 10_000_000 for k in range(n)]
    if kind == "zero-one" and n > 1:
        stamps[n // 2] = 0
    elif kind == "all-zero":
        stamps = [0] * n
    elif kind == "years" and n > 1:
        stamps[-1] += 3 * 365 * 86400 * 10**9
    elif kind == "negative" and a["fmt"] != "ros1":
        stamps = [-T0 + k * 10_000_000 for k in range(n)]
    elif kind == "duplicate":
        stamps = [T0] * n
    elif kind == "reversed":
        stamps = stamps[::-1]
    elif kind == "huge":
        top = (2**31 - 100) * 10**9  # rosbags writes ROS 1 stamps as int32 too
        stamps = [top + k * 10_000_000 for k in range(n)]
    return stamps


def _write_bag(path: Path, a: dict[str, Any]) -> None:
    from tests.bag_writers import BagWriter

    w = BagWriter(path, a["fmt"])
    if a["compression"] != "none":
        if a["fmt"] == "ros1":
            from rosbags.rosbag1 import Writer as W1

            w.writer.set_compression(W1.CompressionFormat[a["compression"].upper()])
        else:
            from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

            w.writer.set_compression(CompressionMode[a["compression"].upper()], CompressionFormat.ZSTD)
    values = a["values"]
    with w:
        for k, ns in enumerate(_stamp_list(a)):
            y = float(np.sin(k / 5))
            if k == a["n"] // 2 and values in ("nan", "inf"):
                y = float(values)
            names, pos = ["a", "b"], [y, -y]
            if values == "dup-names":
                names = ["a", "a"]
            elif values == "short-position":
                pos = [y]
            elif values == "empty-names":
                names, pos = [], []
            recv = T0 + k * 10_000_000
            w.write("/joint_states", w.joint_state(ns, names, pos), recv)
            pose = [y, 0.0, 0.1 * k, 1.0, 0.0, 0.0, 0.0]
            w.write("/pose", w.pose_stamped(ns, "world", pose), recv)
            w.write("/tf", w.tf_message(ns, [("world", "tool", pose)]), recv)


def _bomb(path: Path, a: dict[str, Any]) -> str | None:
    from tests.bag_writers import file_bomb, mcap_chunk_bomb, message_bomb, ros1_chunk_bomb

    kind = (a["fmt"], a["compression"])
    if a["compression"] == "file":
        file_bomb(path, BOMB_ZEROS)
    elif kind == ("ros2-sqlite3", "message"):
        message_bomb(path, BOMB_ZEROS)
    elif kind == ("ros2-mcap", "storage"):
        mcap_chunk_bomb(path, BOMB_ZEROS)
    elif kind == ("ros1", "lz4"):
        ros1_chunk_bomb(path, BOMB_ZEROS_LZ4)
    else:
        return None
    return f"a compression bomb ({a['fmt']}, {a['compression']})"


def _refusals(a: dict[str, Any]) -> str | None:
    """Why a bag must be refused whatever is read from it (None: it may be read)."""
    if a["stamps"] == "zero-one" and a["n"] > 1:
        return "a zero stamp among set ones"
    if a["stamps"] == "years" and a["n"] > 1:
        return "a gap of three years"
    return None


def run_bag(a: dict[str, Any]) -> list[Any]:
    from dmprs.io import bag_topics, read_joint_states, read_poses, read_tf

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / ("demo.bag" if a["fmt"] == "ros1" else "demo")
        _write_bag(path, a)
        refuse = None
        storage = path if a["fmt"] == "ros1" else next(p for p in sorted(path.iterdir()) if p.name != "metadata.yaml")
        damage = a["damage"]
        if damage == "bomb":
            refuse = _bomb(path, a)
        elif damage == "metadata" and a["fmt"] != "ros1":
            meta = path / "metadata.yaml"
            pattern, new = _META_EDITS[a["edit"]]
            meta.write_bytes(re.sub(pattern, new, meta.read_text(), count=1).encode("utf-8", "surrogateescape")
                             if not new.startswith("\xff") else b"\xff\xfe" + meta.read_bytes())
        elif damage == "metadata-fifo" and a["fmt"] != "ros1":
            refuse = _replace_file(path / "metadata.yaml", "fifo", 0, 0, 0)
        elif damage in FILE_DAMAGE:
            refuse = _replace_file(storage, damage, a["frac"], a["seed"], a["nflip"])
        call = a["call"]
        try:
            if call == "topics":
                return _check(list(bag_topics(path).items()), refuse)
            if call in ("joints", "velocities"):
                rec = read_joint_states(path, "/joint_states", velocities=call == "velocities")
                bad = _refusals(a) or ({"nan": "a NaN position", "inf": "an infinite position",
                                        "dup-names": "a joint named twice"}.get(a["values"]))
            elif call == "poses":
                rec = read_poses(path, "/pose")
                bad = _refusals(a) or {"nan": "a NaN pose", "inf": "an infinite pose"}.get(a["values"])
            else:
                rec = read_tf(path, "world", "tool")
                bad = _refusals(a) or {"nan": "a NaN transform", "inf": "an infinite transform"}.get(a["values"])
            return _check(rec, refuse or bad)
        except DmprsError as exc:
            _require_clear(exc, tmp)
            raise


# --- LeRobot -------------------------------------------------------------------------------------

_INFO_EDITS: list[Any] = [
    [1, 2], "text", None, {"codebase_version": 3}, {"codebase_version": "v1.6"},
    {"codebase_version": "v3.0", "features": 5}, {"codebase_version": "v3.0", "features": {"observation.state": {"names": 7}}},
    {"codebase_version": "v3.0", "features": {"observation.state": {"names": {"motors": 5}}}},
    {"codebase_version": "v3.0", "features": {"observation.state": {"names": ["a"] * 3}}},
    {"codebase_version": "v3.0", "fps": 1e308}, {"codebase_version": "v3.0", "fps": -1},
]
_INFO_TEXTS = ["{" * 5000, '{"codebase_version": "v3.0", "fps": NaN}', '{"codebase_version": "v3.0", "n": 1' + "0" * 5000 + "}",
               '{"codebase_version": "v3.0", "fps": 1e999}', "\xff\xfe{}", '{"codebase_version": "v3.0"', ""]
_COLUMN_EDITS = ["strings", "ints", "list-strings", "nested", "nulls", "ragged", "empty-lists", "nan", "inf",
                 "drop", "timestamp-strings", "timestamp-back", "frame-dup", "episode-float", "two-frames",
                 "zero-rows", "split-episode"]
_META_FILES = {"v2.1": ["meta/tasks.jsonl", "meta/episodes.jsonl"],
               "v3.0": ["meta/tasks.parquet", "meta/episodes/chunk-000/file-000.parquet"]}
_JSONL_EDITS = ["[1]\n", '{"task_index": "x", "task": 5}\n', '{"episode_index": 1e999}\n', "{\n", "[" * 5000 + "\n",
                '{"task_index": 99999999999999999999999, "task": "t"}\n', "\xff\n"]


@st.composite
def lerobot_args(draw: Any) -> dict[str, Any]:
    return {
        "version": draw(st.sampled_from(["v2.1", "v3.0"])),
        "damage": draw(st.sampled_from(["none"] * 3 + ["info", "info-text", "column", "column", "column", "data-file",
                                                       "meta-file", "meta-jsonl"])),
        "info": draw(st.sampled_from(range(len(_INFO_EDITS)))), "info_text": draw(st.sampled_from(range(len(_INFO_TEXTS)))),
        "column_edit": draw(st.sampled_from(_COLUMN_EDITS)),
        "target": draw(st.sampled_from(["observation.state", "observation.state", "timestamp", "episode_index",
                                        "frame_index", "task_index"])),
        "file_damage": draw(st.sampled_from(FILE_DAMAGE)), "meta": draw(st.integers(0, 1)),
        "jsonl": draw(st.sampled_from(range(len(_JSONL_EDITS)))),
        "frac": draw(st.floats(0.0, 1.0)), "seed": draw(st.integers(0, 2**32 - 1)), "nflip": draw(st.integers(1, 64)),
        "column": draw(st.sampled_from(["observation.state"] * 4 + ["action", "timestamp", "index", "nope"])),
        "dims": draw(st.sampled_from([None, None, ["elbow"], ["shoulder", "shoulder"], ["x"], []])),
        "episodes": draw(st.sampled_from([None, None, [0], [2, 0], [7], [-1]])),
    }


def _edit_column(path: Path, a: dict[str, Any]) -> str | None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    n, name, edit = table.num_rows, a["target"], a["column_edit"]
    ep = table.column("episode_index").to_numpy()
    state = table.column("observation.state").to_pylist()
    refuse = None
    if edit == "drop":
        table = table.drop([name])
        return _write(table, path, None)
    if edit == "two-frames":
        keep = np.concatenate([np.flatnonzero(ep == e)[:2] for e in np.unique(ep)])
        return _write(table.take(pa.array(keep)), path, "an episode of 2 frames")
    if edit == "zero-rows":
        return _write(table.slice(0, 0), path, None)
    if edit == "split-episode":
        return _write(table.set_column(table.schema.get_field_index("episode_index"), "episode_index",
                                       pa.array(np.full(n, 10**6), type=pa.int64())), path, None)
    if edit in ("nan", "inf"):
        state[n // 2][1] = float(edit)
        column: Any = pa.array(state, type=pa.list_(pa.float32()))
        name, refuse = "observation.state", f"a {edit} in observation.state"
    elif edit == "timestamp-back":
        t = table.column("timestamp").to_numpy().copy()
        t[3] = t[1]
        column, name, refuse = pa.array(t), "timestamp", "a timestamp going back"
    elif edit == "frame-dup":
        f = table.column("frame_index").to_numpy().copy()
        f[3] = f[2]
        column, name, refuse = pa.array(f), "frame_index", "a frame index repeated"
    elif edit == "episode-float":
        column, name = pa.array(ep.astype(float)), "episode_index"
    elif edit == "timestamp-strings":
        column, name = pa.array(["0.1"] * n), "timestamp"
    elif edit == "strings":
        column = pa.array(["x"] * n)
    elif edit == "ints":
        column = pa.array(np.arange(n))
    elif edit == "list-strings":
        column = pa.array([["a", "b", "c"]] * n)
    elif edit == "nested":
        column = pa.array([[[1.0]]] * n)
    elif edit == "nulls":
        column = pa.array([None] * n, type=pa.list_(pa.float32()))
    elif edit == "ragged":
        column = pa.array([[0.0] * (1 + k % 3) for k in range(n)], type=pa.list_(pa.float32()))
    else:  # empty lists
        column = pa.array([[]] * n, type=pa.list_(pa.float32()))
    table = table.set_column(table.schema.get_field_index(name), name, column)
    return _write(table, path, refuse)


def _write(table: Any, path: Path, refuse: str | None) -> str | None:
    import pyarrow.parquet as pq

    pq.write_table(table, path)
    return refuse


def run_lerobot(a: dict[str, Any]) -> list[Any]:
    from dmprs.io import read_lerobot
    from tests.lerobot_writer import write_v2, write_v3

    with tempfile.TemporaryDirectory() as tmp:
        root = (write_v2 if a["version"] == "v2.1" else write_v3)(Path(tmp) / "ds", 3)
        data = sorted((root / "data").glob("**/*.parquet"))
        refuse = None
        damage = a["damage"]
        if damage == "info":
            (root / "meta" / "info.json").write_text(json.dumps(_INFO_EDITS[a["info"]]))
        elif damage == "info-text":
            (root / "meta" / "info.json").write_bytes(_INFO_TEXTS[a["info_text"]].encode("utf-8", "surrogateescape")
                                                      if not _INFO_TEXTS[a["info_text"]].startswith("\xff")
                                                      else b"\xff\xfe{}")
        elif damage == "column":
            refuse = _edit_column(data[0], a)
        elif damage == "data-file":
            refuse = _replace_file(data[-1], a["file_damage"], a["frac"], a["seed"], a["nflip"])
            if a["file_damage"] == "missing" and len(data) == 1:
                refuse = None
        elif damage == "meta-file":
            meta = root / _META_FILES[a["version"]][a["meta"]]
            refuse = _replace_file(meta, a["file_damage"], a["frac"], a["seed"], a["nflip"])
        elif damage == "meta-jsonl" and a["version"] == "v2.1":
            meta = root / _META_FILES["v2.1"][a["meta"]]
            meta.write_bytes(meta.read_bytes() + _JSONL_EDITS[a["jsonl"]].encode("utf-8", "surrogateescape"))
        try:
            return _check(read_lerobot(root, a["column"], dims=a["dims"], episodes=a["episodes"]), refuse)
        except DmprsError as exc:
            _require_clear(exc, tmp)
            raise


# --- CSV, npz and query tables -------------------------------------------------------------------

_CSV_EDITS = ["none", "none", "latin1", "utf16", "nul", "quote", "huge-field", "nan", "inf", "1e999", "missing-field",
              "extra-field", "blank-lines", "dup-header", "backwards", "cr-only", "no-rows", "one-row", "two-rows",
              "header-only", "bom", "spaces", "hex"]
_NPZ_EDITS = ["none", "none", "truncate", "flip", "huge-shape", "object", "complex", "strings", "deflate-bomb",
              "nan-label", "bool-label", "2d-t", "mismatch", "empty", "fortran", "big-endian", "npy3"]
_TABLE_TEXTS = ["demo,v\nrun,1\n", "demo,v\nrun,1\nrun,2\n", "demo,v\n,1\n", "demo,v\nrun,nan\n", "demo,v,v\nrun,1,2\n",
                "v\n1\n", "demo\nrun\n", '{"demos": [{"demo": "run", "v": 1}]}', '[{"demo": "run", "v": true}]',
                '{"units": 3, "demos": [{"demo": "run", "v": 1}]}', "[" * 5000, '[{"demo": "run", "v": 1e999}]',
                '[{"demo": "run", "v": 1' + "0" * 400 + "}]", "[1, 2]", '{"demos": []}', "\xff\xfe", ""]


@st.composite
def table_args(draw: Any) -> dict[str, Any]:
    return {
        "kind": draw(st.sampled_from(["csv", "csv", "npz", "npz", "table"])),
        "csv": draw(st.sampled_from(_CSV_EDITS)), "npz": draw(st.sampled_from(_NPZ_EDITS)),
        "table": draw(st.sampled_from(range(len(_TABLE_TEXTS)))), "json": draw(st.booleans()),
        "file_damage": draw(st.sampled_from(["none"] * 8 + FILE_DAMAGE)),
        "frac": draw(st.floats(0.0, 1.0)), "seed": draw(st.integers(0, 2**32 - 1)), "nflip": draw(st.integers(1, 64)),
        "n": draw(st.sampled_from([20, 20, 5, 3])),
    }


def _csv_bytes(edit: str, n: int) -> tuple[bytes, str | None]:
    t = np.linspace(0.0, 1.0, n)
    rows = [["t", "a", "b"]] + [[repr(float(v)), repr(float(v * v)), repr(float(-v))] for v in t]
    refuse = None
    if edit in ("nan", "inf", "1e999"):
        rows[n // 2 + 1][1] = edit
        refuse = f"a {edit} value"
    elif edit == "missing-field":
        rows[3] = rows[3][:2]
    elif edit == "extra-field":
        rows[3] = [*rows[3], "9"]
    elif edit == "dup-header":
        rows[0] = ["t", "a", "a"]
    elif edit == "backwards":
        rows[2][0], rows[3][0] = rows[3][0], rows[2][0]
        refuse = "times going back"
    elif edit == "huge-field":
        rows[2][1] = "1" * 200_000
    elif edit == "quote":
        rows[2][1] = '"1.0'
    elif edit == "hex":
        rows[2][1] = "0x10"
    elif edit == "spaces":
        rows[2][1] = "  1.0  "
    elif edit in ("no-rows", "header-only"):
        rows = rows[:1]
    elif edit == "one-row":
        rows = rows[:2]
    elif edit == "two-rows":
        rows = rows[:3]
    sep = "\r" if edit == "cr-only" else ("\n\n\n" if edit == "blank-lines" else "\n")
    text = sep.join(",".join(r) for r in rows) + sep
    if edit == "no-rows":
        text = ""
    if edit == "latin1":
        return text.replace("t,a,b", "t,\xe4,b").replace("a", "\xe4").encode("latin-1"), None
    if edit == "utf16":
        return text.encode("utf-16"), None
    if edit == "nul":
        return text.replace("\n", "\x00\n", 2).encode(), None
    if edit == "bom":
        return b"\xef\xbb\xbf" + text.encode(), None
    return text.encode(), refuse


@functools.cache
def _npz_bomb() -> bytes:
    """An npz whose y.npy is a valid header claiming 1.1 GiB of zeros, deflated to about 1 MB: the
    deflate stream of 1 MiB of zeros, flushed, repeated (a full flush makes each copy the same).
    """
    n = 1100 * 2**20
    header = {"descr": "<f8", "fortran_order": False, "shape": (n // 8,)}
    head = io.BytesIO()
    np.lib.format.write_array_header_1_0(head, header)
    c = zlib.compressobj(9, zlib.DEFLATED, -15)
    first = c.compress(head.getvalue()) + c.flush(zlib.Z_FULL_FLUSH)
    block = c.compress(bytes(2**20)) + c.flush(zlib.Z_FULL_FLUSH)
    again = c.compress(bytes(2**20)) + c.flush(zlib.Z_FULL_FLUSH)
    assert block == again
    body = first + block * 1100 + c.flush()
    crc = zlib.crc32(head.getvalue())
    zeros = bytes(2**20)
    for _ in range(1100):
        crc = zlib.crc32(zeros, crc)
    size = len(head.getvalue()) + n
    out = io.BytesIO()
    t = io.BytesIO()
    np.save(t, np.linspace(0, 1, 5))
    with zipfile.ZipFile(out, "w") as z:
        z.writestr("t.npy", t.getvalue())
    # append y.npy by hand: a local header, the deflate stream, and a new central directory
    zdata = out.getvalue()
    end = zdata.rfind(b"PK\x05\x06")
    cd_start = struct.unpack_from("<I", zdata, end + 16)[0]
    central = zdata[cd_start:end]
    name = b"y.npy"
    local = struct.pack("<IHHHHHIIIHH", 0x04034B50, 20, 0, 8, 0, 0, crc, len(body), size, len(name), 0) + name
    offset = cd_start
    entry = struct.pack("<IHHHHHHIIIHHHHHII", 0x02014B50, 20, 20, 0, 8, 0, 0, crc, len(body), size, len(name),
                        0, 0, 0, 0, 0, offset) + name
    new_cd = central + entry
    start = offset + len(local) + len(body)
    eocd = struct.pack("<IHHHHIIH", 0x06054B50, 0, 0, 2, 2, len(new_cd), start, 0)
    return zdata[:cd_start] + local + body + new_cd + eocd


def _npz_bytes(edit: str, n: int) -> tuple[bytes, str | None]:
    if edit == "deflate-bomb":
        return _npz_bomb(), "a deflate bomb"
    t = np.linspace(0.0, 1.0, n)
    arrays: dict[str, Any] = {"t": t, "y": np.stack([t * t, -t], 1), "amplitude": np.float64(0.5)}
    refuse = None
    if edit == "object":
        arrays["y"] = np.array([[1.0], "x"] * (n // 2) + [[0.0]] * (n % 2), dtype=object)
    elif edit == "complex":
        arrays["y"] = arrays["y"] + 1j
    elif edit == "strings":
        arrays["y"] = np.array(["x"] * n)
    elif edit == "nan-label":
        arrays["amplitude"], refuse = np.float64("nan"), "a NaN label"
    elif edit == "bool-label":
        arrays["amplitude"] = np.bool_(True)
    elif edit == "2d-t":
        arrays["t"] = np.stack([t, t])
    elif edit == "mismatch":
        arrays["y"] = arrays["y"][:-1]
    elif edit == "empty":
        arrays = {}
    elif edit == "fortran":
        arrays["y"] = np.asfortranarray(arrays["y"])
    elif edit == "big-endian":
        arrays["y"] = arrays["y"].astype(">f8")
    buf = io.BytesIO()
    np.savez(buf, **arrays) if edit != "object" else _save_object(buf, arrays)
    data = buf.getvalue()
    if edit == "truncate":
        data = data[: len(data) * 2 // 3]
    elif edit == "flip":
        data = _flip(data, n, 16)
    elif edit in ("huge-shape", "npy3"):
        data = data.replace(b"'shape': (%d, 2)" % n, b"'shape': (1000000000000, 2)")
        if edit == "npy3":
            data = data.replace(b"\x93NUMPY\x01\x00", b"\x93NUMPY\x03\x00")
    return data, refuse


def _save_object(buf: io.BytesIO, arrays: dict[str, Any]) -> None:
    with zipfile.ZipFile(buf, "w") as z:
        for k, v in arrays.items():
            member = io.BytesIO()
            np.save(member, v, allow_pickle=True)
            z.writestr(f"{k}.npy", member.getvalue())


def run_table(a: dict[str, Any]) -> list[Any]:
    from dmprs.io import read_csv_trajectory, read_npz_trajectory, read_query_table

    with tempfile.TemporaryDirectory() as tmp:
        kind = a["kind"]
        if kind == "csv":
            data, refuse = _csv_bytes(a["csv"], a["n"])
            path = Path(tmp) / "take.csv"
        elif kind == "npz":
            data, refuse = _npz_bytes(a["npz"], a["n"])
            path = Path(tmp) / "take.npz"
        else:
            text = _TABLE_TEXTS[a["table"]]
            data, refuse = text.encode("utf-8", "surrogateescape") if not text.startswith("\xff") else b"\xff\xfe", None
            path = Path(tmp) / ("queries.json" if text.startswith(("{", "[")) or a["json"] else "queries.csv")
            if text in ("demo,v\nrun,nan\n", '[{"demo": "run", "v": 1e999}]'):
                refuse = "a non-finite query"
        path.write_bytes(data)
        if a["file_damage"] != "none":
            refuse = _replace_file(path, a["file_damage"], a["frac"], a["seed"], a["nflip"]) or refuse
        try:
            if kind == "csv":
                out: Any = read_csv_trajectory(path)[0]
            elif kind == "npz":
                traj, labels = read_npz_trajectory(path)
                if not all(np.isfinite(v) for v in labels.values()):
                    raise AcceptedGarbage("a non-finite label accepted")
                out = traj
            else:
                table = read_query_table(path)
                if not all(np.isfinite(q).all() for q in table.queries.values()):
                    raise AcceptedGarbage("a non-finite query accepted")
                out = list(table.queries.values())
            return _check(out, refuse)
        except DmprsError as exc:
            _require_clear(exc, tmp)
            raise


# --- dmprs demos import, end to end --------------------------------------------------------------

_RATES = [None, None, None, 100.0, 1e9, 1e-9, 1e308, 5e-324, 0.0, -1.0, float("nan"), float("inf")]
_RANGES = [None, None, None, "0:0.1", "0.1:0", "nan:1", "0:1e308", "a:b", "0:0.1,0:0.1", "5:6", "-1e308:1e308"]
_REST = [None, None, None, 0.01, float("nan"), -1.0, 1e308, 0.0]


@st.composite
def cli_args(draw: Any) -> dict[str, Any]:
    source = draw(st.sampled_from(["csv", "npz", "bag", "lerobot"]))
    inner = draw({"csv": table_args(), "npz": table_args(), "bag": bag_args(), "lerobot": lerobot_args()}[source])
    inner["kind"] = source if source in ("csv", "npz") else inner.get("kind")
    if source == "bag":
        inner["call"] = draw(st.sampled_from(["joints", "joints", "poses", "tf"]))
    return {"source": source, "inner": inner, "rate": draw(st.sampled_from(_RATES)),
            "ranges": draw(st.sampled_from(_RANGES)), "rest": draw(st.sampled_from(_REST)),
            "queries": draw(st.sampled_from(["table", "table", "field", "bad-table"]))}


def _cli_source(a: dict[str, Any], tmp: Path) -> tuple[Path, list[str], str | None]:
    """Writes the drawn source into ``tmp``; returns it, its CLI options, and why it must be refused."""
    inner, source = a["inner"], a["source"]
    if source in ("csv", "npz"):
        data, refuse = (_csv_bytes(inner["csv"], inner["n"]) if source == "csv" else _npz_bytes(inner["npz"], inner["n"]))
        path = tmp / f"take.{source}"
        path.write_bytes(data)
        if inner["file_damage"] != "none":
            refuse = _replace_file(path, inner["file_damage"], inner["frac"], inner["seed"], inner["nflip"]) or refuse
        return path, [], refuse
    if source == "bag":
        path = tmp / ("demo.bag" if inner["fmt"] == "ros1" else "demo")
        _write_bag(path, inner)
        refuse = _refusals(inner)
        if inner["values"] in ("nan", "inf", "dup-names"):
            refuse = refuse or f"a bag with {inner['values']}"
        if inner["damage"] == "bomb":
            refuse = _bomb(path, inner) or refuse
        elif inner["damage"] in ("fifo", "devzero") and inner["fmt"] != "ros1":
            storage = next(p for p in sorted(path.iterdir()) if p.name != "metadata.yaml")
            refuse = _replace_file(storage, inner["damage"], 0, 0, 0)
        options = {"joints": [], "poses": ["--pose-topic", "/pose"], "tf": ["--tf", "world:tool"]}[inner["call"]]
        return path, options, refuse
    from tests.lerobot_writer import write_v2, write_v3

    root = (write_v2 if inner["version"] == "v2.1" else write_v3)(tmp / "ds", 3)
    refuse = None
    if inner["damage"] == "column":
        refuse = _edit_column(min((root / "data").glob("**/*.parquet")), inner)
    elif inner["damage"] == "meta-file":
        refuse = _replace_file(root / _META_FILES[inner["version"]][inner["meta"]], inner["file_damage"], inner["frac"],
                               inner["seed"], inner["nflip"])
    return root, [], refuse


def run_cli(a: dict[str, Any]) -> list[Any]:
    from click.testing import CliRunner

    from dmprs.cli import main

    with tempfile.TemporaryDirectory() as tmp:
        path, options, refuse = _cli_source(a, Path(tmp))
        args = ["demos", "import", str(path), "--out", str(Path(tmp) / "db"), *options]
        stem = path.name.split(".")[0]
        if a["queries"] == "field":
            args += ["--query-field", "bottle_volume" if a["source"] == "lerobot" else "amplitude"]
        else:
            table = Path(tmp) / "q.csv"
            names = [str(k) for k in range(3)] if a["source"] == "lerobot" else [stem] + [f"{stem}#{k}" for k in range(9)]
            table.write_text("demo,v\n" + "".join(f"{n},{k}\n" for k, n in enumerate(names)) if a["queries"] == "table"
                             else "demo,v\nx,nan\n")
            args += ["--queries", str(table)]
        for flag, value in (("--rate", a["rate"]), ("--ranges", a["ranges"]), ("--rest-speed", a["rest"])):
            if value is not None:
                args += [flag, str(value)]
        res = CliRunner().invoke(main, args, catch_exceptions=True)
        if res.exception is not None and not isinstance(res.exception, SystemExit):
            raise res.exception
        lines = [line for line in res.output.splitlines() if line.strip()]
        if res.exit_code != 0:
            if len(lines) != 1 or not lines[0].startswith("Error: ") or "Traceback" in res.output:
                raise AcceptedGarbage(f"not one 'Error:' line: {res.output[:300]!r}")
            exc = DmprsError(lines[0])
            _require_clear(exc, tmp, cli=True)
            raise exc
        if refuse:
            raise AcceptedGarbage(f"accepted: {refuse}")
        db = dmprs.Database.load(Path(tmp) / "db")
        return _check([d.trajectory for d in db], None)


# --- errors that name neither a file nor an argument ---------------------------------------------

_ARGUMENTS = ("rate", "ranges", "joints", "dims", "column", "episode", "format", "rest", "speed", "query", "--",
              "demonstration", "field", "topic")


def _require_clear(exc: BaseException, tmp: str, *, cli: bool = False) -> None:
    """Raises :class:`UnclearMessage` unless the refusal names the file or an argument."""
    text = str(exc)
    if not (tmp in text or any(w in text for w in _ARGUMENTS) or (cli and "Usage" in text)):
        raise UnclearMessage(f"a refusal naming no file or argument: {text[:200]}") from None


IO_TARGETS: dict[str, tuple[st.SearchStrategy[Any], Callable[[Any], list[Any]]]] = {
    "ROS bag import": (bag_args(), run_bag),
    "LeRobot import": (lerobot_args(), run_lerobot),
    "CSV / npz / query tables": (table_args(), run_table),
    "dmprs demos import end to end": (cli_args(), run_cli),
}
#: s before an importer example counts as a hang (a whole bag or dataset is written and read)
IO_HANG_TIMEOUTS = dict.fromkeys(IO_TARGETS, 10.0)


# --- what each bomb costs (python -m tests.fuzz_io --bombs) --------------------------------------

def _bomb_cases() -> dict[str, tuple[Callable[[Path], Path], Callable[[Path], Any]]]:
    """name -> (build it in a directory, read it): built in the parent, read in the child."""
    from dmprs.io import load_demos, read_joint_states, read_npz_trajectory

    def bag(fmt: str, compression: str) -> Callable[[Path], Path]:
        def build(tmp: Path) -> Path:
            a = {"fmt": fmt, "compression": compression, "n": 20, "stamps": "ok", "values": "ok"}
            path = tmp / ("demo.bag" if fmt == "ros1" else "demo")
            _write_bag(path, a)
            _bomb(path, a)
            return path
        return build

    def npz(tmp: Path) -> Path:
        (tmp / "bomb.npz").write_bytes(_npz_bomb())
        return tmp / "bomb.npz"

    def csv(tmp: Path) -> Path:
        (tmp / "a.csv").write_text("t,x\n0,0\n1,1\n2,4\n3.7,9\n")
        return tmp / "a.csv"

    def zero(tmp: Path) -> Path:
        (tmp / "z.csv").symlink_to("/dev/zero")
        return tmp / "z.csv"

    joints = read_joint_states
    return {"ROS 2 bag, file-compressed (zstd)": (bag("ros2-sqlite3", "file"), joints),
            "ROS 2 bag, message-compressed (zstd)": (bag("ros2-sqlite3", "message"), joints),
            "MCAP chunk (zstd)": (bag("ros2-mcap", "storage"), joints),
            "ROS 1 chunk (lz4)": (bag("ros1", "lz4"), joints),
            "npz deflate bomb (1.1 GiB declared)": (npz, read_npz_trajectory),
            "CSV with --rate 1e9": (csv, lambda p: load_demos([p], rate=1e9)),
            "a link to /dev/zero as a CSV": (zero, lambda p: load_demos([p]))}


def _poll_size(directory: Path, peak: list[int], done: Any) -> None:
    """Keeps in ``peak[0]`` the largest total size of the files under ``directory`` until ``done``."""
    import time

    while not done.is_set():
        try:
            size = sum(f.stat().st_size for f in directory.rglob("*") if f.is_file())
        except OSError:  # a file removed while it was listed
            continue
        peak[0] = max(peak[0], size)
        time.sleep(0.02)


def bombs(timeout: float = 120.0) -> None:
    """Each bomb in a forked child with its own temporary directory: wall time, the child's peak
    RSS (wait4) and the peak size of its temporary directory (polled), and how it ended.
    """
    import shutil
    import threading
    import time

    print("| input | outcome | time (s) | peak RSS (MB) | peak temporary files (MB) |")
    print("|---|---|---:|---:|---:|")
    for name, (build, case) in _bomb_cases().items():
        with tempfile.TemporaryDirectory() as top:
            work, scratch = Path(top) / "work", Path(top) / "tmp"
            work.mkdir()
            scratch.mkdir()
            path = build(work)
            read, write = os.pipe()
            t0 = time.monotonic()
            pid = os.fork()
            if pid == 0:  # the child: run it, report how it ended
                os.close(read)
                tempfile.tempdir = str(scratch)
                try:
                    case(path)
                    said = "accepted"
                except DmprsError as exc:
                    said = f"refused: {str(exc).split(': ', 1)[-1][:90]}"
                except BaseException as exc:  # noqa: BLE001
                    said = f"{type(exc).__name__}: {str(exc)[:80]}"
                os.write(write, said.encode())
                os._exit(0)
            os.close(write)
            peak, done = [0], threading.Event()
            watcher = threading.Thread(target=_poll_size, args=(scratch, peak, done))
            watcher.start()
            deadline = time.monotonic() + timeout
            while (status := os.wait4(pid, os.WNOHANG))[0] == 0 and time.monotonic() < deadline:
                time.sleep(0.02)
            if status[0] == 0:
                os.kill(pid, 9)
                status = os.wait4(pid, 0)
                said = f"killed after {timeout:g} s"
            else:
                said = os.read(read, 4096).decode() or f"died (status {status[1]})"
            os.close(read)
            done.set()
            watcher.join()
            seconds = time.monotonic() - t0
            print(f"| {name} | {said} | {seconds:.2f} | {status[2].ru_maxrss / 1024:.0f} | {peak[0] / 2**20:.0f} |",
                  flush=True)
            shutil.rmtree(scratch, ignore_errors=True)


if __name__ == "__main__":
    bombs()
