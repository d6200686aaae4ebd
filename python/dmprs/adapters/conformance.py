"""``check_adapter``: the conformance suite any adapter implementer can run, in the spirit of
scikit-learn's ``check_estimator`` and Gymnasium's ``check_env``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping

import numpy as np

from dmprs.adapters.base import Adapter
from dmprs.adapters.spec import AdapterSpec, Outcome, Status
from dmprs.errors import AdapterConformanceError
from dmprs.trajectory import CartesianTrajectory, Trajectory


def check_adapter(
    adapter: Adapter,
    valid_trajectory: Trajectory | CartesianTrajectory,
    *,
    execute: bool = True,
    deterministic: bool = True,
) -> list[str]:
    """Checks that ``adapter`` follows the protocol; raises listing every failure.

    ``valid_trajectory`` must be one the adapter accepts: a joint :class:`~dmprs.Trajectory`, or
    a :class:`~dmprs.CartesianTrajectory` for a pose adapter (the bad ones it is shown are then
    poses with bad positions). Every outcome is checked for its types:
    a :class:`~dmprs.adapters.Status` (not a string that equals one), a str message, a
    trajectory or None as executed, and a mapping of declared signals of their declared types. With ``execute=False`` nothing moves
    (for a first check on real hardware): only the spec, check, dry run, stop and connection
    handling are exercised. With ``deterministic=True`` two executions after ``reset(seed=0)``
    must give identical signals (simulations); set it False for real robots.

    Returns the names of the checks that passed.
    """
    failures: list[str] = []
    passed: list[str] = []

    def run(name: str, fn: Callable[[], None]) -> None:
        try:
            fn()
        except Exception as exc:  # noqa: BLE001 - each failure is reported, not raised
            failures.append(f"{name}: {type(exc).__name__}: {exc}")
        else:
            passed.append(name)

    spec = getattr(adapter, "spec", None)

    # a pose trajectory's DOFs in a pose spec are its positions' (the orientation comes with them)
    n_dof = valid_trajectory.position.shape[1] if isinstance(valid_trajectory, CartesianTrajectory) else (
        valid_trajectory.n_dof)

    def spec_is_valid() -> None:
        assert isinstance(spec, AdapterSpec), "adapter.spec must be an AdapterSpec"
        assert spec.n_dof == n_dof, f"valid_trajectory has {n_dof} DOFs, spec has {spec.n_dof}"

    def altered(make: Callable[[np.ndarray], np.ndarray]) -> Trajectory | CartesianTrajectory:
        """``valid_trajectory`` with its positions changed by ``make``, unvalidated."""
        if isinstance(valid_trajectory, CartesianTrajectory):
            v = valid_trajectory
            return CartesianTrajectory._trusted(v.t.copy(), make(v.position.copy()), v.quaternion.copy(),
                                                None, None, None, None)
        return Trajectory._trusted(valid_trajectory.t.copy(), make(valid_trajectory.y.copy()), None, None)

    run("spec", spec_is_valid)
    if failures:
        raise AdapterConformanceError("; ".join(failures))

    def check_accepts_valid() -> None:
        problems = adapter.check(valid_trajectory)
        assert problems == [], f"check() rejects the valid trajectory: {problems}"

    def check_rejects(name: str, make: Callable[[np.ndarray], np.ndarray]) -> Callable[[], None]:
        def fn() -> None:
            problems = adapter.check(altered(make))
            assert problems and all(isinstance(p, str) and p for p in problems), (
                f"check() accepted a trajectory with {name}")
        return fn

    def nan(y: np.ndarray) -> np.ndarray:
        y[len(y) // 2, 0] = np.nan
        return y

    def far(y: np.ndarray) -> np.ndarray:
        return y + 1e6

    def wrong_dofs(y: np.ndarray) -> np.ndarray:
        return np.hstack([y, y[:, :1]])

    def outcome_shape(o: Outcome, allowed: set[Status]) -> None:
        """The outcome's types, whatever its status: a learner and a run log rely on each."""
        assert isinstance(o, Outcome), f"execute() returned {type(o).__name__}, not Outcome"
        # A plain string equals a Status (Status is a str enum) but is not one: `outcome.ok` is
        # False for it, so every trial would be logged as an error.
        assert isinstance(o.status, Status), (
            f"status is the {type(o.status).__name__} {o.status!r:.40}, not a dmprs.adapters.Status")
        assert o.status in allowed, f"status {o.status} not in {sorted(s.value for s in allowed)}"
        assert isinstance(o.message, str), f"message is {type(o.message).__name__} {o.message!r:.40}, not a str"
        assert o.executed is None or isinstance(o.executed, (Trajectory, CartesianTrajectory)) or (
            hasattr(o.executed, "t") and hasattr(o.executed, "pose")), (
            f"executed is {type(o.executed).__name__}, not a trajectory or None")
        assert isinstance(o.signals, Mapping), (
            f"signals is {type(o.signals).__name__}, not a mapping of signal names to values")
        if o.status is not Status.OK:  # a failed trial may lack signals, but not invent or garble them
            assert isinstance(spec, AdapterSpec)
            problems = [p for p in spec.signal_problems(o.signals) if not p.endswith(" is missing")]
            assert not problems, "; ".join(problems)

    def lifecycle() -> None:
        adapter.connect()
        adapter.connect()  # idempotent
        adapter.disconnect()
        adapter.disconnect()
        with adapter as a:
            assert a is adapter, "__enter__ must return the adapter"

    def dry_run() -> None:
        with adapter:
            adapter.reset(seed=0)
            o = adapter.execute(valid_trajectory, dry_run=True)
            outcome_shape(o, {Status.DRY_RUN})
            o = adapter.execute(altered(nan), dry_run=True)
            outcome_shape(o, {Status.REJECTED})
            assert o.message, "a rejection must say why"

    def rejected_never_raises() -> None:
        with adapter:
            adapter.reset(seed=0)
            o = adapter.execute(altered(far))
            outcome_shape(o, {Status.REJECTED})

    def stop_is_idempotent() -> None:
        adapter.stop()
        adapter.stop()

    def executes() -> None:
        with adapter:
            adapter.reset(seed=0)
            o = adapter.execute(valid_trajectory)
            outcome_shape(o, {Status.OK})
            assert isinstance(spec, AdapterSpec)
            names = {s.name for s in spec.signals}
            problems = spec.signal_problems(o.signals)
            assert not problems, "; ".join(problems)
            if deterministic:
                adapter.reset(seed=0)
                again = adapter.execute(valid_trajectory)
                for k in names:
                    assert np.array_equal(np.asarray(o.signals[k]), np.asarray(again.signals[k])), (
                        f"signal {k!r} differs between two runs after reset(seed=0)")

    run("check accepts the valid trajectory", check_accepts_valid)
    run("check rejects NaN", check_rejects("a NaN", nan))
    run("check rejects positions far outside the limits", check_rejects("positions 1e6 away", far))
    run("check rejects the wrong DOF count", check_rejects("an extra DOF", wrong_dofs))
    run("connect/disconnect idempotent, context manager", lifecycle)
    run("dry run", dry_run)
    run("stop is idempotent", stop_is_idempotent)
    if execute:
        run("a rejected trajectory is an outcome, not an exception", rejected_never_raises)
        run("execute returns the declared signals", executes)
    if failures:
        raise AdapterConformanceError(
            f"{type(adapter).__name__} fails {len(failures)} check(s): " + "; ".join(failures))
    return passed
