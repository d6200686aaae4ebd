"""What a part of the reproduction beyond the paper's three experiments is: its plan, its runner,
its Markdown section and its figure, the optional package it needs, and what it leaves out for
lack of another one.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dmprs._extras import available

#: the liquids of every pouring setting, 2-D, on the arm and held in the servo loop: granular flow
#: is chaotic (docs/arm.md, noise floor), so one liquid's result is one draw, and each setting is
#: run with several and reported by its median and range
LIQUID_SEEDS = (0, 1, 2, 3, 4)


@dataclass(frozen=True)
class Part:
    """One part of the reproduction. Its specs carry ``kind``, which
    :func:`dmprs.reproduce.run.dispatch` sends to :attr:`run`.
    """

    kind: str
    title: str
    plan: Callable[[bool], list[Any]]
    run: Callable[[Any], dict[str, Any]]
    summarize: Callable[[list[dict[str, Any]]], Any]
    markdown_of: Callable[[Any], str]
    figure: Callable[[list[dict[str, Any]], Path], Path | None]
    #: an importable module the part needs (from an optional extra), or None
    needs: str | None = None
    #: one line per group of runs the part, available, leaves out for lack of an optional
    #: package (``quick`` as for :attr:`plan`), naming the extra that brings them
    left_out: Callable[[bool], list[str]] = lambda quick: []

    def available(self) -> bool:
        """Whether the packages this part needs are installed."""
        return self.needs is None or available(self.needs)
