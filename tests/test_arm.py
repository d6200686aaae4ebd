"""The arm scene's pieces: the model's kinematics against the iiwa data sheet, the IK, the
liquid's geometry and counting. Fast: no pour here (see test_arm_pouring.py).
"""

import math

import mujoco
import numpy as np
import pytest

from dmprs.sim import arm_model as am
from dmprs.sim import arm_scene, granular
from dmprs.sim.arm_ik import ArmKinematics


@pytest.fixture(scope="module")
def kin():
    return ArmKinematics()


def test_zero_configuration_matches_the_data_sheet(kin):
    # KUKA: base to A2 360 mm, A2 to A4 420 mm, A4 to A6 400 mm, A6 to flange 126 mm: straight
    # up, the flange is 1.306 m above the base; the bottle's axis is BRACKET in front of the
    # flange face, its mouth half the bottle's length along the flange's -x.
    pose = kin.pose(np.zeros(7))
    flange = 0.360 + 0.420 + 0.400 + 0.126
    np.testing.assert_allclose(pose[:3], [-am.BOTTLE_LENGTH / 2, 0.0, flange + am.BRACKET], atol=1e-12)
    # A1 turns everything about the vertical axis by its angle
    rotated = kin.pose(np.array([math.pi / 2, 0, 0, 0, 0, 0, 0]))
    np.testing.assert_allclose(rotated[:3], [0.0, -am.BOTTLE_LENGTH / 2, flange + am.BRACKET], atol=1e-12)


def test_limits_are_the_data_sheets():
    m = am.load()
    np.testing.assert_allclose(np.degrees(m.jnt_range[:7, 1]), [170, 120, 170, 120, 170, 120, 175])
    np.testing.assert_allclose(np.degrees(am.VELOCITY_LIMITS), [85, 85, 100, 75, 130, 135, 135])
    np.testing.assert_allclose(m.actuator_forcerange[:, 1], [320, 320, 176, 176, 110, 40, 40])
    # the links' masses as modelled (the bottle and bracket ride on link 7)
    masses = [m.body(f"link{i}").mass[0] for i in range(1, 8)]
    np.testing.assert_allclose(masses[:6], am.LINK_MASSES[:6])


def test_ik_reaches_reachable_poses(kin):
    rng = np.random.default_rng(0)
    home = arm_scene.home_configuration()
    for _ in range(5):
        q_true = home + rng.uniform(-0.3, 0.3, size=7)
        target = kin.pose(q_true)
        q, pe, re = kin.solve(target, home)
        assert pe < 1e-4 and re < 1e-3
        reached = kin.pose(q)
        np.testing.assert_allclose(reached[:3], target[:3], atol=1e-4)
        # the same rotation (q and -q are one rotation)
        assert abs(abs(float(np.dot(reached[3:], target[3:]))) - 1) < 1e-6


def test_ik_refuses_unreachable_poses(kin):
    home = arm_scene.home_configuration()
    far = np.array([1.5, 0.0, 0.4, 1.0, 0.0, 0.0, 0.0])  # 1.5 m away: the arm reaches ~0.82 m from A2
    _, pe, _ = kin.solve(far, home)
    assert pe > 0.3


def test_ik_tracks_a_pose_trajectory_and_keeps_the_joints_in_range(kin):
    home = arm_scene.home_configuration()
    start = kin.pose(home)
    t = np.linspace(0, 1, 501)
    s = 10 * t**3 - 15 * t**4 + 6 * t**5
    poses = np.tile(start, (len(t), 1))
    poses[:, 1] -= 0.15 * s
    angle = 1.5 * s  # tilt about the world's x axis, composed with the start orientation
    rot = np.stack([np.cos(angle / 2), np.sin(angle / 2), 0 * t, 0 * t], axis=1)
    for k in range(len(t)):
        out = np.zeros(4)
        mujoco.mju_mulQuat(out, rot[k], start[3:])
        poses[k, 3:] = out
    ik = kin.track(t, poses, home)
    assert ik.position_error.max() < 1e-4 and ik.orientation_error.max() < 1e-3
    assert (np.abs(ik.q) < np.asarray(am.JOINT_LIMITS)).all()
    # a smooth joint path: no jumps between samples
    assert np.abs(np.diff(ik.q, axis=0)).max() < 0.02


def test_spawn_sites_fit_and_do_not_overlap():
    sites = granular.spawn_sites(granular.MAX_PARTICLES, seed=3)
    assert len(sites) == granular.MAX_PARTICLES
    from scipy.spatial.distance import pdist

    assert pdist(sites).min() >= 2 * am.PARTICLE_RADIUS
    r = np.hypot(sites[:, 0], sites[:, 1])
    assert (r + am.PARTICLE_RADIUS <= granular.cavity_radius(sites[:, 2])).all()
    assert (sites[:, 2] - am.PARTICLE_RADIUS >= -am.BOTTLE_LENGTH).all()
    assert not np.array_equal(sites, granular.spawn_sites(granular.MAX_PARTICLES, seed=4))
    with pytest.raises(ValueError):
        granular.spawn_sites(granular.MAX_PARTICLES + 1, seed=0)


def test_classify_hand_placed_spheres():
    # A bottle tilted by 90 deg about the world's x axis (mouth toward -y) at (0.75, 0, 0.3).
    c, s = math.cos(math.pi / 2), math.sin(math.pi / 2)
    mat = np.array([[1, 0, 0], [0, c, -s], [0, s, c]])
    pos = np.array([0.75, 0.0, 0.3])
    axis = mat[:, 2]  # out of the mouth: -y
    gx, gy = am.GLASS_CENTER
    points = np.array([
        pos - 0.1 * axis,                                  # 10 cm inside along the axis: bottle
        pos + 0.01 * axis,                                 # just outside the mouth: spilled
        pos - 0.1 * axis + [0, 0, am.BOTTLE_RADIUS + 0.01],  # beside the body: spilled
        [gx, gy, 0.03],                                    # in the glass
        [gx + am.GLASS_RADIUS + 0.01, gy, 0.03],           # beside the glass: spilled
        [gx, gy, am.GLASS_HEIGHT + 0.01],                  # above the rim: spilled
        [gx, gy, am.FLOOR_Z],                              # on the floor: spilled
    ])
    region = granular.classify(points, pos, mat)
    G, B, S = granular.IN_GLASS, granular.IN_BOTTLE, granular.SPILLED
    assert region.tolist() == [B, S, S, G, S, S, S]


def test_glass_geometry_matches_the_counting_region():
    # The counting region's radius is the glass's inner radius as built: every wall stave's inner
    # face is GLASS_RADIUS from the glass's axis (independent of granular.in_glass).
    m = am.load()
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    gx, gy = am.GLASS_CENTER
    staves = [g for g in range(m.ngeom) if m.geom(g).name.startswith("glass") and m.geom(g).name[5:].isdigit()]
    assert len(staves) == am.STAVES
    for g in staves:
        centre = d.geom_xpos[g]
        normal = d.geom_xmat[g].reshape(3, 3)[:, 0]
        inner_face = centre - m.geom_size[g][0] * normal
        assert math.hypot(inner_face[0] - gx, inner_face[1] - gy) == pytest.approx(am.GLASS_RADIUS, abs=1e-9)


def test_sphere_radii_are_polydisperse_and_seeded():
    r = granular.radii(500, seed=0)
    assert np.array_equal(r, granular.radii(500, seed=0))
    assert not np.array_equal(r, granular.radii(500, seed=1))
    assert r.min() >= am.PARTICLE_RADIUS * (1 - am.POLYDISPERSITY)
    assert r.max() <= am.PARTICLE_RADIUS * (1 + am.POLYDISPERSITY)
    m = am.load(granular.spawn_sites(5, 0), particle_radii=r[:5])
    sizes = [m.geom_size[m.body(f"p{i}").geomadr[0]][0] for i in range(5)]
    np.testing.assert_allclose(sizes, r[:5])
