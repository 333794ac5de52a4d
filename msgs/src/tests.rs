//! Layout of the message types through [`crate::cdr`]: golden bytes for small ones
//! (hand-derived from the CDR alignment rules), round trips for all; with the feature `ros2`,
//! the same bytes as RustDDS's CDR (what the robot node puts on the wire) and DDS type names.

use super::*;
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::fmt::Debug;

/// The message's body (after the encapsulation header), checked to decode back to `v`, and with
/// `ros2` to be RustDDS's bytes for `v` and to decode with RustDDS too.
fn roundtrip<T: Serialize + DeserializeOwned + PartialEq + Debug>(v: &T) -> Vec<u8> {
    let bytes = cdr::to_vec(v).unwrap();
    assert_eq!(&bytes[..4], &[0, 1, 0, 0]);
    assert_eq!(&cdr::from_bytes::<T>(&bytes).unwrap(), v);
    #[cfg(feature = "ros2")]
    {
        use byteorder::LittleEndian;
        use ros2_client::dds::rustdds::cdr_encoding;
        assert_eq!(cdr_encoding::to_vec::<T, LittleEndian>(v).unwrap(), bytes[4..], "RustDDS writes other bytes");
        let (back, used) = cdr_encoding::from_bytes::<T, LittleEndian>(&bytes[4..]).unwrap();
        assert_eq!((&back, used), (v, bytes.len() - 4));
    }
    bytes[4..].to_vec()
}

#[test]
fn pose_stamped_golden_bytes() {
    let m = PoseStamped {
        header: Header::new(Time { sec: 1, nanosec: 2 }, "map"),
        pose: Pose { position: Point { x: 1.5, y: -2.0, z: 0.0 }, orientation: Quaternion::default() },
    };
    let b = roundtrip(&m);
    // sec (4) nanosec (4) | len 4 + "map\0" (8) → 16 | 7 × f64 aligned at 16 → 72.
    assert_eq!(b.len(), 72);
    assert_eq!(&b[0..8], &[1, 0, 0, 0, 2, 0, 0, 0]);
    assert_eq!(&b[8..16], &[4, 0, 0, 0, b'm', b'a', b'p', 0]);
    assert_eq!(&b[16..24], &1.5f64.to_le_bytes());
    assert_eq!(&b[64..72], &1.0f64.to_le_bytes()); // w
}

#[test]
fn covariance_is_a_fixed_array_without_length() {
    let mut m = PoseWithCovarianceStamped::default();
    m.header.frame_id = "map".into();
    for (i, c) in m.pose.covariance.iter_mut().enumerate() {
        *c = i as f64;
    }
    let b = roundtrip(&m);
    // header 16, pose 56, 36 × 8 = 288, no length prefix.
    assert_eq!(b.len(), 16 + 56 + 288);
    assert_eq!(&b[72..80], &0f64.to_le_bytes());
    assert_eq!(&b[b.len() - 8..], &35f64.to_le_bytes());
}

#[test]
fn every_message_roundtrips() {
    let h = Header::new(Time { sec: 7, nanosec: 9 }, "base_link");
    roundtrip(&OccupancyGrid {
        header: h.clone(),
        info: MapMetaData { map_load_time: Time { sec: 3, nanosec: 0 }, resolution: 0.05, width: 2, height: 2, origin: Pose::default() },
        data: vec![0, 100, -1, 50],
    });
    roundtrip(&PointCloud2 {
        header: h.clone(),
        height: 1,
        width: 1,
        fields: vec![PointField { name: "x".into(), offset: 0, datatype: PointField::FLOAT32, count: 1 }],
        is_bigendian: false,
        point_step: 4,
        row_step: 4,
        data: vec![1, 2, 3, 4],
        is_dense: true,
    });
    roundtrip(&TFMessage {
        transforms: vec![TransformStamped { header: h.clone(), child_frame_id: "x".into(), transform: Transform::default() }],
    });
    roundtrip(&PolygonStamped { header: h.clone(), polygon: Polygon { points: vec![Point32 { x: 1.0, y: 2.0, z: 3.0 }] } });
    roundtrip(&StringMsg { data: "{\"phase\":\"done\"}".into() });
    roundtrip(&MarkerArray {
        markers: vec![Marker {
            header: h.clone(),
            ns: "a".into(),
            points: vec![Point::default()],
            colors: vec![ColorRGBA::new(1.0, 0.0, 0.0, 1.0)],
            ..Marker::default()
        }],
    });
    roundtrip(&NavigateToPoseGoal { pose: PoseStamped { header: h.clone(), pose: Pose::default() }, behavior_tree: String::new() });
    roundtrip(&NavigateToPoseResult { error_code: 9003, error_msg: "timeout".into() });
    roundtrip(&NavigateToPoseFeedback { distance_remaining: 2.5, number_of_recoveries: 1, ..Default::default() });
}

#[cfg(feature = "ros2")]
#[test]
fn dds_type_names_follow_ros2() {
    assert_eq!(PoseStamped::type_name().dds_msg_type(), "geometry_msgs::msg::dds_::PoseStamped_");
    assert_eq!(OccupancyGrid::type_name().dds_msg_type(), "nav_msgs::msg::dds_::OccupancyGrid_");
    assert_eq!(TFMessage::type_name().dds_msg_type(), "tf2_msgs::msg::dds_::TFMessage_");
    assert_eq!(StringMsg::type_name().dds_msg_type(), "std_msgs::msg::dds_::String_");
    assert_eq!(MarkerArray::type_name().dds_msg_type(), "visualization_msgs::msg::dds_::MarkerArray_");
}

#[test]
fn time_conversions() {
    assert_eq!(Time::from_secs_f64(1.25), Time { sec: 1, nanosec: 250_000_000 });
    assert_eq!(Time::from_secs_f64(f64::NAN), Time::default());
    assert_eq!(Time::from_secs_f64(-3.0), Time::default());
    assert_eq!(Time { sec: 2, nanosec: 500_000_000 }.as_secs_f64(), 2.5);
    // Rounded to the nanosecond as a whole: just below 3 s is 3 s, not 2 s + 999 999 999 ns.
    assert_eq!(Time::from_secs_f64(2.9999999999999996), Time { sec: 3, nanosec: 0 });
    assert_eq!(Time::from_secs_f64(1e12), Time { sec: i32::MAX, nanosec: 999_999_999 });
}

#[test]
fn navigate_to_pose_results_of_older_distros_decode_with_defaults() {
    // Jazzy: (error_code, error_msg); Iron: error_code only; Humble: std_msgs/Empty (one octet).
    let jazzy = NavigateToPoseResult { error_code: 9003, error_msg: "timeout".into() };
    assert_eq!(cdr::from_bytes::<NavigateToPoseResult>(&cdr::to_vec(&jazzy).unwrap()).unwrap(), jazzy);
    let iron = cdr::to_vec(&9001u16).unwrap();
    assert_eq!(cdr::from_bytes::<NavigateToPoseResult>(&iron).unwrap(), NavigateToPoseResult { error_code: 9001, ..Default::default() });
    let humble = [0, 1, 0, 0, 0];
    assert_eq!(cdr::from_bytes::<NavigateToPoseResult>(&humble).unwrap(), NavigateToPoseResult::default());
}

/// The same through ros2-client's action result (status first), as the node receives it.
#[cfg(feature = "ros2")]
#[test]
fn navigate_to_pose_results_of_older_distros_decode_with_defaults_in_ros2_client() {
    use byteorder::LittleEndian;
    use ros2_client::action::{GetResultResponse, GoalStatusEnum};
    use ros2_client::dds::rustdds::cdr_encoding::{from_bytes, to_vec};
    // Jazzy: status (int8), then (error_code, error_msg).
    let jazzy = GetResultResponse {
        status: GoalStatusEnum::Aborted,
        result: NavigateToPoseResult { error_code: 9003, error_msg: "timeout".into() },
    };
    let b = to_vec::<_, LittleEndian>(&jazzy).unwrap();
    let (back, _) = from_bytes::<GetResultResponse<NavigateToPoseResult>, LittleEndian>(&b).unwrap();
    assert_eq!((back.status, back.result), (GoalStatusEnum::Aborted, jazzy.result));
    // Iron: status, error_code only.
    let iron = to_vec::<_, LittleEndian>(&(4i8, 9001u16)).unwrap();
    let (back, _) = from_bytes::<GetResultResponse<NavigateToPoseResult>, LittleEndian>(&iron).unwrap();
    assert_eq!((back.status, back.result.error_code, back.result.error_msg.as_str()), (GoalStatusEnum::Succeeded, 9001, ""));
    // Humble: status, std_msgs/Empty (one octet), with and without the payload's padding.
    for humble in [vec![4u8, 0], vec![4u8, 0, 0, 0]] {
        let (back, _) = from_bytes::<GetResultResponse<NavigateToPoseResult>, LittleEndian>(&humble).unwrap();
        assert_eq!((back.status, back.result), (GoalStatusEnum::Succeeded, NavigateToPoseResult::default()));
    }
}
