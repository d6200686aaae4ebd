"""Real bags for the tests, written with rosbags' own writers (ROS 2 sqlite3 and mcap, ROS 1)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any, Self

import numpy as np

FORMATS = ("ros2-sqlite3", "ros2-mcap", "ros1")


def typestore(fmt: str) -> Any:
    from rosbags.typesys import Stores, get_typestore

    if fmt != "ros1":
        return get_typestore(Stores.ROS2_HUMBLE)
    from rosbags.typesys import get_types_from_msg

    # noetic's store lacks tf2_msgs: register TFMessage as ROS 1 defines it
    store = get_typestore(Stores.ROS1_NOETIC)
    store.register(get_types_from_msg("geometry_msgs/TransformStamped[] transforms",
                                      "tf2_msgs/msg/TFMessage"))
    return store


def bag_path(tmp: Path, fmt: str, name: str = "demo") -> Path:
    return tmp / (f"{name}.bag" if fmt == "ros1" else name)


class BagWriter:
    """``with BagWriter(path, fmt) as w: w.write(topic, msg, t_ns)``."""

    def __init__(self, path: Path, fmt: str) -> None:
        self.fmt, self.ts = fmt, typestore(fmt)
        if fmt == "ros1":
            from rosbags.rosbag1 import Writer as W1

            self.writer: Any = W1(path)
        else:
            from rosbags.rosbag2 import StoragePlugin, Writer

            plugin = StoragePlugin.MCAP if fmt == "ros2-mcap" else StoragePlugin.SQLITE3
            self.writer = Writer(path, version=9, storage_plugin=plugin)
        self.conns: dict[str, Any] = {}

    def __enter__(self) -> Self:
        self.writer.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.writer.close()

    def header(self, t_ns: int, frame: str = "") -> Any:
        T = self.ts.types
        stamp = T["builtin_interfaces/msg/Time"](sec=t_ns // 10**9, nanosec=t_ns % 10**9)
        if self.fmt == "ros1":
            return T["std_msgs/msg/Header"](seq=0, stamp=stamp, frame_id=frame)
        return T["std_msgs/msg/Header"](stamp=stamp, frame_id=frame)

    def write(self, topic: str, msg: Any, t_ns: int) -> None:
        msgtype = msg.__msgtype__
        if topic not in self.conns:
            self.conns[topic] = self.writer.add_connection(topic, msgtype, typestore=self.ts)
        data = (self.ts.serialize_ros1 if self.fmt == "ros1" else self.ts.serialize_cdr)(msg, msgtype)
        self.writer.write(self.conns[topic], t_ns, data)

    def joint_state(self, t_ns: int, names: Sequence[str], position: Iterable[float],
                    velocity: Iterable[float] = ()) -> Any:
        return self.ts.types["sensor_msgs/msg/JointState"](
            header=self.header(t_ns), name=list(names), position=np.asarray(list(position), dtype=np.float64),
            velocity=np.asarray(list(velocity), dtype=np.float64), effort=np.zeros(0))

    def pose_stamped(self, t_ns: int, frame: str, pose: Sequence[float]) -> Any:
        T = self.ts.types
        return T["geometry_msgs/msg/PoseStamped"](header=self.header(t_ns, frame), pose=self._pose(pose))

    def _pose(self, p: Sequence[float]) -> Any:
        T = self.ts.types
        return T["geometry_msgs/msg/Pose"](
            position=T["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]),
            orientation=T["geometry_msgs/msg/Quaternion"](x=p[4], y=p[5], z=p[6], w=p[3]))

    def tf_message(self, t_ns: int, transforms: Sequence[tuple[str, str, Sequence[float]]]) -> Any:
        T = self.ts.types
        items = []
        for parent, child, p in transforms:
            tr = T["geometry_msgs/msg/Transform"](
                translation=T["geometry_msgs/msg/Vector3"](x=p[0], y=p[1], z=p[2]),
                rotation=T["geometry_msgs/msg/Quaternion"](x=p[4], y=p[5], z=p[6], w=p[3]))
            items.append(T["geometry_msgs/msg/TransformStamped"](
                header=self.header(t_ns, parent), child_frame_id=child, transform=tr))
        return T["tf2_msgs/msg/TFMessage"](transforms=items)


# --- damaged and hostile bags (for the tests of dmprs.io.bagcheck and the fuzz targets) ----------

def compressed_bag(path: Path, fmt: str, compression: str, n: int = 50, t0_ns: int = 1_700_000_000 * 10**9) -> Path:
    """A bag of ``n`` joint states ("a": sin) written with rosbags' own compression: ROS 2
    ``file``, ``message`` or ``storage`` (MCAP chunks) zstd, ROS 1 ``bz2`` or ``lz4`` chunks.
    """
    from rosbags.rosbag1 import Writer as W1
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.rosbag2.enums import CompressionFormat, CompressionMode

    ts = typestore(fmt)
    writer: Any
    if fmt == "ros1":
        writer = W1(path)
        writer.set_compression(W1.CompressionFormat[compression.upper()])
    else:
        plugin = StoragePlugin.MCAP if fmt == "ros2-mcap" else StoragePlugin.SQLITE3
        writer = Writer(path, version=9, storage_plugin=plugin)
        writer.set_compression(CompressionMode[compression.upper()], CompressionFormat.ZSTD)
    bw = BagWriter.__new__(BagWriter)
    bw.fmt, bw.ts, bw.writer, bw.conns = fmt, ts, writer, {}
    with bw:
        for k in range(n):
            ns = t0_ns + k * 10_000_000
            bw.write("/joint_states", bw.joint_state(ns, ["a"], [np.sin(k / 10)]), ns)
    return path


def zstd_bomb(payload: bytes, zeros: int) -> bytes:
    """``payload`` followed by ``zeros`` zero bytes, as zstd frames (a few KB per GiB)."""
    from backports import zstd

    c = zstd.ZstdCompressor(level=1)
    out = c.compress(payload)
    piece = bytes(2**20)
    for _ in range(zeros // 2**20):
        out += c.compress(piece)
    return out + c.compress(bytes(zeros % 2**20)) + c.flush()


def file_bomb(bag: Path, zeros: int) -> None:
    """Pads the inflated storage file of a file-compressed ROS 2 bag with ``zeros`` zero bytes
    (sqlite3 ignores what follows its pages: rosbags reads it as before, after inflating it).
    """
    from backports import zstd

    (f,) = [p for p in bag.iterdir() if p.suffix == ".zstd"]
    f.write_bytes(zstd_bomb(zstd.decompress(f.read_bytes()), zeros))


def message_bomb(bag: Path, zeros: int) -> None:
    """Pads the first message of a message-compressed sqlite3 bag with ``zeros`` zero bytes."""
    import sqlite3

    from backports import zstd

    (f,) = [p for p in bag.iterdir() if p.suffix == ".db3"]
    db = sqlite3.connect(f)
    with db:
        (first, data), = db.execute("SELECT id, data FROM messages ORDER BY id LIMIT 1")
        db.execute("UPDATE messages SET data = ? WHERE id = ?", (zstd_bomb(zstd.decompress(data), zeros), first))
    db.close()


def ros1_chunk_bomb(path: Path, zeros: int) -> None:
    """Appends to a bz2/lz4-chunked ROS 1 bag a copy of its first chunk padded with ``zeros`` zero
    bytes (the messages keep their offsets), and points the index at it.
    """
    import bz2
    import struct

    import lz4.frame

    data = bytearray(path.read_bytes())

    def header(pos: int) -> tuple[dict[str, bytes], int]:
        n = struct.unpack_from("<I", data, pos)[0]
        fields, k = {}, pos + 4
        while k < pos + 4 + n:
            m = struct.unpack_from("<I", data, k)[0]
            name, _, value = bytes(data[k + 4:k + 4 + m]).partition(b"=")
            fields[name.decode()] = value
            k += 4 + m
        return fields, pos + 4 + n

    bag_header, _ = header(13)
    index_pos = struct.unpack("<Q", bag_header["index_pos"])[0]
    conn_count = struct.unpack("<I", bag_header["conn_count"])[0]
    pos = index_pos
    for _ in range(2 * conn_count):
        _, pos = header(pos)
    info, _ = header(pos)
    chunk_pos = struct.unpack("<Q", info["chunk_pos"])[0]
    field_at = data.index(b"chunk_pos=", pos) + len(b"chunk_pos=")
    chunk, k = header(chunk_pos)
    compression = chunk["compression"].decode()
    n = struct.unpack_from("<I", data, k)[0]
    raw = (bz2.decompress if compression == "bz2" else lz4.frame.decompress)(bytes(data[k + 4:k + 4 + n]))
    padded = raw + bytes(zeros)
    packed = bz2.compress(padded, 9) if compression == "bz2" else lz4.frame.compress(padded)
    index_data = bytes(data[k + 4 + n:index_pos])  # the index records that follow the chunk

    def field(name: str, value: bytes) -> bytes:
        entry = name.encode() + b"=" + value
        return struct.pack("<I", len(entry)) + entry

    head = field("op", b"\x05") + field("compression", compression.encode()) + field("size", struct.pack("<I", len(padded) % 2**32))
    new = struct.pack("<I", len(head)) + head + struct.pack("<I", len(packed)) + packed + index_data
    data[field_at:field_at + 8] = struct.pack("<Q", len(data))
    path.write_bytes(bytes(data) + new)


def mcap_chunk_bomb(bag: Path, zeros: int, *, declare: int | None = None) -> None:
    """Rewrites the MCAP file of a ROS 2 bag as one zstd chunk holding its records followed by
    ``zeros`` zero bytes (records of opcode 0 and length 0, which readers skip), without a summary
    (so readers scan the data section). ``declare`` overrides the chunk's declared size.
    """
    import struct

    from backports import zstd

    (f,) = [p for p in bag.iterdir() if p.suffix == ".mcap"]
    data = f.read_bytes()
    magic = data[:8]
    pos, inner, header = 8, b"", b""
    while pos < len(data) - 8:
        op, n = data[pos], struct.unpack_from("<Q", data, pos + 1)[0]
        body = data[pos + 9:pos + 9 + n]
        if op == 0x01:
            header = data[pos:pos + 9 + n]
        elif op == 0x06:
            k = 28 + 4 + struct.unpack_from("<I", body, 28)[0]
            compression = body[32:k].decode()
            m = struct.unpack_from("<Q", body, k)[0]
            records = body[k + 8:k + 8 + m]
            inner += zstd.decompress(records) if compression == "zstd" else records
        elif op == 0x0F:
            break
        pos += 9 + n
    zeros -= zeros % 9  # whole empty records
    padded_size = len(inner) + zeros
    packed = zstd_bomb(inner, zeros)
    compression = b"zstd"
    chunk = (struct.pack("<QQQI", 0, 2**62, padded_size if declare is None else declare, 0)
             + struct.pack("<I", len(compression)) + compression + struct.pack("<Q", len(packed)) + packed)
    footer = struct.pack("<QQI", 0, 0, 0)
    out = (magic + header + b"\x06" + struct.pack("<Q", len(chunk)) + chunk
           + b"\x0f" + struct.pack("<Q", 4) + struct.pack("<I", 0)
           + b"\x02" + struct.pack("<Q", len(footer)) + footer + magic)
    f.write_bytes(out)
