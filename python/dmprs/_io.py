"""The files dmprs reads and writes, in one place.

Reading trusts nothing (a file named by a user may be a FIFO, a device, a link to one, huge, or
crafted): :func:`open_regular` refuses anything but a regular file at once (without blocking),
sizes are bounded before anything is allocated (:func:`read_bytes`, :func:`load_npz` reads every
npy header first), and JSON is bounded in depth and in its numbers (:func:`parse_json`). Every
failure raises the caller's :class:`~dmprs.errors.DmprsError` subclass naming the file.

Writing is crash-safe, and never follows a symlink: a finished trial must survive a crash or
Ctrl-C at any later moment, so every write is either atomic (temp file in the same directory,
fsync, rename, fsync of the directory; the rename replaces a link rather than writing through
it) or an append of one complete line followed by flush and fsync, opened with ``O_NOFOLLOW``.
"""

from __future__ import annotations

import contextlib
import functools
import io
import json
import math
import os
import re
import stat
import tempfile
import zipfile
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import IO, Any

try:
    import fcntl
except ImportError:  # Windows: no advisory locks; concurrent saves there are not serialized
    fcntl = None  # type: ignore[assignment]

import numpy as np

from dmprs.errors import DmprsError, InvalidInputError

#: The exception class a reader raises: the caller's DmprsError subclass, built from a message.
ErrorClass = Callable[[str], DmprsError]

_O_NOFOLLOW = getattr(os, "O_NOFOLLOW", 0)
_O_NONBLOCK = getattr(os, "O_NONBLOCK", 0)
_O_CLOEXEC = getattr(os, "O_CLOEXEC", 0)

MiB = 2**20
#: A JSON file dmprs reads (manifests, run descriptions, query tables, dataset metadata) may
#: not be larger than this, nor nested deeper than :data:`JSON_MAX_DEPTH`.
JSON_MAX_BYTES = 256 * MiB
JSON_MAX_DEPTH = 64
#: Integers in JSON beyond this magnitude are refused (no count or index dmprs reads is larger).
JSON_MAX_INT = 2**63 - 1


# --- reading ------------------------------------------------------------------------------------


def _kind(mode: int) -> str:
    """What a non-regular file is, in words."""
    for test, name in ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
                       (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
                       (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return "not a regular file"


def open_regular(path: str | os.PathLike[str], *, what: str = "file",
                 error: ErrorClass = InvalidInputError) -> tuple[IO[bytes], int]:
    """Opens ``path`` for reading if it is a regular file (a link to one is fine) and returns the
    binary file and its size. A FIFO, a device, a socket or a directory (or a link to one) is
    refused at once: the open does not block (``O_NONBLOCK``) and the check is made on the opened
    file, so nothing can be swapped in between.
    """
    try:
        fd = os.open(path, os.O_RDONLY | _O_NONBLOCK | _O_CLOEXEC)
    except FileNotFoundError:
        raise error(f"{path}: no such {what}") from None
    except OSError as exc:
        raise error(f"{path}: cannot open the {what} ({exc.strerror or exc})") from None
    try:
        return _regular(fd, path, what, error)
    except BaseException:
        os.close(fd)
        raise


def _regular(fd: int, path: str | os.PathLike[str], what: str,
             error: ErrorClass) -> tuple[IO[bytes], int]:
    """The opened descriptor ``fd`` as a binary file and its size, if it is a regular file."""
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        raise error(f"{path}: is {_kind(st.st_mode)}; a {what} must be a regular file")
    if _O_NONBLOCK and fcntl is not None:  # regular files ignore it; keep reads plain
        fcntl.fcntl(fd, fcntl.F_SETFL, fcntl.fcntl(fd, fcntl.F_GETFL) & ~_O_NONBLOCK)
    return os.fdopen(fd, "rb"), st.st_size


def check_regular(path: str | os.PathLike[str], *, what: str = "file",
                  error: ErrorClass = InvalidInputError) -> int:
    """Raises unless ``path`` is a regular file (see :func:`open_regular`); returns its size. For
    paths that a third-party reader opens itself.
    """
    f, size = open_regular(path, what=what, error=error)
    f.close()
    return size


def check_directory(path: str | os.PathLike[str], *, what: str = "directory",
                    error: ErrorClass = InvalidInputError) -> Path:
    """``path`` as a Path if it is a directory (a link to one is fine), else a clear error."""
    p = Path(path)
    try:
        st = os.stat(p)
    except FileNotFoundError:
        raise error(f"{p}: no such {what}") from None
    except OSError as exc:
        raise error(f"{p}: cannot read the {what} ({exc.strerror or exc})") from None
    if not stat.S_ISDIR(st.st_mode):
        raise error(f"{p}: is {_kind(st.st_mode) if not stat.S_ISREG(st.st_mode) else 'a file'}; "
                    f"expected a {what}")
    return p


def read_bytes(path: str | os.PathLike[str], *, limit: int, what: str = "file",
               error: ErrorClass = InvalidInputError) -> bytes:
    """The contents of the regular file ``path``, refused (before reading) if larger than
    ``limit`` bytes.
    """
    f, size = open_regular(path, what=what, error=error)
    with f:
        if size > limit:
            raise error(f"{path}: {size} bytes, more than the {limit} bytes a {what} may have")
        try:
            data = f.read(limit + 1)  # the size may have changed since fstat
        except OSError as exc:
            raise error(f"{path}: cannot read the {what} ({exc.strerror or exc})") from None
    if len(data) > limit:
        raise error(f"{path}: more than the {limit} bytes a {what} may have")
    return data


def read_text(path: str | os.PathLike[str], *, limit: int, what: str = "file",
              error: ErrorClass = InvalidInputError, encoding: str = "utf-8") -> str:
    """The text of ``path`` (see :func:`read_bytes`); a byte that is not ``encoding`` is an error
    naming the encoding and the offset.
    """
    data = read_bytes(path, limit=limit, what=what, error=error)
    try:
        return data.decode(encoding)
    except UnicodeDecodeError as exc:
        raise error(f"{path}: not {encoding} text (byte {exc.start} is {data[exc.start:exc.start + 1]!r}); "
                    f"a {what} must be {encoding}-encoded") from None


def _bounded_int(text: str) -> int:
    if len(text.lstrip("-")) > 19 or abs(n := int(text)) > JSON_MAX_INT:
        raise ValueError(f"the integer {text[:24]}{'...' if len(text) > 24 else ''} is too large")
    return n


def _finite_float(text: str) -> float:
    x = float(text)
    if not np.isfinite(x):
        raise ValueError(f"the number {text[:24]} is too large for a float")
    return x


def _refuse_constant(text: str) -> Any:
    raise ValueError(f"{text} is not valid JSON (write non-finite numbers as strings)")


def _depth(value: Any) -> int:
    """Nesting depth of a parsed JSON value, iteratively (a deep value cannot overflow the stack)."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        v, d = stack.pop()
        if isinstance(v, (dict, list)):
            deepest = max(deepest, d)
            stack.extend((c, d + 1) for c in (v.values() if isinstance(v, dict) else v))
    return deepest


def parse_json(text: str, where: str, *, error: ErrorClass = InvalidInputError,
               max_depth: int = JSON_MAX_DEPTH) -> Any:
    """Strict, bounded JSON: no bare NaN or Infinity, integers within 64 bits, floats finite,
    nesting at most ``max_depth`` deep. ``where`` names the file (and line) in the error.
    """
    try:
        value = json.loads(text, parse_int=_bounded_int, parse_float=_finite_float,
                           parse_constant=_refuse_constant)
    except RecursionError:
        raise error(f"{where}: nested too deeply (at most {max_depth} levels)") from None
    except ValueError as exc:  # JSONDecodeError is a ValueError, so are the bounds above
        raise error(f"{where}: not valid JSON ({exc})") from None
    if _depth(value) > max_depth:
        raise error(f"{where}: nested too deeply (at most {max_depth} levels)")
    return value


def read_json(path: str | os.PathLike[str], *, what: str = "JSON file", error: ErrorClass = InvalidInputError,
              limit: int = JSON_MAX_BYTES) -> Any:
    """:func:`parse_json` of the UTF-8 text of the regular file ``path``."""
    return parse_json(read_text(path, limit=limit, what=what, error=error), str(path), error=error)


_NPY_HEADERS = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}
#: numpy's own bound on an npy header (read_array_header's max_header_size)
_NPY_HEADER_MAX = 10_000


@functools.lru_cache(maxsize=256)
def _npy_header(version: tuple[int, int], raw: bytes) -> tuple[tuple[int, ...], bool, np.dtype[Any]]:
    """numpy's parse of one npy header (its length field and text). Cached: numpy evaluates the
    header as a Python literal, which costs more than reading a small array, and the arrays of a
    database share a handful of headers.
    """
    shape, fortran, dtype = _NPY_HEADERS[version](io.BytesIO(raw))
    return shape, fortran, dtype


def _read_npy_header(f: IO[bytes], version: tuple[int, int]) -> tuple[tuple[int, ...], bool, np.dtype[Any]]:
    length_size = 2 if version == (1, 0) else 4
    prefix = f.read(length_size)
    if len(prefix) < length_size:
        raise EOFError("the npy header is cut short")
    length = int.from_bytes(prefix, "little")
    if length > _NPY_HEADER_MAX:
        raise ValueError(f"the npy header claims {length} bytes, more than numpy's {_NPY_HEADER_MAX}")
    return _npy_header(version, prefix + f.read(length))


def load_npz(source: str | os.PathLike[str] | bytes, where: str, *, limit: int,
             error: ErrorClass = InvalidInputError, kinds: str = "fiub") -> dict[str, np.ndarray]:
    """The arrays of an .npz (a path or its bytes), reading every array's header before its data:
    an array whose header claims more than ``limit`` bytes, or whose dtype kind is not in
    ``kinds`` (object arrays never are), is refused before anything is allocated or inflated.
    Zip members are read through their declared size, so a deflate bomb stops there.
    """
    data = source if isinstance(source, bytes) else read_bytes(source, limit=limit, what="npz file", error=error)
    out: dict[str, np.ndarray] = {}
    total = 0
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as z:
            for info in z.infolist():
                name = info.filename.removesuffix(".npy")
                if info.file_size > limit:
                    raise error(f"{where}: array {name!r} would inflate to {info.file_size} bytes, "
                                f"more than the {limit} allowed")
                with z.open(info) as f:
                    version = np.lib.format.read_magic(f)
                    if version not in _NPY_HEADERS:  # 3.0 only adds UTF-8 field names: never numbers
                        raise error(f"{where}: array {name!r} has npy format version {version}")
                    shape, fortran, dtype = _read_npy_header(f, version)
                    if dtype.hasobject or dtype.kind not in kinds:
                        raise error(f"{where}: array {name!r} has dtype {dtype}; expected numbers")
                    nbytes = math.prod(shape) * dtype.itemsize
                    total += nbytes
                    if nbytes > info.file_size or total > limit:
                        raise error(f"{where}: array {name!r} claims {nbytes} bytes of data, more than "
                                    f"{'its file holds' if nbytes > info.file_size else f'the {limit} allowed'}")
                    arr = np.frombuffer(f.read(nbytes), dtype=dtype)
                    if arr.size != math.prod(shape):
                        raise error(f"{where}: array {name!r} is truncated")
                    out[name] = arr.reshape(shape, order="F" if fortran else "C").copy()
    except DmprsError:
        raise
    except (zipfile.BadZipFile, ValueError, EOFError, OSError, NotImplementedError, RuntimeError) as exc:
        raise error(f"{where}: not a readable npz file ({type(exc).__name__}: {exc})") from None
    return out


#: Inflated pieces are produced and counted this many bytes at a time.
_INFLATE_PIECE = MiB


def open_inflated(source: IO[bytes], codec: str) -> tuple[IO[bytes], tuple[type[Exception], ...]]:
    """A file object inflating ``source`` (zstd frames, bz2 streams or lz4 frames, several
    concatenated as the one-shot decompressors of these formats accept) and the exceptions it
    raises on corrupt or cut data.
    """
    if codec == "zstd":
        import sys

        if sys.version_info >= (3, 14):
            from compression import zstd
        else:
            from backports import zstd
        return zstd.ZstdFile(source, "rb"), (zstd.ZstdError, EOFError)  # type: ignore[return-value]
    if codec == "bz2":
        import bz2

        return bz2.BZ2File(source, "rb"), (OSError, EOFError)
    if codec == "lz4":
        import lz4.frame  # type: ignore[import-untyped]

        return lz4.frame.LZ4FrameFile(source, "rb"), (RuntimeError, EOFError)
    raise ValueError(f"unknown codec {codec!r}")


def inflate_bounded(source: IO[bytes] | bytes, codec: str, *, limit: int, where: str,
                    error: ErrorClass = InvalidInputError, keep: bool = False, why: str = "") -> tuple[int, bytes]:
    """Inflates ``source`` (compressed with ``codec``: ``zstd``, ``bz2`` or ``lz4``) a piece at a
    time and refuses it as soon as it passes ``limit`` bytes, so a compression bomb costs at most
    ``limit`` bytes of work and no memory beyond one piece (unless ``keep``). Returns the inflated
    size and, with ``keep``, the inflated bytes. Corrupt data is an error naming ``where``; ``why``
    follows the limit in the error (where it comes from).
    """
    stream = io.BytesIO(source) if isinstance(source, bytes) else source
    pieces: list[bytes] = []
    total = 0
    inflated, corrupt = open_inflated(stream, codec)
    try:
        with inflated:
            while piece := inflated.read(min(_INFLATE_PIECE, limit + 1 - total)):
                total += len(piece)
                if total > limit:
                    raise error(f"{where}: {codec} data inflates to more than {limit} bytes, the limit{why}")
                if keep:
                    pieces.append(piece)
    except DmprsError:
        raise
    except corrupt as exc:
        raise error(f"{where}: corrupt {codec} data ({type(exc).__name__}: {exc})") from None
    return total, b"".join(pieces)


# --- writing ------------------------------------------------------------------------------------


def fsync_dir(path: Path) -> None:
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


def _open_for_writing(path: Path, flags: int) -> int:
    """``os.open`` for writing that never follows a link and refuses anything but a regular file
    (a FIFO would block, a device would swallow the data); raises OSError saying which.
    """
    try:
        fd = os.open(path, flags | _O_NOFOLLOW | _O_NONBLOCK | _O_CLOEXEC, 0o644)
    except OSError as exc:
        try:
            mode = os.lstat(path).st_mode
        except OSError:
            raise exc from None
        if stat.S_ISLNK(mode):
            raise OSError(f"{path} is a symbolic link; dmprs never writes through a link") from None
        if not stat.S_ISREG(mode):  # a FIFO without a reader fails the non-blocking open
            raise OSError(f"{path} is {_kind(mode)}; dmprs writes only regular files") from None
        raise exc from None
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode):
        os.close(fd)
        raise OSError(f"{path} is {_kind(st.st_mode)}; dmprs writes only regular files")
    return fd


@contextlib.contextmanager
def directory_lock(directory: Path, *, shared: bool) -> Iterator[None]:
    """Holds an advisory lock (``flock``) on ``directory/.dmprs.lock`` for the ``with`` block:
    exclusive for a writer, shared for readers, so concurrent saves into one directory take turns
    and a reader sees the files of one save, never a mix of two.

    Only a writer creates the lock file (a read never creates a file); a reader finding none
    reads without it, as nobody has saved there yet. The lock file is never followed through a
    link: a writer refuses one (OSError), a reader ignores it.
    """
    if fcntl is None:
        yield
        return
    lock = Path(directory) / LOCK_FILE
    if shared:
        try:
            fd = os.open(lock, os.O_RDONLY | _O_NOFOLLOW | _O_NONBLOCK | _O_CLOEXEC)
        except OSError:  # missing, a link, unreadable: nobody can be saving through it
            yield
            return
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            os.close(fd)
            yield
            return
    else:
        fd = _open_for_writing(lock, os.O_RDWR | os.O_CREAT)
    try:
        fcntl.flock(fd, fcntl.LOCK_SH if shared else fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # releases the lock


def write_atomic(path: Path, data: bytes, *, sync_dir: bool = True) -> None:
    """Writes ``data`` to ``path`` so that readers see the old file or the new one, never a mix.

    With ``sync_dir=False`` the directory entry is not fsync'ed: a caller writing many files
    calls :func:`fsync_dir` once after the last.
    """
    path = Path(path)
    try:  # the file keeps its permissions; a new one gets a plain file's, not mkstemp's 0600
        mode = stat.S_IMODE(path.stat().st_mode)
    except OSError:
        mode = 0o644
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        os.fchmod(fd, mode)
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
    if sync_dir:
        fsync_dir(path.parent)


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
    ``"-Infinity"``: strict JSON parsers reject the bare tokens Python writes for them.
    """
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
    to disk. Never through a link, never into anything but a regular file.
    """
    line = json.dumps(strict_json(record), separators=(",", ":"), allow_nan=False) + "\n"
    fd = _open_for_writing(Path(path), os.O_WRONLY | os.O_APPEND | os.O_CREAT)
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(line)
        f.flush()
        os.fsync(f.fileno())


#: A JSON-lines log (trials, recordings) larger than this is not one dmprs wrote.
JSONL_MAX_BYTES = 1024 * MiB


def read_jsonl(path: Path, *, what: str = "log", error: ErrorClass = InvalidInputError,
               ) -> tuple[list[dict[str, Any]], str | None]:
    """Reads complete lines; returns them and a description of a cut last line, if any.

    Only the last line may be incomplete (a crash mid-append); a bad line elsewhere means the
    file is not ours and raises ``error`` naming the file and the line.
    """
    text = read_text(path, limit=JSONL_MAX_BYTES, what=what, error=error)
    lines = text.split("\n")
    records: list[dict[str, Any]] = []
    cut = None
    for i, line in enumerate(lines):
        if not line.strip():
            continue
        last = i == len(lines) - 1  # no newline after it: the write may have been cut
        try:
            value = parse_json(line, f"{path}, line {i + 1}", error=error)
            if not isinstance(value, dict):
                raise error(f"{path}, line {i + 1}: not a JSON record (a JSON object), but a {type(value).__name__}")
        except DmprsError:
            if last:
                cut = f"line {i + 1} of {path} was cut mid-write ({len(line)} bytes) and is ignored"
                break
            raise
        records.append(value)
    return records, cut


def truncate_cut_line(path: Path) -> None:
    """Drops an incomplete last line so that appends start on a fresh line."""
    fd = _open_for_writing(Path(path), os.O_RDWR)
    with os.fdopen(fd, "r+b") as f:
        data = f.read()
        if data and not data.endswith(b"\n"):
            f.truncate(data.rfind(b"\n") + 1)
            f.flush()
            os.fsync(f.fileno())


# --- files a writer owns in its directory -------------------------------------------------------

#: The temporary files of :func:`write_atomic`: ``.<target name>.<8 random characters>.tmp``
#: (``tempfile.mkstemp``'s names). A crash between the write and the rename leaves one behind.
_ATOMIC_TEMP = re.compile(r"^\.(?P<target>.+)\.[a-z0-9_]{8}\.tmp$")


def atomic_temp_target(name: str) -> str | None:
    """The file a temporary file of :func:`write_atomic` named ``name`` was to become, or None
    if ``name`` is not such a name.
    """
    m = _ATOMIC_TEMP.match(name)
    return m["target"] if m else None


def regular_files(directory: Path) -> list[str]:
    """The names of the regular files directly in ``directory`` (a link, a FIFO, a device or a
    subdirectory is not one: nothing here follows a link), sorted.
    """
    with os.scandir(directory) as entries:
        return sorted(e.name for e in entries if e.is_file(follow_symlinks=False))


def create_empty(path: Path) -> None:
    """Creates ``path`` as an empty regular file if it does not exist; never through a link, never
    anything but a regular file (see :func:`append_jsonl`).
    """
    os.close(_open_for_writing(Path(path), os.O_WRONLY | os.O_CREAT))


def remove_if(path: Path, owned: Callable[[bytes], bool], *, limit: int) -> bool:
    """Removes the regular file ``path`` (not a link: its entry is checked first) if ``owned``
    says its contents are ours; a file larger than ``limit`` bytes, or one that cannot be read,
    is left alone. Returns whether it was removed.
    """
    try:
        if not stat.S_ISREG(os.lstat(path).st_mode):
            return False
        if not owned(read_bytes(path, limit=limit)):
            return False
        os.unlink(path)
    except (OSError, DmprsError):
        return False
    return True


def remove_stale_temp_files(directory: Path, targets: Callable[[str], bool]) -> list[str]:
    """Removes the temporary files an interrupted :func:`write_atomic` left in ``directory`` for
    the files ``targets`` accepts (by name); returns their names. Call it only under the
    directory's exclusive :func:`directory_lock`: a running writer's temporary file would go too.
    """
    removed = []
    for name in regular_files(directory):
        target = atomic_temp_target(name)
        if target is not None and targets(target):
            with contextlib.suppress(OSError):
                os.unlink(Path(directory) / name)
                removed.append(name)
    return removed
