"""Damped-least-squares differential inverse kinematics of the arm, with joint-limit avoidance in
the null space (MuJoCo's kinematics and Jacobians of :mod:`dmprs.sim.arm_model`).

For a pose trajectory sampled at t_k, the joint solution of sample k starts from that of sample
k - 1 and takes Newton steps of the damped least-squares update (Wampler 1986; Nakamura & Hanafusa
1986)::

    dq = J^T (J J^T + lambda^2 I)^-1 e  +  (I - J^+ J) z,      z = -k_lim dt grad H(q)

with the pose error ``e = (p* - p, R(q) log(q^-1 * q*))`` (position in m, orientation as the
rotation vector in the world frame), ``J`` the 6 x 7 site Jacobian of the mouth, and the
joint-limit cost ``H = 1/2 sum ((q_i - m_i) / r_i)^2`` (m_i, r_i: the middle and half-range of
joint i) whose gradient the redundant seventh DOF descends without moving the bottle. Steps are
repeated (at most ``max_steps``) until the error is below ``tol``; the residual error is
returned for every sample, so the caller decides what "unreachable" means.

The step's linear algebra and the error norms are :mod:`dmprs.portable`'s (the Rust core's, in a
fixed order), never BLAS's: the poured volume is chaotic in the joint trajectory, and a BLAS
kernel chosen by the CPU would make it differ between machines.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dmprs import _core
from dmprs.portable import matvec_rows, norm
from dmprs.sim import arm_model

#: damping lambda of the least-squares step (m or rad): small enough not to slow convergence
#: away from singularities, large enough to keep steps bounded near them
DAMPING = 0.02
#: gain of the joint-limit avoidance (1/s)
LIMIT_GAIN = 2.0
#: a sample's error counts as solved below these (m, rad)
POSITION_TOL = 1e-5
ORIENTATION_TOL = 1e-4


@dataclass(frozen=True)
class IKResult:
    """Joint positions ``q`` (T, 7) for the poses at ``t`` (T,), with the residual position error
    (m) and orientation error (rad) of every sample.
    """

    t: NDArray[np.float64]
    q: NDArray[np.float64]
    position_error: NDArray[np.float64]
    orientation_error: NDArray[np.float64]


class ArmKinematics:
    """Forward kinematics and Jacobians of the mouth site, on a particle-free copy of the model."""

    def __init__(self) -> None:
        import mujoco

        self._mj = mujoco
        self.model = arm_model.load()
        self.data = mujoco.MjData(self.model)
        self.site = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_SITE, "mouth")
        self.lower = self.model.jnt_range[:7, 0].copy()
        self.upper = self.model.jnt_range[:7, 1].copy()
        self._jacp = np.zeros((3, self.model.nv))
        self._jacr = np.zeros((3, self.model.nv))
        self._quat = np.zeros(4)
        self._err = np.zeros(3)
        self._rot_err = np.zeros(3)
        self._no_motion = np.zeros(7)

    def _set(self, q: NDArray[np.float64]) -> None:
        self.data.qpos[:7] = q
        self._mj.mj_kinematics(self.model, self.data)

    def pose(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """The mouth's pose (x, y, z, qw, qx, qy, qz) at joint positions ``q``."""
        self._set(q)
        self._mj.mju_mat2Quat(self._quat, self.data.site_xmat[self.site])
        return np.concatenate([self.data.site_xpos[self.site], self._quat])

    def jacobian(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """The mouth's Jacobian J (6, 7) at ``q``: its linear, then its angular velocity (world
        frame) per unit of joint velocity.
        """
        mj, m, d = self._mj, self.model, self.data
        self._set(q)
        mj.mj_comPos(m, d)
        mj.mj_jacSite(m, d, self._jacp, self._jacr, self.site)
        return np.ascontiguousarray(np.vstack([self._jacp[:, :7], self._jacr[:, :7]]))

    def error_and_jacobian(self, q: NDArray[np.float64], target: NDArray[np.float64],
                           ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The pose error e (6,) of ``q`` against ``target`` and the Jacobian J (6, 7)."""
        mj, d = self._mj, self.data
        jac = self.jacobian(q)
        xmat = d.site_xmat[self.site]
        mj.mju_mat2Quat(self._quat, xmat)
        mj.mju_subQuat(self._err, np.ascontiguousarray(target[3:]), self._quat)  # in the site frame
        mj.mju_mulMatVec(self._rot_err, xmat.reshape(3, 3), self._err)  # to the world frame
        e = np.empty(6)
        e[:3] = target[:3] - d.site_xpos[self.site]
        e[3:] = self._rot_err
        return e, jac

    def limit_gradient(self, q: NDArray[np.float64]) -> NDArray[np.float64]:
        """grad H of the joint-limit cost H = 1/2 sum ((q - middle) / half_range)^2."""
        middle = 0.5 * (self.lower + self.upper)
        half = 0.5 * (self.upper - self.lower)
        return (q - middle) / (half * half)

    def step(self, q: NDArray[np.float64], target: NDArray[np.float64], null_step: float,
             ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """One damped-least-squares step toward ``target``: (new q, the error before the step)."""
        e, jac = self.error_and_jacobian(q, target)
        z = -null_step * self.limit_gradient(q) if null_step else self._no_motion
        return q + _core.dls_step(jac, e, z, DAMPING), e

    def solve(self, target: NDArray[np.float64], q_init: NDArray[np.float64], *, max_steps: int = 200,
              ) -> tuple[NDArray[np.float64], float, float]:
        """Joint positions reaching ``target`` from ``q_init`` (iterated to convergence, with limit
        avoidance): (q, position error m, orientation error rad) of the returned q.
        """
        q = np.array(q_init, dtype=float)
        for _ in range(max_steps):
            q_next, e = self.step(q, target, null_step=0.01)
            if norm(e[:3]) < POSITION_TOL and norm(e[3:]) < ORIENTATION_TOL:
                break
            q = q_next
        e, _ = self.error_and_jacobian(q, target)
        return q, norm(e[:3]), norm(e[3:])

    def track(self, t: NDArray[np.float64], poses: NDArray[np.float64], q0: NDArray[np.float64], *,
              max_steps: int = 4) -> IKResult:
        """Joint positions following ``poses`` (T, 7) sampled at ``t``, starting from ``q0`` (the
        joint solution of ``poses[0]``).
        """
        n = len(t)
        q_out = np.empty((n, 7))
        pos_err = np.empty(n)
        rot_err = np.empty(n)
        q = np.array(q0, dtype=float)
        for k in range(n):
            q, pos_err[k], rot_err[k] = self.follow(q, poses[k], float(t[k] - t[k - 1]) if k else 0.0,
                                                    max_steps=max_steps)
            q_out[k] = q
        return IKResult(np.asarray(t, dtype=float), q_out, pos_err, rot_err)

    def follow(self, q: NDArray[np.float64], target: NDArray[np.float64], dt: float, *, max_steps: int = 4,
               ) -> tuple[NDArray[np.float64], float, float]:
        """One sample of :meth:`track`: the joint positions reaching ``target`` from the previous
        sample's ``q``, ``dt`` s before (the first step descends the limit cost for that long),
        with their position (m) and orientation (rad) errors.
        """
        for i in range(max_steps):
            q_next, e = self.step(q, target, null_step=LIMIT_GAIN * dt if i == 0 else 0.0)
            pe, re = norm(e[:3]), norm(e[3:])
            if pe < POSITION_TOL and re < ORIENTATION_TOL and i > 0:
                break
            q = q_next
        else:
            e, _ = self.error_and_jacobian(q, target)
            pe, re = norm(e[:3]), norm(e[3:])
        return q, pe, re

    def joint_velocity(self, q: NDArray[np.float64], twist: NDArray[np.float64]) -> NDArray[np.float64]:
        """The joint velocity (7,) that moves the mouth at ``twist`` (6,: linear, then angular,
        world frame) from ``q``: :meth:`step` per unit of time, the damped least-squares solution
        of ``J qd = twist`` with the limit cost descended at :data:`LIMIT_GAIN` in the null space,
        so that following a pose stream with :meth:`follow` moves the joints at this velocity.
        """
        return _core.dls_step(self.jacobian(q), np.ascontiguousarray(twist, dtype=np.float64),
                              -LIMIT_GAIN * self.limit_gradient(q), DAMPING)

    def twist(self, q: NDArray[np.float64], qd: NDArray[np.float64]) -> NDArray[np.float64]:
        """The mouth's velocity (6,: linear, then angular, world frame) at joint positions ``q``
        moving at ``qd``: ``J qd``, summed in joint order (no BLAS, as the step).
        """
        return matvec_rows(np.asarray(qd, dtype=np.float64)[None, :], self.jacobian(q))[0]
