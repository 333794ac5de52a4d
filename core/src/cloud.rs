//! Point clouds and landmark sets, as loaded from PCD / PLY / CSV / LAS.

use nalgebra::{Matrix3, Point3};

/// A set of 3D points in one frame (metres), with optional per-point attributes.
///
/// # Examples
///
/// ```
/// use fitslam_core::PointCloud;
/// use nalgebra::{Matrix3, Point3};
///
/// let mut landmarks = PointCloud::from_points(vec![Point3::new(1.0, 2.0, 0.5), Point3::new(3.0, 0.0, 0.2)]);
/// assert_eq!(landmarks.len(), 2);
/// // Per-point covariances, when given, are one per point (m²).
/// landmarks.covariances = Some(vec![Matrix3::identity() * 0.01; 2]);
/// let csv = fitslam_core::io::write_csv(&landmarks);
/// assert_eq!(fitslam_core::load_cloud(csv.as_bytes(), "landmarks.csv")?, landmarks);
/// # Ok::<(), Box<dyn std::error::Error>>(())
/// ```
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointCloud {
    /// The points, metres.
    pub points: Vec<Point3<f64>>,
    /// Per-point 3×3 position covariance (m²), when the source has one (landmark sets).
    pub covariances: Option<Vec<Matrix3<f64>>>,
    /// Per-point ASPRS classification (LAS, or a PLY `classification` property).
    pub classification: Option<Vec<u8>>,
}

impl PointCloud {
    /// A cloud of bare points (no covariance, no classification).
    pub fn from_points(points: Vec<Point3<f64>>) -> Self {
        Self { points, covariances: None, classification: None }
    }

    /// Number of points.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether the cloud has no point.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }
}
