//! Fisher information of one landmark's bearing seen from a camera pose (paper eqs. 8–9,
//! corrected as in notes §6).
//!
//! Observation (eq. 8): `b = v_c / ‖v_c‖`, `v_c = camera_from_world · v_w`, `d = ‖v_c‖`.
//! Jacobian with a camera-frame (right) perturbation `world_from_camera · Exp(ξ)`, `ξ = (δt, δφ)`:
//! `J = (I − bbᵀ)/d · [−I₃, [v_c]×]` (3×6). Notes §6: the paper's world-frame Jacobian makes the
//! score grow with the landmark's distance from the map origin; this one does not.
//! Bearing covariance with the landmark's own uncertainty `Q` (world frame) propagated:
//! `Σ_b = σ_b²(I − bbᵀ) + (∂b/∂v_w) Q (∂b/∂v_w)ᵀ`, `∂b/∂v_w = (I − bbᵀ)/d · R_cw`.
//! Information (eq. 9, dimensionally right): `I = Jᵀ Σ_b⁺ J`, `⁺` the pseudo-inverse on the
//! tangent plane of `b` (rank 2). With an orthonormal basis `T` (3×2) of that plane,
//! `Σ_t = Tᵀ Σ_b T = σ_b² I₂ + Tᵀ R_cw Q R_cwᵀ T / d²`, `J_t = Tᵀ J = Tᵀ [−I₃, [v_c]×] / d` and
//! `I = J_tᵀ Σ_t⁻¹ J_t`.
//!
//! Only `tr(I)` is scored (T-optimality). Since `J_t J_tᵀ = (1 + 1/d²) I₂` (because
//! `[v]×[v]×ᵀ = d²I − vvᵀ` and `Tᵀv = 0`), `tr(I) = (1 + 1/d²) · tr(Σ_t⁻¹)` for any `Q`, and with
//! `Q = σ_l² I` the closed form `tr(I) = 2(1 + 1/d²) / (σ_b² + σ_l²/d²)` (notes §6). The trace
//! adds rad⁻² and m⁻² terms, as the paper's score does.
//!
//! Cost: O(1) per landmark; the isotropic trace is a handful of flops, the general trace a 2×2
//! inverse, the full 6×6 matrix a few hundred flops.

#[cfg(test)]
use nalgebra::{Isometry3, Matrix3x6, Matrix6, Point3};
use nalgebra::{Matrix2, Matrix2x3, Matrix3, Vector3};

/// `tr(I)` for an isotropic landmark covariance `Q = σ_l² I` at camera distance `distance_m`:
/// `2(1 + 1/d²) / (σ_b² + σ_l²/d²)`. Returns 0 for a non-positive or non-finite distance or a
/// zero total noise.
#[inline]
pub(crate) fn trace_information(distance_m: f64, sigma_bearing_rad: f64, landmark_var_m2: f64) -> f64 {
    let valid = distance_m > 0.0 && distance_m.is_finite();
    if !valid {
        return 0.0;
    }
    let inv_d2 = 1.0 / (distance_m * distance_m);
    let noise = sigma_bearing_rad * sigma_bearing_rad + landmark_var_m2 * inv_d2;
    if noise.is_nan() || noise <= 0.0 {
        return 0.0;
    }
    2.0 * (1.0 + inv_d2) / noise
}

#[cfg(test)]
/// `[v]×`, the matrix of `v × ·`.
#[inline]
pub(crate) fn skew(v: &Vector3<f64>) -> Matrix3<f64> {
    Matrix3::new(0.0, -v.z, v.y, v.z, 0.0, -v.x, -v.y, v.x, 0.0)
}

/// Orthonormal basis (as rows of a 2×3 matrix, i.e. `Tᵀ`) of the plane orthogonal to unit `b`.
fn tangent_basis_t(b: &Vector3<f64>) -> Matrix2x3<f64> {
    let a = if b.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
    let t1 = a.cross(b).normalize();
    let t2 = b.cross(&t1);
    Matrix2x3::from_rows(&[t1.transpose(), t2.transpose()])
}

#[cfg(test)]
/// `J = (I − bbᵀ)/d · [−I₃, [v_c]×]` for the landmark at `point_in_camera`; `None` at d = 0.
pub(crate) fn bearing_jacobian(point_in_camera: &Vector3<f64>) -> Option<Matrix3x6<f64>> {
    let d = point_in_camera.norm();
    if !(d > 0.0 && d.is_finite()) {
        return None;
    }
    let b = point_in_camera / d;
    let p = (Matrix3::identity() - b * b.transpose()) / d;
    let mut j = Matrix3x6::zeros();
    j.fixed_view_mut::<3, 3>(0, 0).copy_from(&(-p));
    j.fixed_view_mut::<3, 3>(0, 3).copy_from(&(p * skew(point_in_camera)));
    Some(j)
}

/// Tangent-plane pieces shared by the full matrix and the general trace.
fn tangent_terms(
    point_in_camera: &Vector3<f64>,
    camera_from_world_rotation: &Matrix3<f64>,
    q_world_m2: &Matrix3<f64>,
    sigma_bearing_rad: f64,
) -> Option<(f64, Matrix2x3<f64>, Matrix2<f64>)> {
    let d = point_in_camera.norm();
    if !(d > 0.0 && d.is_finite()) {
        return None;
    }
    let b = point_in_camera / d;
    let tt = tangent_basis_t(&b);
    let tr = tt * camera_from_world_rotation;
    let sigma_t = Matrix2::identity() * (sigma_bearing_rad * sigma_bearing_rad) + tr * q_world_m2 * tr.transpose() / (d * d);
    let inv = sigma_t.try_inverse()?;
    inv.iter().all(|v| v.is_finite()).then_some((d, tt, inv))
}

/// `tr(I)` for a general landmark covariance `Q` (world frame, m²): `(1 + 1/d²) · tr(Σ_t⁻¹)`.
/// `None` at d = 0 or a singular bearing covariance.
pub(crate) fn trace_information_general(
    point_in_camera: &Vector3<f64>,
    camera_from_world_rotation: &Matrix3<f64>,
    q_world_m2: &Matrix3<f64>,
    sigma_bearing_rad: f64,
) -> Option<f64> {
    let (d, _, inv) = tangent_terms(point_in_camera, camera_from_world_rotation, q_world_m2, sigma_bearing_rad)?;
    Some((1.0 + 1.0 / (d * d)) * inv.trace())
}

#[cfg(test)]
/// The full 6×6 information `I = Jᵀ Σ_b⁺ J` of landmark `landmark_in_world` with covariance
/// `q_world_m2` seen from `camera_from_world`, in the camera-frame perturbation `ξ = (δt, δφ)`.
pub(crate) fn information_matrix(
    camera_from_world: &Isometry3<f64>,
    landmark_in_world: &Point3<f64>,
    q_world_m2: &Matrix3<f64>,
    sigma_bearing_rad: f64,
) -> Option<Matrix6<f64>> {
    let v_c = (camera_from_world * landmark_in_world).coords;
    let r_cw = camera_from_world.rotation.to_rotation_matrix().into_inner();
    let (d, tt, inv) = tangent_terms(&v_c, &r_cw, q_world_m2, sigma_bearing_rad)?;
    let mut a = nalgebra::Matrix2x6::zeros();
    a.fixed_view_mut::<2, 3>(0, 0).copy_from(&(-tt / d));
    a.fixed_view_mut::<2, 3>(0, 3).copy_from(&(tt * skew(&v_c) / d));
    Some(a.transpose() * inv * a)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Translation3, UnitQuaternion, Vector6};
    use proptest::prelude::*;

    /// SE(3) exponential of ξ = (δt, δφ) (translation first), local to these tests.
    fn se3_exp(xi: &Vector6<f64>) -> Isometry3<f64> {
        let t = Vector3::new(xi[0], xi[1], xi[2]);
        let phi = Vector3::new(xi[3], xi[4], xi[5]);
        let th = phi.norm();
        let k = skew(&phi);
        let v = if th < 1e-9 {
            Matrix3::identity() + k * 0.5
        } else {
            Matrix3::identity() + k * ((1.0 - th.cos()) / (th * th)) + k * k * ((th - th.sin()) / (th * th * th))
        };
        Isometry3::from_parts(Translation3::from(v * t), UnitQuaternion::from_scaled_axis(phi))
    }

    fn bearing(world_from_camera: &Isometry3<f64>, p_w: &Point3<f64>) -> Vector3<f64> {
        (world_from_camera.inverse() * p_w).coords.normalize()
    }

    fn pose(tx: f64, ty: f64, tz: f64, rx: f64, ry: f64, rz: f64) -> Isometry3<f64> {
        Isometry3::from_parts(Translation3::new(tx, ty, tz), UnitQuaternion::from_scaled_axis(Vector3::new(rx, ry, rz)))
    }

    #[test]
    fn closed_form_by_hand() {
        // d = 1, σ_b = 0.01, σ_l = 0: tr = 2·2/1e-4 = 40000.
        assert!((trace_information(1.0, 0.01, 0.0) - 40000.0).abs() < 1e-6);
        // d = 2, σ_b = 0.01, σ_l = 0.05: tr = 2(1 + 1/4)/(1e-4 + 0.0025/4) = 2.5/7.25e-4 = 3448.2758…
        assert!((trace_information(2.0, 0.01, 0.0025) - 2.5 / 7.25e-4).abs() < 1e-8);
        assert_eq!(trace_information(0.0, 0.01, 0.0025), 0.0);
        assert_eq!(trace_information(1.0, 0.0, 0.0), 0.0);
    }

    #[test]
    fn jacobian_matches_finite_differences() {
        let x = pose(1.0, -2.0, 0.5, 0.3, -0.7, 1.9);
        for p_w in [Point3::new(3.0, 1.0, 2.0), Point3::new(-4.0, 0.2, 0.1), Point3::new(1.1, -2.2, 3.5)] {
            let v_c = (x.inverse() * p_w).coords;
            let j = bearing_jacobian(&v_c).unwrap();
            let h = 1e-6;
            for k in 0..6 {
                let mut e = Vector6::zeros();
                e[k] = h;
                let plus = bearing(&(x * se3_exp(&e)), &p_w);
                let minus = bearing(&(x * se3_exp(&(-e))), &p_w);
                let fd = (plus - minus) / (2.0 * h);
                let col = j.column(k);
                assert!((fd - col).norm() < 1e-7, "column {k}: fd {fd:?} vs J {col:?}");
            }
        }
    }

    #[test]
    fn full_matrix_is_symmetric_psd_rank_two() {
        let x = pose(0.0, 0.0, 0.2, 0.1, 0.2, 0.3);
        let q = Matrix3::new(0.01, 0.002, 0.0, 0.002, 0.02, 0.001, 0.0, 0.001, 0.005);
        let m = information_matrix(&x.inverse(), &Point3::new(2.0, 0.5, 0.3), &q, 0.01).unwrap();
        assert!((m - m.transpose()).norm() < 1e-9 * m.norm());
        let eig = m.symmetric_eigen().eigenvalues;
        let mut ev: Vec<f64> = eig.iter().cloned().collect();
        ev.sort_by(|a, b| b.total_cmp(a));
        assert!(ev[0] > 0.0 && ev[1] > 0.0);
        assert!(ev[2..].iter().all(|&e| e.abs() < 1e-8 * ev[0]), "{ev:?}");
    }

    #[test]
    fn degenerate_inputs() {
        assert!(bearing_jacobian(&Vector3::zeros()).is_none());
        let x = Isometry3::identity();
        assert!(information_matrix(&x, &Point3::origin(), &Matrix3::identity(), 0.01).is_none());
        // No noise at all: Σ_t singular.
        assert!(information_matrix(&x, &Point3::new(0.0, 0.0, 1.0), &Matrix3::zeros(), 0.0).is_none());
    }

    fn unit(a: f64, z: f64) -> Vector3<f64> {
        let r = (1.0 - z * z).sqrt();
        Vector3::new(r * a.cos(), r * a.sin(), z)
    }

    proptest! {
        #[test]
        fn trace_matches_closed_form_for_isotropic_q(
            d in 0.2f64..30.0,
            rot in proptest::array::uniform3(-3.0f64..3.0),
            pos in proptest::array::uniform3(-50.0f64..50.0),
            az in 0.0f64..std::f64::consts::TAU, z in -0.99f64..0.99,
            sigma_b in 0.001f64..0.1, sigma_l in 0.0f64..0.5,
        ) {
            let world_from_camera = pose(pos[0], pos[1], pos[2], rot[0], rot[1], rot[2]);
            let p_w = world_from_camera * Point3::from(unit(az, z) * d);
            let q = Matrix3::identity() * (sigma_l * sigma_l);
            let m = information_matrix(&world_from_camera.inverse(), &p_w, &q, sigma_b).unwrap();
            let closed = 2.0 * (1.0 + 1.0 / (d * d)) / (sigma_b * sigma_b + sigma_l * sigma_l / (d * d));
            prop_assert!((m.trace() - closed).abs() <= 1e-9 * closed, "{} vs {}", m.trace(), closed);
            prop_assert!((trace_information(d, sigma_b, sigma_l * sigma_l) - closed).abs() <= 1e-12 * closed);
            let v_c = (world_from_camera.inverse() * p_w).coords;
            let r_cw = world_from_camera.inverse().rotation.to_rotation_matrix().into_inner();
            let g = trace_information_general(&v_c, &r_cw, &q, sigma_b).unwrap();
            prop_assert!((g - closed).abs() <= 1e-9 * closed);
        }

        #[test]
        fn general_trace_equals_full_matrix_trace_and_is_translation_invariant(
            rot in proptest::array::uniform3(-3.0f64..3.0),
            pos in proptest::array::uniform3(-5.0f64..5.0),
            lm in proptest::array::uniform3(-5.0f64..5.0),
            l in proptest::array::uniform6(-0.2f64..0.2),
            offset in proptest::array::uniform3(-1.0e5f64..1.0e5),
        ) {
            let world_from_camera = pose(pos[0], pos[1], pos[2], rot[0], rot[1], rot[2]);
            let p_w = Point3::new(lm[0], lm[1], lm[2]);
            prop_assume!((p_w - world_from_camera.translation.vector).coords.norm() > 0.1);
            // Anisotropic Q = L Lᵀ + small diagonal.
            let lo = Matrix3::new(l[0], 0.0, 0.0, l[1], l[2], 0.0, l[3], l[4], l[5]);
            let q = lo * lo.transpose() + Matrix3::identity() * 1e-4;
            let m = information_matrix(&world_from_camera.inverse(), &p_w, &q, 0.01).unwrap();
            let v_c = (world_from_camera.inverse() * p_w).coords;
            let r_cw = world_from_camera.inverse().rotation.to_rotation_matrix().into_inner();
            let g = trace_information_general(&v_c, &r_cw, &q, 0.01).unwrap();
            prop_assert!((g - m.trace()).abs() <= 1e-9 * g);
            // Move the whole scene far from the map origin: the trace must not change (the
            // world-frame Jacobian's artefact, notes §6).
            let shift = Vector3::new(offset[0], offset[1], offset[2]);
            let far_camera = Isometry3::from_parts(
                Translation3::from(world_from_camera.translation.vector + shift),
                world_from_camera.rotation,
            );
            let m_far = information_matrix(&far_camera.inverse(), &(p_w + shift), &q, 0.01).unwrap();
            prop_assert!((m_far.trace() - m.trace()).abs() <= 1e-6 * m.trace(), "{} vs {}", m_far.trace(), m.trace());
        }
    }
}
