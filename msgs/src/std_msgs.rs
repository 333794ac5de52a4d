//! `std_msgs`: Header, String, ColorRGBA.

use super::Time;
use serde::{Deserialize, Serialize};

/// `std_msgs/Header`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    pub stamp: Time,
    pub frame_id: String,
}
super::ros_message!(Header, "std_msgs", "Header");

impl Header {
    pub fn new(stamp: Time, frame_id: &str) -> Self {
        Self { stamp, frame_id: frame_id.to_owned() }
    }
}

/// `std_msgs/String` (named `StringMsg` to keep Rust's `String` in scope).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StringMsg {
    pub data: String,
}
super::ros_message!(StringMsg, "std_msgs", "String");

/// `std_msgs/ColorRGBA`, components in [0, 1].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ColorRGBA {
    pub r: f32,
    pub g: f32,
    pub b: f32,
    pub a: f32,
}
super::ros_message!(ColorRGBA, "std_msgs", "ColorRGBA");

impl ColorRGBA {
    pub const fn new(r: f32, g: f32, b: f32, a: f32) -> Self {
        Self { r, g, b, a }
    }
}
