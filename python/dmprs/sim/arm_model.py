"""The MJCF model of the arm-pouring scene, written by the project (no meshes, nothing downloaded):
a 7-DOF arm with the published kinematics of the KUKA LBR iiwa 14 R820, a bottle rigidly held at
its flange, a table, a glass and (optionally) a granular "liquid" of 2 ml spheres.

Every number's source is in the comment beside it; docs/arm.md collects them. Lengths are m,
masses kg, angles rad, SI throughout (MuJoCo has no unit system of its own).

Frames. The world's z is up; the arm's base stands on the table top (z = 0) at the origin. In the
zero configuration the arm is straight up and the joint axes are, in world coordinates,
``+z, +y, +z, -y, +z, +y, +z`` (the iiwa convention, e.g. Drake's ``iiwa14_no_collision.sdf``).
The bottle body's origin is the **mouth centre** and its z axis points out of the mouth, so the
"bottle pose" a Cartesian trajectory commands is the mouth's pose and a pure rotation of it tilts
the bottle about its mouth. The bottle is fixed to link 7 so that its axis is perpendicular to
the flange axis: turning A7 tilts the bottle, as a wrist pours.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs.errors import NumericalError

# --- the arm: KUKA LBR iiwa 14 R820 ------------------------------------------------------------
#: Distances between consecutive joint frames along the arm in the zero configuration (m):
#: base -> A1, A1 -> A2, ..., A7 -> flange. KUKA's data sheet gives 360 mm (base to A2),
#: 420 mm (A2 to A4), 400 mm (A4 to A6) and 126 mm (A6 to flange); the split at A1, A3, A5, A7 is
#: that of Drake's iiwa14 model (0.1575 + 0.2025, 0.2045 + 0.2155, 0.1845 + 0.2155, 0.081 + 0.045).
LINK_OFFSETS = (0.1575, 0.2025, 0.2045, 0.2155, 0.1845, 0.2155, 0.081, 0.045)
#: Joint axes in the zero configuration (world frame), A1..A7 (iiwa convention, see above).
JOINT_AXES = ((0, 0, 1), (0, 1, 0), (0, 0, 1), (0, -1, 0), (0, 0, 1), (0, 1, 0), (0, 0, 1))
#: Joint position limits (rad): +-170, 120, 170, 120, 170, 120, 175 deg (KUKA LBR iiwa data sheet).
JOINT_LIMITS = tuple(math.radians(d) for d in (170, 120, 170, 120, 170, 120, 175))
#: Joint velocity limits (rad/s): 85, 85, 100, 75, 130, 135, 135 deg/s (KUKA LBR iiwa brochure,
#: "axis data" table, iiwa 14 R820; the same values are in Drake's iiwa14 model).
VELOCITY_LIMITS = tuple(math.radians(d) for d in (85, 85, 100, 75, 130, 135, 135))
#: Maximum joint torques (N m): 320, 320, 176, 176, 110, 40, 40 (same table).
TORQUE_LIMITS = (320.0, 320.0, 176.0, 176.0, 110.0, 40.0, 40.0)
#: Link masses (kg), links 1..7, from Drake's iiwa14 model (identified by its authors); with the
#: 5 kg base they total 30.6 kg against the data sheet's 29.5 kg. Inertias are MuJoCo's for a
#: uniform capsule of the link's size and mass (an approximation: the real links are not uniform).
LINK_MASSES = (5.76, 6.35, 3.5, 3.5, 3.5, 1.8, 1.2)
#: Capsule radii of links 1..7 (m): the iiwa's housings are 0.12-0.14 m across at the shoulder and
#: ~0.10 m at the wrist (data-sheet drawing); these are the collision shapes too.
LINK_RADII = (0.07, 0.07, 0.065, 0.065, 0.06, 0.055, 0.045)
JOINT_NAMES = tuple(f"a{i}" for i in range(1, 8))

# --- the servo: a joint PD at 1 kHz ------------------------------------------------------------
#: s; the physics step and the servo rate (the iiwa's FRI interface runs at 1 kHz)
TIMESTEP = 0.001
#: Position gains (N m/rad) and velocity gains (N m s/rad) of the joint PD, chosen by us (a real
#: iiwa's are not published): stiff enough that a full bottle (1.5 kg at ~0.15 m from A6) sags
#: ~1 mrad, kv ~ 2 sqrt(kp I) for damping ratio ~1 at the link inertias I seen by each joint; the
#: velocity term is integrated implicitly (MuJoCo's implicitfast), so these gains are stable at
#: 1 ms. Gravity is compensated exactly (MuJoCo's ``gravcomp``), as the iiwa's controller does.
KP = (10000.0, 10000.0, 5000.0, 5000.0, 3000.0, 2000.0, 2000.0)
KV = (300.0, 300.0, 120.0, 120.0, 35.0, 20.0, 12.0)

# --- the bottle, held at the flange -------------------------------------------------------------
#: inner radius of the bottle's body (m): 150 mm across, a squat 2.6-litre bottle (a tall one
#: would pour from too high: the upright bottle must pass over the glass's rim)
BOTTLE_RADIUS = 0.075
#: height of the straight body (m)
BOTTLE_BODY = 0.15
#: height of the conical shoulder from the body to the neck (m)
BOTTLE_SHOULDER = 0.03
#: neck: inner radius (m; the mouth is 56 mm across, 3.6 sphere diameters, so the spheres do not
#: jam in it and the flow is fast enough to finish while the tilt is held) and length (m)
NECK_RADIUS = 0.028
NECK_LENGTH = 0.02
#: mouth to the bottom's inner face (m)
BOTTLE_LENGTH = NECK_LENGTH + BOTTLE_SHOULDER + BOTTLE_BODY
#: wall half-thickness (m); 3 mm keeps a sphere that moves 3 mm per step from tunnelling
WALL = 0.003
#: staves that approximate the round walls (a 16-gon's inner radius is within 2 % of the circle)
STAVES = 16
#: empty bottle (kg): a glass bottle of this size weighs ~0.5 kg
BOTTLE_MASS = 0.5
#: distance from the flange face to the bottle's axis along the flange axis (m): the outer radius
#: plus a 5 mm bracket
BRACKET = BOTTLE_RADIUS + 2 * WALL + 0.005

# --- table and glass ------------------------------------------------------------------------------
#: table top is z = 0; half extents (m) and centre (x, y)
TABLE_HALF = (0.6, 0.6, 0.02)
TABLE_CENTER = (0.35, 0.0)
#: the glass: inner radius, height, centre on the table (m); a wide beaker, 0.2 l fills 40 mm
GLASS_RADIUS = 0.06
GLASS_HEIGHT = 0.10
GLASS_CENTER = (0.75, -0.22)
#: a floor 0.75 m below the table top catches what falls off it
FLOOR_Z = -0.75

# --- the liquid -----------------------------------------------------------------------------------
#: litres per sphere: 2 ml, as in the 2-D scene (docs/method.md §9.3)
PARTICLE_VOLUME = 0.002
#: the radius of a 2 ml sphere (m): (3 V / 4 pi)^(1/3) = 7.82 mm
PARTICLE_RADIUS = (3 * PARTICLE_VOLUME * 1e-3 / (4 * math.pi)) ** (1 / 3)
#: the mass of 2 ml of water (kg)
PARTICLE_MASS = 0.002
#: sphere radii are PARTICLE_RADIUS (1 +- POLYDISPERSITY), uniform, drawn from the liquid's seed,
#: as the 2-D scene's discs: equal spheres settle into a crystal, which a liquid is not. (It does
#: not make the outcome less noisy: docs/arm.md.) Each sphere counts as 2 ml and weighs 2 g.
POLYDISPERSITY = 0.1

# --- contact and solver (measured, see docs/arm.md) --------------------------------------------
#: frictionless contacts (condim 1): an inviscid liquid, like the 2-D scene's frictionless discs;
#: also the cheapest contact (one constraint row instead of 3 or 4)
CONDIM = 1
SOLVER = "CG"
ITERATIONS = 10
SOLVER_TOLERANCE = 1e-8

#: contact stiffness: the time constant (s) of MuJoCo's soft contacts, 2 timesteps (the smallest
#: MuJoCo recommends), critically damped; 5 ms let falling spheres sink up to 5.9 mm into each
#: other, 2 ms 1.4 mm (measured over a pour, docs/arm.md)
SOLREF_TIME = 2 * TIMESTEP

#: collision groups (MuJoCo's contype/conaffinity bit masks): bit 0 the liquid and the containers
#: (which all collide with each other), bit 1 the arm's links, which collide with the table and
#: the glass only.
_LIQUID, _ARM = 1, 2


def _fmt(v: Sequence[float] | NDArray[np.float64]) -> str:
    return " ".join(f"{float(x):.9g}" for x in v)


def wall(name: str, r0: float, z0: float, r1: float, z1: float, *, n: int = STAVES,
          rgba: str = "0.7 0.85 1 0.35", cls: str = "container") -> list[str]:
    """Box staves forming the surface of revolution of the segment (r0, z0)-(r1, z1) of a
    container's inner wall (a cylinder when r0 = r1, a cone frustum otherwise), in the frame of
    the body they are added to (axis = z). Each stave's inner face lies on the segment.
    """
    dr, dz = r1 - r0, z1 - z0
    length = math.hypot(dr, dz)
    nr, nz = dz / length, -dr / length  # outward normal in the (radial, z) plane
    r_out = max(r0, r1) + 2 * WALL
    half_width = r_out * math.tan(math.pi / n) * 1.02  # neighbours overlap a little: no gaps
    geoms = []
    for i in range(n):
        phi = 2 * math.pi * i / n
        er = np.array([math.cos(phi), math.sin(phi), 0.0])
        ephi = np.array([-math.sin(phi), math.cos(phi), 0.0])
        ez = np.array([0.0, 0.0, 1.0])
        centre = (0.5 * (r0 + r1) + WALL * nr) * er + (0.5 * (z0 + z1) + WALL * nz) * ez
        x_axis = nr * er + nz * ez
        geoms.append(
            f'<geom name="{name}{i}" class="{cls}" type="box" size="{WALL} {half_width:.9g} '
            f'{length / 2:.9g}" pos="{_fmt(centre)}" xyaxes="{_fmt(x_axis)} {_fmt(ephi)}" rgba="{rgba}"/>')
    return geoms


def bottle_geoms() -> list[str]:
    """The bottle in its own frame: origin at the mouth centre, z out of the mouth."""
    z_neck = -NECK_LENGTH
    z_shoulder = z_neck - BOTTLE_SHOULDER
    z_bottom = -BOTTLE_LENGTH
    geoms = wall("neck", NECK_RADIUS, z_neck, NECK_RADIUS, 0.0, n=12)
    geoms += wall("shoulder", BOTTLE_RADIUS, z_shoulder, NECK_RADIUS, z_neck)
    geoms += wall("body", BOTTLE_RADIUS, z_bottom, BOTTLE_RADIUS, z_shoulder)
    geoms.append(f'<geom name="bottom" class="container" type="cylinder" '
                 f'size="{BOTTLE_RADIUS + 2 * WALL:.9g} {WALL}" pos="0 0 {z_bottom - WALL:.9g}" '
                 'rgba="0.7 0.85 1 0.35"/>')
    return geoms


def glass_geoms() -> list[str]:
    """The glass in the world frame, standing on the table at GLASS_CENTER."""
    x, y = GLASS_CENTER
    inner = wall("glass", GLASS_RADIUS, 2 * WALL, GLASS_RADIUS, GLASS_HEIGHT, rgba="0.6 0.8 0.6 0.4",
                  cls="glassware")
    body = "\n".join(inner)
    return [f'<body name="glass" pos="{x} {y} 0">',
            (f'<geom name="glass_bottom" class="glassware" type="cylinder" '
            f'size="{GLASS_RADIUS + 2 * WALL:.9g} {WALL}" pos="0 0 {WALL}" rgba="0.6 0.8 0.6 0.4"/>'),
            body, "</body>"]


def arm_bodies(tool: list[str]) -> str:
    """Links 1..7 as nested bodies, each a capsule from its joint to the next, with the ``tool``'s
    geoms (the bottle, or the throwing scene's cup) in a body held at link 7's flange.
    """
    open_tags, z = [], 0.0
    for i in range(7):
        z_joint = sum(LINK_OFFSETS[: i + 1])
        length = LINK_OFFSETS[i + 1]
        pos = z_joint - z
        z = z_joint
        r = LINK_RADII[i]
        shape = (f'<geom name="link{i + 1}" class="link" type="capsule" size="{r}" '
                 f'fromto="0 0 0 0 0 {length:.9g}" mass="{LINK_MASSES[i]}"/>')
        if i == 6:  # link 7 ends at the flange: a short cylinder, then the bottle's bracket
            shape = (f'<geom name="link7" class="link" type="cylinder" size="{r} {length / 2:.9g}" '
                     f'pos="0 0 {length / 2:.9g}" mass="{LINK_MASSES[i]}"/>')
        open_tags.append(
            f'<body name="link{i + 1}" pos="0 0 {pos:.9g}" gravcomp="1">\n'
            f'<joint name="{JOINT_NAMES[i]}" axis="{_fmt(JOINT_AXES[i])}" '
            f'range="{-JOINT_LIMITS[i]:.9g} {JOINT_LIMITS[i]:.9g}"/>\n{shape}')
    flange = LINK_OFFSETS[7]
    # The bottle's axis is perpendicular to the flange axis (the flange's -x), BRACKET in front
    # of the flange; the mouth is BOTTLE_LENGTH / 2 from the bottle's middle. Its frame: z = -x of
    # the flange (out of the mouth), x = the flange's z, y = the flange's y (a -90 deg turn about y).
    mid = BOTTLE_LENGTH / 2
    bracket = (f'<geom name="bracket" class="link" type="box" size="0.02 0.02 {BRACKET / 2:.9g}" '
               f'pos="0 0 {flange + BRACKET / 2:.9g}" mass="0.2"/>')
    bottle_body = (f'<body name="bottle" pos="{-mid:.9g} 0 {flange + BRACKET:.9g}" '
                   f'xyaxes="0 0 1 0 1 0" gravcomp="1">\n'
                   f'<site name="mouth" pos="0 0 0" size="0.005"/>\n'
                   f'<geom name="bottle_mass" type="sphere" size="0.01" pos="0 0 {-mid:.9g}" '
                   f'mass="{BOTTLE_MASS}" contype="0" conaffinity="0" group="3"/>\n'
                   + "\n".join(tool) + "\n</body>")
    return "\n".join(open_tags) + "\n" + bracket + "\n" + bottle_body + "\n" + "</body>\n" * 7


def particle_bodies(positions: NDArray[np.float64], radii: NDArray[np.float64] | None = None) -> str:
    """One free sphere per row of ``positions`` (m, world frame), of ``radii`` (m; default
    PARTICLE_RADIUS).
    """
    p = np.asarray(positions, dtype=float)
    r = np.full(len(p), PARTICLE_RADIUS) if radii is None else np.asarray(radii, dtype=float)
    return "\n".join(
        f'<body name="p{i}" pos="{_fmt(x)}"><freejoint/><geom class="particle" size="{ri:.9g}"/></body>'
        for i, (x, ri) in enumerate(zip(p, r, strict=True)))


def header(model: str, *, solver: str = SOLVER, iterations: int = ITERATIONS, tolerance: float = SOLVER_TOLERANCE,
           condim: int = CONDIM, classes: Sequence[str] = (), timestep: float = TIMESTEP) -> str:
    """The MJCF of a scene with this arm up to its world body: the compiler, the physics options,
    the offscreen buffer and the default classes of the arm's links and of containers, then
    ``classes`` (more default classes, one MJCF line each). ``timestep``: the physics step (s),
    the servo's period unless a scene sub-steps its commands.
    """
    lines = [
        f'<mujoco model="{model}">',
        '<compiler angle="radian" autolimits="true"/>',
        f'<option timestep="{timestep:.17g}" integrator="implicitfast" solver="{solver}" iterations="{iterations}"',
        f'        tolerance="{tolerance}" cone="pyramidal"/>',
        '<visual><global offwidth="640" offheight="480"/></visual>',
        "<default>",
        f'  <geom condim="{condim}" solref="{SOLREF_TIME} 1"/>',
        f'  <default class="link"><geom contype="{_ARM}" conaffinity="0" rgba="0.9 0.9 0.9 1"/></default>',
        f'  <default class="container"><geom contype="{_LIQUID}" conaffinity="{_LIQUID}" mass="0"/></default>',
        *classes,
        "</default>",
    ]
    return "\n".join(lines)


def servo_actuators() -> str:
    """The arm's joint servos as MJCF position actuators: the PD gains and the torque limits."""
    return "\n".join(
        f'<position name="servo_{j}" joint="{j}" kp="{kp}" kv="{kv}" '
        f'forcerange="{-tau} {tau}" forcelimited="true"/>'
        for j, kp, kv, tau in zip(JOINT_NAMES, KP, KV, TORQUE_LIMITS, strict=True))


#: The end of a scene with this arm: its servos.
FOOTER = f"""<actuator>
{servo_actuators()}
</actuator>
</mujoco>
"""


def scene_xml(particle_positions: NDArray[np.float64] | None = None, *,
              particle_radii: NDArray[np.float64] | None = None, solver: str = SOLVER,
              iterations: int = ITERATIONS, condim: int = CONDIM, tolerance: float = SOLVER_TOLERANCE,
              with_glass: bool = True) -> str:
    """The whole scene as an MJCF string: table, floor, arm with bottle, glass and one sphere per
    row of ``particle_positions`` with ``particle_radii`` (none: the kinematic model used by the IK
    and the checks).
    """
    parts = np.zeros((0, 3)) if particle_positions is None else np.asarray(particle_positions, dtype=float)
    tx, ty = TABLE_CENTER
    glass = "\n".join(glass_geoms()) if with_glass else ""
    classes = (
        f'  <default class="glassware"><geom contype="{_LIQUID}" conaffinity="{_LIQUID | _ARM}" mass="0"/></default>',
        (f'  <default class="particle"><geom type="sphere" size="{PARTICLE_RADIUS:.9g}" mass="{PARTICLE_MASS}"\n'
        f'      contype="{_LIQUID}" conaffinity="{_LIQUID}" rgba="0.2 0.4 0.9 1"/></default>'),
    )
    return f"""{header("dmprs arm pouring", solver=solver, iterations=iterations, tolerance=tolerance, condim=condim,
                   classes=classes)}
<worldbody>
<light pos="0.4 -0.6 2" dir="0 0.3 -1"/>
<geom name="floor" type="plane" size="3 3 0.1" pos="0 0 {FLOOR_Z}" contype="{_LIQUID}"
      conaffinity="{_LIQUID}" rgba="0.3 0.3 0.3 1"/>
<geom name="table" type="box" size="{_fmt(TABLE_HALF)}" pos="{tx} {ty} {-TABLE_HALF[2]}"
      contype="{_LIQUID}" conaffinity="{_LIQUID | _ARM}" rgba="0.55 0.4 0.3 1"/>
<geom name="base" type="cylinder" size="0.09 {LINK_OFFSETS[0] / 2:.9g}" pos="0 0 {LINK_OFFSETS[0] / 2:.9g}"
      contype="0" conaffinity="0" rgba="0.9 0.9 0.9 1"/>
{arm_bodies(bottle_geoms())}
{glass}
{particle_bodies(parts, particle_radii)}
</worldbody>
{FOOTER}"""


def load(particle_positions: NDArray[np.float64] | None = None, **options: Any) -> Any:
    """The compiled ``mujoco.MjModel`` of :func:`scene_xml`."""
    import mujoco

    return mujoco.MjModel.from_xml_string(scene_xml(particle_positions, **options))


#: MuJoCo's warnings that mean the state is no longer physical (on a bad qpos, qvel or qacc
#: MuJoCo resets the state and carries on, so the warning is the only trace)
WARNINGS = ("mjWARN_BADQPOS", "mjWARN_BADQVEL", "mjWARN_BADQACC", "mjWARN_BADCTRL", "mjWARN_CONTACTFULL",
            "mjWARN_CNSTRFULL", "mjWARN_INERTIA")


def check_health(mujoco: Any, data: Any, when: float) -> None:
    """Raises :class:`~dmprs.errors.NumericalError` if MuJoCo warned any of :data:`WARNINGS` or
    the state of a scene with this arm became non-finite (``when``: the time, s, for the message).
    """
    for name in WARNINGS:
        if data.warning[getattr(mujoco.mjtWarning, name)].number > 0:
            raise NumericalError(f"MuJoCo warned {name} at t = {when:.3f} s: the simulation diverged")
    if not (np.isfinite(data.qpos).all() and np.isfinite(data.qvel).all()):
        raise NumericalError(f"the simulation diverged: its state became non-finite at t = {when:.3f} s")
