//! A simulated ros2_control robot on the ROS 2 wire, built on ros2-client (RustDDS).
//!
//! [`RobotNode`] shows what a robot running a `joint_trajectory_controller` shows: the
//! `<controller>/follow_joint_trajectory` action server and `<controller>/joint_trajectory`
//! topic, a `forward_position_controller`'s command topic, `/joint_states`, `/clock` and named
//! signal topics. It is the peer of dmprs's own ROS 2 side (Cyclone DDS, in Python), so that
//! every exchange crosses two independent ROS 2 implementations. Services use rmw_cyclonedds's
//! request header (ros2-client's `ServiceMapping::Cyclone`).

pub mod cdr;
pub mod goals;
pub mod msgs;
pub mod probe;
mod robot;
pub mod validate;

pub use goals::{GoalId, GoalStatus, GoalTableError};
pub use robot::{AcceptedGoal, Rejection, RobotConfig, RobotNode, SignalKind, TargetPose};

/// What can go wrong on the robot's side.
#[derive(Debug, thiserror::Error)]
pub enum RobotError {
    /// A bad argument: the message names it.
    #[error("{0}")]
    InvalidInput(String),
    /// Joining the domain or creating an entity failed.
    #[error("could not create the robot node's {0}")]
    Create(String),
    /// Publishing or answering on the wire failed.
    #[error("could not send {0}")]
    Write(String),
    /// A sample could not be decoded.
    #[error("could not read {0}")]
    Read(String),
    /// A goal operation out of order (unknown goal, finished goal, non-terminal end).
    #[error(transparent)]
    Goal(#[from] GoalTableError),
    /// The node was shut down.
    #[error("the robot node has been shut down")]
    Stopped,
}

fn wire<T, E: std::fmt::Debug>(result: Result<T, E>, what: &str) -> Result<(), RobotError> {
    result
        .map(|_| ())
        .map_err(|e| RobotError::Write(format!("{what}: {e:?}")))
}
