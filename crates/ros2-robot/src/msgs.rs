//! The ROS 2 messages the robot speaks, as serde structs in ROS's field order.
//!
//! CDR serializes a struct as its fields in declaration order, so these structs are the wire
//! format: field names and order follow the ROS 2 definitions (Humble and Jazzy agree on all of
//! them; control_msgs' FollowJointTrajectory is the 4.x/5.x one). `tests/cdr_fixtures.rs` checks
//! each against bytes serialized by rosbags.

use ros2_client::message::Message;
use serde::{Deserialize, Serialize};

macro_rules! ros_message {
    ($(#[$doc:meta])* $name:ident { $($field:ident : $ty:ty),* $(,)? }) => {
        $(#[$doc])*
        #[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
        pub struct $name {
            $(pub $field: $ty),*
        }
        impl Message for $name {}
    };
}

ros_message!(
    /// builtin_interfaces/msg/Time
    Time { sec: i32, nanosec: u32 }
);
ros_message!(
    /// builtin_interfaces/msg/Duration
    Duration { sec: i32, nanosec: u32 }
);
ros_message!(
    /// std_msgs/msg/Header
    Header { stamp: Time, frame_id: String }
);
ros_message!(
    /// trajectory_msgs/msg/JointTrajectoryPoint
    JointTrajectoryPoint {
        positions: Vec<f64>,
        velocities: Vec<f64>,
        accelerations: Vec<f64>,
        effort: Vec<f64>,
        time_from_start: Duration,
    }
);
ros_message!(
    /// trajectory_msgs/msg/JointTrajectory
    JointTrajectory { header: Header, joint_names: Vec<String>, points: Vec<JointTrajectoryPoint> }
);
ros_message!(
    /// geometry_msgs/msg/Vector3
    Vector3 { x: f64, y: f64, z: f64 }
);
ros_message!(
    /// geometry_msgs/msg/Quaternion
    Quaternion { x: f64, y: f64, z: f64, w: f64 }
);
ros_message!(
    /// geometry_msgs/msg/Transform
    Transform { translation: Vector3, rotation: Quaternion }
);
ros_message!(
    /// geometry_msgs/msg/Twist
    Twist { linear: Vector3, angular: Vector3 }
);
ros_message!(
    /// trajectory_msgs/msg/MultiDOFJointTrajectoryPoint
    MultiDofJointTrajectoryPoint {
        transforms: Vec<Transform>,
        velocities: Vec<Twist>,
        accelerations: Vec<Twist>,
        time_from_start: Duration,
    }
);
ros_message!(
    /// trajectory_msgs/msg/MultiDOFJointTrajectory
    MultiDofJointTrajectory {
        header: Header,
        joint_names: Vec<String>,
        points: Vec<MultiDofJointTrajectoryPoint>,
    }
);
ros_message!(
    /// control_msgs/msg/JointTolerance
    JointTolerance { name: String, position: f64, velocity: f64, acceleration: f64 }
);
ros_message!(
    /// control_msgs/msg/JointComponentTolerance
    JointComponentTolerance {
        joint_name: String,
        component: u16,
        position: f64,
        velocity: f64,
        acceleration: f64,
    }
);
ros_message!(
    /// control_msgs/action/FollowJointTrajectory_Goal
    FollowJointTrajectoryGoal {
        trajectory: JointTrajectory,
        multi_dof_trajectory: MultiDofJointTrajectory,
        path_tolerance: Vec<JointTolerance>,
        component_path_tolerance: Vec<JointComponentTolerance>,
        goal_tolerance: Vec<JointTolerance>,
        component_goal_tolerance: Vec<JointComponentTolerance>,
        goal_time_tolerance: Duration,
    }
);
ros_message!(
    /// control_msgs/action/FollowJointTrajectory_Result
    FollowJointTrajectoryResult { error_code: i32, error_string: String }
);
ros_message!(
    /// control_msgs/action/FollowJointTrajectory_Feedback
    FollowJointTrajectoryFeedback {
        header: Header,
        joint_names: Vec<String>,
        desired: JointTrajectoryPoint,
        actual: JointTrajectoryPoint,
        error: JointTrajectoryPoint,
        multi_dof_joint_names: Vec<String>,
        multi_dof_desired: MultiDofJointTrajectoryPoint,
        multi_dof_actual: MultiDofJointTrajectoryPoint,
        multi_dof_error: MultiDofJointTrajectoryPoint,
    }
);
ros_message!(
    /// sensor_msgs/msg/JointState
    JointState {
        header: Header,
        name: Vec<String>,
        position: Vec<f64>,
        velocity: Vec<f64>,
        effort: Vec<f64>,
    }
);
ros_message!(
    /// std_msgs/msg/Float64
    Float64 { data: f64 }
);
ros_message!(
    /// std_msgs/msg/MultiArrayDimension
    MultiArrayDimension { label: String, size: u32, stride: u32 }
);
ros_message!(
    /// std_msgs/msg/MultiArrayLayout
    MultiArrayLayout { dim: Vec<MultiArrayDimension>, data_offset: u32 }
);
ros_message!(
    /// std_msgs/msg/Float64MultiArray
    Float64MultiArray { layout: MultiArrayLayout, data: Vec<f64> }
);
ros_message!(
    /// geometry_msgs/msg/Point
    Point { x: f64, y: f64, z: f64 }
);
ros_message!(
    /// geometry_msgs/msg/PointStamped
    PointStamped { header: Header, point: Point }
);
ros_message!(
    /// geometry_msgs/msg/Pose
    Pose { position: Point, orientation: Quaternion }
);
ros_message!(
    /// geometry_msgs/msg/PoseStamped
    PoseStamped { header: Header, pose: Pose }
);
ros_message!(
    /// rosgraph_msgs/msg/Clock
    Clock { clock: Time }
);

/// control_msgs/action/FollowJointTrajectory_Result's error codes.
pub mod error_code {
    pub const SUCCESSFUL: i32 = 0;
    pub const INVALID_GOAL: i32 = -1;
    pub const INVALID_JOINTS: i32 = -2;
    pub const OLD_HEADER_TIMESTAMP: i32 = -3;
    pub const PATH_TOLERANCE_VIOLATED: i32 = -4;
    pub const GOAL_TOLERANCE_VIOLATED: i32 = -5;
}

impl Time {
    /// The stamp of `seconds` (any finite value; negative times count down from the epoch as ROS
    /// does: `sec` is floored, `nanosec` is the positive remainder).
    pub fn from_seconds(seconds: f64) -> Time {
        let total = (seconds * 1e9).round() as i64;
        Time {
            sec: total.div_euclid(1_000_000_000) as i32,
            nanosec: total.rem_euclid(1_000_000_000) as u32,
        }
    }

    pub fn seconds(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}

impl Duration {
    pub fn from_seconds(seconds: f64) -> Duration {
        let Time { sec, nanosec } = Time::from_seconds(seconds);
        Duration { sec, nanosec }
    }

    pub fn seconds(&self) -> f64 {
        f64::from(self.sec) + f64::from(self.nanosec) * 1e-9
    }
}

impl Header {
    pub fn stamped(seconds: f64) -> Header {
        Header {
            stamp: Time::from_seconds(seconds),
            frame_id: String::new(),
        }
    }
}

ros_message!(
    /// unique_identifier_msgs/msg/UUID
    Uuid { uuid: [u8; 16] }
);
ros_message!(
    /// action_msgs/msg/GoalInfo
    GoalInfo { goal_id: Uuid, stamp: Time }
);
ros_message!(
    /// action_msgs/srv/CancelGoal_Request
    CancelGoalRequest { goal_info: GoalInfo }
);
