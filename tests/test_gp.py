"""dmprs.GaussianProcess against scikit-learn's GaussianProcessRegressor (an independent
implementation): same kernel, same data, same hyperparameters -> same predictions.
"""

import numpy as np
import pytest

# scikit-learn is in the "test" extra: a missing install must fail, not skip, these checks.
import sklearn.gaussian_process as sk_gp
from hypothesis import given, settings
from hypothesis import strategies as st
from sklearn.gaussian_process.kernels import RBF, WhiteKernel
from sklearn.gaussian_process.kernels import ConstantKernel as C

import dmprs
from dmprs.errors import DmprsError, InvalidInputError


def problem(seed: int, m: int = 30, n: int = 2):
    rng = np.random.default_rng(seed)
    X = rng.uniform(-2, 2, (m, n))
    y = np.sin(X[:, 0]) + (X[:, 1] ** 2 if n > 1 else 0) + 0.1 * rng.standard_normal(m)
    return X, y, rng.uniform(-3, 3, (40, n))


def sklearn_fixed(X, y, length_scale, signal_var, noise_var):
    """Our model is sklearn's on centred outputs (constant prior mean = the training mean).
    alpha = noise_var (no WhiteKernel) makes sklearn's std the latent std, as ours.
    """
    k = C(signal_var, "fixed") * RBF(length_scale, "fixed")
    return sk_gp.GaussianProcessRegressor(k, alpha=noise_var, optimizer=None).fit(X, y - y.mean())


@pytest.mark.parametrize(
    "n, length_scale",
    [(1, [0.7]), (2, [0.7, 1.9]), (3, [0.3, 1.0, 4.0])],  # ARD: a different scale per dimension
)
def test_fixed_hyperparameters_agree_with_sklearn(n, length_scale):
    X, y, Xt = problem(n, n=n)
    gp = dmprs.GaussianProcess(length_scale, 1.7, 0.02).fit(X, y, optimize=False)
    sk = sklearn_fixed(X, y, length_scale, 1.7, 0.02)
    mean, std = gp.predict(Xt, return_std=True)
    sk_mean, sk_std = sk.predict(Xt, return_std=True)
    np.testing.assert_allclose(mean, sk_mean + y.mean(), rtol=0, atol=1e-8)
    np.testing.assert_allclose(std, sk_std, rtol=0, atol=1e-8)
    assert abs(gp.log_marginal_likelihood() - sk.log_marginal_likelihood_value_) < 1e-8
    # The same at the training points, and the mean alone.
    np.testing.assert_allclose(gp.predict(X), sk.predict(X) + y.mean(), rtol=0, atol=1e-8)


def test_white_kernel_std_includes_the_noise():
    X, y, Xt = problem(5)
    gp = dmprs.GaussianProcess([1.0, 0.5], 2.0, 0.1).fit(X, y, optimize=False)
    k = C(2.0, "fixed") * RBF([1.0, 0.5], "fixed") + WhiteKernel(0.1, "fixed")
    sk = sk_gp.GaussianProcessRegressor(k, alpha=0.0, optimizer=None).fit(X, y - y.mean())
    _, std = gp.predict(Xt, return_std=True)
    _, sk_std = sk.predict(Xt, return_std=True)
    np.testing.assert_allclose(np.sqrt(std**2 + 0.1), sk_std, rtol=0, atol=1e-8)


@settings(max_examples=15, deadline=None)
@given(
    ls=st.lists(st.floats(0.2, 5.0), min_size=2, max_size=2),
    signal=st.floats(0.1, 10.0),
    noise=st.floats(1e-4, 1.0),
    seed=st.integers(0, 1000),
)
def test_lml_and_its_gradient_agree_with_sklearn(ls, signal, noise, seed):
    X, y, _ = problem(seed, m=15)
    gp = dmprs.GaussianProcess(ls, signal, noise).fit(X, y, optimize=False)
    k = C(signal) * RBF(ls) + WhiteKernel(noise)
    sk = sk_gp.GaussianProcessRegressor(k, alpha=0.0, optimizer=None).fit(X, y - y.mean())
    # sklearn's theta: [ln signal, ln l1, ln l2, ln noise]; ours: [ln l1, ln l2, ln signal, ln noise]
    sk_val, sk_grad = sk.log_marginal_likelihood(sk.kernel_.theta, eval_gradient=True)
    val, grad = gp.log_marginal_likelihood(gp.theta, eval_gradient=True)
    assert abs(val - sk_val) < 1e-8 * max(1.0, abs(val))
    np.testing.assert_allclose(grad, sk_grad[[1, 2, 0, 3]], rtol=1e-7, atol=1e-8)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_ml2_reaches_sklearns_optimum(seed):
    X, y, _ = problem(seed)
    gp = dmprs.GaussianProcess(n_restarts=4).fit(X, y)
    k = C(1.0, (1e-5, 1e5)) * RBF([1.0, 1.0], (1e-5, 1e5)) + WhiteKernel(1e-2, (1e-10, 1e2))
    sk = sk_gp.GaussianProcessRegressor(k, alpha=0.0, n_restarts_optimizer=4, random_state=0)
    sk.fit(X, y - y.mean())
    assert gp.log_marginal_likelihood() >= sk.log_marginal_likelihood_value_ - 1e-4
    # And it is a stationary point: the gradient vanishes at interior optima.
    _, grad = gp.log_marginal_likelihood(gp.theta, eval_gradient=True)
    assert np.abs(grad).max() < 1e-3


def test_fitting_is_deterministic():
    X, y, Xt = problem(3)
    a = dmprs.GaussianProcess().fit(X, y)
    b = dmprs.GaussianProcess().fit(X, y)
    assert a.theta.tobytes() == b.theta.tobytes()
    assert a.predict(Xt).tobytes() == b.predict(Xt).tobytes()


def test_fixed_bounds_hold_a_hyperparameter():
    X, y, _ = problem(4)
    gp = dmprs.GaussianProcess(noise_var=0.05, noise_var_bounds=(0.05, 0.05)).fit(X, y)
    assert gp.noise_var == pytest.approx(0.05, rel=1e-14)
    assert gp.prior_mean == pytest.approx(y.mean())


def test_bad_gp_input():
    X, y, _ = problem(0)
    with pytest.raises(InvalidInputError, match=r"y\[3\] is (NaN|nan)"):
        yb = y.copy()
        yb[3] = np.nan
        dmprs.GaussianProcess().fit(X, yb)
    with pytest.raises(InvalidInputError, match="y has shape"):
        dmprs.GaussianProcess().fit(X, y[:-1])
    with pytest.raises(InvalidInputError, match="length_scale"):
        dmprs.GaussianProcess([1.0, 2.0, 3.0]).fit(X, y)
    with pytest.raises(InvalidInputError, match="noise_var"):
        dmprs.GaussianProcess(noise_var=-1.0)
    with pytest.raises(InvalidInputError, match="low must not exceed high"):
        dmprs.GaussianProcess(signal_var_bounds=(2.0, 1.0)).fit(X, y)
    with pytest.raises(DmprsError, match="not fitted"):
        dmprs.GaussianProcess().predict(X)
    gp = dmprs.GaussianProcess().fit(X, y, optimize=False)
    with pytest.raises(InvalidInputError, match="X has shape"):
        gp.predict(np.zeros((3, 5)))


def test_fits_do_not_depend_on_the_thread_count():
    """Restarts run in parallel for m >= 40; the best is picked in start order."""
    import os
    import subprocess
    import sys

    code = (
        "import numpy as np, dmprs\n"
        "rng = np.random.default_rng(11)\n"
        "X = rng.uniform(-2, 2, (60, 2)); y = np.sin(X[:, 0]) + 0.1 * rng.standard_normal(60)\n"
        "print(dmprs.GaussianProcess().fit(X, y).theta.tobytes().hex())\n"
    )
    runs = {
        threads: subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True,
            env={**os.environ, "RAYON_NUM_THREADS": threads},
        ).stdout
        for threads in ("1", "2")
    }
    assert runs["1"] == runs["2"] != ""


@pytest.mark.parametrize("option", ["length_scale", "length_scale_bounds"])
def test_a_length_scale_whose_square_underflows_is_refused(option):
    value = 5e-324 if option == "length_scale" else [[5e-324, 1.0]]
    with pytest.raises(InvalidInputError, match=rf"{option} = 4.94066e-324 is too short"):
        dmprs.GaussianProcess(**{option: value})
