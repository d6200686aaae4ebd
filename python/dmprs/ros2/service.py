"""A ROS 2 service client speaking rmw_cyclonedds's wire format.

rmw_cyclonedds sends a request on `rq/<service>Request` and the reply on `rr/<service>Reply`, each
sample being the message preceded by `cdds_request_header_t` (a uint64 naming the client, the
instance handle of its request writer, and an int64 sequence number); the server copies that
header into its reply, and the client keeps the replies that carry its own id. The client's
request writer and reply reader carry `clientid=<id>;` in their USER_DATA, which an
rmw_cyclonedds server uses to wait for the client's reply reader before it answers.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import os
import time
from typing import Any, cast

from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet
from cyclonedds.idl import IdlStruct
from cyclonedds.idl import types as idl
from cyclonedds.idl._main import IdlMeta
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader

from dmprs.errors import AdapterError, InvalidInputError
from dmprs.ros2 import messages, names
from dmprs.ros2.node import Node, check_timeout, wait_for_matches
from dmprs.ros2.qos import SERVICES, QosProfile

#: The two header fields rmw_cyclonedds puts before a request's or reply's own fields.
HEADER_FIELDS = ("cdds_request_guid", "cdds_request_seq")

#: rmw_cyclonedds's server waits this long for a client's reply reader before answering; the
#: client gives a server the same margin to match its reply reader after it has matched them.
MATCH_MARGIN = 0.1


@functools.cache
def _wrapped(ros_type: str) -> type[Any]:
    """The message class of `ros_type` with rmw_cyclonedds's request header in front, under the
    same DDS name (one class per type, so that every client of a node shares its topics).
    """
    message_type = messages.message_class(ros_type)
    name = message_type.__name__ + "_Wrapped"
    namespace = cast(dict[str, Any], IdlMeta.__prepare__(name, (IdlStruct,), typename=message_type.__idl_typename__))
    namespace["__idl_annotations__"]["extensibility"] = "final"
    namespace["__annotations__"].update({HEADER_FIELDS[0]: idl.uint64, HEADER_FIELDS[1]: idl.int64})
    namespace["__annotations__"].update(message_type.__annotations__)
    return dataclasses.dataclass(IdlMeta(name, (IdlStruct,), namespace))


def wrap(wrapped_type: type[Any], guid: int, seq: int, message: Any) -> Any:
    """``message`` in the request/reply wrapper of rmw_cyclonedds (writer guid, sequence number)."""
    fields = {f: getattr(message, f) for f in type(message).__annotations__}
    return wrapped_type(**{HEADER_FIELDS[0]: guid, HEADER_FIELDS[1]: seq}, **fields)


def unwrap(message_type: type[Any], sample: Any) -> Any:
    """The ``message_type`` message inside a request/reply wrapper."""
    return message_type(**{f: getattr(sample, f) for f in message_type.__annotations__})


def _endpoint_id(key: bytes) -> bytes:
    """An id in rmw_cyclonedds's USER_DATA form: `<key>=<16 hex bytes joined by .>;`."""
    return key + b"=" + ".".join(f"{b:x}" for b in os.urandom(16)).encode() + b";"


class _ServiceEndpoints:
    """One side's writer and reader of a service's request and reply topics.

    rmw_cyclonedds tags both endpoints of a client (or of a service) with one id in their
    USER_DATA, `clientid=<id>;` (`serviceid=<id>;`).
    """

    def __init__(self, node: Node, service_type: str, service: str, qos: QosProfile, server: bool):
        self.service_name = node.resolve(service)
        self.request_type = messages.message_class(service_type + "_Request")
        self.response_type = messages.message_class(service_type + "_Response")
        self._request_wire = _wrapped(service_type + "_Request")
        self._response_wire = _wrapped(service_type + "_Response")
        request_name, reply_name = names.service_dds_names(self.service_name)
        request_topic = node.topic(request_name, self._request_wire)
        reply_topic = node.topic(reply_name, self._response_wire)
        tag = _endpoint_id(b"serviceid" if server else b"clientid")
        writes, reads = (reply_topic, request_topic) if server else (request_topic, reply_topic)
        self._participant = node.participant
        self._writer = DataWriter(node.participant, writes, qos=qos.to_cyclone(tag))
        self._reader: DataReader[Any] = DataReader(node.participant, reads, qos=qos.to_cyclone(tag))
        self._unread = ReadCondition(self._reader, SampleState.NotRead | ViewState.Any | InstanceState.Alive)
        self._waitset = WaitSet(node.participant)
        self._waitset.attach(self._unread)


class ServiceClient(_ServiceEndpoints):
    """Calls one ROS 2 service, e.g. `ServiceClient(node, "action_msgs/srv/CancelGoal", "/x/_action/cancel_goal")`.

    `service_type` names the request and response types without their `_Request`/`_Response`
    suffix.
    """

    _sequence = itertools.count(1)

    def __init__(self, node: Node, service_type: str, service: str, qos: QosProfile = SERVICES):
        super().__init__(node, service_type, service, qos, server=False)
        # rmw_cyclonedds names the client by its request writer's instance handle (a uint64)
        self.client_guid = int(self._writer.get_instance_handle()) & 0xFFFF_FFFF_FFFF_FFFF
        self._replies: dict[int, Any] = {}
        self._forgotten: set[int] = set()
        self._matched = False

    def wait_for_server(self, timeout: float) -> bool:
        """Block until a server matches both the request and the reply topic (True) or `timeout`."""
        if self._matched:
            return True
        deadline = time.monotonic() + check_timeout(timeout) * 1e-9
        for entity, publication in ((self._writer, True), (self._reader, False)):
            if not wait_for_matches(entity, self._participant, 1, max(0.0, deadline - time.monotonic()), publication):
                return False
        time.sleep(MATCH_MARGIN)
        self._matched = True
        return True

    def send(self, request: Any) -> int:
        """Send `request` and return its sequence number (for `wait_for_reply`)."""
        if not isinstance(request, self.request_type):
            raise InvalidInputError(
                f"{self.service_name} takes {self.request_type.__name__}, not {type(request).__name__}"
            )
        seq = next(self._sequence)
        self._writer.write(wrap(self._request_wire, self.client_guid, seq, request))
        return seq

    def wait_for_reply(self, seq: int, timeout: float) -> Any | None:
        """The reply to request `seq`, waiting at most `timeout` seconds; None if it did not come."""
        deadline = time.monotonic() + check_timeout(timeout) * 1e-9
        while True:
            for sample in self._reader.take(N=64, condition=self._unread):
                if getattr(sample, HEADER_FIELDS[0]) == self.client_guid:
                    number = getattr(sample, HEADER_FIELDS[1])
                    if number in self._forgotten:
                        self._forgotten.discard(number)
                    else:
                        self._replies[number] = unwrap(self.response_type, sample)
            if seq in self._replies:
                return self._replies.pop(seq)
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            self._waitset.wait(int(left * 1e9))

    def forget(self, seq: int) -> None:
        """Request `seq`'s reply is no longer wanted: dropped now, or when it comes."""
        if self._replies.pop(seq, None) is None:
            self._forgotten.add(seq)

    def call(self, request: Any, timeout: float) -> Any:
        """Send `request` and return the reply; AdapterError if no server answers in `timeout`."""
        deadline = time.monotonic() + check_timeout(timeout) * 1e-9
        if not self.wait_for_server(timeout):
            raise AdapterError(f"no server for {self.service_name} within {timeout} s")
        reply = self.wait_for_reply(self.send(request), max(0.0, deadline - time.monotonic()))
        if reply is None:
            raise AdapterError(f"{self.service_name} did not answer within {timeout} s")
        return reply


class ServiceServer(_ServiceEndpoints):
    """Answers one ROS 2 service in rmw_cyclonedds's wire format: each reply carries its request's
    header back, so that the client that sent it keeps it.
    """

    def __init__(self, node: Node, service_type: str, service: str, qos: QosProfile = SERVICES):
        super().__init__(node, service_type, service, qos, server=True)
        #: (client id, sequence number) of the last request answered, as read from its header
        self.last_header: tuple[int, int] | None = None

    def serve(self, handler: Any, timeout: float) -> int:
        """Answer every waiting request with `handler(request)`, first waiting up to `timeout`
        seconds for one; returns how many were answered.
        """
        samples = self._reader.take(N=64, condition=self._unread)
        if not samples and self._waitset.wait(check_timeout(timeout)) > 0:
            samples = self._reader.take(N=64, condition=self._unread)
        for sample in samples:
            response = handler(unwrap(self.request_type, sample))
            guid, seq = (getattr(sample, f) for f in HEADER_FIELDS)
            self._writer.write(wrap(self._response_wire, guid, seq, response))
            self.last_header = (guid, seq)
        return len(samples)
