"""Property-based fuzzing of the public API (the reliability issue): whatever a caller passes,
only :class:`~dmprs.errors.DmprsError` subclasses escape, nothing non-finite is returned, nothing
is written outside the directory given nor garbage accepted (``AcceptedGarbage``), and every call
returns within its deadline. The inputs are drawn in ``tests/fuzz_targets.py``.
"""

from __future__ import annotations

from datetime import timedelta
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings

from dmprs.errors import DmprsError
from tests.fuzz_targets import TARGETS, TEST_EXAMPLES, non_finite

# A derandomized run: the same examples in CI and on every machine, about a minute in all. The
# deadline catches a hang, not slowness: a rollout at the core's work cap (5e7 state updates)
# takes 1.5 s on a quiet 2-core machine and twice that under load.
DEADLINE = timedelta(seconds=10)
FUZZ = settings(
    max_examples=200,
    deadline=DEADLINE,
    derandomize=True,
    database=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


@pytest.mark.parametrize("name", list(TARGETS))
def test_only_dmprs_errors_and_finite_outputs(name: str) -> None:
    strategy, run = TARGETS[name]
    budget = TEST_EXAMPLES.get(name)  # the slower targets (files, whole runs, MuJoCo): fewer examples

    @settings(FUZZ, max_examples=budget or 200, deadline=None if budget else DEADLINE)
    @given(strategy)
    def check(args: Any) -> None:
        try:
            out = run(args)
        except DmprsError:
            return
        bad = non_finite(out)
        assert bad is None, f"{name} returned {bad}"

    check()
