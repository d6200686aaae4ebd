import numpy as np
import pytest


def min_jerk(s: np.ndarray) -> np.ndarray:
    return 10 * s**3 - 15 * s**4 + 6 * s**5


@pytest.fixture
def demo() -> tuple[np.ndarray, np.ndarray]:
    """A smooth 3-DOF, 1 s demonstration that starts and ends at rest."""
    t = np.linspace(0.0, 1.0, 1001)
    s = min_jerk(t)
    y = np.stack([s, 0.5 - 2.0 * s, 0.3 * np.sin(np.pi * t) ** 2], axis=1)
    return t, y
