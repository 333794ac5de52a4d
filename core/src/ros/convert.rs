//! Messages ⇄ core types, with validation: anything a message can get wrong (NaN fields, a data
//! length that disagrees with width × height, a rotated map, a point field outside its record)
//! is a typed [`ConvertError`], never a panic. The robot node, the bag replay and the
//! simulator's recorder all convert here.
//!
//! PointCloud2 decoding reads x, y, z as FLOAT32 or FLOAT64 at any offsets, any `point_step`,
//! `row_step` and byte order; points with a non-finite coordinate are skipped and counted.
//! O(points) per cloud, O(cells) per map.

use crate::frontier::Boundary;
use crate::grid::{GridGeometry, UNKNOWN};
use crate::{OccupancyGrid, Pose2};
use fitslam_msgs::{self as msgs, Header, PointCloud2, PointField};
use nalgebra::{Isometry3, Point3, Quaternion, Translation3, UnitQuaternion};
use thiserror::Error;

/// Largest map accepted from a message, cells (2²⁵ ≈ 33 M; 4× the core's own grids,
/// 2²³: a large SLAM map is thresholded, not mapped into).
pub const MAX_MAP_CELLS: usize = 1 << 25;

/// Largest yaw of a map's origin that is still taken as axis-aligned, radians.
pub const MAX_MAP_YAW_RAD: f64 = 1e-3;

/// Why a message could not be converted.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum ConvertError {
    /// A field that must be a finite number is not (its name: `map origin`, `quaternion`, …).
    #[error("{0} is not finite")]
    NonFinite(&'static str),
    /// The map's cell size, metres, is not finite and positive.
    #[error("map resolution must be finite and > 0 (got {0})")]
    BadResolution(f32),
    /// The map's data does not hold one value per cell.
    #[error("map has {data_len} cells of data but width × height = {width} × {height}")]
    MapSizeMismatch {
        /// Columns the message declares.
        width: u32,
        /// Rows the message declares.
        height: u32,
        /// Values it carries.
        data_len: usize,
    },
    /// The map has more cells than [`MAX_MAP_CELLS`].
    #[error("map of {width} × {height} cells exceeds the limit of {limit}")]
    MapTooLarge {
        /// Columns the message declares.
        width: u32,
        /// Rows the message declares.
        height: u32,
        /// The limit, cells.
        limit: usize,
    },
    /// The map's origin is turned by more than [`MAX_MAP_YAW_RAD`] (or tilted): grids are
    /// axis-aligned in their frame.
    #[error("map origin is rotated by {yaw_rad} rad about z (or tilted); only axis-aligned maps are supported")]
    MapRotated {
        /// The origin's yaw, radians.
        yaw_rad: f64,
    },
    /// A quaternion of norm 0, which is no rotation.
    #[error("quaternion has zero norm")]
    ZeroQuaternion,
    /// A point cloud without an `x`, `y` or `z` field (the one named).
    #[error("point cloud has no '{0}' field")]
    CloudMissingField(&'static str),
    /// A coordinate field of another type than FLOAT32 or FLOAT64.
    #[error("point cloud field '{name}' has datatype {datatype}; x, y, z must be FLOAT32 (7) or FLOAT64 (8)")]
    CloudFieldType {
        /// `x`, `y` or `z`.
        name: &'static str,
        /// Its `PointField` datatype code.
        datatype: u8,
    },
    /// A coordinate field that runs past the end of a point's record.
    #[error("point cloud field '{name}' at offset {offset} (+{size} bytes) does not fit in point_step {point_step}")]
    CloudFieldOutsideRecord {
        /// `x`, `y` or `z`.
        name: &'static str,
        /// Its byte offset in the record.
        offset: u32,
        /// Its size, bytes.
        size: u32,
        /// The record's size, bytes.
        point_step: u32,
    },
    /// A row shorter than its points: `row_step` < `width` × `point_step`.
    #[error("point cloud row_step {row_step} < width {width} × point_step {point_step}")]
    CloudRowStep {
        /// Bytes per row.
        row_step: u32,
        /// Points per row.
        width: u32,
        /// Bytes per point.
        point_step: u32,
    },
    /// Fewer data bytes than `height` rows of `width` points need.
    #[error("point cloud data has {got} bytes, needs {needed}")]
    CloudDataTooShort {
        /// Bytes the rows need.
        needed: usize,
        /// Bytes the message carries.
        got: usize,
    },
    /// A boundary polygon with fewer than 3 finite vertices (how many it has).
    #[error("polygon has {0} finite vertices; a boundary needs at least 3")]
    PolygonTooFewVertices(usize),
}

/// Yaw of a quaternion (rotation about +z of its heading), radians in (−π, π]. Normalises
/// first; errors on a non-finite or zero quaternion.
pub fn yaw_of(q: &msgs::Quaternion) -> Result<f64, ConvertError> {
    Ok(unit_quaternion(q)?.euler_angles().2)
}

/// A unit quaternion from a message (normalised).
pub fn unit_quaternion(q: &msgs::Quaternion) -> Result<UnitQuaternion<f64>, ConvertError> {
    if ![q.x, q.y, q.z, q.w].iter().all(|v| v.is_finite()) {
        return Err(ConvertError::NonFinite("quaternion"));
    }
    let raw = Quaternion::new(q.w, q.x, q.y, q.z);
    let norm = raw.norm();
    if norm.is_nan() || norm <= 1e-9 {
        return Err(ConvertError::ZeroQuaternion);
    }
    Ok(UnitQuaternion::from_quaternion(raw))
}

/// `Pose` → rigid transform (`frame_from_body`).
pub fn isometry_of_pose(p: &msgs::Pose) -> Result<Isometry3<f64>, ConvertError> {
    let t = p.position;
    if ![t.x, t.y, t.z].iter().all(|v| v.is_finite()) {
        return Err(ConvertError::NonFinite("pose position"));
    }
    Ok(Isometry3::from_parts(Translation3::new(t.x, t.y, t.z), unit_quaternion(&p.orientation)?))
}

/// `Transform` → rigid transform (`parent_from_child`).
pub fn isometry_of_transform(t: &msgs::Transform) -> Result<Isometry3<f64>, ConvertError> {
    let v = t.translation;
    if ![v.x, v.y, v.z].iter().all(|a| a.is_finite()) {
        return Err(ConvertError::NonFinite("transform translation"));
    }
    Ok(Isometry3::from_parts(Translation3::new(v.x, v.y, v.z), unit_quaternion(&t.rotation)?))
}

/// The planar pose (x, y, yaw) of a 3D transform.
pub fn pose2_of_isometry(iso: &Isometry3<f64>) -> Pose2 {
    let t = iso.translation.vector;
    Pose2::new(t.x, t.y, iso.rotation.euler_angles().2)
}

/// `Pose` → planar pose.
pub fn pose2_of_pose(p: &msgs::Pose) -> Result<Pose2, ConvertError> {
    Ok(pose2_of_isometry(&isometry_of_pose(p)?))
}

/// Planar pose → `Pose` (z = 0, rotation about +z).
pub fn pose_of_pose2(p: Pose2) -> msgs::Pose {
    msgs::Pose { position: msgs::Point { x: p.x_m, y: p.y_m, z: 0.0 }, orientation: msgs::Quaternion::from_yaw(p.yaw_rad) }
}

/// Planar pose → `Transform` (`parent_from_child`; z = 0, rotation about +z).
pub fn transform_of_pose2(p: Pose2) -> msgs::Transform {
    msgs::Transform { translation: msgs::Vector3 { x: p.x_m, y: p.y_m, z: 0.0 }, rotation: msgs::Quaternion::from_yaw(p.yaw_rad) }
}

/// The f64 a float32 resolution stands for: its shortest decimal form (0.05f32 is
/// 0.0500000007 as f64, but map_server wrote 0.05), so that cell boundaries fall where the map's
/// author put them.
pub fn resolution_m(resolution: f32) -> f64 {
    resolution.to_string().parse().unwrap_or(resolution as f64)
}

/// `nav_msgs/OccupancyGrid` → core grid. Values 0–100 and −1 are kept; anything else (101–127,
/// −128…−2: not ROS values) becomes unknown. The origin's z is ignored; a rotated origin is an
/// error.
pub fn occupancy_of_msg(msg: &msgs::OccupancyGrid) -> Result<OccupancyGrid, ConvertError> {
    let info = &msg.info;
    if !(info.resolution.is_finite() && info.resolution > 0.0) {
        return Err(ConvertError::BadResolution(info.resolution));
    }
    let cells = (info.width as usize).checked_mul(info.height as usize).filter(|&n| n <= MAX_MAP_CELLS);
    let Some(cells) = cells else {
        return Err(ConvertError::MapTooLarge { width: info.width, height: info.height, limit: MAX_MAP_CELLS });
    };
    if msg.data.len() != cells {
        return Err(ConvertError::MapSizeMismatch { width: info.width, height: info.height, data_len: msg.data.len() });
    }
    let origin = isometry_of_pose(&info.origin)?;
    let (roll, pitch, yaw) = origin.rotation.euler_angles();
    if yaw.abs() > MAX_MAP_YAW_RAD || roll.abs() > MAX_MAP_YAW_RAD || pitch.abs() > MAX_MAP_YAW_RAD {
        return Err(ConvertError::MapRotated { yaw_rad: yaw });
    }
    let geometry = GridGeometry::new(
        info.origin.position.x,
        info.origin.position.y,
        resolution_m(info.resolution),
        info.width as usize,
        info.height as usize,
    );
    let data = msg.data.iter().map(|&v| if (-1..=100).contains(&v) { v } else { UNKNOWN }).collect();
    OccupancyGrid::from_vec(geometry, data).ok_or(ConvertError::MapSizeMismatch {
        width: info.width,
        height: info.height,
        data_len: msg.data.len(),
    })
}

/// Core grid → `nav_msgs/OccupancyGrid`. Dimensions above u32 saturate (cannot happen for grids
/// from [`occupancy_of_msg`] or the core's builders).
pub fn msg_of_occupancy(grid: &OccupancyGrid, header: Header) -> msgs::OccupancyGrid {
    let g = grid.geometry;
    msgs::OccupancyGrid {
        header: header.clone(),
        info: msgs::MapMetaData {
            map_load_time: header.stamp,
            resolution: g.resolution_m as f32,
            width: u32::try_from(g.width).unwrap_or(u32::MAX),
            height: u32::try_from(g.height).unwrap_or(u32::MAX),
            origin: msgs::Pose {
                position: msgs::Point { x: g.origin_x_m, y: g.origin_y_m, z: 0.0 },
                orientation: msgs::Quaternion::default(),
            },
        },
        data: grid.data.clone(),
    }
}

/// What [`points_of_cloud`] read.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CloudStats {
    /// Point records in the message (width × height).
    pub records: usize,
    /// Records skipped for a non-finite coordinate.
    pub non_finite: usize,
}

#[derive(Clone, Copy)]
struct FieldReader {
    offset: usize,
    f64: bool,
}

fn field_reader(cloud: &PointCloud2, name: &'static str) -> Result<FieldReader, ConvertError> {
    let f: &PointField = cloud.fields.iter().find(|f| f.name == name).ok_or(ConvertError::CloudMissingField(name))?;
    let size = match f.datatype {
        PointField::FLOAT32 => 4,
        PointField::FLOAT64 => 8,
        datatype => return Err(ConvertError::CloudFieldType { name, datatype }),
    };
    if f.offset.checked_add(size).is_none_or(|end| end > cloud.point_step) {
        return Err(ConvertError::CloudFieldOutsideRecord { name, offset: f.offset, size, point_step: cloud.point_step });
    }
    Ok(FieldReader { offset: f.offset as usize, f64: size == 8 })
}

/// `sensor_msgs/PointCloud2` → points (x, y, z), in the cloud's own frame. Records with a
/// non-finite coordinate are skipped (counted in [`CloudStats::non_finite`]).
pub fn points_of_cloud(cloud: &PointCloud2) -> Result<(Vec<Point3<f64>>, CloudStats), ConvertError> {
    let readers = [field_reader(cloud, "x")?, field_reader(cloud, "y")?, field_reader(cloud, "z")?];
    let (width, height) = (cloud.width as usize, cloud.height as usize);
    let (point_step, row_step) = (cloud.point_step as usize, cloud.row_step as usize);
    let records = width.saturating_mul(height);
    if records == 0 {
        return Ok((Vec::new(), CloudStats::default()));
    }
    if width.checked_mul(point_step).is_none_or(|w| w > row_step) {
        return Err(ConvertError::CloudRowStep { row_step: cloud.row_step, width: cloud.width, point_step: cloud.point_step });
    }
    // Last row needs only width × point_step bytes (some publishers pad only between rows).
    let needed = (height - 1).checked_mul(row_step).and_then(|n| n.checked_add(width * point_step)).unwrap_or(usize::MAX);
    if cloud.data.len() < needed {
        return Err(ConvertError::CloudDataTooShort { needed, got: cloud.data.len() });
    }
    let big = cloud.is_bigendian;
    let read = |base: usize, r: FieldReader| -> f64 {
        let at = base + r.offset;
        if r.f64 {
            let mut b = [0u8; 8];
            b.copy_from_slice(&cloud.data[at..at + 8]);
            if big { f64::from_be_bytes(b) } else { f64::from_le_bytes(b) }
        } else {
            let mut b = [0u8; 4];
            b.copy_from_slice(&cloud.data[at..at + 4]);
            (if big { f32::from_be_bytes(b) } else { f32::from_le_bytes(b) }) as f64
        }
    };
    let mut points = Vec::with_capacity(records);
    let mut stats = CloudStats { records, non_finite: 0 };
    for row in 0..height {
        for col in 0..width {
            let base = row * row_step + col * point_step;
            let p = Point3::new(read(base, readers[0]), read(base, readers[1]), read(base, readers[2]));
            if p.coords.iter().all(|v| v.is_finite()) {
                points.push(p);
            } else {
                stats.non_finite += 1;
            }
        }
    }
    Ok((points, stats))
}

/// Points → an unorganised little-endian FLOAT32 x, y, z `PointCloud2` (point_step 12).
pub fn cloud_of_points(points: &[Point3<f64>], header: Header) -> PointCloud2 {
    let mut data = Vec::with_capacity(points.len() * 12);
    for p in points {
        for v in [p.x, p.y, p.z] {
            data.extend_from_slice(&(v as f32).to_le_bytes());
        }
    }
    let field = |name: &str, offset| PointField { name: name.into(), offset, datatype: PointField::FLOAT32, count: 1 };
    let n = u32::try_from(points.len()).unwrap_or(u32::MAX);
    PointCloud2 {
        header,
        height: 1,
        width: n,
        fields: vec![field("x", 0), field("y", 4), field("z", 8)],
        is_bigendian: false,
        point_step: 12,
        row_step: n.saturating_mul(12),
        data,
        is_dense: true,
    }
}

/// `geometry_msgs/PolygonStamped` → boundary (x, y of its vertices). Non-finite vertices are
/// dropped; fewer than 3 left is an error. A repeated closing vertex is removed.
pub fn boundary_of_polygon(msg: &msgs::PolygonStamped) -> Result<Boundary, ConvertError> {
    let mut v: Vec<[f64; 2]> =
        msg.polygon.points.iter().filter(|p| p.x.is_finite() && p.y.is_finite()).map(|p| [p.x as f64, p.y as f64]).collect();
    if v.len() > 1 && v.first() == v.last() {
        v.pop();
    }
    if v.len() < 3 {
        return Err(ConvertError::PolygonTooFewVertices(v.len()));
    }
    Ok(Boundary::new(v))
}

#[cfg(test)]
mod tests {
    use super::*;
    use fitslam_msgs::{MapMetaData, Time};
    use proptest::prelude::*;

    fn map_msg(width: u32, height: u32, data: Vec<i8>) -> msgs::OccupancyGrid {
        msgs::OccupancyGrid {
            header: Header::new(Time::default(), "map"),
            info: MapMetaData {
                map_load_time: Time::default(),
                resolution: 0.5,
                width,
                height,
                origin: msgs::Pose { position: msgs::Point { x: -1.0, y: 2.0, z: 0.3 }, orientation: msgs::Quaternion::default() },
            },
            data,
        }
    }

    #[test]
    fn map_keeps_ros_values_and_geometry() {
        let g = occupancy_of_msg(&map_msg(3, 2, vec![0, 100, -1, 50, 101, -7])).unwrap();
        assert_eq!(g.geometry, GridGeometry::new(-1.0, 2.0, 0.5, 3, 2));
        assert_eq!(g.data, vec![0, 100, -1, 50, -1, -1]);
        // Row 1, col 0 (value 50) sits at x ∈ [-1, -0.5), y ∈ [2.5, 3).
        assert_eq!(g.at_world(-0.75, 2.75), Some(&50));
        let back = msg_of_occupancy(&g, Header::new(Time::default(), "map"));
        assert_eq!(occupancy_of_msg(&back).unwrap(), g);
    }

    #[test]
    fn float32_resolutions_keep_their_decimal_value() {
        assert_eq!(resolution_m(0.05), 0.05);
        assert_eq!(resolution_m(0.1), 0.1);
        assert_eq!(resolution_m(0.5), 0.5);
    }

    #[test]
    fn map_errors_are_typed() {
        assert_eq!(occupancy_of_msg(&map_msg(3, 2, vec![0; 5])), Err(ConvertError::MapSizeMismatch { width: 3, height: 2, data_len: 5 }));
        let mut m = map_msg(1, 1, vec![0]);
        m.info.resolution = f32::NAN;
        assert!(matches!(occupancy_of_msg(&m), Err(ConvertError::BadResolution(_))));
        let mut m = map_msg(1, 1, vec![0]);
        m.info.origin.position.x = f64::NAN;
        assert_eq!(occupancy_of_msg(&m), Err(ConvertError::NonFinite("pose position")));
        let mut m = map_msg(1, 1, vec![0]);
        m.info.origin.orientation = msgs::Quaternion::from_yaw(0.5);
        assert!(matches!(occupancy_of_msg(&m), Err(ConvertError::MapRotated { .. })));
        let m = map_msg(u32::MAX, u32::MAX, vec![]);
        assert!(matches!(occupancy_of_msg(&m), Err(ConvertError::MapTooLarge { .. })));
        let mut m = map_msg(1, 1, vec![0]);
        m.info.origin.orientation = msgs::Quaternion { x: 0.0, y: 0.0, z: 0.0, w: 0.0 };
        assert_eq!(occupancy_of_msg(&m), Err(ConvertError::ZeroQuaternion));
    }

    #[test]
    fn yaw_roundtrips_and_unnormalised_quaternions_are_normalised() {
        for yaw in [-3.0, -1.0, 0.0, 0.7, 3.1] {
            let p = pose_of_pose2(Pose2::new(1.0, -2.0, yaw));
            let back = pose2_of_pose(&p).unwrap();
            assert!((back.yaw_rad - yaw).abs() < 1e-12 && back.x_m == 1.0 && back.y_m == -2.0);
        }
        // (0, 0, 2, 2) normalises to a 90° yaw.
        let q = msgs::Quaternion { x: 0.0, y: 0.0, z: 2.0, w: 2.0 };
        assert!((yaw_of(&q).unwrap() - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        let q = msgs::Quaternion { x: f64::NAN, y: 0.0, z: 0.0, w: 1.0 };
        assert_eq!(yaw_of(&q), Err(ConvertError::NonFinite("quaternion")));
    }

    /// A cloud with a padding field first, then z, x, y in the given type and byte order.
    fn odd_cloud(points: &[[f64; 3]], f64s: bool, big: bool, pad_row: usize) -> PointCloud2 {
        let size = if f64s { 8 } else { 4 };
        let point_step = 3 + 3 * size + 5; // 3 bytes of padding in front, 5 behind
        let width = points.len();
        let row_step = width * point_step + pad_row;
        let mut data = vec![0xAAu8; row_step];
        for (i, p) in points.iter().enumerate() {
            let base = i * point_step;
            for (k, v) in [p[2], p[0], p[1]].iter().enumerate() {
                let at = base + 3 + k * size;
                let bytes: Vec<u8> = match (f64s, big) {
                    (true, true) => v.to_be_bytes().to_vec(),
                    (true, false) => v.to_le_bytes().to_vec(),
                    (false, true) => (*v as f32).to_be_bytes().to_vec(),
                    (false, false) => (*v as f32).to_le_bytes().to_vec(),
                };
                data[at..at + size].copy_from_slice(&bytes);
            }
        }
        let dt = if f64s { PointField::FLOAT64 } else { PointField::FLOAT32 };
        let f = |n: &str, k: u32| PointField { name: n.into(), offset: 3 + k * size as u32, datatype: dt, count: 1 };
        PointCloud2 {
            header: Header::default(),
            height: 1,
            width: width as u32,
            fields: vec![
                PointField { name: "pad".into(), offset: 0, datatype: PointField::UINT8, count: 3 },
                f("z", 0),
                f("x", 1),
                f("y", 2),
            ],
            is_bigendian: big,
            point_step: point_step as u32,
            row_step: row_step as u32,
            data,
            is_dense: false,
        }
    }

    #[test]
    fn clouds_decode_any_layout_and_skip_nan() {
        let pts = [[1.5, -2.25, 0.125], [f64::NAN, 0.0, 0.0], [3.0, 4.0, -5.0]];
        for f64s in [false, true] {
            for big in [false, true] {
                let (p, s) = points_of_cloud(&odd_cloud(&pts, f64s, big, 7)).unwrap();
                assert_eq!(s, CloudStats { records: 3, non_finite: 1 });
                // All values are exact in f32.
                assert_eq!(p, vec![Point3::new(1.5, -2.25, 0.125), Point3::new(3.0, 4.0, -5.0)]);
            }
        }
    }

    #[test]
    fn organised_clouds_use_row_step() {
        let mut c = cloud_of_points(&[Point3::new(1.0, 2.0, 3.0), Point3::new(4.0, 5.0, 6.0)], Header::default());
        // Re-shape as 2 rows of 1 point with 4 bytes of row padding.
        let mut data = c.data[..12].to_vec();
        data.extend_from_slice(&[0; 4]);
        data.extend_from_slice(&c.data[12..]);
        (c.width, c.height, c.row_step, c.data) = (1, 2, 16, data);
        let (p, _) = points_of_cloud(&c).unwrap();
        assert_eq!(p, vec![Point3::new(1.0, 2.0, 3.0), Point3::new(4.0, 5.0, 6.0)]);
    }

    #[test]
    fn cloud_errors_are_typed() {
        let good = cloud_of_points(&[Point3::new(1.0, 2.0, 3.0)], Header::default());
        let mut c = good.clone();
        c.fields.retain(|f| f.name != "y");
        assert_eq!(points_of_cloud(&c), Err(ConvertError::CloudMissingField("y")));
        let mut c = good.clone();
        c.fields[2].datatype = PointField::UINT16;
        assert_eq!(points_of_cloud(&c), Err(ConvertError::CloudFieldType { name: "z", datatype: PointField::UINT16 }));
        let mut c = good.clone();
        c.fields[0].offset = 10;
        assert!(matches!(points_of_cloud(&c), Err(ConvertError::CloudFieldOutsideRecord { name: "x", .. })));
        let mut c = good.clone();
        c.fields[0].offset = u32::MAX;
        assert!(matches!(points_of_cloud(&c), Err(ConvertError::CloudFieldOutsideRecord { .. })));
        let mut c = good.clone();
        c.data.pop();
        assert_eq!(points_of_cloud(&c), Err(ConvertError::CloudDataTooShort { needed: 12, got: 11 }));
        let mut c = good.clone();
        c.row_step = 11;
        assert!(matches!(points_of_cloud(&c), Err(ConvertError::CloudRowStep { .. })));
        let mut c = good;
        (c.width, c.height) = (u32::MAX, u32::MAX);
        assert!(points_of_cloud(&c).is_err());
    }

    #[test]
    fn polygons_need_three_finite_vertices() {
        let poly = |pts: &[[f32; 2]]| msgs::PolygonStamped {
            header: Header::default(),
            polygon: msgs::Polygon { points: pts.iter().map(|p| msgs::Point32 { x: p[0], y: p[1], z: 0.0 }).collect() },
        };
        let b = boundary_of_polygon(&poly(&[[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0], [0.0, 0.0]])).unwrap();
        assert_eq!(b.vertices_m.len(), 4);
        assert_eq!(b.area_m2(), 4.0);
        assert_eq!(boundary_of_polygon(&poly(&[[0.0, 0.0], [f32::NAN, 0.0], [2.0, 2.0]])), Err(ConvertError::PolygonTooFewVertices(2)));
    }

    proptest! {
        /// Decoding never panics on arbitrary layouts and bytes.
        #[test]
        fn cloud_decoding_never_panics(
            data in proptest::collection::vec(any::<u8>(), 0..200),
            width in 0u32..20, height in 0u32..4, point_step in 0u32..40, row_step in 0u32..400,
            ox in 0u32..48, oy in 0u32..48, oz in 0u32..48, dt in 0u8..10, big in any::<bool>(),
        ) {
            let f = |n: &str, o| PointField { name: n.into(), offset: o, datatype: dt, count: 1 };
            let c = PointCloud2 {
                header: Header::default(), height, width,
                fields: vec![f("x", ox), f("y", oy), f("z", oz)],
                is_bigendian: big, point_step, row_step, data, is_dense: false,
            };
            let _ = points_of_cloud(&c);
        }

        #[test]
        fn map_conversion_never_panics(width in 0u32..50, height in 0u32..50, len in 0usize..3000, res in -1.0f32..1.0) {
            let mut m = map_msg(width, height, vec![0; len]);
            m.info.resolution = res;
            if let Ok(g) = occupancy_of_msg(&m) {
                prop_assert_eq!(g.data.len(), (width * height) as usize);
            }
        }
    }
}
