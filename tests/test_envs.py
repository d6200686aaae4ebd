"""The Gymnasium environments: Gymnasium's own checker, determinism, and each step against the
task pipeline run by hand.
"""

from __future__ import annotations

import contextlib
import subprocess
import sys
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import dmprs.envs
from dmprs.errors import InvalidInputError

# Small bottles keep the demonstrations' calibration to a few seconds (the defaults are the paper's).
SMALL_POURING = {"target_volume": 0.04, "demo_volumes": (0.08, 0.16), "volume_range": (0.08, 0.16)}
KWARGS = {"dmprs/MatchboxFlip-v0": {}, "dmprs/MatchboxFlipWeights-v0": {},
          "dmprs/Pouring-v0": SMALL_POURING, "dmprs/PouringWeights-v0": SMALL_POURING,
          "dmprs/ArmThrowing-v0": {}, "dmprs/ArmThrowingWeights-v0": {}, "dmprs/ArmPouring-v0": {},
          "dmprs/ArmJuggling-v0": {}}


@contextlib.contextmanager
def quiet_checker():
    """The matchbox has one context (the desired angle pi/2): its observation box is a point,
    which Gymnasium's checkers note; query actions are in task units, not normalized, also noted.
    """
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*maximum and minimum values are equal")
        warnings.filterwarnings("ignore", message=".*symmetric and normalized space")
        yield


@pytest.fixture(scope="module")
def envs(calibration_cache):
    with quiet_checker():
        made = {i: gym.make(i, **({"cache_dir": calibration_cache} if i == "dmprs/ArmPouring-v0" else {}), **kw)
                for i, kw in KWARGS.items()}
    yield made
    for e in made.values():
        e.close()


@pytest.mark.parametrize("env_id", dmprs.envs.ENV_IDS)
def test_gymnasium_check_env_passes(envs, env_id):
    with quiet_checker():
        check_env(envs[env_id].unwrapped)


@pytest.mark.parametrize("env_id", dmprs.envs.ENV_IDS)
def test_one_step_episodes_are_deterministic_under_seeded_reset(envs, env_id):
    env = envs[env_id]
    action = env.action_space.sample() * 0 + (env.action_space.low + env.action_space.high) / 2
    runs = []
    for _ in range(2):
        obs, _ = env.reset(seed=7)
        runs.append((obs, *env.step(action)))
    (o1, s1, r1, term1, trunc1, i1), (o2, s2, r2, *_rest, i2) = runs
    assert np.array_equal(o1, o2) and np.array_equal(s1, s2) and r1 == r2 and term1 and not trunc1
    assert i1["status"] == i2["status"] and np.array_equal(i1["eps"], i2["eps"])
    assert env.observation_space.contains(o1)


def test_pouring_contexts_are_drawn_from_the_seed(envs):
    env = envs["dmprs/Pouring-v0"]
    volumes = [float(env.reset(seed=s)[0][0]) for s in range(4)]
    assert len(set(volumes)) == 4 and all(0.08 <= v <= 0.16 for v in volumes)
    assert float(env.reset(seed=2)[0][0]) == volumes[2]


def test_steps_match_the_task_pipeline_by_hand(envs):
    env = envs["dmprs/MatchboxFlip-v0"]
    scenario = env.unwrapped.scenario
    task, gen = scenario.make_task(np.array([np.pi / 2])), scenario.generalizer
    for q in (1.2, 1.9, 2.6):
        with task.adapter:
            task.adapter.reset(seed=0)
            outcome = task.adapter.execute(task.trajectory(gen.predict([q])))
        want = -abs(float(task.error([np.pi / 2], outcome)[0]))
        env.reset(seed=0)
        _, reward, _, _, info = env.step(np.array([q]))
        assert reward == want and info["regime"] == outcome.signals["regime"]
    # weight action 0 is the generalizer's DMP at the desired query: the same strike
    weights = envs["dmprs/MatchboxFlipWeights-v0"]
    weights.reset(seed=0)
    _, r_w, _, _, info_w = weights.step(np.zeros(weights.action_space.shape))
    env.reset(seed=0)
    _, r_q, _, _, info_q = env.step(np.array([np.pi / 2]))
    assert r_w == r_q and info_w["outcome_angle"] == info_q["outcome_angle"]


def test_bad_actions_and_order(envs):
    env = envs["dmprs/MatchboxFlip-v0"].unwrapped
    env.reset(seed=0)
    with pytest.raises(InvalidInputError, match="not finite"):
        env.step(np.array([np.nan]))
    _, _, _, _, info = env.step(np.array([100.0]))  # clipped to the demonstrations' span
    assert info["clipped"] and info["query"][0] == env.action_space.high[0]
    fresh = dmprs.envs.make_matchbox()
    with pytest.raises(dmprs.envs.ResetNeeded, match="before reset"):
        fresh.step(np.array([1.5]))
    with pytest.raises(InvalidInputError, match="action = 'torques'"):
        dmprs.envs.make_matchbox(action="torques")


def test_registration_is_explicit():
    code = ("import gymnasium as gym, dmprs; assert 'dmprs/MatchboxFlip-v0' not in gym.registry; "
            "env = gym.make('dmprs.envs:dmprs/MatchboxFlip-v0'); print(env.spec.id)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "dmprs/MatchboxFlip-v0"


@pytest.fixture(scope="module")
def matchbox():
    return dmprs.envs.make_matchbox()


@pytest.mark.parametrize(("action", "why"), [
    (np.array([1.5 + 0j]), "dtype complex128"), (1.5 + 0j, "dtype complex128"),
    (np.array([[1.5]]), r"shape \(1, 1\)"), (np.array(1.5), r"shape \(\)"), ([1.5, 1.6], r"shape \(2,\)"),
    ("1.5", "not an array of numbers"), (None, "not an array of numbers"), (b"x", "not an array of numbers"),
    (np.array([1.5], dtype=object), "dtype object"), (np.array([True]), "dtype bool"), ([[1.0], [2.0, 3.0]], "not an array"),
    ([2**70], "dtype object"), (np.array([np.inf]), "not finite"), ([np.nan], "not finite"),
])
def test_an_action_of_the_wrong_type_or_shape_is_refused_naming_the_space(matchbox, action, why):
    matchbox.reset(seed=0)
    with pytest.raises(InvalidInputError, match=rf"the action = .*{why}.*; the space is Box\(") as info:
        matchbox.step(action)
    assert isinstance(info.value, ValueError)
    matchbox.step(np.array([1.5]))  # a refused action is no step: the episode is still open


def test_a_step_after_the_episode_ended_needs_a_reset(matchbox):
    matchbox.reset(seed=0)
    *_, terminated, truncated, _ = matchbox.step(np.array([1.5]))
    assert terminated and not truncated
    with pytest.raises(dmprs.envs.ResetNeeded, match="after the episode ended") as info:
        matchbox.step(np.array([1.5]))
    assert isinstance(info.value, gym.error.ResetNeeded) and isinstance(info.value, dmprs.DmprsError)
    matchbox.reset()
    matchbox.step(np.array([1.5]))


@pytest.mark.parametrize(("seed", "options", "why"), [
    (-1, None, "seed = -1"), (1.5, None, "seed = 1.5"), ("3", None, "seed = '3'"), (True, None, "seed = True"),
    (0, {"contxt": [1.0]}, "unknown keys"), (0, [1], "options = "), (0, {"context": [np.nan]}, "not finite"),
    (0, {"context": [0.0]}, "outside the space"), (0, {"context": "a"}, "not an array"),
])
def test_bad_seeds_and_options_are_refused(matchbox, seed, options, why):
    with pytest.raises(InvalidInputError, match=why):
        matchbox.reset(seed=seed, options=options)


def test_a_seeded_episode_is_reproducible_bit_for_bit():
    env = dmprs.envs.make_pouring(**SMALL_POURING)
    runs = []
    for _ in range(2):
        obs, _ = env.reset(seed=np.int64(11))
        runs.append((obs.tobytes(), *env.step(np.array([0.12]))[1:4]))
    assert runs[0] == runs[1]
