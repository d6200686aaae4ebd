"""Finding adapters by name: the ones shipped with dmprs and third-party ones registered under
the entry-point group ``dmprs.adapters`` (so the core never imports a robot SDK).

A robot package declares, in its pyproject.toml::

    [project.entry-points."dmprs.adapters"]
    my_arm = "my_arm_dmprs:MyArmAdapter"
"""

from __future__ import annotations

import importlib
from importlib.metadata import entry_points
from typing import Any

from dmprs.adapters.base import Adapter
from dmprs.errors import InvalidInputError

ENTRY_POINT_GROUP = "dmprs.adapters"

#: The adapters shipped with dmprs, as ``"module:Class"``: imported only when loaded (the
#: simulations pull in their physics engines), listed here so that nothing depends on which
#: task modules happen to have been imported.
BUILTIN: dict[str, str] = {
    "analytic": "dmprs.tasks.analytic:AnalyticAdapter",
    "arm-pouring": "dmprs.tasks.arm_pouring:ArmPouringAdapter",
    "matchbox": "dmprs.tasks.matchbox:MatchboxAdapter",
    "pouring": "dmprs.tasks.pouring:PouringAdapter",
    "arm-throwing": "dmprs.tasks.arm_throwing:ArmThrowingAdapter",
    "arm-juggling": "dmprs.tasks.arm_juggling:ArmJugglingAdapter",
}


def available_adapters() -> list[str]:
    """The names of every adapter :func:`load_adapter` can load, built in and registered."""
    names = set(BUILTIN) | {ep.name for ep in entry_points(group=ENTRY_POINT_GROUP)}
    return sorted(names)


def load_adapter(name: str, **kwargs: Any) -> Adapter:
    """Instantiates the adapter registered under ``name`` with ``kwargs``."""
    if name in BUILTIN:
        module, _, attr = BUILTIN[name].partition(":")
        cls = getattr(importlib.import_module(module), attr)
    else:
        matches = [ep for ep in entry_points(group=ENTRY_POINT_GROUP) if ep.name == name]
        if not matches:
            raise InvalidInputError(
                f"unknown adapter {name!r}; available: {', '.join(available_adapters()) or 'none'}"
            )
        cls = matches[0].load()
    adapter = cls(**kwargs)
    if not isinstance(adapter, Adapter):
        raise InvalidInputError(f"adapter {name!r} ({cls!r}) does not implement dmprs.adapters.Adapter")
    return adapter
