"""A job's memo of simulated pours, shared by its worker processes.

The pouring scenes are deterministic: the same commanded trajectory poured from the same settled
liquid gives the same pour, bit for bit. Many runs of one job pour the same thing (every learner of
a setting starts from the same generalized trial; some parts run a learner another part runs
too), so a job that names a folder in :data:`MEMO_DIR` has each pour simulated once and read back
by every later run that pours it, in any of its workers. Without it nothing is kept.

The folder belongs to one job (the code and the engines cannot change under it): its files are
keyed by the pour's inputs alone and are read by nothing else.
"""

from __future__ import annotations

import hashlib
import os
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from dmprs.sim.pour_record import PourRecord

#: the environment variable naming the job's memo folder (unset: no memo)
MEMO_DIR = "DMPRS_POUR_MEMO"

R = TypeVar("R", bound=PourRecord)


def _digest(inputs: tuple[Any, ...]) -> str:
    """A key of ``inputs``: arrays by dtype, shape and bytes, everything else by its repr."""
    h = hashlib.sha256()
    for x in inputs:
        if isinstance(x, np.ndarray):
            a = np.ascontiguousarray(x)
            h.update(f"{a.dtype.str}{a.shape}".encode())
            h.update(a.tobytes())
        else:
            h.update(repr(x).encode())
        h.update(b"\0")
    return h.hexdigest()[:32]


def memoized(scene: str, inputs: tuple[Any, ...], simulate: Callable[[], R | None]) -> R | None:
    """``simulate()``, or the pour it gave when this job last called it with the same ``scene``
    and ``inputs`` (everything the pour depends on). An interrupted pour (or None, a pour that
    did not start) is not kept.
    """
    folder = os.environ.get(MEMO_DIR)
    if not folder:
        return simulate()
    path = Path(folder) / f"{scene}-{_digest(inputs)}.pickle"
    try:
        kept: R = pickle.loads(path.read_bytes())  # written by this job's own workers only
    except FileNotFoundError:
        pass
    else:
        return kept
    result = simulate()
    if result is not None and not result.interrupted:
        # Written whole, then renamed: a worker reading it meanwhile sees all of it or nothing.
        part = path.with_name(f"{path.name}.{os.getpid()}.part")
        part.write_bytes(pickle.dumps(result, protocol=pickle.HIGHEST_PROTOCOL))
        os.replace(part, path)
    return result
