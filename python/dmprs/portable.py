"""Elementwise maths, norms and small products whose bits are the same on every machine.

Use these, not numpy's, wherever a value feeds a chaotic simulator (granular liquid, a strike)
or a learner's branch. numpy chooses its kernels by the CPU at run time: on AVX-512 its own
``exp``, ``log``, ``sin``, ``cos``, ``power`` and ``arctan2`` (and on AVX2 ``tanh``) differ in
the last bit from its portable loops, and ``@``, ``np.dot``, ``np.linalg.norm`` of a vector and
``np.linalg.solve`` run through the BLAS kernel chosen for the CPU. The granular flow turns one
differing bit into a different pour, and so a different trial count. Here the functions are
libm's (a pure-Rust port of musl's, in the Rust core) and the sums run in a fixed order.
Arithmetic (``+ - * /``, ``sqrt``), comparisons, sums along an axis and ``np.interp`` are exact
or fixed-order in numpy already and need nothing from here.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import _core


def _unary(name: str, x: ArrayLike) -> NDArray[np.float64]:
    a = np.asarray(x, dtype=np.float64)
    return _core.portable_unary(name, np.ascontiguousarray(a)).reshape(a.shape)


def _binary(name: str, x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
    a, b = np.broadcast_arrays(np.asarray(x, dtype=np.float64), np.asarray(y, dtype=np.float64))
    out = _core.portable_binary(name, np.ascontiguousarray(a), np.ascontiguousarray(b))
    return out.reshape(a.shape)


def sin(x: ArrayLike) -> NDArray[np.float64]:
    """``sin(x)`` elementwise."""
    return _unary("sin", x)


def cos(x: ArrayLike) -> NDArray[np.float64]:
    """``cos(x)`` elementwise."""
    return _unary("cos", x)


def arccos(x: ArrayLike) -> NDArray[np.float64]:
    """``arccos(x)`` elementwise (NaN outside [-1, 1])."""
    return _unary("arccos", x)


def exp(x: ArrayLike) -> NDArray[np.float64]:
    """``exp(x)`` elementwise."""
    return _unary("exp", x)


def arctan2(y: ArrayLike, x: ArrayLike) -> NDArray[np.float64]:
    """``arctan2(y, x)`` elementwise, broadcast."""
    return _binary("arctan2", y, x)


def hypot(x: ArrayLike, y: ArrayLike) -> NDArray[np.float64]:
    """``sqrt(x^2 + y^2)`` elementwise without overflow, broadcast."""
    return _binary("hypot", x, y)


def norm(v: ArrayLike) -> float:
    """The Euclidean norm of a vector (flattened), summed in index order."""
    return _core.portable_norm(np.ascontiguousarray(v, dtype=np.float64).ravel())


def norms(v: ArrayLike) -> NDArray[np.float64]:
    """The Euclidean norm of each row of ``v`` (..., n)."""
    a = np.asarray(v, dtype=np.float64)
    return np.sqrt(np.sum(a * a, axis=-1))


def matvec_rows(points: ArrayLike, matrix: ArrayLike) -> NDArray[np.float64]:
    """``points @ matrix.T``: each row p of ``points`` (n, k) mapped to ``matrix @ p``
    (``matrix``: (r, k)), summed over k in order.
    """
    p = np.asarray(points, dtype=np.float64)
    m = np.asarray(matrix, dtype=np.float64)
    out = p[:, :1] * m[:, 0]
    for k in range(1, m.shape[1]):
        out = out + p[:, k:k + 1] * m[:, k]
    return out


def combine(weights: ArrayLike, rows: ArrayLike) -> NDArray[np.float64]:
    """``weights @ rows``: the sum of ``weights[i] * rows[i]`` over i in order."""
    w = np.asarray(weights, dtype=np.float64)
    r = np.asarray(rows, dtype=np.float64)
    out = w[0] * r[0]
    for i in range(1, len(w)):
        out = out + w[i] * r[i]
    return out


def inverses(matrices: ArrayLike) -> NDArray[np.float64]:
    """The inverses of a stack of square matrices (..., n, n) by Gauss-Jordan elimination with
    partial pivoting, elementwise over the stack (a singular matrix gives non-finite entries).
    """
    a = np.array(matrices, dtype=np.float64)
    n = a.shape[-1]
    aug = np.concatenate([a, np.broadcast_to(np.eye(n), a.shape)], axis=-1)
    stack = np.arange(int(np.prod(a.shape[:-2], dtype=np.int64))).reshape(a.shape[:-2])
    with np.errstate(all="ignore"):
        for c in range(n):
            pivot = c + np.argmax(np.abs(aug[..., c:, c]), axis=-1)
            rows = aug[stack, pivot].copy()
            aug[stack, pivot] = aug[..., c, :]
            aug[..., c, :] = rows / rows[..., c:c + 1]
            for r in range(n):
                if r != c:
                    aug[..., r, :] = aug[..., r, :] - aug[..., r, c:c + 1] * aug[..., c, :]
    return aug[..., n:]
