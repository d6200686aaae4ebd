"""Generalizers over the databases users have: N demonstrations of 7 DOF x 200 samples with a 2-D
query. Times the build of ``Generalizer(db, method)`` and one ``predict(q)``, and the memory the
build adds to the process (peak resident set, each case in a fresh process); and compares the
local (``gp_neighbours=k``) and sparse (``gp_sparse=True``) GPs of ``"lwr-gp"`` with the exact
ones where the exact ones are affordable.

Run:  python benches/bench_generalizer_scale.py [N ...]      (default 1000 10000)
Floors at 10,000 demos: "linear" build <= 2 s, predict <= 1 ms; "lwr-gp" (local or sparse)
build <= 10 s, predict <= 20 ms, memory <= 1 GB; against the exact GPs at 200 demos, the same
predictions to 1e-6 of each parameter's range. No other library generalizes DMPs over a database, so there
is no peer to compare with. Not part of the test suite.
"""

from __future__ import annotations

import json
import resource
import statistics
import subprocess
import sys
import time

import numpy as np

import dmprs

SAMPLES, DOF = 200, 7
NEIGHBOURS = 100


def database(n: int, seed: int = 0) -> dmprs.Database:
    """``n`` demos whose duration, goals and shape all vary smoothly (and not affinely) with a
    2-D query drawn uniformly from the unit square.
    """
    rng = np.random.default_rng(seed)
    db = dmprs.Database(("x", "y"), ("m", "m"))
    for q in rng.uniform(0.0, 1.0, (n, 2)):
        tau = 1.5 + 0.5 * q[0] + 0.2 * np.sin(3 * q[1])
        t = np.linspace(0.0, tau, SAMPLES)
        s = t / tau
        mj = 10 * s**3 - 15 * s**4 + 6 * s**5
        amp = 0.5 + q[0] + 0.3 * np.cos(2 * q[1]) + 0.1 * np.arange(DOF)
        y = np.outer(mj, amp) + 0.05 * np.sin(np.pi * s)[:, None] * q[1] * (1 + np.arange(DOF))
        db.add(q, dmprs.Trajectory(t, y))
    return db


def maxrss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


#: The ways of "lwr-gp" compared, by name: the generalizer's GP options.
GPS = {"local": {"gp_neighbours": NEIGHBOURS}, "sparse": {"gp_sparse": True}}


def case(n: int, method: str, gp: str | None) -> dict[str, float]:
    """Runs in a fresh process (the peak RSS is the process's high-water mark)."""
    db = database(n)
    before = maxrss_mb()
    t0 = time.perf_counter()
    gen = dmprs.Generalizer(db, method, **GPS.get(gp or "", {}))
    build = time.perf_counter() - t0
    grown = maxrss_mb() - before
    probes = np.random.default_rng(1).uniform(0.1, 0.9, (50, 2))
    gen.predict(probes[0])
    times = []
    for q in probes:
        t0 = time.perf_counter()
        gen.predict(q)
        times.append(time.perf_counter() - t0)
    return {"build_s": build, "predict_ms": 1e3 * statistics.median(times), "memory_mb": grown}


def accuracy(n: int, variants: list[dict[str, object]]) -> list[dict[str, object]]:
    """Largest error of the local or sparse GPs' tau, goal and start (each of ``variants``: the
    generalizer's GP options) against the exact GPs over ``n`` demos, relative to each
    parameter's range over the demos (those that vary), at 100 queries inside the square.
    """
    db = database(n)
    t0 = time.perf_counter()
    exact = dmprs.Generalizer(db, "lwr-gp")
    exact_build = time.perf_counter() - t0
    nw = exact.n_basis * exact.n_dof
    probes = np.random.default_rng(2).uniform(0.05, 0.95, (100, 2))
    want = np.array([exact.parameters(q)[nw:] for q in probes])
    spread = np.ptp(np.array([exact.parameters(d.query)[nw:] for d in db]), axis=0)
    varies = spread > 0  # the demos' starts are all 0 here
    want, spread = want[:, varies], spread[varies]
    rows = []
    for options in variants:
        t0 = time.perf_counter()
        approx = dmprs.Generalizer(db, "lwr-gp", **options)  # type: ignore[arg-type]
        build = time.perf_counter() - t0
        got = np.array([approx.parameters(q)[nw:] for q in probes])[:, varies]
        name = ", ".join(f"{k}={v}" for k, v in options.items())
        rows.append({"n": n, "gps": name, "max_rel": float(np.max(np.abs(got - want) / spread)),
                     "median_rel": float(np.median(np.abs(got - want) / spread)),
                     "exact_build_s": exact_build, "build_s": build})
    return rows


def run_case(n: int, method: str, gp: str | None) -> dict[str, float]:
    out = subprocess.run([sys.executable, __file__, "--case", json.dumps([n, method, gp])],
                         check=True, capture_output=True, text=True).stdout
    return json.loads(out.splitlines()[-1])


def main() -> None:
    if sys.argv[1:2] == ["--case"]:
        print(json.dumps(case(*json.loads(sys.argv[2]))))
        return
    sizes = [int(a) for a in sys.argv[1:]] or [1000, 10_000]
    print("| demos | method | build (s) | predict (ms) | memory added by the build (MB) |")
    print("|---:|---|---:|---:|---:|")
    for n in sizes:
        for method, gp in (("linear", None), ("lwr-gp", "local"), ("lwr-gp", "sparse")):
            r = run_case(n, method, gp)
            name = method if gp is None else f"{method}, " + ", ".join(f"{k}={v}" for k, v in GPS[gp].items())
            print(f"| {n} | {name} | {r['build_s']:.2f} | {r['predict_ms']:.2f} | {r['memory_mb']:.0f} |", flush=True)
    print("\n| demos | GPs | largest error (of the range) | median error | exact build (s) | build (s) |")
    print("|---:|---|---:|---:|---:|---:|")
    at_200 = [{"gp_neighbours": k} for k in (50, 100, 200)] + [GPS["sparse"]]
    for r in accuracy(200, at_200) + accuracy(1000, [GPS["local"], GPS["sparse"]]):
        print(f"| {r['n']} | {r['gps']} | {r['max_rel']:.2e} | {r['median_rel']:.2e} | {r['exact_build_s']:.2f} "
              f"| {r['build_s']:.2f} |", flush=True)


if __name__ == "__main__":
    main()
