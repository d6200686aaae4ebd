"""The reproduction's parts beyond the paper's three experiments, in one table: each has its plan,
its runner, its Markdown section and its figure, and may need an optional extra.

A spec's ``kind`` names its part; :func:`dmprs.reproduce.run.dispatch` sends it to the part's
runner, and the report appends each part's section in this order.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from dmprs._extras import available


@dataclass(frozen=True)
class Part:
    """One part of the reproduction (a module of :mod:`dmprs.reproduce`)."""

    kind: str
    title: str
    module: str
    #: an importable module the part needs (from an optional extra), or None
    needs: str | None = None

    def available(self) -> bool:
        return self.needs is None or available(self.needs)

    def _get(self, name: str) -> Callable[..., Any]:
        return getattr(importlib.import_module(self.module), f"{name}_{self.kind.replace('-', '_')}")

    def plan(self, quick: bool) -> list[Any]:
        return list(self._get("plan")(quick))

    def run(self, spec: Any) -> dict[str, Any]:
        return self._get("run")(spec)

    def markdown(self, results: list[dict[str, Any]]) -> str:
        return self._get("markdown")(self._get("summarize")(results))

    def figure(self, results: list[dict[str, Any]], out: Path) -> Path | None:
        return self._get("figure")(results, out)


PARTS: tuple[Part, ...] = (
    Part("growing", "Learning gets faster as the database grows (2-D pouring; docs/growing.md)",
         "dmprs.reproduce.growing"),
    Part("noisy", "A noisy robot (matchbox and 2-D pouring; docs/growing.md)", "dmprs.reproduce.noisy"),
    Part("throwing", "Throwing into a basket with the 7-DOF arm, a 2-D query (docs/throwing.md)",
         "dmprs.reproduce.throwing", needs="mujoco"),
)

BY_KIND = {p.kind: p for p in PARTS}
