"""Tasks: an adapter plus scoring (desired outcome, signed error, success).

``AnalyticTask`` is a physics-free toy for exercising the loop; ``Pouring`` is the paper's
pouring experiment in a pymunk simulation (pymunk is imported only when a pour runs).
"""

from dmprs.tasks.analytic import AnalyticTask
from dmprs.tasks.base import Task
from dmprs.tasks.pouring import Pouring, PouringAdapter

__all__ = ["AnalyticTask", "Pouring", "PouringAdapter", "Task"]
