"""The hardware-adapter interface: how dmprs talks to simulations and real robots.

An adapter is episodic: ``execute`` runs one whole trajectory and returns the measured
:class:`Outcome`. Scoring is not the adapter's job (see :mod:`dmprs.tasks`). See
``docs/adapters.md`` for writing one for a real arm.
"""

from dmprs.adapters.base import Adapter, BaseAdapter
from dmprs.adapters.conformance import check_adapter
from dmprs.adapters.recording import RecordingAdapter, ReplayAdapter
from dmprs.adapters.registry import ENTRY_POINT_GROUP, available_adapters, load_adapter
from dmprs.adapters.spec import AdapterSpec, Outcome, SignalSpec, Status
from dmprs.errors import AdapterConformanceError, AdapterError

__all__ = [
    "ENTRY_POINT_GROUP",
    "Adapter",
    "AdapterConformanceError",
    "AdapterError",
    "AdapterSpec",
    "BaseAdapter",
    "Outcome",
    "RecordingAdapter",
    "ReplayAdapter",
    "SignalSpec",
    "Status",
    "available_adapters",
    "check_adapter",
    "load_adapter",
]
