//! `nav2_msgs/action/NavigateToPose` (Jazzy layout). Humble's result is `std_msgs/Empty`
//! instead of (error_code, error_msg): against a Humble Nav2 the result fails to decode and the
//! node treats the goal as failed, so run it against Jazzy or use the `/goal_pose` fallback.

use super::{Duration, PoseStamped};
use serde::{Deserialize, Serialize};

/// Action package and name for `ros2_client::ActionTypeName`.
pub const ACTION_PACKAGE: &str = "nav2_msgs";
pub const ACTION_NAME: &str = "NavigateToPose";

/// Goal.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NavigateToPoseGoal {
    pub pose: PoseStamped,
    /// Behaviour tree file or ID; empty = Nav2's default.
    pub behavior_tree: String,
}
impl ros2_client::Message for NavigateToPoseGoal {}

/// Result: `error_code` 0 is success (NONE); 9000+ are Nav2's codes.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NavigateToPoseResult {
    pub error_code: u16,
    pub error_msg: String,
}
impl ros2_client::Message for NavigateToPoseResult {}

/// Feedback.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NavigateToPoseFeedback {
    pub current_pose: PoseStamped,
    pub navigation_time: Duration,
    pub estimated_time_remaining: Duration,
    pub number_of_recoveries: i16,
    pub distance_remaining: f32,
}
impl ros2_client::Message for NavigateToPoseFeedback {}
