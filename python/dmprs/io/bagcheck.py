"""A ROS bag checked before ``rosbags`` opens it: every file rosbags will open is a regular file,
and nothing it will inflate can inflate without bound.

How rosbags (0.10, 0.11) inflates, and so what is checked here:

* a ROS 2 bag with ``compression_mode: file`` has each storage file zstd-compressed; rosbags
  copies every one, inflated (``zstd.open`` + ``shutil.copyfileobj``), into a temporary
  directory when the bag is opened;
* ``compression_mode: message``: every message is ``zstd.decompress``-ed whole, in memory;
* MCAP storage files hold chunks compressed with zstd or lz4, each inflated whole in memory
  (only then compared with the size the chunk declares);
* ROS 1 bags hold chunks compressed with bz2 or lz4, each inflated whole in memory.

The walks below read the same records rosbags reads (the ROS 1 index's chunk positions, every
MCAP record, every message of a message-compressed bag) and inflate each compressed piece a
piece at a time with :func:`dmprs._io.inflate_bounded`, counting: a piece may inflate to at
most :func:`inflate_limit` of its compressed size, so a bomb is refused after a bounded amount
of work and nothing is written. Real recordings compress a few times, far below that ratio.
"""

from __future__ import annotations

import io
import os
import shutil
import sqlite3
import struct
import tempfile
from pathlib import Path, PurePath
from typing import IO, Any

from dmprs._io import MiB, check_regular, inflate_bounded, open_inflated, open_regular, read_text
from dmprs.errors import InvalidInputError

__all__ = ["INFLATE_FLOOR_BYTES", "INFLATE_MAX_BYTES", "INFLATE_MAX_RATIO", "METADATA_MAX_BYTES",
           "check_bag", "inflate_limit"]

#: A compressed piece of a bag (a chunk, a message, a storage file) may inflate to at most
#: INFLATE_FLOOR_BYTES + INFLATE_MAX_RATIO x its compressed size ...
INFLATE_FLOOR_BYTES = 64 * MiB
INFLATE_MAX_RATIO = 100
#: ... and a piece rosbags inflates in memory (a chunk, a message) to at most this.
INFLATE_MAX_BYTES = 1024 * MiB
#: A ROS 2 bag's metadata.yaml larger than this is not one a recorder wrote.
METADATA_MAX_BYTES = 16 * MiB

_MCAP_MAGIC = b"\x89MCAP0\r\n"
_ROS1_MAGIC = b"#ROSBAG V2.0\n"
_PIECE = MiB


def inflate_limit(compressed: int, cap: int = INFLATE_MAX_BYTES) -> int:
    """The most bytes ``compressed`` bytes of a bag may inflate to."""
    return min(cap, INFLATE_FLOOR_BYTES + INFLATE_MAX_RATIO * compressed)


def _inflate(data: bytes | IO[bytes], size: int, codec: str, where: str, *, cap: int = INFLATE_MAX_BYTES,
             keep: bool = False) -> tuple[int, bytes]:
    limit = inflate_limit(size, cap)
    return inflate_bounded(data, codec, limit=limit, where=where, keep=keep, why=_why(size, cap))


def _why(size: int, cap: int) -> str:
    return (f" for {size} compressed bytes ({INFLATE_MAX_RATIO} x that + {INFLATE_FLOOR_BYTES // MiB} MiB, at most "
            f"{cap} bytes: dmprs.io.bagcheck); a compression bomb?")


def check_bag(path: Path) -> None:
    """Raises :class:`~dmprs.errors.InvalidInputError` naming the file unless rosbags can open
    the bag ``path`` (a ROS 2 directory or a ROS 1 ``.bag``) without blocking on a FIFO or
    device and without inflating a compressed piece beyond :func:`inflate_limit`.
    """
    if path.is_dir():
        _ros2(path)
    elif path.suffix == ".mcap":  # rosbags also reads a ROS 2 storage file on its own
        f, size = open_regular(path, what="MCAP file")
        with f:
            _mcap(f, str(path), messages=False, limit=size)
    elif path.suffix == ".db3":
        check_regular(path, what="sqlite3 bag file")
    else:
        _ros1(path)


# --- reading records ------------------------------------------------------------------------------

def _read(f: IO[bytes], n: int, where: str) -> bytes:
    """Exactly ``n`` bytes, read a piece at a time (a crafted length cannot allocate more than
    the file holds).
    """
    pieces, got = [], 0
    while got < n:
        piece = f.read(min(_PIECE, n - got))
        if not piece:
            raise InvalidInputError(f"{where}: cut short ({n} bytes declared, {got} present)")
        pieces.append(piece)
        got += len(piece)
    return b"".join(pieces)


def _skip(f: IO[bytes], n: int, where: str) -> None:
    if f.seekable():
        here, end = f.tell(), os.fstat(f.fileno()).st_size
        if here + n > end:
            raise InvalidInputError(f"{where}: cut short ({n} bytes declared, {end - here} present)")
        f.seek(n, io.SEEK_CUR)
    else:
        while n > 0:
            piece = f.read(min(_PIECE, n))
            if not piece:
                raise InvalidInputError(f"{where}: cut short")
            n -= len(piece)


def _u(data: bytes, fmt: str, where: str) -> Any:
    try:
        return struct.unpack(fmt, data)[0]
    except struct.error:
        raise InvalidInputError(f"{where}: a field is cut short") from None


# --- ROS 1 ----------------------------------------------------------------------------------------

def _ros1_header(f: IO[bytes], size: int, where: str) -> dict[str, bytes]:
    """The fields of the record header at the current position (``name=value`` entries)."""
    n = _u(_read(f, 4, where), "<I", where)
    if n > size:
        raise InvalidInputError(f"{where}: a record header claims {n} bytes, more than the file holds")
    raw, fields, k = _read(f, n, where), {}, 0
    while k + 4 <= len(raw):
        m = _u(raw[k:k + 4], "<I", where)
        entry = raw[k + 4:k + 4 + m]
        name, eq, value = entry.partition(b"=")
        if not eq:
            raise InvalidInputError(f"{where}: a record header field has no '='")
        fields[name.decode("latin-1")] = value
        k += 4 + m
    return fields


def _field(fields: dict[str, bytes], name: str, fmt: str, where: str) -> Any:
    if name not in fields:
        raise InvalidInputError(f"{where}: a record lacks its {name!r} field")
    return _u(fields[name], fmt, f"{where}, field {name!r}")


def _ros1(path: Path) -> None:
    """Every chunk rosbags will inflate: the positions its index lists, read as rosbags reads them."""
    f, size = open_regular(path, what="ROS 1 bag")
    where = str(path)
    with f:
        if f.read(len(_ROS1_MAGIC)) != _ROS1_MAGIC:  # (rosbags would read its first line, however long)
            raise InvalidInputError(f"{where}: not a ROS 1 bag (it does not start with '#ROSBAG V2.0')")
        header = _ros1_header(f, size, f"{where}, bag header")
        index_pos = _field(header, "index_pos", "<Q", where)
        conn_count = _field(header, "conn_count", "<I", where)
        chunk_count = _field(header, "chunk_count", "<I", where)
        if index_pos == 0 or chunk_count == 0:
            return  # rosbags reads no chunk of it
        if index_pos > size:
            raise InvalidInputError(f"{where}: its index is at byte {index_pos}, beyond its end ({size} bytes)")
        f.seek(index_pos)
        for k in range(conn_count):
            w = f"{where}, connection record {k}"
            _ros1_header(f, size, w)
            _ros1_header(f, size, w)  # the connection's data is a header too
        positions = set()
        for k in range(chunk_count):
            w = f"{where}, chunk info {k}"
            info = _ros1_header(f, size, w)
            positions.add(_field(info, "chunk_pos", "<Q", w))
            count = _field(info, "count", "<I", w)
            _read(f, 4, w)
            _skip(f, 8 * count, w)
        for pos in sorted(positions):
            w = f"{where}, chunk at byte {pos}"
            if pos > size:
                raise InvalidInputError(f"{w}: beyond the end of the file ({size} bytes)")
            f.seek(pos)
            chunk = _ros1_header(f, size, w)
            compression = chunk.get("compression", b"none").decode("latin-1")
            n = _u(_read(f, 4, w), "<I", w)
            if compression in ("bz2", "lz4"):
                _inflate(_read(f, n, w), n, compression, w)


# --- MCAP -----------------------------------------------------------------------------------------

def _string(body: bytes, k: int, where: str) -> tuple[str, int]:
    n = _u(body[k:k + 4], "<I", where)
    if k + 4 + n > len(body):
        raise InvalidInputError(f"{where}: a string runs past its record")
    return body[k + 4:k + 4 + n].decode("utf-8", "replace"), k + 4 + n


def _mcap(f: IO[bytes], where: str, *, messages: bool, limit: int) -> None:
    """Every chunk of an MCAP stream (and with ``messages`` every message, zstd-compressed by a
    message-compressed ROS 2 bag) inflates within bounds, and what rosbags seeks by (the footer
    at the end, the summary it points at, the chunk index there) points at those chunks only.
    Records are read forward, so the stream may be an inflating one.
    """
    if f.read(len(_MCAP_MAGIC)) != _MCAP_MAGIC:
        raise InvalidInputError(f"{where}: not an MCAP file (no MCAP magic at its start)")
    chunks: dict[int, tuple[str, int, int]] = {}
    indexed: list[tuple[int, str, int, int]] = []
    summary_starts = {0}  # where a summary may start: after a DataEnd record (0 = no summary)
    pos = len(_MCAP_MAGIC)
    while True:
        head = f.read(9)
        if len(head) < 9:
            raise InvalidInputError(f"{where}: cut short (no MCAP footer at its end)")
        op, n = head[0], _u(head[1:], "<Q", where)
        w = f"{where}, record at byte {pos}"
        if op not in (0x02, 0x05, 0x06, 0x08):
            _skip(f, n, w)
        elif n > limit:
            raise InvalidInputError(f"{w}: {n} bytes, more than the {limit} the file holds")
        else:
            body = _read(f, n, w)
            if op == 0x02:
                summary_start = _u(body[0:8], "<Q", w)
                if n != 20 or f.read(len(_MCAP_MAGIC) + 1) != _MCAP_MAGIC:
                    raise InvalidInputError(f"{w}: the footer is not the end of the file")
                if summary_start not in summary_starts:
                    raise InvalidInputError(f"{w}: the footer points at byte {summary_start}, where no summary starts")
                break
            if op == 0x05 and messages:
                _message(body[22:], w)
            elif op == 0x06:
                chunks[pos] = _chunk(body, w, messages)
            elif op == 0x08:
                offset = _u(body[16:24], "<Q", w)
                k = 36 + _u(body[32:36], "<I", w)  # past the message index offsets
                compression, k = _string(body, k + 8, w)
                indexed.append((offset, compression, _u(body[k:k + 8], "<Q", w), _u(body[k + 8:k + 16], "<Q", w)))
        pos += 9 + n
        if op == 0x0F:  # DataEnd: the summary follows
            summary_starts.add(pos)
    for offset, compression, compressed, declared in indexed:
        if chunks.get(offset) != (compression, compressed, declared):
            raise InvalidInputError(
                f"{where}: its chunk index points at byte {offset}, where no such chunk is "
                f"({compression or 'uncompressed'}, {compressed} bytes); a damaged or crafted file")


def _chunk(body: bytes, where: str, messages: bool) -> tuple[str, int, int]:
    """Checks one MCAP chunk record; returns its compression, compressed and declared size."""
    declared = _u(body[16:24], "<Q", where)
    compression, k = _string(body, 28, where)
    n = _u(body[k:k + 8], "<Q", where)
    data = body[k + 8:k + 8 + n]
    if len(data) != n:
        raise InvalidInputError(f"{where}: its records run past the chunk")
    if compression in ("zstd", "lz4"):
        # rosbags inflates the chunk whole and only then compares with the declared size
        _, data = _inflate(data, n, compression, f"{where} (a chunk declaring {declared} bytes)",
                           cap=min(declared, INFLATE_MAX_BYTES), keep=messages)
    if messages:
        inner, k = memoryview(data), 0
        while k + 9 <= len(inner):
            op, m = inner[k], _u(bytes(inner[k + 1:k + 9]), "<Q", where)
            if op == 0x05:
                _message(bytes(inner[k + 9 + 22:k + 9 + m]), f"{where}, byte {k} of the chunk")
            k += 9 + m
    return compression, n, declared


def _message(data: bytes, where: str) -> None:
    _inflate(data, len(data), "zstd", f"{where}, a message")


# --- ROS 2 ----------------------------------------------------------------------------------------

def _metadata(directory: Path) -> dict[str, Any]:
    from ruamel.yaml import YAML
    from ruamel.yaml.error import YAMLError

    meta = directory / "metadata.yaml"
    text = read_text(meta, limit=METADATA_MAX_BYTES, what="bag metadata file")
    try:
        doc = YAML(typ="safe", pure=True).load(text)
    except (YAMLError, RecursionError, ValueError, TypeError) as exc:
        said = " ".join(str(exc).split())[:200]
        raise InvalidInputError(f"{meta}: not readable YAML ({type(exc).__name__}: {said})") from None
    info = doc.get("rosbag2_bagfile_information") if isinstance(doc, dict) else None
    if not isinstance(info, dict):
        raise InvalidInputError(f"{meta}: no 'rosbag2_bagfile_information' mapping; not a ROS 2 bag's metadata")
    files = info.get("relative_file_paths")
    if not isinstance(files, list) or not files or not all(isinstance(x, str) for x in files):
        raise InvalidInputError(f"{meta}: 'relative_file_paths' must be a list of file names")
    return info


def _ros2(directory: Path) -> None:
    info = _metadata(directory)
    mode = str(info.get("compression_mode") or "").lower()
    storage = str(info.get("storage_identifier", ""))
    # rosbags opens each listed file by its name inside the bag directory
    paths = [directory / PurePath(x).name for x in info["relative_file_paths"]]
    sizes = [check_regular(p, what="bag storage file") for p in paths]
    if mode == "file":
        total = 0
        for p, size in zip(paths, sizes, strict=True):
            total += _inflated_file(p, size, storage)
        tmp = tempfile.gettempdir()
        free = shutil.disk_usage(tmp).free
        if total > free:
            raise InvalidInputError(
                f"{directory}: its compressed files inflate to {total} bytes, which rosbags writes into "
                f"the temporary directory {tmp}: it has {free} bytes free (set TMPDIR elsewhere)")
        return
    for p, size in zip(paths, sizes, strict=True):
        if storage == "mcap":
            f, _ = open_regular(p, what="bag storage file")
            with f:
                _mcap(f, str(p), messages=mode == "message", limit=size)
        elif mode == "message" and storage == "sqlite3":
            _sqlite_messages(p)


def _inflated_file(path: Path, size: int, storage: str) -> int:
    """The inflated size of a zstd-compressed storage file (an MCAP one's chunks checked too)."""
    limit = inflate_limit(size, cap=2**63 - 1)
    where = f"{path} (a zstd-compressed bag file, which rosbags inflates into the temporary directory)"
    f, _ = open_regular(path, what="bag storage file")
    with f:
        if storage == "mcap":  # read the inflated MCAP as it streams, counting what it inflates to
            counted = _Counted(f, limit, where, _why(size, limit))
            _mcap(counted.reader, str(path), messages=False, limit=limit)
            counted.drain()
            return counted.total
        return inflate_bounded(f, "zstd", limit=limit, where=where, why=_why(size, limit))[0]


class _Counted:
    """A zstd stream read forward, refused as soon as more than ``limit`` bytes came out of it."""

    def __init__(self, f: IO[bytes], limit: int, where: str, why: str) -> None:
        self.inner, self.corrupt = open_inflated(f, "zstd")
        self.limit, self.where, self.why, self.total = limit, where, why, 0
        self.reader: IO[bytes] = self  # type: ignore[assignment]

    def read(self, n: int = -1) -> bytes:
        try:
            data = self.inner.read(min(n if n >= 0 else _PIECE, _PIECE))
        except self.corrupt as exc:
            raise InvalidInputError(f"{self.where}: corrupt zstd data ({exc})") from None
        self.total += len(data)
        if self.total > self.limit:
            raise InvalidInputError(f"{self.where}: zstd data inflates to more than {self.limit} bytes, the "
                                    f"limit{self.why}")
        return data

    def seekable(self) -> bool:
        return False

    def drain(self) -> None:
        while self.read(_PIECE):
            pass


def _sqlite_messages(path: Path) -> None:
    """Every zstd-compressed message of a message-compressed sqlite3 bag file."""
    uri = path.resolve().as_uri() + "?mode=ro&immutable=1"
    try:
        db = sqlite3.connect(uri, uri=True)
    except sqlite3.Error as exc:
        raise InvalidInputError(f"{path}: not a readable sqlite3 bag file ({exc})") from None
    try:
        for k, (data,) in enumerate(db.execute("SELECT data FROM messages ORDER BY id")):
            if isinstance(data, bytes):
                _inflate(data, len(data), "zstd", f"{path}, message {k}")
    except sqlite3.Error as exc:
        raise InvalidInputError(f"{path}: not a readable sqlite3 bag file ({exc})") from None
    finally:
        db.close()
