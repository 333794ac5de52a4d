//! The ROS 2 messages a replay reads, decoded from CDR ([`super::cdr`]) into plain structs, and
//! encoded back for [`super::record`]: `nav_msgs/OccupancyGrid`, `tf2_msgs/TFMessage`,
//! `sensor_msgs/PointCloud2`, `geometry_msgs/PoseWithCovarianceStamped`, `std_msgs/String`.
//! Field order and types are those of ROS 2 Jazzy's definitions ([`super::schemas`]).
//!
//! Conversions to the core's types (a grid, points, a rigid transform) validate what a message
//! can get wrong: a data length that disagrees with width × height, NaN, a zero quaternion.

use super::cdr::{CdrError, CdrReader, CdrWriter};
use crate::OccupancyGrid;
use crate::grid::{GridGeometry, UNKNOWN};
use nalgebra::{Isometry3, Point3, Quaternion as NaQuaternion, Translation3, UnitQuaternion};

/// Largest map accepted, cells (2²⁵, as the robot node).
pub const MAX_MAP_CELLS: usize = 1 << 25;

/// `std_msgs/Header`: stamp (seconds) and frame.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Header {
    pub stamp_s: f64,
    pub frame_id: String,
}

/// `geometry_msgs/Pose` or `Transform`: translation (x, y, z) and quaternion (x, y, z, w).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RigidPose {
    pub translation: [f64; 3],
    pub rotation_xyzw: [f64; 4],
}

impl Default for RigidPose {
    fn default() -> Self {
        Self { translation: [0.0; 3], rotation_xyzw: [0.0, 0.0, 0.0, 1.0] }
    }
}

impl RigidPose {
    /// A planar pose (z = 0, rotation about +z).
    pub fn planar(x_m: f64, y_m: f64, yaw_rad: f64) -> Self {
        let h = 0.5 * yaw_rad;
        Self { translation: [x_m, y_m, 0.0], rotation_xyzw: [0.0, 0.0, crate::math::sin(h), crate::math::cos(h)] }
    }

    /// `parent_from_child` as an isometry; `None` for a non-finite value or a zero quaternion.
    pub fn isometry(&self) -> Option<Isometry3<f64>> {
        let [x, y, z] = self.translation;
        let [qx, qy, qz, qw] = self.rotation_xyzw;
        if ![x, y, z, qx, qy, qz, qw].iter().all(|v| v.is_finite()) {
            return None;
        }
        let q = NaQuaternion::new(qw, qx, qy, qz);
        if q.norm() <= 1e-9 {
            return None;
        }
        Some(Isometry3::from_parts(Translation3::new(x, y, z), UnitQuaternion::from_quaternion(q)))
    }
}

/// `nav_msgs/OccupancyGrid`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OccupancyGridMsg {
    pub header: Header,
    pub resolution: f32,
    pub width: u32,
    pub height: u32,
    pub origin: RigidPose,
    /// Row-major from cell (0, 0): 0–100, −1 unknown.
    pub data: Vec<i8>,
}

/// `geometry_msgs/TransformStamped`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TransformStamped {
    pub header: Header,
    pub child_frame_id: String,
    pub transform: RigidPose,
}

/// `sensor_msgs/PointField`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointField {
    pub name: String,
    pub offset: u32,
    pub datatype: u8,
    pub count: u32,
}

/// PointField datatype FLOAT32.
pub const FLOAT32: u8 = 7;
/// PointField datatype FLOAT64.
pub const FLOAT64: u8 = 8;

/// `sensor_msgs/PointCloud2`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointCloud2 {
    pub header: Header,
    pub height: u32,
    pub width: u32,
    pub fields: Vec<PointField>,
    pub is_bigendian: bool,
    pub point_step: u32,
    pub row_step: u32,
    pub data: Vec<u8>,
    pub is_dense: bool,
}

/// `geometry_msgs/PoseWithCovarianceStamped`.
#[derive(Clone, Debug, PartialEq)]
pub struct PoseWithCovarianceStamped {
    pub header: Header,
    pub pose: RigidPose,
    /// Row-major 6×6 over (x, y, z, roll, pitch, yaw).
    pub covariance: [f64; 36],
}

fn header(r: &mut CdrReader) -> Result<Header, CdrError> {
    let sec = r.i32("header.stamp.sec")?;
    let nanosec = r.u32("header.stamp.nanosec")?;
    Ok(Header { stamp_s: sec as f64 + nanosec as f64 * 1e-9, frame_id: r.string("header.frame_id")? })
}

fn rigid(r: &mut CdrReader, what: &'static str) -> Result<RigidPose, CdrError> {
    let mut v = [0.0; 7];
    for slot in &mut v {
        *slot = r.f64(what)?;
    }
    Ok(RigidPose { translation: [v[0], v[1], v[2]], rotation_xyzw: [v[3], v[4], v[5], v[6]] })
}

/// Decodes a `nav_msgs/OccupancyGrid`.
pub fn decode_occupancy_grid(bytes: &[u8]) -> Result<OccupancyGridMsg, CdrError> {
    let mut r = CdrReader::new(bytes)?;
    let header = header(&mut r)?;
    let _load_sec = r.i32("info.map_load_time")?;
    let _load_nsec = r.u32("info.map_load_time")?;
    let resolution = r.f32("info.resolution")?;
    let width = r.u32("info.width")?;
    let height = r.u32("info.height")?;
    let origin = rigid(&mut r, "info.origin")?;
    let data = r.bytes("data")?.iter().map(|&b| b as i8).collect();
    Ok(OccupancyGridMsg { header, resolution, width, height, origin, data })
}

/// Decodes a `tf2_msgs/TFMessage` into its transforms.
pub fn decode_tf_message(bytes: &[u8]) -> Result<Vec<TransformStamped>, CdrError> {
    let mut r = CdrReader::new(bytes)?;
    // A transform holds at least a header (12 bytes), a child frame (4) and 56 bytes of pose.
    let n = r.sequence_len(72, "transforms")?;
    let mut out = Vec::with_capacity(n);
    for _ in 0..n {
        let header = header(&mut r)?;
        let child_frame_id = r.string("child_frame_id")?;
        let transform = rigid(&mut r, "transform")?;
        out.push(TransformStamped { header, child_frame_id, transform });
    }
    Ok(out)
}

/// Decodes a `sensor_msgs/PointCloud2`.
pub fn decode_point_cloud2(bytes: &[u8]) -> Result<PointCloud2, CdrError> {
    let mut r = CdrReader::new(bytes)?;
    let header = header(&mut r)?;
    let height = r.u32("height")?;
    let width = r.u32("width")?;
    let n = r.sequence_len(13, "fields")?;
    let mut fields = Vec::with_capacity(n);
    for _ in 0..n {
        let name = r.string("fields.name")?;
        let offset = r.u32("fields.offset")?;
        let datatype = r.u8("fields.datatype")?;
        let count = r.u32("fields.count")?;
        fields.push(PointField { name, offset, datatype, count });
    }
    let is_bigendian = r.bool("is_bigendian")?;
    let point_step = r.u32("point_step")?;
    let row_step = r.u32("row_step")?;
    let data = r.bytes("data")?.to_vec();
    let is_dense = r.bool("is_dense")?;
    Ok(PointCloud2 { header, height, width, fields, is_bigendian, point_step, row_step, data, is_dense })
}

/// Decodes a `geometry_msgs/PoseWithCovarianceStamped`.
pub fn decode_pose_with_covariance(bytes: &[u8]) -> Result<PoseWithCovarianceStamped, CdrError> {
    let mut r = CdrReader::new(bytes)?;
    let header = header(&mut r)?;
    let pose = rigid(&mut r, "pose.pose")?;
    let mut covariance = [0.0; 36];
    for c in &mut covariance {
        *c = r.f64("pose.covariance")?;
    }
    Ok(PoseWithCovarianceStamped { header, pose, covariance })
}

/// Decodes a `std_msgs/String`.
pub fn decode_string(bytes: &[u8]) -> Result<String, CdrError> {
    CdrReader::new(bytes)?.string("data")
}

/// Seconds → `builtin_interfaces/Time` (sec, nanosec), rounded to the nanosecond.
fn split_stamp(stamp_s: f64) -> (i32, u32) {
    let ns = libm::round(stamp_s * 1e9) as i64;
    (ns.div_euclid(1_000_000_000) as i32, ns.rem_euclid(1_000_000_000) as u32)
}

fn write_header(w: &mut CdrWriter, h: &Header) {
    let (sec, nanosec) = split_stamp(h.stamp_s);
    w.i32(sec).u32(nanosec).string(&h.frame_id);
}

fn write_rigid(w: &mut CdrWriter, p: &RigidPose) {
    for v in p.translation.iter().chain(p.rotation_xyzw.iter()) {
        w.f64(*v);
    }
}

/// Encodes a `nav_msgs/OccupancyGrid` (with a zero `map_load_time`, which no reader here uses).
pub fn encode_occupancy_grid(m: &OccupancyGridMsg) -> Vec<u8> {
    let mut w = CdrWriter::new();
    write_header(&mut w, &m.header);
    w.i32(0).u32(0);
    w.f32(m.resolution).u32(m.width).u32(m.height);
    write_rigid(&mut w, &m.origin);
    w.len(m.data.len());
    for &v in &m.data {
        w.i8(v);
    }
    w.finish()
}

/// Encodes a `tf2_msgs/TFMessage`.
pub fn encode_tf_message(transforms: &[TransformStamped]) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.len(transforms.len());
    for t in transforms {
        write_header(&mut w, &t.header);
        w.string(&t.child_frame_id);
        write_rigid(&mut w, &t.transform);
    }
    w.finish()
}

/// Encodes a `sensor_msgs/PointCloud2`.
pub fn encode_point_cloud2(c: &PointCloud2) -> Vec<u8> {
    let mut w = CdrWriter::new();
    write_header(&mut w, &c.header);
    w.u32(c.height).u32(c.width).len(c.fields.len());
    for f in &c.fields {
        w.string(&f.name).u32(f.offset).u8(f.datatype).u32(f.count);
    }
    w.bool(c.is_bigendian).u32(c.point_step).u32(c.row_step).bytes(&c.data).bool(c.is_dense);
    w.finish()
}

/// Encodes a `geometry_msgs/PoseWithCovarianceStamped`.
pub fn encode_pose_with_covariance(p: &PoseWithCovarianceStamped) -> Vec<u8> {
    let mut w = CdrWriter::new();
    write_header(&mut w, &p.header);
    write_rigid(&mut w, &p.pose);
    for &c in &p.covariance {
        w.f64(c);
    }
    w.finish()
}

/// Encodes a `std_msgs/String`.
pub fn encode_string(s: &str) -> Vec<u8> {
    let mut w = CdrWriter::new();
    w.string(s);
    w.finish()
}

/// Why a decoded message does not convert to the core's types.
#[derive(Clone, Debug, thiserror::Error, PartialEq)]
pub enum ConvertError {
    #[error("map resolution {0} is not finite and > 0")]
    BadResolution(f32),
    #[error("map of {width} × {height} cells has {data_len} values")]
    MapSize { width: u32, height: u32, data_len: usize },
    #[error("map of {width} × {height} cells exceeds the limit of {MAX_MAP_CELLS}")]
    MapTooLarge { width: u32, height: u32 },
    #[error("map origin is not finite or has a zero quaternion")]
    BadOrigin,
    #[error("map origin is rotated ({yaw_rad} rad about z, or tilted): only axis-aligned maps are supported")]
    MapRotated { yaw_rad: f64 },
    #[error("point cloud: {0}")]
    Cloud(String),
}

/// The f64 a float32 resolution stands for: its shortest decimal form (0.05f32 → 0.05).
pub fn resolution_m(resolution: f32) -> f64 {
    resolution.to_string().parse().unwrap_or(resolution as f64)
}

impl OccupancyGridMsg {
    /// The core grid. Values outside 0–100 and −1 become unknown; the origin's z is ignored.
    pub fn to_grid(&self) -> Result<OccupancyGrid, ConvertError> {
        if !(self.resolution.is_finite() && self.resolution > 0.0) {
            return Err(ConvertError::BadResolution(self.resolution));
        }
        let (width, height) = (self.width, self.height);
        let cells = (width as usize).checked_mul(height as usize).filter(|&n| n <= MAX_MAP_CELLS);
        let Some(cells) = cells else { return Err(ConvertError::MapTooLarge { width, height }) };
        if self.data.len() != cells {
            return Err(ConvertError::MapSize { width, height, data_len: self.data.len() });
        }
        let origin = self.origin.isometry().ok_or(ConvertError::BadOrigin)?;
        let (roll, pitch, yaw) = origin.rotation.euler_angles();
        if [roll, pitch, yaw].iter().any(|a| a.abs() > 1e-3) {
            return Err(ConvertError::MapRotated { yaw_rad: yaw });
        }
        let [x, y, _] = self.origin.translation;
        let geometry = GridGeometry::new(x, y, resolution_m(self.resolution), width as usize, height as usize);
        let data = self.data.iter().map(|&v| if (-1..=100).contains(&v) { v } else { UNKNOWN }).collect();
        OccupancyGrid::from_vec(geometry, data).ok_or(ConvertError::MapSize { width, height, data_len: self.data.len() })
    }

    /// The message of a core grid, axis-aligned at the grid's origin.
    pub fn from_grid(grid: &OccupancyGrid, header: Header) -> Self {
        let g = grid.geometry;
        Self {
            header,
            resolution: g.resolution_m as f32,
            width: u32::try_from(g.width).unwrap_or(u32::MAX),
            height: u32::try_from(g.height).unwrap_or(u32::MAX),
            origin: RigidPose::planar(g.origin_x_m, g.origin_y_m, 0.0),
            data: grid.data.clone(),
        }
    }
}

impl PointCloud2 {
    /// x, y, z of every record (FLOAT32 or FLOAT64 at any offset, either byte order, any
    /// `row_step`), in the cloud's frame; records with a non-finite coordinate are left out.
    pub fn points(&self) -> Result<Vec<Point3<f64>>, ConvertError> {
        let mut readers = [(0usize, false); 3];
        for (slot, axis) in readers.iter_mut().zip(["x", "y", "z"]) {
            let f = self.fields.iter().find(|f| f.name == axis).ok_or_else(|| ConvertError::Cloud(format!("no '{axis}' field")))?;
            let size = match f.datatype {
                FLOAT32 => 4,
                FLOAT64 => 8,
                d => return Err(ConvertError::Cloud(format!("field '{axis}' has datatype {d}; expected FLOAT32 (7) or FLOAT64 (8)"))),
            };
            if f.offset.checked_add(size).is_none_or(|end| end > self.point_step) {
                return Err(ConvertError::Cloud(format!("field '{axis}' does not fit in point_step {}", self.point_step)));
            }
            *slot = (f.offset as usize, size == 8);
        }
        let (width, height) = (self.width as usize, self.height as usize);
        let (step, row) = (self.point_step as usize, self.row_step as usize);
        if width == 0 || height == 0 {
            return Ok(Vec::new());
        }
        if width.checked_mul(step).is_none_or(|w| w > row) {
            return Err(ConvertError::Cloud(format!("row_step {row} < width {width} × point_step {step}")));
        }
        let needed = (height - 1).checked_mul(row).and_then(|n| n.checked_add(width * step));
        if needed.is_none_or(|n| n > self.data.len()) {
            return Err(ConvertError::Cloud(format!(
                "data has {} bytes, fewer than {height} rows of {width} points need",
                self.data.len()
            )));
        }
        let read = |at: usize, f64: bool| -> f64 {
            let b = &self.data[at..at + if f64 { 8 } else { 4 }];
            match (f64, self.is_bigendian) {
                (true, false) => f64::from_le_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]),
                (true, true) => f64::from_be_bytes([b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7]]),
                (false, false) => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
                (false, true) => f32::from_be_bytes([b[0], b[1], b[2], b[3]]) as f64,
            }
        };
        let mut out = Vec::with_capacity(width * height);
        for r in 0..height {
            for c in 0..width {
                let base = r * row + c * step;
                let p = Point3::new(
                    read(base + readers[0].0, readers[0].1),
                    read(base + readers[1].0, readers[1].1),
                    read(base + readers[2].0, readers[2].1),
                );
                if p.coords.iter().all(|v| v.is_finite()) {
                    out.push(p);
                }
            }
        }
        Ok(out)
    }

    /// An unorganised little-endian FLOAT32 x, y, z cloud (point_step 12).
    pub fn from_points(points: &[Point3<f64>], header: Header) -> Self {
        let mut data = Vec::with_capacity(points.len() * 12);
        for p in points {
            for v in [p.x, p.y, p.z] {
                data.extend_from_slice(&(v as f32).to_le_bytes());
            }
        }
        let field = |name: &str, offset| PointField { name: name.into(), offset, datatype: FLOAT32, count: 1 };
        let n = u32::try_from(points.len()).unwrap_or(u32::MAX);
        Self {
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
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn a_hand_built_map_decodes_and_converts() {
        let m = decode_occupancy_grid(&hand_built_map()).unwrap();
        assert_eq!(m.header, Header { stamp_s: 5.5, frame_id: "map".into() });
        assert_eq!((m.width, m.height, m.data.as_slice()), (2, 1, [0i8, 100].as_slice()));
        let g = m.to_grid().unwrap();
        assert_eq!((g.geometry.origin_x_m, g.geometry.origin_y_m, g.geometry.resolution_m), (-1.0, 2.0, 0.05));
        assert_eq!(encode_occupancy_grid(&m), hand_built_map());
    }

    #[test]
    fn a_hand_built_tf_message_decodes() {
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
        let t = decode_tf_message(&b).unwrap();
        assert_eq!(t.len(), 1);
        assert_eq!((t[0].header.frame_id.as_str(), t[0].child_frame_id.as_str()), ("odom", "base_link"));
        assert_eq!(t[0].transform.translation, [1.0, 0.0, 0.0]);
        assert_eq!(encode_tf_message(&t), b);
    }

    #[test]
    fn clouds_pose_and_strings_round_trip() {
        let pts = [Point3::new(1.0, 2.0, 3.0), Point3::new(-1.5, 0.25, 0.0)];
        let c = PointCloud2::from_points(&pts, Header { stamp_s: 1.0, frame_id: "map".into() });
        let d = decode_point_cloud2(&encode_point_cloud2(&c)).unwrap();
        assert_eq!(d, c);
        assert_eq!(d.points().unwrap(), pts);
        let p = PoseWithCovarianceStamped { header: Header::default(), pose: RigidPose::planar(1.0, 2.0, 0.5), covariance: [0.1; 36] };
        assert_eq!(decode_pose_with_covariance(&encode_pose_with_covariance(&p)).unwrap(), p);
        assert_eq!(decode_string(&encode_string("{\"t_s\":1}")).unwrap(), "{\"t_s\":1}");
    }

    #[test]
    fn inconsistent_messages_are_errors_not_panics() {
        let mut m = decode_occupancy_grid(&hand_built_map()).unwrap();
        m.width = 3;
        assert!(matches!(m.to_grid(), Err(ConvertError::MapSize { .. })));
        let bytes = hand_built_map();
        for n in 0..bytes.len() {
            assert!(decode_occupancy_grid(&bytes[..n]).is_err());
        }
        let mut c = PointCloud2::from_points(&[Point3::new(1.0, 2.0, 3.0)], Header::default());
        c.data.pop();
        assert!(c.points().is_err());
    }
}
