"""ROS 2 message types as Cyclone DDS IDL classes, generated at run time from ROS's own definitions.

Nothing here is typed by hand: the field lists come from `rosbags`' ROS 2 typestore (Jazzy's;
Humble's agrees on every type used here, which the tests check) and, for the interfaces that
typestore lacks (control_msgs' FollowJointTrajectory, action_msgs' CancelGoal service), from the
upstream `.action`/`.msg`/`.srv` files shipped in `definitions/` (provenance in its SOURCES.md),
parsed by `rosbags.typesys.get_types_from_msg`.

Each class is a `@final` IDL struct named as rmw_cyclonedds names it on the wire
(`pkg::msg::dds_::Name_`), so Cyclone serializes it to the same XCDR1 bytes a ROS 2 node sends.
Every field has ROS's default value (zero, empty, or a default nested message), and the message
constants (`GoalStatus.STATUS_SUCCEEDED`, ...) are class attributes.
"""

from __future__ import annotations

import dataclasses
import functools
from importlib import resources
from typing import Any, cast

import numpy as np
from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types as idl
from cyclonedds.idl._main import IdlMeta
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.base import Nodetype
from rosbags.typesys.store import Typestore

from dmprs.errors import InvalidInputError

#: The rosbags store the message definitions are read from (Humble's agrees on these types).
STORE = Stores.ROS2_JAZZY

#: Interface files shipped with dmprs, relative to `definitions/` (see SOURCES.md there).
SHIPPED_DEFINITIONS = (
    "control_msgs/msg/JointTolerance.msg",
    "control_msgs/msg/JointComponentTolerance.msg",
    "control_msgs/action/FollowJointTrajectory.action",
    "action_msgs/srv/CancelGoal.srv",
)

_PRIMITIVES: dict[str, Any] = {
    "bool": bool,
    "byte": idl.uint8,
    "char": idl.uint8,
    "int8": idl.int8,
    "uint8": idl.uint8,
    "int16": idl.int16,
    "uint16": idl.uint16,
    "int32": idl.int32,
    "uint32": idl.uint32,
    "int64": idl.int64,
    "uint64": idl.uint64,
    "float32": idl.float32,
    "float64": idl.float64,
}

# Cyclone's generic IDL types are indexed at run time (array[T, n], sequence[T], bounded_str[n])
_array: Any = idl.array
_sequence: Any = idl.sequence
_bounded_str: Any = idl.bounded_str

_NUMPY_DTYPES = {
    "bool": np.bool_,
    "byte": np.uint8,
    "char": np.uint8,
    "int8": np.int8,
    "uint8": np.uint8,
    "int16": np.int16,
    "uint16": np.uint16,
    "int32": np.int32,
    "uint32": np.uint32,
    "int64": np.int64,
    "uint64": np.uint64,
    "float32": np.float32,
    "float64": np.float64,
}


def _split_definition(text: str, parts: int, source: str) -> list[str]:
    """Split a .srv (2 parts) or .action (3 parts) text on its `---` separator lines."""
    chunks: list[list[str]] = [[]]
    for line in text.splitlines():
        if line.strip() == "---":
            chunks.append([])
        else:
            chunks[-1].append(line)
    if len(chunks) != parts:
        raise InvalidInputError(f"{source}: expected {parts} parts separated by '---', found {len(chunks)}")
    return ["\n".join(chunk) + "\n" for chunk in chunks]


def _resolve_bare_names(types: dict[str, Any], package: str) -> dict[str, Any]:
    """Point the bare type names of a .srv/.action file at `<package>/msg/<Name>`.

    ROS resolves a bare name inside an interface file to a message of the same package; rosbags
    resolves it next to the owning type (parsed here as `<package>/action/<Name>`), which is right
    only for the types the file itself defines.
    """

    def fix(node: Any) -> Any:
        kind, detail = node
        if kind == Nodetype.NAME and detail.startswith(f"{package}/action/") and detail not in types:
            return (kind, f"{package}/msg/{detail.rsplit('/', 1)[1]}")
        if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            inner, size = detail
            return (kind, (fix(inner), size))
        return node

    return {name: (consts, [(field, fix(node)) for field, node in fields]) for name, (consts, fields) in types.items()}


def _parse(text: str, ros_type: str) -> dict[str, Any]:
    # rosbags re-homes a name outside msg/ and action/ (pkg/srv/X -> pkg/srv/msg/X): parse under
    # the action namespace and register under ROS's own name
    package, _, name = ros_type.split("/")
    ((consts, fields),) = get_types_from_msg(text, f"{package}/action/{name}").values()
    return {ros_type: (consts, fields)}


def _action_types(package: str, name: str, text: str, source: str) -> dict[str, Any]:
    """The message types rosidl derives from one .action file.

    Goal, result and feedback are the file's three parts; the send-goal and get-result services
    and the feedback message wrap them with the goal's UUID as rosidl's `Action` definition does.
    """
    goal, result, feedback = _split_definition(text, 3, source)
    base = f"{package}/action/{name}"
    types: dict[str, Any] = {}
    derived = {
        f"{base}_Goal": goal,
        f"{base}_Result": result,
        f"{base}_Feedback": feedback,
        f"{base}_SendGoal_Request": f"unique_identifier_msgs/UUID goal_id\n{base}_Goal goal\n",
        f"{base}_SendGoal_Response": "bool accepted\nbuiltin_interfaces/Time stamp\n",
        f"{base}_GetResult_Request": "unique_identifier_msgs/UUID goal_id\n",
        f"{base}_GetResult_Response": f"int8 status\n{base}_Result result\n",
        f"{base}_FeedbackMessage": f"unique_identifier_msgs/UUID goal_id\n{base}_Feedback feedback\n",
    }
    for ros_type, definition in derived.items():
        types.update(_parse(definition, ros_type))
    return _resolve_bare_names(types, package)


def _service_types(package: str, name: str, text: str, source: str) -> dict[str, Any]:
    request, response = _split_definition(text, 2, source)
    base = f"{package}/srv/{name}"
    types = {**_parse(request, f"{base}_Request"), **_parse(response, f"{base}_Response")}
    return _resolve_bare_names(types, package)


@functools.cache
def typestore() -> Typestore:
    """rosbags' ROS 2 typestore with the shipped definitions registered (serialize_cdr reads them)."""
    store = get_typestore(STORE)
    folder = resources.files(__package__) / "definitions"
    for relative in SHIPPED_DEFINITIONS:
        text = (folder / relative).read_text(encoding="utf-8")
        package, _, filename = relative.split("/")
        name, _, suffix = filename.partition(".")
        if suffix == "msg":
            types = _resolve_bare_names(_parse(text, f"{package}/msg/{name}"), package)
        elif suffix == "srv":
            types = _service_types(package, name, text, relative)
        else:
            types = _action_types(package, name, text, relative)
        store.register(types)
    return store


def dds_type_name(ros_type: str) -> str:
    """The type name rmw_cyclonedds puts on the wire: `pkg/msg/Name` -> `pkg::msg::dds_::Name_`."""
    package, kind, name = _split_type(ros_type)
    return f"{package}::{kind}::dds_::{name}_"


def _split_type(ros_type: str) -> tuple[str, str, str]:
    parts = ros_type.split("/")
    if len(parts) != 3 or not all(parts):
        raise InvalidInputError(f"ROS type {ros_type!r}: expected 'package/kind/Name'")
    return parts[0], parts[1], parts[2]


def _field_type(node: Any) -> Any:
    kind, detail = node
    if kind == Nodetype.BASE:
        name, bound = detail
        if name == "string":
            return _bounded_str[bound] if bound else str
        if name not in _PRIMITIVES:
            raise InvalidInputError(f"ROS field type {name!r} is not supported")
        return _PRIMITIVES[name]
    if kind == Nodetype.NAME:
        return message_class(detail)
    inner, size = detail
    if kind == Nodetype.ARRAY:
        return _array[_field_type(inner), size]
    return _sequence[_field_type(inner), size] if size else _sequence[_field_type(inner)]


def _default_factory(node: Any) -> Any:
    kind, detail = node
    if kind == Nodetype.BASE:
        name = detail[0]
        value = "" if name == "string" else False if name == "bool" else 0.0 if "float" in name else 0
        return lambda: value
    if kind == Nodetype.NAME:
        return message_class(detail)
    inner, size = detail
    if _is_octets(node):
        return (lambda: bytes(size)) if kind == Nodetype.ARRAY else bytes
    if kind == Nodetype.ARRAY:
        element = _default_factory(inner)
        return lambda: [element() for _ in range(size)]
    return list


def _is_octets(node: Any) -> bool:
    """An array or sequence of bytes (uint8, byte, char): Cyclone reads these as `bytes`."""
    kind, detail = node
    if kind not in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        return False
    inner_kind, inner = detail[0]
    return bool(inner_kind == Nodetype.BASE and inner[0] in ("uint8", "byte", "char"))


@functools.cache
def message_class(ros_type: str) -> type[Any]:
    """The Cyclone IDL class of a ROS 2 type, e.g. `message_class('sensor_msgs/msg/JointState')`."""
    store = typestore()
    if ros_type not in store.fielddefs:
        raise InvalidInputError(f"ROS type {ros_type!r} is not known to the {STORE.name} typestore")
    consts, fields = store.fielddefs[ros_type]
    class_name = _split_type(ros_type)[2]
    namespace = cast(dict[str, Any], IdlMeta.__prepare__(class_name, (IdlStruct,), typename=dds_type_name(ros_type)))
    namespace["__idl_annotations__"]["extensibility"] = "final"
    for field, node in fields:
        namespace["__annotations__"][field] = _field_type(node)
        namespace[field] = dataclasses.field(default_factory=_default_factory(node))
    for const, _, value in consts:
        namespace[const] = value
    namespace["__module__"] = __name__
    namespace["__qualname__"] = class_name
    namespace["ros_type"] = ros_type
    return dataclasses.dataclass(IdlMeta(class_name, (IdlStruct,), namespace))


def to_rosbags(message: Any) -> Any:
    """The same message as a rosbags object (primitive arrays as numpy arrays), for serialize_cdr."""
    ros_type = type(message).ros_type
    store = typestore()
    _, fields = store.fielddefs[ros_type]
    values = {field: _to_rosbags_value(getattr(message, field), node) for field, node in fields}
    return store.types[ros_type](**values)


def _to_rosbags_value(value: Any, node: Any) -> Any:
    kind, detail = node
    if kind == Nodetype.NAME:
        return to_rosbags(value)
    if kind == Nodetype.BASE:
        return value
    inner_kind, inner = detail[0]
    if inner_kind == Nodetype.BASE and inner[0] in _NUMPY_DTYPES:
        if isinstance(value, (bytes, bytearray)):
            return np.frombuffer(value, dtype=np.uint8).copy()
        return np.array(value, dtype=_NUMPY_DTYPES[inner[0]])
    return [_to_rosbags_value(item, detail[0]) for item in value]


def from_rosbags(message: Any, ros_type: str) -> Any:
    """A rosbags object of `ros_type` as this module's IDL class."""
    _, fields = typestore().fielddefs[ros_type]
    values = {field: _from_rosbags_value(getattr(message, field), node) for field, node in fields}
    return message_class(ros_type)(**values)


def _from_rosbags_value(value: Any, node: Any) -> Any:
    kind, detail = node
    if kind == Nodetype.NAME:
        return from_rosbags(value, detail)
    if kind == Nodetype.BASE:
        return value.item() if isinstance(value, np.generic) else value
    if _is_octets(node):
        return bytes(value)
    return [_from_rosbags_value(item, detail[0]) for item in value]


# the types dmprs speaks (rclpy's names, with rosidl's underscores for the action's parts)
Time = message_class("builtin_interfaces/msg/Time")
Duration = message_class("builtin_interfaces/msg/Duration")
Header = message_class("std_msgs/msg/Header")
Float64 = message_class("std_msgs/msg/Float64")
Float64MultiArray = message_class("std_msgs/msg/Float64MultiArray")
JointState = message_class("sensor_msgs/msg/JointState")
JointTrajectory = message_class("trajectory_msgs/msg/JointTrajectory")
JointTrajectoryPoint = message_class("trajectory_msgs/msg/JointTrajectoryPoint")
JointTolerance = message_class("control_msgs/msg/JointTolerance")
Point = message_class("geometry_msgs/msg/Point")
Quaternion = message_class("geometry_msgs/msg/Quaternion")
Pose = message_class("geometry_msgs/msg/Pose")
PoseStamped = message_class("geometry_msgs/msg/PoseStamped")
PointStamped = message_class("geometry_msgs/msg/PointStamped")
Clock = message_class("rosgraph_msgs/msg/Clock")
UUID = message_class("unique_identifier_msgs/msg/UUID")
GoalInfo = message_class("action_msgs/msg/GoalInfo")
GoalStatus = message_class("action_msgs/msg/GoalStatus")
GoalStatusArray = message_class("action_msgs/msg/GoalStatusArray")
CancelGoal_Request = message_class("action_msgs/srv/CancelGoal_Request")
CancelGoal_Response = message_class("action_msgs/srv/CancelGoal_Response")
FollowJointTrajectory_Goal = message_class("control_msgs/action/FollowJointTrajectory_Goal")
FollowJointTrajectory_Result = message_class("control_msgs/action/FollowJointTrajectory_Result")
FollowJointTrajectory_Feedback = message_class("control_msgs/action/FollowJointTrajectory_Feedback")
FollowJointTrajectory_FeedbackMessage = message_class("control_msgs/action/FollowJointTrajectory_FeedbackMessage")
FollowJointTrajectory_SendGoal_Request = message_class("control_msgs/action/FollowJointTrajectory_SendGoal_Request")
FollowJointTrajectory_SendGoal_Response = message_class(
    "control_msgs/action/FollowJointTrajectory_SendGoal_Response"
)
FollowJointTrajectory_GetResult_Request = message_class(
    "control_msgs/action/FollowJointTrajectory_GetResult_Request"
)
FollowJointTrajectory_GetResult_Response = message_class(
    "control_msgs/action/FollowJointTrajectory_GetResult_Response"
)
