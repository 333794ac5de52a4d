//! Recorded missions: rosbag2 MCAP files, read and written, and the decision inputs they held.
//!
//! A ROS 2 robot running the fitslam node records its inputs with `ros2 bag record` (MCAP is
//! rosbag2's default storage since Iron); `fitslam explore --bag` writes a simulated mission the
//! same way (`sim::recorder`). Either opens here: the map, landmarks and pose the robot
//! had at any instant, and what the robot chose then (its status messages), so a decision can
//! be made again with other parameters.
//!
//! | module | what |
//! |---|---|
//! | [`mcap`] | the MCAP container: records, chunks (zstd, lz4 or none), CRCs |
//! | [`mcap_write`] | an MCAP writer (rosbag2 profile, uncompressed chunks, summary and indexes) |
//! | [`replay`] | topics, the inputs at an instant (map, landmarks, pose through tf), decision instants |
//!
//! Messages are `fitslam_msgs` types in CDR ([`fitslam_msgs::cdr`]), converted to the core's
//! types by [`crate::ros`]; the node's status is [`crate::ros::NodeStatus`]. Every function
//! takes bytes and a `source_name` used only in messages; hostile bytes give a [`BagError`],
//! never a panic.

pub mod mcap;
pub mod mcap_write;
pub mod replay;

pub use mcap::Mcap;
pub use mcap_write::McapWriter;
pub use replay::{Bag, BagTopics, DecisionInstant, InstantSource, PoseSource, RobotChoice, Snapshot, TopicInfo};

use thiserror::Error;

/// Why a bag could not be read, or an instant of it replayed. Every message starts with the
/// file's name.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum BagError {
    /// Not an MCAP file (the detail says what it is, when known).
    #[error("{name}: not an MCAP file: {detail}")]
    NotMcap {
        /// The bag's name, as given to [`Bag::parse`] (usually its file name).
        name: String,
        /// What is wrong, in words.
        detail: String,
    },
    /// The file ends inside a record, or before its data section is closed.
    #[error("{name}: truncated at byte {offset}: {detail}")]
    Truncated {
        /// The bag's name, as given to [`Bag::parse`] (usually its file name).
        name: String,
        /// Byte offset in the file.
        offset: u64,
        /// What is wrong, in words.
        detail: String,
    },
    /// A record whose content is inconsistent.
    #[error("{name}: byte {offset}: {detail}")]
    Malformed {
        /// The bag's name, as given to [`Bag::parse`] (usually its file name).
        name: String,
        /// Byte offset in the file.
        offset: u64,
        /// What is wrong, in words.
        detail: String,
    },
    /// A chunk compressed with something this reader does not decode.
    #[error("{name}: byte {offset}: chunk compression {compression:?} is not supported (zstd, lz4 and none are)")]
    Compression {
        /// The bag's name, as given to [`Bag::parse`] (usually its file name).
        name: String,
        /// Byte offset in the file.
        offset: u64,
        /// The chunk's compression name.
        compression: String,
    },
    /// A chunk whose compressed bytes do not decode to what its header says.
    #[error("{name}: byte {offset}: {compression} chunk: {detail}")]
    Decompress {
        /// The bag's name, as given to [`Bag::parse`] (usually its file name).
        name: String,
        /// Byte offset in the file.
        offset: u64,
        /// The chunk's compression name.
        compression: String,
        /// What is wrong, in words.
        detail: String,
    },
    /// A message that does not decode as its topic's type.
    #[error("{name}: {topic} ({msg_type}) message at t = {t_s:.3} s: {detail}")]
    Message {
        /// The bag's name, as given to [`Bag::parse`] (usually its file name).
        name: String,
        /// The topic.
        topic: String,
        /// Its message type.
        msg_type: String,
        /// Seconds from the bag's first message.
        t_s: f64,
        /// What is wrong, in words.
        detail: String,
    },
    /// A topic recorded with a type other than the one a replay reads there.
    #[error("{name}: topic {topic} has type {found}, expected {expected}")]
    WrongType {
        /// The bag's name, as given to [`Bag::parse`] (usually its file name).
        name: String,
        /// The topic.
        topic: String,
        /// The type recorded on the topic.
        found: String,
        /// The type the replay reads there.
        expected: String,
    },
    /// An input the replay needs is not in the bag (before the instant asked for).
    #[error("{name}: {detail}")]
    Missing {
        /// The bag's name, as given to [`Bag::parse`] (usually its file name).
        name: String,
        /// What is wrong, in words.
        detail: String,
    },
    /// An instant outside the bag.
    #[error("{name}: t = {t_s} s is outside the recording (0 to {duration_s:.3} s from its first message)")]
    OutOfRange {
        /// The bag's name, as given to [`Bag::parse`] (usually its file name).
        name: String,
        /// Seconds from the bag's first message.
        t_s: f64,
        /// The bag's length, seconds.
        duration_s: f64,
    },
}

impl BagError {
    /// The error of a record inside a decompressed chunk, placed at the chunk's file offset.
    pub(crate) fn at_chunk(self, chunk_offset: u64) -> Self {
        match self {
            BagError::Truncated { name, detail, .. } => BagError::Truncated { name, offset: chunk_offset, detail },
            BagError::Malformed { name, detail, .. } => BagError::Malformed { name, offset: chunk_offset, detail },
            other => other,
        }
    }
}

#[cfg(test)]
mod tests;
