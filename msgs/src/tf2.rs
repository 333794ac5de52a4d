//! `tf2_msgs/TFMessage` (topics `/tf` and `/tf_static`).

use super::TransformStamped;
use serde::{Deserialize, Serialize};

/// `tf2_msgs/msg/TFMessage`: a batch of stamped transforms between coordinate frames.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct TFMessage {
    /// Each one's parent is `header.frame_id`, its child `child_frame_id`.
    pub transforms: Vec<TransformStamped>,
}
super::ros_message!(TFMessage, "tf2_msgs", "TFMessage");
