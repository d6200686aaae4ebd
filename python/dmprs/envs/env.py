"""Episodic Gymnasium environments over dmprs tasks: one step executes one whole trajectory.

The observation is the task's context (e.g. the bottle's volume); the episode ends after one
step. Two action spaces:

* ``action="query"``: the task query fed to the generalizer (the paper's learning in the query
  space, docs/method.md §5), within the demonstrations' span;
* ``action="weights"``: the DMP's shape weights, as fancy_gym's black-box wrappers expose a
  movement primitive's parameters. The action ``a`` in [-1, 1]^(D N) is normalized:
  ``w = w_ref + a * h``, with ``w_ref`` the weights the generalizer gives for the context's
  desired query and ``h`` per DOF the spread of the demonstrations' weights plus a quarter of
  their largest magnitude; goal, start and tau stay those of ``w_ref``'s DMP.

The reward is ``-|eps|`` in the task's outcome units (eps as the task defines it, method.md
§5.3), or the scenario's ``failure_reward`` when the trial gives no measurement; ``info`` has the
status, eps, success, query and the scalar outcome signals. Finite actions outside the space are
clipped to it (as Gymnasium's continuous-control environments do; ``info["clipped"]`` says so);
a non-finite action raises :class:`~dmprs.errors.InvalidInputError`.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from dmprs.dmp import DMP
from dmprs.envs.scenarios import Scenario
from dmprs.errors import InvalidInputError

__all__ = ["TaskEnv"]

ACTIONS = ("query", "weights")


class TaskEnv(gym.Env[NDArray[np.float64], NDArray[np.float64]]):
    """One-step episodes of a :class:`~dmprs.envs.scenarios.Scenario`; see the module docs."""

    metadata: dict[str, Any] = {"render_modes": []}  # noqa: RUF012 - Gymnasium declares it so

    def __init__(self, scenario: Scenario, action: str = "query") -> None:
        if action not in ACTIONS:
            raise InvalidInputError(f"action = {action!r}; use one of {ACTIONS}")
        self.scenario = scenario
        self.action_kind = action
        gen = scenario.generalizer
        self.observation_space = gym.spaces.Box(scenario.context_low, scenario.context_high, dtype=np.float64)
        if action == "query":
            self.action_space = gym.spaces.Box(scenario.query_low, scenario.query_high, dtype=np.float64)
        else:
            w = np.stack([d.weights for d in gen.demo_dmps])  # (M, D, N)
            spread = np.abs(w - w.mean(axis=0)).max(axis=(0, 2))
            self._half = (spread + 0.25 * np.abs(w).max(axis=(0, 2)))[:, None]  # (D, 1)
            self._shape = w.shape[1:]
            self.action_space = gym.spaces.Box(-1.0, 1.0, shape=(int(np.prod(self._shape)),), dtype=np.float64)
        self._context: NDArray[np.float64] | None = None

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None,
              ) -> tuple[NDArray[np.float64], dict[str, Any]]:
        """Draws a context from the seeded generator (or takes ``options["context"]``)."""
        super().reset(seed=seed)
        if options and "context" in options:
            ctx = np.atleast_1d(np.asarray(options["context"], dtype=np.float64))
            if not self.observation_space.contains(ctx):
                raise InvalidInputError(
                    f"options['context'] = {ctx.tolist()} is outside {self.observation_space}")
        else:
            ctx = self.scenario.sample_context(self.np_random)
        self._context = ctx
        task = self.scenario.make_task(ctx)
        task.adapter.connect()
        task.adapter.reset(seed=int(self.np_random.integers(2**31)))
        return ctx.copy(), {"desired_query": self.scenario.desired_query(ctx)}

    def _dmp(self, action: NDArray[np.float64], desired: NDArray[np.float64]) -> tuple[Any, NDArray[np.float64]]:
        gen = self.scenario.generalizer
        if self.action_kind == "query":
            return gen.predict(action), action
        ref = gen.predict(desired)
        if not isinstance(ref, DMP):
            raise InvalidInputError(f"{self.scenario.name}: weight actions are for joint-space DMPs")
        w = ref.weights + action.reshape(self._shape) * self._half
        dmp = DMP(w, ref.goal, ref.y0, ref.tau, alpha_z=ref.alpha_z, beta_z=ref.beta_z, alpha_x=ref.alpha_x,
                  width_factor=ref.width_factor)
        return dmp, desired

    def step(self, action: Any) -> tuple[NDArray[np.float64], float, bool, bool, dict[str, Any]]:
        if self._context is None:
            raise InvalidInputError(f"{self.scenario.name}: step() before reset()")
        a = np.asarray(action, dtype=np.float64).reshape(self.action_space.shape)
        if not np.isfinite(a).all():
            raise InvalidInputError(f"the action {a.tolist()} is not finite")
        box = self.action_space
        assert isinstance(box, gym.spaces.Box)
        clipped = np.clip(a, box.low, box.high)
        ctx = self._context
        desired = self.scenario.desired_query(ctx)
        task = self.scenario.make_task(ctx)
        dmp, query = self._dmp(clipped, desired)
        outcome = task.adapter.execute(task.trajectory(dmp))
        info: dict[str, Any] = {"status": outcome.status.value, "message": outcome.message, "query": query,
                                "clipped": bool((clipped != a).any()), "success": False, "eps": None}
        info.update({k: v for k, v in outcome.signals.items() if np.ndim(v) == 0})
        if outcome.ok:
            eps = task.error(desired, outcome)
            info["eps"] = eps
            info["success"] = task.success(desired, outcome)
            reward = -float(np.linalg.norm(eps))
        else:
            reward = float(self.scenario.failure_reward)
        return ctx.copy(), reward, True, False, info

    def close(self) -> None:
        if self._context is not None:
            self.scenario.make_task(self._context).adapter.disconnect()
        super().close()
