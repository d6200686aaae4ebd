"""The importers fuzzed (``tests/fuzz_io.py``): whatever file a user or an attacker hands them, only
:class:`~dmprs.errors.DmprsError` subclasses escape, input that cannot be meant is refused (never
read as garbage), and what is read is a usable demonstration. A derandomized run of a few
examples per target; ``python -m tests.fuzz_io N`` runs N per target in forked children."""

from __future__ import annotations

from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings

from dmprs.errors import DmprsError
from tests.fuzz_io import IO_TARGETS

FUZZ = settings(max_examples=12, deadline=None, derandomize=True, database=None,
                suppress_health_check=list(HealthCheck))


@pytest.mark.parametrize("name", list(IO_TARGETS))
def test_only_clear_errors_and_usable_demonstrations(name: str) -> None:
    strategy, run = IO_TARGETS[name]

    @FUZZ
    @given(strategy)
    def check(args: Any) -> None:
        try:
            run(args)
        except DmprsError as exc:
            assert not getattr(exc, "vague", False), f"an error naming no file or argument: {exc}"

    check()
