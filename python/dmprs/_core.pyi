# Type stubs for the Rust extension dmprs._core (crates/py-bindings). The documented API is in
# dmprs.dmp; these low-level entry points take arrays that are already float64 and C-contiguous.
from typing import ClassVar, Self, TypeAlias, TypedDict, final

import numpy as np
from numpy.typing import NDArray
from typing_extensions import disjoint_base

__all__ = [
    "MIN_GP_NEIGHBOURS",
    "PI2",
    "UNIT_TOLERANCE",
    "AdaptiveOscillator",
    "CartesianDmp",
    "CartesianGeneralizer",
    "CartesianSequenceStepper",
    "CartesianStepper",
    "Dmp",
    "ErrorLearning",
    "GaussianProcess",
    "Generalizer",
    "GoldenSection",
    "IllinoisRootFinder",
    "MatchboxConfig",
    "PeriodicCartesianDmp",
    "PeriodicDmp",
    "PeriodicGeneralizer",
    "PeriodicOnlineFit",
    "PeriodicStepper",
    "PoWER",
    "PolicyGradient",
    "RobotGoal",
    "RobotNode",
    "RobotTrajectory",
    "Ros2GoalClient",
    "Ros2JointStateListener",
    "SequenceStepper",
    "Stepper",
    "__version__",
    "cartesian_sequence_rollout",
    "dls_step",
    "matchbox_check",
    "matchbox_simulate",
    "matchbox_simulate_batch",
    "portable_binary",
    "portable_norm",
    "portable_unary",
    "rollout_batch",
    "rollout_batch_cartesian",
    "rollout_batch_periodic",
    "rollout_batch_periodic_cartesian",
    "sequence_rollout",
]

__version__: str
UNIT_TOLERANCE: float
MIN_GP_NEIGHBOURS: int

_TrajectoryArrays: TypeAlias = tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]
]

class _Primitive:
    """What Dmp and CartesianDmp share (crates/py-bindings/src/primitive.rs): the parameters."""

    @property
    def weights(self) -> NDArray[np.float64]: ...
    @property
    def goal(self) -> NDArray[np.float64]: ...
    @property
    def start(self) -> NDArray[np.float64]: ...
    @property
    def tau(self) -> float: ...
    @property
    def n_dof(self) -> int: ...
    @property
    def n_basis(self) -> int: ...
    @property
    def alpha_z(self) -> float: ...
    @property
    def beta_z(self) -> float: ...
    @property
    def alpha_x(self) -> float: ...
    @property
    def width_factor(self) -> float: ...
    @property
    def centers(self) -> NDArray[np.float64]: ...
    @property
    def widths(self) -> NDArray[np.float64]: ...

#: The constants as the core takes them: alpha_z, beta_z, alpha_x, width_factor.
_Constants: TypeAlias = dict[str, float]

class _StepperOptions(TypedDict):
    """The options both steppers share, as the core takes them (dmprs.stepper documents them)."""

    substeps: int | None
    alpha_e: list[float]
    goal_filter: float | None
    velocity_max: list[float] | None
    acceleration_max: list[float] | None
    position_min: list[float] | None
    position_max: list[float] | None
    limit_margin: list[float] | None
    limit_gain: float
    gamma_nominal: float
    gamma_a: float
    eps: float
    rest_tol: float

class _GeneralizerOptions(TypedDict):
    """The generalizers' options as the core takes them (dmprs.Generalizer documents them)."""

    kernel: str
    bandwidth: float
    ridge: float
    interpolate: bool
    gp_noise: float
    gp_optimize: bool | None
    gp_restarts: int
    gp_neighbours: int | None
    gp_sparse: bool
    trend: str

@final
class Dmp(_Primitive):
    def __new__(
        cls,
        weights: NDArray[np.float64],
        goal: NDArray[np.float64],
        start: NDArray[np.float64],
        tau: float,
        constants: _Constants,
    ) -> Dmp: ...
    @staticmethod
    def fit(
        t: NDArray[np.float64],
        y: NDArray[np.float64],
        yd: NDArray[np.float64] | None,
        ydd: NDArray[np.float64] | None,
        n_basis: int,
        constants: _Constants,
        final_velocity: NDArray[np.float64] | None = None,
        final_velocity_from_demo: bool = False,
    ) -> Dmp: ...
    def with_final_velocity(self, final_velocity: NDArray[np.float64]) -> Dmp: ...
    @property
    def final_velocity(self) -> NDArray[np.float64] | None: ...
    def rollout(
        self, dt: float, duration: float | None = None, until_rest: bool = False, rest_tol: float = 1e-4
    ) -> _TrajectoryArrays: ...
    def with_goal(self, goal: NDArray[np.float64]) -> Dmp: ...
    def with_start(self, start: NDArray[np.float64]) -> Dmp: ...
    def with_via_points(self, times: NDArray[np.float64], positions: NDArray[np.float64], dt: float) -> Dmp: ...
    def with_tau(self, tau: float) -> Dmp: ...

def rollout_batch(
    dmps: list[Dmp],
    dt: float,
    duration: float | None = None,
    until_rest: bool = False,
    rest_tol: float = 1e-4,
) -> list[_TrajectoryArrays]: ...

_CartesianArrays: TypeAlias = tuple[
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
]

@final
class CartesianDmp(_Primitive):
    """Position + unit-quaternion DMP of crates/dmp-core/src/cartesian.rs; documented by
    dmprs.cartesian. Rollouts give (t, position, quaternion, velocity, angular_velocity,
    acceleration, angular_acceleration).
    """

    def __new__(
        cls,
        weights: NDArray[np.float64],
        goal: NDArray[np.float64],
        start: NDArray[np.float64],
        tau: float,
        constants: _Constants,
    ) -> CartesianDmp: ...
    @staticmethod
    def fit(
        t: NDArray[np.float64],
        pose: NDArray[np.float64],
        derivatives: dict[str, NDArray[np.float64] | None],
        normalize: bool,
        n_basis: int,
        constants: _Constants,
        final_velocity: NDArray[np.float64] | None = None,
        final_velocity_from_demo: bool = False,
    ) -> CartesianDmp: ...
    def with_final_velocity(self, final_velocity: NDArray[np.float64]) -> CartesianDmp: ...
    @property
    def final_velocity(self) -> NDArray[np.float64] | None: ...
    def rollout(
        self, dt: float, duration: float | None = None, until_rest: bool = False, rest_tol: float = 1e-4
    ) -> _CartesianArrays: ...
    def with_goal(self, goal: NDArray[np.float64]) -> CartesianDmp: ...
    def with_start(self, start: NDArray[np.float64]) -> CartesianDmp: ...
    def with_tau(self, tau: float) -> CartesianDmp: ...

def rollout_batch_cartesian(
    dmps: list[CartesianDmp],
    dt: float,
    duration: float | None = None,
    until_rest: bool = False,
    rest_tol: float = 1e-4,
) -> list[_CartesianArrays]: ...

@final
class PeriodicDmp:
    """Periodic DMP of crates/dmp-core/src/periodic.rs; documented by dmprs.periodic."""

    def __new__(
        cls,
        weights: NDArray[np.float64],
        goal: NDArray[np.float64],
        amplitude: NDArray[np.float64],
        start: NDArray[np.float64],
        tau: float,
        constants: _Constants,
    ) -> PeriodicDmp: ...
    @staticmethod
    def fit(
        t: NDArray[np.float64],
        y: NDArray[np.float64],
        yd: NDArray[np.float64] | None,
        ydd: NDArray[np.float64] | None,
        period: float | None,
        n_basis: int,
        constants: _Constants,
    ) -> PeriodicDmp: ...
    def rollout(self, dt: float, duration: float | None, phase: float) -> _TrajectoryArrays: ...
    def with_goal(self, goal: NDArray[np.float64]) -> PeriodicDmp: ...
    def with_amplitude(self, amplitude: NDArray[np.float64]) -> PeriodicDmp: ...
    def with_start(self, start: NDArray[np.float64]) -> PeriodicDmp: ...
    def with_tau(self, tau: float) -> PeriodicDmp: ...
    @property
    def weights(self) -> NDArray[np.float64]: ...
    @property
    def goal(self) -> NDArray[np.float64]: ...
    @property
    def amplitude(self) -> NDArray[np.float64]: ...
    @property
    def start(self) -> NDArray[np.float64]: ...
    @property
    def tau(self) -> float: ...
    @property
    def n_dof(self) -> int: ...
    @property
    def n_basis(self) -> int: ...
    @property
    def alpha_z(self) -> float: ...
    @property
    def beta_z(self) -> float: ...
    @property
    def width_factor(self) -> float: ...
    @property
    def centers(self) -> NDArray[np.float64]: ...
    @property
    def h(self) -> float: ...

def rollout_batch_periodic(
    dmps: list[PeriodicDmp], dt: float, duration: float | None, phase: float
) -> list[_TrajectoryArrays]: ...

@final
class PeriodicCartesianDmp:
    """Periodic pose DMP of crates/dmp-core/src/periodic_cartesian.rs; documented by
    dmprs.periodic. Rollouts give the arrays of CartesianDmp's.
    """

    def __new__(
        cls,
        weights: NDArray[np.float64],
        goal: NDArray[np.float64],
        amplitude: NDArray[np.float64],
        start: NDArray[np.float64],
        tau: float,
        constants: _Constants,
    ) -> PeriodicCartesianDmp: ...
    @staticmethod
    def fit(
        t: NDArray[np.float64],
        pose: NDArray[np.float64],
        derivatives: dict[str, NDArray[np.float64] | None],
        normalize: bool,
        period: float | None,
        n_basis: int,
        constants: _Constants,
    ) -> PeriodicCartesianDmp: ...
    def rollout(self, dt: float, duration: float | None, phase: float) -> _CartesianArrays: ...
    def with_goal(self, goal: NDArray[np.float64]) -> PeriodicCartesianDmp: ...
    def with_amplitude(self, amplitude: NDArray[np.float64]) -> PeriodicCartesianDmp: ...
    def with_start(self, start: NDArray[np.float64]) -> PeriodicCartesianDmp: ...
    def with_tau(self, tau: float) -> PeriodicCartesianDmp: ...
    @property
    def weights(self) -> NDArray[np.float64]: ...
    @property
    def goal(self) -> NDArray[np.float64]: ...
    @property
    def amplitude(self) -> NDArray[np.float64]: ...
    @property
    def start(self) -> NDArray[np.float64]: ...
    @property
    def tau(self) -> float: ...
    @property
    def n_dof(self) -> int: ...
    @property
    def n_basis(self) -> int: ...
    @property
    def alpha_z(self) -> float: ...
    @property
    def beta_z(self) -> float: ...
    @property
    def width_factor(self) -> float: ...
    @property
    def centers(self) -> NDArray[np.float64]: ...
    @property
    def h(self) -> float: ...

def rollout_batch_periodic_cartesian(
    dmps: list[PeriodicCartesianDmp], dt: float, duration: float | None, phase: float
) -> list[_CartesianArrays]: ...

@final
class PeriodicOnlineFit:
    def __new__(
        cls, n_dof: int, n_basis: int, constants: _Constants, forgetting: float, delta: float
    ) -> PeriodicOnlineFit: ...
    def update(
        self,
        phase: float,
        tau: float,
        y: NDArray[np.float64],
        yd: NDArray[np.float64],
        ydd: NDArray[np.float64],
        goal: NDArray[np.float64],
        amplitude: NDArray[np.float64],
    ) -> None: ...
    @property
    def weights(self) -> NDArray[np.float64]: ...
    @property
    def samples(self) -> int: ...

@final
class AdaptiveOscillator:
    def __new__(
        cls,
        frequency: float,
        n_dof: int,
        harmonics: int,
        drive: int,
        frequency_range: tuple[float, float],
        gains: tuple[float, float, float],
    ) -> AdaptiveOscillator: ...
    def update(self, dt: float, y: NDArray[np.float64]) -> None: ...
    def estimate(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]: ...
    def coefficients(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]: ...
    def copy(self) -> AdaptiveOscillator: ...
    @property
    def phase(self) -> float: ...
    @property
    def omega(self) -> float: ...
    @property
    def samples(self) -> int: ...
    @property
    def n_dof(self) -> int: ...

class _PeriodicStepperOptions(TypedDict):
    phase: float
    ramp: float
    change_filter: float
    alpha_e: list[float]
    velocity_max: list[float] | None
    acceleration_max: list[float] | None
    gamma_nominal: float
    gamma_a: float
    eps: float

@disjoint_base
class PeriodicStepper:
    def __new__(
        cls, source: PeriodicDmp | PeriodicStepper, dt: float | None = None,
        options: _PeriodicStepperOptions | None = None,
    ) -> Self: ...
    def step(self, measured: object = None) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]: ...
    def stop(self, rest: NDArray[np.float64] | None = None) -> None: ...
    def set_goal(self, goal: NDArray[np.float64]) -> None: ...
    def set_amplitude(self, amplitude: NDArray[np.float64]) -> None: ...
    def set_tau(self, tau: float) -> None: ...
    def done(self) -> bool: ...
    def over_limit(self) -> bool: ...
    @property
    def phase(self) -> float: ...
    @property
    def tau(self) -> float: ...
    @property
    def nominal_tau(self) -> float: ...
    @property
    def envelope(self) -> float: ...
    @property
    def goal(self) -> list[float]: ...
    @property
    def amplitude(self) -> list[float]: ...
    @property
    def steps(self) -> int: ...
    @property
    def dt(self) -> float: ...
    @property
    def n_dof(self) -> int: ...

# The online steppers of crates/dmp-core (stepper.rs, cartesian_stepper.rs); subclassed, validated
# and documented by dmprs.stepper. step() returns one cached tuple of read-only arrays that the
# next call overwrites.
_StepOutput: TypeAlias = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]

@disjoint_base
class Stepper:
    DEFAULTS: ClassVar[dict[str, float]]
    def __new__(
        cls,
        dmp: Dmp | Stepper,
        dt: float | None = None,
        options: _StepperOptions | None = None,
    ) -> Self: ...
    def __copy__(self) -> Self: ...
    def __deepcopy__(self, memo: object) -> Self: ...
    def step(self, measured: object | None = None, coupling: object | None = None) -> _StepOutput: ...
    def reset(self, start: object | None = None) -> None: ...
    def set_goal(self, goal: object) -> None: ...
    def set_tau(self, tau: float) -> None: ...
    def done(self) -> bool: ...
    def over_limit(self) -> bool: ...
    def blocked(self) -> bool: ...
    @property
    def output(self) -> _StepOutput: ...
    @property
    def phase(self) -> float: ...
    @property
    def tau(self) -> float: ...
    @property
    def nominal_tau(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def goal(self) -> NDArray[np.float64]: ...
    @property
    def goal_target(self) -> NDArray[np.float64]: ...
    @property
    def dt(self) -> float: ...
    @property
    def substeps(self) -> int: ...
    @property
    def n_dof(self) -> int: ...

@disjoint_base
class SequenceStepper:
    def __new__(
        cls,
        dmps: list[Dmp] | SequenceStepper,
        dt: float | None = None,
        options: _StepperOptions | None = None,
    ) -> Self: ...
    def __copy__(self) -> Self: ...
    def __deepcopy__(self, memo: object) -> Self: ...
    def step(self, measured: object | None = None, coupling: object | None = None) -> _StepOutput: ...
    def reset(self, start: object | None = None) -> None: ...
    def set_goal(self, goal: object) -> None: ...
    def set_tau(self, tau: float) -> None: ...
    def done(self) -> bool: ...
    def over_limit(self) -> bool: ...
    def blocked(self) -> bool: ...
    @property
    def active(self) -> int: ...
    @property
    def output(self) -> _StepOutput: ...
    @property
    def phase(self) -> float: ...
    @property
    def tau(self) -> float: ...
    @property
    def nominal_tau(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def goal(self) -> NDArray[np.float64]: ...
    @property
    def goal_target(self) -> NDArray[np.float64]: ...
    @property
    def dt(self) -> float: ...
    @property
    def substeps(self) -> int: ...
    @property
    def n_dof(self) -> int: ...

def sequence_rollout(
    dmps: list[Dmp], dt: float, duration: float | None = None, until_rest: bool = False, rest_tol: float = 1e-4
) -> _TrajectoryArrays: ...

@disjoint_base
class CartesianStepper:
    def __new__(
        cls,
        dmp: CartesianDmp | CartesianStepper,
        dt: float | None = None,
        options: _StepperOptions | None = None,
        obstacles: NDArray[np.float64] | None = None,
        obstacle_gain: float | None = None,
        obstacle_beta: float | None = None,
    ) -> Self: ...
    def __copy__(self) -> Self: ...
    def __deepcopy__(self, memo: object) -> Self: ...
    def step(self, measured: object | None = None, coupling: object | None = None) -> _StepOutput: ...
    def reset(self, start: object | None = None) -> None: ...
    def set_goal(self, goal: object) -> None: ...
    def set_tau(self, tau: float) -> None: ...
    def set_obstacles(self, obstacles: NDArray[np.float64] | None) -> None: ...
    def done(self) -> bool: ...
    def over_limit(self) -> bool: ...
    def blocked(self) -> bool: ...
    @property
    def output(self) -> _StepOutput: ...
    @property
    def phase(self) -> float: ...
    @property
    def tau(self) -> float: ...
    @property
    def nominal_tau(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def goal(self) -> NDArray[np.float64]: ...
    @property
    def goal_target(self) -> NDArray[np.float64]: ...
    @property
    def obstacles(self) -> NDArray[np.float64]: ...
    @property
    def dt(self) -> float: ...
    @property
    def substeps(self) -> int: ...

@disjoint_base
class CartesianSequenceStepper:
    def __new__(
        cls,
        dmps: list[CartesianDmp] | CartesianSequenceStepper,
        dt: float | None = None,
        options: _StepperOptions | None = None,
        obstacles: NDArray[np.float64] | None = None,
        obstacle_gain: float | None = None,
        obstacle_beta: float | None = None,
    ) -> Self: ...
    def __copy__(self) -> Self: ...
    def __deepcopy__(self, memo: object) -> Self: ...
    def step(self, measured: object | None = None, coupling: object | None = None) -> _StepOutput: ...
    def reset(self, start: object | None = None) -> None: ...
    def set_goal(self, goal: object) -> None: ...
    def set_tau(self, tau: float) -> None: ...
    def done(self) -> bool: ...
    def over_limit(self) -> bool: ...
    def blocked(self) -> bool: ...
    @property
    def active(self) -> int: ...
    @property
    def output(self) -> _StepOutput: ...
    @property
    def phase(self) -> float: ...
    @property
    def tau(self) -> float: ...
    @property
    def nominal_tau(self) -> float: ...
    @property
    def steps(self) -> int: ...
    @property
    def goal(self) -> NDArray[np.float64]: ...
    @property
    def goal_target(self) -> NDArray[np.float64]: ...
    @property
    def obstacles(self) -> NDArray[np.float64]: ...
    @property
    def dt(self) -> float: ...
    @property
    def substeps(self) -> int: ...

def cartesian_sequence_rollout(
    dmps: list[CartesianDmp], dt: float, duration: float | None = None, until_rest: bool = False,
    rest_tol: float = 1e-4,
) -> _CartesianArrays: ...

# The ask/tell learners of crates/learners; built and documented by dmprs.learners. An option
# left at None takes the default of the core's config struct.
_Trial: TypeAlias = tuple[NDArray[np.float64], NDArray[np.float64], float]
_Vector: TypeAlias = NDArray[np.float64]

class _AskTell:
    """What every learner class offers (crates/py-bindings/src/learners.rs)."""

    def ask(self) -> NDArray[np.float64]: ...
    def tell(self, q: NDArray[np.float64], feedback: NDArray[np.float64]) -> None: ...
    @property
    def dim(self) -> int: ...
    @property
    def status(self) -> str: ...
    @property
    def status_detail(self) -> str: ...
    @property
    def converged(self) -> bool: ...
    @property
    def n_told(self) -> int: ...
    @property
    def best(self) -> _Trial | None: ...
    @property
    def history(self) -> list[_Trial]: ...

@final
class ErrorLearning(_AskTell):
    def __new__(
        cls,
        q0: _Vector,
        *,
        low: _Vector | None = None,
        high: _Vector | None = None,
        gain: float | NDArray[np.float64] | None = None,
        weighted: bool | None = None,
        scale: float | None = None,
        jacobian: str | float | NDArray[np.float64] | None = None,
        delta: float | None = None,
        tol: float | None = None,
        max_trials: int | None = None,
        pin_limit: int | None = None,
        broyden: bool | None = None,
        trust_radius: float | None = None,
    ) -> ErrorLearning: ...
    @property
    def jacobian(self) -> NDArray[np.float64]: ...

@final
class GoldenSection(_AskTell):
    def __new__(
        cls,
        q0: _Vector,
        *,
        low: _Vector | None = None,
        high: _Vector | None = None,
        mode: str | None = None,
        tol: float | None = None,
        q_tol: float | None = None,
        max_trials: int | None = None,
        max_expansions: int | None = None,
        noise: float | None = None,
        max_repeats: int | None = None,
    ) -> GoldenSection: ...
    @property
    def bracket(self) -> tuple[float, float]: ...
    @property
    def reopened(self) -> int: ...

@final
class IllinoisRootFinder(_AskTell):
    def __new__(
        cls,
        q0: _Vector,
        *,
        low: _Vector | None = None,
        high: _Vector | None = None,
        tol: float | None = None,
        q_tol: float | None = None,
        max_trials: int | None = None,
        max_expansions: int | None = None,
    ) -> IllinoisRootFinder: ...
    @property
    def bracket(self) -> tuple[float, float]: ...
    @property
    def expansions(self) -> tuple[int, int]: ...

@final
class PolicyGradient(_AskTell):
    def __new__(
        cls,
        q0: _Vector,
        *,
        low: _Vector | None = None,
        high: _Vector | None = None,
        alpha0: float | None = None,
        decay: float | None = None,
        delta: float | None = None,
        scale: float | None = None,
        evaluate_center: bool | None = None,
        tol: float | None = None,
        max_trials: int | None = None,
        pin_limit: int | None = None,
    ) -> PolicyGradient: ...
    @property
    def center(self) -> NDArray[np.float64]: ...

@final
class PoWER(_AskTell):
    def __new__(
        cls,
        theta0: _Vector,
        sigma: _Vector,
        *,
        seed: int | None = None,
        n_best: int | None = None,
        adapt_variance: bool | None = None,
        variance_window: int | None = None,
        target_return: float | None = None,
        max_trials: int | None = None,
    ) -> PoWER: ...
    @property
    def mean(self) -> NDArray[np.float64]: ...
    @property
    def variance(self) -> NDArray[np.float64]: ...

@final
class PI2(_AskTell):
    def __new__(
        cls,
        theta0: _Vector,
        sigma: _Vector,
        *,
        seed: int | None = None,
        n_rollouts: int | None = None,
        n_reuse: int | None = None,
        h: float | None = None,
        n_updates: int | None = None,
        n_dof: int | None = None,
        n_steps: int | None = None,
        alpha_x: float | None = None,
        width_factor: float | None = None,
        projection: bool | None = None,
        cost_tol: float | None = None,
        max_trials: int | None = None,
    ) -> PI2: ...
    @property
    def theta(self) -> NDArray[np.float64]: ...
    @property
    def n_updates_done(self) -> int: ...
    @property
    def asked_evaluation(self) -> bool: ...

@final
class MatchboxConfig:
    def __new__(
        cls,
        *,
        box_size: tuple[float, float, float] | None = None,
        box_mass: float | None = None,
        overhang: float | None = None,
        friction: float | None = None,
        restitution: float | None = None,
        finger_radius: float | None = None,
        dt: float | None = None,
        solver_iterations: int | None = None,
        settle_time: float | None = None,
        delta_t: float | None = None,
        upright_tolerance: float | None = None,
        upright_hold: float | None = None,
    ) -> MatchboxConfig: ...
    def to_dict(self) -> dict[str, object]: ...
    def default_strike(self) -> tuple[tuple[float, float], tuple[float, float]]: ...

def matchbox_check(
    t: NDArray[np.float64], x: NDArray[np.float64], z: NDArray[np.float64], config: MatchboxConfig
) -> list[str]: ...
def matchbox_simulate(
    t: NDArray[np.float64], x: NDArray[np.float64], z: NDArray[np.float64], config: MatchboxConfig
) -> dict[str, object]: ...
def matchbox_simulate_batch(
    paths: list[tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]],
    config: MatchboxConfig,
) -> list[dict[str, object]]: ...
def portable_unary(name: str, x: NDArray[np.float64]) -> NDArray[np.float64]: ...
def portable_binary(name: str, x: NDArray[np.float64], y: NDArray[np.float64]) -> NDArray[np.float64]: ...
def portable_norm(x: NDArray[np.float64]) -> float: ...
def dls_step(
    jac: NDArray[np.float64], e: NDArray[np.float64], z: NDArray[np.float64], damping: float
) -> NDArray[np.float64]: ...
@final
class GaussianProcess:
    @staticmethod
    def fit(
        x: NDArray[np.float64],
        y: NDArray[np.float64],
        *,
        length_scale: NDArray[np.float64] | None,
        signal_var: float | None,
        noise_var: float | None,
        optimize: bool,
        n_restarts: int,
        length_scale_bounds: NDArray[np.float64] | None,
        signal_var_bounds: tuple[float, float] | None,
        noise_var_bounds: tuple[float, float] | None,
        max_iter: int,
    ) -> GaussianProcess: ...
    def predict(
        self, x: NDArray[np.float64], return_std: bool = False
    ) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]: ...
    def log_marginal_likelihood_at(
        self, theta: NDArray[np.float64]
    ) -> tuple[float, NDArray[np.float64]]: ...
    @property
    def log_marginal_likelihood(self) -> float: ...
    @property
    def length_scale(self) -> NDArray[np.float64]: ...
    @property
    def signal_var(self) -> float: ...
    @property
    def noise_var(self) -> float: ...
    @property
    def prior_mean(self) -> float: ...
    @property
    def n_dim(self) -> int: ...
    @property
    def n_train(self) -> int: ...

_DemoArrays: TypeAlias = tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None, NDArray[np.float64] | None
]

@final
class Generalizer:
    def __new__(
        cls,
        queries: NDArray[np.float64],
        demos: list[_DemoArrays],
        method: str,
        n_basis: int,
        constants: _Constants,
        options: _GeneralizerOptions,
        final_velocity: bool = False,
    ) -> Generalizer: ...
    def predict(self, q: NDArray[np.float64]) -> Dmp: ...
    def parameters(self, q: NDArray[np.float64]) -> NDArray[np.float64]: ...
    def jacobian(self, q: NDArray[np.float64], rel_step: float) -> NDArray[np.float64]: ...
    @property
    def demo_dmps(self) -> list[Dmp]: ...
    @property
    def method(self) -> str: ...
    @property
    def n_query(self) -> int: ...
    @property
    def n_dof(self) -> int: ...
    @property
    def n_demos(self) -> int: ...
    @property
    def n_basis(self) -> int: ...
    @property
    def n_parameters(self) -> int: ...
    @property
    def tau_bounds(self) -> tuple[float, float]: ...

_PoseDemoArrays: TypeAlias = tuple[
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64] | None,
    NDArray[np.float64] | None,
    NDArray[np.float64] | None,
    NDArray[np.float64] | None,
]

@final
class CartesianGeneralizer:
    """crates/dmp-core/src/cartesian_generalize.rs; built and documented by dmprs.Generalizer.
    Demos are (t, pose, velocity, acceleration, angular_velocity, angular_acceleration).
    """

    def __new__(
        cls,
        queries: NDArray[np.float64],
        demos: list[_PoseDemoArrays],
        method: str,
        n_basis: int,
        constants: _Constants,
        options: _GeneralizerOptions,
        final_velocity: bool = False,
    ) -> CartesianGeneralizer: ...
    def predict(self, q: NDArray[np.float64]) -> CartesianDmp: ...
    def parameters(self, q: NDArray[np.float64]) -> NDArray[np.float64]: ...
    def jacobian(self, q: NDArray[np.float64], rel_step: float) -> NDArray[np.float64]: ...
    @property
    def demo_dmps(self) -> list[CartesianDmp]: ...
    @property
    def method(self) -> str: ...
    @property
    def n_query(self) -> int: ...
    @property
    def n_dof(self) -> int: ...
    @property
    def n_demos(self) -> int: ...
    @property
    def n_basis(self) -> int: ...
    @property
    def n_parameters(self) -> int: ...
    @property
    def tau_bounds(self) -> tuple[float, float]: ...

@final
class PeriodicGeneralizer:
    """crates/dmp-core/src/periodic_generalize.rs; built and documented by dmprs.Generalizer
    (periodic=True). Each demo has its period (None: its duration).
    """

    def __new__(
        cls,
        queries: NDArray[np.float64],
        demos: list[_DemoArrays],
        periods: list[float | None],
        method: str,
        n_basis: int,
        constants: _Constants,
        options: _GeneralizerOptions,
    ) -> PeriodicGeneralizer: ...
    def predict(self, q: NDArray[np.float64]) -> PeriodicDmp: ...
    def parameters(self, q: NDArray[np.float64]) -> NDArray[np.float64]: ...
    def jacobian(self, q: NDArray[np.float64], rel_step: float) -> NDArray[np.float64]: ...
    @property
    def demo_dmps(self) -> list[PeriodicDmp]: ...
    @property
    def method(self) -> str: ...
    @property
    def n_query(self) -> int: ...
    @property
    def n_dof(self) -> int: ...
    @property
    def n_demos(self) -> int: ...
    @property
    def n_basis(self) -> int: ...
    @property
    def n_parameters(self) -> int: ...
    @property
    def tau_bounds(self) -> tuple[float, float]: ...

@final
class RobotTrajectory:
    @property
    def stamp(self) -> float: ...
    @property
    def times(self) -> NDArray[np.float64]: ...
    @property
    def positions(self) -> NDArray[np.float64]: ...
    @property
    def velocities(self) -> NDArray[np.float64] | None: ...
    @property
    def accelerations(self) -> NDArray[np.float64] | None: ...

@final
class RobotGoal:
    @property
    def id(self) -> bytes: ...
    @property
    def trajectory(self) -> RobotTrajectory: ...
    @property
    def goal_time_tolerance(self) -> float: ...
    @property
    def path_tolerance(self) -> list[tuple[str, float, float, float]]: ...
    @property
    def goal_tolerance(self) -> list[tuple[str, float, float, float]]: ...

@final
class RobotNode:
    def __new__(
        cls,
        domain_id: int,
        controller: str,
        joint_names: list[str],
        *,
        node_name: str = "dmprs_robot",
        namespace: str = "/",
        command_topic: str = "/forward_position_controller/commands",
        cartesian_controller: str = "/cartesian_motion_controller",
        float_signals: list[str] = ...,
        point_signals: list[str] = ...,
        loopback_only: bool = True,
    ) -> RobotNode: ...
    @property
    def joint_names(self) -> list[str]: ...
    def poll_goal(self, timeout: float) -> RobotGoal | None: ...
    def poll_rejections(self) -> list[tuple[bytes | None, str]]: ...
    def poll_cancels(self) -> list[bytes]: ...
    def poll_trajectories(self) -> list[RobotTrajectory]: ...
    def poll_commands(self) -> NDArray[np.float64]: ...
    def poll_poses(self) -> tuple[NDArray[np.float64], NDArray[np.float64], list[str]]: ...
    def publish_pose(self, stamp: float, pose: NDArray[np.float64], frame_id: str = "base_link") -> None: ...
    def publish_joint_state(
        self, stamp: float, position: NDArray[np.float64], velocity: NDArray[np.float64] | None = None
    ) -> None: ...
    def publish_feedback(
        self,
        goal_id: bytes,
        stamp: float,
        desired: NDArray[np.float64],
        actual: NDArray[np.float64],
        desired_velocity: NDArray[np.float64] | None = None,
        actual_velocity: NDArray[np.float64] | None = None,
        time_from_start: float = 0.0,
    ) -> None: ...
    def finish_goal(self, goal_id: bytes, status: int, error_code: int = 0, error_string: str = "") -> None: ...
    def publish_signal(self, topic: str, value: float | list[float], stamp: float) -> None: ...
    def publish_clock(self, seconds: float) -> None: ...
    def shutdown(self) -> None: ...

@final
class Ros2GoalClient:
    def __new__(cls, domain_id: int, action: str, loopback_only: bool = True) -> Ros2GoalClient: ...
    def wait_for_server(self, timeout: float) -> bool: ...
    def send_goal(
        self, joint_names: list[str], times: NDArray[np.float64], positions: NDArray[np.float64], timeout: float
    ) -> bool | None: ...

@final
class Ros2JointStateListener:
    def __new__(
        cls, domain_id: int, topic: str = "/joint_states", depth: int = 1000, loopback_only: bool = True
    ) -> Ros2JointStateListener: ...
    def count(self) -> int: ...
    def stop(self) -> NDArray[np.float64]: ...
