//! `nav2_msgs/action/NavigateToPose` (Jazzy layout). The goal and feedback are the same in
//! Humble and Iron; the result is not (Humble: `std_msgs/Empty`; Iron: `error_code` only), so
//! the result decodes leniently: missing trailing fields take their defaults (the outcome itself
//! travels in the action's status, not in these fields).

use super::{Duration, PoseStamped};
use serde::{Deserialize, Serialize};

/// Action package, for `ros2_client::ActionTypeName`.
pub const ACTION_PACKAGE: &str = "nav2_msgs";
/// Action name, for `ros2_client::ActionTypeName`.
pub const ACTION_NAME: &str = "NavigateToPose";

/// `nav2_msgs/action/NavigateToPose` goal: the pose to drive to and the behaviour tree to use.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NavigateToPoseGoal {
    /// Pose to reach, in the frame named by its header (usually `map`).
    pub pose: PoseStamped,
    /// Behaviour tree file or ID; empty = Nav2's default.
    pub behavior_tree: String,
}
#[cfg(feature = "ros2")]
impl ros2_client::Message for NavigateToPoseGoal {}

/// `nav2_msgs/action/NavigateToPose` result: `error_code` 0 is success (NONE); 9000+ are Nav2's
/// codes.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct NavigateToPoseResult {
    /// 0 (`NONE`) on success, else one of the action's error codes (9000 `UNKNOWN`,
    /// 9001 `FAILED_TO_LOAD_BEHAVIOR_TREE`, …); 0 too when the server's layout lacks the field.
    pub error_code: u16,
    /// Why the goal failed, as text; empty when the server sends none or its layout lacks the
    /// field.
    pub error_msg: String,
}
#[cfg(feature = "ros2")]
impl ros2_client::Message for NavigateToPoseResult {}

impl<'de> Deserialize<'de> for NavigateToPoseResult {
    /// Jazzy's (error_code, error_msg); a result that ends early (Iron, Humble) keeps the
    /// defaults of the fields it lacks.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = NavigateToPoseResult;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a NavigateToPose result")
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<Self::Value, A::Error> {
                let error_code = seq.next_element::<u16>().ok().flatten().unwrap_or(0);
                let error_msg = seq.next_element::<String>().ok().flatten().unwrap_or_default();
                Ok(NavigateToPoseResult { error_code, error_msg })
            }
        }
        d.deserialize_struct("NavigateToPoseResult", &["error_code", "error_msg"], V)
    }
}

/// `nav2_msgs/action/NavigateToPose` feedback: the robot's progress towards the goal.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NavigateToPoseFeedback {
    /// The robot's pose in Nav2's global frame.
    pub current_pose: PoseStamped,
    /// Time spent on this goal so far.
    pub navigation_time: Duration,
    /// Nav2's estimate of the time left to reach the goal.
    pub estimated_time_remaining: Duration,
    /// Recovery behaviours run so far for this goal.
    pub number_of_recoveries: i16,
    /// Length of the remaining path to the goal, metres.
    pub distance_remaining: f32,
}
#[cfg(feature = "ros2")]
impl ros2_client::Message for NavigateToPoseFeedback {}
