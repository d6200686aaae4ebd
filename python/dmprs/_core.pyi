# Type stubs for the Rust extension dmprs._core (crates/py-bindings). The documented API is in
# dmprs.dmp; these low-level entry points take arrays that are already float64 and C-contiguous.
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
