//! Point clouds and landmark sets, as loaded from PCD / PLY / CSV / LAS.

use nalgebra::{Matrix3, Point3};

/// A set of 3D points in one frame (metres), with optional per-point attributes.
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
