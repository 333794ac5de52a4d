//! What the node and its ROS adapter exchange: the commands the node gives and what the
//! navigation stack reported about a goal. The status it publishes is the core's
//! [`fitslam_core::ros::NodeStatus`].

use fitslam_core::Pose2;

/// What the adapter must do.
#[derive(Clone, Debug, PartialEq)]
pub enum Command {
    /// Send this goal (map frame) under this id.
    SendGoal { id: u64, goal: Pose2 },
    /// Cancel the goal with this id (no-op for topic goals).
    CancelGoal { id: u64 },
    /// No frontier left (or the time limit): the mission is over.
    MissionComplete,
}

/// What the navigation stack reported about a goal.
#[derive(Clone, Debug, PartialEq)]
pub enum GoalEvent {
    Accepted,
    /// Feedback from the action server: the goal is still being driven to.
    Feedback,
    Rejected,
    Succeeded,
    /// Aborted by the navigation stack, with its message.
    Aborted(String),
    /// Cancelled by someone else.
    Canceled,
    /// Communication failure (no answer, undecodable result): dropped, not blacklisted.
    Lost(String),
}
