"""Gymnasium environments for dmprs's tasks (``pip install "dmprs[gym]"``).

Importing this module registers them (importing ``dmprs`` does not import Gymnasium)::

    import gymnasium as gym
    import dmprs.envs                      # or gym.make("dmprs.envs:dmprs/Pouring-v0")
    env = gym.make("dmprs/MatchboxFlip-v0")

=============================== ====================================================
id                              action
=============================== ====================================================
``dmprs/MatchboxFlip-v0``       the query: outcome angle (rad) for the generalizer
``dmprs/MatchboxFlipWeights-v0`` the DMP weights (2 DOFs x 25 kernels), normalized
``dmprs/Pouring-v0``            the query: assumed bottle volume (l)
``dmprs/PouringWeights-v0``     the DMP weights (1 DOF x 40 kernels), normalized
``dmprs/ArmPouring-v0``         the query: assumed bottle volume (l), robot extra
``dmprs/ArmThrowing-v0``        the query: landing point (x, y in m), robot extra
``dmprs/ArmThrowingWeights-v0`` the DMP weights (7 DOFs x 30 kernels), normalized
``dmprs/ArmJuggling-v0``        the query: apex height (m), robot extra
=============================== ====================================================

Keyword arguments of ``gym.make`` go to the scenario (:func:`matchbox_scenario`,
:func:`pouring_scenario`, :func:`throwing_scenario`, :func:`arm_pouring_scenario`,
:func:`juggling_scenario`). The arm's pouring has no weight-space variant (its Cartesian DMP's
6 x 40 weights), and one of its steps costs seconds of MuJoCo; juggling has none either (a
periodic DMP's weights set the rhythm's shape, its period is what the apex depends on). See :mod:`dmprs.envs.env` and ``docs/envs.md``.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym

from dmprs.envs.env import ResetNeeded, TaskEnv
from dmprs.envs.scenarios import (
    Scenario,
    arm_pouring_scenario,
    juggling_scenario,
    matchbox_scenario,
    pouring_scenario,
    throwing_scenario,
)

__all__ = ["ENV_IDS", "ResetNeeded", "Scenario", "TaskEnv", "arm_pouring_scenario", "juggling_scenario",
           "make_arm_pouring", "make_juggling", "make_matchbox", "make_pouring", "make_throwing", "matchbox_scenario",
           "pouring_scenario", "register_envs", "throwing_scenario"]

ENV_IDS = ("dmprs/MatchboxFlip-v0", "dmprs/MatchboxFlipWeights-v0", "dmprs/Pouring-v0", "dmprs/PouringWeights-v0",
           "dmprs/ArmPouring-v0", "dmprs/ArmThrowing-v0", "dmprs/ArmThrowingWeights-v0", "dmprs/ArmJuggling-v0")


def make_matchbox(action: str = "query", **options: Any) -> TaskEnv:
    """The matchbox flip-up as a one-step environment (``action``: ``"query"`` or ``"weights"``)."""
    return TaskEnv(matchbox_scenario(**options), action=action)


def make_pouring(action: str = "query", **options: Any) -> TaskEnv:
    """2-D pouring from a bottle of random volume as a one-step environment."""
    return TaskEnv(pouring_scenario(**options), action=action)


def make_arm_pouring(action: str = "query", **options: Any) -> TaskEnv:
    """Pouring with the 7-DOF arm from a bottle of random volume as a one-step environment."""
    return TaskEnv(arm_pouring_scenario(**options), action=action)


def make_throwing(action: str = "query", **options: Any) -> TaskEnv:
    """Throwing into a basket at a random place with the 7-DOF arm as a one-step environment."""
    return TaskEnv(throwing_scenario(**options), action=action)


def make_juggling(action: str = "query", **options: Any) -> TaskEnv:
    """Bouncing a ball to a random apex with the 7-DOF arm holding a paddle as a one-step environment."""
    return TaskEnv(juggling_scenario(**options), action=action)


def register_envs() -> None:
    """Registers the environments of :data:`ENV_IDS` with Gymnasium (idempotent)."""
    specs = {
        "dmprs/MatchboxFlip-v0": ("dmprs.envs:make_matchbox", "query"),
        "dmprs/MatchboxFlipWeights-v0": ("dmprs.envs:make_matchbox", "weights"),
        "dmprs/Pouring-v0": ("dmprs.envs:make_pouring", "query"),
        "dmprs/PouringWeights-v0": ("dmprs.envs:make_pouring", "weights"),
        "dmprs/ArmPouring-v0": ("dmprs.envs:make_arm_pouring", "query"),
        "dmprs/ArmThrowing-v0": ("dmprs.envs:make_throwing", "query"),
        "dmprs/ArmThrowingWeights-v0": ("dmprs.envs:make_throwing", "weights"),
        "dmprs/ArmJuggling-v0": ("dmprs.envs:make_juggling", "query"),
    }
    for env_id, (entry, action) in specs.items():
        if env_id not in gym.registry:
            # no max_episode_steps: a TimeLimit would mark the single step truncated as well as terminated
            gym.register(env_id, entry_point=entry, kwargs={"action": action})


register_envs()
