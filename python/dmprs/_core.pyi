# Type stubs for the Rust extension dmprs._core (crates/py-bindings). The documented API is in
# dmprs.dmp; these low-level entry points take arrays that are already float64 and C-contiguous.
from typing import Any, final

import numpy as np
from numpy.typing import NDArray

__version__: str

_TrajectoryArrays = tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]
]

class Dmp:
    def __new__(
        cls,
        weights: NDArray[np.float64],
        goal: NDArray[np.float64],
        y0: NDArray[np.float64],
        tau: float,
        *,
        alpha_z: float,
        beta_z: float,
        alpha_x: float,
        width_factor: float,
    ) -> Dmp: ...
    @staticmethod
    def fit(
        t: NDArray[np.float64],
        y: NDArray[np.float64],
        yd: NDArray[np.float64] | None,
        ydd: NDArray[np.float64] | None,
        *,
        n_basis: int,
        alpha_z: float,
        beta_z: float,
        alpha_x: float,
        width_factor: float,
    ) -> Dmp: ...
    def rollout(
        self, dt: float, duration: float | None = None, until_rest: bool = False, rest_tol: float = 1e-4
    ) -> _TrajectoryArrays: ...
    def with_goal(self, goal: NDArray[np.float64]) -> Dmp: ...
    def with_start(self, y0: NDArray[np.float64]) -> Dmp: ...
    def with_tau(self, tau: float) -> Dmp: ...
    @property
    def weights(self) -> NDArray[np.float64]: ...
    @property
    def goal(self) -> NDArray[np.float64]: ...
    @property
    def y0(self) -> NDArray[np.float64]: ...
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

def rollout_batch(
    dmps: list[Dmp],
    dt: float,
    duration: float | None = None,
    until_rest: bool = False,
    rest_tol: float = 1e-4,
) -> list[_TrajectoryArrays]: ...

_CartesianArrays = tuple[
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
    NDArray[np.float64],
]

@final
class CartesianDmp:
    """Position + unit-quaternion DMP of crates/dmp-core/src/cartesian.rs; documented by
    dmprs.cartesian. Rollouts give (t, position, quaternion, velocity, angular_velocity,
    acceleration, angular_acceleration)."""

    def __new__(
        cls,
        weights: NDArray[np.float64],
        goal: NDArray[np.float64],
        start: NDArray[np.float64],
        tau: float,
        *,
        alpha_z: float,
        beta_z: float,
        alpha_x: float,
        width_factor: float,
    ) -> CartesianDmp: ...
    @staticmethod
    def fit(
        t: NDArray[np.float64],
        pose: NDArray[np.float64],
        velocity: NDArray[np.float64] | None,
        acceleration: NDArray[np.float64] | None,
        angular_velocity: NDArray[np.float64] | None,
        angular_acceleration: NDArray[np.float64] | None,
        *,
        normalize: bool,
        n_basis: int,
        alpha_z: float,
        beta_z: float,
        alpha_x: float,
        width_factor: float,
    ) -> CartesianDmp: ...
    def rollout(
        self, dt: float, duration: float | None = None, until_rest: bool = False, rest_tol: float = 1e-4
    ) -> _CartesianArrays: ...
    def with_goal(self, goal: NDArray[np.float64]) -> CartesianDmp: ...
    def with_start(self, start: NDArray[np.float64]) -> CartesianDmp: ...
    def with_tau(self, tau: float) -> CartesianDmp: ...
    @property
    def weights(self) -> NDArray[np.float64]: ...
    @property
    def goal(self) -> NDArray[np.float64]: ...
    @property
    def start(self) -> NDArray[np.float64]: ...
    @property
    def tau(self) -> float: ...
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

def rollout_batch_cartesian(
    dmps: list[CartesianDmp],
    dt: float,
    duration: float | None = None,
    until_rest: bool = False,
    rest_tol: float = 1e-4,
) -> list[_CartesianArrays]: ...

class Learner:
    """Every ask/tell learner of crates/learner; built and documented by dmprs.learners."""

    @staticmethod
    def error_learning(
        q0: NDArray[np.float64],
        gain: NDArray[np.float64],
        weighted: bool,
        scale: float,
        jacobian: str,
        jacobian_matrix: NDArray[np.float64] | None,
        delta: float,
        low: NDArray[np.float64] | None,
        high: NDArray[np.float64] | None,
        tol: float,
        max_trials: int,
        pin_limit: int,
    ) -> Learner: ...
    @staticmethod
    def golden(
        q0: float, low: float, high: float, mode: str, tol: float, q_tol: float, max_trials: int, max_expansions: int
    ) -> Learner: ...
    @staticmethod
    def root_finder(q0: float, low: float, high: float, tol: float, q_tol: float, max_trials: int) -> Learner: ...
    @staticmethod
    def policy_gradient(
        q0: NDArray[np.float64],
        alpha0: float,
        decay: float,
        delta: float,
        scale: float,
        evaluate_center: bool,
        low: NDArray[np.float64] | None,
        high: NDArray[np.float64] | None,
        tol: float,
        max_trials: int,
        pin_limit: int,
    ) -> Learner: ...
    @staticmethod
    def power(
        theta0: NDArray[np.float64],
        sigma: NDArray[np.float64],
        n_best: int,
        adapt_variance: bool,
        variance_window: int,
        target_return: float | None,
        max_trials: int,
        seed: int,
    ) -> Learner: ...
    @staticmethod
    def pi2(
        theta0: NDArray[np.float64],
        sigma: NDArray[np.float64],
        n_rollouts: int,
        n_reuse: int,
        h: float,
        n_updates: int,
        n_dof: int,
        n_steps: int,
        alpha_x: float,
        width_factor: float,
        projection: bool,
        cost_tol: float | None,
        max_trials: int,
        seed: int,
    ) -> Learner: ...
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
    def best(self) -> tuple[NDArray[np.float64], NDArray[np.float64], float] | None: ...
    @property
    def history(self) -> list[tuple[NDArray[np.float64], NDArray[np.float64], float]]: ...
    def state(self) -> dict[str, Any]: ...

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

_DemoArrays = tuple[
    NDArray[np.float64], NDArray[np.float64], NDArray[np.float64] | None, NDArray[np.float64] | None
]

class Generalizer:
    def __new__(
        cls,
        queries: NDArray[np.float64],
        demos: list[_DemoArrays],
        method: str,
        *,
        n_basis: int,
        alpha_z: float,
        beta_z: float,
        alpha_x: float,
        width_factor: float,
        kernel: str,
        bandwidth: float,
        ridge: float,
        interpolate: bool,
        gp_noise: float,
        gp_optimize: bool | None,
        gp_restarts: int,
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

_PoseDemoArrays = tuple[
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
    Demos are (t, pose, velocity, acceleration, angular_velocity, angular_acceleration)."""

    def __new__(
        cls,
        queries: NDArray[np.float64],
        demos: list[_PoseDemoArrays],
        method: str,
        *,
        n_basis: int,
        alpha_z: float,
        beta_z: float,
        alpha_x: float,
        width_factor: float,
        kernel: str,
        bandwidth: float,
        ridge: float,
        interpolate: bool,
        gp_noise: float,
        gp_optimize: bool | None,
        gp_restarts: int,
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
