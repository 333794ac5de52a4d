//! `std_msgs`: Header, String, ColorRGBA.

use super::Time;
use serde::{Deserialize, Serialize};

/// `std_msgs/msg/Header`: when the data was taken and the coordinate frame it is expressed in.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// Acquisition time of the data (zero: unset, or "latest" in tf2 lookups).
    pub stamp: Time,
    /// tf2 frame the data is expressed in, e.g. `map`, `odom`, `base_link`.
    pub frame_id: String,
}
super::ros_message!(Header, "std_msgs", "Header");

impl Header {
    /// A header stamped `stamp` in frame `frame_id`.
    pub fn new(stamp: Time, frame_id: &str) -> Self {
        Self { stamp, frame_id: frame_id.to_owned() }
    }
}

/// `std_msgs/msg/String`: one text value (named `StringMsg` to keep Rust's `String` in scope).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StringMsg {
    /// The text, UTF-8.
    pub data: String,
}
super::ros_message!(StringMsg, "std_msgs", "String");

/// `std_msgs/msg/ColorRGBA`: a colour with opacity, components in [0, 1].
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ColorRGBA {
    /// Red, 0..=1.
    pub r: f32,
    /// Green, 0..=1.
    pub g: f32,
    /// Blue, 0..=1.
    pub b: f32,
    /// Opacity, 0 transparent ..= 1 opaque.
    pub a: f32,
}
super::ros_message!(ColorRGBA, "std_msgs", "ColorRGBA");

impl ColorRGBA {
    /// From red, green, blue and opacity, each in [0, 1] (not clamped).
    pub const fn new(r: f32, g: f32, b: f32, a: f32) -> Self {
        Self { r, g, b, a }
    }
}
