//! `RobotNode`: the simulated ros2_control robot of `ros2-robot` (ros2-client / RustDDS). Every
//! call returns at once or after its timeout, with the GIL released while it waits.

use std::time::Duration;

use numpy::{IntoPyArray, PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray1};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyBytes};
use ros2_robot::msgs::{Duration as RosDuration, JointTrajectoryPoint};
use ros2_robot::validate::{TrajectoryArrays, controller_order};
use ros2_robot::{GoalId, GoalStatus, RobotConfig, RobotError, SignalKind};

use crate::errors::{IntoPyResult, PyErrorClass, invalid_input};
use crate::stepper::read_vector;

impl<T> IntoPyResult<T> for Result<T, RobotError> {
    fn py_err(self) -> PyResult<T> {
        self.map_err(|e| {
            let class = match e {
                RobotError::InvalidInput(_) => PyErrorClass::InvalidInput,
                RobotError::Create(_)
                | RobotError::Write(_)
                | RobotError::Read(_)
                | RobotError::Goal(_)
                | RobotError::Stopped => PyErrorClass::Adapter,
            };
            class.err(e.to_string())
        })
    }
}

fn timeout(seconds: f64) -> PyResult<Duration> {
    Duration::try_from_secs_f64(seconds).map_err(|_| {
        invalid_input(format!(
            "timeout {seconds} must be a finite number of seconds >= 0"
        ))
    })
}

fn goal_id(id: &[u8]) -> PyResult<GoalId> {
    id.try_into()
        .map_err(|_| invalid_input(format!("goal id must be 16 bytes, not {}", id.len())))
}

fn rows<'py>(
    py: Python<'py>,
    rows: &[Vec<f64>],
    width: usize,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    let flat: Vec<f64> = rows.iter().flatten().copied().collect();
    flat.into_pyarray(py).reshape([rows.len(), width])
}

/// A trajectory in the controller's joint order (from a goal or the joint_trajectory topic).
#[pyclass(name = "RobotTrajectory", module = "dmprs._core", frozen)]
pub struct PyRobotTrajectory {
    arrays: TrajectoryArrays,
    width: usize,
}

#[pymethods]
impl PyRobotTrajectory {
    /// The header stamp (s) on the robot's clock: when the trajectory starts, 0.0 meaning as
    /// soon as it arrives (as joint_trajectory_controller reads it).
    #[getter]
    fn stamp(&self) -> f64 {
        self.arrays.stamp
    }

    /// Each point's time_from_start (s).
    #[getter]
    fn times<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.arrays.times.clone().into_pyarray(py)
    }

    /// Positions, one row per point, one column per controller joint.
    #[getter]
    fn positions<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        rows(py, &self.arrays.positions, self.width)
    }

    /// Velocities like positions, or None unless every point has them.
    #[getter]
    fn velocities<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
        self.arrays
            .velocities
            .as_ref()
            .map(|v| rows(py, v, self.width))
            .transpose()
    }

    /// Accelerations like positions, or None unless every point has them.
    #[getter]
    fn accelerations<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
        self.arrays
            .accelerations
            .as_ref()
            .map(|v| rows(py, v, self.width))
            .transpose()
    }
}

/// A FollowJointTrajectory goal the robot accepted; it executes until `finish_goal`.
#[pyclass(name = "RobotGoal", module = "dmprs._core", frozen)]
pub struct PyRobotGoal {
    id: GoalId,
    trajectory: Py<PyRobotTrajectory>,
    goal_time_tolerance: f64,
    path_tolerance: Vec<(String, f64, f64, f64)>,
    goal_tolerance: Vec<(String, f64, f64, f64)>,
}

#[pymethods]
impl PyRobotGoal {
    /// The goal's UUID (16 bytes).
    #[getter]
    fn id<'py>(&self, py: Python<'py>) -> Bound<'py, PyBytes> {
        PyBytes::new(py, &self.id)
    }

    #[getter]
    fn trajectory(&self, py: Python<'_>) -> Py<PyRobotTrajectory> {
        self.trajectory.clone_ref(py)
    }

    /// goal_time_tolerance (s).
    #[getter]
    fn goal_time_tolerance(&self) -> f64 {
        self.goal_time_tolerance
    }

    /// (joint, position, velocity, acceleration) tolerances while executing.
    #[getter]
    fn path_tolerance(&self) -> Vec<(String, f64, f64, f64)> {
        self.path_tolerance.clone()
    }

    /// (joint, position, velocity, acceleration) tolerances at the end.
    #[getter]
    fn goal_tolerance(&self) -> Vec<(String, f64, f64, f64)> {
        self.goal_tolerance.clone()
    }
}

fn tolerances(list: &[ros2_robot::msgs::JointTolerance]) -> Vec<(String, f64, f64, f64)> {
    list.iter()
        .map(|t| (t.name.clone(), t.position, t.velocity, t.acceleration))
        .collect()
}

fn point(
    positions: Vec<f64>,
    velocities: Option<Vec<f64>>,
    time_from_start: f64,
) -> JointTrajectoryPoint {
    JointTrajectoryPoint {
        positions,
        velocities: velocities.unwrap_or_default(),
        time_from_start: RosDuration::from_seconds(time_from_start),
        ..Default::default()
    }
}

/// An integer argument as Python gives it (a Python or numpy integer) within `range`, else a dmprs
/// error naming it: not Python's TypeError for a float or OverflowError for a huge integer, and a
/// bool is no count.
fn integer(
    name: &str,
    value: &Bound<'_, PyAny>,
    range: std::ops::RangeInclusive<i64>,
) -> PyResult<i64> {
    let refused = || {
        let shown = value
            .repr()
            .map(|r| r.to_string())
            .unwrap_or_else(|_| "?".into());
        invalid_input(format!(
            "{name} = {shown} must be an integer in {}..{}",
            range.start(),
            range.end()
        ))
    };
    if value.is_instance_of::<PyBool>() {
        return Err(refused());
    }
    match value.extract::<i64>() {
        Ok(n) if range.contains(&n) => Ok(n),
        _ => Err(refused()),
    }
}

/// A ROS 2 domain id as Python gives it, checked against the range every dmprs entry point takes
/// (RTPS port arithmetic leaves 0..232), not wrapped into a `u16`.
fn domain(domain_id: &Bound<'_, PyAny>) -> PyResult<u16> {
    Ok(integer("domain_id", domain_id, 0..=232)? as u16)
}

/// control_msgs' error code: a 32-bit integer on the wire.
fn error_code(value: &Bound<'_, PyAny>) -> PyResult<i32> {
    Ok(integer(
        "error_code",
        value,
        i64::from(i32::MIN)..=i64::from(i32::MAX),
    )? as i32)
}

/// action_msgs' terminal goal status: STATUS_SUCCEEDED (4), STATUS_CANCELED (5), STATUS_ABORTED (6).
fn terminal_status(value: &Bound<'_, PyAny>) -> PyResult<GoalStatus> {
    integer("status", value, 4..=6)
        .ok()
        .and_then(|code| i8::try_from(code).ok())
        .and_then(GoalStatus::from_code)
        .filter(|s| s.is_terminal())
        .ok_or_else(|| {
            invalid_input(format!(
                "status = {} is not a terminal goal status (4, 5 or 6)",
                value
                    .repr()
                    .map(|r| r.to_string())
                    .unwrap_or_else(|_| "?".into())
            ))
        })
}

/// A probe's history depth: at least one sample.
fn depth(value: &Bound<'_, PyAny>) -> PyResult<usize> {
    Ok(integer("depth", value, 1..=i64::from(i32::MAX))? as usize)
}

/// A 1-D array argument of real numbers (any float or integer dtype), refused by name otherwise.
fn reals(name: &str, value: &Bound<'_, PyAny>) -> PyResult<Vec<f64>> {
    let mut values = Vec::new();
    read_vector(name, value, &mut values)?;
    Ok(values)
}

fn vector(name: &str, a: Option<&Bound<'_, PyAny>>) -> PyResult<Option<Vec<f64>>> {
    a.map(|a| reals(name, a)).transpose()
}

/// Target poses as Python receives them: stamps (s), `[x, y, z, qw, qx, qy, qz]` rows, frame ids.
type TargetPoses<'py> = (
    Bound<'py, PyArray1<f64>>,
    Bound<'py, PyArray2<f64>>,
    Vec<String>,
);

/// A simulated ros2_control robot on ROS 2 (ros2-client / RustDDS, its own threads).
#[pyclass(name = "RobotNode", module = "dmprs._core", frozen)]
pub struct PyRobotNode {
    inner: ros2_robot::RobotNode,
}

#[pymethods]
impl PyRobotNode {
    #[new]
    #[pyo3(signature = (domain_id, controller, joint_names, *, node_name="dmprs_robot", namespace="/",
        command_topic="/forward_position_controller/commands",
        cartesian_controller="/cartesian_motion_controller", float_signals=vec![], point_signals=vec![],
        loopback_only=true))]
    #[allow(clippy::too_many_arguments)]
    fn new(
        py: Python<'_>,
        #[pyo3(from_py_with = domain)] domain_id: u16,
        controller: &str,
        joint_names: Vec<String>,
        node_name: &str,
        namespace: &str,
        command_topic: &str,
        cartesian_controller: &str,
        float_signals: Vec<String>,
        point_signals: Vec<String>,
        loopback_only: bool,
    ) -> PyResult<Self> {
        let mut config = RobotConfig::new(domain_id, controller, joint_names);
        config.node_name = node_name.into();
        config.namespace = namespace.into();
        config.command_topic = command_topic.into();
        config.cartesian_controller = cartesian_controller.into();
        config.loopback_only = loopback_only;
        config.signals = float_signals
            .into_iter()
            .map(|t| (t, SignalKind::Float64))
            .chain(
                point_signals
                    .into_iter()
                    .map(|t| (t, SignalKind::PointStamped)),
            )
            .collect();
        let inner = py
            .detach(|| ros2_robot::RobotNode::start(config))
            .py_err()?;
        Ok(PyRobotNode { inner })
    }

    #[getter]
    fn joint_names(&self) -> Vec<String> {
        self.inner.config().joint_names.clone()
    }

    /// The next accepted goal, waiting at most `timeout` seconds; None if none came.
    fn poll_goal(&self, py: Python<'_>, timeout: f64) -> PyResult<Option<PyRobotGoal>> {
        let wait = self::timeout(timeout)?;
        let Some(accepted) = py.detach(|| self.inner.poll_goal(wait)).py_err()? else {
            return Ok(None);
        };
        let joints = &self.inner.config().joint_names;
        let trajectory = PyRobotTrajectory {
            arrays: controller_order(&accepted.goal.trajectory, joints),
            width: joints.len(),
        };
        Ok(Some(PyRobotGoal {
            id: accepted.id,
            trajectory: Py::new(py, trajectory)?,
            goal_time_tolerance: accepted.goal.goal_time_tolerance.seconds(),
            path_tolerance: tolerances(&accepted.goal.path_tolerance),
            goal_tolerance: tolerances(&accepted.goal.goal_tolerance),
        }))
    }

    /// Goals and topic trajectories refused since the last call: (goal id or None, reason).
    fn poll_rejections<'py>(&self, py: Python<'py>) -> Vec<(Option<Bound<'py, PyBytes>>, String)> {
        self.inner
            .poll_rejections()
            .into_iter()
            .map(|r| (r.id.map(|id| PyBytes::new(py, &id)), r.reason))
            .collect()
    }

    /// Ids of goals a client asked to cancel since the last call (each is CANCELING).
    fn poll_cancels<'py>(&self, py: Python<'py>) -> Vec<Bound<'py, PyBytes>> {
        self.inner
            .poll_cancels()
            .iter()
            .map(|id| PyBytes::new(py, id))
            .collect()
    }

    /// Trajectories received on `<controller>/joint_trajectory` since the last call.
    fn poll_trajectories(&self) -> Vec<PyRobotTrajectory> {
        let joints = &self.inner.config().joint_names;
        self.inner
            .poll_trajectories()
            .iter()
            .map(|t| PyRobotTrajectory {
                arrays: controller_order(t, joints),
                width: joints.len(),
            })
            .collect()
    }

    /// Position commands received since the last call, one row each, oldest first.
    fn poll_commands<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        rows(
            py,
            &self.inner.poll_commands(),
            self.inner.config().joint_names.len(),
        )
    }

    /// Target poses received by the Cartesian controller since the last call: `(stamps, poses)`,
    /// `poses` one `[x, y, z, qw, qx, qy, qz]` row per target, and their frame ids.
    fn poll_poses<'py>(&self, py: Python<'py>) -> PyResult<TargetPoses<'py>> {
        let targets = self.inner.poll_poses();
        let stamps: Vec<f64> = targets.iter().map(|t| t.stamp).collect();
        let poses: Vec<Vec<f64>> = targets.iter().map(|t| t.pose.to_vec()).collect();
        let frames = targets.into_iter().map(|t| t.frame_id).collect();
        Ok((stamps.into_pyarray(py), rows(py, &poses, 7)?, frames))
    }

    /// Publish the Cartesian controller's `current_pose` (`[x, y, z, qw, qx, qy, qz]`).
    #[pyo3(signature = (stamp, pose, frame_id="base_link"))]
    fn publish_pose(
        &self,
        py: Python<'_>,
        stamp: f64,
        pose: &Bound<'_, PyAny>,
        frame_id: &str,
    ) -> PyResult<()> {
        let pose = reals("pose", pose)?;
        py.detach(|| self.inner.publish_pose(stamp, frame_id, &pose))
            .py_err()
    }

    #[pyo3(signature = (stamp, position, velocity=None))]
    fn publish_joint_state(
        &self,
        py: Python<'_>,
        stamp: f64,
        position: &Bound<'_, PyAny>,
        velocity: Option<&Bound<'_, PyAny>>,
    ) -> PyResult<()> {
        let (mut position_, mut velocity_) = (Vec::new(), Vec::new());
        read_vector("position", position, &mut position_)?;
        if let Some(v) = velocity {
            read_vector("velocity", v, &mut velocity_)?;
        }
        let (position, velocity) = (position_, velocity_);
        py.detach(|| self.inner.publish_joint_state(stamp, &position, &velocity))
            .py_err()
    }

    #[pyo3(signature = (goal_id, stamp, desired, actual, desired_velocity=None, actual_velocity=None,
        time_from_start=0.0))]
    #[allow(clippy::too_many_arguments)]
    fn publish_feedback(
        &self,
        py: Python<'_>,
        goal_id: &[u8],
        stamp: f64,
        desired: &Bound<'_, PyAny>,
        actual: &Bound<'_, PyAny>,
        desired_velocity: Option<&Bound<'_, PyAny>>,
        actual_velocity: Option<&Bound<'_, PyAny>>,
        time_from_start: f64,
    ) -> PyResult<()> {
        let id = self::goal_id(goal_id)?;
        if !time_from_start.is_finite() {
            return Err(invalid_input("time_from_start must be finite"));
        }
        let desired = point(
            reals("desired", desired)?,
            vector("desired_velocity", desired_velocity)?,
            time_from_start,
        );
        let actual = point(
            reals("actual", actual)?,
            vector("actual_velocity", actual_velocity)?,
            time_from_start,
        );
        py.detach(|| self.inner.publish_feedback(&id, stamp, desired, actual))
            .py_err()
    }

    /// End a goal: `status` is action_msgs' STATUS_SUCCEEDED (4), STATUS_CANCELED (5) or
    /// STATUS_ABORTED (6); `error_code` and `error_string` as control_msgs defines them.
    #[pyo3(signature = (goal_id, status, error_code=0, error_string=""))]
    fn finish_goal(
        &self,
        py: Python<'_>,
        goal_id: &[u8],
        #[pyo3(from_py_with = terminal_status)] status: GoalStatus,
        #[pyo3(from_py_with = self::error_code)] error_code: i32,
        error_string: &str,
    ) -> PyResult<()> {
        let id = self::goal_id(goal_id)?;
        py.detach(|| {
            self.inner
                .finish_goal(&id, status, error_code, error_string)
        })
        .py_err()
    }

    /// Publish a signal topic: a float on a Float64 topic, (x, y, z) on a PointStamped one.
    fn publish_signal(
        &self,
        py: Python<'_>,
        topic: &str,
        value: &Bound<'_, PyAny>,
        stamp: f64,
    ) -> PyResult<()> {
        let value: Vec<f64> = match value.extract::<f64>() {
            Ok(v) => vec![v],
            Err(_) => value.extract().map_err(|_| {
                invalid_input(format!("signal {topic}: value must be a float or 3 floats"))
            })?,
        };
        py.detach(|| self.inner.publish_signal(topic, &value, stamp))
            .py_err()
    }

    fn publish_clock(&self, py: Python<'_>, seconds: f64) -> PyResult<()> {
        py.detach(|| self.inner.publish_clock(seconds)).py_err()
    }

    /// Stop the node's thread and leave the domain (idempotent).
    fn shutdown(&self, py: Python<'_>) {
        py.detach(|| self.inner.shutdown());
    }
}

/// A FollowJointTrajectory action client on ros2-client, for measuring it against dmprs.ros2.
#[pyclass(name = "Ros2GoalClient", module = "dmprs._core", frozen)]
pub struct PyRos2GoalClient {
    inner: ros2_robot::probe::GoalClient,
}

#[pymethods]
impl PyRos2GoalClient {
    #[new]
    #[pyo3(signature = (domain_id, action, loopback_only=true))]
    fn new(
        py: Python<'_>,
        #[pyo3(from_py_with = domain)] domain_id: u16,
        action: &str,
        loopback_only: bool,
    ) -> PyResult<Self> {
        let inner = py
            .detach(|| ros2_robot::probe::GoalClient::new(domain_id, action, loopback_only))
            .py_err()?;
        Ok(PyRos2GoalClient { inner })
    }

    /// True once the action's send_goal service has a server, False after `timeout` seconds.
    fn wait_for_server(&self, py: Python<'_>, timeout: f64) -> PyResult<bool> {
        let wait = self::timeout(timeout)?;
        Ok(py.detach(|| self.inner.wait_for_server(wait)))
    }

    /// Send a goal (positions: one row per point) and wait for the answer: accepted (bool), or
    /// None after `timeout` seconds.
    fn send_goal(
        &self,
        py: Python<'_>,
        joint_names: Vec<String>,
        times: PyReadonlyArray1<'_, f64>,
        positions: numpy::PyReadonlyArray2<'_, f64>,
        timeout: f64,
    ) -> PyResult<Option<bool>> {
        let wait = self::timeout(timeout)?;
        let times = times
            .as_slice()
            .map_err(|_| invalid_input("times must be contiguous"))?;
        let positions = positions.as_array();
        if positions.nrows() != times.len() || positions.ncols() != joint_names.len() {
            return Err(invalid_input(
                "positions must have one row per time and one column per joint",
            ));
        }
        let points = times
            .iter()
            .zip(positions.rows())
            .map(|(&t, row)| point(row.to_vec(), None, t))
            .collect();
        let goal = ros2_robot::msgs::FollowJointTrajectoryGoal {
            trajectory: ros2_robot::msgs::JointTrajectory {
                joint_names,
                points,
                ..Default::default()
            },
            ..Default::default()
        };
        py.detach(|| self.inner.send_goal(goal, wait)).py_err()
    }
}

/// Records the stamps of `/joint_states` on ros2-client, for measuring it against dmprs.ros2.
#[pyclass(name = "Ros2JointStateListener", module = "dmprs._core", frozen)]
pub struct PyRos2JointStateListener {
    inner: std::sync::Mutex<ros2_robot::probe::JointStateListener>,
}

#[pymethods]
impl PyRos2JointStateListener {
    #[new]
    #[pyo3(signature = (domain_id, topic="/joint_states", depth=1000, loopback_only=true))]
    fn new(
        py: Python<'_>,
        #[pyo3(from_py_with = domain)] domain_id: u16,
        topic: &str,
        #[pyo3(from_py_with = self::depth)] depth: usize,
        loopback_only: bool,
    ) -> PyResult<Self> {
        let inner = py
            .detach(|| {
                ros2_robot::probe::JointStateListener::start(domain_id, topic, depth, loopback_only)
            })
            .py_err()?;
        Ok(PyRos2JointStateListener {
            inner: std::sync::Mutex::new(inner),
        })
    }

    /// Messages received so far.
    fn count(&self) -> usize {
        self.inner.lock().unwrap_or_else(|p| p.into_inner()).count()
    }

    /// Stop listening; the header stamps received (s), in arrival order.
    fn stop<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let stamps = py
            .detach(|| self.inner.lock().unwrap_or_else(|p| p.into_inner()).stop())
            .py_err()?;
        Ok(stamps.into_pyarray(py))
    }
}
