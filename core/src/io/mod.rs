//! Loaders and writers: bytes in, typed errors out.
//!
//! Every loader takes the file's bytes and a `source_name` (the file name, used only in error
//! messages), never a path: the core does no file I/O. Every parser is total: hostile input gives
//! an error, never a panic, and allocations are capped by the length of the input (a header that
//! declares 10⁹ points in a 100-byte file is rejected before anything is reserved).
//!
//! | file | formats |
//! |---|---|
//! | [`ply`] | PLY ascii / binary little- and big-endian; writer: binary little-endian |
//! | [`pcd`] | PCD v0.6/v0.7 ascii / binary / binary_compressed (LZF); writer: ascii or binary |
//! | [`csv`] | `x,y,z[,covariance]` text |
//! | [`las`] | LAS 1.0–1.4 via the `las` crate; LAZ through the `laz` feature (on by default) |
//! | [`map_server`] | ROS map_server YAML + PGM (P2/P5, 8/16-bit) or PNG; writers: YAML+PGM, PNG |
//!
//! Point attributes shared by the formats that carry named fields (PLY, PCD):
//! - `x`, `y`, `z` (required; any numeric type, metres);
//! - `classification` (optional; also `scalar_Classification` as CloudCompare writes it, any
//!   case): an integer 0–255, the ASPRS class;
//! - covariance (optional, m²): all six of `cov_xx cov_xy cov_xz cov_yy cov_yz cov_zz` (the upper
//!   triangle of the symmetric 3×3 position covariance), or none of them.
//!
//! Non-finite coordinates are an error naming the point (or line). Covariances must be finite with
//! a non-negative diagonal.

pub mod csv;
pub(crate) mod image;
#[cfg(feature = "las")]
pub mod las;
pub mod map_server;
pub mod pcd;
pub mod ply;

#[cfg(test)]
mod tests;

/// `bytes` without a leading UTF-8 byte-order mark. Some editors (Notepad, Excel's "CSV UTF-8")
/// start text files with one; YAML, TOML and CSV readers skip it, and so do the text loaders here.
pub fn without_bom(bytes: &[u8]) -> &[u8] {
    bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes)
}

/// `text` without a leading byte-order mark (U+FEFF), as [`without_bom`].
pub fn without_bom_str(text: &str) -> &str {
    text.strip_prefix('\u{feff}').unwrap_or(text)
}

pub use csv::{load_csv, write_csv};
pub use image::{write_png_gray8, write_png_rgb8};
pub use map_server::{MapMode, MapThresholds, MapYaml, load_map, load_map_image, save_map};
pub use pcd::{PcdEncoding, load_pcd, write_pcd};
pub use ply::{load_ply, write_ply_binary};

use crate::cloud::PointCloud;
use nalgebra::Matrix3;
use thiserror::Error;

/// Why a point cloud could not be loaded. Every message starts with the source name.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum CloudError {
    /// The extension is not one of .pcd, .ply, .csv, .las, .laz.
    #[error("{name}: unknown point-cloud extension (expected .pcd, .ply, .csv, .las or .laz)")]
    UnknownExtension {
        /// The source name (file name) given to the loader.
        name: String,
    },
    /// The header is malformed or inconsistent (the detail says how).
    #[error("{name}: {detail}")]
    Header {
        /// The source name (file name) given to the loader.
        name: String,
        /// What is wrong.
        detail: String,
    },
    /// A required field or property is missing (e.g. "vertex element has no 'z' property").
    #[error("{name}: {detail}")]
    MissingField {
        /// The source name (file name) given to the loader.
        name: String,
        /// Which field is missing, and where.
        detail: String,
    },
    /// The header declares a number of points the data does not hold.
    #[error("{name}: header says {keyword} {declared} but the data holds {found} points")]
    WrongPointCount {
        /// The source name (file name) given to the loader.
        name: String,
        /// The header keyword that declares the count (e.g. `POINTS`, `element vertex`).
        keyword: &'static str,
        /// Points the header declares.
        declared: u64,
        /// Points the data holds.
        found: u64,
    },
    /// A point whose x, y or z is NaN or infinite (`index` counts from 0 in file order).
    #[error("{name}: point {index}: non-finite coordinate")]
    NonFinitePoint {
        /// The source name (file name) given to the loader.
        name: String,
        /// 0-based index of the point in file order.
        index: usize,
    },
    /// A text line that cannot be read (1-based line number).
    #[error("{name}: line {line}: {detail}")]
    Line {
        /// The source name (file name) given to the loader.
        name: String,
        /// 1-based line number.
        line: usize,
        /// What is wrong.
        detail: String,
    },
    /// A point's attribute is invalid (bad classification, negative variance, …).
    #[error("{name}: point {index}: {detail}")]
    Attribute {
        /// The source name (file name) given to the loader.
        name: String,
        /// 0-based index of the point in file order.
        index: usize,
        /// What is wrong.
        detail: String,
    },
    /// A valid file using a feature this build does not support.
    #[error("{name}: {what} is not supported")]
    Unsupported {
        /// The source name (file name) given to the loader.
        name: String,
        /// The unsupported feature.
        what: String,
    },
    /// An error reported by the `las` crate.
    #[error("{name}: LAS: {detail}")]
    Las {
        /// The source name (file name) given to the loader.
        name: String,
        /// The `las` crate's message.
        detail: String,
    },
}

/// Why an occupancy map could not be loaded or written. Every message starts with the file name.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum MapError {
    /// The YAML text does not parse (or is not a mapping).
    #[error("{name}: invalid YAML: {detail}")]
    Yaml {
        /// The file name given to the loader or writer.
        name: String,
        /// The YAML parser's message.
        detail: String,
    },
    /// A key map_server requires is absent.
    #[error("{name}: missing required key '{key}'")]
    MissingKey {
        /// The file name given to the loader or writer.
        name: String,
        /// The missing key.
        key: &'static str,
    },
    /// A key has a value of the wrong type or out of range.
    #[error("{name}: key '{key}': {detail}")]
    BadValue {
        /// The file name given to the loader or writer.
        name: String,
        /// The key.
        key: &'static str,
        /// What is wrong with its value.
        detail: String,
    },
    /// The origin has a non-zero yaw: the grid type is axis-aligned.
    #[error("{name}: origin yaw {yaw_rad} rad is not zero: rotated maps are not supported (rotate the image instead)")]
    RotatedOrigin {
        /// The file name given to the loader or writer.
        name: String,
        /// The origin's yaw, radians.
        yaw_rad: f64,
    },
    /// The image bytes are not a readable PGM or PNG.
    #[error("{name}: {detail}")]
    Image {
        /// The file name given to the loader or writer.
        name: String,
        /// What is wrong.
        detail: String,
    },
    /// Writer input whose size does not match the data.
    #[error("image of {width} × {height} pixels needs {expected} bytes, got {got}")]
    ImageSize {
        /// Image width, pixels.
        width: usize,
        /// Image height, pixels.
        height: usize,
        /// Bytes the image needs (one per pixel in gray, three in RGB).
        expected: usize,
        /// Bytes given.
        got: usize,
    },
}

/// Loads a point cloud, choosing the parser from the extension of `source_name` (.pcd, .ply,
/// .csv, .las, .laz; case-insensitive).
///
/// # Examples
///
/// ```
/// use fitslam_core::io::CloudError;
/// use fitslam_core::load_cloud;
///
/// let csv = b"x,y,z\n0.0,0.0,0.0\n1.5,-2.0,0.25\n";
/// let cloud = load_cloud(csv, "scan.CSV")?;
/// assert_eq!(cloud.len(), 2);
/// assert_eq!(cloud.points[1].coords.as_slice(), &[1.5, -2.0, 0.25]);
/// assert!(cloud.covariances.is_none());
///
/// // Errors name the source and, in a text file, the line.
/// let error = load_cloud(b"x,y,z\n1.0,nan,0.0\n", "scan.csv").unwrap_err();
/// assert!(error.to_string().starts_with("scan.csv"), "{error}");
/// assert!(matches!(load_cloud(csv, "scan.xyz"), Err(CloudError::UnknownExtension { .. })));
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
pub fn load_cloud(bytes: &[u8], source_name: &str) -> Result<PointCloud, CloudError> {
    let ext = extension(source_name);
    match ext.as_deref() {
        Some("ply") => ply::load_ply(bytes, source_name),
        Some("pcd") => pcd::load_pcd(bytes, source_name),
        Some("csv") => csv::load_csv(bytes, source_name),
        Some("las") | Some("laz") => load_las_dispatch(bytes, source_name),
        _ => Err(CloudError::UnknownExtension { name: source_name.to_string() }),
    }
}

#[cfg(feature = "las")]
fn load_las_dispatch(bytes: &[u8], source_name: &str) -> Result<PointCloud, CloudError> {
    las::load_las(bytes, source_name)
}

#[cfg(not(feature = "las"))]
fn load_las_dispatch(_bytes: &[u8], source_name: &str) -> Result<PointCloud, CloudError> {
    Err(CloudError::Unsupported {
        name: source_name.to_string(),
        what: "LAS/LAZ (fitslam-core built without the `las` feature)".to_string(),
    })
}

/// Lower-case extension of a file name (after the last '.' of the last path component).
pub(crate) fn extension(name: &str) -> Option<String> {
    let base = name.rsplit(['/', '\\']).next().unwrap_or(name);
    let dot = base.rfind('.')?;
    Some(base[dot + 1..].to_ascii_lowercase())
}

/// Names under which a per-point classification is accepted (compared case-insensitively).
pub(crate) fn is_classification_name(name: &str) -> bool {
    name.eq_ignore_ascii_case("classification") || name.eq_ignore_ascii_case("scalar_classification")
}

/// The accepted covariance field names, in the order of [`cov_from_upper`].
pub(crate) const COV_NAMES: [&str; 6] = ["cov_xx", "cov_xy", "cov_xz", "cov_yy", "cov_yz", "cov_zz"];

/// Symmetric 3×3 matrix from its upper triangle `xx xy xz yy yz zz`.
pub(crate) fn cov_from_upper(u: [f64; 6]) -> Matrix3<f64> {
    Matrix3::new(u[0], u[1], u[2], u[1], u[3], u[4], u[2], u[4], u[5])
}

/// Upper triangle `xx xy xz yy yz zz` of a 3×3 matrix.
pub(crate) fn cov_to_upper(m: &Matrix3<f64>) -> [f64; 6] {
    [m[(0, 0)], m[(0, 1)], m[(0, 2)], m[(1, 1)], m[(1, 2)], m[(2, 2)]]
}

/// A point attribute with a value no point can have (the loaders put it in their own errors).
#[derive(Clone, Copy, Debug, Error, PartialEq)]
pub(crate) enum AttributeError {
    #[error("non-finite covariance")]
    NonFiniteCovariance,
    #[error("negative variance on the covariance diagonal")]
    NegativeVariance,
    #[error("classification {0} is not an integer in 0..=255")]
    Classification(f64),
}

/// Checks a covariance: finite entries, non-negative diagonal.
pub(crate) fn check_cov(m: &Matrix3<f64>) -> Result<(), AttributeError> {
    if m.iter().any(|v| !v.is_finite()) {
        return Err(AttributeError::NonFiniteCovariance);
    }
    if (0..3).any(|i| m[(i, i)] < 0.0) {
        return Err(AttributeError::NegativeVariance);
    }
    Ok(())
}

/// A classification value read as a number: must be an integer in 0..=255.
pub(crate) fn classification_of(v: f64) -> Result<u8, AttributeError> {
    if v.fract() == 0.0 && (0.0..=255.0).contains(&v) { Ok(v as u8) } else { Err(AttributeError::Classification(v)) }
}

/// Where each attribute lives among a record's numeric fields (PLY properties, PCD fields).
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct FieldMap {
    pub xyz: [usize; 3],
    pub classification: Option<usize>,
    pub cov: Option<[usize; 6]>,
}

impl FieldMap {
    /// Finds the attributes among `names`; `what` names the container in messages
    /// (e.g. "vertex element", "FIELDS").
    pub(crate) fn find<'a>(
        names: impl Iterator<Item = &'a str> + Clone,
        source_name: &str,
        what: &str,
        kind: &str,
    ) -> Result<Self, CloudError> {
        let position = |wanted: &str| names.clone().position(|n| n == wanted);
        let mut xyz = [0usize; 3];
        for (axis, slot) in ["x", "y", "z"].into_iter().zip(xyz.iter_mut()) {
            *slot = position(axis).ok_or_else(|| CloudError::MissingField {
                name: source_name.to_string(),
                detail: format!("{what} has no '{axis}' {kind}"),
            })?;
        }
        let classification = names.clone().position(is_classification_name);
        let found: Vec<Option<usize>> = COV_NAMES.iter().map(|c| position(c)).collect();
        let cov = if found.iter().all(Option::is_none) {
            None
        } else if let Some(missing) = found.iter().position(Option::is_none) {
            return Err(CloudError::MissingField {
                name: source_name.to_string(),
                detail: format!(
                    "{what} has some covariance {kind}s but no '{}' (all of {} are needed)",
                    COV_NAMES[missing],
                    COV_NAMES.join(" ")
                ),
            });
        } else {
            let mut c = [0usize; 6];
            for (slot, f) in c.iter_mut().zip(found) {
                *slot = f.unwrap_or(0);
            }
            Some(c)
        };
        Ok(Self { xyz, classification, cov })
    }
}

/// Accumulates points and attributes, validating as it goes; shared by the named-field parsers.
pub(crate) struct CloudBuilder<'a> {
    name: &'a str,
    map: FieldMap,
    cloud: PointCloud,
    /// Records seen, kept or not.
    records: usize,
    /// Whether a record with x, y and z all NaN is skipped (PCL's "no return" in PCD files).
    skip_no_returns: bool,
}

impl<'a> CloudBuilder<'a> {
    pub(crate) fn new(name: &'a str, map: FieldMap, capacity: usize) -> Self {
        let cloud = PointCloud {
            points: Vec::with_capacity(capacity),
            covariances: map.cov.map(|_| Vec::with_capacity(capacity)),
            classification: map.classification.map(|_| Vec::with_capacity(capacity)),
        };
        Self { name, map, cloud, records: 0, skip_no_returns: false }
    }

    /// Skips the records whose x, y and z are all NaN instead of failing on them: PCL stores a
    /// sensor's missing returns so (organised clouds, `is_dense` false). Partly NaN or infinite
    /// coordinates stay errors.
    pub(crate) fn skipping_no_returns(mut self) -> Self {
        self.skip_no_returns = true;
        self
    }

    /// Adds one record given a getter for its numeric fields by index.
    pub(crate) fn push(&mut self, field: impl Fn(usize) -> f64) -> Result<(), CloudError> {
        let index = self.records;
        self.records += 1;
        let [ix, iy, iz] = self.map.xyz;
        let p = nalgebra::Point3::new(field(ix), field(iy), field(iz));
        if self.skip_no_returns && p.x.is_nan() && p.y.is_nan() && p.z.is_nan() {
            return Ok(());
        }
        if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
            return Err(CloudError::NonFinitePoint { name: self.name.to_string(), index });
        }
        let attr_err = |e: AttributeError| CloudError::Attribute { name: self.name.to_string(), index, detail: e.to_string() };
        if let (Some(i), Some(out)) = (self.map.classification, self.cloud.classification.as_mut()) {
            out.push(classification_of(field(i)).map_err(attr_err)?);
        }
        if let (Some(c), Some(out)) = (self.map.cov, self.cloud.covariances.as_mut()) {
            let m = cov_from_upper(c.map(&field));
            check_cov(&m).map_err(attr_err)?;
            out.push(m);
        }
        self.cloud.points.push(p);
        Ok(())
    }

    pub(crate) fn len(&self) -> usize {
        self.cloud.points.len()
    }

    pub(crate) fn finish(self) -> PointCloud {
        self.cloud
    }
}

/// Attributes of `cloud` that can be written: present and as long as the points.
pub(crate) fn writable_attributes(cloud: &PointCloud) -> (Option<&[u8]>, Option<&[Matrix3<f64>]>) {
    let n = cloud.points.len();
    let class = cloud.classification.as_deref().filter(|c| c.len() == n);
    let cov = cloud.covariances.as_deref().filter(|c| c.len() == n);
    (class, cov)
}
