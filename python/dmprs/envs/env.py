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
clipped to it (as Gymnasium's continuous-control environments do; ``info["clipped"]`` says so).
An action that is not a real array of the space's shape (a complex, boolean, string or object
array, a 2-D array, None, a string), or is not finite, raises
:class:`~dmprs.errors.InvalidInputError` naming the action and the space: it is never reshaped
or cast into one.

An episode is one step: ``step`` before ``reset``, or again after the episode ended, raises
:class:`ResetNeeded`, which is both a :class:`~dmprs.errors.DmprsError` and Gymnasium's own
``gymnasium.error.ResetNeeded`` (what Gymnasium's ``OrderEnforcing`` wrapper raises for a step
before reset), so code written for either catches it. ``reset(seed=s)`` makes the episode
reproducible bit for bit: the context and the adapter's seed are drawn from ``s``.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from numpy.typing import NDArray

from dmprs._arrays import short
from dmprs.dmp import DMP
from dmprs.envs.scenarios import Scenario
from dmprs.errors import DmprsError, InvalidInputError

__all__ = ["ResetNeeded", "TaskEnv"]

ACTIONS = ("query", "weights")
#: the keys ``reset(options=...)`` understands
RESET_OPTIONS = ("context",)


class ResetNeeded(DmprsError, gym.error.ResetNeeded):
    """``step`` before ``reset`` or after the episode ended. It lives here, not in
    :mod:`dmprs.errors`, because it derives from Gymnasium's class (importing dmprs does not
    import Gymnasium).
    """


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
        self._done = False

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None,
              ) -> tuple[NDArray[np.float64], dict[str, Any]]:
        """Draws a context from the generator seeded with ``seed`` (a non-negative integer, or None
        to keep the current stream), or takes ``options["context"]``.
        """
        if seed is not None and (isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer))
                                 or seed < 0):
            raise InvalidInputError(f"seed = {short(seed)} is invalid: use a non-negative integer or None")
        if options is not None and not isinstance(options, dict):
            raise InvalidInputError(f"options = {short(options)} is invalid: use a dict or None")
        unknown = sorted(map(str, set(options or {}) - set(RESET_OPTIONS)))
        if unknown:
            raise InvalidInputError(f"options has unknown keys {unknown}; {self.scenario.name} knows {RESET_OPTIONS}")
        ctx = None
        if options and "context" in options:
            ctx = self._checked(options["context"], "options['context']", self.observation_space)
        super().reset(seed=None if seed is None else int(seed))
        if ctx is None:
            ctx = self.scenario.sample_context(self.np_random)
        self._context = ctx
        self._done = False
        task = self.scenario.make_task(ctx)
        task.adapter.connect()
        task.adapter.reset(seed=int(self.np_random.integers(2**31)))
        return ctx.copy(), {"desired_query": self.scenario.desired_query(ctx)}

    @staticmethod
    def _checked(value: Any, name: str, box: gym.spaces.Space[Any], clip: bool = False) -> NDArray[np.float64]:
        """``value`` as a finite float64 array of ``box``'s shape, or an InvalidInputError naming
        ``name`` and ``box``; within ``box`` unless ``clip`` (then the caller clips).
        """
        assert isinstance(box, gym.spaces.Box)
        space = f"the space is {box}"
        try:
            arr = None if value is None or isinstance(value, (str, bytes)) else np.asarray(value)
        except (ValueError, TypeError):  # ragged sequences and the like
            arr = None
        if arr is None:
            raise InvalidInputError(f"{name} = {short(value)} is not an array of numbers; {space}")
        if arr.dtype.kind not in "fiu":
            raise InvalidInputError(f"{name} = {short(value)} has dtype {arr.dtype}, not real numbers; {space}")
        if arr.shape != box.shape:
            raise InvalidInputError(f"{name} = {short(value)} has shape {arr.shape}; {space}")
        out = arr.astype(np.float64)
        if not np.isfinite(out).all():
            raise InvalidInputError(f"{name} = {short(value)} is not finite; {space}")
        if not clip and not box.contains(out):
            raise InvalidInputError(f"{name} = {out.tolist()} is outside the space; {space}")
        return out

    def _dmp(self, action: NDArray[np.float64], desired: NDArray[np.float64]) -> tuple[Any, NDArray[np.float64]]:
        gen = self.scenario.generalizer
        if self.action_kind == "query":
            return gen.predict(action), action
        ref = gen.predict(desired)
        if not isinstance(ref, DMP):
            raise InvalidInputError(f"{self.scenario.name}: weight actions are for joint-space DMPs")
        w = ref.weights + action.reshape(self._shape) * self._half
        dmp = DMP(w, ref.goal, ref.start, ref.tau, alpha_z=ref.alpha_z, beta_z=ref.beta_z, alpha_x=ref.alpha_x,
                  width_factor=ref.width_factor)
        return dmp, desired

    def step(self, action: Any) -> tuple[NDArray[np.float64], float, bool, bool, dict[str, Any]]:
        """Executes the DMP the action chooses; the episode ends after this one trial."""
        if self._context is None:
            raise ResetNeeded(f"{self.scenario.name}: step() before reset()")
        if self._done:
            raise ResetNeeded(f"{self.scenario.name}: step() after the episode ended (terminated); call reset() "
                              "first: an episode is one step")
        a = self._checked(action, "the action", self.action_space, clip=True)
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
        self._done = True
        return ctx.copy(), reward, True, False, info

    def close(self) -> None:
        """Disconnects the current task's adapter."""
        if self._context is not None:
            self.scenario.make_task(self._context).adapter.disconnect()
        super().close()
