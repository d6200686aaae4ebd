"""Crash-safe files: atomic writes and append-only JSON lines.

A finished trial must survive a crash or Ctrl-C at any later moment, so every write is either
atomic (temp file in the same directory, fsync, rename, fsync of the directory) or an append of
one complete line followed by flush and fsync.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import tempfile
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

try:
    import fcntl
except ImportError:  # Windows: no advisory locks; concurrent saves there are not serialized
    fcntl = None  # type: ignore[assignment]

import numpy as np


def _fsync_dir(path: Path) -> None:
    """Makes a rename durable; not possible (nor needed) on every platform."""
    try:
        fd = os.open(path, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


LOCK_FILE = ".dmprs.lock"


@contextlib.contextmanager
def directory_lock(directory: Path, *, shared: bool) -> Iterator[None]:
    """Holds an advisory lock (``flock``) on ``directory/.dmprs.lock`` for the ``with`` block:
    exclusive for a writer, shared for readers, so concurrent saves into one directory take turns
    and a reader sees the files of one save, never a mix of two. Where the lock file cannot be
    created (a read-only directory: nobody can be writing there) it reads without one."""
    if fcntl is None:
        yield
        return
    try:
        fd = os.open(Path(directory) / LOCK_FILE, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError:
        if not shared:
            raise
        yield
        return
    try:
        fcntl.flock(fd, fcntl.LOCK_SH if shared else fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


def write_atomic(path: Path, data: bytes) -> None:
    """Writes ``data`` to ``path`` so that readers see the old file or the new one, never a mix."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise
    _fsync_dir(path.parent)


def write_npz_atomic(path: Path, arrays: Mapping[str, Any]) -> bytes:
    """Saves arrays as an uncompressed .npz atomically; returns the bytes written (for hashing)."""
    buf = io.BytesIO()
    savez: Any = np.savez  # numpy's stub types the keyword arrays as its own options
    savez(buf, **{k: np.asarray(v) for k, v in arrays.items()})
    data = buf.getvalue()
    write_atomic(path, data)
    return data


_NON_FINITE = {"NaN": float("nan"), "Infinity": float("inf"), "-Infinity": float("-inf")}


def strict_json(value: Any) -> Any:
    """``value`` with every NaN or infinity replaced by the string ``"NaN"``, ``"Infinity"`` or
    ``"-Infinity"``: strict JSON parsers reject the bare tokens Python writes for them."""
    if isinstance(value, float) and not np.isfinite(value):
        return "NaN" if np.isnan(value) else ("Infinity" if value > 0 else "-Infinity")
    if isinstance(value, Mapping):
        return {k: strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict_json(v) for v in value]
    return value


def float_from_json(value: Any) -> Any:
    """Inverse of :func:`strict_json` for one number: the three strings back to floats."""
    return _NON_FINITE.get(value, value) if isinstance(value, str) else value


def append_jsonl(path: Path, record: Mapping[str, Any]) -> None:
    """Appends one JSON object as one line (strict JSON: see :func:`strict_json`) and forces it
    to disk."""
    line = json.dumps(strict_json(record), separators=(",", ":"), allow_nan=False) + "\n"
    with open(path, "a", encoding="utf-8") as f:
        f.write(line)
        f.flush()
        os.fsync(f.fileno())


def read_jsonl(path: Path) -> tuple[list[dict[str, Any]], str | None]:
    """Reads complete lines; returns them and a description of a cut last line, if any.

    Only the last line may be incomplete (a crash mid-append); a bad line elsewhere means the
    file is not ours and raises ``ValueError`` naming the line.
    """
    text = Path(path).read_text(encoding="utf-8")
    lines = text.split("\n")
    records: list[dict[str, Any]] = []
    cut = None
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        last = i == len(lines) - 1  # no newline after it: the write may have been cut
        try:
            value = json.loads(line)
            if not isinstance(value, dict):
                raise ValueError("not a JSON object")  # noqa: TRY004 - a bad line, handled below as one
        except ValueError as exc:
            if last:
                cut = f"line {i + 1} of {path} was cut mid-write ({len(line)} bytes) and is ignored"
                break
            raise ValueError(f"{path}, line {i + 1}: not a JSON record ({exc})") from None
        records.append(value)
    return records, cut


def truncate_cut_line(path: Path) -> None:
    """Drops an incomplete last line so that appends start on a fresh line."""
    data = Path(path).read_bytes()
    if data and not data.endswith(b"\n"):
        keep = data.rfind(b"\n") + 1
        with open(path, "r+b") as f:
            f.truncate(keep)
            f.flush()
            os.fsync(f.fileno())
