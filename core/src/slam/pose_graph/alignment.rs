//! The relative pose of two keyframes from their views of the same landmarks: a weighted,
//! robust 3D–3D alignment (the geometric verification of a visual-odometry link or a loop
//! closure, RTAB-Map's `Vis/EstimationType` 0 with its `Vis/MinInliers` check), and the link's
//! covariance from the inliers it kept.
//!
//! Each correspondence i is a landmark seen at `p_a` in frame a and at `p_b` in frame b, with
//! covariances `C_a`, `C_b`. For `T = a_from_b` the residual is `r_i = T p_b − p_a`, of covariance
//! `S_i = C_a + R C_b Rᵀ`; with the right perturbation `T ⊕ ξ = T · Exp(ξ)`, ξ = (ρ, φ), its
//! Jacobian is `J_i = [R, −R [p_b]×]`. The estimate minimises `Σ ρ(r_iᵀ S_i⁻¹ r_i)` (Cauchy ρ)
//! by Gauss-Newton from an initial pose (the caller's guess, or Kabsch's closed form on every
//! correspondence); the inliers are the correspondences whose whitened error is below the χ²₃
//! gate; a last Gauss-Newton on the inliers alone (no kernel) gives the pose and its information
//! `H = Σ_inliers J_iᵀ S_i⁻¹ J_i` (Gauss-Newton's, exact for the linearised problem), the link's
//! covariance being `H⁻¹`: fewer or worse-placed inliers give a larger one. O(n) per iteration.

use nalgebra::{Matrix3, Matrix6, SMatrix, Vector3, Vector6};

use crate::slam::lie::{Se3, hat};

/// Gauss-Newton iterations of the robust stage and of the final one.
const ROBUST_ITERATIONS: usize = 10;
const FINAL_ITERATIONS: usize = 3;
/// Cauchy scale of the robust stage, in σ of the whitened 3-D residual.
const CAUCHY_K: f64 = 3.0;

/// One landmark seen from both frames.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Correspondence {
    /// The landmark in frame a, metres, and its covariance, m².
    pub in_a: Vector3<f64>,
    pub cov_a: Matrix3<f64>,
    /// The landmark in frame b, metres, and its covariance, m².
    pub in_b: Vector3<f64>,
    pub cov_b: Matrix3<f64>,
}

/// The alignment's answer.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Alignment {
    /// `a_from_b`.
    pub a_from_b: Se3,
    /// Covariance of `a_from_b` in its right tangent (δt, δφ), from the inliers.
    pub covariance: Matrix6<f64>,
    /// Whether each correspondence is an inlier, in input order.
    pub inliers: Vec<bool>,
    /// How many are.
    pub inlier_count: usize,
}

/// Aligns frame b onto frame a from `pairs` (see the module doc); `guess` starts the robust
/// stage (`None`: Kabsch on every pair). `inlier_chi2` gates the whitened squared residual
/// (χ²₃). `None` with fewer than 3 pairs or inliers, or when the inliers do not fix all six
/// degrees of freedom.
pub(crate) fn align(pairs: &[Correspondence], guess: Option<Se3>, inlier_chi2: f64) -> Option<Alignment> {
    if pairs.len() < 3 {
        return None;
    }
    let mut t = match guess {
        Some(g) => g,
        None => kabsch(pairs.iter().map(|c| (c.in_a, c.in_b)))?,
    };
    let all = vec![true; pairs.len()];
    for _ in 0..ROBUST_ITERATIONS {
        t = gauss_newton_step(pairs, &all, &t, true)?;
    }
    let mut inliers: Vec<bool> = pairs.iter().map(|c| whitened_sq(c, &t).is_some_and(|s| s < inlier_chi2)).collect();
    let inlier_count = inliers.iter().filter(|&&i| i).count();
    if inlier_count < 3 {
        return None;
    }
    for _ in 0..FINAL_ITERATIONS {
        t = gauss_newton_step(pairs, &inliers, &t, false)?;
    }
    let information = information_at(pairs, &inliers, &t)?;
    let covariance = information.try_inverse().filter(|c| c.iter().all(|v| v.is_finite()) && (0..6).all(|i| c[(i, i)] > 0.0))?;
    let covariance = (covariance + covariance.transpose()) * 0.5;
    // Inliers at the final pose (the last steps may have moved it a little).
    for (flag, c) in inliers.iter_mut().zip(pairs) {
        *flag = *flag && whitened_sq(c, &t).is_some_and(|s| s < inlier_chi2);
    }
    let inlier_count = inliers.iter().filter(|&&i| i).count();
    Some(Alignment { a_from_b: t, covariance, inliers, inlier_count })
}

/// `r = T p_b − p_a` and `S = C_a + R C_b Rᵀ`.
fn residual(c: &Correspondence, t: &Se3) -> (Vector3<f64>, Matrix3<f64>) {
    let r = t.rotation_matrix();
    (t.transform_point(&c.in_b) - c.in_a, c.cov_a + r * c.cov_b * r.transpose())
}

/// `rᵀ S⁻¹ r`; `None` when S is singular.
fn whitened_sq(c: &Correspondence, t: &Se3) -> Option<f64> {
    let (r, s) = residual(c, t);
    let w = s.try_inverse()?;
    Some((r.transpose() * w * r)[(0, 0)])
}

/// `J = [R, −R [p_b]×]`.
fn jacobian(c: &Correspondence, t: &Se3) -> SMatrix<f64, 3, 6> {
    let r = t.rotation_matrix();
    let mut j = SMatrix::<f64, 3, 6>::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&r);
    j.fixed_view_mut::<3, 3>(0, 3).copy_from(&(-r * hat(&c.in_b)));
    j
}

/// `Σ J_iᵀ S_i⁻¹ J_i` over the `used` pairs.
fn information_at(pairs: &[Correspondence], used: &[bool], t: &Se3) -> Option<Matrix6<f64>> {
    let mut h = Matrix6::zeros();
    for (c, _) in pairs.iter().zip(used).filter(|(_, u)| **u) {
        let (_, s) = residual(c, t);
        let w = s.try_inverse()?;
        let j = jacobian(c, t);
        h += j.transpose() * w * j;
    }
    Some(h)
}

/// One (robust, Cauchy-weighted) Gauss-Newton step over the `used` pairs: the new pose.
fn gauss_newton_step(pairs: &[Correspondence], used: &[bool], t: &Se3, robust: bool) -> Option<Se3> {
    let mut h = Matrix6::zeros();
    let mut g = Vector6::zeros();
    for (c, _) in pairs.iter().zip(used).filter(|(_, u)| **u) {
        let (r, s) = residual(c, t);
        let w = s.try_inverse()?;
        let s2 = (r.transpose() * w * r)[(0, 0)];
        let weight = if robust { 1.0 / (1.0 + s2 / (CAUCHY_K * CAUCHY_K)) } else { 1.0 };
        let j = jacobian(c, t);
        let jtw = j.transpose() * w * weight;
        h += jtw * j;
        g += jtw * r;
    }
    let step = -h.cholesky()?.solve(&g);
    step.iter().all(|v| v.is_finite()).then(|| t.retract(&step))
}

/// The rotation and translation that best map the `b` points onto the `a` points in the least
/// squares sense (Kabsch / Umeyama without scale): `R = V diag(1, 1, det(V Uᵀ)) Uᵀ` from the
/// SVD `U Σ Vᵀ` of `Σ (b − b̄)(a − ā)ᵀ`, `t = ā − R b̄`. `None` for fewer than 3 points.
pub(crate) fn kabsch(pairs: impl Iterator<Item = (Vector3<f64>, Vector3<f64>)> + Clone) -> Option<Se3> {
    let n = pairs.clone().count();
    if n < 3 {
        return None;
    }
    let (sa, sb) = pairs.clone().fold((Vector3::zeros(), Vector3::zeros()), |(sa, sb), (a, b)| (sa + a, sb + b));
    let (ca, cb) = (sa / n as f64, sb / n as f64);
    let cross: Matrix3<f64> = pairs.map(|(a, b)| (b - cb) * (a - ca).transpose()).sum();
    let svd = cross.svd(true, true);
    let (u, v_t) = (svd.u?, svd.v_t?);
    let v = v_t.transpose();
    let d = (v * u.transpose()).determinant().signum();
    let r = v * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * u.transpose();
    let rotation = nalgebra::UnitQuaternion::from_matrix(&r);
    let t = Se3::new(rotation, ca - rotation * cb);
    t.is_finite().then_some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::UnitQuaternion;

    fn pair(in_a: Vector3<f64>, a_from_b: &Se3, sigma_m: f64) -> Correspondence {
        let cov = Matrix3::identity() * sigma_m * sigma_m;
        Correspondence { in_a, cov_a: cov, in_b: a_from_b.inverse_transform_point(&in_a), cov_b: cov }
    }

    fn spread_points() -> Vec<Vector3<f64>> {
        vec![
            Vector3::new(2.0, 1.0, 0.2),
            Vector3::new(3.0, -1.0, 0.0),
            Vector3::new(1.5, 0.3, 0.8),
            Vector3::new(2.5, 2.0, -0.3),
            Vector3::new(4.0, 0.0, 0.5),
            Vector3::new(1.0, -1.5, 0.1),
        ]
    }

    #[test]
    fn recovers_a_known_transform_from_exact_points_with_and_without_a_guess() {
        let truth = Se3::new(UnitQuaternion::from_euler_angles(0.05, -0.02, 0.4), Vector3::new(0.5, -0.2, 0.03));
        let pairs: Vec<_> = spread_points().into_iter().map(|p| pair(p, &truth, 0.01)).collect();
        for guess in [None, Some(Se3::identity())] {
            let a = align(&pairs, guess, 11.34).expect("aligned");
            assert!(a.a_from_b.local(&truth).norm() < 1e-9, "{:?}", a.a_from_b);
            assert_eq!(a.inlier_count, pairs.len());
        }
    }

    /// Four points around the origin, σ 0.1 m in both frames, identity pose: S = 0.02 I, and
    /// with Σ p = 0 the translation and rotation blocks decouple, H_tt = n S⁻¹ = 200 I, so the
    /// translation covariance is 0.005 I. The rotation block: H_φφ = Σ [p]×ᵀ S⁻¹ [p]× =
    /// 50 Σ (|p|² I − p pᵀ) = 50 diag(2, 2, 4) for (±1, 0, 0), (0, ±1, 0): variances 0.01,
    /// 0.01, 0.005.
    #[test]
    fn covariance_is_the_inverse_of_the_inliers_information() {
        let pts = [Vector3::new(1.0, 0.0, 0.0), Vector3::new(-1.0, 0.0, 0.0), Vector3::new(0.0, 1.0, 0.0), Vector3::new(0.0, -1.0, 0.0)];
        let pairs: Vec<_> = pts.iter().map(|&p| pair(p, &Se3::identity(), 0.1)).collect();
        let a = align(&pairs, None, 11.34).expect("aligned");
        let expected = [0.005, 0.005, 0.005, 0.01, 0.01, 0.005];
        for (i, e) in expected.iter().enumerate() {
            assert!((a.covariance[(i, i)] - e).abs() < 1e-12, "{i}: {}", a.covariance[(i, i)]);
        }
        assert!(a.covariance[(0, 4)].abs() < 1e-12);
        // Half the points: twice the translation variance.
        let fewer = align(&[pairs[0], pairs[1], pairs[2]], None, 11.34).expect("aligned");
        assert!(fewer.covariance[(0, 0)] > a.covariance[(0, 0)]);
    }

    #[test]
    fn a_wrong_match_is_an_outlier_and_does_not_move_the_estimate() {
        let truth = Se3::new(UnitQuaternion::from_euler_angles(0.0, 0.0, -0.3), Vector3::new(0.4, 0.1, 0.0));
        let mut pairs: Vec<_> = spread_points().into_iter().map(|p| pair(p, &truth, 0.02)).collect();
        // The third landmark's measurement in b is another one's, 1.5 m away.
        pairs[2].in_b += Vector3::new(1.0, 1.1, 0.0);
        let a = align(&pairs, Some(Se3::identity()), 11.34).expect("aligned");
        assert!(!a.inliers[2]);
        assert_eq!(a.inlier_count, pairs.len() - 1);
        assert!(a.a_from_b.local(&truth).norm() < 1e-9);
    }

    #[test]
    fn too_few_pairs_or_a_degenerate_set_give_none() {
        let pairs: Vec<_> = spread_points().into_iter().take(2).map(|p| pair(p, &Se3::identity(), 0.01)).collect();
        assert!(align(&pairs, None, 11.34).is_none());
        // Three collinear points leave the rotation about their line free.
        let line: Vec<_> = (1..4).map(|i| pair(Vector3::new(f64::from(i), 0.0, 0.0), &Se3::identity(), 0.01)).collect();
        assert!(align(&line, Some(Se3::identity()), 11.34).is_none());
    }
}
