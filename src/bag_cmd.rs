//! `fitslam bag-info`: a rosbag2 MCAP recording's topics, types, counts, duration and decision
//! instants; and the options and loading `fitslam select --bag` shares with it.

use crate::load;
use anyhow::Result;
use clap::Args;
use fitslam_core::bag::{Bag, BagTopics, InstantSource, PoseSource};
use std::path::{Path, PathBuf};

/// Where a bag's inputs are: the node's configuration defaults, each overridable.
#[derive(Args, Debug, Clone)]
pub struct TopicArgs {
    /// nav_msgs/OccupancyGrid topic.
    #[arg(long, default_value = "/map")]
    pub map_topic: String,
    /// sensor_msgs/PointCloud2 landmark topic ("" for none).
    #[arg(long, default_value = "/cloud_map")]
    pub landmarks_topic: String,
    /// geometry_msgs/PoseWithCovarianceStamped topic (used when tf gives no pose).
    #[arg(long, default_value = "/localization_pose")]
    pub pose_topic: String,
    /// The node's std_msgs/String status topic.
    #[arg(long, default_value = "/fitslam/status")]
    pub status_topic: String,
    /// Global frame.
    #[arg(long, default_value = "map")]
    pub map_frame: String,
    /// Robot body frame.
    #[arg(long, default_value = "base_link")]
    pub base_frame: String,
    /// Pose from tf or from the pose topic; default: tf when it links the frames, else the topic.
    #[arg(long, value_enum)]
    pub pose_source: Option<PoseSource>,
}

impl TopicArgs {
    pub fn topics(&self) -> BagTopics {
        BagTopics {
            map_topic: self.map_topic.clone(),
            landmarks_topic: self.landmarks_topic.clone(),
            pose_topic: self.pose_topic.clone(),
            status_topic: self.status_topic.clone(),
            map_frame: self.map_frame.clone(),
            base_frame: self.base_frame.clone(),
            pose_source: self.pose_source,
            ..BagTopics::default()
        }
    }
}

/// Reads and parses a bag file.
pub fn open(path: &Path) -> Result<Bag> {
    Ok(Bag::parse(&load::read(path)?, &path.display().to_string())?)
}

#[derive(Args, Debug)]
pub struct BagInfoArgs {
    /// rosbag2 MCAP file (`ros2 bag record -s mcap`, or `fitslam explore --bag`).
    pub bag: PathBuf,
    #[command(flatten)]
    pub topics: TopicArgs,
    /// Print as JSON.
    #[arg(long)]
    pub json: bool,
}

pub fn run(args: &BagInfoArgs) -> Result<()> {
    let bag = open(&args.bag)?;
    let topics = bag.topics();
    let instants = bag.decision_instants(&args.topics.topics())?;
    if args.json {
        let json = serde_json::json!({
            "duration_s": bag.duration_s(),
            "profile": bag.mcap().profile,
            "library": bag.mcap().library,
            "topics": topics,
            "decision_instants": instants,
        });
        outln!("{}", serde_json::to_string_pretty(&json)?)?;
        return Ok(());
    }
    outln!(
        "{}: {:.3} s, {} messages, written by {:?}",
        args.bag.display(),
        bag.duration_s(),
        bag.mcap().messages.len(),
        bag.mcap().library
    )?;
    outln!("{:<28} {:<44} {:>7} {:>9} {:>9}", "topic", "type", "count", "first_s", "last_s")?;
    for t in &topics {
        outln!("{:<28} {:<44} {:>7} {:>9.3} {:>9.3}", t.topic, t.msg_type, t.count, t.first_s, t.last_s)?;
    }
    let from = match instants.first().map(|i| i.source) {
        Some(InstantSource::NewGoal) => format!("new goals on {}", args.topics.status_topic),
        Some(InstantSource::MapUpdate) => format!("map updates on {} (no status recorded)", args.topics.map_topic),
        None => "none".into(),
    };
    outln!("decision instants ({}, {from}):", instants.len())?;
    for i in &instants {
        match i.goal {
            Some(g) => outln!("  {:>9.3} s  goal ({:.2}, {:.2})", i.t_s, g.x_m, g.y_m)?,
            None => outln!("  {:>9.3} s", i.t_s)?,
        }
    }
    Ok(())
}
