"""A ROS 2 node on Cyclone DDS: a participant in a domain, with publishers and subscriptions.

Every wait blocks in Cyclone (a waitset on a read condition) for at most its timeout; nothing
polls in a loop.
"""

from __future__ import annotations

import math
import time
from typing import Any, Generic, Self, TypeVar

from cyclonedds.core import (
    DDSException,
    DDSStatus,
    GuardCondition,
    InstanceState,
    ReadCondition,
    SampleState,
    ViewState,
    WaitSet,
)
from cyclonedds.domain import Domain, DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration

from dmprs.errors import AdapterError, InvalidInputError
from dmprs.ros2 import names
from dmprs.ros2.qos import DEFAULT, QosProfile

M = TypeVar("M")

MAX_DOMAIN_ID = names.MAX_DOMAIN_ID

#: A Cyclone configuration that keeps a node on the loopback interface, discovering peers by
#: unicast there (loopback carries no multicast on Linux): it advertises and sends on 127.0.0.1
#: only. Cyclone still binds its unicast receive sockets to the wildcard address (no setting of
#: its configuration binds them to an interface).
LOOPBACK_CONFIG = (
    "<CycloneDDS><Domain id='any'><General><Interfaces><NetworkInterface address='127.0.0.1'/>"
    "</Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery>"
    "<ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>30</MaxAutoParticipantIndex>"
    "<Peers><Peer address='127.0.0.1'/></Peers></Discovery></Domain></CycloneDDS>"
)


def check_timeout(timeout: float) -> int:
    """A timeout in seconds as DDS nanoseconds; it must be finite and >= 0."""
    if not isinstance(timeout, (int, float)) or not math.isfinite(timeout) or timeout < 0:
        raise InvalidInputError(f"timeout {timeout!r} must be a finite number of seconds >= 0")
    return int(timeout * 1e9)


def stamp_seconds(message: Any) -> float:
    """A sample's time: its header stamp when it has one, else when the publisher wrote it."""
    header = getattr(message, "header", None)
    if header is not None:
        return float(header.stamp.sec + header.stamp.nanosec * 1e-9)
    return float(message.sample_info.source_timestamp * 1e-9)


class Node:
    """A ROS 2 node: `Node("dmprs", domain_id=0)`; close it (or use `with`) to leave the domain.
    Without `domain_id` it joins `ROS_DOMAIN_ID`'s domain (0 when unset), as a ROS 2 node does.

    `config` is a Cyclone XML configuration for the domain (e.g. `LOOPBACK_CONFIG`); without it
    Cyclone reads `CYCLONEDDS_URI` as a ROS 2 node would.
    """

    def __init__(self, name: str, domain_id: int | None = None, namespace: str = "/", config: str | None = None):
        domain_id = names.domain_id(domain_id)
        self.name = names.check_node_name(name)
        self.namespace = names.check_namespace(namespace)
        self.domain_id = domain_id
        # the Domain must outlive the participant, or Cyclone falls back to its default config
        try:
            self._domain = Domain(domain_id, config) if config is not None else None
            self.participant = DomainParticipant(domain_id)
        except DDSException as exc:
            why = (" (this process has joined the domain already, with its configuration: a second one "
                   "cannot be given)" if config is not None else "")
            raise AdapterError(f"cannot join ROS 2 domain {domain_id}{why}: {exc}") from None
        self._topics: dict[str, Topic] = {}
        self._closed = False

    def resolve(self, name: str) -> str:
        """The fully qualified name of a topic, service or action name for this node."""
        return names.resolve(name, self.namespace, self.name)

    def topic(self, dds_name: str, message_type: type[Any]) -> Topic:
        """The DDS topic `dds_name` carrying `message_type` (one per name and participant)."""
        self._check_open()
        topic = self._topics.get(dds_name)
        if topic is None:
            topic = self._topics[dds_name] = Topic(self.participant, dds_name, message_type)
        elif topic.data_type is not message_type:
            raise InvalidInputError(
                f"topic {dds_name!r} already carries {topic.data_type.__idl_typename__}, "
                f"not {message_type.__idl_typename__}"
            )
        return topic

    def create_publisher(self, message_type: type[M], topic: str, qos: QosProfile = DEFAULT) -> Publisher[M]:
        """A publisher of ``message_type`` on ``topic`` (resolved in this node's namespace)."""
        return Publisher(self, message_type, self.resolve(topic), qos)

    def create_subscription(
        self, message_type: type[M], topic: str, qos: QosProfile = DEFAULT
    ) -> Subscription[M]:
        """A subscription to ``message_type`` on ``topic`` (resolved in this node's namespace)."""
        return Subscription(self, message_type, self.resolve(topic), qos)

    def _check_open(self) -> None:
        if self._closed:
            raise AdapterError(f"node {self.name!r} is closed")

    def close(self) -> None:
        """Leave the domain: every entity of this node is deleted."""
        if not self._closed:
            self._closed = True
            self._topics.clear()
            # Cyclone's Python entities are kept in a registry until deleted explicitly; deleting
            # the participant deletes every reader, writer and topic under it
            self.participant.__del__()
            if self._domain is not None:
                self._domain.__del__()
                self._domain = None

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class Publisher(Generic[M]):
    """Publishes one message type on one topic."""

    def __init__(self, node: Node, message_type: type[M], full_name: str, qos: QosProfile):
        self.topic_name = full_name
        topic = node.topic(names.topic_dds_name(full_name), message_type)
        self._participant = node.participant
        self._writer = DataWriter(node.participant, topic, qos=qos.to_cyclone())

    def publish(self, message: M) -> None:
        """Write one message."""
        self._writer.write(message)

    def wait_for_acknowledgments(self, timeout: float = 5.0) -> bool:
        """Whether every matched reliable subscription acknowledged what was published, within
        ``timeout`` seconds: it has the messages.
        """
        return self._writer.wait_for_acks(check_timeout(timeout))

    def subscription_count(self) -> int:
        """Number of subscriptions matched now."""
        return int(self._writer.get_publication_matched_status().current_count)

    def wait_for_subscribers(self, count: int = 1, timeout: float = 5.0) -> bool:
        """Whether ``count`` subscriptions matched within ``timeout`` seconds."""
        return wait_for_matches(self._writer, self._participant, count, timeout, publication=True)


class Subscription(Generic[M]):
    """Receives one message type on one topic; samples wait in a history of `qos.depth`."""

    def __init__(self, node: Node, message_type: type[M], full_name: str, qos: QosProfile):
        self.topic_name = full_name
        topic = node.topic(names.topic_dds_name(full_name), message_type)
        self._participant = node.participant
        self._reader: DataReader[M] = DataReader(node.participant, topic, qos=qos.to_cyclone())
        self._unread = ReadCondition(
            self._reader, SampleState.NotRead | ViewState.Any | InstanceState.Alive
        )
        self._waitset = WaitSet(node.participant)
        self._waitset.attach(self._unread)
        # set by `interrupt` to end a wait early (from another thread)
        self.guard = GuardCondition(node.participant)
        self._waitset.attach(self.guard)

    def take(self, max_samples: int = 256) -> list[M]:
        """Every waiting sample (up to `max_samples`), oldest first, without blocking."""
        return list(self._reader.take(N=max_samples, condition=self._unread))

    def wait(self, timeout: float) -> bool:
        """Block until a sample waits (True) or `timeout` seconds pass (False)."""
        return self._waitset.wait(check_timeout(timeout)) > 0 and not self.guard.read()

    def interrupt(self) -> None:
        """Wake a thread blocked in `wait` (it returns False)."""
        self.guard.set(True)

    def take_one(self, timeout: float) -> M | None:
        """The oldest waiting sample, waiting for one at most `timeout` seconds; None if none came."""
        samples = self._reader.take(N=1, condition=self._unread)
        if not samples and self.wait(timeout):
            samples = self._reader.take(N=1, condition=self._unread)
        return samples[0] if samples else None

    def wait_for_sample(self, after: float, timeout: float) -> M | None:
        """The first sample stamped after `after` seconds (`stamp_seconds`), within `timeout`."""
        deadline = time.monotonic() + check_timeout(timeout) * 1e-9
        while True:
            for sample in self.take():
                if stamp_seconds(sample) > after:
                    return sample
            left = deadline - time.monotonic()
            if left <= 0 or not self.wait(left):
                return None

    def publisher_count(self) -> int:
        """Number of publishers matched now."""
        return int(self._reader.get_subscription_matched_status().current_count)

    def wait_for_publishers(self, count: int = 1, timeout: float = 5.0) -> bool:
        """Whether ``count`` publishers matched within ``timeout`` seconds."""
        return wait_for_matches(self._reader, self._participant, count, timeout, publication=False)


def wait_for_matches(
    entity: DataWriter[Any] | DataReader[Any],
    participant: DomainParticipant,
    count: int,
    timeout: float,
    publication: bool,
) -> bool:
    """Block until `entity` has matched `count` remote endpoints (True) or `timeout` passes."""
    mask = DDSStatus.PublicationMatched if publication else DDSStatus.SubscriptionMatched
    status = getattr(entity, "get_publication_matched_status" if publication else "get_subscription_matched_status")
    entity.set_status_mask(mask)
    waitset = WaitSet(participant)
    waitset.attach(entity)
    deadline = time.monotonic() + check_timeout(timeout) * 1e-9
    try:
        while int(status().current_count) < count:
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            waitset.wait(duration(seconds=left))
            entity.take_status(mask)
        return True
    finally:
        waitset.detach(entity)
