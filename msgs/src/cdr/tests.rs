//! The codec against messages byte by byte as rclcpp serialises them, the alignment rules, big-
//! endian input, and hostile bytes (typed errors naming the field, never a panic).

use super::*;
use crate::{
    Header, MapMetaData, OccupancyGrid, Point, PointCloud2, PointField, Pose, PoseWithCovarianceStamped, Quaternion, StringMsg, TFMessage,
    Time, Transform, TransformStamped, Vector3,
};
use proptest::prelude::*;

/// A `nav_msgs/OccupancyGrid` of 2 × 1 cells, byte by byte as rclcpp serialises it.
fn hand_built_map() -> Vec<u8> {
    let mut b = vec![0, 1, 0, 0];
    b.extend_from_slice(&5i32.to_le_bytes()); // stamp.sec
    b.extend_from_slice(&500_000_000u32.to_le_bytes()); // stamp.nanosec
    b.extend_from_slice(&4u32.to_le_bytes()); // frame_id length with NUL
    b.extend_from_slice(b"map\0");
    b.extend_from_slice(&[0; 8]); // map_load_time
    b.extend_from_slice(&0.05f32.to_le_bytes());
    b.extend_from_slice(&2u32.to_le_bytes());
    b.extend_from_slice(&1u32.to_le_bytes());
    b.extend_from_slice(&[0; 4]); // pad to 8 (offset 36 → 40)
    for v in [-1.0f64, 2.0, 0.0, 0.0, 0.0, 0.0, 1.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    b.extend_from_slice(&2u32.to_le_bytes());
    b.extend_from_slice(&[0, 100]);
    b
}

fn hand_built_map_msg() -> OccupancyGrid {
    OccupancyGrid {
        header: Header::new(Time { sec: 5, nanosec: 500_000_000 }, "map"),
        info: MapMetaData {
            map_load_time: Time::default(),
            resolution: 0.05,
            width: 2,
            height: 1,
            origin: Pose { position: Point { x: -1.0, y: 2.0, z: 0.0 }, orientation: Quaternion::default() },
        },
        data: vec![0, 100],
    }
}

#[test]
fn a_hand_built_map_decodes_and_encodes_back() {
    assert_eq!(from_bytes::<OccupancyGrid>(&hand_built_map()).unwrap(), hand_built_map_msg());
    assert_eq!(to_vec(&hand_built_map_msg()).unwrap(), hand_built_map());
}

#[test]
fn a_hand_built_tf_message_decodes_and_encodes_back() {
    let mut b = vec![0, 1, 0, 0];
    b.extend_from_slice(&1u32.to_le_bytes());
    b.extend_from_slice(&[0; 8]); // stamp
    b.extend_from_slice(&5u32.to_le_bytes());
    b.extend_from_slice(b"odom\0");
    b.extend_from_slice(&[0; 3]); // pad to 4 (offset 21 → 24)
    b.extend_from_slice(&10u32.to_le_bytes());
    b.extend_from_slice(b"base_link\0");
    b.extend_from_slice(&[0; 2]); // pad to 8 (offset 38 → 40)
    for v in [1.0f64, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    let t = from_bytes::<TFMessage>(&b).unwrap();
    let expected = TransformStamped {
        header: Header::new(Time::default(), "odom"),
        child_frame_id: "base_link".into(),
        transform: Transform { translation: Vector3 { x: 1.0, y: 0.0, z: 0.0 }, rotation: Quaternion::default() },
    };
    assert_eq!(t.transforms, [expected]);
    assert_eq!(to_vec(&t).unwrap(), b);
}

#[test]
fn alignment_is_relative_to_the_end_of_the_header() {
    // u8 1, pad to 4, u32 2, pad to 8, f64 0.5, string "ab": a tuple is a struct's fields.
    let mut bytes = vec![0, 1, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0];
    bytes.extend_from_slice(&0.5f64.to_le_bytes());
    bytes.extend_from_slice(&[3, 0, 0, 0, b'a', b'b', 0]);
    assert_eq!(from_bytes::<(u8, u32, f64, String)>(&bytes).unwrap(), (1, 2, 0.5, "ab".into()));
    assert_eq!(to_vec(&(1u8, 2u32, 0.5f64, "ab")).unwrap(), bytes);
    // Empty strings: written with their NUL; a length of 0 reads too.
    assert_eq!(to_vec("").unwrap(), [0, 1, 0, 0, 1, 0, 0, 0, 0]);
    assert_eq!(from_bytes::<String>(&[0, 1, 0, 0, 0, 0, 0, 0]).unwrap(), "");
}

#[test]
fn big_endian_messages_read_too() {
    let bytes = [0, 0, 0, 0, 0, 0, 0, 7, 0x3f, 0x80, 0, 0, 0, 0, 0, 2, 0xfe, 0xff];
    assert_eq!(from_bytes::<(u32, f32, Vec<i8>)>(&bytes).unwrap(), (7, 1.0, vec![-2, -1]));
}

#[test]
fn bad_input_gives_typed_errors_naming_the_field() {
    assert_eq!(from_bytes::<u32>(&[0, 1]), Err(CdrError::NoHeader { len: 2 }));
    assert_eq!(from_bytes::<u32>(&[0, 7, 0, 0]), Err(CdrError::Encapsulation { kind: 7 }));
    assert!(matches!(from_bytes::<u32>(&[0, 1, 0, 0, 1, 0]), Err(CdrError::Truncated { at: 0, len: 2, .. })));
    let e = from_bytes::<Vec<u8>>(&[0, 1, 0, 0, 0xff, 0xff, 0xff, 0xff]).unwrap_err();
    assert!(matches!(e, CdrError::SequenceTooLong { count: u32::MAX, left: 0, .. }), "{e}");
    let e = from_bytes::<StringMsg>(&[0, 1, 0, 0, 2, 0, 0, 0, b'a', b'b']).unwrap_err();
    assert_eq!(e, CdrError::BadString { field: "data".into(), detail: "no terminating NUL" });
    let e = from_bytes::<StringMsg>(&[0, 1, 0, 0, 2, 0, 0, 0, 0xff, 0]).unwrap_err();
    assert_eq!(e.to_string(), "data: not UTF-8");
    let map = hand_built_map();
    let e = from_bytes::<OccupancyGrid>(&map[..34]).unwrap_err();
    assert_eq!(e.to_string(), "ends inside info.width (byte 28 of 30 after the header)");
    let e = from_bytes::<OccupancyGrid>(&map[..map.len() - 1]).unwrap_err();
    assert!(matches!(&e, CdrError::SequenceTooLong { field, count: 2, left: 1 } if field == "data"), "{e}");
    assert!(matches!(to_vec(&Some(1u8)), Err(CdrError::Unsupported("Option"))));
}

#[test]
fn every_prefix_of_a_message_is_an_error() {
    let map = hand_built_map();
    for n in 0..map.len() {
        assert!(from_bytes::<OccupancyGrid>(&map[..n]).is_err(), "{n} bytes");
    }
}

proptest! {
    /// Hostile bytes after a valid header: an error or a message, never a panic or a huge
    /// reservation.
    #[test]
    fn arbitrary_bytes_never_panic(body in proptest::collection::vec(any::<u8>(), 0..600), big in any::<bool>()) {
        let mut bytes = vec![0, u8::from(!big), 0, 0];
        bytes.extend_from_slice(&body);
        let _ = from_bytes::<OccupancyGrid>(&bytes);
        let _ = from_bytes::<TFMessage>(&bytes);
        let _ = from_bytes::<PointCloud2>(&bytes);
        let _ = from_bytes::<PoseWithCovarianceStamped>(&bytes);
        let _ = from_bytes::<StringMsg>(&bytes);
        let _ = from_bytes::<crate::MarkerArray>(&bytes);
    }

    /// Clouds with any fields and data round-trip.
    #[test]
    fn clouds_round_trip(data in proptest::collection::vec(any::<u8>(), 0..100), name in "[a-z]{0,5}", offset in any::<u32>()) {
        let c = PointCloud2 {
            fields: vec![PointField { name, offset, datatype: PointField::FLOAT32, count: 1 }],
            data,
            ..PointCloud2::default()
        };
        prop_assert_eq!(from_bytes::<PointCloud2>(&to_vec(&c).unwrap()).unwrap(), c);
    }
}
