//! `nav2_msgs/action/NavigateToPose` (Jazzy layout). The goal and feedback are the same in
//! Humble and Iron; the result is not (Humble: `std_msgs/Empty`; Iron: `error_code` only), so
//! the result decodes leniently: missing trailing fields take their defaults (the outcome itself
//! travels in the action's status, not in these fields).

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
#[cfg(feature = "ros2")]
impl ros2_client::Message for NavigateToPoseGoal {}

/// Result: `error_code` 0 is success (NONE); 9000+ are Nav2's codes.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct NavigateToPoseResult {
    pub error_code: u16,
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

/// Feedback.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct NavigateToPoseFeedback {
    pub current_pose: PoseStamped,
    pub navigation_time: Duration,
    pub estimated_time_remaining: Duration,
    pub number_of_recoveries: i16,
    pub distance_remaining: f32,
}
#[cfg(feature = "ros2")]
impl ros2_client::Message for NavigateToPoseFeedback {}
