//! `builtin_interfaces`: Time and Duration.

use serde::{Deserialize, Serialize};

const NS_PER_S: u64 = 1_000_000_000;

/// `builtin_interfaces/msg/Time`: a point in time as seconds and nanoseconds since the Unix
/// epoch (or since the start of a simulation, with `use_sim_time`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
pub struct Time {
    /// Whole seconds, over the full `i32` range (−1.7 s is `sec` −2 plus 0.3 s in `nanosec`).
    pub sec: i32,
    /// Nanoseconds added to `sec`, in `0..1_000_000_000`.
    pub nanosec: u32,
}
super::ros_message!(Time, "builtin_interfaces", "Time");

impl Time {
    /// From seconds, rounded to the nanosecond (saturating at the i32 range; negative and NaN
    /// give zero).
    pub fn from_secs_f64(t_s: f64) -> Self {
        if t_s.is_nan() || t_s <= 0.0 {
            return Self::default();
        }
        let ns = (t_s * 1e9).round() as u64; // saturates on overflow
        match i32::try_from(ns / NS_PER_S) {
            Ok(sec) => Self { sec, nanosec: (ns % NS_PER_S) as u32 },
            Err(_) => Self { sec: i32::MAX, nanosec: 999_999_999 },
        }
    }

    /// Seconds as f64.
    pub fn as_secs_f64(&self) -> f64 {
        self.sec as f64 + self.nanosec as f64 * 1e-9
    }

    /// Whether this is the zero stamp ("latest available" in tf2 and unset in most publishers).
    pub fn is_zero(&self) -> bool {
        self.sec == 0 && self.nanosec == 0
    }
}

/// `builtin_interfaces/msg/Duration`: a signed span of time as seconds and nanoseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Duration {
    /// Whole seconds, negative for a negative span (`nanosec` is still added).
    pub sec: i32,
    /// Nanoseconds added to `sec`, in `0..1_000_000_000`.
    pub nanosec: u32,
}
super::ros_message!(Duration, "builtin_interfaces", "Duration");
