use super::*;
use crate::slam::factors::fixtures::se3;
use crate::slam::factors::{BetweenSe2, BetweenSe3, GaussianNoise, PointObservation3, PriorSe3};
use crate::slam::lie::{Se2, Se3};
use crate::slam::values::Variable;
use nalgebra::{Matrix6, Vector3};

/// Checks every block against the dense inverse; returns whether the factor was supernodal.
fn assert_matches_dense_inverse(graph: &FactorGraph, values: &Values, ids: &[VarId]) -> bool {
    assert_matches_dense_inverse_with(graph, values, ids, Factorisation::Fastest)
}

fn assert_matches_dense_inverse_with(graph: &FactorGraph, values: &Values, ids: &[VarId], factorisation: Factorisation) -> bool {
    let marginals = Marginals::new(graph, values, factorisation).unwrap();
    let h = marginals.dense_information();
    let inv = h.clone().try_inverse().unwrap();
    let by_solves = marginals.covariances_by_solves(ids).unwrap();
    let selected = marginals.covariances_from_selected_inverse(ids).unwrap();
    let chosen = marginals.covariances(ids).unwrap();
    let mut col = 0;
    let mut offsets = Vec::new();
    for (id, v) in values.iter() {
        offsets.push(if values.is_fixed(id) { usize::MAX } else { col });
        if !values.is_fixed(id) {
            col += v.dim();
        }
    }
    for (id, cov) in ids.iter().zip(by_solves.iter()).chain(ids.iter().zip(&selected)).chain(ids.iter().zip(&chosen)) {
        let d = cov.nrows();
        if offsets[id.0] == usize::MAX {
            assert_eq!(cov.amax(), 0.0, "fixed variable has zero covariance");
            continue;
        }
        let block = inv.view((offsets[id.0], offsets[id.0]), (d, d));
        let rel = (cov - block).amax() / block.amax();
        assert!(rel < 1e-9, "{id:?}: relative difference {rel:e}");
    }
    assert!(marginals.sorted_patterns);
    marginals.is_supernodal()
}

/// On real graphs (assets/data/slam; intel: 1,728 poses, factorised simplicially;
/// smallGrid3D: 125 3D poses, supernodally) the selected inverse and the path solves agree on
/// every variable's block, and the factors' patterns are sorted as the former needs.
#[test]
fn selected_inverse_agrees_with_path_solves_on_real_graphs() {
    use crate::slam::factors::Se2Residual;
    use crate::slam::problem::Gauge;
    for (name, supernodal) in [("intel.g2o", false), ("smallGrid3D.g2o", true)] {
        let path = format!("{}/../assets/data/slam/{name}", env!("CARGO_MANIFEST_DIR"));
        let g2o = crate::slam::g2o::read_g2o(&std::fs::read(&path).unwrap()).unwrap();
        let p = g2o.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
        let m = Marginals::new(&p.graph, &p.values, Factorisation::Fastest).unwrap();
        assert!(m.sorted_patterns && m.is_supernodal() == supernodal, "{name}");
        let all: Vec<VarId> = p.values.iter().map(|(id, _)| id).collect();
        let by_solves = m.covariances_by_solves(&all).unwrap();
        let selected = m.covariances_from_selected_inverse(&all).unwrap();
        for (id, (a, b)) in all.iter().zip(by_solves.iter().zip(&selected)) {
            let rel = (a - b).amax() / a.amax().max(f64::MIN_POSITIVE);
            assert!(rel < 1e-10, "{name} {id:?}: relative difference {rel:e}");
        }
    }
}

#[test]
fn se2_chain_with_loop_matches_dense_inverse() {
    // A square loop of 6 poses, odometry plus one loop closure, first pose fixed.
    let mut values = Values::new();
    let mut graph = FactorGraph::new();
    let info = nalgebra::Matrix3::new(50.0, 5.0, 1.0, 5.0, 30.0, 2.0, 1.0, 2.0, 200.0);
    let noise = GaussianNoise::from_information(&info).unwrap();
    let ids: Vec<VarId> = (0..6).map(|k| values.push(Variable::Se2(Se2::new(k as f64 * 0.9, 0.1 * k as f64, 0.2 * k as f64)))).collect();
    for k in 0..5 {
        graph.add(BetweenSe2::new(ids[k], ids[k + 1], Se2::new(1.0, 0.0, 0.3), noise)).unwrap();
    }
    graph.add(BetweenSe2::new(ids[0], ids[5], Se2::new(3.0, 2.0, 1.4), noise)).unwrap();
    values.set_fixed(ids[0], true);
    assert!(!assert_matches_dense_inverse(&graph, &values, &ids), "simplicial factor");
}

/// SE(3) poses on a prior-anchored odometry chain, point landmarks, and an observation of
/// landmark j from pose k wherever `sees(k, j)`; `info6` is the odometry and prior information.
fn pose_chain_with_landmarks(
    poses: &[Se3],
    landmarks: &[Vector3<f64>],
    info6: Matrix6<f64>,
    sigma_point_m: f64,
    sees: impl Fn(usize, usize) -> bool,
) -> (FactorGraph, Values, Vec<VarId>, Vec<VarId>) {
    let mut values = Values::new();
    let mut graph = FactorGraph::new();
    let noise6 = GaussianNoise::from_information(&info6).unwrap();
    let noise3 = GaussianNoise::isotropic(3, sigma_point_m).unwrap();
    let pose_ids: Vec<VarId> = poses.iter().map(|&p| values.push(Variable::Se3(p))).collect();
    let lm_ids: Vec<VarId> = landmarks.iter().map(|&l| values.push(Variable::Point3(l))).collect();
    graph.add(PriorSe3::new(pose_ids[0], se3([0.0; 3], [0.0; 3]), noise6)).unwrap();
    for k in 1..poses.len() {
        let step = se3([1.0, 0.1 * k as f64, 0.1], [0.0, 0.0, 0.3]);
        graph.add(BetweenSe3::new(pose_ids[k - 1], pose_ids[k], step, noise6)).unwrap();
    }
    for (k, &p) in pose_ids.iter().enumerate() {
        for (j, &l) in lm_ids.iter().enumerate() {
            if sees(k, j) {
                let z = Vector3::new(1.0 + 0.1 * j as f64, 2.0 - 0.05 * k as f64, 0.5);
                graph.add(PointObservation3::new(p, l, z, noise3)).unwrap();
            }
        }
    }
    (graph, values, pose_ids, lm_ids)
}

/// A dense information matrix of n unknowns costs n³/3 flops whatever the layout: one
/// supernode (k = n, m = 0), or n columns with m = n − 1 − j rows below column j, Σ (⅓ + m +
/// m²) = n/3 + n(n−1)/2 + (n−1)n(2n−1)/6 = n³/3. Two SE(3) poses joined by a between factor
/// (the first with a prior): n = 12, 576 flops.
#[test]
fn factor_flops_of_a_dense_problem_are_n_cubed_over_three() {
    let poses = [se3([0.0; 3], [0.0; 3]), se3([1.0, 0.0, 0.0], [0.0, 0.0, 0.3])];
    let (graph, values, _, _) = pose_chain_with_landmarks(&poses, &[], Matrix6::identity() * 4.0, 0.1, |_, _| false);
    for factorisation in [Factorisation::Fastest, Factorisation::Reproducible] {
        let stats = Marginals::new(&graph, &values, factorisation).unwrap().factor_stats();
        assert_eq!(stats.dim, 12);
        assert!((stats.flops - 576.0).abs() < 1e-9, "{factorisation:?}: {stats:?}");
        assert!(stats.factor_entries >= 78, "the 12 × 12 lower triangle: {stats:?}");
    }
}

#[test]
fn se3_poses_and_landmarks_match_dense_inverse() {
    let a = Matrix6::from_fn(|i, j| ((i * 5 + j) as f64).sin());
    let poses: Vec<Se3> = (0..4).map(|k| se3([k as f64, 0.2, 0.0], [0.0, 0.1, 0.3 * k as f64])).collect();
    let lms: Vec<Vector3<f64>> = (0..3).map(|k| Vector3::new(k as f64, 3.0, 1.0)).collect();
    let info6 = a * a.transpose() + Matrix6::identity() * 5.0;
    let (graph, mut values, poses, lms) = pose_chain_with_landmarks(&poses, &lms, info6, 0.2, |k, j| (k + j) % 2 == 0 || k == 3);
    let all: Vec<VarId> = poses.iter().chain(&lms).copied().collect();
    assert!(!assert_matches_dense_inverse(&graph, &values, &all), "simplicial factor");
    // Anchored instead of prior: the first pose is fixed, its covariance zero.
    values.set_fixed(poses[0], true);
    assert!(!assert_matches_dense_inverse(&graph, &values, &all), "simplicial factor");
}

/// 40 SE(3) poses on a chain with a loop, 30 landmarks each seen from most poses: dense
/// enough that faer factorises supernodally, with several supernodes. Returns every variable.
fn supernodal_example() -> (FactorGraph, Values, Vec<VarId>) {
    let a = Matrix6::from_fn(|i, j| ((i * 7 + j) as f64).cos());
    let poses: Vec<Se3> = (0..40).map(|k| se3([0.3 * k as f64, (0.2 * k as f64).sin(), 0.0], [0.0, 0.05, 0.1 * k as f64])).collect();
    let lms: Vec<Vector3<f64>> = (0..30).map(|j| Vector3::new(0.4 * j as f64, 3.0 + (j % 3) as f64, 1.0)).collect();
    let info6 = a * a.transpose() + Matrix6::identity() * 3.0;
    let (mut graph, values, poses, lms) = pose_chain_with_landmarks(&poses, &lms, info6, 0.3, |k, j| (k * 7 + j * 3) % 5 != 0);
    let noise6 = GaussianNoise::from_information(&info6).unwrap();
    graph.add(BetweenSe3::new(poses[0], poses[39], se3([11.0, 0.5, 0.0], [0.0, 0.0, 3.9]), noise6)).unwrap();
    (graph, values, poses.iter().chain(&lms).copied().collect())
}

#[test]
fn supernodal_factor_matches_dense_inverse() {
    let (graph, values, all) = supernodal_example();
    assert!(assert_matches_dense_inverse(&graph, &values, &all), "supernodal factor");
    let m = Marginals::new(&graph, &values, Factorisation::Fastest).unwrap();
    assert!(m.node_count() > 1, "several supernodes: {}", m.node_count());
}

/// Every free variable has its own place in the elimination order, inside the problem; a
/// fixed one has none.
#[test]
fn elimination_positions_are_distinct_and_fixed_variables_have_none() {
    let (graph, mut values, all) = supernodal_example();
    values.set_fixed(all[0], true);
    let m = Marginals::new(&graph, &values, Factorisation::Fastest).unwrap();
    assert_eq!(m.elimination_position(all[0]), None);
    let mut positions: Vec<usize> = all[1..].iter().map(|&id| m.elimination_position(id).unwrap()).collect();
    assert!(positions.iter().all(|&p| p < m.factor_stats().dim));
    positions.sort_unstable();
    positions.dedup();
    assert_eq!(positions.len(), all.len() - 1);
}

/// Where faer would factorise supernodally, the reproducible choice factorises simplicially
/// (scalar loops only: the same bits on every CPU and in wasm), with the same marginals.
#[test]
fn reproducible_factorisation_is_simplicial_with_the_same_marginals() {
    let (graph, values, all) = supernodal_example();
    assert!(!assert_matches_dense_inverse_with(&graph, &values, &all, Factorisation::Reproducible), "simplicial factor");
}

/// Solved in batches (paths shared near the root, not below), every block is bit for bit
/// its solve alone; fixed variables keep their place with a zero block.
#[test]
fn batched_solves_equal_solves_alone_bit_for_bit() {
    let (graph, mut values, all) = supernodal_example();
    values.set_fixed(all[3], true);
    let m = Marginals::new(&graph, &values, Factorisation::Fastest).unwrap();
    // Landmarks and poses mixed, out of order, more than one batch.
    let ids: Vec<VarId> = all.iter().rev().step_by(3).chain(all.iter().step_by(5)).copied().collect();
    assert!(ids.len() > 2 * SOLVE_BATCH && ids.contains(&all[3]));
    let batched = m.covariances_by_solves(&ids).unwrap();
    for (id, cov) in ids.iter().zip(&batched) {
        let alone = m.covariances_by_solves(&[*id]).unwrap().remove(0);
        assert_eq!(cov.shape(), alone.shape());
        assert!(cov.iter().zip(alone.iter()).all(|(a, b)| a.to_bits() == b.to_bits()), "{id:?}");
    }
    assert_eq!(batched[ids.iter().position(|&i| i == all[3]).unwrap()].amax(), 0.0);
}

/// The interleaved forward solves of a variable's d columns give, bit for bit, what d solves
/// of one right-hand side each give (3 and 6 columns, supernodal and simplicial factors; the
/// unit right-hand sides start with zeros, so columns that are all zero are skipped and columns
/// with some zero entries subtract l · 0 from those).
#[test]
fn interleaved_solves_equal_one_at_a_time_bit_for_bit() {
    let (graph, values, all) = supernodal_example();
    let (chain_graph, chain_values, chain_poses, chain_lms) = {
        let poses: Vec<Se3> = (0..6).map(|k| se3([k as f64, 0.2, 0.0], [0.0, 0.1, 0.3 * k as f64])).collect();
        let lms: Vec<Vector3<f64>> = (0..4).map(|k| Vector3::new(k as f64, 3.0, 1.0)).collect();
        pose_chain_with_landmarks(&poses, &lms, Matrix6::identity() * 7.0, 0.2, |k, j| (k + j) % 2 == 0)
    };
    let chain_all: Vec<VarId> = chain_poses.iter().chain(&chain_lms).copied().collect();
    for (graph, values, ids, supernodal) in [(&graph, &values, &all, true), (&chain_graph, &chain_values, &chain_all, false)] {
        let m = Marginals::new(graph, values, Factorisation::Fastest).unwrap();
        assert_eq!(m.is_supernodal(), supernodal);
        let n = m.system.dim();
        let inv = m.system.factor_parts().0.perm().map(|p| p.arrays().1);
        let (mut on_path, mut path) = (vec![false; m.parent.len()], Vec::new());
        for &id in ids {
            let (d, c) = (m.dims[id.0], m.system.column_of(id).unwrap());
            let permuted = |a: usize| inv.map_or(c + a, |inv| inv[c + a]);
            let mut x = vec![0.0; n * MAX_RHS];
            let mut one_at_a_time = vec![vec![0.0; n]; d];
            for a in 0..d {
                x[permuted(a) * MAX_RHS + a] = 1.0;
                one_at_a_time[a][permuted(a)] = 1.0;
            }
            m.collect_path((0..d).map(permuted), &mut on_path, &mut path);
            for &s in &path {
                forward_node(&m.node(s), &mut x, 0..d, MAX_RHS);
                for y in &mut one_at_a_time {
                    forward_node(&m.node(s), y, 0..1, 1);
                }
                on_path[s] = false;
            }
            for (a, y) in one_at_a_time.iter().enumerate() {
                for (r, v) in y.iter().enumerate() {
                    assert_eq!(x[r * MAX_RHS + a].to_bits(), v.to_bits(), "{id:?} column {a} row {r}");
                }
            }
        }
    }
}
