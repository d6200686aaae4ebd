"""dmprs.GaussianProcess vs scikit-learn's GaussianProcessRegressor: fit with ML-II and predict.

Both fit the same model to the same data: ConstantKernel * RBF (ARD) + WhiteKernel on the centred
outputs (our constant prior mean = the training mean; sklearn with normalize_y=False on
y - mean(y)), from the same start (length scales = input range, signal = var(y), noise =
1 % of it), within the same bounds (length scales 1e-3..1e3 x range, signal 1e-4..1e4 x var,
noise 1e-10..10 x var), with the same number of restarts (4, i.e. 5 starts). Restart points
differ (Halton points for us, random for sklearn), so the log marginal likelihood reached is
printed too.

Run:  python benches/bench_gp.py [--sizes 10 30 100 200 500 1000] [--dims 1 2 3] [--repeats 5]
Fits: medians of --repeats runs (fewer for n >= 500, see below), both libraries timed in the same
process, interleaved. Predictions: medians of 5 rounds of about 0.2 s of calls each (timeit).
Not part of the test suite.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import timeit

import numpy as np
from sklearn.gaussian_process import GaussianProcessRegressor
from sklearn.gaussian_process.kernels import RBF, WhiteKernel
from sklearn.gaussian_process.kernels import ConstantKernel as C

import dmprs
from _timing import timed

N_RESTARTS = 4


def data(n: int, d: int, seed: int = 0):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-3, 3, (n, d))
    y = np.sin(X[:, 0]) * np.cos(X[:, -1] / 2) + 0.3 * X.sum(axis=1) / d + 0.05 * rng.standard_normal(n)
    Xt = rng.uniform(-3, 3, (100, d))
    return X, y, Xt


def sklearn_model(X, y):
    ranges = np.ptp(X, axis=0)
    var = y.var()
    kernel = C(var, (1e-4 * var, 1e4 * var)) * RBF(
        ranges, [(1e-3 * r, 1e3 * r) for r in ranges]
    ) + WhiteKernel(1e-2 * var, (1e-10 * var, 10 * var))
    return GaussianProcessRegressor(
        kernel, alpha=0.0, normalize_y=False, n_restarts_optimizer=N_RESTARTS, random_state=0
    )


def per_call(fn, repeats: int = 5) -> float:
    """Seconds per call: the median over `repeats` rounds of as many calls as fill about 0.2 s
    (timeit's autorange). Microsecond calls timed one at a time mostly measure the timer and
    the first call's cold caches.
    """
    timer = timeit.Timer(fn)
    number, _ = timer.autorange()
    return statistics.median(timer.repeat(repeats, number)) / number


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--sizes", type=int, nargs="+", default=[10, 30, 100, 200, 500, 1000])
    ap.add_argument("--dims", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--repeats", type=int, default=5)
    args = ap.parse_args()
    print(f"# {platform.processor() or platform.machine()}, {os.cpu_count()} CPUs, "
          f"numpy {np.__version__}, dmprs {dmprs.__version__}")
    print("| n | d | fit: dmprs | sklearn | ratio | LML dmprs / sklearn "
          "| predict 100, mean: dmprs | sklearn | ratio "
          "| predict 100, mean+std: dmprs | sklearn | ratio "
          "| predict 1: dmprs | sklearn | ratio |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for n in args.sizes:
        for d in args.dims:
            X, y, Xt = data(n, d)
            yc = y - y.mean()
            reps = args.repeats if n <= 200 else (3 if n <= 500 else 1)
            # Interleave so that load from other processes hits both alike.
            ours_t, theirs_t = [], []
            for _ in range(reps):
                t_o, gp = timed(lambda: dmprs.GaussianProcess(n_restarts=N_RESTARTS).fit(X, y), 1, warm_up=False)
                t_s, sk = timed(lambda: sklearn_model(X, y).fit(X, yc), 1, warm_up=False)
                ours_t.append(t_o)
                theirs_t.append(t_s)
            fit_o, fit_s = statistics.median(ours_t), statistics.median(theirs_t)
            pm_o = per_call(lambda: gp.predict(Xt))
            pm_s = per_call(lambda: sk.predict(Xt))
            p_o = per_call(lambda: gp.predict(Xt, return_std=True))
            p_s = per_call(lambda: sk.predict(Xt, return_std=True))
            x1 = Xt[:1]
            p1_o = per_call(lambda: gp.predict(x1))
            p1_s = per_call(lambda: sk.predict(x1))
            print(
                f"| {n} | {d} | {fit_o * 1e3:.1f} ms | {fit_s * 1e3:.1f} ms | {fit_s / fit_o:.1f}x "
                f"| {gp.log_marginal_likelihood():.2f} / {sk.log_marginal_likelihood_value_:.2f} "
                f"| {pm_o * 1e6:.0f} us | {pm_s * 1e6:.0f} us | {pm_s / pm_o:.1f}x "
                f"| {p_o * 1e6:.0f} us | {p_s * 1e6:.0f} us | {p_s / p_o:.1f}x "
                f"| {p1_o * 1e6:.1f} us | {p1_s * 1e6:.0f} us | {p1_s / p1_o:.0f}x |",
                flush=True,
            )


if __name__ == "__main__":
    main()
