"""dmprs: learn a robot skill from two or three demonstrations and get it right in a handful of
trials (Nemec, Vuga, Ude, "Efficient sensorimotor learning from multiple demonstrations", 2013).

The numerical core is Rust (``dmprs._core``); this package is the API users import.
"""

from dmprs import adapters, learners, tasks
from dmprs._core import __version__
from dmprs.batch import rollout_batch
from dmprs.cartesian import CartesianDMP
from dmprs.database import Database, Demo
from dmprs.dmp import DMP
from dmprs.errors import (
    DatabaseError,
    DmprsError,
    ExtrapolationError,
    InvalidInputError,
    LearnerStateError,
    NumericalError,
)
from dmprs.generalize import Generalizer
from dmprs.gp import GaussianProcess
from dmprs.loop import LearningResult, learn
from dmprs.oscillator import AdaptiveOscillator, RhythmLearner
from dmprs.periodic import PeriodicCartesianDMP, PeriodicDMP, PeriodicOnlineFit
from dmprs.periodic_stepper import PeriodicStepper
from dmprs.sequence import CartesianSequenceStepper, Sequence, SequenceStepper
from dmprs.stepper import CartesianStepper, JointStepper
from dmprs.trajectory import CartesianTrajectory, Trajectory

__all__ = [
    "DMP",
    "AdaptiveOscillator",
    "CartesianDMP",
    "CartesianSequenceStepper",
    "CartesianStepper",
    "CartesianTrajectory",
    "Database",
    "DatabaseError",
    "Demo",
    "DmprsError",
    "ExtrapolationError",
    "GaussianProcess",
    "Generalizer",
    "InvalidInputError",
    "JointStepper",
    "LearnerStateError",
    "LearningResult",
    "NumericalError",
    "PeriodicCartesianDMP",
    "PeriodicDMP",
    "PeriodicOnlineFit",
    "PeriodicStepper",
    "RhythmLearner",
    "Sequence",
    "SequenceStepper",
    "Trajectory",
    "__version__",
    "adapters",
    "learn",
    "learners",
    "rollout_batch",
    "tasks",
]
