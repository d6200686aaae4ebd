"""Tasks: an adapter plus scoring (desired outcome, signed error, success).

``AnalyticTask`` is a physics-free toy for exercising the loop; ``Pouring`` is the paper's
pouring experiment in a pymunk simulation (pymunk is imported only when a pour runs);
``MatchboxFlip`` is the matchbox flip-up in the Rust/Rapier simulation.
"""

from dmprs.tasks.analytic import AnalyticTask
from dmprs.tasks.base import Task
from dmprs.tasks.matchbox import MatchboxAdapter, MatchboxFlip
from dmprs.tasks.pouring import Pouring, PouringAdapter

__all__ = ["AnalyticTask", "MatchboxAdapter", "MatchboxFlip", "Pouring", "PouringAdapter", "Task"]
