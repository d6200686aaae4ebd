"""Gaussian process regression with a squared-exponential ARD kernel, fitted by the Rust core.

Used by the "lwr-gp" generalizer for the goal and duration (docs/method.md §3.2, after Ude et al.
2010), and usable on its own.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import _core
from dmprs._arrays import as_count, as_float_array, as_scalar, check_finite
from dmprs.errors import DmprsError, InvalidInputError

__all__ = ["GaussianProcess"]


def _bounds_pair(value: Any, name: str) -> tuple[float, float] | None:
    if value is None:
        return None
    arr = as_float_array(value, name, 1)
    if arr.shape != (2,):
        raise InvalidInputError(f"{name} must be a (low, high) pair; got shape {arr.shape}")
    low, high = as_scalar(arr[0], f"{name}[0]", positive=True), as_scalar(arr[1], f"{name}[1]", positive=True)
    if low > high:  # checked here too, not only when fit optimizes: bad input is bad either way
        raise InvalidInputError(f"{name} = ({low:g}, {high:g}) is invalid: low must not exceed high")
    return (low, high)


class GaussianProcess:
    r"""Gaussian process regression (Rasmussen & Williams 2006, ch. 2 and 5) with the covariance

    .. code-block:: text

        k(x, x') = signal_var * exp(-1/2 sum_d (x_d - x'_d)^2 / length_scale_d^2)
                   + noise_var * [x == x']

    (squared-exponential with one length scale per input dimension, ARD) and a **constant prior
    mean equal to the mean of the training outputs**. Predictions are the posterior mean (R&W
    eq. 2.25) and, on request, the standard deviation of the latent function (eq. 2.26, without
    the noise).

    Hyperparameters given here are the start (``optimize=True``) or the final values
    (``optimize=False``). Any left as ``None`` default to the data: each length scale the range
    of its input column, ``signal_var`` the variance of y, ``noise_var`` 1 % of it.

    With ``optimize=True``, :meth:`fit` maximizes the log marginal likelihood (ML-II, R&W eq.
    2.30 with the analytic gradient 5.9) over the log hyperparameters with a box-constrained
    quasi-Newton method, from the start and from ``n_restarts`` fixed Halton points of the log
    box: deterministic, no random numbers. Default bounds are data-relative: length scales
    ``[1e-3, 1e3] x`` the input range, ``signal_var`` ``[1e-4, 1e4] x var(y)``, ``noise_var``
    ``[1e-10, 10] x var(y)``. A bound with ``low == high`` holds that hyperparameter fixed.

    Relation to scikit-learn: ``ConstantKernel(signal_var) * RBF(length_scale) +
    WhiteKernel(noise_var)`` fitted to ``y - y.mean()`` gives the same mean and log marginal
    likelihood; scikit-learn's ``predict(return_std=True)`` then includes the white noise in the
    std, ours does not (use ``alpha=noise_var`` instead of a WhiteKernel to match it).
    """

    __slots__ = (
        "_core",
        "_length_scale",
        "_length_scale_bounds",
        "_max_iter",
        "_n_restarts",
        "_noise_var",
        "_noise_var_bounds",
        "_signal_var",
        "_signal_var_bounds",
    )

    def __init__(
        self,
        length_scale: float | ArrayLike | None = None,
        signal_var: float | None = None,
        noise_var: float | None = None,
        *,
        n_restarts: int = 4,
        length_scale_bounds: ArrayLike | None = None,
        signal_var_bounds: tuple[float, float] | None = None,
        noise_var_bounds: tuple[float, float] | None = None,
        max_iter: int = 200,
    ) -> None:
        self._length_scale = (
            None if length_scale is None
            else _length_scales(as_float_array(length_scale, "length_scale", (0, 1)), "length_scale")
        )
        self._signal_var = None if signal_var is None else as_scalar(signal_var, "signal_var", positive=True)
        self._noise_var = None if noise_var is None else as_scalar(noise_var, "noise_var", positive=True)
        self._n_restarts = as_count(n_restarts, "n_restarts", 0)
        self._length_scale_bounds = (
            None if length_scale_bounds is None
            else np.atleast_2d(_length_scales(as_float_array(length_scale_bounds, "length_scale_bounds", (1, 2)),
                                              "length_scale_bounds"))
        )
        self._signal_var_bounds = _bounds_pair(signal_var_bounds, "signal_var_bounds")
        self._noise_var_bounds = _bounds_pair(noise_var_bounds, "noise_var_bounds")
        self._max_iter = as_count(max_iter, "max_iter", 1)
        self._core: _core.GaussianProcess | None = None

    def fit(self, X: ArrayLike, y: ArrayLike, optimize: bool = True) -> GaussianProcess:
        """Fits to inputs ``X`` (m, n) (a 1-D X is m samples of one input) and outputs ``y``
        (m,). Returns self.
        """
        x = as_float_array(X, "X", (1, 2))
        x = x.reshape(-1, 1) if x.ndim == 1 else x
        yy = as_float_array(y, "y", 1)
        check_finite(x, "X")
        check_finite(yy, "y")
        ls = self._length_scale
        if ls is not None and ls.shape == (1,) and x.shape[1] > 1:
            ls = np.full(x.shape[1], ls[0])  # one scalar for every dimension (isotropic start)
        lsb = self._length_scale_bounds
        if lsb is not None and lsb.shape == (1, 2) and x.shape[1] > 1:
            lsb = np.repeat(lsb, x.shape[1], axis=0)
        self._core = _core.GaussianProcess.fit(
            x, yy,
            length_scale=ls, signal_var=self._signal_var, noise_var=self._noise_var,
            optimize=bool(optimize), n_restarts=self._n_restarts,
            length_scale_bounds=None if lsb is None else np.ascontiguousarray(lsb),
            signal_var_bounds=self._signal_var_bounds, noise_var_bounds=self._noise_var_bounds,
            max_iter=self._max_iter,
        )
        return self

    def _fitted(self) -> _core.GaussianProcess:
        if self._core is None:
            raise DmprsError("this GaussianProcess is not fitted yet; call fit(X, y) first")
        return self._core

    def predict(
        self, X: ArrayLike, return_std: bool = False
    ) -> NDArray[np.float64] | tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Posterior mean (p,) at ``X`` (p, n); with ``return_std`` also the latent std (p,)."""
        core = self._fitted()
        x = as_float_array(X, "X", (1, 2))
        x = x.reshape(-1, core.n_dim) if x.ndim == 1 and core.n_dim == 1 else x
        if x.ndim == 1:
            x = x.reshape(1, -1)
        mean, std = core.predict(x, bool(return_std))
        if not return_std:
            return mean
        assert std is not None  # the core computes it when asked
        return mean, std

    def log_marginal_likelihood(
        self, theta: ArrayLike | None = None, eval_gradient: bool = False
    ) -> float | tuple[float, NDArray[np.float64]]:
        """log p(y | X) at the fitted hyperparameters, or at ``theta = [ln l_1 .. ln l_n,
        ln signal_var, ln noise_var]``; with ``eval_gradient`` also its gradient w.r.t. theta.
        """
        core = self._fitted()
        if theta is None and not eval_gradient:
            return core.log_marginal_likelihood
        th = self.theta if theta is None else as_float_array(theta, "theta", 1)
        value, grad = core.log_marginal_likelihood_at(th)
        return (value, grad) if eval_gradient else value

    @property
    def theta(self) -> NDArray[np.float64]:
        """The fitted log hyperparameters ``[ln l_1 .. ln l_n, ln signal_var, ln noise_var]``."""
        core = self._fitted()
        return np.log(np.concatenate([core.length_scale, [core.signal_var, core.noise_var]]))

    @property
    def length_scale(self) -> NDArray[np.float64]:
        """Fitted length scales (n,)."""
        return self._fitted().length_scale

    @property
    def signal_var(self) -> float:
        """The signal variance of the kernel (after a fit: ML-II's)."""
        return self._fitted().signal_var

    @property
    def noise_var(self) -> float:
        """The observation noise variance (after a fit: ML-II's)."""
        return self._fitted().noise_var

    @property
    def prior_mean(self) -> float:
        """The constant prior mean: the mean of the training outputs."""
        return self._fitted().prior_mean

    def __repr__(self) -> str:
        if self._core is None:
            return "GaussianProcess(unfitted)"
        c = self._core
        return (
            f"GaussianProcess(n_train={c.n_train}, length_scale={np.array2string(c.length_scale, precision=4)}, "
            f"signal_var={c.signal_var:.4g}, noise_var={c.noise_var:.4g})"
        )


#: The shortest length scale: the kernel divides by its square, which must be a normal float
#: (below, it underflows to zero or loses its digits, and the kernel turns into 0 / 0).
MIN_LENGTH_SCALE = 1e-150


def _length_scales(values: NDArray[np.float64], name: str) -> NDArray[np.float64]:
    """``values`` as at least 1-D, refused where finite but shorter than MIN_LENGTH_SCALE (the
    core refuses what is not positive and finite, naming it).
    """
    short = np.isfinite(values) & (values > 0) & (values < MIN_LENGTH_SCALE)
    if short.any():
        raise InvalidInputError(
            f"{name} = {values[short].flat[0]:g} is too short: length scales must be at least "
            f"{MIN_LENGTH_SCALE:g} (the kernel divides by their square)")
    return np.atleast_1d(values)
