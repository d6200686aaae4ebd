//! The robot node: what a ros2_control robot with a joint_trajectory_controller shows on the wire.
//!
//! One thread owns the incoming side (goal, cancel and result requests of the
//! `<controller>/follow_joint_trajectory` action, the `<controller>/joint_trajectory` topic, the
//! streamed position commands, the Cartesian controller's target poses) and waits on them with mio, woken by the DDS readers or by
//! [`RobotNode::shutdown`]. What arrives is queued for the simulation, which polls it with a
//! timeout. The outgoing side (joint states, clock, signals, feedback, results) is published
//! from the caller's thread.

use std::collections::HashMap;
use std::net::{IpAddr, Ipv4Addr};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::Duration as StdDuration;

use ros2_client::action::{
    ActionServer, ActionServerQosPolicies, GetResultResponse, SendGoalResponse,
};
use ros2_client::action_msgs::{
    CancelGoalRequest, CancelGoalResponse, CancelGoalResponseEnum, GoalInfo as RosGoalInfo,
    GoalStatus as RosGoalStatus, GoalStatusArray, GoalStatusEnum,
};
use ros2_client::dds::rustdds::{
    self as rustdds, DomainParticipantBuilder, QosPolicyBuilder, TopicKind, policy,
};

use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token, Waker};
use ros2_client::dds::{Context, Node, Publisher, ServiceMapping, Subscription};
use ros2_client::qos::{Durability, History, QosProfile, Reliability, WhenFull};
use ros2_client::service::RmwRequestId;
use ros2_client::unique_identifier_msgs::UUID;
use ros2_client::{
    ActionTypeName, MessageTypeName, Name, NodeName, NodeOptions, WriteError, WriteResult,
    builtin_interfaces,
};

use crate::goals::{CancelReturn, GoalId, GoalStatus, GoalTable, ResultReply};
use crate::msgs::{
    Clock, Float64, Float64MultiArray, FollowJointTrajectoryFeedback, FollowJointTrajectoryGoal,
    FollowJointTrajectoryResult, Header, JointState, JointTrajectory, JointTrajectoryPoint, Point,
    PointStamped, Pose, PoseStamped, Quaternion, Time,
};
use crate::validate::check_trajectory;
use crate::{RobotError, wire};

/// How many finished goals the action server remembers for late result requests and the status
/// topic.
const KEEP_FINISHED_GOALS: usize = 64;
/// The longest error string a result carries (bytes, cut at a character): with the bounded
/// status array it keeps every message of the node under the ~64 KB that RustDDS sends to Cyclone
/// DDS in one piece (a larger one goes out in DATA_FRAG fragments that Cyclone drops).
pub const MAX_ERROR_STRING: usize = 4096;

/// `text` cut to at most [`MAX_ERROR_STRING`] bytes at a character boundary, marked as cut.
fn bounded(text: &str) -> String {
    if text.len() <= MAX_ERROR_STRING {
        return text.into();
    }
    let mut end = MAX_ERROR_STRING - "... (cut)".len();
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    format!("{}... (cut)", &text[..end])
}

/// The status arrays the action's status writer keeps for readers that have not acknowledged
/// them. Its durability is transient local (as rcl_action's), and RustDDS keeps every sample of
/// such a writer that no reader has acknowledged, up to 8192 by default: all of them while no
/// client subscribes to the status topic, or once the last one has left, each array a few
/// kilobytes (at most `MAX_UNFINISHED_GOALS + KEEP_FINISHED_GOALS` goals). With this bound
/// RustDDS drops the older ones each time it cleans its writers' histories (every few seconds).
const STATUS_HISTORY: i32 = 8;

/// The node thread drains every reader at this period even without an event, so an edge lost
/// between registration and the first poll delays nothing for longer.
const IDLE_DRAIN: StdDuration = StdDuration::from_millis(100);

const GOAL: Token = Token(0);
const CANCEL: Token = Token(1);
const RESULT: Token = Token(2);
const TRAJECTORY: Token = Token(3);
const COMMANDS: Token = Token(4);
const WAKE: Token = Token(5);
const POSES: Token = Token(6);

/// The kind of message a named signal topic carries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SignalKind {
    /// std_msgs/msg/Float64: one value, no stamp of its own.
    Float64,
    /// geometry_msgs/msg/PointStamped: three values and a stamp.
    PointStamped,
}

/// What the robot node exposes, named as a ros2_control setup names it.
#[derive(Clone, Debug)]
pub struct RobotConfig {
    pub domain_id: u16,
    pub node_name: String,
    /// The node's namespace ("/" for none); relative topic names resolve under it.
    pub namespace: String,
    /// The joint_trajectory_controller's name: its action is `<controller>/follow_joint_trajectory`.
    pub controller: String,
    pub joint_names: Vec<String>,
    /// Topic of streamed position commands (std_msgs/msg/Float64MultiArray).
    pub command_topic: String,
    /// A Cartesian controller (as FZI's cartesian_motion_controller): it follows the poses
    /// streamed on `<cartesian_controller>/target_frame` and publishes the end effector's on
    /// `<cartesian_controller>/current_pose` (both geometry_msgs/msg/PoseStamped).
    pub cartesian_controller: String,
    /// Named signal topics the simulation publishes.
    pub signals: Vec<(String, SignalKind)>,
    /// Advertise, discover and send on the loopback interface only (127.0.0.1). RustDDS still
    /// binds its receiving sockets to 0.0.0.0 (it offers no way to bind them to an interface).
    pub loopback_only: bool,
}

impl RobotConfig {
    pub fn new(domain_id: u16, controller: &str, joint_names: Vec<String>) -> RobotConfig {
        RobotConfig {
            domain_id,
            node_name: "dmprs_robot".into(),
            namespace: "/".into(),
            controller: controller.into(),
            joint_names,
            command_topic: "/forward_position_controller/commands".into(),
            cartesian_controller: "/cartesian_motion_controller".into(),
            signals: Vec::new(),
            loopback_only: true,
        }
    }
}

/// A goal the action server accepted; it is executing until [`RobotNode::finish_goal`].
#[derive(Clone, Debug)]
pub struct AcceptedGoal {
    pub id: GoalId,
    pub goal: FollowJointTrajectoryGoal,
}

/// A target pose received by the Cartesian controller: its header stamp (s), the frame it is
/// given in, and the pose as `[x, y, z, qw, qx, qy, qz]` (m, unit quaternion, dmprs's order).
#[derive(Clone, Debug, PartialEq)]
pub struct TargetPose {
    pub stamp: f64,
    pub frame_id: String,
    pub pose: [f64; 7],
}

/// A goal or trajectory the controller refused, and why (a ROS 2 rejection carries no reason on
/// the wire: this is the robot side's own record of it). `id` is `None` for the topic.
#[derive(Clone, Debug)]
pub struct Rejection {
    pub id: Option<GoalId>,
    pub reason: String,
}

type Server = ActionServer<
    FollowJointTrajectoryGoal,
    FollowJointTrajectoryResult,
    FollowJointTrajectoryFeedback,
>;

struct ActionSide {
    server: Server,
    /// The status topic's writer: the action server's own cannot be given resource limits.
    status: rustdds::no_key::DataWriterCdr<GoalStatusArray>,
    table: GoalTable<RmwRequestId>,
}

struct Outgoing {
    joint_states: Publisher<JointState>,
    clock: Publisher<Clock>,
    float_signals: HashMap<String, Publisher<Float64>>,
    point_signals: HashMap<String, Publisher<PointStamped>>,
    current_pose: Publisher<PoseStamped>,
}

/// One lock per queue, so that a caller blocked in `poll_goal` holds up no other poll.
struct Queues {
    goals: Mutex<Receiver<AcceptedGoal>>,
    rejections: Mutex<Receiver<Rejection>>,
    cancels: Mutex<Receiver<GoalId>>,
    trajectories: Mutex<Receiver<JointTrajectory>>,
    commands: Mutex<Receiver<Vec<f64>>>,
    poses: Mutex<Receiver<TargetPose>>,
}

struct Senders {
    goals: Sender<AcceptedGoal>,
    rejections: Sender<Rejection>,
    cancels: Sender<GoalId>,
    trajectories: Sender<JointTrajectory>,
    commands: Sender<Vec<f64>>,
    poses: Sender<TargetPose>,
}

/// A running robot node. Dropping it shuts it down.
pub struct RobotNode {
    config: RobotConfig,
    action: Arc<Mutex<ActionSide>>,
    outgoing: Outgoing,
    queues: Queues,
    stop: Arc<AtomicBool>,
    waker: Arc<Waker>,
    thread: Mutex<Option<JoinHandle<()>>>,
}

/// ROS 2's default QoS (rmw_qos_profile_default): reliable, volatile, keep last 10.
fn default_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability(Reliability::Reliable {
            when_full: WhenFull::DEFAULT,
        })
        .history(History::KeepLast { depth: 10 })
}

/// rcl_action's status topic QoS: reliable, transient local, keep last 1.
fn status_qos() -> QosProfile {
    default_qos()
        .durability(Durability::TransientLocal)
        .history(History::KeepLast { depth: 1 })
}

/// `text` as an absolute ROS name: a relative name is resolved under `namespace` here, since
/// ros2-client would put an empty token after the root namespace ("rt//name").
fn name(namespace: &str, text: &str, what: &str) -> Result<Name, RobotError> {
    let absolute = if text.starts_with('/') {
        text.to_string()
    } else {
        format!("{}/{text}", namespace.trim_end_matches('/'))
    };
    Name::parse(&absolute).map_err(|e| RobotError::InvalidInput(format!("{what} {text:?}: {e:?}")))
}

fn create<T, E: std::fmt::Debug>(result: Result<T, E>, what: &str) -> Result<T, RobotError> {
    result.map_err(|e| RobotError::Create(format!("{what}: {e:?}")))
}

impl RobotNode {
    /// Join the domain and start the node's thread.
    pub fn start(config: RobotConfig) -> Result<RobotNode, RobotError> {
        if config.joint_names.is_empty() {
            return Err(RobotError::InvalidInput(
                "the robot needs at least one joint".into(),
            ));
        }
        let mut builder = DomainParticipantBuilder::new(config.domain_id);
        if config.loopback_only {
            builder = builder.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)]);
        }
        let participant = create(builder.build(), "DDS participant")?;
        let dds = participant.clone();
        let context = create(
            Context::from_domain_participant(participant),
            "ROS 2 context",
        )?;
        let node_name = NodeName::new(&config.namespace, &config.node_name)
            .map_err(|e| RobotError::InvalidInput(format!("node {:?}: {e:?}", config.node_name)))?;
        let mut node = create(
            context.new_node(node_name, NodeOptions::new().enable_rosout(false)),
            "node",
        )?;

        let ns = config.namespace.as_str();
        let action_name = name(
            ns,
            &format!("{}/follow_joint_trajectory", config.controller),
            "controller",
        )?;
        let mut server: Server = create(
            node.create_action_server(
                ServiceMapping::Cyclone,
                &action_name,
                &ActionTypeName::new("control_msgs", "FollowJointTrajectory"),
                ActionServerQosPolicies {
                    goal_service: default_qos(),
                    result_service: default_qos(),
                    cancel_service: default_qos(),
                    feedback_publisher: default_qos(),
                    status_publisher: status_qos(),
                },
            ),
            "follow_joint_trajectory action server",
        )?;
        let status = status_writer(&dds, &action_name)?;

        let mut trajectory_sub: Subscription<JointTrajectory> = subscription(
            &mut node,
            &name(
                ns,
                &format!("{}/joint_trajectory", config.controller),
                "controller",
            )?,
            "trajectory_msgs",
            "JointTrajectory",
        )?;
        let mut command_sub: Subscription<Float64MultiArray> = subscription(
            &mut node,
            &name(ns, &config.command_topic, "topic")?,
            "std_msgs",
            "Float64MultiArray",
        )?;
        let cartesian = config.cartesian_controller.trim_end_matches('/');
        let mut pose_sub: Subscription<PoseStamped> = subscription(
            &mut node,
            &name(
                ns,
                &format!("{cartesian}/target_frame"),
                "cartesian controller",
            )?,
            "geometry_msgs",
            "PoseStamped",
        )?;

        let outgoing = Outgoing {
            joint_states: publisher(
                &mut node,
                &name(ns, "joint_states", "topic")?,
                "sensor_msgs",
                "JointState",
                default_qos(),
            )?,
            // rclcpp's ClockQoS readers are best effort; a reliable writer serves them and reliable ones
            clock: publisher(
                &mut node,
                &name("/", "/clock", "topic")?,
                "rosgraph_msgs",
                "Clock",
                default_qos().history(History::KeepLast { depth: 1 }),
            )?,
            float_signals: signal_publishers(
                &mut node,
                ns,
                &config.signals,
                SignalKind::Float64,
                "std_msgs",
                "Float64",
            )?,
            point_signals: signal_publishers(
                &mut node,
                ns,
                &config.signals,
                SignalKind::PointStamped,
                "geometry_msgs",
                "PointStamped",
            )?,
            current_pose: publisher(
                &mut node,
                &name(
                    ns,
                    &format!("{cartesian}/current_pose"),
                    "cartesian controller",
                )?,
                "geometry_msgs",
                "PoseStamped",
                default_qos(),
            )?,
        };

        let poll = create(Poll::new(), "mio poll")?;
        let registry = poll.registry();
        let register = |result: std::io::Result<()>| create(result, "mio registration");
        register(registry.register(server.goal_server(), GOAL, Interest::READABLE))?;
        register(registry.register(server.cancel_server(), CANCEL, Interest::READABLE))?;
        register(registry.register(server.result_server(), RESULT, Interest::READABLE))?;
        register(registry.register(&mut trajectory_sub, TRAJECTORY, Interest::READABLE))?;
        register(registry.register(&mut command_sub, COMMANDS, Interest::READABLE))?;
        register(registry.register(&mut pose_sub, POSES, Interest::READABLE))?;
        let waker = Arc::new(create(Waker::new(registry, WAKE), "mio waker")?);

        let (goals_tx, goals) = mpsc::channel();
        let (rejections_tx, rejections) = mpsc::channel();
        let (cancels_tx, cancels) = mpsc::channel();
        let (trajectories_tx, trajectories) = mpsc::channel();
        let (commands_tx, commands) = mpsc::channel();
        let (poses_tx, poses) = mpsc::channel();
        let senders = Senders {
            goals: goals_tx,
            rejections: rejections_tx,
            cancels: cancels_tx,
            trajectories: trajectories_tx,
            commands: commands_tx,
            poses: poses_tx,
        };
        let action = Arc::new(Mutex::new(ActionSide {
            server,
            status,
            table: GoalTable::new(KEEP_FINISHED_GOALS),
        }));
        let stop = Arc::new(AtomicBool::new(false));
        let incoming = Incoming {
            node,
            _context: context,
            action: Arc::clone(&action),
            trajectory_sub,
            command_sub,
            pose_sub,
            senders,
            joint_names: config.joint_names.clone(),
        };
        let thread_stop = Arc::clone(&stop);
        let thread = create(
            std::thread::Builder::new()
                .name("ros2-robot".into())
                .spawn(move || incoming.run(poll, &thread_stop)),
            "node thread",
        )?;
        Ok(RobotNode {
            config,
            action,
            outgoing,
            queues: Queues {
                goals: Mutex::new(goals),
                rejections: Mutex::new(rejections),
                cancels: Mutex::new(cancels),
                trajectories: Mutex::new(trajectories),
                commands: Mutex::new(commands),
                poses: Mutex::new(poses),
            },
            stop,
            waker,
            thread: Mutex::new(Some(thread)),
        })
    }

    pub fn config(&self) -> &RobotConfig {
        &self.config
    }

    fn action(&self) -> MutexGuard<'_, ActionSide> {
        lock(&self.action)
    }

    fn check_running(&self) -> Result<(), RobotError> {
        if self.stop.load(Ordering::Acquire) {
            Err(RobotError::Stopped)
        } else {
            Ok(())
        }
    }

    /// The next accepted goal, waiting at most `timeout`; `None` when none came.
    pub fn poll_goal(&self, timeout: StdDuration) -> Result<Option<AcceptedGoal>, RobotError> {
        self.check_running()?;
        match queue(&self.queues.goals).recv_timeout(timeout) {
            Ok(goal) => Ok(Some(goal)),
            Err(RecvTimeoutError::Timeout) => Ok(None),
            Err(RecvTimeoutError::Disconnected) => Err(RobotError::Stopped),
        }
    }

    /// Goals and trajectories refused since the last call.
    pub fn poll_rejections(&self) -> Vec<Rejection> {
        queue(&self.queues.rejections).try_iter().collect()
    }

    /// Goals a client asked to cancel since the last call; each is CANCELING until it is finished.
    pub fn poll_cancels(&self) -> Vec<GoalId> {
        queue(&self.queues.cancels).try_iter().collect()
    }

    /// Valid trajectories received on `<controller>/joint_trajectory` since the last call.
    pub fn poll_trajectories(&self) -> Vec<JointTrajectory> {
        queue(&self.queues.trajectories).try_iter().collect()
    }

    /// Position commands received since the last call, oldest first.
    pub fn poll_commands(&self) -> Vec<Vec<f64>> {
        queue(&self.queues.commands).try_iter().collect()
    }

    /// Target poses received by the Cartesian controller since the last call, oldest first.
    pub fn poll_poses(&self) -> Vec<TargetPose> {
        queue(&self.queues.poses).try_iter().collect()
    }

    /// Publish the Cartesian controller's `current_pose`: `pose` = `[x, y, z, qw, qx, qy, qz]`
    /// in `frame_id` at `stamp` (s).
    pub fn publish_pose(&self, stamp: f64, frame_id: &str, pose: &[f64]) -> Result<(), RobotError> {
        self.check_running()?;
        check_len("pose", pose, 7)?;
        let message = PoseStamped {
            header: Header {
                stamp: Time::from_seconds(check_stamp(stamp)?),
                frame_id: frame_id.into(),
            },
            pose: Pose {
                position: Point {
                    x: pose[0],
                    y: pose[1],
                    z: pose[2],
                },
                orientation: Quaternion {
                    w: pose[3],
                    x: pose[4],
                    y: pose[5],
                    z: pose[6],
                },
            },
        };
        stream_sample(self.outgoing.current_pose.publish(message), "current_pose")
    }

    /// Publish `/joint_states` with the controller's joint names.
    pub fn publish_joint_state(
        &self,
        stamp: f64,
        position: &[f64],
        velocity: &[f64],
    ) -> Result<(), RobotError> {
        self.check_running()?;
        let n = self.config.joint_names.len();
        check_len("position", position, n)?;
        if !velocity.is_empty() {
            check_len("velocity", velocity, n)?;
        }
        let message = JointState {
            header: Header::stamped(check_stamp(stamp)?),
            name: self.config.joint_names.clone(),
            position: position.to_vec(),
            velocity: velocity.to_vec(),
            effort: Vec::new(),
        };
        stream_sample(self.outgoing.joint_states.publish(message), "/joint_states")
    }

    /// Publish `/clock` at simulated time `seconds`.
    pub fn publish_clock(&self, seconds: f64) -> Result<(), RobotError> {
        self.check_running()?;
        let clock = Clock {
            clock: Time::from_seconds(check_stamp(seconds)?),
        };
        stream_sample(self.outgoing.clock.publish(clock), "/clock")
    }

    /// Publish a named signal: one value on a Float64 topic, three (x, y, z) on a PointStamped one.
    pub fn publish_signal(
        &self,
        topic: &str,
        values: &[f64],
        stamp: f64,
    ) -> Result<(), RobotError> {
        self.check_running()?;
        if values.iter().any(|v| !v.is_finite()) {
            return Err(RobotError::InvalidInput(format!(
                "signal {topic}: non-finite value"
            )));
        }
        if let Some(publisher) = self.outgoing.float_signals.get(topic) {
            check_len("a Float64 signal", values, 1)?;
            return wire(publisher.publish(Float64 { data: values[0] }), topic);
        }
        if let Some(publisher) = self.outgoing.point_signals.get(topic) {
            check_len("a PointStamped signal", values, 3)?;
            let message = PointStamped {
                header: Header::stamped(check_stamp(stamp)?),
                point: Point {
                    x: values[0],
                    y: values[1],
                    z: values[2],
                },
            };
            return wire(publisher.publish(message), topic);
        }
        Err(RobotError::InvalidInput(format!(
            "{topic:?} is not one of the robot's signal topics"
        )))
    }

    /// Publish feedback for an active goal; `error` is `desired - actual`, as the controller
    /// reports it.
    pub fn publish_feedback(
        &self,
        id: &GoalId,
        stamp: f64,
        desired: JointTrajectoryPoint,
        actual: JointTrajectoryPoint,
    ) -> Result<(), RobotError> {
        self.check_running()?;
        let n = self.config.joint_names.len();
        check_len("desired positions", &desired.positions, n)?;
        check_len("actual positions", &actual.positions, n)?;
        let difference = |a: &[f64], b: &[f64]| -> Vec<f64> {
            if a.len() == b.len() {
                a.iter().zip(b).map(|(x, y)| x - y).collect()
            } else {
                Vec::new()
            }
        };
        let error = JointTrajectoryPoint {
            positions: difference(&desired.positions, &actual.positions),
            velocities: difference(&desired.velocities, &actual.velocities),
            time_from_start: desired.time_from_start.clone(),
            ..Default::default()
        };
        let feedback = FollowJointTrajectoryFeedback {
            header: Header::stamped(check_stamp(stamp)?),
            joint_names: self.config.joint_names.clone(),
            desired,
            actual,
            error,
            ..Default::default()
        };
        let side = self.action();
        match side.table.status(id) {
            Some(GoalStatus::Executing | GoalStatus::Canceling) => {}
            Some(_) => {
                return Err(RobotError::Goal(crate::goals::GoalTableError::Finished(
                    *id,
                )));
            }
            None => return Err(RobotError::Goal(crate::goals::GoalTableError::Unknown(*id))),
        }
        wire(
            side.server.send_feedback(goal_uuid(id), feedback),
            "feedback",
        )
    }

    /// End an active goal with a terminal status and control_msgs' result fields; answers every
    /// result request waiting for it and publishes the new status.
    pub fn finish_goal(
        &self,
        id: &GoalId,
        status: GoalStatus,
        error_code: i32,
        error_string: &str,
    ) -> Result<(), RobotError> {
        self.check_running()?;
        let result = FollowJointTrajectoryResult {
            error_code,
            error_string: bounded(error_string),
        };
        let mut side = self.action();
        let waiting = side.table.finish(id, status, result.clone())?;
        for request in waiting {
            send_result(&side.server, request, status, result.clone())?;
        }
        publish_statuses(&side)
    }

    /// Stop the node's thread and leave the domain.
    pub fn shutdown(&self) {
        self.stop.store(true, Ordering::Release);
        // a failed wake only delays the stop until the thread's next idle drain
        let _ = self.waker.wake();
        let thread = self
            .thread
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .take();
        if let Some(thread) = thread {
            let _ = thread.join();
        }
    }
}

impl Drop for RobotNode {
    fn drop(&mut self) {
        self.shutdown();
    }
}

/// One sample of a periodic stream (`/joint_states`, `/clock`, the current pose): a sample that
/// would block behind a subscriber that has not acknowledged the last ones is dropped, since the
/// stream's next sample supersedes it (what keep-last means), instead of failing the robot.
fn stream_sample<M: std::fmt::Debug>(
    result: WriteResult<(), M>,
    what: &str,
) -> Result<(), RobotError> {
    match result {
        Err(WriteError::WouldBlock { .. }) => Ok(()),
        other => wire(other, what),
    }
}

fn queue<T>(receiver: &Mutex<Receiver<T>>) -> MutexGuard<'_, Receiver<T>> {
    receiver
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

fn lock(action: &Mutex<ActionSide>) -> MutexGuard<'_, ActionSide> {
    action
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

fn check_len(what: &str, values: &[f64], n: usize) -> Result<(), RobotError> {
    if values.len() != n {
        return Err(RobotError::InvalidInput(format!(
            "{what}: {} values for {n}",
            values.len()
        )));
    }
    if values.iter().any(|v| !v.is_finite()) {
        return Err(RobotError::InvalidInput(format!(
            "{what}: non-finite value"
        )));
    }
    Ok(())
}

fn check_stamp(seconds: f64) -> Result<f64, RobotError> {
    if !seconds.is_finite() || seconds.abs() >= f64::from(i32::MAX) {
        return Err(RobotError::InvalidInput(format!(
            "stamp {seconds} s is not a ROS time"
        )));
    }
    Ok(seconds)
}

fn goal_uuid(id: &GoalId) -> UUID {
    UUID {
        uuid: uuid::Uuid::from_bytes(*id),
    }
}

fn ros_time(time: &Time) -> builtin_interfaces::Time {
    builtin_interfaces::Time::new(time.sec, time.nanosec)
}

fn now() -> Time {
    let nanos = builtin_interfaces::Time::now().to_nanos();
    Time {
        sec: nanos.div_euclid(1_000_000_000) as i32,
        nanosec: nanos.rem_euclid(1_000_000_000) as u32,
    }
}

fn ros_status(status: GoalStatus) -> GoalStatusEnum {
    match status {
        GoalStatus::Unknown => GoalStatusEnum::Unknown,
        GoalStatus::Accepted => GoalStatusEnum::Accepted,
        GoalStatus::Executing => GoalStatusEnum::Executing,
        GoalStatus::Canceling => GoalStatusEnum::Canceling,
        GoalStatus::Succeeded => GoalStatusEnum::Succeeded,
        GoalStatus::Canceled => GoalStatusEnum::Canceled,
        GoalStatus::Aborted => GoalStatusEnum::Aborted,
    }
}

fn send_result(
    server: &Server,
    request: RmwRequestId,
    status: GoalStatus,
    result: FollowJointTrajectoryResult,
) -> Result<(), RobotError> {
    wire(
        server.send_result(
            request,
            GetResultResponse {
                status: ros_status(status),
                result,
            },
        ),
        "get_result reply",
    )
}

fn publish_statuses(side: &ActionSide) -> Result<(), RobotError> {
    let status_list = side
        .table
        .statuses()
        .into_iter()
        .map(|(id, stamp, status)| RosGoalStatus {
            goal_info: RosGoalInfo {
                goal_id: goal_uuid(&id),
                stamp: ros_time(&stamp),
            },
            status: ros_status(status),
        })
        .collect();
    match side.status.write(GoalStatusArray { status_list }, None) {
        // a reader that has not acknowledged the last STATUS_HISTORY arrays gets the next one
        // that fits: each array supersedes the ones before it
        Err(rustdds::dds::WriteError::WouldBlock { .. }) => Ok(()),
        other => wire(other, "goal status"),
    }
}

/// The writer of `<action>/_action/status`, with rcl_action's QoS (reliable, transient local,
/// keep last 1) and a bounded history ([`STATUS_HISTORY`]).
fn status_writer(
    participant: &rustdds::DomainParticipant,
    action: &Name,
) -> Result<rustdds::no_key::DataWriterCdr<GoalStatusArray>, RobotError> {
    let qos = QosPolicyBuilder::new()
        // a full history fails the write at once rather than stalling the goal's thread
        .reliable(rustdds::Duration::ZERO)
        .durability(policy::Durability::TransientLocal)
        .history(policy::History::KeepLast { depth: 1 })
        .resource_limits(policy::ResourceLimits {
            max_samples: STATUS_HISTORY,
            max_instances: 1,
            max_samples_per_instance: STATUS_HISTORY,
        })
        .build();
    let what = "the action's status writer";
    // the name and type as ros2-client and rmw map them to DDS (rt<name>, <package>::msg::dds_::<type>_)
    let topic = create(
        participant.create_topic(
            format!("rt{action}/_action/status"),
            MessageTypeName::new("action_msgs", "GoalStatusArray").dds_msg_type(),
            &qos,
            TopicKind::NoKey,
        ),
        what,
    )?;
    let publisher = create(participant.create_publisher(&qos), what)?;
    create(
        publisher.create_datawriter_no_key_cdr::<GoalStatusArray>(&topic, Some(qos)),
        what,
    )
}

fn subscription<M: 'static>(
    node: &mut Node,
    topic: &Name,
    package: &str,
    type_name: &str,
) -> Result<Subscription<M>, RobotError> {
    let what = topic.to_string();
    let dds_topic = create(
        node.create_topic(
            topic,
            MessageTypeName::new(package, type_name),
            &default_qos(),
        ),
        &what,
    )?;
    create(
        node.create_subscription(&dds_topic, Some(default_qos())),
        &what,
    )
}

fn publisher<M: serde::Serialize>(
    node: &mut Node,
    topic: &Name,
    package: &str,
    type_name: &str,
    qos: QosProfile,
) -> Result<Publisher<M>, RobotError> {
    let what = topic.to_string();
    let dds_topic = create(
        node.create_topic(topic, MessageTypeName::new(package, type_name), &qos),
        &what,
    )?;
    create(node.create_publisher(&dds_topic, Some(qos)), &what)
}

fn signal_publishers<M: serde::Serialize>(
    node: &mut Node,
    namespace: &str,
    signals: &[(String, SignalKind)],
    kind: SignalKind,
    package: &str,
    type_name: &str,
) -> Result<HashMap<String, Publisher<M>>, RobotError> {
    let mut publishers = HashMap::new();
    for (topic, _) in signals.iter().filter(|(_, k)| *k == kind) {
        // one topic carries one type: given twice, of either kind, is refused
        if signals.iter().filter(|(t, _)| t == topic).count() > 1 {
            return Err(RobotError::InvalidInput(format!(
                "signal topic {topic:?} given twice"
            )));
        }
        let topic_name = name(namespace, topic, "signal topic")?;
        publishers.insert(
            topic.clone(),
            publisher(node, &topic_name, package, type_name, default_qos())?,
        );
    }
    Ok(publishers)
}

/// The node thread's side: everything that arrives.
struct Incoming {
    // the node and context own the DDS participant: they live as long as the thread
    node: Node,
    _context: Context,
    action: Arc<Mutex<ActionSide>>,
    trajectory_sub: Subscription<JointTrajectory>,
    command_sub: Subscription<Float64MultiArray>,
    pose_sub: Subscription<PoseStamped>,
    senders: Senders,
    joint_names: Vec<String>,
}

impl Incoming {
    fn run(self, mut poll: Poll, stop: &AtomicBool) {
        let mut events = Events::with_capacity(16);
        while !stop.load(Ordering::Acquire) {
            if let Err(e) = poll.poll(&mut events, Some(IDLE_DRAIN))
                && e.kind() != std::io::ErrorKind::Interrupted
            {
                self.reject(
                    None,
                    format!("the node thread stopped: polling failed: {e}"),
                );
                break;
            }
            // edge-triggered: drain every reader, whichever woke us
            self.drain_goals();
            self.drain_cancels();
            self.drain_results();
            self.drain_topics();
        }
        let _ = &self.node;
    }

    fn reject(&self, id: Option<GoalId>, reason: String) {
        // the receiving side may be gone during shutdown: nothing is left to tell then
        let _ = self.senders.rejections.send(Rejection { id, reason });
    }

    fn drain_goals(&self) {
        loop {
            let mut side = lock(&self.action);
            let (request_id, request) = match side.server.receive_goal() {
                Ok(Some(pair)) => pair,
                Ok(None) => return,
                Err(e) => {
                    drop(side);
                    self.reject(None, format!("unreadable goal request: {e:?}"));
                    continue;
                }
            };
            let id = *request.goal_id.uuid.as_bytes();
            let stamp = now();
            let verdict =
                check_trajectory(&request.goal.trajectory, &self.joint_names).and_then(|()| {
                    side.table
                        .accept(id, stamp.clone())
                        .map_err(|e| e.to_string())
                });
            let accepted = verdict.is_ok();
            let response = SendGoalResponse {
                accepted,
                stamp: ros_time(&stamp),
            };
            if let Err(e) = side.server.send_goal_response(request_id, response) {
                self.reject(
                    Some(id),
                    format!("the goal response could not be sent: {e:?}"),
                );
            }
            match verdict {
                Ok(()) => {
                    if let Err(e) = publish_statuses(&side) {
                        self.reject(Some(id), e.to_string());
                    }
                    drop(side);
                    let _ = self.senders.goals.send(AcceptedGoal {
                        id,
                        goal: request.goal,
                    });
                }
                Err(reason) => self.reject(Some(id), reason),
            }
        }
    }

    fn drain_cancels(&self) {
        loop {
            let mut side = lock(&self.action);
            let (request_id, request) = match side.server.receive_cancel_request() {
                Ok(Some(pair)) => pair,
                Ok(None) => return,
                Err(e) => {
                    drop(side);
                    self.reject(None, format!("unreadable cancel request: {e:?}"));
                    continue;
                }
            };
            let info = match cancel_goal_info(&request) {
                Ok(info) => info,
                Err(e) => {
                    drop(side);
                    self.reject(None, e.to_string());
                    continue;
                }
            };
            let outcome = side.table.cancel(&info.goal_id.uuid, &info.stamp);
            let response = CancelGoalResponse {
                return_code: match outcome.return_code {
                    CancelReturn::None => CancelGoalResponseEnum::None,
                    CancelReturn::Rejected => CancelGoalResponseEnum::Rejected,
                    CancelReturn::UnknownGoalId => CancelGoalResponseEnum::UnknownGoal,
                    CancelReturn::GoalTerminated => CancelGoalResponseEnum::GoalTerminated,
                },
                goals_canceling: outcome
                    .goals_canceling
                    .iter()
                    .map(|(id, stamp)| RosGoalInfo {
                        goal_id: goal_uuid(id),
                        stamp: ros_time(stamp),
                    })
                    .collect(),
            };
            if let Err(e) = side.server.send_cancel_response(request_id, response) {
                self.reject(
                    None,
                    format!("the cancel response could not be sent: {e:?}"),
                );
            }
            if !outcome.goals_canceling.is_empty()
                && let Err(e) = publish_statuses(&side)
            {
                self.reject(None, e.to_string());
            }
            drop(side);
            for (id, _) in outcome.goals_canceling {
                let _ = self.senders.cancels.send(id);
            }
        }
    }

    fn drain_results(&self) {
        loop {
            let mut side = lock(&self.action);
            let (request_id, request) = match side.server.receive_result_request() {
                Ok(Some(pair)) => pair,
                Ok(None) => return,
                Err(e) => {
                    drop(side);
                    self.reject(None, format!("unreadable result request: {e:?}"));
                    continue;
                }
            };
            let id = *request.goal_id.uuid.as_bytes();
            if let ResultReply::Now(status, result) = side.table.request_result(&id, request_id)
                && let Err(e) = send_result(&side.server, request_id, status, result)
            {
                self.reject(Some(id), e.to_string());
            }
        }
    }

    fn drain_topics(&self) {
        loop {
            match self.trajectory_sub.take() {
                Ok(Some((trajectory, _))) => match check_trajectory(&trajectory, &self.joint_names)
                {
                    Ok(()) => {
                        let _ = self.senders.trajectories.send(trajectory);
                    }
                    Err(reason) => self.reject(None, format!("joint_trajectory topic: {reason}")),
                },
                Ok(None) => break,
                Err(e) => self.reject(None, format!("unreadable joint_trajectory message: {e:?}")),
            }
        }
        loop {
            match self.command_sub.take() {
                Ok(Some((command, _))) => {
                    if command.data.len() == self.joint_names.len()
                        && command.data.iter().all(|v| v.is_finite())
                    {
                        let _ = self.senders.commands.send(command.data);
                    } else {
                        self.reject(
                            None,
                            format!(
                                "position command of {} values for {} joints",
                                command.data.len(),
                                self.joint_names.len()
                            ),
                        );
                    }
                }
                Ok(None) => break,
                Err(e) => self.reject(None, format!("unreadable position command: {e:?}")),
            }
        }
        loop {
            match self.pose_sub.take() {
                Ok(Some((target, _))) => {
                    let (p, q) = (&target.pose.position, &target.pose.orientation);
                    let pose = [p.x, p.y, p.z, q.w, q.x, q.y, q.z];
                    if pose.iter().all(|v| v.is_finite()) {
                        let _ = self.senders.poses.send(TargetPose {
                            stamp: target.header.stamp.seconds(),
                            frame_id: target.header.frame_id,
                            pose,
                        });
                    } else {
                        self.reject(None, "target pose with a non-finite value".into());
                    }
                }
                Ok(None) => break,
                Err(e) => self.reject(None, format!("unreadable target pose: {e:?}")),
            }
        }
    }
}

/// The goal info of a cancel request. ros2-client keeps that field to itself, so it is read back
/// from the request's own CDR bytes into this crate's `action_msgs/srv/CancelGoal_Request`.
fn cancel_goal_info(request: &CancelGoalRequest) -> Result<crate::msgs::GoalInfo, RobotError> {
    let bytes = crate::cdr::to_bytes(request)
        .map_err(|e| RobotError::Read(format!("cancel request: {e}")))?;
    let parsed: crate::msgs::CancelGoalRequest = crate::cdr::from_bytes(&bytes)
        .map_err(|e| RobotError::Read(format!("cancel request: {e}")))?;
    Ok(parsed.goal_info)
}
