"""The granular "liquid" of the arm-pouring scene, as geometry: where the 2 ml spheres are spawned
inside the bottle and which region (bottle, glass, spilled) each one is in. No physics here (see
:mod:`dmprs.sim.arm_scene`), so the counting can be tested against hand-placed spheres.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from dmprs.portable import arctan2, hypot, matvec_rows
from dmprs.sim import arm_model as am

#: region codes of :func:`classify`
IN_BOTTLE, IN_GLASS, SPILLED = 0, 1, 2
#: clearance between spawned spheres and from the walls (m)
SPAWN_GAP = 0.0004
#: the most spheres the bottle accepts (1.0 l): the spawn lattice holds 14 full layers below the
#: shoulder, and a full bottle must start with its surface below the neck
MAX_PARTICLES = 500


def radii(n: int, seed: int) -> NDArray[np.float64]:
    """The radii (m) of the ``n`` spheres of the liquid of ``seed``: PARTICLE_RADIUS
    (1 +- POLYDISPERSITY), uniform (a generator of its own, so the lattice's draws do not move).
    """
    rng = np.random.default_rng([seed, 1])
    return am.PARTICLE_RADIUS * (1 + am.POLYDISPERSITY * rng.uniform(-1, 1, size=n))


def cavity_radius(z: NDArray[np.float64]) -> NDArray[np.float64]:
    """The bottle's inner radius at height ``z`` of its own frame (mouth at 0, bottom at
    ``-BOTTLE_LENGTH``): the body, the conical shoulder, the neck.
    """
    z = np.asarray(z, dtype=float)
    z_neck = -am.NECK_LENGTH
    z_shoulder = z_neck - am.BOTTLE_SHOULDER
    cone = am.BOTTLE_RADIUS + (z - z_shoulder) / am.BOTTLE_SHOULDER * (am.NECK_RADIUS - am.BOTTLE_RADIUS)
    return np.where(z >= z_neck, am.NECK_RADIUS, np.where(z >= z_shoulder, cone, am.BOTTLE_RADIUS))


def spawn_sites(n: int, seed: int) -> NDArray[np.float64]:
    """Centres of ``n`` spheres in the upright bottle, in the bottle's frame (m): hexagonal
    layers in A/B stacking from the bottom up, each layer's points ordered by radius and angle;
    ``seed`` turns the lattice about the axis by a random angle and shifts it by a random
    sub-millimetre offset, so different seeds give different (settled) liquids.
    """
    if not 1 <= n <= MAX_PARTICLES:
        raise ValueError(f"n = {n} spheres: the bottle holds 1..{MAX_PARTICLES}")
    rng = np.random.default_rng(seed)
    r = am.PARTICLE_RADIUS * (1 + am.POLYDISPERSITY)  # room for the largest sphere
    d = 2 * r + SPAWN_GAP
    layer_height = d * math.sqrt(2.0 / 3.0)
    z = -am.BOTTLE_LENGTH + r + SPAWN_GAP
    sites: list[NDArray[np.float64]] = []
    count, layer = 0, 0
    angle = rng.uniform(0, 2 * math.pi)
    c, s = math.cos(angle), math.sin(angle)
    shift = rng.uniform(-0.5, 0.5, size=2) * SPAWN_GAP
    while count < n:
        limit = float(cavity_radius(np.array(z + r))) - r - SPAWN_GAP  # the layer's top must fit
        if limit <= 0 or z > -am.NECK_LENGTH:
            raise ValueError(f"{n} spheres do not fit in the bottle (only {count} do)")
        m = int(limit / d) + 2
        i, j = np.meshgrid(np.arange(-m, m + 1), np.arange(-m, m + 1))
        x = (i + 0.5 * (j % 2) + (layer % 2) / 2.0) * d
        y = (j + (layer % 2) / 3.0) * d * math.sqrt(3) / 2
        px, py = c * x - s * y + shift[0], s * x + c * y + shift[1]
        keep = hypot(px, py) <= limit
        pts = np.stack([px[keep], py[keep], np.full(int(keep.sum()), z)], axis=1)
        pts = pts[np.lexsort((arctan2(pts[:, 1], pts[:, 0]), hypot(pts[:, 0], pts[:, 1]).round(6)))]
        sites.append(pts[: n - count])
        count += len(sites[-1])
        z += layer_height
        layer += 1
    return np.concatenate(sites)


def in_glass(positions: NDArray[np.float64]) -> NDArray[np.bool_]:
    """Whether each sphere centre (n, 3; world, m) is inside the glass: within its inner radius,
    above its bottom and below its rim.
    """
    p = np.asarray(positions, dtype=float)
    gx, gy = am.GLASS_CENTER
    return ((hypot(p[:, 0] - gx, p[:, 1] - gy) < am.GLASS_RADIUS)
            & (p[:, 2] > 2 * am.WALL) & (p[:, 2] < am.GLASS_HEIGHT))


def classify(positions: NDArray[np.float64], bottle_pos: NDArray[np.float64],
             bottle_mat: NDArray[np.float64]) -> NDArray[np.int8]:
    """The region of each sphere centre (n, 3; world, m): inside the bottle's cavity (below the
    mouth plane, within the cavity radius), inside the glass (within its inner radius, above
    its bottom and below its rim), or spilled (anywhere else: on the table, on the floor, in
    flight, on a rim). The bottle is at ``bottle_pos`` with rotation ``bottle_mat`` (3, 3).
    """
    p = np.asarray(positions, dtype=float)
    local = matvec_rows(p - bottle_pos, np.asarray(bottle_mat).reshape(3, 3).T)  # R^T (p - pos)
    z = local[:, 2]
    in_bottle = (z <= 0) & (z >= -am.BOTTLE_LENGTH) & (hypot(local[:, 0], local[:, 1]) < cavity_radius(z))
    region = np.full(len(p), SPILLED, dtype=np.int8)
    region[in_glass(p)] = IN_GLASS
    region[in_bottle] = IN_BOTTLE
    return region
