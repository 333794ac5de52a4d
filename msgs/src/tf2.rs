//! `tf2_msgs/TFMessage` (topics `/tf` and `/tf_static`).

use super::TransformStamped;
use serde::{Deserialize, Serialize};

/// `tf2_msgs/TFMessage`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TFMessage {
    pub transforms: Vec<TransformStamped>,
}
super::ros_message!(TFMessage, "tf2_msgs", "TFMessage");
