"""dmprs.ros2.messages against rosbags: the same bytes for every type on the wire, both ways."""

from __future__ import annotations

import pytest
from rosbags.typesys import Stores, get_typestore

from dmprs.ros2 import messages as m


def _time(sec: int, nanosec: int) -> object:
    return m.Time(sec=sec, nanosec=nanosec)


def _header(frame: str = "base_link") -> object:
    return m.Header(stamp=_time(1_700_000_000, 123_456_789), frame_id=frame)


def _point(k: int, with_rates: bool = True) -> object:
    return m.JointTrajectoryPoint(
        positions=[0.5 * k, -1.25, 3.0e-7],
        velocities=[0.1, 0.2, -0.3] if with_rates else [],
        accelerations=[1.5, 0.0, -2.0] if with_rates else [],
        effort=[],
        time_from_start=m.Duration(sec=k, nanosec=250_000_000),
    )


def _trajectory() -> object:
    return m.JointTrajectory(header=_header(), joint_names=["shoulder", "elbow", "wrist_ü"], points=[_point(1), _point(2, False)])


def _goal_id(n: int) -> object:
    return m.UUID(uuid=bytes((n * 37 + i) % 256 for i in range(16)))


def _goal() -> object:
    tolerance = m.message_class("control_msgs/msg/JointTolerance")
    component = m.message_class("control_msgs/msg/JointComponentTolerance")
    return m.FollowJointTrajectory_Goal(
        trajectory=_trajectory(),
        path_tolerance=[tolerance(name="elbow", position=0.05, velocity=0.5, acceleration=-1.0)],
        component_path_tolerance=[component(joint_name="base", component=4, position=0.01)],
        goal_tolerance=[tolerance(name="shoulder", position=0.001)],
        goal_time_tolerance=m.Duration(sec=0, nanosec=500_000_000),
    )


def _feedback() -> object:
    return m.FollowJointTrajectory_Feedback(
        header=_header(), joint_names=["shoulder", "elbow", "wrist_ü"], desired=_point(1), actual=_point(2), error=_point(3)
    )


def _goal_info(n: int) -> object:
    return m.GoalInfo(goal_id=_goal_id(n), stamp=_time(12, 34))


# one non-trivial value of every type dmprs puts on the wire
VALUES = {
    "trajectory_msgs/msg/JointTrajectory": _trajectory,
    "sensor_msgs/msg/JointState": lambda: m.JointState(
        header=_header(), name=["a", "b"], position=[1.0, -2.5], velocity=[0.25, 1e-9], effort=[]
    ),
    "geometry_msgs/msg/PoseStamped": lambda: m.PoseStamped(
        header=_header("map"),
        pose=m.message_class("geometry_msgs/msg/Pose")(
            position=m.message_class("geometry_msgs/msg/Point")(x=1.0, y=-2.0, z=0.5),
            orientation=m.message_class("geometry_msgs/msg/Quaternion")(x=0.0, y=0.6, z=0.0, w=0.8),
        ),
    ),
    "std_msgs/msg/Float64": lambda: m.Float64(data=-3.14159),
    "std_msgs/msg/Float64MultiArray": lambda: m.Float64MultiArray(
        layout=m.message_class("std_msgs/msg/MultiArrayLayout")(
            dim=[m.message_class("std_msgs/msg/MultiArrayDimension")(label="joints", size=3, stride=3)], data_offset=1
        ),
        data=[0.1, 0.2, 0.3],
    ),
    "geometry_msgs/msg/PointStamped": lambda: m.PointStamped(
        header=_header(), point=m.message_class("geometry_msgs/msg/Point")(x=0.25, y=-0.5, z=7.0)
    ),
    "rosgraph_msgs/msg/Clock": lambda: m.Clock(clock=_time(42, 999_999_999)),
    "control_msgs/action/FollowJointTrajectory_Goal": _goal,
    "control_msgs/action/FollowJointTrajectory_Result": lambda: m.FollowJointTrajectory_Result(
        error_code=m.FollowJointTrajectory_Result.GOAL_TOLERANCE_VIOLATED, error_string="elbow off by 0.2 rad"
    ),
    "control_msgs/action/FollowJointTrajectory_Feedback": _feedback,
    "control_msgs/action/FollowJointTrajectory_FeedbackMessage": lambda: m.FollowJointTrajectory_FeedbackMessage(
        goal_id=_goal_id(1), feedback=_feedback()
    ),
    "control_msgs/action/FollowJointTrajectory_SendGoal_Request": lambda: m.FollowJointTrajectory_SendGoal_Request(
        goal_id=_goal_id(2), goal=_goal()
    ),
    "control_msgs/action/FollowJointTrajectory_SendGoal_Response": lambda: m.FollowJointTrajectory_SendGoal_Response(
        accepted=True, stamp=_time(5, 6)
    ),
    "control_msgs/action/FollowJointTrajectory_GetResult_Request": lambda: m.FollowJointTrajectory_GetResult_Request(
        goal_id=_goal_id(3)
    ),
    "control_msgs/action/FollowJointTrajectory_GetResult_Response": lambda: m.FollowJointTrajectory_GetResult_Response(
        status=m.GoalStatus.STATUS_ABORTED,
        result=m.FollowJointTrajectory_Result(error_code=-4, error_string="path"),
    ),
    "action_msgs/srv/CancelGoal_Request": lambda: m.CancelGoal_Request(goal_info=_goal_info(4)),
    "action_msgs/srv/CancelGoal_Response": lambda: m.CancelGoal_Response(
        return_code=m.CancelGoal_Response.ERROR_NONE, goals_canceling=[_goal_info(5), _goal_info(6)]
    ),
    "action_msgs/msg/GoalStatusArray": lambda: m.GoalStatusArray(
        status_list=[m.GoalStatus(goal_info=_goal_info(7), status=m.GoalStatus.STATUS_EXECUTING)]
    ),
}


@pytest.mark.parametrize("ros_type", sorted(VALUES))
def test_cyclone_bytes_equal_rosbags_bytes_and_round_trip(ros_type: str) -> None:
    message = VALUES[ros_type]()
    assert type(message).ros_type == ros_type
    wire = message.serialize()
    # XCDR1 little-endian, ROS 2's encapsulation
    assert wire[:4] == b"\x00\x01\x00\x00"
    store = m.typestore()
    assert bytes(store.serialize_cdr(m.to_rosbags(message), ros_type)) == wire
    assert type(message).deserialize(wire) == message
    assert m.from_rosbags(store.deserialize_cdr(wire, ros_type), ros_type) == message


def test_dds_type_names_are_rmw_cyclonedds_names() -> None:
    assert m.JointTrajectory.__idl_typename__ == "trajectory_msgs::msg::dds_::JointTrajectory_"
    assert (
        m.FollowJointTrajectory_SendGoal_Request.__idl_typename__
        == "control_msgs::action::dds_::FollowJointTrajectory_SendGoal_Request_"
    )
    assert m.CancelGoal_Response.__idl_typename__ == "action_msgs::srv::dds_::CancelGoal_Response_"


def test_humble_and_jazzy_agree_on_every_type_from_rosbags() -> None:
    humble, jazzy = get_typestore(Stores.ROS2_HUMBLE), get_typestore(Stores.ROS2_JAZZY)
    shipped = {t for t in m.typestore().fielddefs if t.startswith(("control_msgs/", "action_msgs/srv/"))}
    seen: set[str] = set()

    def walk(ros_type: str) -> None:
        if ros_type in seen:
            return
        seen.add(ros_type)
        _, fields = m.typestore().fielddefs[ros_type]
        for _, node in fields:
            while node[0] in (3, 4):  # array, sequence
                node = node[1][0]
            if node[0] == 2:
                walk(node[1])

    for ros_type in VALUES:
        walk(ros_type)
    from_rosbags = seen - shipped
    assert "builtin_interfaces/msg/Time" in from_rosbags and "control_msgs/msg/JointTolerance" in seen
    for ros_type in from_rosbags:
        assert humble.fielddefs[ros_type] == jazzy.fielddefs[ros_type], ros_type


def test_defaults_are_ros_defaults_and_constants_are_class_attributes() -> None:
    goal = m.FollowJointTrajectory_Goal()
    assert goal.trajectory.points == [] and goal.goal_time_tolerance == m.Duration(sec=0, nanosec=0)
    assert m.UUID().uuid == bytes(16)
    assert m.GoalStatus.STATUS_SUCCEEDED == 4 and m.CancelGoal_Response.ERROR_UNKNOWN_GOAL_ID == 2
    assert m.FollowJointTrajectory_Result.INVALID_JOINTS == -2


def test_unknown_type_is_refused_by_name() -> None:
    from dmprs.errors import InvalidInputError

    with pytest.raises(InvalidInputError, match="nope_msgs/msg/Nothing"):
        m.message_class("nope_msgs/msg/Nothing")
