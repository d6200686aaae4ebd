//! The action server's goal table: the ROS 2 action state machine (action_msgs/msg/GoalStatus),
//! the CancelGoal policy (action_msgs/srv/CancelGoal), and result requests waiting for their goal.
//!
//! It holds no DDS entity, so every transition is tested without a network; `RequestId` is
//! whatever identifies a pending get_result request on the wire.

use std::collections::VecDeque;

use crate::msgs::{FollowJointTrajectoryResult, Time};

/// A goal's UUID (unique_identifier_msgs/msg/UUID).
pub type GoalId = [u8; 16];

/// The all-zero UUID: "every goal" in a cancel request.
pub const ZERO_GOAL_ID: GoalId = [0; 16];

/// action_msgs/msg/GoalStatus's status codes that a goal of this table can have.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(i8)]
pub enum GoalStatus {
    Unknown = 0,
    Accepted = 1,
    Executing = 2,
    Canceling = 3,
    Succeeded = 4,
    Canceled = 5,
    Aborted = 6,
}

impl GoalStatus {
    pub fn is_terminal(self) -> bool {
        matches!(
            self,
            GoalStatus::Succeeded | GoalStatus::Canceled | GoalStatus::Aborted
        )
    }

    pub fn from_code(code: i8) -> Option<GoalStatus> {
        Some(match code {
            0 => GoalStatus::Unknown,
            1 => GoalStatus::Accepted,
            2 => GoalStatus::Executing,
            3 => GoalStatus::Canceling,
            4 => GoalStatus::Succeeded,
            5 => GoalStatus::Canceled,
            6 => GoalStatus::Aborted,
            _ => return None,
        })
    }
}

/// action_msgs/srv/CancelGoal_Response's return codes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(i8)]
pub enum CancelReturn {
    None = 0,
    Rejected = 1,
    UnknownGoalId = 2,
    GoalTerminated = 3,
}

/// What a cancel request did: its return code and the goals now canceling (id, accept stamp).
#[derive(Clone, Debug, PartialEq)]
pub struct CancelOutcome {
    pub return_code: CancelReturn,
    pub goals_canceling: Vec<(GoalId, Time)>,
}

#[derive(Debug, thiserror::Error, PartialEq)]
pub enum GoalTableError {
    #[error("goal {0:02x?} is already known")]
    Duplicate(GoalId),
    #[error("goal {0:02x?} is not known to the action server")]
    Unknown(GoalId),
    #[error("goal {0:02x?} has already finished")]
    Finished(GoalId),
    #[error("a goal ends as succeeded, canceled or aborted, not as {0:?}")]
    NotTerminal(GoalStatus),
    #[error("{0} goals are unfinished already: finish some before sending more")]
    Full(usize),
}

/// The most goals the action server holds unfinished: beyond it a goal is rejected, so that
/// memory and the status topic's array stay bounded (with the finished goals kept, the array has
/// at most `MAX_UNFINISHED_GOALS + keep_finished` entries, a few kilobytes).
pub const MAX_UNFINISHED_GOALS: usize = 64;

struct Goal<RequestId> {
    id: GoalId,
    accepted_at: Time,
    status: GoalStatus,
    result: FollowJointTrajectoryResult,
    waiting: Vec<RequestId>,
}

/// Goals in the order they were accepted; finished goals are kept (for late result requests and
/// the status topic) until `keep_finished` newer ones have finished.
pub struct GoalTable<RequestId> {
    goals: VecDeque<Goal<RequestId>>,
    keep_finished: usize,
}

/// What a get_result request gets: answered now, or parked until the goal finishes.
#[derive(Debug, PartialEq)]
pub enum ResultReply {
    Now(GoalStatus, FollowJointTrajectoryResult),
    Later,
}

impl<RequestId> GoalTable<RequestId> {
    pub fn new(keep_finished: usize) -> Self {
        GoalTable {
            goals: VecDeque::new(),
            keep_finished,
        }
    }

    fn find(&mut self, id: &GoalId) -> Option<&mut Goal<RequestId>> {
        self.goals.iter_mut().find(|g| &g.id == id)
    }

    /// Accept a goal: it starts executing at once (rclcpp's ACCEPT_AND_EXECUTE).
    pub fn accept(&mut self, id: GoalId, stamp: Time) -> Result<(), GoalTableError> {
        if self.goals.iter().any(|g| g.id == id) {
            return Err(GoalTableError::Duplicate(id));
        }
        if self
            .goals
            .iter()
            .filter(|g| !g.status.is_terminal())
            .count()
            >= MAX_UNFINISHED_GOALS
        {
            return Err(GoalTableError::Full(MAX_UNFINISHED_GOALS));
        }
        self.goals.push_back(Goal {
            id,
            accepted_at: stamp,
            status: GoalStatus::Executing,
            result: FollowJointTrajectoryResult::default(),
            waiting: Vec::new(),
        });
        Ok(())
    }

    /// End an active goal; returns the result requests that were waiting for it.
    pub fn finish(
        &mut self,
        id: &GoalId,
        status: GoalStatus,
        result: FollowJointTrajectoryResult,
    ) -> Result<Vec<RequestId>, GoalTableError> {
        if !status.is_terminal() {
            return Err(GoalTableError::NotTerminal(status));
        }
        let goal = self.find(id).ok_or(GoalTableError::Unknown(*id))?;
        if goal.status.is_terminal() {
            return Err(GoalTableError::Finished(*id));
        }
        goal.status = status;
        goal.result = result;
        let waiting = std::mem::take(&mut goal.waiting);
        self.forget_old_finished();
        Ok(waiting)
    }

    fn forget_old_finished(&mut self) {
        let finished = self.goals.iter().filter(|g| g.status.is_terminal()).count();
        let mut excess = finished.saturating_sub(self.keep_finished);
        self.goals.retain(|g| {
            if excess > 0 && g.status.is_terminal() {
                excess -= 1;
                false
            } else {
                true
            }
        });
    }

    /// A get_result request: a finished goal's result now, an active goal's when it finishes, an
    /// unknown goal's as STATUS_UNKNOWN with an empty result (as rcl answers).
    pub fn request_result(&mut self, id: &GoalId, request: RequestId) -> ResultReply {
        match self.find(id) {
            None => ResultReply::Now(GoalStatus::Unknown, FollowJointTrajectoryResult::default()),
            Some(goal) if goal.status.is_terminal() => {
                ResultReply::Now(goal.status, goal.result.clone())
            }
            Some(goal) => {
                goal.waiting.push(request);
                ResultReply::Later
            }
        }
    }

    /// A cancel request, by action_msgs/srv/CancelGoal's policy: a zero id and zero stamp cancel
    /// every goal, a zero id and a stamp the goals accepted at or before it, an id that goal (and,
    /// with a stamp, also those accepted at or before it). Active goals move to CANCELING.
    pub fn cancel(&mut self, id: &GoalId, stamp: &Time) -> CancelOutcome {
        let zero_stamp = *stamp == Time::default();
        let by_stamp = |g: &Goal<RequestId>| {
            (*id == ZERO_GOAL_ID && zero_stamp) || (!zero_stamp && time_le(&g.accepted_at, stamp))
        };
        let mut goals_canceling = Vec::new();
        for goal in self.goals.iter_mut() {
            let selected = goal.id == *id || by_stamp(goal);
            if selected && matches!(goal.status, GoalStatus::Accepted | GoalStatus::Executing) {
                goal.status = GoalStatus::Canceling;
                goals_canceling.push((goal.id, goal.accepted_at.clone()));
            }
        }
        let return_code = if !goals_canceling.is_empty() {
            CancelReturn::None
        } else if *id == ZERO_GOAL_ID {
            CancelReturn::Rejected
        } else {
            match self.goals.iter().find(|g| g.id == *id) {
                None => CancelReturn::UnknownGoalId,
                Some(g) if g.status.is_terminal() => CancelReturn::GoalTerminated,
                Some(_) => CancelReturn::Rejected,
            }
        };
        CancelOutcome {
            return_code,
            goals_canceling,
        }
    }

    /// Every goal's (id, accept stamp, status), for action_msgs/msg/GoalStatusArray.
    pub fn statuses(&self) -> Vec<(GoalId, Time, GoalStatus)> {
        self.goals
            .iter()
            .map(|g| (g.id, g.accepted_at.clone(), g.status))
            .collect()
    }

    pub fn status(&self, id: &GoalId) -> Option<GoalStatus> {
        self.goals.iter().find(|g| &g.id == id).map(|g| g.status)
    }
}

fn time_le(a: &Time, b: &Time) -> bool {
    (a.sec, a.nanosec) <= (b.sec, b.nanosec)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn id(n: u8) -> GoalId {
        [n; 16]
    }

    fn stamp(sec: i32) -> Time {
        Time { sec, nanosec: 0 }
    }

    fn result(code: i32, text: &str) -> FollowJointTrajectoryResult {
        FollowJointTrajectoryResult {
            error_code: code,
            error_string: text.into(),
        }
    }

    #[test]
    fn goals_beyond_the_unfinished_limit_are_rejected_until_one_finishes() {
        let mut table: GoalTable<&str> = GoalTable::new(4);
        for n in 0..MAX_UNFINISHED_GOALS {
            table.accept([n as u8; 16], stamp(1)).unwrap();
        }
        assert_eq!(
            table.accept(id(200), stamp(2)),
            Err(GoalTableError::Full(MAX_UNFINISHED_GOALS))
        );
        table
            .finish(&id(0), GoalStatus::Succeeded, result(0, ""))
            .unwrap();
        table.accept(id(200), stamp(2)).unwrap();
    }

    #[test]
    fn a_result_request_waits_for_its_goal_and_is_answered_when_it_finishes() {
        let mut table = GoalTable::new(4);
        table.accept(id(1), stamp(1)).unwrap();
        assert_eq!(table.request_result(&id(1), "req-a"), ResultReply::Later);
        let waiting = table
            .finish(&id(1), GoalStatus::Aborted, result(-4, "path"))
            .unwrap();
        assert_eq!(waiting, vec!["req-a"]);
        assert_eq!(
            table.request_result(&id(1), "req-b"),
            ResultReply::Now(GoalStatus::Aborted, result(-4, "path"))
        );
        assert_eq!(
            table.request_result(&id(9), "req-c"),
            ResultReply::Now(GoalStatus::Unknown, FollowJointTrajectoryResult::default())
        );
    }

    #[test]
    fn goals_cannot_be_accepted_twice_nor_finished_twice_nor_end_non_terminal() {
        let mut table = GoalTable::<()>::new(4);
        table.accept(id(1), stamp(1)).unwrap();
        assert_eq!(
            table.accept(id(1), stamp(2)),
            Err(GoalTableError::Duplicate(id(1)))
        );
        assert_eq!(
            table.finish(&id(1), GoalStatus::Executing, result(0, "")),
            Err(GoalTableError::NotTerminal(GoalStatus::Executing))
        );
        table
            .finish(&id(1), GoalStatus::Succeeded, result(0, ""))
            .unwrap();
        assert_eq!(
            table.finish(&id(1), GoalStatus::Succeeded, result(0, "")),
            Err(GoalTableError::Finished(id(1)))
        );
        assert_eq!(
            table.finish(&id(2), GoalStatus::Succeeded, result(0, "")),
            Err(GoalTableError::Unknown(id(2)))
        );
    }

    #[test]
    fn cancel_follows_the_cancel_goal_policy() {
        let mut table = GoalTable::<()>::new(4);
        for n in 1..=3 {
            table.accept(id(n), stamp(i32::from(n) * 10)).unwrap();
        }
        // one goal by id
        let one = table.cancel(&id(2), &Time::default());
        assert_eq!(one.return_code, CancelReturn::None);
        assert_eq!(one.goals_canceling, vec![(id(2), stamp(20))]);
        assert_eq!(table.status(&id(2)), Some(GoalStatus::Canceling));
        // already canceling: nothing more to cancel, but the goal is not terminal
        assert_eq!(
            table.cancel(&id(2), &Time::default()).return_code,
            CancelReturn::Rejected
        );
        // zero id with a stamp: goals accepted at or before it
        let before = table.cancel(&ZERO_GOAL_ID, &stamp(10));
        assert_eq!(before.goals_canceling, vec![(id(1), stamp(10))]);
        // unknown and finished goals
        assert_eq!(
            table.cancel(&id(7), &Time::default()).return_code,
            CancelReturn::UnknownGoalId
        );
        table
            .finish(&id(1), GoalStatus::Canceled, result(0, ""))
            .unwrap();
        assert_eq!(
            table.cancel(&id(1), &Time::default()).return_code,
            CancelReturn::GoalTerminated
        );
        // zero id and zero stamp: every active goal
        let all = table.cancel(&ZERO_GOAL_ID, &Time::default());
        assert_eq!(all.goals_canceling, vec![(id(3), stamp(30))]);
        assert_eq!(
            table.cancel(&ZERO_GOAL_ID, &Time::default()).return_code,
            CancelReturn::Rejected
        );
    }

    #[test]
    fn only_the_newest_finished_goals_are_kept() {
        let mut table = GoalTable::<()>::new(2);
        for n in 1..=4 {
            table.accept(id(n), stamp(i32::from(n))).unwrap();
        }
        table.accept(id(9), stamp(9)).unwrap();
        for n in 1..=4 {
            table
                .finish(&id(n), GoalStatus::Succeeded, result(0, ""))
                .unwrap();
        }
        let ids: Vec<GoalId> = table.statuses().iter().map(|s| s.0).collect();
        assert_eq!(ids, vec![id(3), id(4), id(9)]);
    }
}
