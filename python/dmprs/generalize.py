"""Generalization from several demonstrations: the paper's G(q; Z) -> DMP (eq. 6, docs/method.md §3),
computed by the Rust core.
"""

from __future__ import annotations

from typing import Any, TypeAlias

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import _core
from dmprs._arrays import as_count, as_query, as_scalar
from dmprs.cartesian import CartesianDMP
from dmprs.database import Database, Demo
from dmprs.dmp import DMP
from dmprs.errors import InvalidInputError
from dmprs.periodic import PeriodicDMP
from dmprs.primitive import constants as _constants
from dmprs.primitive import spring
from dmprs.trajectory import CartesianTrajectory, Trajectory
from dmprs.triangulation import PiecewiseLinear

__all__ = ["GeneralizedDMP", "Generalizer"]

#: the kinds of DMP a generalizer predicts
GeneralizedDMP: TypeAlias = DMP | CartesianDMP | PeriodicDMP

#: The most demonstrations the exact GPs of "lwr-gp" take: their build grows with the cube of
#: their number (docs/growing.md measures it). Local (``gp_neighbours``) and sparse (``gp_sparse``)
#: GPs take any number.
MAX_GP_DEMOS = 1000
_METHODS = ("linear", "lwr-gp")
_KERNELS = ("tricube", "gaussian")
_TRENDS = ("constant", "affine")


def _needs_triangulation(queries: NDArray[np.float64]) -> bool:
    """More demos than one simplex (n + 1), or repeated queries: the core's "linear" cannot."""
    distinct = len(np.unique(queries, axis=0))
    return distinct > queries.shape[1] + 1 or distinct < len(queries)


def _period(demo: Demo, k: int) -> float | None:
    """A periodic demonstration's period: its metadata's ``"period"``, else None (its duration)."""
    if "period" not in demo.metadata:
        return None
    return as_scalar(demo.metadata["period"], f"metadata['period'] of demonstration {k}", positive=True)


def _periodic_core(db: Database, method: str, n_basis: int, spring_constants: dict[str, float],
                   alpha_x: float | None, triangulate: bool | None,
                   options: _core._GeneralizerOptions) -> _core.PeriodicGeneralizer | PiecewiseLinear:
    """The periodic generalizer over ``db``'s joint trajectories, or the reason it cannot be."""
    if alpha_x is not None:
        raise InvalidInputError("alpha_x is the discrete phase's decay rate: a periodic DMP's phase does not "
                                "decay (leave alpha_x unset with periodic=True)")
    if db.is_cartesian:
        raise InvalidInputError("periodic=True generalizes joint-space demonstrations; the database holds "
                                "pose trajectories")
    n = as_count(n_basis, "n_basis", 3)
    trajectories = [tr for tr in (d.trajectory for d in db) if isinstance(tr, Trajectory)]
    periods = [_period(d, k) for k, d in enumerate(db)]
    if method == "linear" and (triangulate or (triangulate is None and _needs_triangulation(db.queries))):
        dmps = [PeriodicDMP.fit(tr.t, tr.y, period, n, tr.yd, tr.ydd, **spring_constants)
                for tr, period in zip(trajectories, periods, strict=True)]
        return PiecewiseLinear(db.queries, dmps)
    demos = [(tr.t, tr.y, tr.yd, tr.ydd) for tr in trajectories]
    return _core.PeriodicGeneralizer(db.queries, demos, periods, method, n, spring_constants, options)


class Generalizer:
    r"""Maps a task query q (n,) to a DMP, learned from the demonstrations of a :class:`Database`.

    Each demonstration is first fitted as a DMP (:meth:`dmprs.DMP.fit`, with its own tau = its
    duration, its own goal and start, and its measured yd/ydd if the trajectory has them; with
    ``final_velocity=True`` its last velocity as its final velocity, docs/method.md §2.8, which
    is then generalized like the goal). Then:

    ``method="linear"`` (docs/method.md §3.3; the paper's matchbox setting): every parameter
    (weights, tau, goal, start) is interpolated and extrapolated affinely in q. For two demos
    and a scalar query this is ``theta(q) = (1 - a) theta_1 + a theta_2`` with
    ``a = (q - q_1) / (q_2 - q_1)``. For an n-D query it uses barycentric coordinates, so it
    needs 2 to n + 1 demos with affinely independent queries (a segment, a triangle, ...); with
    fewer than n + 1 it is constant along directions orthogonal to the demos' affine hull (it uses
    the projection of q onto it). It reproduces each demo exactly. With more than n + 1 demos
    (a growing database), repeated queries, or ``triangulate=True``, it is piecewise linear on a
    triangulation of the queries (sorted intervals in 1-D, Delaunay in n-D), extrapolated
    affinely from the nearest interval or simplex, and averages repeats
    (:mod:`dmprs.triangulation`, docs/growing.md); for <= n + 1 distinct demos both agree.

    ``method="lwr-gp"`` (Ude et al. 2010, docs/method.md §3.2): the weights by locally weighted
    regression, one weighted least-squares problem over the data of all demos with one
    ``kernel`` weight per demo (tricube or Gaussian in the query distance scaled by the demos'
    query range; bandwidth ``bandwidth x`` the distance to the farthest of the n + 1 nearest
    demos; ridge ``ridge x trace / N``); tau, goal and start each by a Gaussian process (SE-ARD,
    prior mean = the demos' mean, noise std ``gp_noise x`` the outputs' std, length scales and
    signal variance by ML-II when there are at least 4 demos, else the query range and the
    outputs' variance). With ``interpolate=True`` (default) the kernel weights are multiplied
    by ``(d_min / d_k)^2`` (a Shepard-type factor) so that a demo's own query returns that demo:
    its weights exactly (the default ridge is the one :meth:`dmprs.DMP.fit` uses), tau, goal and
    start to the GP noise (1e-5 relative or better in our tests). ``interpolate=False`` gives the plain locally
    constant blend of docs/method.md §3.2, which mixes a demo with its neighbours even at its own
    query. LWR cannot extrapolate the weights: far from the demos they tend to those of the
    nearest ones, and the GPs' tau, goal and start to the demos' mean. ``trend="affine"``
    (ours) extrapolates instead: the weights by first-order LWR (Atkeson, Moore & Schaal 1997:
    at q, the intercept of a model affine in the query, fitted to the demos' data with the same
    kernel weights) and the GPs with the least-squares affine fit of their outputs as prior
    mean (needs n + 1 demos spanning the query space, else the mean stays constant). It
    reproduces the demos as the default does, is exact where the parameters are affine in q,
    and extrapolates affinely from the nearest demos (throwing beyond the demos:
    docs/throwing.md).
    "lwr-gp" refuses repeated queries; "linear" averages them.

    Which for a growing database (``learn(..., database=db)``; docs/growing.md compares them on
    2-D pouring): ``"linear"``, with its defaults, for a low-dimensional query; ``"lwr-gp"`` with
    ``bandwidth=2.5, trend="affine"`` where demos are noisy or repeated samples of a smooth map,
    or the query too high-dimensional to triangulate densely. To extrapolate, ``"linear"`` or
    ``trend="affine"``.

    Many demonstrations (a large dataset): the exact GPs of ``"lwr-gp"`` cost the cube of the
    number of demos, so beyond ``MAX_GP_DEMOS`` they are refused. ``gp_neighbours=k`` makes
    them local: each prediction conditions the GPs on the ``k`` demos nearest to the query
    (distance scaled by the demos' query range), with hyperparameters fitted once by the same
    ML-II on the ``k`` demos around the most central one, so build and prediction no longer
    grow with ``M`` (the LWR of the weights already is local). With ``k >= M`` it is
    the exact generalizer, bit for bit; below, close to it where the neighbourhood spans a few
    GP length scales (docs/growing.md measures a choice of k). ``gp_sparse=True`` keeps every
    demo instead: hyperparameters by the same ML-II on at most 200 demos spread over the query
    space (every demo when there are no more: the exact GPs' own), then each GP conditioned on
    all demos through a pivoted Cholesky factor of its kernel matrix, which keeps the demos it
    needs until what it leaves out is a thousandth of the GP's noise. Where tau, goal and start
    vary smoothly with the query it keeps a few dozen demos and gives the exact GPs' mean
    closely (docs/growing.md); where they do not, it would need more than 1000 and is refused
    with the reason (use ``gp_neighbours`` then). ``"linear"`` takes any number.

    Pose demonstrations (:class:`~dmprs.CartesianTrajectory`) work the same way and give a
    :class:`~dmprs.CartesianDMP`: weights and tau as above, positions like goals and starts, and
    the goal and start orientations as rotation vectors in the tangent space of demonstration
    0's goal and start (linear: slerp for two demos; lwr-gp: a GP per tangent coordinate).

    Periodic demonstrations (``periodic=True``; Ude et al. 2010, docs/method.md §12.7): each
    demonstration, a joint trajectory of one or more periods, is fitted by
    :meth:`dmprs.PeriodicDMP.fit` with its period ``demo.metadata["period"]`` (s) where the
    database holds one, else its duration (exactly one period), and :meth:`predict` gives a
    :class:`~dmprs.PeriodicDMP`: the amplitude-normalized weights as above (LWR on the demos'
    normal equations, which are in the phase, so rhythms of different frequencies share them),
    and tau (the frequency), the baseline, the amplitude and the start per DOF by the GPs
    (``"lwr-gp"``) or affinely (``"linear"``, piecewise on a triangulation beyond n + 1 demos).
    A query whose amplitude of some DOF would not be positive is refused like one whose tau
    leaves its range.

    Either way, tau(q) must stay within ``(0.2 x`` the shortest, ``5 x`` the longest demo
    duration); a query outside raises :class:`~dmprs.errors.ExtrapolationError`.
    """

    __slots__ = ("_core", "_db_names", "_kind")

    def __init__(
        self,
        db: Database,
        method: str = "linear",
        n_basis: int = 25,
        *,
        alpha_z: float = 48.0,
        beta_z: float | None = None,
        alpha_x: float | None = None,
        width_factor: float = 2.0,
        kernel: str = "tricube",
        bandwidth: float = 1.5,
        ridge: float = 1e-10,
        interpolate: bool = True,
        gp_noise: float = 1e-4,
        gp_optimize: bool | None = None,
        gp_restarts: int = 4,
        gp_neighbours: int | None = None,
        gp_sparse: bool = False,
        triangulate: bool | None = None,
        trend: str = "constant",
        periodic: bool = False,
        final_velocity: bool = False,
    ) -> None:
        if not isinstance(db, Database):
            raise InvalidInputError(f"db is a {type(db).__name__}; expected a dmprs.Database")
        if method not in _METHODS:
            raise InvalidInputError(f"method = {method!r} is invalid: use one of {_METHODS}")
        if kernel not in _KERNELS:
            raise InvalidInputError(f"kernel = {kernel!r} is invalid: use one of {_KERNELS}")
        if trend not in _TRENDS:
            raise InvalidInputError(f"trend = {trend!r} is invalid: use one of {_TRENDS}")
        if len(db) == 0:
            raise InvalidInputError("the database is empty: a generalizer needs at least 2 demonstrations")
        if len(db) < 2:
            raise InvalidInputError(
                f"method {method!r} needs at least 2 demonstrations, but the database has {len(db)}"
            )
        neighbours = None if gp_neighbours is None else as_count(gp_neighbours, "gp_neighbours", _core.MIN_GP_NEIGHBOURS)
        if gp_sparse and neighbours is not None:
            raise InvalidInputError(
                f"gp_sparse=True and gp_neighbours={neighbours} cannot be combined: the GPs are either "
                "local (over the demos nearest to each query) or sparse (over every demo)")
        if method == "lwr-gp" and not gp_sparse and min(len(db), neighbours or len(db)) > MAX_GP_DEMOS:
            raise InvalidInputError(
                f"method 'lwr-gp' with exact Gaussian processes over {min(len(db), neighbours or len(db))} "
                f"demonstrations is refused: they cost the cube of the number of demos per "
                f"hyperparameter step, and beyond {MAX_GP_DEMOS} the build takes many minutes to days. "
                "Use sparse GPs (gp_sparse=True), local GPs over the demos nearest to each query "
                "(gp_neighbours=100, say), or method 'linear' (any number of demos)"
            )
        if method == "lwr-gp" and len(np.unique(db.queries, axis=0)) < len(db):
            raise InvalidInputError(
                "method 'lwr-gp' cannot use repeated queries (its GP needs distinct inputs); add "
                "repeats with on_duplicate='replace', or use method 'linear', which averages them"
            )
        self._core: _core.Generalizer | _core.CartesianGeneralizer | _core.PeriodicGeneralizer | PiecewiseLinear
        self._db_names = db.query_names
        self._kind: type[GeneralizedDMP] = (
            PeriodicDMP if periodic is True else CartesianDMP if db.is_cartesian else DMP)
        options: _core._GeneralizerOptions = {
            "kernel": kernel,
            "bandwidth": as_scalar(bandwidth, "bandwidth", positive=True),
            "ridge": as_scalar(ridge, "ridge", positive=True),
            "interpolate": bool(interpolate),
            "gp_noise": as_scalar(gp_noise, "gp_noise", positive=True),
            "gp_optimize": None if gp_optimize is None else bool(gp_optimize),
            "gp_restarts": as_count(gp_restarts, "gp_restarts", 0),
            "gp_neighbours": neighbours,
            "gp_sparse": bool(gp_sparse),
            "trend": trend,
        }
        if not isinstance(periodic, bool):
            raise InvalidInputError(f"periodic = {periodic!r} is invalid: use True or False")
        if not isinstance(final_velocity, bool):
            raise InvalidInputError(f"final_velocity = {final_velocity!r} is invalid: use True or False")
        if final_velocity and periodic:
            raise InvalidInputError("final_velocity=True generalizes discrete demonstrations only: a rhythm "
                                    "never reaches a goal (docs/method.md §2.8)")
        if periodic:
            self._core = _periodic_core(db, method, n_basis, spring(alpha_z, beta_z, width_factor), alpha_x,
                                        triangulate, options)
            return
        alpha_x = 2.0 if alpha_x is None else alpha_x
        if method == "linear" and (triangulate or (triangulate is None and _needs_triangulation(db.queries))):
            if db.is_cartesian:
                raise InvalidInputError(
                    f"method 'linear' over {len(db)} pose demonstrations needs a triangulation, which "
                    f"is implemented for joint-space demonstrations only; use at most "
                    f"{db.queries.shape[1] + 1} distinct queries or method 'lwr-gp'")
            dmps = [DMP.fit(tr.t, tr.y, as_count(n_basis, "n_basis", 2), tr.yd, tr.ydd, alpha_z=alpha_z,
                            beta_z=beta_z, alpha_x=alpha_x, width_factor=width_factor,
                            final_velocity="demo" if final_velocity else None)
                    for tr in (d.trajectory for d in db) if isinstance(tr, Trajectory)]
            self._core = PiecewiseLinear(db.queries, dmps, final_velocity)
            return
        n = as_count(n_basis, "n_basis", 2)
        constants = _constants(alpha_z, beta_z, alpha_x, width_factor)
        if db.is_cartesian:
            poses = [
                (tr.t, tr.pose, tr.velocity, tr.acceleration, tr.angular_velocity, tr.angular_acceleration)
                for tr in (d.trajectory for d in db)
                if isinstance(tr, CartesianTrajectory)
            ]
            self._core = _core.CartesianGeneralizer(db.queries, poses, method, n, constants, options, final_velocity)
        else:
            demos = [
                (tr.t, tr.y, tr.yd, tr.ydd)
                for tr in (d.trajectory for d in db)
                if isinstance(tr, Trajectory)
            ]
            self._core = _core.Generalizer(db.queries, demos, method, n, constants, options, final_velocity)
        self._db_names = db.query_names

    def _query(self, q: ArrayLike) -> NDArray[np.float64]:
        return as_query(q, "q", self._db_names)

    @property
    def is_cartesian(self) -> bool:
        """True when the demonstrations are poses (:class:`~dmprs.CartesianTrajectory`)."""
        return self._kind is CartesianDMP

    @property
    def is_periodic(self) -> bool:
        """True when it generalizes periodic demonstrations (``periodic=True``)."""
        return self._kind is PeriodicDMP

    def predict(self, q: ArrayLike) -> GeneralizedDMP:
        """The DMP for query ``q`` (n,) (a scalar for n = 1): a :class:`~dmprs.CartesianDMP`
        when the demonstrations are poses, a :class:`~dmprs.PeriodicDMP` when periodic.
        """
        return self._kind._wrap(self._core.predict(self._query(q)))

    def parameters(self, q: ArrayLike) -> NDArray[np.float64]:
        """The generalized parameters flattened as ``[w.ravel() (D*N, row d = DOF d), tau,
        goal (D), y0 (D)]``, without the tau validity check. For poses: ``[w.ravel() (6*N),
        tau, goal position (3), goal rotation vector (3), start position (3), start rotation
        vector (3)]``, the rotation vectors in the tangent space of demonstration 0's goal and
        start orientations (docs/cartesian.md). Periodic: ``[w.ravel() (D*N), tau, goal (D),
        amplitude (D), y0 (D)]``. With ``final_velocity=True``: ``[w.ravel() (D*N), tau,
        goal (D), y0 (D), final velocity (D)]``, for poses the final linear (3) and angular (3,
        world frame) velocity after the start rotation vector.
        """
        return self._core.parameters(self._query(q))

    def jacobian(self, q: ArrayLike, rel_step: float = 1e-4) -> NDArray[np.float64]:
        """d :meth:`parameters` / dq at ``q``, shape ``(n_parameters, n)``, by central
        differences with step ``rel_step x`` the demos' query range per dimension. Exact up to
        rounding for ``"linear"`` (affine).

        This is the "numerical derivative of the generalization function" of paper section 4 / docs/method.md
        §5.2; the learner's gain K = d(achieved query)/dq further needs the task's outcome map.
        """
        return self._core.jacobian(self._query(q), as_scalar(rel_step, "rel_step", positive=True))

    @property
    def demo_dmps(self) -> list[GeneralizedDMP]:
        """The DMP fitted to each demonstration, in database order (all of one kind)."""
        return [self._kind._wrap(d) for d in self._core.demo_dmps]

    @property
    def method(self) -> str:
        """The generalization method ('lwr', 'gp' or 'linear')."""
        return self._core.method

    @property
    def n_query(self) -> int:
        """Dimension of the query."""
        return self._core.n_query

    @property
    def n_dof(self) -> int:
        """Degrees of freedom of the predicted DMPs."""
        return self._core.n_dof

    @property
    def n_basis(self) -> int:
        """Kernels per degree of freedom of the predicted DMPs."""
        return self._core.n_basis

    @property
    def n_demos(self) -> int:
        """Number of demonstrations generalized over."""
        return self._core.n_demos

    @property
    def n_parameters(self) -> int:
        """``D * N + 1 + 2 * D``; for poses ``6 * N + 1 + 12``, periodic ``D * N + 1 + 3 * D``,
        with final velocities ``D * N + 1 + 3 * D`` (poses ``6 * N + 1 + 18``; see :meth:`parameters`).
        """
        return self._core.n_parameters

    @property
    def tau_bounds(self) -> tuple[float, float]:
        """tau(q) must lie strictly inside this interval (s)."""
        return self._core.tau_bounds

    def __repr__(self) -> str:
        return (
            f"Generalizer(method={self.method!r}, n_demos={self.n_demos}, n_query={self.n_query}, "
            f"n_dof={self.n_dof}, n_basis={self.n_basis})"
        )

    def __reduce__(self) -> Any:
        raise TypeError("Generalizer is not picklable; pickle its Database and rebuild it")
