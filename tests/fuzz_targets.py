"""Hostile inputs for every public constructor and method of dmprs that takes user data.

Each target is a hypothesis strategy that draws the arguments and a runner that makes the calls
and returns what they produced. ``tests/test_fuzz.py`` asserts on them (only ``DmprsError``
subclasses escape, nothing non-finite comes back, every example within its deadline);
``tests/fuzz_tally.py`` runs the same targets in forked children and counts the outcomes
(clear errors, panics, aborts, leaked exception types, hangs, non-finite outputs), which is how
the before/after table of the reliability issue is measured.
"""

from __future__ import annotations

import contextlib
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import strategies as st

import dmprs
from dmprs.learners import PI2, ErrorLearning, GoldenSection, IllinoisRootFinder, PolicyGradient, PoWER
from tests.fuzz_io import IO_HANG_TIMEOUTS, IO_TARGETS
from tests.fuzz_verdicts import AcceptedGarbage, UnclearMessage
from tests.hostile import plant

# Values a careless or hostile caller passes where a number is expected.
_SPECIAL_FLOATS = [
    0.0, -0.0, 1e-300, 5e-324, -1.0, 0.5, 1.0, 2.0, 20.0, 48.0, 1e4, 1e200, 1e308, -1e308,
    float("nan"), float("inf"), float("-inf"),
]
_SPECIAL_INTS = [-1, 0, 1, 2, 3, 7, 25, 10**4, 10**6, 2**40, 2**64, 2**70]
_JUNK = [None, "1", "abc", True, [], [1.0, 2.0], {"a": 1}, 10**400, 2**2000]

number = st.one_of(
    st.sampled_from(_SPECIAL_FLOATS),
    st.floats(allow_nan=True, allow_infinity=True, width=64),
    st.floats(min_value=1e-3, max_value=1e3),
)
count = st.one_of(st.sampled_from(_SPECIAL_INTS), st.integers(-5, 60))
anything = st.one_of(number, count, st.sampled_from(_JUNK))
# Mostly sensible values, sometimes hostile: the hostile value must reach deep calls too.
maybe_number = st.one_of(st.floats(min_value=1e-2, max_value=1e2), number, st.sampled_from(_JUNK))
maybe_count = st.one_of(st.integers(2, 40), count, st.sampled_from(_JUNK))


@st.composite
def samples(draw: Any, n_dof_max: int = 3, hostile: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """Sample times and positions: usually valid, sometimes short, unsorted, huge or NaN (never
    broken when not ``hostile``).
    """
    if not hostile:
        t = np.linspace(0.0, draw(st.floats(0.05, 20.0)), draw(st.integers(3, 60)))
        y = draw(st.floats(-5, 5)) * np.sin(draw(st.floats(0.1, 30.0)) * t / t[-1])
        return t, y
    n = draw(st.one_of(st.integers(3, 60), st.integers(0, 3)))
    d = draw(st.integers(1, n_dof_max))
    span = draw(st.one_of(st.floats(1e-3, 1e2), st.sampled_from([1e-12, 1e-300, 1e300, 0.0, -1.0])))
    t = np.linspace(0.0, span, n)
    if draw(st.booleans()) and n > 2:
        t[draw(st.integers(0, n - 1))] = draw(number)
    amp = draw(st.one_of(st.floats(-10, 10), st.sampled_from([0.0, 1e-300, 1e200, 1e308])))
    freq = draw(st.floats(0.1, 80.0))
    y = amp * np.sin(freq * np.linspace(0, 1, n)[:, None] + np.arange(d)[None, :])
    if draw(st.integers(0, 9)) == 0 and y.size:
        y.flat[draw(st.integers(0, y.size - 1))] = draw(number)
    return t, y


def _fit_kwargs(draw: Any) -> dict[str, Any]:
    return {
        "n_basis": draw(maybe_count),
        "alpha_z": draw(maybe_number),
        "beta_z": draw(st.one_of(st.none(), maybe_number)),
        "alpha_x": draw(maybe_number),
        "width_factor": draw(maybe_number),
    }


def _rollout_kwargs(draw: Any) -> dict[str, Any]:
    return {
        "dt": draw(st.one_of(st.sampled_from([1e-3, 1e-2, 0.1]), maybe_number)),
        "duration": draw(st.one_of(st.none(), maybe_number)),
        "until_rest": draw(st.one_of(st.booleans(), st.sampled_from(["no", 0, None]))),
        "rest_tol": draw(st.one_of(st.just(1e-4), maybe_number)),
    }


# --- DMP ---------------------------------------------------------------------------------------
@st.composite
def dmp_fit_args(draw: Any) -> dict[str, Any]:
    t, y = draw(samples())
    return {
        "t": t, "y": y, "fit": _fit_kwargs(draw), "rollout": _rollout_kwargs(draw),
        "goal": draw(st.one_of(st.just(None), maybe_number)), "tau": draw(maybe_number),
    }


def run_dmp_fit(a: dict[str, Any]) -> list[Any]:
    dmp = dmprs.DMP.fit(a["t"], a["y"], **a["fit"])
    out: list[Any] = [dmp.weights, dmp.goal, dmp.tau]
    out.append(dmp.rollout(**a["rollout"]))
    if a["goal"] is not None:
        out.append(dmp.with_goal(np.full(dmp.n_dof, a["goal"])).rollout(**a["rollout"]))
    out.append(dmp.with_tau(a["tau"]).rollout(**a["rollout"]))
    out.append(dmprs.rollout_batch([dmp, dmp], **a["rollout"]))
    return out


@st.composite
def stiff_rollout_args(draw: Any) -> dict[str, Any]:
    """Valid inputs only, over the whole range of stiffness, speed and size."""
    span = draw(st.floats(1e-3, 10.0))
    t = np.linspace(0.0, span, draw(st.integers(5, 80)))
    y = draw(st.floats(-2, 2)) * np.sin(draw(st.floats(0.5, 60)) * t / span)
    return {
        "t": t, "y": y,
        "alpha_z": draw(st.floats(1.0, 1e5)), "alpha_x": draw(st.floats(0.5, 40.0)),
        "dt": draw(st.floats(1e-4, 0.1)), "duration": draw(st.one_of(st.none(), st.floats(1e-2, 5.0))),
        "goal": draw(st.one_of(st.floats(-1e3, 1e3), st.sampled_from([1e100, 1e200, 1e308]))),
        "tau": draw(st.floats(1e-3, 10.0)),
    }


def run_stiff_rollout(a: dict[str, Any]) -> list[Any]:
    dmp = dmprs.DMP.fit(a["t"], a["y"], alpha_z=a["alpha_z"], alpha_x=a["alpha_x"])
    opts = {"dt": a["dt"], "duration": a["duration"]}
    return [
        dmp.rollout(**opts), dmp.with_tau(a["tau"]).rollout(**opts),
        dmprs.rollout_batch([dmp.with_goal([a["goal"]])], **opts),
    ]


@st.composite
def dmp_new_args(draw: Any) -> dict[str, Any]:
    d = draw(st.integers(1, 3))
    n = draw(st.integers(0, 30))
    scale = draw(st.one_of(st.floats(-1e3, 1e3), st.sampled_from([1e200, 1e308, 0.0])))
    return {
        "weights": scale * np.cos(np.arange(d * n, dtype=float)).reshape(d, n),
        "goal": draw(st.one_of(st.just([1.0] * d), st.lists(number, min_size=0, max_size=4), anything)),
        "start": [0.0] * d,
        "tau": draw(maybe_number),
        "ctor": {k: v for k, v in _fit_kwargs(draw).items() if k != "n_basis"},
        "rollout": _rollout_kwargs(draw),
        "dict_key": draw(st.sampled_from(["tau", "alpha_z", "beta_z", "version", "type", "goal", "extra"])),
        "dict_value": draw(anything),
        "batch": draw(st.sampled_from([None, 3, "dmp", [None], []])),
    }


def run_dmp_new(a: dict[str, Any]) -> list[Any]:
    dmp = dmprs.DMP(a["weights"], a["goal"], a["start"], a["tau"], **a["ctor"])
    out: list[Any] = [dmp.rollout(**a["rollout"])]
    data = dmp.to_dict()
    data[a["dict_key"]] = a["dict_value"]
    try:
        out.append(dmprs.DMP.from_dict(data).rollout(**a["rollout"]))
    finally:
        out.append(dmprs.rollout_batch(a["batch"]))  # type: ignore[arg-type]
    return out


# --- Trajectory --------------------------------------------------------------------------------
@st.composite
def trajectory_args(draw: Any) -> dict[str, Any]:
    t, y = draw(samples())
    with np.errstate(over="ignore"):
        doubled = y * 2
    return {"t": t, "y": y, "yd": draw(st.one_of(st.none(), st.just(doubled), anything))}


def run_trajectory(a: dict[str, Any]) -> list[Any]:
    return [dmprs.Trajectory(a["t"], a["y"], a["yd"])]


# --- Gaussian process --------------------------------------------------------------------------
@st.composite
def gp_args(draw: Any) -> dict[str, Any]:
    m = draw(st.integers(0, 25))
    n = draw(st.integers(1, 3))
    x = np.cos(np.arange(m * n, dtype=float) * 1.7).reshape(m, n) * draw(st.floats(1e-3, 1e3))
    y = np.sin(x.sum(axis=1) * 3.0) * draw(st.one_of(st.floats(-10, 10), st.sampled_from([1e200, 1e-300, 0.0])))
    if draw(st.integers(0, 9)) == 0 and m:
        y[0] = draw(number)
    pair = st.one_of(st.none(), st.tuples(maybe_number, maybe_number))
    return {
        "x": x, "y": y,
        "ctor": {
            "length_scale": draw(st.one_of(st.none(), maybe_number)),
            "signal_var": draw(st.one_of(st.none(), maybe_number)),
            "noise_var": draw(st.one_of(st.none(), maybe_number)),
            "n_restarts": draw(st.one_of(st.integers(0, 3), count)),
            "signal_var_bounds": draw(pair),
            "noise_var_bounds": draw(pair),
            "max_iter": draw(st.one_of(st.integers(1, 50), count)),
        },
        "optimize": draw(st.booleans()),
        "xq": draw(st.one_of(st.just(x[:3] + 0.1), st.lists(number, min_size=1, max_size=3))),
    }


def run_gp(a: dict[str, Any]) -> list[Any]:
    gp = dmprs.GaussianProcess(**a["ctor"]).fit(a["x"], a["y"], optimize=a["optimize"])
    mean, std = gp.predict(a["xq"], return_std=True)
    return [mean, std, gp.theta, gp.log_marginal_likelihood()]


# --- Database and Generalizer ------------------------------------------------------------------
@st.composite
def generalizer_args(draw: Any) -> dict[str, Any]:
    n_demos = draw(st.sampled_from([2, 2, 3, 3, 4, 5, 1]))
    queries = list(draw(st.one_of(
        st.lists(st.floats(-5, 5), min_size=n_demos, max_size=n_demos, unique=True),
        st.lists(st.sampled_from([0.0, 1e-300, 1e300, -1e300, 5e-324]), min_size=n_demos, max_size=n_demos),
    )))
    demos = [draw(samples(n_dof_max=1, hostile=draw(st.integers(0, 9)) == 0)) for _ in range(n_demos)]
    fit = _fit_kwargs(draw) if draw(st.integers(0, 3)) == 0 else {"n_basis": draw(st.integers(2, 40))}
    return {
        "queries": queries, "demos": demos, "fit": fit,
        "method": draw(st.sampled_from(["linear"] * 3 + ["lwr-gp"] * 6 + ["bogus"])),
        "gp": {
            "gp_noise": draw(st.one_of(st.just(1e-4), maybe_number)),
            "gp_restarts": draw(st.one_of(st.integers(0, 3), count)),
            "bandwidth": draw(st.one_of(st.just(1.5), maybe_number)),
            "trend": draw(st.sampled_from(["constant", "affine", "affine", "cubic", None])),
        },
        "q": draw(st.one_of(st.floats(-6, 6), number, anything)),
        "rel_step": draw(st.one_of(st.just(1e-4), maybe_number)),
        "names": draw(st.sampled_from([["x"]] * 10 + [[], ["x", "x"], "x", [1], None])),
    }


def run_generalizer(a: dict[str, Any]) -> list[Any]:
    db = dmprs.Database(a["names"])
    for q, (t, y) in zip(a["queries"], a["demos"], strict=True):
        db.add([q], dmprs.Trajectory(t, y))
    with tempfile.TemporaryDirectory() as tmp:
        db.save(Path(tmp) / "db")
        db = dmprs.Database.load(Path(tmp) / "db")
    gen = dmprs.Generalizer(db, a["method"], **a["fit"], **(a["gp"] if a["method"] == "lwr-gp" else {}))
    dmp = gen.predict(a["q"])
    return [gen.parameters(a["q"]), gen.jacobian(a["q"], a["rel_step"]), dmp.rollout(dt=0.01)]


# --- learners (constructors only: the learn loop is fuzzed through its own tests) ---------------
@st.composite
def learner_args(draw: Any) -> dict[str, Any]:
    kind = draw(st.sampled_from(["error", "golden", "root", "pg", "power", "pi2"]))
    vec = st.one_of(st.lists(st.floats(-5, 5), min_size=1, max_size=3), st.lists(number, max_size=3), anything)
    kw: dict[str, Any] = {"max_trials": draw(st.one_of(st.integers(1, 50), count))}
    if kind in ("error", "pg"):
        kw |= {"q0": draw(vec), "tol": draw(maybe_number)}
        kw |= {"scale": draw(maybe_number)} if kind == "error" else {"delta": draw(st.one_of(st.none(), maybe_number))}
    elif kind in ("golden", "root"):
        kw |= {"q0": draw(maybe_number), "low": draw(maybe_number), "high": draw(maybe_number),
               "q_tol": draw(st.one_of(st.none(), maybe_number))}
        if kind == "golden":  # the noise guard
            kw |= {"noise": draw(st.one_of(st.none(), maybe_number)),
                   "max_repeats": draw(st.one_of(st.none(), st.integers(1, 5), count))}
    else:
        kw |= {"theta0": draw(vec), "sigma": draw(st.one_of(st.just(0.1), maybe_number)), "seed": draw(count)}
    return {"kind": kind, "kw": kw}


_LEARNERS: dict[str, Callable[..., Any]] = {
    "error": ErrorLearning, "golden": GoldenSection, "root": IllinoisRootFinder,
    "pg": PolicyGradient, "power": PoWER, "pi2": PI2,
}


def run_learner(a: dict[str, Any]) -> list[Any]:
    learner = _LEARNERS[a["kind"]](**a["kw"])
    return [learner.ask()]


# --- files and directories: what a hostile directory does to a save, a load, a resume, a plot ------
def _snapshot(root: Path) -> dict[str, bytes | str]:
    """Every entry under ``root`` with its content (a link: its target; a FIFO or device: its kind),
    never following a link or opening anything but a regular file.
    """
    import os
    import stat

    out: dict[str, bytes | str] = {}
    for dirpath, dirnames, filenames in os.walk(root):
        for name in dirnames + filenames:
            p = Path(dirpath) / name
            mode = os.lstat(p).st_mode
            key = str(p.relative_to(root))
            if stat.S_ISLNK(mode):
                out[key] = "link to " + os.readlink(p)
            elif stat.S_ISREG(mode):
                out[key] = p.read_bytes()
            else:
                out[key] = "dir" if stat.S_ISDIR(mode) else f"special {stat.S_IFMT(mode)}"
    return out


_JSON_BOMBS = {
    "deep": "[" * 100_000 + "]" * 100_000, "huge-int": "1" * 5000, "huge-float": "1e999", "bare-nan": "NaN",
    "list": "[1, 2, 3]", "string": '"manifest"', "empty": "", "binary": "\x00\xff\xfe",
}
_FILE_KINDS = ["fifo", "zero", "dir", "link-outside", "dangling", *_JSON_BOMBS]


@st.composite
def database_dir_args(draw: Any) -> dict[str, Any]:
    where = st.sampled_from(["manifest.json", ".dmprs.lock", "demo", "notes.txt", "demo_0123456789abcdef.npz",
                             "orphans", "foreign-manifest"])
    damage = draw(st.lists(st.tuples(where, st.sampled_from(_FILE_KINDS)), min_size=1, max_size=3))
    return {"damage": damage, "op": draw(st.sampled_from(["load", "save", "save", "load+save"])),
            "fresh": draw(st.booleans()), "scale": draw(st.sampled_from([1.0, 2.0, 3.0]))}


def _regular_content(path: Path) -> bytes | None:
    """The bytes of ``path`` if it is (or links to) a regular file, without opening anything else."""
    import os
    import stat

    try:
        return path.read_bytes() if stat.S_ISREG(os.stat(path).st_mode) else None
    except OSError:
        return None


def _is_dmprs_manifest(data: bytes | None) -> bool:
    import json

    try:
        value = json.loads(data or b"")
    except (ValueError, RecursionError):
        return False
    return isinstance(value, dict) and value.get("format") == "dmprs.Database"


def _db(scale: float, n: int = 3) -> Any:
    db = dmprs.Database(["q"])
    t = np.linspace(0.0, 1.0, 20)
    for q in range(n):
        db.add([float(q)], dmprs.Trajectory(t, scale * (1.0 + q) * t))
    return db


def _orphans(path: Path, scale: float) -> list[str]:
    """What a save killed before its manifest leaves: content-named demo files and a temp file."""
    import hashlib
    import io

    names = []
    for demo in _db(scale + 10.0):
        buf = io.BytesIO()
        np.savez(buf, query=demo.query, t=demo.trajectory.t, y=demo.trajectory.y)
        name = f"demo_{hashlib.sha256(buf.getvalue()).hexdigest()[:16]}.npz"
        (path / name).write_bytes(buf.getvalue())
        names.append(name)
    (path / ".manifest.json.ab12cd_9.tmp").write_bytes(b'{"format": ')
    return [*names, ".manifest.json.ab12cd_9.tmp"]


def run_database_dir(a: dict[str, Any]) -> list[Any]:
    """Saves and loads a database in a directory made hostile; raises AcceptedGarbage if the
    operation wrote outside it, through a link, over a foreign manifest, left a refused save's
    files, created files on a read, or left the orphans of an interrupted save.
    """
    import os

    with tempfile.TemporaryDirectory() as tmp:
        root, outside = Path(tmp) / "db", Path(tmp) / "outside"
        outside.mkdir()
        root.mkdir()
        if not a["fresh"]:
            _db(1.0).save(root)
        foreign_manifest = None
        orphans: list[str] = []
        for where, kind in a["damage"]:
            if where == "orphans":
                orphans = _orphans(root, a["scale"])
                continue
            if where == "foreign-manifest":
                plant(root / "manifest.json", "bomb", outside, b'{"project": "somebody else\'s"}')
                continue
            if where == "demo":
                demos = sorted(root.glob("demo_*.npz"))
                if not demos:
                    continue
                target = demos[0]
            else:
                target = root / where
            content = _regular_content(target) or b""
            bomb = _JSON_BOMBS.get(kind)
            plant(target, kind if bomb is None else "bomb", outside, content if bomb is None else bomb.encode())
        manifest = root / "manifest.json"
        if os.path.lexists(manifest) and not _is_dmprs_manifest(_regular_content(manifest)):
            foreign_manifest = _regular_content(manifest) or b"(not a regular file)"
        outside_before, inside_before = _snapshot(outside), _snapshot(root)
        out: list[Any] = []
        try:
            with _naming(str(root)):
                _database_ops(a, root, inside_before, foreign_manifest, orphans, out)
        finally:
            if _snapshot(outside) != outside_before:
                raise AcceptedGarbage("wrote outside the directory it was given (through a link)")
        return out


@contextlib.contextmanager
def _naming(*words: str) -> Any:
    """Re-raises a DmprsError whose message names none of ``words`` as an UnclearMessage."""
    try:
        yield
    except dmprs.DmprsError as exc:
        if not any(w in str(exc) for w in words):
            raise UnclearMessage(f"names none of {words}: {exc}") from None
        raise


def _database_ops(a: dict[str, Any], root: Path, inside_before: dict[str, Any], foreign_manifest: bytes | None,
                  orphans: list[str], out: list[Any]) -> None:
    """Loads and/or saves in the damaged ``root``; AcceptedGarbage for what must not happen."""
    if a["op"] in ("load", "load+save"):
        try:
            out.append(dmprs.Database.load(root).queries)
        finally:
            created = set(_snapshot(root)) - set(inside_before)
            if created:
                raise AcceptedGarbage(f"a load created {sorted(created)}")
    if a["op"] in ("save", "load+save"):
        try:
            _db(a["scale"]).save(root)
        except dmprs.DmprsError:
            left = set(_snapshot(root)) - set(inside_before)
            if left:
                raise AcceptedGarbage(f"a refused save left {sorted(left)}") from None
            raise
        if foreign_manifest is not None:
            raise AcceptedGarbage("a save overwrote a manifest.json that is not a dmprs database's")
        left = [n for n in orphans if (root / n).exists()]
        if left:
            raise AcceptedGarbage(f"the orphans of an interrupted save stayed: {left}")
        out.append(dmprs.Database.load(root).queries)


# --- run logs: dmprs resume and dmprs plot on a damaged run directory, end to end ------------------
_RUN_TEMPLATE: dict[str, Path] = {}


def _template_run() -> Path:
    """A logged 2-trial run of the analytic task that did not converge (made once per process;
    matplotlib imported with it, so that a forked child's plot does not spend seconds on it).
    """
    from dmprs.plots import pyplot

    pyplot()
    if "run" not in _RUN_TEMPLATE:
        from click.testing import CliRunner

        from dmprs.cli import main

        run_dir = Path(tempfile.mkdtemp(prefix="dmprs-fuzz-run-")) / "run"
        CliRunner().invoke(main, ["learn", "analytic", "--log-dir", str(run_dir), "--max-trials", "2",
                                  "--noise", "0.05", "--tol", "1e-9"])
        _RUN_TEMPLATE["run"] = run_dir
    return _RUN_TEMPLATE["run"]


_DROP = "<dropped>"
_RAW = {"1e999": "1e999", "huge-int": "1" * 400, "bare-NaN": "NaN", "deep": "[" * 5000 + "]" * 5000}
_VALUES = [None, "x", True, -1, 0, 2**62, 1e308, -1e308, [], [1.0, 2.0], [0.5], {"a": 1}, "NaN", ["NaN"],
           ["Infinity"], [None], [[1.0]], 1.5, _DROP, *_RAW]
_TRIAL_FIELDS = ["trial", "query", "status", "eps", "success", "signals", "message", "file"]
_RUN_FIELDS = ["schema_version", "experiment", "setup_options", "learner_name", "learner_options", "max_trials",
               "tol", "seed", "query_names", "query_units", "desired_query", "task", "learner"]


@st.composite
def run_log_args(draw: Any) -> dict[str, Any]:
    damage = draw(st.one_of(
        st.tuples(st.just("file"), st.sampled_from(["trials.jsonl", "run.json", "trial_0001.npz"]),
                  st.sampled_from([*_FILE_KINDS, "missing", "garbage-bytes"])),
        st.tuples(st.just("trial"), st.integers(0, 1), st.sampled_from(_TRIAL_FIELDS), st.sampled_from(_VALUES)),
        st.tuples(st.just("meta"), st.sampled_from(_RUN_FIELDS), st.sampled_from(_VALUES)),
        st.tuples(st.just("lines"), st.sampled_from(["duplicate", "drop-first", "swap", "cut", "garbage-line",
                                                     "blank-lines", "crlf"])),
        st.tuples(st.just("plot-out-link"),),
    ))
    return {"damage": damage, "command": draw(st.sampled_from(["resume", "plot"]))}


def _set_field(text: str, field: str, value: Any) -> str:
    import json

    record = json.loads(text)
    if not isinstance(record, dict):
        return text
    if value == _DROP:
        record.pop(field, None)
        return json.dumps(record)
    if isinstance(value, str) and value in _RAW:
        record[field] = "@RAW@"
        return json.dumps(record).replace('"@RAW@"', _RAW[value])
    record[field] = value
    return json.dumps(record)


def run_run_log(a: dict[str, Any]) -> list[Any]:
    """``dmprs resume`` or ``dmprs plot`` of a damaged copy of a logged run, in-process. Clean
    refusals (one line, naming the run's file) become a DmprsError; a traceback re-raises the
    exception; a write outside the run (through a link) is AcceptedGarbage.
    """
    import shutil

    from click.testing import CliRunner

    from dmprs.cli import main

    with tempfile.TemporaryDirectory() as tmp:
        run_dir, outside = Path(tmp) / "run", Path(tmp) / "outside"
        shutil.copytree(_template_run(), run_dir, symlinks=True)
        outside.mkdir()
        for stale in run_dir.glob("learning.png"):
            stale.unlink()
        kind = a["damage"][0]
        args = [a["command"], str(run_dir)]
        if kind == "file":
            _, name, how = a["damage"]
            target = run_dir / name
            if how == "missing":
                target.unlink()
            else:
                content = target.read_bytes()
                bomb = {"garbage-bytes": "\x00garbage\xff", **_JSON_BOMBS}.get(how)
                plant(target, how if bomb is None else "bomb", outside, content if bomb is None else bomb.encode())
        elif kind in ("trial", "meta"):
            name = "trials.jsonl" if kind == "trial" else "run.json"
            path = run_dir / name
            lines = path.read_text().splitlines()
            if kind == "trial":
                _, index, field, value = a["damage"]
                lines[index] = _set_field(lines[index], field, value)
                path.write_text("\n".join(lines) + "\n")
            else:
                _, field, value = a["damage"]
                path.write_text(_set_field(path.read_text(), field, value))
        elif kind == "lines":
            path = run_dir / "trials.jsonl"
            lines = path.read_text().splitlines()
            how = a["damage"][1]
            text = {
                "duplicate": "\n".join([lines[0], *lines]) + "\n", "drop-first": "\n".join(lines[1:]) + "\n",
                "swap": "\n".join(lines[::-1]) + "\n", "cut": "\n".join(lines)[:-7],
                "garbage-line": "\n".join([lines[0], "}{", *lines[1:]]) + "\n",
                "blank-lines": "\n\n".join(lines) + "\n\n", "crlf": "\r\n".join(lines) + "\r\n",
            }[how]
            path.write_text(text)
        else:  # plot into a folder whose learning.png is a link to a file outside
            folder = Path(tmp) / "figures"
            folder.mkdir()
            (folder / "learning.png").symlink_to(outside / "written-through-a-link.png")
            args = ["plot", str(run_dir), "--out", str(folder)]
        before = _snapshot(outside)
        try:
            result = CliRunner().invoke(main, args)
        finally:
            if _snapshot(outside) != before:
                raise AcceptedGarbage("wrote outside the run directory (through a link)")
    if result.exception is not None and not isinstance(result.exception, SystemExit):
        raise result.exception
    output = result.output.strip()
    if "Traceback" in output:
        raise UnclearMessage(f"a traceback: {output[-300:]}")
    if result.exit_code == 0 or (a["command"] == "resume" and "not converged" in output and "Error" not in output):
        return []
    errors = [line for line in output.splitlines() if line.startswith("Error:")]
    if len(errors) != 1 or str(run_dir) not in errors[0]:
        raise UnclearMessage(f"not one line naming {run_dir}: {output[-300:]!r}")
    raise dmprs.DmprsError(errors[0])


# --- Gymnasium environments: actions, seeds, reset options, step order ----------------------------
_ENVS: dict[str, Any] = {}


def _env(kind: str) -> Any:
    if kind not in _ENVS:
        import dmprs.envs

        _ENVS[kind] = dmprs.envs.make_matchbox(action=kind)
    return _ENVS[kind]


def _warm_envs() -> None:
    _env("query")
    _env("weights")


def _actions(n: int) -> st.SearchStrategy[tuple[str, Any]]:
    """(label, action): "valid" (a finite real array of shape (n,)), or why it is garbage."""
    valid = st.one_of(
        st.lists(st.floats(0.6, 3.0), min_size=n, max_size=n).map(lambda v: np.array(v)),
        st.lists(st.floats(-1e6, 1e6), min_size=n, max_size=n).map(lambda v: np.array(v)),  # clipped
        st.just(np.ones(n, dtype=np.float32)), st.just(np.ones(n, dtype=np.int64)), st.just([1.0] * n),
    ).map(lambda a: ("valid", a))
    garbage = st.sampled_from([
        ("complex", np.ones(n, dtype=complex)), ("complex", 1.5 + 0j), ("2-D", np.ones((n, 1))), ("2-D", np.ones((1, n))),
        ("string", "1.5"), ("string", ["1.5"] * n), ("None", None), ("object", np.array([1.0] * n, dtype=object)),
        ("bool", np.ones(n, dtype=bool)), ("bool", True), ("NaN", np.full(n, np.nan)), ("inf", np.full(n, np.inf)),
        ("wrong length", np.ones(n + 1)), ("wrong length", np.ones(max(n - 1, 0) or 2)), ("scalar", 1.5),
        ("dict", {"q": 1.5}), ("huge int", [2**70] * n), ("ragged", [[1.0], [1.0, 2.0]]), ("empty", []),
    ])
    return st.one_of(valid, garbage)


_SEEDS = [None, 0, 5, 2**31, -1, 2**70, 1.5, "3", True, np.int64(3), np.uint8(2)]
_OPTIONS = [None, {}, {"context": [np.pi / 2]}, {"context": [0.0]}, {"context": "x"}, {"context": [np.nan]},
            {"contxt": 1}, [1], {"context": [[np.pi / 2]]}]


@st.composite
def env_args(draw: Any) -> dict[str, Any]:
    kind = draw(st.sampled_from(["query", "query", "weights"]))
    n = 1 if kind == "query" else 50
    ops = draw(st.lists(st.one_of(
        st.tuples(st.just("reset"), st.sampled_from(_SEEDS), st.sampled_from(_OPTIONS)),
        st.tuples(st.just("step"), _actions(n)),
    ), min_size=1, max_size=5))
    return {"kind": kind, "ops": ops, "seed": draw(st.integers(0, 2**31))}


def run_env(a: dict[str, Any]) -> list[Any]:
    """Drives a fresh copy of the environment through the ops; AcceptedGarbage if a garbage
    action is taken, a step after the episode ended needs no reset, or a seeded episode is not
    reproducible bit for bit.
    """
    env = type(_env(a["kind"]))(_env(a["kind"]).scenario, action=a["kind"])  # fresh, on the built scenario
    valid = np.full(env.action_space.shape, 1.5 if a["kind"] == "query" else 0.1)
    out: list[Any] = []
    open_episode, reset_once = False, False
    for op in a["ops"]:
        if op[0] == "reset":
            with _naming("seed", "options"):
                obs, _ = env.reset(seed=op[1], options=op[2])
            out.append(obs)
            open_episode = reset_once = True
            continue
        label, action = op[1]
        ended = reset_once and not open_episode
        with _naming("action", "reset"):
            result = env.step(action)
        if label != "valid":
            raise AcceptedGarbage(f"a {label} action {action!r:.60} was taken")
        if ended:
            raise AcceptedGarbage("a step after the episode ended was taken without reset()")
        out.extend([result[0], result[1]])
        open_episode = not (result[2] or result[3])
    episodes = []
    for _ in range(2):
        obs, _ = env.reset(seed=a["seed"])
        obs2, reward, *_ = env.step(valid)
        episodes.append((obs.tobytes(), obs2.tobytes(), reward))
    if episodes[0] != episodes[1]:
        raise AcceptedGarbage(f"reset(seed={a['seed']}) is not reproducible: {episodes}")
    return out


# --- the MuJoCo arm adapters and setups -----------------------------------------------------------
def _warm_arms() -> None:
    from dmprs.experiments.arm_throwing import demonstrations
    from dmprs.sim import throw_scene

    demonstrations()
    throw_scene.settled_ball()


_ARM_VALUES = [None, "x", True, -1, 0, 0.5, 1e9, float("nan"), float("inf"), [1.0], {"a": 1}, 2**70, -0.1]


@st.composite
def arm_args(draw: Any) -> dict[str, Any]:
    what = draw(st.sampled_from(["pouring adapter", "pouring task", "throwing task", "throwing setup"]))
    anything_arm = st.one_of(st.sampled_from(_ARM_VALUES), st.floats(-2, 20))
    if what == "pouring adapter":
        opts = {k: draw(st.one_of(st.just(v), anything_arm)) for k, v in
                (("bottle_volume", 0.02), ("liquid_seed", 0), ("hold", 0.2))}
        opts["reseed_liquid"] = draw(st.sampled_from([False, True, "no", 1, None]))
    elif what == "pouring task":
        opts = {"bottle_volume": 0.02, "tol": draw(st.one_of(st.just(0.01), anything_arm)),
                "desired": draw(st.one_of(st.floats(-1, 3), anything_arm))}
    elif what == "throwing task":
        opts = {"tol": draw(st.one_of(st.just(0.05), anything_arm)),
                "noise": draw(st.sampled_from([None, "loud", 0.1, "Noise(execution=1e-3)", "Noise(contact=0.1)"]))}
    else:
        target = draw(st.one_of(
            st.tuples(st.floats(0.8, 1.4), st.floats(-0.4, 0.4)), st.tuples(st.floats(-30, 30), st.floats(-30, 30)),
            st.sampled_from([(1e9, 0.0), (0.0, 0.0), (0.05, 0.0), "far", (1.0,), (1.0, 0.0, 0.0), (np.nan, 0.0),
                             (1.0, None), [[1.0, 0.0]]])))
        opts = {"target": target, "generalizer": draw(st.sampled_from(["linear", "lwr-gp", "bogus", None, 3])),
                "tol": draw(st.one_of(st.none(), anything_arm)),
                "n_basis": draw(st.sampled_from([30, 30, 30, 0, "30", 2**70, 2.5])),
                "max_trials": draw(st.sampled_from([50, 0, -1, "5", 2.5]))}
    return {"what": what, "opts": opts, "timeout_s": draw(st.sampled_from([None, None, 0.05, 0, -1, "x", np.nan]))}


def _noise(value: Any) -> Any:
    """The drawn noise: a Noise for the names below, the hostile value itself otherwise."""
    from dmprs.tasks.noise import Noise

    made = {"Noise(execution=1e-3)": lambda: Noise(execution=1e-3), "Noise(contact=0.1)": lambda: Noise(contact=0.1)}
    return made[value]() if value in made else value


def run_arm(a: dict[str, Any]) -> list[Any]:
    """Builds an arm adapter, task or setup from hostile options and runs one short trial with a
    hostile timeout; AcceptedGarbage for a target beyond any throw (a basket more than 20 m from the
    base or inside the pedestal) or a bottle beyond the scene's 1 l, or a timeout of 0.05 s that
    did not stop the simulation within 1 s. A refusal must name the option it refuses.
    """
    with _naming(*a["opts"], "timeout_s", "noise", "desired", "target"):
        return _arm_ops(a)


def _arm_ops(a: dict[str, Any]) -> list[Any]:
    import math
    import time

    from dmprs.experiments.arm_throwing import setup as arm_throwing_setup
    from dmprs.tasks.arm_pouring import ArmPouring, ArmPouringAdapter
    from dmprs.tasks.arm_throwing import ArmThrowing, throw_trajectory

    o = a["opts"]
    if a["what"] == "throwing setup":
        setup = arm_throwing_setup(**o)
        x, y = (float(v) for v in setup.desired_query)
        if not 0.15 <= math.hypot(x, y) <= 20:
            raise AcceptedGarbage(f"a basket at ({x:g}, {y:g}) m was accepted: no throw lands there")
        return [setup.desired_query]
    if a["what"] == "pouring task":
        task = ArmPouring(o["bottle_volume"], tol=o["tol"])
        q = task.validate_query(o["desired"])
        if not 0 < q[0] <= 1.0:
            raise AcceptedGarbage(f"a bottle of {q[0]:g} l was accepted: the scene's holds at most 1 l")
        return [q]
    if a["what"] == "throwing task":
        adapter = ArmThrowing(o["tol"], noise=_noise(o["noise"])).adapter
        trajectory: Any = throw_trajectory(0.8, 0.0)
    else:
        adapter = ArmPouringAdapter(**o)
        home = adapter.home
        t = np.linspace(0.0, 0.2, 101)
        trajectory = dmprs.Trajectory(t, np.tile(home, (len(t), 1)))
    with adapter:
        adapter.reset(seed=0)
        start = time.perf_counter()
        out = adapter.execute(trajectory, timeout_s=a["timeout_s"])
        if a["timeout_s"] == 0.05 and time.perf_counter() - start > 1.0:
            raise AcceptedGarbage(f"timeout_s = 0.05 stopped nothing: the trial took {time.perf_counter() - start:.2f} s")
    return [np.asarray(v, dtype=float) for v in out.signals.values()]


#: Targets whose examples take longer than the tally's 5 s default to answer, in s.
HANG_TIMEOUTS: dict[str, float] = {"MuJoCo arm adapters and setups": 60.0, "run logs: dmprs resume / plot": 30.0,
                                   **IO_HANG_TIMEOUTS}
#: What to compute once in the tally's parent, before it forks a child per example.
WARMUPS: dict[str, Callable[[], Any]] = {
    "database directory": lambda: None,
    "run logs: dmprs resume / plot": _template_run,
    "Gymnasium environments": _warm_envs,
    "MuJoCo arm adapters and setups": _warm_arms,
}
#: Examples per target in tests/test_fuzz.py (the tally takes its count on the command line);
#: 200 when not listed.
TEST_EXAMPLES: dict[str, int] = {"database directory": 60, "run logs: dmprs resume / plot": 25,
                                 "Gymnasium environments": 60, "MuJoCo arm adapters and setups": 4,
                                 **dict.fromkeys(IO_TARGETS, 12)}


TARGETS: dict[str, tuple[st.SearchStrategy[Any], Callable[[Any], list[Any]]]] = {
    "DMP.fit + rollout/with_*": (dmp_fit_args(), run_dmp_fit),
    "valid DMPs, stiff to slack": (stiff_rollout_args(), run_stiff_rollout),
    "DMP() + from_dict/rollout_batch": (dmp_new_args(), run_dmp_new),
    "Trajectory": (trajectory_args(), run_trajectory),
    "GaussianProcess": (gp_args(), run_gp),
    "Database + Generalizer": (generalizer_args(), run_generalizer),
    "learner constructors": (learner_args(), run_learner),
    "database directory": (database_dir_args(), run_database_dir),
    "run logs: dmprs resume / plot": (run_log_args(), run_run_log),
    "Gymnasium environments": (env_args(), run_env),
    "MuJoCo arm adapters and setups": (arm_args(), run_arm),
}
TARGETS.update(IO_TARGETS)  # the importers' (tests/fuzz_io.py)


def non_finite(value: Any) -> str | None:
    """Describes the first non-finite number in what a call returned, or None."""
    if isinstance(value, dmprs.Trajectory):
        return non_finite([value.t, value.y, value.yd, value.ydd])
    if isinstance(value, dmprs.DMP):
        return non_finite([value.weights, value.goal, value.start, value.tau])
    if isinstance(value, (list, tuple)):
        for v in value:
            if (bad := non_finite(v)) is not None:
                return bad
        return None
    if isinstance(value, (float, np.floating, np.ndarray)):
        arr = np.asarray(value, dtype=float)
        return None if np.isfinite(arr).all() else f"non-finite values in {arr.shape} output"
    return None
