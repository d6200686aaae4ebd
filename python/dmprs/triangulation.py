"""Piecewise-linear generalization over any number of demonstrations (docs/growing.md): the
``"linear"`` method of :class:`dmprs.Generalizer` once a growing database has more than n + 1
demos for an n-D query.

Each demo is a DMP parameter vector ``theta_k = [w, tau, g, y0]`` (a periodic DMP's
``[w, tau, g, r, y0]``, with its amplitude r; with final velocities ``[w, tau, g, y0, gd]``, the
core's order, docs/method.md §2.8) at its query ``q_k``. The
queries are triangulated (1-D: sorted intervals; n-D: the Delaunay triangulation of
:class:`scipy.spatial.Delaunay`) and inside a simplex with vertices ``q_0 .. q_n``

    theta(q) = sum_i b_i(q) theta_i,        b = barycentric coordinates of q (sum b_i = 1),

which is the paper's ``theta(q) = (1 - a) theta_1 + a theta_2`` (docs/method.md §3.3) on each
interval. It reproduces every demo exactly and is continuous across simplices (two simplices
that share a facet agree on it: the coordinates of the vertex off the facet are 0 there).

Outside the hull, ``theta`` is extrapolated affinely from the simplex that q is *least outside
of* (the largest smallest barycentric coordinate). In 1-D that is the end interval, so the
extrapolation is continuous (the matchbox's Fig. 7 case). In n-D it is continuous across the hull
boundary (there the chosen simplex contains q) but may jump, outside the hull, where the chosen
simplex changes.

Repeated queries (a database grown with ``on_duplicate="keep"``) are averaged: their mean
parameter vector is the least-squares estimate at that query. With at most n distinct queries
(only possible with repeats) it falls back to the affine hull, as the core's ``"linear"`` does.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from dmprs import _core, portable
from dmprs._arrays import as_query
from dmprs.dmp import DMP
from dmprs.errors import ExtrapolationError, InvalidInputError
from dmprs.periodic import PeriodicDMP

__all__ = ["PiecewiseLinear"]

#: tau(q) must lie strictly inside (TAU_LOW x the shortest, TAU_HIGH x the longest demo's tau),
#: as in the core (docs/method.md §3.3)
TAU_LOW, TAU_HIGH = 0.2, 5.0
#: From this many simplices on, a query inside the hull is located (scipy's find_simplex) and
#: only the simplices around the one found are compared; below, comparing all costs no more.
LOCAL_SEARCH_FROM = 256


def _flatten(dmp: DMP | PeriodicDMP, final_velocity: bool = False) -> NDArray[np.float64]:
    """``[w, tau, g, y0]``; a periodic DMP's amplitude comes after its baseline g; with
    ``final_velocity``, a discrete DMP's final velocity gd last.
    """
    amplitude = [dmp.amplitude] if isinstance(dmp, PeriodicDMP) else []
    velocity = [dmp.final_velocity] if final_velocity and isinstance(dmp, DMP) else []
    return np.concatenate([dmp.weights.ravel(), [dmp.tau], dmp.goal, *amplitude, dmp.start, *velocity])


class PiecewiseLinear:
    """The generalizer with the core ``Generalizer``'s interface (``predict``, ``parameters``,
    ``jacobian``, ...; DMPs as core objects), over ``queries`` (M, n) and the demos' fitted
    DMPs (all discrete or all periodic), so :class:`dmprs.Generalizer` can hold either. With
    ``final_velocity`` (discrete DMPs only) each demo's final velocity is blended with the other
    parameters and the predicted DMPs reach their goals with it.
    """

    method = "linear"

    def __init__(self, queries: NDArray[np.float64], demo_dmps: Sequence[DMP] | Sequence[PeriodicDMP],
                 final_velocity: bool = False) -> None:
        queries = np.asarray(queries, dtype=np.float64)
        if queries.ndim != 2 or queries.shape[0] != len(demo_dmps):
            raise InvalidInputError(f"queries has shape {queries.shape}; expected ({len(demo_dmps)}, n)")
        self._dmps: list[DMP | PeriodicDMP] = list(demo_dmps)
        self._queries = queries
        self._template: DMP | PeriodicDMP = self._dmps[0]
        if final_velocity and not isinstance(self._template, DMP):
            raise InvalidInputError("final_velocity=True blends discrete DMPs only (docs/method.md §2.8)")
        self._final_velocity = bool(final_velocity)
        thetas = np.array([_flatten(d, self._final_velocity) for d in self._dmps])
        nodes, inverse = np.unique(queries, axis=0, return_inverse=True)
        if len(nodes) < 2:
            raise InvalidInputError(
                f"method 'linear' needs at least 2 distinct demonstration queries; all {len(queries)} "
                f"are {nodes[0].tolist()}")
        inverse = inverse.reshape(-1)
        # Repeats: the mean of their parameters (np.unique sorts the nodes, so 1-D nodes are sorted).
        # Grouped through one stable sort (a scan per node would be quadratic in the demos); a
        # group keeps its demos' order, so its mean is the one numpy takes of them in place.
        counts = np.bincount(inverse, minlength=len(nodes))
        order = np.argsort(inverse, kind="stable")
        starts = np.cumsum(counts) - counts
        self._theta = thetas[order[starts]]
        for j in np.flatnonzero(counts > 1):
            self._theta[j] = thetas[order[starts[j]:starts[j] + counts[j]]].mean(axis=0)
        self._nodes = nodes
        n = nodes.shape[1]
        taus = [d.tau for d in self._dmps]
        self._tau_valid = (TAU_LOW * min(taus), TAU_HIGH * max(taus))
        self._simplices: NDArray[np.intp] | None = None
        self._transform: NDArray[np.float64] | None = None
        self._hull_pinv: NDArray[np.float64] | None = None
        if n == 1:
            return
        if len(nodes) <= n:  # fewer than a simplex: the affine hull (least-squares projection)
            delta = (nodes[1:] - nodes[0]).T
            self._check_rank(delta, len(nodes) - 1)
            self._hull_pinv = np.linalg.pinv(delta)
            return
        self._check_rank((nodes[1:] - nodes[0]).T, n)
        from scipy.spatial import Delaunay, QhullError

        # Triangulated with each dimension in units of its range: Qhull takes a dimension whose
        # units are 1e-10 of another's for a flat one (its points "coplanar", left out).
        self._unit = np.ptp(nodes, axis=0)
        try:
            tri = Delaunay(nodes / self._unit)
        except QhullError as exc:
            raise InvalidInputError(f"the demonstration queries cannot be triangulated: {exc}") from None
        self._simplices = tri.simplices
        # The barycentric transforms (scipy's layout: T^-1 of the edge vectors, then the last
        # vertex) computed here in a fixed order, not by LAPACK's CPU-chosen kernels.
        corners = nodes[tri.simplices]
        last = corners[:, n, :]
        edges = np.swapaxes(corners[:, :n, :] - last[:, None, :], 1, 2)
        self._transform = np.concatenate([portable.inverses(edges), last[:, None, :]], axis=1)
        self._tri = tri
        # The simplices around each node (its star), grouped by node: star[ptr[v]:ptr[v + 1]].
        incidence = tri.simplices.ravel()
        order = np.argsort(incidence, kind="stable")
        self._star = order // (n + 1)
        self._star_ptr = np.searchsorted(incidence[order], np.arange(len(nodes) + 1))

    def _check_rank(self, delta: NDArray[np.float64], rank: int) -> None:
        # Scale-free: each query dimension in units of its own range over the demos, so that a
        # dimension measured in small units is not mistaken for a missing one.
        span = np.ptp(self._nodes, axis=0)
        delta = delta / np.where(span > 0, span, 1.0)[:, None]
        s = np.linalg.svd(delta, compute_uv=False)
        if s.size == 0 or s.min() <= 1e-10 * s.max() or np.linalg.matrix_rank(delta) < rank:
            raise InvalidInputError(
                "method 'linear' needs demo queries that span their dimensions (not all on a line, "
                f"plane, ...), but {self._nodes.tolist()} lie in a lower-dimensional subspace")

    # --- the interpolation ------------------------------------------------------------------
    def _coordinates(self, q: NDArray[np.float64]) -> tuple[NDArray[np.intp], NDArray[np.float64]]:
        """Node indices and barycentric coordinates (summing to 1) whose combination is theta(q)."""
        nodes = self._nodes
        if nodes.shape[1] == 1:
            x = nodes[:, 0]
            i = int(np.clip(np.searchsorted(x, q[0]) - 1, 0, len(x) - 2))
            with np.errstate(all="ignore"):  # an overflow is caught as non-finite in parameters()
                a = (q[0] - x[i]) / (x[i + 1] - x[i])
            return np.array([i, i + 1]), np.array([1.0 - a, a])
        if self._hull_pinv is not None:
            b = self._hull_pinv @ (q - nodes[0])
            return np.arange(len(nodes)), np.concatenate([[1.0 - b.sum()], b])
        assert self._transform is not None and self._simplices is not None
        n = nodes.shape[1]
        candidates = self._around(q)
        t = self._transform if candidates is None else self._transform[candidates]
        d = q - t[:, n, :]
        b = t[:, :n, 0] * d[:, :1]
        for j in range(1, n):
            b = b + t[:, :n, j] * d[:, j:j + 1]
        bary = np.concatenate([b, 1.0 - b.sum(axis=1, keepdims=True)], axis=1)
        # Inside the hull this picks a simplex containing q (smallest coordinate >= 0); outside,
        # the one q is least outside of (the stated extrapolation rule). Ties go to the lowest
        # simplex index either way.
        s = int(np.argmax(bary.min(axis=1)))
        return self._simplices[s if candidates is None else candidates[s]], bary[s]

    def _around(self, q: NDArray[np.float64]) -> NDArray[np.intp] | None:
        """The simplices that can win the comparison for a q inside the hull, in index order, or
        None to compare all (few simplices, or q outside the hull). Any simplex whose smallest
        coordinate at q is not clearly negative contains q up to rounding, so it shares a node
        with the simplex scipy finds: the stars of that simplex's nodes hold them all.
        """
        if self._simplices is None or len(self._simplices) < LOCAL_SEARCH_FROM:
            return None
        found = int(self._tri.find_simplex(q / self._unit))
        if found < 0:
            return None
        star, ptr = self._star, self._star_ptr
        return np.unique(np.concatenate([star[ptr[v]:ptr[v + 1]] for v in self._simplices[found]]))

    def _check_query(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        names = tuple(f"q[{d}]" for d in range(self.n_query))
        return as_query(q, "q", names)

    def parameters(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """``[w.ravel(), tau, goal, y0]`` (``[..., y0, gd]`` with final velocities) at ``q``,
        without the tau check.
        """
        q = self._check_query(q)
        idx, b = self._coordinates(q)
        with np.errstate(all="ignore"):
            theta = portable.combine(b, self._theta[idx])
        if not np.isfinite(theta).all():
            raise ExtrapolationError(
                f"cannot generalize to query {q.tolist()}: its barycentric coordinates {b.tolist()} "
                "overflow (the query is too far from the demonstrations for their spacing)")
        return theta

    def predict(self, q: NDArray[np.float64]) -> _core.Dmp | _core.PeriodicDmp:
        """The DMP for query ``q``: the barycentric blend of its simplex's demonstrations."""
        q = self._check_query(q)
        theta = self.parameters(q)
        d, n = self.n_dof, self.n_basis
        tau = float(theta[d * n])
        lo, hi = self._tau_valid
        if not (lo < tau < hi):
            raise ExtrapolationError(
                f"cannot generalize to query {q.tolist()}: the 'linear' generalization gives tau = {tau} s, "
                f"outside the valid range ({lo}, {hi}) s (0.2 x the shortest and 5 x the longest "
                "demonstration); the query is too far from the demonstrations")
        t = self._template
        w, goal = theta[: d * n].reshape(d, n), theta[d * n + 1: d * n + 1 + d]
        if isinstance(t, PeriodicDMP):
            amplitude = theta[d * n + 1 + d: d * n + 1 + 2 * d]
            if not (amplitude > 0.0).all():
                k = int(np.argmin(amplitude))
                raise ExtrapolationError(
                    f"cannot generalize to query {q.tolist()}: the 'linear' generalization gives "
                    f"amplitude[{k}] = {amplitude[k]}, not positive (every demonstration's is); the query "
                    "is too far from the demonstrations")
            return PeriodicDMP(w, goal, theta[d * n + 1 + 2 * d:], tau, amplitude=amplitude, alpha_z=t.alpha_z,
                               beta_z=t.beta_z, width_factor=t.width_factor)._core
        start = theta[d * n + 1 + d: d * n + 1 + 2 * d]
        velocity = theta[d * n + 1 + 2 * d:] if self._final_velocity else None
        return DMP(w, goal, start, tau, alpha_z=t.alpha_z, beta_z=t.beta_z, alpha_x=t.alpha_x,
                   width_factor=t.width_factor, final_velocity=velocity)._core

    def jacobian(self, q: NDArray[np.float64], rel_step: float) -> NDArray[np.float64]:
        """Central differences, step ``rel_step x`` the demos' query range per dimension (as the
        core): exact inside a simplex, the mean of the two slopes on a shared facet.
        """
        q = self._check_query(q)
        lo, hi = self._queries.min(axis=0), self._queries.max(axis=0)
        scale = np.where(hi > lo, hi - lo, np.maximum(np.abs(q), 1.0))
        jac = np.empty((self.n_parameters, self.n_query))
        for d in range(self.n_query):
            h = rel_step * scale[d]
            step = np.zeros_like(q)
            step[d] = h
            with np.errstate(all="ignore"):  # an overflow is refused just below, not warned about
                jac[:, d] = (self.parameters(q + step) - self.parameters(q - step)) / (2.0 * h)
        if not np.isfinite(jac).all():
            raise ExtrapolationError(
                f"the Jacobian at query {q.tolist()} overflows with rel_step = {rel_step:g}: the step "
                "reaches too far from the demonstrations for their spacing")
        return jac

    # --- the core Generalizer's properties --------------------------------------------------
    @property
    def demo_dmps(self) -> list[_core.Dmp | _core.PeriodicDmp]:
        """The demonstrations' DMPs."""
        return [d._core for d in self._dmps]

    @property
    def n_query(self) -> int:
        """Dimension of the query."""
        return int(self._queries.shape[1])

    @property
    def n_dof(self) -> int:
        """Degrees of freedom of the predicted DMPs."""
        return self._template.n_dof

    @property
    def n_basis(self) -> int:
        """Kernels per degree of freedom."""
        return self._template.n_basis

    @property
    def n_demos(self) -> int:
        """Number of demonstrations."""
        return len(self._dmps)

    @property
    def n_parameters(self) -> int:
        """Length of the parameter vector (weights, tau, goal, start; a periodic DMP's amplitude too,
        the final velocity with ``final_velocity``).
        """
        return len(_flatten(self._template, self._final_velocity))

    @property
    def tau_bounds(self) -> tuple[float, float]:
        """The range of tau over the demonstrations."""
        return self._tau_valid
