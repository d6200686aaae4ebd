"""The 2-D pouring scene (pymunk): a kinematic bottle that tilts about its mouth, a "liquid" of
small polydisperse discs, a glass under the mouth and a tray floor that catches spills.

This module is only the physics: it knows nothing of DMPs, tasks or learners. The adapter in
:mod:`dmprs.tasks.pouring` turns its results into SI outcome signals.

Design (docs/method.md §9.3, checked there with a throw-away prototype):

* Internal units are mm, g, s (gravity 9810 mm/s^2): the particle radius is 2 mm, and pymunk's
  tolerances (``collision_slop``) are absolute lengths, so millimetres keep them meaningful.
* One disc is 2 ml: 500 discs = 1.0 l. Radii are 2 mm +- 15 % (uniform), drawn from a seeded
  ``numpy.random.Generator``: polydispersity keeps the discs from crystallizing and jamming.
* The bottle is a kinematic body whose **origin is the mouth centre**, so it rotates about the
  mouth and the stream stays above the glass. It is driven through its angular velocity,
  ``omega = (theta_des - angle) / dt`` each step, never by setting the angle: teleporting a
  body would push discs through its walls.
* The liquid is spawned on a hexagonal grid inside the upright bottle, settled for 0.5 s and
  checked to be entirely inside. Every trial rebuilds the space in the same insertion order and
  restores the settled positions and velocities, so a trial is bit-identical whether the settled
  state was computed in this process a moment ago or cached (pymunk is deterministic for a fixed
  dt, iteration count and insertion order; its contact cache starts empty in both cases).
* Poured volume = discs inside the glass, counted 1 s after the bottle is back upright
  (``hold``). Glass and bottle regions never overlap: the bottle's lowest point (162 mm) stays
  above the glass rim (150 mm) at every tilt.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from dmprs.errors import InvalidInputError, NumericalError
from dmprs.sim.pour_record import PourRecord

# --- simulation constants (docs/method.md §9.3) -------------------------------------------------
DT = 1.0 / 600.0  #: physics step (s)
ITERATIONS = 12  #: solver iterations per step
COLLISION_SLOP = 0.05  #: allowed penetration (mm)
GRAVITY = 9810.0  #: mm/s^2
SETTLE_TIME = 0.5  #: s of settling before every pour
HOLD_TIME = 1.0  #: s after the trajectory ends (bottle upright) before counting

# --- liquid ---------------------------------------------------------------------------------------
PARTICLE_ML = 2.0  #: volume one disc stands for (ml); 500 discs = 1.0 l
RADIUS = 2.0  #: mean disc radius (mm)
POLYDISPERSITY = 0.15  #: radii uniform in RADIUS * (1 +- POLYDISPERSITY)
DENSITY = 1e-3  #: g per mm^2 of disc area (only ratios matter: every disc has the same density)

# --- bottle, in its own frame: origin at the mouth centre, y up when upright ---------------------
WALL_RADIUS = 1.5  #: mm, all walls
NECK_HALF_WIDTH = 15.0  #: neck 30 mm wide ...
NECK_LENGTH = 30.0  #: ... and 30 mm long
SHOULDER_HEIGHT = 25.0  #: taper from the neck to the body
BODY_HALF_WIDTH = 35.0  #: body 70 mm wide ...
BODY_HEIGHT = 180.0  #: ... and 180 mm tall
PIVOT = (0.0, 400.0)  #: the mouth centre in the world (mm)
BOTTLE_DEPTH = NECK_LENGTH + SHOULDER_HEIGHT + BODY_HEIGHT  #: mouth to bottom, 235 mm
#: The most liquid the bottle accepts (discs). The spawn grid holds ~590 discs; 550 (1.1 l)
#: settles to about 70 % of the straight body's height, so even a full bottle starts with its
#: free surface well below the shoulder (docs/method.md §9.3: keep 1.0 l below ~90 % of the body).
MAX_PARTICLES = 550

# --- glass and tray, world frame --------------------------------------------------------------
GLASS_X = (-10.0, 140.0)  #: glass walls, relative to the mouth (which is at x = 0)
GLASS_HEIGHT = 150.0  #: rim height; the glass stands on the floor (y = 0)
TRAY_HALF_WIDTH = 450.0  #: the floor spans +-450 mm, with walls that keep spills on it
TRAY_WALL_HEIGHT = 150.0
FLOOR_THICKNESS = 40.0  #: mm; floor and tray walls are this thick (no tunnelling)

#: region codes of :func:`classify`
IN_BOTTLE, IN_GLASS, ON_FLOOR, ELSEWHERE = 0, 1, 2, 3

HASH_CELL = 5.0  #: mm, spatial-hash cell (about one disc diameter)
HASH_COUNT = 2000  #: spatial-hash table size

STOP_CHECK_EVERY = 60  #: steps between checks of the stop/timeout callback (0.1 s of sim time)


@dataclass(frozen=True)
class Liquid:
    """A settled liquid inside the upright bottle: per-disc radii, positions and velocities
    (mm, mm/s; world frame), in insertion order. Arrays are read-only.
    """

    seed: int
    radii: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]

    @property
    def n(self) -> int:
        """Number of particles."""
        return int(self.radii.shape[0])


@dataclass(frozen=True, kw_only=True)
class PourResult(PourRecord):
    """What one simulated pour did (:class:`~dmprs.sim.pour_record.PourRecord`, in mm, with
    discs for particles), and ``tilt``: the bottle's executed tilt (rad, positive toward the
    glass) at every physics step. ``region`` holds :data:`IN_BOTTLE`, :data:`IN_GLASS`,
    :data:`ON_FLOOR` or :data:`ELSEWHERE`; ``n_spilled = n - n_bottle - n_glass`` by
    construction (so the three always add up; tests check them against ``region``
    independently).
    """

    tilt: NDArray[np.float64]


# --- geometry -----------------------------------------------------------------------------------

def bottle_outline() -> list[tuple[float, float]]:
    """The bottle's wall polyline in its own frame (mm), from the mouth's right lip round the
    bottom to the left lip.
    """
    n, s, b = NECK_HALF_WIDTH, NECK_LENGTH, NECK_LENGTH + SHOULDER_HEIGHT
    w = BODY_HALF_WIDTH
    return [(n, 0.0), (n, -s), (w, -b), (w, -BOTTLE_DEPTH), (-w, -BOTTLE_DEPTH), (-w, -b), (-n, -s), (-n, 0.0)]


def bottle_half_width(y_local: NDArray[np.float64]) -> NDArray[np.float64]:
    """Inner half-width of the bottle's cavity at height ``y_local`` of its own frame (<= 0)."""
    y = np.asarray(y_local, dtype=float)
    shoulder = NECK_HALF_WIDTH + (-NECK_LENGTH - y) / SHOULDER_HEIGHT * (BODY_HALF_WIDTH - NECK_HALF_WIDTH)
    return np.where(y >= -NECK_LENGTH, NECK_HALF_WIDTH,
                    np.where(y >= -NECK_LENGTH - SHOULDER_HEIGHT, shoulder, BODY_HALF_WIDTH))


def to_bottle_frame(positions: NDArray[np.float64], tilt: float) -> NDArray[np.float64]:
    """World positions (mm) in the frame of a bottle tilted by ``tilt`` (rad, toward the glass)."""
    # The body's pymunk angle is -tilt (tilting toward +x is clockwise); undo that rotation.
    c, s = math.cos(tilt), math.sin(tilt)
    d = np.asarray(positions, dtype=float) - np.asarray(PIVOT)
    return np.stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1]], axis=1)


def classify(positions: NDArray[np.float64], tilt: float) -> NDArray[np.int8]:
    """The region of each disc centre: in the bottle's cavity (below the mouth plane), inside the
    glass (below its rim), on the tray floor outside the glass (below the rim height), or
    elsewhere (in flight, on a rim, escaped).
    """
    p = np.asarray(positions, dtype=float)
    local = to_bottle_frame(p, tilt)
    in_bottle = ((local[:, 1] <= 0.0) & (local[:, 1] > -BOTTLE_DEPTH)
                 & (np.abs(local[:, 0]) < bottle_half_width(local[:, 1])))
    in_glass = ((p[:, 0] > GLASS_X[0] + WALL_RADIUS) & (p[:, 0] < GLASS_X[1] - WALL_RADIUS)
                & (p[:, 1] > 0.0) & (p[:, 1] < GLASS_HEIGHT))
    outside_glass = (p[:, 0] <= GLASS_X[0] - WALL_RADIUS) | (p[:, 0] >= GLASS_X[1] + WALL_RADIUS)
    on_floor = (outside_glass & (p[:, 1] > 0.0) & (p[:, 1] < GLASS_HEIGHT)
                & (np.abs(p[:, 0]) < TRAY_HALF_WIDTH))
    region = np.full(len(p), ELSEWHERE, dtype=np.int8)
    # Assigned in this order; tests check that the masks are disjoint, so the order never matters.
    region[on_floor] = ON_FLOOR
    region[in_glass] = IN_GLASS
    region[in_bottle] = IN_BOTTLE
    return region


def in_glass(positions: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether each disc centre is inside the glass, below its rim."""
    p = positions
    return ((p[:, 0] > GLASS_X[0] + WALL_RADIUS) & (p[:, 0] < GLASS_X[1] - WALL_RADIUS)
            & (p[:, 1] > 0.0) & (p[:, 1] < GLASS_HEIGHT))


# --- building the space -------------------------------------------------------------------------

class _Scene:
    """One pymunk space with the bottle, glass, tray and a liquid, always built in the same order."""

    def __init__(self, radii: NDArray[np.float64], positions: NDArray[np.float64],
                 velocities: NDArray[np.float64] | None = None) -> None:
        # pymunk loads with the first scene, not with `import dmprs` (the package's rule for
        # simulators: they load where they are used).
        import pymunk
        import pymunk.batch

        space = pymunk.Space()
        space.gravity = (0.0, -GRAVITY)
        space.iterations = ITERATIONS
        space.collision_slop = COLLISION_SLOP
        # A spatial hash with ~disc-sized cells is ~2.5x faster than the default bounding-box
        # tree for hundreds of equal-sized discs (measured: 1.2 s vs 2.9 s CPU per 500-disc pour).
        space.use_spatial_hash(HASH_CELL, HASH_COUNT)
        static = space.static_body
        # The floor and the tray walls are thick (a disc falling from the mouth reaches ~3 m/s,
        # 5 mm per step: it would tunnel through a 3 mm wall). The floor's top face is y = 0 and
        # it is also the glass's bottom; the glass walls are thin like the bottle's.
        walls = [
            ((-TRAY_HALF_WIDTH, -FLOOR_THICKNESS / 2), (TRAY_HALF_WIDTH, -FLOOR_THICKNESS / 2), FLOOR_THICKNESS / 2),
            ((-TRAY_HALF_WIDTH - FLOOR_THICKNESS / 2, 0.0), (-TRAY_HALF_WIDTH - FLOOR_THICKNESS / 2, TRAY_WALL_HEIGHT), FLOOR_THICKNESS / 2),
            ((TRAY_HALF_WIDTH + FLOOR_THICKNESS / 2, 0.0), (TRAY_HALF_WIDTH + FLOOR_THICKNESS / 2, TRAY_WALL_HEIGHT), FLOOR_THICKNESS / 2),
            ((GLASS_X[0], 0.0), (GLASS_X[0], GLASS_HEIGHT), WALL_RADIUS),
            ((GLASS_X[1], 0.0), (GLASS_X[1], GLASS_HEIGHT), WALL_RADIUS),
        ]
        for a, b, radius in walls:
            seg = pymunk.Segment(static, a, b, radius)
            seg.friction = 0.0
            seg.elasticity = 0.0
            space.add(seg)

        bottle = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        bottle.position = PIVOT
        space.add(bottle)
        outline = bottle_outline()
        for a, b in itertools.pairwise(outline):
            seg = pymunk.Segment(bottle, a, b, WALL_RADIUS)
            seg.friction = 0.0
            seg.elasticity = 0.0
            space.add(seg)

        bodies = []
        vel = np.zeros_like(positions) if velocities is None else velocities
        for r, p, v in zip(radii.tolist(), positions.tolist(), vel.tolist(), strict=True):
            mass = DENSITY * math.pi * r * r
            body = pymunk.Body(mass, pymunk.moment_for_circle(mass, 0.0, r))
            body.position = p
            body.velocity = v
            shape = pymunk.Circle(body, r)
            shape.friction = 0.0  # an inviscid liquid: no tangential contact forces
            shape.elasticity = 0.0
            space.add(body, shape)
            bodies.append(body)

        self.space = space
        self.bottle = bottle
        self.bodies = bodies
        self._ids = np.array([b.id for b in bodies], dtype=np.uint64)
        self._buffer = pymunk.batch.Buffer()
        self._listed = np.zeros(0, dtype=np.uint64)  # the batch's bodies when _rows was made
        self._rows = np.zeros(0, dtype=np.intp)

    def positions(self) -> NDArray[np.float64]:
        """(n, 2) disc positions in insertion order, read in one batch call."""
        import pymunk.batch  # loaded by __init__ already; named here for this method's calls

        buf = self._buffer
        buf.clear()
        pymunk.batch.get_space_bodies(
            self.space, pymunk.batch.BodyFields.BODY_ID | pymunk.batch.BodyFields.POSITION, buf)
        ids = np.frombuffer(buf.int_buf(), dtype=np.uint64)
        xy = np.frombuffer(buf.float_buf(), dtype=np.float64).reshape(-1, 2)
        # The batch lists every non-static body (the kinematic bottle too), in the space's
        # order: select and order the discs by id rather than trusting that order. The rows
        # are looked up again only when the batch's order changed since the last call.
        if not np.array_equal(ids, self._listed):
            order = {int(i): k for k, i in enumerate(ids)}
            self._rows = np.array([order[int(i)] for i in self._ids], dtype=np.intp)
            self._listed = ids.copy()
        return xy[self._rows]

    def velocities(self) -> NDArray[np.float64]:
        return np.array([tuple(b.velocity) for b in self.bodies], dtype=float).reshape(-1, 2)


# --- the liquid ---------------------------------------------------------------------------------

def _radii(n: int, seed: int) -> NDArray[np.float64]:
    rng = np.random.default_rng(seed)
    return RADIUS * (1.0 + POLYDISPERSITY * rng.uniform(-1.0, 1.0, size=n))


def spawn_sites() -> NDArray[np.float64]:
    """Hexagonal grid of disc centres inside the upright bottle's straight body (world frame,
    mm), bottom row first, each row left to right. The spacing clears the largest disc.
    """
    d = 2.0 * RADIUS * (1.0 + POLYDISPERSITY) + COLLISION_SLOP
    x_max = BODY_HALF_WIDTH - WALL_RADIUS - RADIUS * (1.0 + POLYDISPERSITY) - COLLISION_SLOP
    y0 = -BOTTLE_DEPTH + WALL_RADIUS + RADIUS * (1.0 + POLYDISPERSITY) + COLLISION_SLOP
    y1 = -NECK_LENGTH - SHOULDER_HEIGHT - RADIUS * (1.0 + POLYDISPERSITY)
    sites = []
    row = 0
    y = y0
    while y <= y1:
        x = -x_max + (d / 2.0 if row % 2 else 0.0)
        while x <= x_max + 1e-9:
            sites.append((PIVOT[0] + x, PIVOT[1] + y))
            x += d
        row += 1
        y += d * math.sqrt(3.0) / 2.0
    return np.array(sites)


@functools.lru_cache(maxsize=16)
def settled_liquid(n_particles: int, seed: int = 0) -> Liquid:
    """``n_particles`` discs (radii drawn from ``seed``) spawned in the upright bottle and settled
    for :data:`SETTLE_TIME`. Cached per process: a trial restores a copy, so the cache changes
    nothing but the time taken.

    Raises InvalidInputError for a count outside 1..MAX_PARTICLES and NumericalError if a disc
    is not inside the bottle after settling (a broken scene, never expected).
    """
    n = int(n_particles)
    if not 1 <= n <= MAX_PARTICLES:
        raise InvalidInputError(
            f"n_particles = {n_particles} must be between 1 and {MAX_PARTICLES} "
            f"(the bottle holds at most {MAX_PARTICLES * PARTICLE_ML / 1000:g} l)")
    sites = spawn_sites()
    assert len(sites) >= MAX_PARTICLES, "the spawn grid must hold a full bottle"
    radii = _radii(n, seed)
    scene = _Scene(radii, sites[:n])
    for _ in range(round(SETTLE_TIME / DT)):
        scene.space.step(DT)
    pos = scene.positions()
    region = classify(pos, 0.0)
    if not (region == IN_BOTTLE).all():
        bad = int(np.flatnonzero(region != IN_BOTTLE)[0])
        raise NumericalError(
            f"settling {n} discs (seed {seed}) left disc {bad} at {pos[bad].tolist()} mm, "
            "outside the bottle")
    vel = scene.velocities()
    for arr in (radii, pos, vel):
        arr.setflags(write=False)
    return Liquid(seed=int(seed), radii=radii, positions=pos, velocities=vel)


# --- one pour -----------------------------------------------------------------------------------

def simulate_pour(
    t: NDArray[np.float64],
    tilt: NDArray[np.float64],
    liquid: Liquid,
    *,
    hold: float = HOLD_TIME,
    sample_period: float = 0.02,
    should_stop: Callable[[], bool] | None = None,
) -> PourResult:
    """Pours ``liquid`` by following the tilt profile ``tilt(t)`` (rad; positive turns the mouth
    toward the glass), then holds the last tilt for ``hold`` s and counts.

    The profile's time base need not match the physics step: the commanded tilt is interpolated
    linearly at every physics time ``t[0] + k DT`` (which is why trajectories may be sampled at
    any rate). The caller validates the profile (limits, finiteness); this function trusts it.
    """
    t = np.asarray(t, dtype=float)
    theta = np.asarray(tilt, dtype=float)
    n_move = max(1, math.ceil((t[-1] - t[0]) / DT - 1e-9))
    n_steps = n_move + round(hold / DT)
    times = np.arange(n_steps + 1) * DT
    command = np.interp(t[0] + times, t, theta)  # holds the last value beyond the profile
    sample_every = max(1, round(sample_period / DT))

    scene = _Scene(liquid.radii, liquid.positions, liquid.velocities)
    bottle, space = scene.bottle, scene.space
    executed = np.empty(n_steps + 1)
    executed[0] = -bottle.angle
    sample_t = [0.0]
    counts = [int(in_glass(scene.positions()).sum())]
    interrupted = False
    k = 0
    for k in range(1, n_steps + 1):
        # Drive through velocity (docs/method.md §9.3): reach the commanded angle at the end of the step.
        bottle.angular_velocity = (-command[k] - bottle.angle) / DT
        space.step(DT)
        executed[k] = -bottle.angle
        if k % sample_every == 0 or k == n_steps:
            sample_t.append(k * DT)
            counts.append(int(in_glass(scene.positions()).sum()))
        if should_stop is not None and k % STOP_CHECK_EVERY == 0 and should_stop():
            interrupted = True
            break
    bottle.angular_velocity = 0.0
    pos = scene.positions()
    final_tilt = float(executed[k])
    region = classify(pos, final_tilt)
    n = liquid.n
    n_bottle = int((region == IN_BOTTLE).sum())
    n_glass = int(in_glass(pos).sum())
    return PourResult(
        times=times[: k + 1], tilt=executed[: k + 1],
        sample_times=np.array(sample_t), glass_counts=np.array(counts, dtype=np.int64),
        region=region, positions=pos, n_particles=n,
        n_bottle=n_bottle, n_glass=n_glass, n_spilled=n - n_bottle - n_glass,
        interrupted=interrupted,
    )
