//! The client side on ros2-client, to measure it against dmprs's Cyclone side (benches/bench_ros2.py):
//! a FollowJointTrajectory action client that sends goals and waits for their acceptance, and a
//! `/joint_states` listener that records every stamp it receives.

use std::future::Future;
use std::net::{IpAddr, Ipv4Addr};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::task::{Context as TaskContext, Poll as TaskPoll, Wake, Waker};
use std::thread::{JoinHandle, Thread};
use std::time::{Duration, Instant};

use ros2_client::action::{ActionClient, ActionClientQosPolicies};
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::dds::rustdds::mio1::{Events, Interest, Poll, Token};
use ros2_client::dds::{Context, Node, ServiceMapping, Subscription};
use ros2_client::qos::{Durability, History, QosProfile};
use ros2_client::{ActionTypeName, MessageTypeName, Name, NodeName, NodeOptions};

use crate::RobotError;
use crate::msgs::{
    FollowJointTrajectoryFeedback, FollowJointTrajectoryGoal, FollowJointTrajectoryResult,
    JointState,
};

struct ThreadWaker(Thread);

impl Wake for ThreadWaker {
    fn wake(self: Arc<Self>) {
        self.0.unpark();
    }
}

/// Run `future` on this thread until it completes (`Some`) or `timeout` passes (`None`), parked
/// between wake-ups.
pub fn block_on_timeout<F: Future>(future: F, timeout: Duration) -> Option<F::Output> {
    let deadline = Instant::now() + timeout;
    let waker = Waker::from(Arc::new(ThreadWaker(std::thread::current())));
    let mut context = TaskContext::from_waker(&waker);
    let mut future = std::pin::pin!(future);
    loop {
        if let TaskPoll::Ready(value) = future.as_mut().poll(&mut context) {
            return Some(value);
        }
        let now = Instant::now();
        if now >= deadline {
            return None;
        }
        std::thread::park_timeout(deadline - now);
    }
}

fn node(domain_id: u16, name: &str, loopback_only: bool) -> Result<(Context, Node), RobotError> {
    let create = |e: String| RobotError::Create(e);
    let mut builder = DomainParticipantBuilder::new(domain_id);
    if loopback_only {
        builder = builder.with_only_networks([IpAddr::V4(Ipv4Addr::LOCALHOST)]);
    }
    let participant = builder
        .build()
        .map_err(|e| create(format!("DDS participant: {e:?}")))?;
    let context = Context::from_domain_participant(participant)
        .map_err(|e| create(format!("context: {e:?}")))?;
    let node_name =
        NodeName::new("/", name).map_err(|e| RobotError::InvalidInput(format!("{name}: {e:?}")))?;
    let node = context
        .new_node(node_name, NodeOptions::new().enable_rosout(false))
        .map_err(|e| create(format!("node: {e:?}")))?;
    Ok((context, node))
}

fn default_qos() -> QosProfile {
    QosProfile::publisher_default().history(History::KeepLast { depth: 10 })
}

/// A FollowJointTrajectory action client on ros2-client.
pub struct GoalClient {
    _context: Context,
    node: Node,
    client: ActionClient<
        FollowJointTrajectoryGoal,
        FollowJointTrajectoryResult,
        FollowJointTrajectoryFeedback,
    >,
}

impl GoalClient {
    pub fn new(
        domain_id: u16,
        action: &str,
        loopback_only: bool,
    ) -> Result<GoalClient, RobotError> {
        let (context, mut node) = node(domain_id, "dmprs_goal_client", loopback_only)?;
        let action_name = Name::parse(action)
            .map_err(|e| RobotError::InvalidInput(format!("action {action:?}: {e:?}")))?;
        let client = node
            .create_action_client(
                ServiceMapping::Cyclone,
                &action_name,
                &ActionTypeName::new("control_msgs", "FollowJointTrajectory"),
                ActionClientQosPolicies {
                    goal_service: default_qos(),
                    result_service: default_qos(),
                    cancel_service: default_qos(),
                    feedback_subscription: default_qos(),
                    status_subscription: default_qos()
                        .durability(Durability::TransientLocal)
                        .history(History::KeepLast { depth: 1 }),
                },
            )
            .map_err(|e| RobotError::Create(format!("action client: {e:?}")))?;
        Ok(GoalClient {
            _context: context,
            node,
            client,
        })
    }

    /// Wait until the send_goal service has a server (true) or `timeout` passes (false).
    pub fn wait_for_server(&self, timeout: Duration) -> bool {
        block_on_timeout(
            self.client.goal_client().wait_for_service(&self.node),
            timeout,
        )
        .is_some()
    }

    /// Send a goal and wait for the server's answer: `Some(accepted)`, `None` after `timeout`.
    pub fn send_goal(
        &self,
        goal: FollowJointTrajectoryGoal,
        timeout: Duration,
    ) -> Result<Option<bool>, RobotError> {
        match block_on_timeout(self.client.async_send_goal(goal), timeout) {
            None => Ok(None),
            Some(Ok((_, response))) => Ok(Some(response.accepted)),
            Some(Err(e)) => Err(RobotError::Write(format!("goal: {e:?}"))),
        }
    }
}

/// Records the header stamp of every `/joint_states` message, on a thread of its own.
pub struct JointStateListener {
    stamps: Arc<Mutex<Vec<f64>>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<Result<(), RobotError>>>,
}

impl JointStateListener {
    pub fn start(
        domain_id: u16,
        topic: &str,
        depth: usize,
        loopback_only: bool,
    ) -> Result<Self, RobotError> {
        let (context, mut node) = node(domain_id, "dmprs_joint_state_listener", loopback_only)?;
        let name = Name::parse(topic)
            .map_err(|e| RobotError::InvalidInput(format!("topic {topic:?}: {e:?}")))?;
        let qos = default_qos().history(History::KeepLast { depth });
        let dds_topic = node
            .create_topic(
                &name,
                MessageTypeName::new("sensor_msgs", "JointState"),
                &qos,
            )
            .map_err(|e| RobotError::Create(format!("{topic}: {e:?}")))?;
        let mut subscription: Subscription<JointState> = node
            .create_subscription(&dds_topic, Some(qos))
            .map_err(|e| RobotError::Create(format!("{topic}: {e:?}")))?;
        let mut poll = Poll::new().map_err(|e| RobotError::Create(format!("mio poll: {e}")))?;
        poll.registry()
            .register(&mut subscription, Token(0), Interest::READABLE)
            .map_err(|e| RobotError::Create(format!("mio registration: {e}")))?;
        let stamps = Arc::new(Mutex::new(Vec::new()));
        let stop = Arc::new(AtomicBool::new(false));
        let (thread_stamps, thread_stop) = (Arc::clone(&stamps), Arc::clone(&stop));
        let thread = std::thread::spawn(move || {
            let _keep = (context, node);
            let mut events = Events::with_capacity(4);
            while !thread_stop.load(Ordering::Acquire) {
                poll.poll(&mut events, Some(Duration::from_millis(50)))
                    .map_err(|e| RobotError::Read(format!("mio poll: {e}")))?;
                while let Some((message, _)) = subscription
                    .take()
                    .map_err(|e| RobotError::Read(format!("joint state: {e:?}")))?
                {
                    let stamp = f64::from(message.header.stamp.sec)
                        + f64::from(message.header.stamp.nanosec) * 1e-9;
                    thread_stamps
                        .lock()
                        .unwrap_or_else(|p| p.into_inner())
                        .push(stamp);
                }
            }
            Ok(())
        });
        Ok(JointStateListener {
            stamps,
            stop,
            thread: Some(thread),
        })
    }

    /// How many messages arrived so far.
    pub fn count(&self) -> usize {
        self.stamps.lock().unwrap_or_else(|p| p.into_inner()).len()
    }

    /// Stop listening; the stamps received, in arrival order.
    pub fn stop(&mut self) -> Result<Vec<f64>, RobotError> {
        self.stop.store(true, Ordering::Release);
        if let Some(thread) = self.thread.take() {
            thread
                .join()
                .map_err(|_| RobotError::Read("the listener thread panicked".into()))??;
        }
        Ok(std::mem::take(
            &mut *self.stamps.lock().unwrap_or_else(|p| p.into_inner()),
        ))
    }
}

impl Drop for JointStateListener {
    fn drop(&mut self) {
        let _ = self.stop();
    }
}
