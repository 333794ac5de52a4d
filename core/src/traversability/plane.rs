//! Least-squares plane of a set of points from its moments: normal, slope, roughness.
//!
//! Notes §2: the plane's normal is the eigenvector of the smallest eigenvalue λ_min of the
//! centred covariance C = S/n; slope = angle between that normal and +z; roughness = √λ_min
//! (the RMS distance of the points to the plane). One 3×3 symmetric eigenproblem, O(1): λ_min by
//! Newton's method on the characteristic cubic when well separated (no trigonometry), else in
//! closed form (trigonometric), else nalgebra's iterative `SymmetricEigen`.
//!
//! Degenerate geometry (not in the notes; chosen so the answer is always defined and never
//! optimistic for vertical structures): when the points do not span a plane the least-squares
//! plane is not unique, and we take the *least-sloped* plane among those that fit:
//! - all points (numerically) coincident: the horizontal plane, slope 0, roughness 0;
//! - collinear points (λ_mid ≤ 10⁻⁶ λ_max) with direction u: the plane containing u whose normal
//!   is closest to +z, so slope = asin(|u_z|) (a vertical line of points — a pole — gives 90°).

use nalgebra::{Matrix3, SymmetricEigen};

use super::moments::CellMoments;
use crate::math;

/// Relative size of λ_mid below which the points are treated as collinear.
const COLLINEAR_RATIO: f64 = 1e-6;
/// λ_max below which the points are treated as coincident, m² ((1 nm)²).
const COINCIDENT_VAR_M2: f64 = 1e-18;

/// A fitted plane, in the coordinates of the moments it was fitted to.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct PlaneFit {
    /// Unit normal with n_z ≥ 0.
    pub normal: [f64; 3],
    /// The plane passes through the points' centroid.
    pub centroid: [f64; 3],
    /// Angle between the normal and +z, radians in [0, π/2].
    pub slope_rad: f64,
    /// RMS distance of the points to the plane, metres.
    pub roughness_m: f64,
}

impl PlaneFit {
    /// Height of the plane above (x, y); `None` for a (near-)vertical plane.
    #[inline]
    pub fn height_at(&self, x: f64, y: f64) -> Option<f64> {
        let [nx, ny, nz] = self.normal;
        (nz > 1e-9).then(|| self.centroid[2] - (nx * (x - self.centroid[0]) + ny * (y - self.centroid[1])) / nz)
    }
}

/// Fits the least-squares plane to the points summarised by `m`; `None` when `m` is empty or
/// not finite.
pub(crate) fn fit_plane(m: &CellMoments) -> Option<PlaneFit> {
    if m.count == 0 {
        return None;
    }
    let c = m.covariance();
    if !c.iter().flatten().all(|v| v.is_finite()) {
        return None;
    }
    let (normal, roughness_m) =
        smallest_eigenpair_newton(&c).or_else(|| smallest_eigenpair_closed_form(&c)).unwrap_or_else(|| normal_iterative(&c));
    let normal = if normal[2] < 0.0 { normal.map(|v| -v) } else { normal };
    let horizontal = (normal[0] * normal[0] + normal[1] * normal[1]).sqrt();
    let slope_rad = math::atan2(horizontal, normal[2]);
    Some(PlaneFit { normal, centroid: m.mean, slope_rad, roughness_m })
}

/// nᵀ C n, clamped at 0.
fn quad(c: &[[f64; 3]; 3], n: [f64; 3]) -> f64 {
    let mut q = 0.0;
    for i in 0..3 {
        for j in 0..3 {
            q += n[i] * c[i][j] * n[j];
        }
    }
    q.max(0.0)
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// The common case, well separated λ_min (terrain: points near a plane), without trigonometry:
/// on C scaled to unit largest entry, p(λ) = det(C − λI) = c₀ − c₁λ + c₂λ² − λ³ is decreasing
/// and convex left of its smallest root (all roots are real and ≥ 0), so Newton's method from
/// λ = 0 climbs to λ_min monotonically (quadratically once λ_min ≪ λ_mid; a few steps on
/// terrain). λ_mid and λ_max come from the deflated quadratic; the eigenvector and roughness as in
/// [`smallest_eigenpair_closed_form`]. `None` (use the closed form) for coincident or collinear
/// points, or when Newton is slow (λ_min close to λ_mid) or the cross product is inaccurate.
/// Agrees with the closed form to rounding (proptest below).
fn smallest_eigenpair_newton(c: &[[f64; 3]; 3]) -> Option<([f64; 3], f64)> {
    let s = c.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if s.is_nan() || s <= COINCIDENT_VAR_M2 {
        return None;
    }
    let k = 1.0 / s;
    let a = [[c[0][0] * k, c[0][1] * k, c[0][2] * k], [c[1][0] * k, c[1][1] * k, c[1][2] * k], [c[2][0] * k, c[2][1] * k, c[2][2] * k]];
    let c2 = a[0][0] + a[1][1] + a[2][2];
    let m12 = a[1][1] * a[2][2] - a[1][2] * a[1][2];
    let c1 = a[0][0] * a[1][1] - a[0][1] * a[0][1] + a[0][0] * a[2][2] - a[0][2] * a[0][2] + m12;
    let c0 = a[0][0] * m12 - a[0][1] * (a[0][1] * a[2][2] - a[1][2] * a[0][2]) + a[0][2] * (a[0][1] * a[1][2] - a[1][1] * a[0][2]);
    let mut l = 0.0f64;
    let mut converged = false;
    for _ in 0..24 {
        let p = c0 + l * (-c1 + l * (c2 - l));
        let dp = -c1 + l * (2.0 * c2 - 3.0 * l);
        if dp.is_nan() || dp >= 0.0 {
            return None;
        }
        let step = p / dp;
        l -= step;
        if converged {
            break; // one polishing step after the step fell below 1e-9
        }
        converged = step.abs() <= 1e-9 * c2;
    }
    if !converged || !l.is_finite() {
        return None;
    }
    let l_min = l.max(0.0);
    let sum = c2 - l_min;
    let prod = c1 - l_min * sum;
    let l_max = 0.5 * (sum + (sum * sum - 4.0 * prod).max(0.0).sqrt());
    let l_mid = sum - l_max;
    if s * l_max <= COINCIDENT_VAR_M2 || l_mid <= COLLINEAR_RATIO * l_max || l_mid - l_min <= 1e-3 * l_max {
        return None;
    }
    eigenvector_of_smallest(c, &a, l_min)
}

/// The common, well-conditioned case in closed form (about 3× faster than the iterative
/// solver): eigenvalues by the trigonometric method (Smith 1961) on C scaled to unit largest
/// entry, the λ_min eigenvector as the largest cross product of two rows of C − λ_min I, and
/// roughness from the Rayleigh quotient nᵀCn. `None` (use [`normal_iterative`]) for coincident
/// or collinear points, or when λ_min is too close to λ_mid for the cross product to be accurate.
fn smallest_eigenpair_closed_form(c: &[[f64; 3]; 3]) -> Option<([f64; 3], f64)> {
    let s = c.iter().flatten().fold(0.0f64, |m, v| m.max(v.abs()));
    if s.is_nan() || s <= COINCIDENT_VAR_M2 {
        return None;
    }
    let a = c.map(|row| row.map(|v| v / s));
    let p1 = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
    let q = (a[0][0] + a[1][1] + a[2][2]) / 3.0;
    let (d0, d1, d2) = (a[0][0] - q, a[1][1] - q, a[2][2] - q);
    let p2 = d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * p1;
    if p2.is_nan() || p2 <= 1e-24 {
        return None; // isotropic: every direction is an eigenvector
    }
    let p = (p2 / 6.0).sqrt();
    let b = [[d0 / p, a[0][1] / p, a[0][2] / p], [a[1][0] / p, d1 / p, a[1][2] / p], [a[2][0] / p, a[2][1] / p, d2 / p]];
    let det = b[0][0] * (b[1][1] * b[2][2] - b[1][2] * b[2][1]) - b[0][1] * (b[1][0] * b[2][2] - b[1][2] * b[2][0])
        + b[0][2] * (b[1][0] * b[2][1] - b[1][1] * b[2][0]);
    let phi = math::acos((0.5 * det).clamp(-1.0, 1.0)) / 3.0;
    let l_max = q + 2.0 * p * math::cos(phi);
    let l_min = q + 2.0 * p * math::cos(phi + 2.0 * std::f64::consts::FRAC_PI_3);
    let l_mid = 3.0 * q - l_max - l_min;
    if s * l_max <= COINCIDENT_VAR_M2 || l_mid <= COLLINEAR_RATIO * l_max {
        return None;
    }
    eigenvector_of_smallest(c, &a, l_min)
}

/// The unit eigenvector of the scaled covariance `a` for its smallest eigenvalue `l_min`, as the
/// largest cross product of two rows of `a − l_min I`, and the roughness √(nᵀ C n) on the
/// unscaled `c`. `None` when the cross product is too small to give an accurate direction:
/// |cross| ≈ (λ_max − λ_min)(λ_mid − λ_min); below 1e-6 the direction error could exceed
/// ~1e-10 rad, so the caller falls back to a more robust solver.
fn eigenvector_of_smallest(c: &[[f64; 3]; 3], a: &[[f64; 3]; 3], l_min: f64) -> Option<([f64; 3], f64)> {
    let rows = [[a[0][0] - l_min, a[0][1], a[0][2]], [a[1][0], a[1][1] - l_min, a[1][2]], [a[2][0], a[2][1], a[2][2] - l_min]];
    let mut best = [0.0; 3];
    let mut best_n2 = 0.0;
    for (i, j) in [(0, 1), (0, 2), (1, 2)] {
        let v = cross(rows[i], rows[j]);
        let n2 = v[0] * v[0] + v[1] * v[1] + v[2] * v[2];
        if n2 > best_n2 {
            best = v;
            best_n2 = n2;
        }
    }
    if best_n2.is_nan() || best_n2 <= 1e-12 {
        return None;
    }
    let inv = 1.0 / best_n2.sqrt();
    let n = best.map(|v| v * inv);
    Some((n, quad(c, n).sqrt()))
}

/// The general case with nalgebra's iterative symmetric eigensolver, including the degenerate
/// geometries described in the module doc. Returns (unit normal, roughness).
fn normal_iterative(c: &[[f64; 3]; 3]) -> ([f64; 3], f64) {
    let cov = Matrix3::new(c[0][0], c[0][1], c[0][2], c[1][0], c[1][1], c[1][2], c[2][0], c[2][1], c[2][2]);
    let eig = SymmetricEigen::new(cov);
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eig.eigenvalues[a].total_cmp(&eig.eigenvalues[b]));
    let lam = order.map(|i| eig.eigenvalues[i].max(0.0));
    let vec_of = |k: usize| {
        let v = eig.eigenvectors.column(order[k]);
        [v[0], v[1], v[2]]
    };
    if lam[2] <= COINCIDENT_VAR_M2 {
        ([0.0, 0.0, 1.0], 0.0)
    } else if lam[1] <= COLLINEAR_RATIO * lam[2] {
        // Least-sloped plane containing the line direction u: normal ∝ z − u_z u.
        let u = vec_of(2);
        let n = [-u[2] * u[0], -u[2] * u[1], 1.0 - u[2] * u[2]];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        let n = if len > 1e-12 {
            [n[0] / len, n[1] / len, n[2] / len]
        } else {
            // Vertical line: any vertical plane through it; pick the one facing +x or +y.
            let h = (u[0] * u[0] + u[1] * u[1]).sqrt();
            if h > 1e-12 { [-u[1] / h, u[0] / h, 0.0] } else { [1.0, 0.0, 0.0] }
        };
        (n, quad(c, n).sqrt())
    } else {
        (vec_of(0), lam[0].sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn moments(points: impl IntoIterator<Item = [f64; 3]>) -> CellMoments {
        let mut m = CellMoments::EMPTY;
        for p in points {
            m.add(p);
        }
        m
    }

    fn grid_points(n: usize, f: impl Fn(f64, f64) -> f64) -> Vec<[f64; 3]> {
        let mut v = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let (x, y) = (i as f64 * 0.01, j as f64 * 0.01);
                v.push([x, y, f(x, y)]);
            }
        }
        v
    }

    #[test]
    fn tilted_plane_gives_its_angle_and_no_roughness() {
        // z = tan(20°)·(x cos 30° + y sin 30°): a plane tilted 20° about an oblique axis.
        let a = 20f64.to_radians();
        let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
        let p = fit_plane(&moments(grid_points(20, |x, y| 3.0 + a.tan() * (x * c + y * s)))).unwrap();
        assert!((p.slope_rad - a).abs() < 1e-9, "{}", p.slope_rad.to_degrees());
        assert!(p.roughness_m < 1e-7, "{}", p.roughness_m);
        // Normal ∝ (−tan a cos 30°, −tan a sin 30°, 1).
        let n = [-a.tan() * c, -a.tan() * s, 1.0];
        let len = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        for (got, want) in p.normal.iter().zip(n) {
            assert!((got - want / len).abs() < 1e-9);
        }
        let h = p.height_at(0.05, 0.1).unwrap();
        assert!((h - (3.0 + a.tan() * (0.05 * c + 0.1 * s))).abs() < 1e-9);
    }

    #[test]
    fn plus_minus_sigma_offsets_give_roughness_sigma() {
        // Horizontal plane, every point offset by +σ or −σ in a checkerboard: each point is
        // exactly σ from the plane z = 0, so the RMS distance is σ.
        let sigma = 0.013;
        let pts: Vec<[f64; 3]> = (0..400)
            .map(|k| {
                let (i, j) = (k / 20, k % 20);
                [i as f64 * 0.01, j as f64 * 0.01, if (i + j) % 2 == 0 { sigma } else { -sigma }]
            })
            .collect();
        let p = fit_plane(&moments(pts)).unwrap();
        assert!((p.roughness_m - sigma).abs() < 1e-12, "{}", p.roughness_m);
        assert!(p.slope_rad < 1e-9);
    }

    #[test]
    fn degenerate_inputs_are_defined() {
        assert!(fit_plane(&CellMoments::EMPTY).is_none());
        // Coincident points: horizontal, zero roughness.
        let p = fit_plane(&moments([[1.0, 2.0, 3.0]; 5])).unwrap();
        assert_eq!((p.slope_rad, p.roughness_m), (0.0, 0.0));
        // A horizontal line of points: slope 0 (a horizontal plane contains it).
        let p = fit_plane(&moments((0..10).map(|i| [i as f64 * 0.1, 0.5 * i as f64 * 0.1, 1.0]))).unwrap();
        assert!(p.slope_rad < 1e-9, "{}", p.slope_rad);
        // A line rising at 10°: least-sloped plane through it has slope 10°.
        let t = 10f64.to_radians().tan();
        let p = fit_plane(&moments((0..10).map(|i| [0.0, i as f64 * 0.1, t * i as f64 * 0.1]))).unwrap();
        assert!((p.slope_rad - 10f64.to_radians()).abs() < 1e-9, "{}", p.slope_rad.to_degrees());
        // A vertical line of points (a pole): 90°, and no plane height.
        let p = fit_plane(&moments((0..10).map(|i| [0.3, 0.4, i as f64 * 0.1]))).unwrap();
        assert!((p.slope_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-12);
        assert!(p.height_at(0.0, 0.0).is_none());
    }

    #[test]
    fn vertical_wall_is_ninety_degrees() {
        let pts: Vec<[f64; 3]> = (0..100).map(|k| [1.0, (k % 10) as f64 * 0.02, (k / 10) as f64 * 0.02]).collect();
        let p = fit_plane(&moments(pts)).unwrap();
        assert!((p.slope_rad - std::f64::consts::FRAC_PI_2).abs() < 1e-9);
    }

    proptest! {
        /// The closed form agrees with the iterative solver wherever it answers.
        #[test]
        fn closed_form_matches_iterative(
            pts in proptest::collection::vec((-1.0f64..1.0, -1.0f64..1.0, -0.3f64..0.3), 4..60),
            tilt in -1.2f64..1.2,
            scale in prop_oneof![Just(1e-3), Just(1.0), Just(100.0)],
        ) {
            let m = moments(pts.into_iter().map(|(x, y, z)| [x * scale, y * scale, (z + tilt * x) * scale]));
            let c = m.covariance();
            let (n_it, r_it) = normal_iterative(&c);
            for (n_cf, r_cf) in [smallest_eigenpair_closed_form(&c), smallest_eigenpair_newton(&c)].into_iter().flatten() {
                let dot = (n_it[0] * n_cf[0] + n_it[1] * n_cf[1] + n_it[2] * n_cf[2]).abs();
                prop_assert!(dot > 1.0 - 1e-9, "{:?} vs {:?}", n_it, n_cf);
                prop_assert!((r_it - r_cf).abs() <= 1e-7 * scale, "{} vs {}", r_it, r_cf);
            }
            // Newton and the closed form agree to rounding where both answer.
            if let (Some((n_nt, r_nt)), Some((n_cf, r_cf))) = (smallest_eigenpair_newton(&c), smallest_eigenpair_closed_form(&c)) {
                let dot = (n_nt[0] * n_cf[0] + n_nt[1] * n_cf[1] + n_nt[2] * n_cf[2]).abs();
                prop_assert!(dot > 1.0 - 1e-15, "{:?} vs {:?}", n_nt, n_cf);
                prop_assert!((r_nt - r_cf).abs() <= 1e-9 * scale.max(r_cf), "{} vs {}", r_nt, r_cf);
            }
        }
    }

    #[test]
    fn closed_form_declines_degenerate_inputs() {
        let line = moments((0..10).map(|i| [i as f64 * 0.1, 0.0, 0.0]));
        assert!(smallest_eigenpair_closed_form(&line.covariance()).is_none());
        let blob = moments([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0]]);
        assert!(smallest_eigenpair_closed_form(&blob.covariance()).is_none()); // isotropic
        // A well-conditioned tilted patch is answered in closed form.
        let t = 0.3;
        let patch = moments(
            (0..25).map(|k| [(k % 5) as f64 * 0.1, (k / 5) as f64 * 0.1, t * (k % 5) as f64 * 0.1 + if k % 2 == 0 { 0.01 } else { -0.01 }]),
        );
        assert!(smallest_eigenpair_closed_form(&patch.covariance()).is_some());
        assert!(smallest_eigenpair_newton(&patch.covariance()).is_some());
        assert!(smallest_eigenpair_newton(&line.covariance()).is_none());
        assert!(smallest_eigenpair_newton(&blob.covariance()).is_none());
    }
}
