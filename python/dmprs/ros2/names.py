"""ROS 2 names: the domain a node joins, and resolving a topic or service name against a node,
and its name on DDS.

Follows design.ros2.org's "Topic and Service name mapping to DDS": a name is absolute (`/a/b`),
relative (`a/b`, under the node's namespace) or private (`~/a`, under the node's fully qualified
name); on DDS a topic is `rt<name>`, a service's request and reply topics `rq<name>Request` and
`rr<name>Reply`.
"""

from __future__ import annotations

import os
import re

import numpy as np

from dmprs.errors import InvalidInputError

#: ROS 2 domain ids (RTPS port arithmetic leaves 0..232 usable).
MAX_DOMAIN_ID = 232


def domain_id(value: int | None = None) -> int:
    """The ROS 2 domain to join: ``value``, or, when it is None, ``ROS_DOMAIN_ID`` as every ROS 2
    tool reads it (0 when unset or empty). Raises naming the id (or the variable) outside
    0..:data:`MAX_DOMAIN_ID`.
    """
    name = "domain_id"
    if value is None:
        raw = os.environ.get("ROS_DOMAIN_ID", "").strip()
        if not raw:
            return 0
        name = "ROS_DOMAIN_ID"
        try:
            value = int(raw)
        except ValueError:
            raise InvalidInputError(f"ROS_DOMAIN_ID = {raw!r} must be an integer in 0..{MAX_DOMAIN_ID}") from None
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 0 <= value <= MAX_DOMAIN_ID:
        raise InvalidInputError(f"{name} = {value!r} must be an integer in 0..{MAX_DOMAIN_ID}")
    return int(value)

_TOKEN = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")


def _check_tokens(name: str, what: str) -> None:
    tokens = name.strip("/").split("/") if name.strip("/") else []
    for token in tokens:
        if not _TOKEN.fullmatch(token) or "__" in token:
            raise InvalidInputError(
                f"{what} {name!r}: each part must be letters, digits and single underscores, "
                f"not starting with a digit (bad part {token!r})"
            )


def check_namespace(namespace: str) -> str:
    """A node namespace, absolute and without a trailing slash ('/' for none)."""
    if not namespace.startswith("/"):
        namespace = "/" + namespace
    if len(namespace) > 1 and namespace.endswith("/"):
        raise InvalidInputError(f"namespace {namespace!r} must not end with '/'")
    if "//" in namespace:
        raise InvalidInputError(f"namespace {namespace!r} has an empty part")
    _check_tokens(namespace, "namespace")
    return namespace


def check_node_name(name: str) -> str:
    """``name`` if it is a valid ROS 2 node name, else an InvalidInputError."""
    if not _TOKEN.fullmatch(name) or "__" in name:
        raise InvalidInputError(f"node name {name!r}: letters, digits and single underscores only")
    return name


def resolve(name: str, namespace: str = "/", node_name: str | None = None) -> str:
    """The fully qualified ROS name of `name` for a node `node_name` in `namespace`."""
    if not name or name.endswith("/") or "//" in name:
        raise InvalidInputError(f"ROS name {name!r} is empty, ends with '/' or has an empty part")
    namespace = check_namespace(namespace)
    if name.startswith("~"):
        if node_name is None:
            raise InvalidInputError(f"ROS name {name!r}: '~' needs a node name")
        if name != "~" and not name.startswith("~/"):
            raise InvalidInputError(f"ROS name {name!r}: '~' must be followed by '/'")
        base = namespace.rstrip("/") + "/" + check_node_name(node_name)
        full = base + name[1:]
    elif name.startswith("/"):
        full = name
    else:
        full = namespace.rstrip("/") + "/" + name
    _check_tokens(full, "ROS name")
    return full


def topic_dds_name(full_name: str) -> str:
    """DDS topic of a ROS topic: `/joint_states` -> `rt/joint_states`."""
    return "rt" + full_name


def service_dds_names(full_name: str) -> tuple[str, str]:
    """DDS request and reply topics of a ROS service."""
    return "rq" + full_name + "Request", "rr" + full_name + "Reply"
