//! Landmarks binned into voxels, with a 2D spatial index (notes §6; paper §II-D).
//!
//! Each landmark falls in the voxel `⌊p / voxel_m⌋` (per axis). Each occupied voxel counts once,
//! at the centroid of its landmarks, with covariance `Q` = the mean of its members' covariances
//! when the cloud has them, else `σ_l² I`. Non-finite points (or covariances) are skipped and
//! counted. Voxels are stored sorted by (index bucket, voxel key), so every query visits them in
//! a deterministic order.
//!
//! Index: a uniform grid of square buckets over the voxels' x–y extent (edge
//! `max(1 m, voxel_m)`, enlarged if the extent would need more than 2²⁰ buckets); voxels are
//! sorted by bucket (row-major), so the voxels of a run of buckets along x are one contiguous
//! slice and a box query touches one slice per bucket row.
//!
//! Build: O(n log n) for n landmarks (a sort). Box query: O(rows + voxels in the touched
//! buckets). Built once per landmark set and reused across decisions.

use super::UtilityError;
use crate::cloud::PointCloud;
use nalgebra::Matrix3;

const MIN_BUCKET_M: f64 = 1.0;
const MAX_BUCKETS: f64 = (1u64 << 20) as f64;
const MAX_KEY: f64 = (1u64 << 40) as f64;

/// Voxelised landmarks with a spatial index; see the module doc.
#[derive(Clone, Debug, PartialEq)]
pub struct LandmarkVoxels {
    voxel_m: f64,
    centroids_m: Vec<[f64; 3]>,
    counts: Vec<u32>,
    /// σ² (m²) when the voxel's `Q` is isotropic, NaN otherwise.
    isotropic_var_m2: Vec<f64>,
    covariances_m2: Vec<Matrix3<f64>>,
    skipped_points: usize,
    bucket_m: f64,
    bucket_origin_m: [f64; 2],
    buckets_x: usize,
    buckets_y: usize,
    /// Voxels of bucket `k` are `bucket_start[k]..bucket_start[k + 1]`.
    bucket_start: Vec<u32>,
}

impl LandmarkVoxels {
    /// No landmarks.
    pub fn empty(voxel_m: f64) -> Self {
        Self {
            voxel_m,
            centroids_m: Vec::new(),
            counts: Vec::new(),
            isotropic_var_m2: Vec::new(),
            covariances_m2: Vec::new(),
            skipped_points: 0,
            bucket_m: MIN_BUCKET_M,
            bucket_origin_m: [0.0, 0.0],
            buckets_x: 0,
            buckets_y: 0,
            bucket_start: vec![0],
        }
    }

    /// Voxelises `cloud` into voxels of edge `voxel_m`; points without a covariance get
    /// `σ_l² I` with `σ_l = sigma_landmark_m`.
    pub fn new(cloud: &PointCloud, voxel_m: f64, sigma_landmark_m: f64) -> Result<Self, UtilityError> {
        if !(voxel_m.is_finite() && voxel_m > 0.0) {
            return Err(UtilityError::InvalidParameter { name: "voxel_m", value: voxel_m });
        }
        if !(sigma_landmark_m.is_finite() && sigma_landmark_m >= 0.0) {
            return Err(UtilityError::InvalidParameter { name: "sigma_landmark_m", value: sigma_landmark_m });
        }
        let covs = cloud.covariances.as_deref();
        if let Some(c) = covs
            && c.len() != cloud.points.len()
        {
            return Err(UtilityError::CovarianceCountMismatch { points: cloud.points.len(), covariances: c.len() });
        }
        let default_q = Matrix3::identity() * (sigma_landmark_m * sigma_landmark_m);

        // (voxel key, point index), sorted: deterministic grouping whatever the input order.
        let mut entries: Vec<([i64; 3], u32)> = Vec::with_capacity(cloud.points.len());
        let mut skipped_points = 0;
        for (i, p) in cloud.points.iter().enumerate() {
            let key = [p.x, p.y, p.z].map(|v| (v / voxel_m).floor());
            let cov_ok = covs.is_none_or(|c| c[i].iter().all(|v| v.is_finite()));
            if key.iter().all(|k| k.is_finite() && k.abs() < MAX_KEY) && cov_ok && i <= u32::MAX as usize {
                entries.push((key.map(|k| k as i64), i as u32));
            } else {
                skipped_points += 1;
            }
        }
        entries.sort_unstable();

        struct Voxel {
            key: [i64; 3],
            centroid: [f64; 3],
            count: u32,
            q: Matrix3<f64>,
        }
        let mut voxels: Vec<Voxel> = Vec::new();
        let mut a = 0;
        while a < entries.len() {
            let key = entries[a].0;
            let mut b = a;
            let mut sum = [0.0; 3];
            let mut q = Matrix3::zeros();
            while b < entries.len() && entries[b].0 == key {
                let i = entries[b].1 as usize;
                let p = &cloud.points[i];
                sum[0] += p.x;
                sum[1] += p.y;
                sum[2] += p.z;
                q += covs.map_or(default_q, |c| c[i]);
                b += 1;
            }
            let n = (b - a) as f64;
            voxels.push(Voxel { key, centroid: sum.map(|s| s / n), count: (b - a) as u32, q: q / n });
            a = b;
        }
        if voxels.is_empty() {
            let mut out = Self::empty(voxel_m);
            out.skipped_points = skipped_points;
            return Ok(out);
        }

        // Bucket grid over the centroids' x–y extent.
        let (mut min_x, mut min_y, mut max_x, mut max_y) = (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
        for v in &voxels {
            min_x = min_x.min(v.centroid[0]);
            min_y = min_y.min(v.centroid[1]);
            max_x = max_x.max(v.centroid[0]);
            max_y = max_y.max(v.centroid[1]);
        }
        let mut bucket_m = voxel_m.max(MIN_BUCKET_M);
        let count_for = |b: f64| (((max_x - min_x) / b).floor() + 1.0) * (((max_y - min_y) / b).floor() + 1.0);
        while count_for(bucket_m) > MAX_BUCKETS {
            bucket_m *= 2.0;
        }
        let buckets_x = ((max_x - min_x) / bucket_m).floor() as usize + 1;
        let buckets_y = ((max_y - min_y) / bucket_m).floor() as usize + 1;
        let bucket_of = |c: &[f64; 3]| {
            let bx = (((c[0] - min_x) / bucket_m).floor() as usize).min(buckets_x - 1);
            let by = (((c[1] - min_y) / bucket_m).floor() as usize).min(buckets_y - 1);
            by * buckets_x + bx
        };
        let mut keyed: Vec<(usize, Voxel)> = voxels.into_iter().map(|v| (bucket_of(&v.centroid), v)).collect();
        keyed.sort_unstable_by(|x, y| x.0.cmp(&y.0).then(x.1.key.cmp(&y.1.key)));
        let mut bucket_start = vec![0u32; buckets_x * buckets_y + 1];
        for (b, _) in &keyed {
            bucket_start[b + 1] += 1;
        }
        for k in 1..bucket_start.len() {
            bucket_start[k] += bucket_start[k - 1];
        }
        let mut out = Self {
            voxel_m,
            centroids_m: Vec::with_capacity(keyed.len()),
            counts: Vec::with_capacity(keyed.len()),
            isotropic_var_m2: Vec::with_capacity(keyed.len()),
            covariances_m2: Vec::with_capacity(keyed.len()),
            skipped_points,
            bucket_m,
            bucket_origin_m: [min_x, min_y],
            buckets_x,
            buckets_y,
            bucket_start,
        };
        for (_, v) in keyed {
            out.centroids_m.push(v.centroid);
            out.counts.push(v.count);
            out.isotropic_var_m2.push(isotropic_variance(&v.q).unwrap_or(f64::NAN));
            out.covariances_m2.push(v.q);
        }
        Ok(out)
    }

    /// Voxel edge, metres.
    pub fn voxel_m(&self) -> f64 {
        self.voxel_m
    }

    /// Number of occupied voxels.
    pub fn len(&self) -> usize {
        self.centroids_m.len()
    }

    /// Whether no voxel is occupied.
    pub fn is_empty(&self) -> bool {
        self.centroids_m.is_empty()
    }

    #[cfg(test)]
    /// Points of the cloud that were skipped (non-finite position or covariance).
    pub(crate) fn skipped_points(&self) -> usize {
        self.skipped_points
    }

    /// Centroid of voxel `i` in the world frame, metres.
    #[inline]
    pub(crate) fn centroid_m(&self, i: usize) -> [f64; 3] {
        self.centroids_m[i]
    }

    /// Number of landmarks in voxel `i`.
    pub fn count(&self, i: usize) -> u32 {
        self.counts[i]
    }

    /// Covariance `Q` of voxel `i` (world frame, m²).
    #[inline]
    pub(crate) fn covariance_m2(&self, i: usize) -> &Matrix3<f64> {
        &self.covariances_m2[i]
    }

    /// `σ²` if voxel `i`'s `Q` is `σ² I` (the fast FIM path applies), else `None`.
    #[inline]
    pub(crate) fn isotropic_variance_m2(&self, i: usize) -> Option<f64> {
        let v = self.isotropic_var_m2[i];
        (!v.is_nan()).then_some(v)
    }

    /// Calls `f` with the index of every voxel whose bucket overlaps the box
    /// `[min_x, max_x] × [min_y, max_y]` (metres). Voxels just outside the box may be included
    /// (whole buckets are visited); the caller tests each one.
    pub(crate) fn for_each_in_box(&self, min_x_m: f64, min_y_m: f64, max_x_m: f64, max_y_m: f64, mut f: impl FnMut(usize)) {
        if self.is_empty() || !(min_x_m <= max_x_m && min_y_m <= max_y_m) {
            return;
        }
        let range = |lo: f64, hi: f64, origin: f64, n: usize| -> Option<(usize, usize)> {
            let a = ((lo - origin) / self.bucket_m).floor();
            let b = ((hi - origin) / self.bucket_m).floor();
            if b < 0.0 || a >= n as f64 || a.is_nan() || b.is_nan() {
                return None;
            }
            Some((a.max(0.0) as usize, (b.min((n - 1) as f64)) as usize))
        };
        let Some((x0, x1)) = range(min_x_m, max_x_m, self.bucket_origin_m[0], self.buckets_x) else { return };
        let Some((y0, y1)) = range(min_y_m, max_y_m, self.bucket_origin_m[1], self.buckets_y) else { return };
        for by in y0..=y1 {
            let row = by * self.buckets_x;
            let (a, b) = (self.bucket_start[row + x0] as usize, self.bucket_start[row + x1 + 1] as usize);
            for i in a..b {
                f(i);
            }
        }
    }
}

/// `σ²` if `q` is `σ² I` up to 1e-12 relative, else `None`.
fn isotropic_variance(q: &Matrix3<f64>) -> Option<f64> {
    let mean = q.trace() / 3.0;
    let tol = 1e-12 * mean.abs().max(f64::MIN_POSITIVE);
    let iso = (0..3).all(|r| {
        (0..3).all(|c| {
            let target = if r == c { mean } else { 0.0 };
            (q[(r, c)] - target).abs() <= tol
        })
    });
    iso.then_some(mean)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;
    use proptest::prelude::*;

    #[test]
    fn voxels_by_hand() {
        // Voxel 0.5 m. (0.1,0.1,0.1) and (0.3,0.2,0.4) share voxel (0,0,0): centroid (0.2,0.15,0.25).
        // (0.6,0,0) is voxel (1,0,0); (−0.1,0,0) is voxel (−1,0,0).
        let cloud = PointCloud::from_points(vec![
            Point3::new(0.1, 0.1, 0.1),
            Point3::new(0.6, 0.0, 0.0),
            Point3::new(0.3, 0.2, 0.4),
            Point3::new(-0.1, 0.0, 0.0),
            Point3::new(f64::NAN, 0.0, 0.0),
        ]);
        let v = LandmarkVoxels::new(&cloud, 0.5, 0.05).unwrap();
        assert_eq!(v.len(), 3);
        assert_eq!(v.skipped_points(), 1);
        let mut found = false;
        for i in 0..v.len() {
            let c = v.centroid_m(i);
            if v.count(i) == 2 {
                assert!((c[0] - 0.2).abs() < 1e-12 && (c[1] - 0.15).abs() < 1e-12 && (c[2] - 0.25).abs() < 1e-12);
                found = true;
            }
            assert!((v.isotropic_variance_m2(i).unwrap() - 0.0025).abs() < 1e-15);
        }
        assert!(found);
    }

    #[test]
    fn covariances_are_averaged() {
        let mut cloud = PointCloud::from_points(vec![Point3::new(0.1, 0.1, 0.1), Point3::new(0.2, 0.2, 0.2), Point3::new(5.0, 5.0, 0.0)]);
        let a = Matrix3::new(0.02, 0.01, 0.0, 0.01, 0.02, 0.0, 0.0, 0.0, 0.02);
        let b = Matrix3::identity() * 0.04;
        cloud.covariances = Some(vec![a, b, b]);
        let v = LandmarkVoxels::new(&cloud, 1.0, 0.05).unwrap();
        assert_eq!(v.len(), 2);
        let i = (0..2).find(|&i| v.count(i) == 2).unwrap();
        assert!((v.covariance_m2(i) - (a + b) / 2.0).norm() < 1e-15);
        assert!(v.isotropic_variance_m2(i).is_none());
        let j = 1 - i;
        assert_eq!(v.isotropic_variance_m2(j), Some(0.04));
        cloud.covariances = Some(vec![a]);
        assert!(matches!(LandmarkVoxels::new(&cloud, 1.0, 0.05), Err(UtilityError::CovarianceCountMismatch { .. })));
        assert!(LandmarkVoxels::new(&cloud, 0.0, 0.05).is_err());
    }

    #[test]
    fn empty_and_far_outliers() {
        let v = LandmarkVoxels::new(&PointCloud::default(), 0.25, 0.05).unwrap();
        assert!(v.is_empty());
        let mut n = 0;
        v.for_each_in_box(-1e9, -1e9, 1e9, 1e9, |_| n += 1);
        assert_eq!(n, 0);
        // A landmark a million metres away must not make the bucket grid explode.
        let cloud = PointCloud::from_points(vec![Point3::new(0.0, 0.0, 0.0), Point3::new(1.0e6, 1.0e6, 0.0)]);
        let v = LandmarkVoxels::new(&cloud, 0.25, 0.05).unwrap();
        assert!(v.bucket_start.len() <= MAX_BUCKETS as usize + 1);
        let mut seen = Vec::new();
        v.for_each_in_box(-1.0, -1.0, 1.0, 1.0, |i| seen.push(i));
        assert!(seen.iter().any(|&i| v.centroid_m(i)[0] < 1.0));
    }

    #[test]
    fn order_does_not_depend_on_input_order() {
        let pts: Vec<Point3<f64>> =
            (0..200).map(|k| Point3::new((k * 37 % 101) as f64 * 0.13, (k * 53 % 97) as f64 * 0.11, (k % 7) as f64 * 0.3)).collect();
        let mut rev = pts.clone();
        rev.reverse();
        let a = LandmarkVoxels::new(&PointCloud::from_points(pts), 0.25, 0.05).unwrap();
        let b = LandmarkVoxels::new(&PointCloud::from_points(rev), 0.25, 0.05).unwrap();
        assert_eq!(a.counts, b.counts);
        for i in 0..a.len() {
            for k in 0..3 {
                assert!((a.centroid_m(i)[k] - b.centroid_m(i)[k]).abs() < 1e-12);
            }
        }
    }

    proptest! {
        #[test]
        fn box_query_finds_every_voxel_inside(
            pts in proptest::collection::vec(proptest::array::uniform3(-20.0f64..20.0), 1..300),
            bx in proptest::array::uniform4(-25.0f64..25.0),
        ) {
            let cloud = PointCloud::from_points(pts.iter().map(|p| Point3::new(p[0], p[1], p[2])).collect());
            let v = LandmarkVoxels::new(&cloud, 0.25, 0.05).unwrap();
            let (x0, x1) = (bx[0].min(bx[1]), bx[0].max(bx[1]));
            let (y0, y1) = (bx[2].min(bx[3]), bx[2].max(bx[3]));
            let mut got = vec![false; v.len()];
            v.for_each_in_box(x0, y0, x1, y1, |i| got[i] = true);
            for (i, &hit) in got.iter().enumerate() {
                let c = v.centroid_m(i);
                if c[0] >= x0 && c[0] <= x1 && c[1] >= y0 && c[1] <= y1 {
                    prop_assert!(hit, "voxel {i} at {c:?} missed");
                }
            }
            let total: u32 = (0..v.len()).map(|i| v.count(i)).sum();
            prop_assert_eq!(total as usize, pts.len());
        }
    }
}
