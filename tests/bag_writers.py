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
