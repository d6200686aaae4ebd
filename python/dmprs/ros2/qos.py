"""ROS 2's QoS profiles (rmw/qos_profiles.h, rcl_action, rclcpp's ClockQoS) and their DDS form.

Every profile also fixes the data representation to XCDR1, the one ROS 2 nodes write and read.
"""

from __future__ import annotations

import dataclasses

from cyclonedds.core import Policy, Qos
from cyclonedds.util import duration

from dmprs._arrays import as_count
from dmprs.errors import InvalidInputError

#: the deepest keep-last history DDS can hold (a 32-bit signed integer)
MAX_DEPTH = 2**31 - 1


@dataclasses.dataclass(frozen=True)
class QosProfile:
    """A ROS 2 QoS profile: reliability, durability and keep-last depth (0 = keep all)."""

    reliable: bool = True
    transient_local: bool = False
    depth: int = 10

    def __post_init__(self) -> None:
        depth = as_count(self.depth, "QoS depth", 0)
        # DDS holds the depth in 32 bits: Cyclone would take a larger one modulo 2**32, silently
        if depth > MAX_DEPTH:
            raise InvalidInputError(f"QoS depth = {depth} is invalid: at most 2**31 - 1 (0 keeps all)")
        object.__setattr__(self, "depth", depth)

    def with_depth(self, depth: int) -> QosProfile:
        """This profile with another history depth."""
        return dataclasses.replace(self, depth=depth)

    def to_cyclone(self, user_data: bytes | None = None) -> Qos:
        """The profile as Cyclone DDS policies (with ROS 2's user data, if given)."""
        policies = [
            Policy.Reliability.Reliable(duration(infinite=True)) if self.reliable else Policy.Reliability.BestEffort,
            Policy.Durability.TransientLocal if self.transient_local else Policy.Durability.Volatile,
            Policy.History.KeepLast(self.depth) if self.depth else Policy.History.KeepAll,
            Policy.DataRepresentation(use_cdrv0_representation=True),
            # as rmw_cyclonedds: unregistering a writer does not dispose its (keyless) instance
            Policy.WriterDataLifecycle(autodispose=False),
        ]
        if user_data is not None:
            policies.append(Policy.Userdata(user_data))
        return Qos(*policies)


#: rmw_qos_profile_default: reliable, volatile, keep last 10.
DEFAULT = QosProfile()
#: rmw_qos_profile_sensor_data: best effort, volatile, keep last 5.
SENSOR_DATA = QosProfile(reliable=False, depth=5)
#: rmw_qos_profile_services_default: reliable, volatile, keep last 10.
SERVICES = QosProfile()
#: rclcpp's ClockQoS: sensor data with depth 1.
CLOCK = QosProfile(reliable=False, depth=1)
#: rcl_action's status topic: reliable, transient local, keep last 1.
ACTION_STATUS = QosProfile(transient_local=True, depth=1)
