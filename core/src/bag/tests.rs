//! The MCAP reader against the writer, chunks compressed as rosbag2 compresses them, hostile
//! bytes, and a snapshot through a tf chain.

use super::mcap::{MAGIC, op};
use super::*;
use crate::Pose2;
use crate::grid::{GridGeometry, OccupancyGrid};
use crate::ros::{cloud_of_points, msg_of_occupancy, transform_of_pose2};
use fitslam_msgs::{Header, OccupancyGrid as MapMsg, PointCloud2, StringMsg, TFMessage, Time, TransformStamped, cdr};
use nalgebra::Point3;

const S: u64 = 1_000_000_000;

fn tf(parent: &str, child: &str, p: Pose2) -> TransformStamped {
    TransformStamped { header: Header::new(Time::default(), parent), child_frame_id: child.into(), transform: transform_of_pose2(p) }
}

fn tfs(transforms: Vec<TransformStamped>) -> Vec<u8> {
    cdr::to_vec(&TFMessage { transforms }).unwrap()
}

/// A small mission: a 20 × 10 free map at 1 s and 3 s, tf map → odom → base_link, a landmark
/// cloud in `odom`, and two status messages with goals 1 and 2.
fn mission() -> Vec<u8> {
    let mut w = McapWriter::new("test");
    let map = w.channel::<MapMsg>("/map");
    let tf_ch = w.channel::<TFMessage>("/tf");
    let tf_static = w.channel::<TFMessage>("/tf_static");
    let lm = w.channel::<PointCloud2>("/cloud_map");
    let status = w.channel::<StringMsg>("/fitslam/status");
    let grid = OccupancyGrid::from_vec(GridGeometry::new(-1.0, -1.0, 0.1, 20, 10), vec![0; 200]).unwrap();
    let h = |f: &str| Header::new(Time::from_secs_f64(1.0), f);
    w.message(tf_static, 0, &tfs(vec![tf("base_link", "laser", Pose2::new(0.1, 0.0, 0.0))]));
    for k in 0..=4u64 {
        let chain = vec![
            tf("map", "odom", Pose2::new(0.5, 0.0, 0.0)),
            tf("odom", "base_link", Pose2::new(0.1 * k as f64, 0.0, std::f64::consts::FRAC_PI_2)),
        ];
        w.message(tf_ch, k * S, &tfs(chain));
    }
    for t in [1, 3] {
        w.message(map, t * S, &cdr::to_vec(&msg_of_occupancy(&grid, h("map"))).unwrap());
    }
    w.message(lm, 2 * S, &cdr::to_vec(&cloud_of_points(&[Point3::new(0.0, 0.0, 1.0)], h("odom"))).unwrap());
    for (t, id) in [(1, 1), (2, 1), (4, 2)] {
        let data = format!(
            r#"{{"t_s":{t},"phase":"navigating","goal":{{"id":{id},"goal":{{"x_m":0.2,"y_m":{id}.0,"yaw_rad":0.0}},"frontier_m":[0.3,{id}.0]}}}}"#
        );
        w.message(status, t * S + 1, &cdr::to_vec(&StringMsg { data }).unwrap());
    }
    w.finish()
}

#[test]
fn written_bags_read_back_with_their_topics_and_instants() {
    let bag = Bag::parse(&mission(), "m.mcap").unwrap();
    assert_eq!(bag.mcap().profile, "ros2");
    let topics = bag.topics();
    let names: Vec<_> = topics.iter().map(|t| (t.topic.as_str(), t.count)).collect();
    assert_eq!(names, [("/cloud_map", 1), ("/fitslam/status", 3), ("/map", 2), ("/tf", 5), ("/tf_static", 1)]);
    assert_eq!(topics[2].msg_type, "nav_msgs/msg/OccupancyGrid");
    let t = BagTopics::default();
    let instants = bag.decision_instants(&t).unwrap();
    assert_eq!(instants.len(), 2, "{instants:?}");
    assert!((instants[1].t_s - 4.0).abs() < 1e-6);
    assert_eq!(instants[1].goal.map(|g| (g.x_m, g.y_m)), Some((0.3, 2.0)));
}

#[test]
fn a_snapshot_composes_the_tf_chain_and_moves_landmarks_into_the_map_frame() {
    let bag = Bag::parse(&mission(), "m.mcap").unwrap();
    let s = bag.snapshot(&BagTopics::default(), 2.5).unwrap();
    assert_eq!(s.pose_source, PoseSource::Tf);
    assert!((s.robot.x_m - 0.7).abs() < 1e-9 && s.robot.y_m.abs() < 1e-9, "{:?}", s.robot);
    assert!((s.robot.yaw_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
    assert!((s.map_t_s - 1.0).abs() < 1e-9);
    assert_eq!(s.landmarks.points, [Point3::new(0.5, 0.0, 1.0)]);
    assert_eq!(s.robot_choice.as_ref().and_then(|c| c.frontier_m), Some([0.3, 1.0]));
    let e = bag.snapshot(&BagTopics::default(), 0.5).unwrap_err();
    assert!(e.to_string().contains("no map on /map at t = 0.5 s: the first is at 1.000000 s"), "{e}");
    assert!(matches!(bag.snapshot(&BagTopics::default(), 9.0), Err(BagError::OutOfRange { .. })));
    let topics = BagTopics { map_topic: "/tf".into(), ..BagTopics::default() };
    assert!(matches!(bag.snapshot(&topics, 2.0), Err(BagError::WrongType { .. })));
}

/// The data section of a written bag with its one chunk's records compressed by `compress`.
fn recompressed(compression: &str, compress: impl Fn(&[u8]) -> Vec<u8>) -> Vec<u8> {
    let plain = Mcap::parse(&mission(), "m").unwrap();
    let mut inner = Vec::new();
    let rec = |out: &mut Vec<u8>, opcode: u8, body: &[u8]| {
        out.push(opcode);
        out.extend_from_slice(&(body.len() as u64).to_le_bytes());
        out.extend_from_slice(body);
    };
    let s = |out: &mut Vec<u8>, t: &str| {
        out.extend_from_slice(&(t.len() as u32).to_le_bytes());
        out.extend_from_slice(t.as_bytes());
    };
    for m in &plain.messages {
        let mut b = m.channel_id.to_le_bytes().to_vec();
        b.extend_from_slice(&0u32.to_le_bytes());
        b.extend_from_slice(&m.log_time_ns.to_le_bytes());
        b.extend_from_slice(&m.log_time_ns.to_le_bytes());
        b.extend_from_slice(&m.data);
        rec(&mut inner, op::MESSAGE, &b);
    }
    let mut out = MAGIC.to_vec();
    let mut h = Vec::new();
    s(&mut h, "ros2");
    s(&mut h, "test");
    rec(&mut out, op::HEADER, &h);
    for c in &plain.channels {
        let mut b = c.id.to_le_bytes().to_vec();
        b.extend_from_slice(&c.schema_id.to_le_bytes());
        s(&mut b, &c.topic);
        s(&mut b, "cdr");
        b.extend_from_slice(&0u32.to_le_bytes());
        rec(&mut out, op::CHANNEL, &b);
    }
    for sc in &plain.schemas {
        let mut b = sc.id.to_le_bytes().to_vec();
        s(&mut b, &sc.name);
        s(&mut b, "ros2msg");
        s(&mut b, "");
        rec(&mut out, op::SCHEMA, &b);
    }
    let packed = compress(&inner);
    let mut chunk = Vec::new();
    chunk.extend_from_slice(&[0; 16]);
    chunk.extend_from_slice(&(inner.len() as u64).to_le_bytes());
    chunk.extend_from_slice(&crc32fast::hash(&inner).to_le_bytes());
    s(&mut chunk, compression);
    chunk.extend_from_slice(&(packed.len() as u64).to_le_bytes());
    chunk.extend_from_slice(&packed);
    rec(&mut out, op::CHUNK, &chunk);
    rec(&mut out, op::DATA_END, &[0; 4]);
    out
}

#[test]
fn lz4_and_zstd_chunks_decode_and_others_are_named() {
    use std::io::Write as _;
    let plain = Mcap::parse(&mission(), "m").unwrap();
    let lz4 = recompressed("lz4", |b| {
        let mut e = lz4_flex::frame::FrameEncoder::new(Vec::new());
        e.write_all(b).unwrap();
        e.finish().unwrap()
    });
    assert_eq!(Mcap::parse(&lz4, "lz4.mcap").unwrap().messages, plain.messages);
    let zstd = recompressed("zstd", |b| ruzstd::encoding::compress_to_vec(b, ruzstd::encoding::CompressionLevel::Fastest));
    assert_eq!(Mcap::parse(&zstd, "z.mcap").unwrap().messages, plain.messages);
    let e = Mcap::parse(&recompressed("bz2", |b| b.to_vec()), "b.mcap").unwrap_err();
    assert!(e.to_string().starts_with("b.mcap: byte ") && e.to_string().contains("\"bz2\" is not supported"), "{e}");
    let mut bad = lz4.clone();
    let n = bad.len();
    bad[n - 40] ^= 0xff;
    assert!(Mcap::parse(&bad, "bad.mcap").is_err());
}

#[test]
fn truncated_and_foreign_files_give_typed_errors() {
    let bytes = mission();
    assert!(matches!(Mcap::parse(b"", "e.mcap"), Err(BagError::NotMcap { .. })));
    assert!(Mcap::parse(b"SQLite format 3\0....", "b.db3").unwrap_err().to_string().contains("ros2 bag convert"));
    // Every prefix fails cleanly up to the end of the data section.
    let data_end = bytes.windows(13).position(|w| w == [op::DATA_END, 4, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]).unwrap();
    for n in (0..data_end).step_by(7) {
        let e = Mcap::parse(&bytes[..n], "cut.mcap").unwrap_err();
        assert!(e.to_string().starts_with("cut.mcap: "), "{e}");
    }
    let e = Mcap::parse(&bytes[..data_end], "cut.mcap").unwrap_err();
    assert!(matches!(e, BagError::Truncated { .. }) && e.to_string().contains("cut short"), "{e}");
}
