"""ROS 2 on the wire, on Cyclone DDS (the DDS of ROS 2's tier-1 rmw_cyclonedds).

A `Node` joins a ROS 2 domain; it publishes and subscribes to topics with ROS 2's names and QoS
profiles, calls services and drives actions (`ActionClient`) in rmw_cyclonedds's wire format;
`JointStateRecorder` records `/joint_states` by joint name; `Ros2TrajectoryAdapter` is a dmprs
adapter for a robot's `joint_trajectory_controller` and `Ros2PoseAdapter` one for a Cartesian
controller fed a stream of target poses, their outcome signals read from topics (`SignalTopic`);
`stream` runs a DMP's stepper online against a forward position controller.
Message classes are generated from
ROS's own definitions in `dmprs.ros2.messages`. Needs the `ros2` extra (cyclonedds, rosbags).
"""

from dmprs.ros2.action import STATUS_NAMES, ActionClient, GoalHandle
from dmprs.ros2.adapter import Ros2Adapter, Ros2TrajectoryAdapter, SignalTopic, signal_specs
from dmprs.ros2.cartesian import CARTESIAN_CONTROLLER, Ros2PoseAdapter
from dmprs.ros2.node import LOOPBACK_CONFIG, MAX_DOMAIN_ID, Node, Publisher, Subscription, stamp_seconds
from dmprs.ros2.qos import ACTION_STATUS, CLOCK, DEFAULT, SENSOR_DATA, SERVICES, QosProfile
from dmprs.ros2.recorder import JointRecording, JointStateRecorder
from dmprs.ros2.service import ServiceClient, ServiceServer
from dmprs.ros2.streaming import FORWARD_COMMANDS, StreamResult, stream

__all__ = [
    "ACTION_STATUS",
    "CARTESIAN_CONTROLLER",
    "CLOCK",
    "DEFAULT",
    "FORWARD_COMMANDS",
    "LOOPBACK_CONFIG",
    "MAX_DOMAIN_ID",
    "SENSOR_DATA",
    "SERVICES",
    "STATUS_NAMES",
    "ActionClient",
    "GoalHandle",
    "JointRecording",
    "JointStateRecorder",
    "Node",
    "Publisher",
    "QosProfile",
    "Ros2Adapter",
    "Ros2PoseAdapter",
    "Ros2TrajectoryAdapter",
    "ServiceClient",
    "ServiceServer",
    "SignalTopic",
    "StreamResult",
    "Subscription",
    "signal_specs",
    "stamp_seconds",
    "stream",
]
