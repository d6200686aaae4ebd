"""Hostile inputs for every public constructor and method of dmprs that takes user data.

Each target is a hypothesis strategy that draws the arguments and a runner that makes the calls
and returns what they produced. ``tests/test_fuzz.py`` asserts on them (only ``DmprsError``
subclasses escape, nothing non-finite comes back, every example within its deadline);
``tests/fuzz_tally.py`` runs the same targets in forked children and counts the outcomes
(clear errors, panics, aborts, leaked exception types, hangs, non-finite outputs), which is how
the before/after table of the reliability issue is measured.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
from hypothesis import strategies as st

import dmprs
from dmprs.learners import PI2, ErrorLearning, GoldenSection, IllinoisRootFinder, PolicyGradient, PoWER

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
    broken when not ``hostile``)."""
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
        "y0": [0.0] * d,
        "tau": draw(maybe_number),
        "ctor": {k: v for k, v in _fit_kwargs(draw).items() if k != "n_basis"},
        "rollout": _rollout_kwargs(draw),
        "dict_key": draw(st.sampled_from(["tau", "alpha_z", "beta_z", "version", "type", "goal", "extra"])),
        "dict_value": draw(anything),
        "batch": draw(st.sampled_from([None, 3, "dmp", [None], []])),
    }


def run_dmp_new(a: dict[str, Any]) -> list[Any]:
    dmp = dmprs.DMP(a["weights"], a["goal"], a["y0"], a["tau"], **a["ctor"])
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


TARGETS: dict[str, tuple[st.SearchStrategy[Any], Callable[[Any], list[Any]]]] = {
    "DMP.fit + rollout/with_*": (dmp_fit_args(), run_dmp_fit),
    "valid DMPs, stiff to slack": (stiff_rollout_args(), run_stiff_rollout),
    "DMP() + from_dict/rollout_batch": (dmp_new_args(), run_dmp_new),
    "Trajectory": (trajectory_args(), run_trajectory),
    "GaussianProcess": (gp_args(), run_gp),
    "Database + Generalizer": (generalizer_args(), run_generalizer),
    "learner constructors": (learner_args(), run_learner),
}


def non_finite(value: Any) -> str | None:
    """Describes the first non-finite number in what a call returned, or None."""
    if isinstance(value, dmprs.Trajectory):
        return non_finite([value.t, value.y, value.yd, value.ydd])
    if isinstance(value, dmprs.DMP):
        return non_finite([value.weights, value.goal, value.y0, value.tau])
    if isinstance(value, (list, tuple)):
        for v in value:
            if (bad := non_finite(v)) is not None:
                return bad
        return None
    if isinstance(value, (float, np.floating, np.ndarray)):
        arr = np.asarray(value, dtype=float)
        return None if np.isfinite(arr).all() else f"non-finite values in {arr.shape} output"
    return None
