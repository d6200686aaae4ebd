"""Input conversion at the Python boundary: anything array-like becomes a C-contiguous float64
array of the expected rank, or a clear :class:`~dmprs.errors.InvalidInputError`.

Integer and lower-precision float inputs are converted; booleans, complex numbers, strings and
objects are rejected (silently turning them into floats hides mistakes).
"""

from __future__ import annotations

import math
import operator
from typing import Any

import numpy as np
from numpy.typing import NDArray

from dmprs.errors import InvalidInputError

_ACCEPTED_KINDS = {"f": "float", "i": "integer", "u": "unsigned integer"}


def as_float_array(value: Any, name: str, ndim: int | tuple[int, ...]) -> NDArray[np.float64]:
    """``value`` as a C-contiguous float64 array whose rank is ``ndim`` (or one of them)."""
    if value is None:
        raise InvalidInputError(f"{name} is None; expected an array of numbers")
    try:
        arr = np.asarray(value)
    except (ValueError, TypeError) as exc:  # ragged nested lists and the like
        raise InvalidInputError(f"{name} cannot be read as an array: {exc}") from None
    if arr.dtype.kind not in _ACCEPTED_KINDS:
        raise InvalidInputError(
            f"{name} has dtype {arr.dtype}; expected real numbers (float or integer)"
        )
    allowed = (ndim,) if isinstance(ndim, int) else ndim
    if arr.ndim not in allowed:
        want = " or ".join(f"{d}-D" for d in allowed)
        raise InvalidInputError(f"{name} must be {want}; got a {arr.ndim}-D array of shape {arr.shape}")
    return np.ascontiguousarray(arr, dtype=np.float64)


def check_finite(arr: NDArray[np.float64], name: str) -> None:
    """Raises naming the first NaN or inf, in the same words as the Rust core."""
    bad = ~np.isfinite(arr)
    if bad.any():
        idx = tuple(int(i) for i in np.argwhere(bad)[0])
        where = "[" + ", ".join(map(str, idx)) + "]"
        raise InvalidInputError(f"{name}{where} is {float(arr[idx])}: all values must be finite")


def check_increasing(t: NDArray[np.float64], name: str = "t") -> None:
    """Raises naming the first sample time that does not exceed the one before it."""
    check_finite(t, name)
    steps = np.diff(t)
    if (steps <= 0).any():
        j = int(np.argmax(steps <= 0)) + 1
        raise InvalidInputError(
            f"{name} must be strictly increasing, but {name}[{j}] = {t[j]:.6g} is not greater than "
            f"{name}[{j - 1}] = {t[j - 1]:.6g}"
        )


# The largest count the Rust core can take (a u64 there); larger ones are certainly mistakes.
_MAX_COUNT = 2**63 - 1


def short(value: Any) -> str:
    """``repr(value)`` cut to 60 characters, for messages about what a caller passed."""
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


def as_count(value: Any, name: str, minimum: int) -> int:
    """An integer parameter such as ``n_basis``, at least ``minimum`` (booleans are refused)."""
    if isinstance(value, (bool, np.bool_)):
        raise InvalidInputError(f"{name} must be an integer; got {value!r}")
    try:
        n = operator.index(value)
    except TypeError:
        raise InvalidInputError(f"{name} must be an integer; got {short(value)}") from None
    if n < minimum:
        raise InvalidInputError(f"{name} = {n} is invalid: must be at least {minimum}")
    if n > _MAX_COUNT:
        raise InvalidInputError(f"{name} = {short(n)} is invalid: far too large (at most 2**63 - 1)")
    return n


def as_scalar(value: Any, name: str, *, positive: bool = False) -> float:
    """A finite real scalar (strictly positive if asked). Numbers only: a string such as
    ``"0.01"`` is refused rather than parsed, and so are booleans.
    """
    numeric = isinstance(value, (int, float, np.number)) or (
        isinstance(value, np.ndarray) and value.ndim == 0 and value.dtype.kind in "fiu"
    )
    if not numeric or isinstance(value, (bool, np.bool_)):
        raise InvalidInputError(f"{name} must be a real number; got {short(value)}")
    try:
        x = float(value)
    except (TypeError, ValueError):
        raise InvalidInputError(f"{name} must be a real number; got {short(value)}") from None
    except OverflowError:
        raise InvalidInputError(f"{name} = {short(value)} is invalid: too large for a float") from None
    if not math.isfinite(x):
        raise InvalidInputError(f"{name} is {x}: all values must be finite")
    if positive and x <= 0:
        raise InvalidInputError(f"{name} = {x:g} is invalid: must be > 0")
    return x


def as_flag(value: Any, name: str) -> bool:
    """A boolean parameter: ``True`` or ``False`` (numpy's too), not a string such as ``"no"``."""
    if not isinstance(value, (bool, np.bool_)):
        raise InvalidInputError(f"{name} must be True or False; got {short(value)}")
    return bool(value)


def as_query(value: Any, name: str, query_names: tuple[str, ...]) -> NDArray[np.float64]:
    """A task query: one finite value per query dimension (a scalar is fine for one)."""
    q = np.atleast_1d(as_float_array(value, name, (0, 1)))
    if q.shape != (len(query_names),):
        raise InvalidInputError(
            f"{name} has shape {q.shape}, expected ({len(query_names)},): one value per query "
            f"dimension {tuple(query_names)}"
        )
    check_finite(q, name)
    return q
