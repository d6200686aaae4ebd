"""One pour of the arm scene in MuJoCo: the joint servo at 1 kHz follows a joint trajectory while
the granular liquid flows; then the bottle is held still and the spheres are counted.

Physics only: it knows nothing of DMPs, IK or tasks (the adapter in
:mod:`dmprs.tasks.arm_pouring` validates the trajectory and turns the result into signals).

* The servo: MuJoCo position actuators ``tau = kp (q_c - q) - kv qd`` with gravity compensation;
  commanding ``q_c = q* + (kv / kp) qd*`` makes it the PD ``kp (q* - q) + kv (qd* - qd)`` on the
  reference (q*, qd*), so the arm does not lag behind a moving reference. The reference is the
  commanded trajectory interpolated linearly at every 1 ms step.
* The liquid is spawned on a lattice in the bottle at the home configuration and settled for
  :data:`SETTLE_TIME` with the arm holding still; the settled state (every qpos and qvel) is
  cached per process, and each trial starts from a fresh ``MjData`` set to it, so a trial is
  bit-identical whether the state was just computed or cached.
* Divergence (a non-finite state, or any of MuJoCo's instability warnings: bad qacc, too many
  contacts or constraints) raises :class:`~dmprs.errors.NumericalError`.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs.errors import NumericalError
from dmprs.portable import matvec_rows
from dmprs.sim import arm_model as am
from dmprs.sim import granular
from dmprs.sim.arm_ik import ArmKinematics
from dmprs.sim.pour_record import PourRecord

#: the mouth's start pose (x, y, z, qw, qx, qy, qz): upright, beside the glass and above its rim
HOME_POSE = (0.75, 0.0, 0.34, 1.0, 0.0, 0.0, 0.0)
#: the IK's seed for the home configuration: elbow up, wrist bent down (deg 0, 34, 0, -69, 0, -57, 0)
HOME_SEED = (0.0, 0.6, 0.0, -1.2, 0.0, -1.0, 0.0)
#: s of settling before a pour (the spheres come to rest within ~0.2 s)
SETTLE_TIME = 0.4
#: physics steps (1 ms each) between stop/timeout checks while settling and pouring
STOP_CHECK_EVERY = 10


@functools.lru_cache(maxsize=1)
def home_configuration() -> NDArray[np.float64]:
    """The joint positions of :data:`HOME_POSE` (the IK from :data:`HOME_SEED`), read-only."""
    q, pe, re = ArmKinematics().solve(np.array(HOME_POSE), np.array(HOME_SEED))
    if pe > 1e-4 or re > 1e-3:
        raise NumericalError(f"the home pose is unreachable (errors {pe:.3g} m, {re:.3g} rad)")
    q.setflags(write=False)
    return q


@dataclass(frozen=True)
class SettledLiquid:
    """A compiled model with ``n`` spheres and its settled state (read-only arrays)."""

    n: int
    seed: int
    model: Any
    qpos: NDArray[np.float64]
    qvel: NDArray[np.float64]
    solver: tuple[str, int, int]


@dataclass(frozen=True, kw_only=True)
class ArmPourResult(PourRecord):
    """What one pour did (:class:`~dmprs.sim.pour_record.PourRecord`, in m, with spheres for
    particles), and ``q``/``q_ref``: executed and reference joint positions at every physics
    step. ``region`` holds :data:`granular.IN_BOTTLE`, ...; spilled is counted from ``region``,
    not by subtraction, so the counts adding up is a real check.
    """

    q: NDArray[np.float64]
    q_ref: NDArray[np.float64]


def _bottle_frame(model: Any, data: Any) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    b = model.body("bottle").id
    return data.xpos[b].copy(), data.xmat[b].reshape(3, 3).copy()


def _particle_positions(data: Any, n: int) -> NDArray[np.float64]:
    # free joints after the 7 arm joints: 7 qpos each (position then quaternion)
    return data.qpos[7:].reshape(n, 7)[:, :3].copy() if n else np.zeros((0, 3))


#: settled liquids kept per process, most recently used last (each holds a compiled model):
#: enough for every liquid of the reproduction's arm pours (its bottles times its liquid seeds),
#: so that a worker handed their runs in any order settles each liquid once
_SETTLED: dict[tuple[int, int, tuple[str, int, int]], SettledLiquid] = {}
_SETTLED_KEPT = 32


def liquid_xml(n: int, seed: int = 0, solver: tuple[str, int, int] = (am.SOLVER, am.ITERATIONS, am.CONDIM),
               ) -> str:
    """The MJCF string of the scene with ``n`` spheres (of ``seed``) spawned in the upright bottle
    at the home configuration: the model :func:`settled_liquid` settles, for a caller that adds
    to it (its state then fits the settled one).
    """
    import mujoco

    kinematic = am.load()
    kd = mujoco.MjData(kinematic)
    kd.qpos[:7] = home_configuration()
    mujoco.mj_kinematics(kinematic, kd)
    pos, mat = _bottle_frame(kinematic, kd)
    world = pos + matvec_rows(granular.spawn_sites(n, seed), mat)
    name, iterations, condim = solver
    return am.scene_xml(world, particle_radii=granular.radii(n, seed), solver=name, iterations=iterations,
                        condim=condim)


def settled_liquid(n: int, seed: int = 0, solver: tuple[str, int, int] = (am.SOLVER, am.ITERATIONS, am.CONDIM),
                   ) -> SettledLiquid:
    """``n`` spheres spawned in the bottle at the home configuration and settled for
    :data:`SETTLE_TIME` s (cached per process); raises NumericalError if one is not in the bottle
    afterwards.
    """
    liquid = settle_liquid(n, seed, solver)
    assert liquid is not None  # nothing can interrupt it
    return liquid


def settle_liquid(n: int, seed: int = 0, solver: tuple[str, int, int] = (am.SOLVER, am.ITERATIONS, am.CONDIM),
                  should_stop: Callable[[], bool] | None = None) -> SettledLiquid | None:
    """:func:`settled_liquid`, interruptible: None (and nothing cached) if ``should_stop()``
    became true while settling (it is asked every :data:`STOP_CHECK_EVERY` steps).
    """
    import mujoco

    key = (n, seed, solver)
    if key in _SETTLED:
        _SETTLED[key] = _SETTLED.pop(key)  # most recently used
        return _SETTLED[key]
    q_home = home_configuration()
    model = mujoco.MjModel.from_xml_string(liquid_xml(n, seed, solver))
    data = mujoco.MjData(model)
    data.qpos[:7] = q_home
    data.ctrl[:] = q_home
    for k in range(round(SETTLE_TIME / am.TIMESTEP)):
        if should_stop is not None and k % STOP_CHECK_EVERY == 0 and should_stop():
            return None
        mujoco.mj_step(model, data)
    am.check_health(mujoco, data, SETTLE_TIME)
    mujoco.mj_kinematics(model, data)
    region = granular.classify(_particle_positions(data, n), *_bottle_frame(model, data))
    if not (region == granular.IN_BOTTLE).all():
        bad = int(np.flatnonzero(region != granular.IN_BOTTLE)[0])
        raise NumericalError(f"settling {n} spheres (seed {seed}) left sphere {bad} outside the bottle")
    qpos, qvel = data.qpos.copy(), data.qvel.copy()
    qpos.setflags(write=False)
    qvel.setflags(write=False)
    liquid = SettledLiquid(n, seed, model, qpos, qvel, solver)
    _SETTLED[key] = liquid
    while len(_SETTLED) > _SETTLED_KEPT:
        del _SETTLED[next(iter(_SETTLED))]
    return liquid


def simulate_pour(t: NDArray[np.float64], q: NDArray[np.float64], qd: NDArray[np.float64],
                  liquid: SettledLiquid, *, hold: float = 1.0, sample_period: float = 0.02,
                  should_stop: Callable[[], bool] | None = None,
                  on_sample: Callable[[Any, Any, float], None] | None = None) -> ArmPourResult:
    """Follows the joint trajectory ``q`` (T, 7) with velocities ``qd`` at times ``t`` (from its
    first sample, which must be the home configuration), then holds the last sample for
    ``hold`` s, and counts. The caller validates the trajectory; this function trusts it.
    ``should_stop()`` is asked every :data:`STOP_CHECK_EVERY` steps, while moving and while
    holding; when it says so the pour ends there (``interrupted``).
    ``on_sample(model, data, t)`` is called at every count (every ``sample_period`` s), e.g. to
    render frames; it must not change ``data``.
    """
    import mujoco

    model, n = liquid.model, liquid.n
    data = mujoco.MjData(model)
    data.qpos[:] = liquid.qpos
    data.qvel[:] = liquid.qvel
    mujoco.mj_forward(model, data)
    am.check_health(mujoco, data, 0.0)
    dt = am.TIMESTEP
    n_move = max(1, math.ceil((t[-1] - t[0]) / dt - 1e-9))
    n_steps = n_move + round(hold / dt)
    times = np.arange(n_steps + 1) * dt
    q_ref = np.stack([np.interp(t[0] + times, t, q[:, j]) for j in range(7)], axis=1)
    qd_ref = np.stack([np.interp(t[0] + times, t, qd[:, j]) for j in range(7)], axis=1)
    qd_ref[n_move + 1:] = 0.0  # holding still after the end
    command = q_ref + qd_ref * (np.asarray(am.KV) / np.asarray(am.KP))
    executed = np.empty((n_steps + 1, 7))
    executed[0] = data.qpos[:7]
    sample_every = max(1, round(sample_period / dt))
    sample_t = [0.0]
    counts = [int(granular.in_glass(_particle_positions(data, n)).sum())]
    if on_sample is not None:
        on_sample(model, data, 0.0)
    interrupted = False
    k = 0
    for k in range(1, n_steps + 1):
        data.ctrl[:] = command[k]
        mujoco.mj_step(model, data)
        executed[k] = data.qpos[:7]
        if k % sample_every == 0 or k == n_steps:
            sample_t.append(k * dt)
            counts.append(int(granular.in_glass(_particle_positions(data, n)).sum()))
            if on_sample is not None:
                on_sample(model, data, k * dt)
            am.check_health(mujoco, data, k * dt)
        if should_stop is not None and k % STOP_CHECK_EVERY == 0 and should_stop():
            interrupted = True
            break
    am.check_health(mujoco, data, k * dt)
    mujoco.mj_kinematics(model, data)
    positions = _particle_positions(data, n)
    region = granular.classify(positions, *_bottle_frame(model, data))
    return ArmPourResult(
        times=times[: k + 1], q=executed[: k + 1], q_ref=q_ref[: k + 1],
        sample_times=np.array(sample_t), glass_counts=np.array(counts, dtype=np.int64),
        region=region, positions=positions, n_particles=n,
        n_bottle=int((region == granular.IN_BOTTLE).sum()), n_glass=int((region == granular.IN_GLASS).sum()),
        n_spilled=int((region == granular.SPILLED).sum()), interrupted=interrupted)
