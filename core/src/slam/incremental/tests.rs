//! iSAM2 against batch Levenberg-Marquardt and against a dense inverse of the information
//! matrix (computed here with nalgebra from the factors' Jacobians, independently of the Bayes
//! tree), on small 2D and 3D graphs with loop closures and landmarks.

use nalgebra::{DMatrix, Vector2, Vector3, Vector6};
use proptest::prelude::*;

use super::*;
use crate::slam::factors::{BetweenSe2, BetweenSe3, GaussianNoise, PointObservation2, PointObservation3, PriorSe2, PriorSe3};
use crate::slam::lie::{Se2, Se3};
use crate::slam::optimizer::{LevenbergMarquardt, Optimizer, OptimizerParams};

/// A factor of a test graph, buildable twice (once for the batch graph, once for iSAM2).
#[derive(Clone, Copy, Debug)]
enum Spec {
    Prior2(usize, Se2),
    Between2(usize, usize, Se2),
    Point2(usize, usize, Vector2<f64>),
    Prior3(usize, Se3),
    Between3(usize, usize, Se3),
    Point3(usize, usize, Vector3<f64>),
}

impl Spec {
    fn build(&self) -> Box<dyn Factor> {
        let n3 = GaussianNoise::from_sigmas(&[0.05, 0.05, 0.02]).unwrap();
        let n6 = GaussianNoise::from_sigmas(&[0.05, 0.05, 0.05, 0.02, 0.02, 0.02]).unwrap();
        let p2 = GaussianNoise::isotropic(2, 0.1).unwrap();
        let p3 = GaussianNoise::isotropic(3, 0.1).unwrap();
        let prior3 = GaussianNoise::isotropic(3, 1e-3).unwrap();
        let prior6 = GaussianNoise::isotropic(6, 1e-3).unwrap();
        match *self {
            Spec::Prior2(a, z) => Box::new(PriorSe2::new(VarId(a), z, prior3)),
            Spec::Between2(a, b, z) => Box::new(BetweenSe2::new(VarId(a), VarId(b), z, n3)),
            Spec::Point2(a, l, z) => Box::new(PointObservation2::new(VarId(a), VarId(l), z, p2)),
            Spec::Prior3(a, z) => Box::new(PriorSe3::new(VarId(a), z, prior6)),
            Spec::Between3(a, b, z) => Box::new(BetweenSe3::new(VarId(a), VarId(b), z, n6)),
            Spec::Point3(a, l, z) => Box::new(PointObservation3::new(VarId(a), VarId(l), z, p3)),
        }
    }

    /// Whether the factor fully determines its variables not yet `known`: a between factor with
    /// one end known, a point observation from a known pose.
    fn admissible(&self, known: &[bool]) -> bool {
        match *self {
            Spec::Prior2(..) | Spec::Prior3(..) => true,
            Spec::Between2(a, b, _) | Spec::Between3(a, b, _) => known[a] || known[b],
            Spec::Point2(a, _, _) | Spec::Point3(a, _, _) => known[a],
        }
    }

    fn keys(&self) -> Vec<usize> {
        match *self {
            Spec::Prior2(a, _) | Spec::Prior3(a, _) => vec![a],
            Spec::Between2(a, b, _) | Spec::Point2(a, b, _) | Spec::Between3(a, b, _) | Spec::Point3(a, b, _) => vec![a, b],
        }
    }
}

/// A deterministic pseudo-random number in [-1, 1).
fn wobble(i: usize, k: usize) -> f64 {
    ((i * 31 + k * 17) as f64 * 0.618_033_988_7).fract() * 2.0 - 1.0
}

/// Poses on a circle (ids 0..n), odometry, loop closures every few poses and landmarks seen
/// from several poses; the initial values are the ground truth perturbed (odometry drift).
fn graph_2d(n: usize) -> (Vec<Variable>, Vec<Spec>) {
    let truth: Vec<Se2> = (0..n)
        .map(|i| {
            let a = i as f64 * 0.5;
            Se2::new(4.0 * libm::cos(a), 4.0 * libm::sin(a), a + std::f64::consts::FRAC_PI_2)
        })
        .collect();
    let mut vars: Vec<Variable> = truth
        .iter()
        .enumerate()
        .map(|(i, p)| Variable::Se2(p.retract(&nalgebra::Vector3::new(0.1 * wobble(i, 0), 0.1 * wobble(i, 1), 0.05 * wobble(i, 2)))))
        .collect();
    let noisy = |i: usize, j: usize, s: f64| {
        truth[i].between(&truth[j]).retract(&nalgebra::Vector3::new(s * wobble(i, j), s * wobble(j, i), 0.3 * s * wobble(i + j, 3)))
    };
    let mut specs = vec![Spec::Prior2(0, truth[0])];
    for i in 1..n {
        specs.push(Spec::Between2(i - 1, i, noisy(i - 1, i, 0.02)));
        if i >= 12 && i % 4 == 0 {
            specs.push(Spec::Between2(i - 12, i, noisy(i - 12, i, 0.02)));
        }
    }
    let landmarks = [Vector2::new(0.5, 0.3), Vector2::new(-1.0, 2.0), Vector2::new(2.0, -1.5)];
    for (k, l) in landmarks.iter().enumerate() {
        let id = vars.len();
        vars.push(Variable::Point2(l + Vector2::new(0.2, -0.1)));
        for i in (k..n).step_by(5) {
            let z = truth[i].inverse_transform_point(l) + Vector2::new(0.01 * wobble(i, k), 0.01 * wobble(k, i));
            specs.push(Spec::Point2(i, id, z));
        }
    }
    (vars, specs)
}

/// The 3D counterpart: a helix with closures and point landmarks.
fn graph_3d(n: usize) -> (Vec<Variable>, Vec<Spec>) {
    let truth: Vec<Se3> = (0..n)
        .map(|i| {
            let a = i as f64 * 0.5;
            Se3::exp(&Vector6::new(4.0 * libm::cos(a), 4.0 * libm::sin(a), 0.1 * i as f64, 0.05, -0.03, a))
        })
        .collect();
    let tangent = |i: usize, j: usize, s: f64| Vector6::from_fn(|r, _| s * wobble(i * 6 + r, j));
    let mut vars: Vec<Variable> = truth.iter().enumerate().map(|(i, p)| Variable::Se3(p.retract(&tangent(i, 1, 0.05)))).collect();
    let noisy = |i: usize, j: usize| truth[i].between(&truth[j]).retract(&tangent(i, j, 0.01));
    let mut specs = vec![Spec::Prior3(0, truth[0])];
    for i in 1..n {
        specs.push(Spec::Between3(i - 1, i, noisy(i - 1, i)));
        if i >= 12 && i % 3 == 0 {
            specs.push(Spec::Between3(i - 12, i, noisy(i - 12, i)));
        }
    }
    let landmarks = [Vector3::new(0.5, 0.3, 1.0), Vector3::new(-1.0, 2.0, 0.2)];
    for (k, l) in landmarks.iter().enumerate() {
        let id = vars.len();
        vars.push(Variable::Point3(l + Vector3::new(0.2, -0.1, 0.1)));
        for i in (k..n).step_by(4) {
            let z = truth[i].inverse_transform_point(l) + Vector3::new(0.01 * wobble(i, k), 0.01 * wobble(k, i), 0.005);
            specs.push(Spec::Point3(i, id, z));
        }
    }
    (vars, specs)
}

fn batch(vars: &[Variable], specs: &[Spec]) -> (FactorGraph, Values) {
    let mut graph = FactorGraph::new();
    let mut values = Values::new();
    for v in vars {
        values.push(*v);
    }
    for s in specs {
        graph.add_boxed(s.build()).unwrap();
    }
    let params = OptimizerParams { relative_tolerance: 1e-14, max_iterations: 200, ..OptimizerParams::default() };
    LevenbergMarquardt::new(params).optimize(&graph, &mut values).unwrap();
    (graph, values)
}

/// Exact parameters: every clique back-substituted, every moved variable relinearised.
fn exact() -> Isam2Params {
    Isam2Params { relinearize_threshold: 0.0, relinearize_skip: 1, wildfire_threshold: 0.0, ..Isam2Params::default() }
}

/// Replays `specs` in the given batches: a variable enters (at its value in `vars`, ids renumbered
/// by first appearance) with the first batch that mentions it. Returns the solver and the new id
/// of every original variable.
fn replay(vars: &[Variable], specs: &[Spec], batches: &[Vec<usize>], params: Isam2Params) -> (Isam2, Vec<usize>) {
    let mut isam = Isam2::new(params);
    let mut new_id = vec![NONE; vars.len()];
    for batch in batches {
        let mut new_vars = Vec::new();
        for &f in batch {
            for k in specs[f].keys() {
                if new_id[k] == NONE {
                    new_id[k] = isam.len() + new_vars.len();
                    new_vars.push(vars[k]);
                }
            }
        }
        let factors = batch.iter().map(|&f| renumber(&specs[f], &new_id).build()).collect();
        isam.update(&new_vars, factors).unwrap();
    }
    (isam, new_id)
}

fn renumber(s: &Spec, id: &[usize]) -> Spec {
    match *s {
        Spec::Prior2(a, z) => Spec::Prior2(id[a], z),
        Spec::Between2(a, b, z) => Spec::Between2(id[a], id[b], z),
        Spec::Point2(a, b, z) => Spec::Point2(id[a], id[b], z),
        Spec::Prior3(a, z) => Spec::Prior3(id[a], z),
        Spec::Between3(a, b, z) => Spec::Between3(id[a], id[b], z),
        Spec::Point3(a, b, z) => Spec::Point3(id[a], id[b], z),
    }
}

/// Empty updates until the step vanishes (iSAM2 run to convergence: Gauss-Newton on the tree).
fn converge(isam: &mut Isam2) {
    for _ in 0..50 {
        isam.update(&[], Vec::new()).unwrap();
        if (0..isam.len()).all(|v| isam.delta_of(VarId(v)).iter().all(|x| x.abs() < 1e-12)) {
            return;
        }
    }
    panic!("iSAM2 did not converge in 50 empty updates");
}

/// Largest tangent difference between two values of the same variable.
fn distance(a: &Variable, b: &Variable) -> f64 {
    match (a, b) {
        (Variable::Se2(p), Variable::Se2(q)) => p.local(q).amax(),
        (Variable::Se3(p), Variable::Se3(q)) => p.local(q).amax(),
        (Variable::Point2(p), Variable::Point2(q)) => (p - q).amax(),
        (Variable::Point3(p), Variable::Point3(q)) => (p - q).amax(),
        _ => f64::INFINITY,
    }
}

/// Dense information matrix Σ JᵀΩJ of `graph` at `values`, with each variable's block at the sum
/// of the dimensions before it.
fn dense_information(graph: &FactorGraph, values: &Values) -> (DMatrix<f64>, Vec<usize>) {
    let mut offsets = Vec::new();
    let mut n = 0;
    for (_, v) in values.iter() {
        offsets.push(n);
        n += v.dim();
    }
    let mut h = DMatrix::zeros(n, n);
    for f in graph.factors() {
        let mut jac = [Jacobian::zeros(); MAX_FACTOR_KEYS];
        f.linearize(values, &mut jac).unwrap();
        let d = f.residual_dim();
        let info = f.noise().information().view((0, 0), (d, d)).into_owned();
        for (p, kp) in f.keys().iter().enumerate() {
            for (q, kq) in f.keys().iter().enumerate() {
                let (dp, dq) = (values.get(*kp).unwrap().dim(), values.get(*kq).unwrap().dim());
                let jp = jac[p].view((0, 0), (d, dp));
                let jq = jac[q].view((0, 0), (d, dq));
                let block = jp.transpose() * &info * jq;
                let mut target = h.view_mut((offsets[kp.0], offsets[kq.0]), (dp, dq));
                target += block;
            }
        }
    }
    (h, offsets)
}

/// The estimate after convergence equals batch LM's, and every marginal (poses and landmarks)
/// the dense inverse's, to 1e-6 (relative for covariances).
fn check_against_batch(vars: &[Variable], specs: &[Spec], batches: &[Vec<usize>]) {
    check_against_batch_with(vars, specs, batches, exact());
}

fn check_against_batch_with(vars: &[Variable], specs: &[Spec], batches: &[Vec<usize>], params: Isam2Params) -> Isam2 {
    let (graph, optimum) = batch(vars, specs);
    let (mut isam, id) = replay(vars, specs, batches, params);
    converge(&mut isam);
    let estimate = isam.estimate();
    for (v, &nv) in id.iter().enumerate() {
        let d = distance(optimum.get(VarId(v)).unwrap(), estimate.get(VarId(nv)).unwrap());
        assert!(d < 1e-6, "variable {v}: {d:e} from the batch optimum");
    }
    let chi2_batch = graph.chi2(&optimum).unwrap();
    assert!((isam.chi2().unwrap() - chi2_batch).abs() <= 1e-6 * chi2_batch.max(1.0));
    let (h, offsets) = dense_information(&graph, &optimum);
    let cov = h.try_inverse().unwrap();
    for (v, &nv) in id.iter().enumerate() {
        let d = vars[v].dim();
        let expected = cov.view((offsets[v], offsets[v]), (d, d));
        let ours = isam.marginal_covariance(VarId(nv)).unwrap();
        let err = (&ours - expected).amax() / expected.amax();
        assert!(err < 1e-6, "variable {v}: marginal off by {err:e} (relative)");
    }
    // All at once (the clique joints shared along the paths): the same blocks, in order.
    let all: Vec<VarId> = id.iter().rev().map(|&nv| VarId(nv)).collect();
    for (k, ours) in isam.marginal_covariances(&all).unwrap().iter().enumerate() {
        let v = id.len() - 1 - k;
        let d = vars[v].dim();
        let expected = cov.view((offsets[v], offsets[v]), (d, d));
        let err = (ours - expected).amax() / expected.amax();
        assert!(err < 1e-6, "variable {v}, in the batch call: marginal off by {err:e} (relative)");
    }
    isam
}

/// Relaxed supernodes (cliques absorbing children whose separators they only contain) change
/// the tree, not the solution: with the thresholds low enough to merge on a small 3D graph, the
/// same optimum and marginals as the batch solver, in fewer cliques.
#[test]
fn relaxed_supernodes_keep_the_batch_solution_in_fewer_cliques() {
    let (vars, specs) = graph_3d(30);
    let batches = per_pose(&specs, 30);
    let strict = check_against_batch_with(&vars, &specs, &batches, Isam2Params { relax_max_frontal: 0, ..exact() });
    let relaxed =
        check_against_batch_with(&vars, &specs, &batches, Isam2Params { relax_min_separator: 6, relax_max_frontal: 24, ..exact() });
    let cliques = |i: &Isam2| i.cliques.iter().flatten().count();
    assert!(cliques(&relaxed) < cliques(&strict), "{} relaxed vs {} strict cliques", cliques(&relaxed), cliques(&strict));
}

/// One update per pose, in pose order, with the factors whose later end it is (the CLI's
/// replay order); landmarks enter with their first observation.
fn per_pose(specs: &[Spec], poses: usize) -> Vec<Vec<usize>> {
    let mut batches = vec![Vec::new(); poses];
    for (f, s) in specs.iter().enumerate() {
        let pose = s.keys().into_iter().filter(|&k| k < poses).max().unwrap_or(0);
        batches[pose].push(f);
    }
    batches
}

#[test]
fn incremental_2d_matches_batch_and_the_dense_inverse() {
    let (vars, specs) = graph_2d(30);
    check_against_batch(&vars, &specs, &per_pose(&specs, 30));
}

#[test]
fn incremental_3d_matches_batch_and_the_dense_inverse() {
    let (vars, specs) = graph_3d(30);
    check_against_batch(&vars, &specs, &per_pose(&specs, 30));
}

#[test]
fn the_newest_pose_is_in_the_root_clique() {
    let (vars, specs) = graph_2d(30);
    let batches = per_pose(&specs, 30);
    let mut isam = Isam2::new(Isam2Params::default());
    let mut next = 0;
    for (pose, batch) in batches.iter().enumerate() {
        let mut new_vars = Vec::new();
        // Poses keep their ids; this test has no landmarks past the poses' updates.
        while next <= pose {
            new_vars.push(vars[next]);
            next += 1;
        }
        let factors = batch.iter().filter(|&&f| specs[f].keys().iter().all(|&k| k < 30)).map(|&f| specs[f].build()).collect();
        let report = isam.update(&new_vars, factors).unwrap();
        assert!(isam.root_variables().contains(&VarId(pose)), "pose {pose} not in the root");
        // Only the top is re-eliminated: odometry-only steps without relinearisation touch a
        // few variables.
        if pose > 12 && batch.len() == 1 && report.relinearized == 0 {
            assert!(report.reeliminated < pose / 2, "pose {pose}: {} re-eliminated", report.reeliminated);
        }
    }
}

/// GTSAM's relinearisation rule: a variable whose step reaches the threshold moves its
/// linearisation point to θ ⊕ Δ, only on every `relinearize_skip`-th update.
#[test]
fn variables_are_relinearised_when_their_step_reaches_the_threshold() {
    let far = Se2::new(1.0, 0.0, 0.0);
    let params = Isam2Params { relinearize_threshold: 0.5, relinearize_skip: 2, wildfire_threshold: 0.0, ..Isam2Params::default() };
    let mut isam = Isam2::new(params);
    // Pose 0 initialised at the origin with a prior at x = 1: a step of 1 m.
    let r = isam.update(&[Variable::Se2(Se2::identity())], vec![Spec::Prior2(0, far).build()]).unwrap();
    assert_eq!(r.relinearized, 0);
    assert!((isam.delta_of(VarId(0))[0] - 1.0).abs() < 1e-9);
    // Update 2 (a multiple of the skip) checks: pose 0's step of 1 m is relinearised; pose 1
    // enters with odometry 0.2 m at 1.1 (its step, about 0.1, is below the threshold anyway).
    let odo = Spec::Between2(0, 1, Se2::new(0.2, 0.0, 0.0));
    let r = isam.update(&[Variable::Se2(Se2::new(1.1, 0.0, 0.0))], vec![odo.build()]).unwrap();
    assert_eq!(r.relinearized, 1);
    assert!(distance(&isam.linearization_point().get(VarId(0)).copied().unwrap(), &Variable::Se2(far)) < 1e-9);
    assert!(isam.delta_of(VarId(0)).iter().all(|x| x.abs() < 1e-9));
    assert!((isam.delta_of(VarId(1))[0] - 0.1).abs() < 1e-9);
    let before = isam.estimate();
    let r = isam.update(&[], Vec::new()).unwrap();
    assert_eq!(r.relinearized, 0, "update 3 is not a multiple of the skip");
    let r = isam.update(&[], Vec::new()).unwrap();
    assert_eq!(r.relinearized, 0, "at update 4 no step reaches 0.5");
    assert!(distance(&isam.linearization_point().get(VarId(1)).copied().unwrap(), &Variable::Se2(Se2::new(1.1, 0.0, 0.0))) < 1e-12);
    // The estimate does not move: the problem is linear in x.
    let after = isam.estimate();
    for v in 0..2 {
        assert!(distance(before.get(VarId(v)).unwrap(), after.get(VarId(v)).unwrap()) < 1e-9);
    }
    // A threshold nothing reaches never relinearises: θ stays at the initial values.
    let (vars, specs) = graph_2d(20);
    let never = Isam2Params { relinearize_threshold: 1e9, relinearize_skip: 1, wildfire_threshold: 0.0, ..Isam2Params::default() };
    let (isam, id) = replay(&vars, &specs, &per_pose(&specs, 20), never);
    for (v, &nv) in id.iter().enumerate() {
        assert_eq!(isam.linearization_point().get(VarId(nv)), Some(&vars[v]));
    }
}

/// Wildfire: with a threshold, back-substitution skips cliques; the estimate stays close to the
/// exact one, and running to convergence still reaches the batch optimum.
#[test]
fn partial_back_substitution_stays_near_the_exact_step() {
    let (vars, specs) = graph_2d(30);
    let batches = per_pose(&specs, 30);
    let wild = Isam2Params { wildfire_threshold: 1e-3, ..exact() };
    let (a, _) = replay(&vars, &specs, &batches, wild);
    let (b, _) = replay(&vars, &specs, &batches, exact());
    let (ea, eb) = (a.estimate(), b.estimate());
    for v in 0..a.len() {
        assert!(distance(ea.get(VarId(v)).unwrap(), eb.get(VarId(v)).unwrap()) < 0.05);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Any order of the factors, in any batching, reaches the batch optimum and marginals.
    #[test]
    fn random_update_orders_give_the_batch_answer(
        seed in 0u64..1000,
        three_d in any::<bool>(),
        batch_size in 1usize..6,
    ) {
        let (vars, specs) = if three_d { graph_3d(16) } else { graph_2d(16) };
        // A seeded shuffle (xorshift) of the factors; a factor waits until it determines its new
        // variable (as a SLAM front end's updates do: a part without an anchor has no estimate).
        let mut shuffled: Vec<usize> = (1..specs.len()).collect();
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407) | 1;
        for i in (1..shuffled.len()).rev() {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            shuffled.swap(i, (state % (i as u64 + 1)) as usize);
        }
        let mut known = vec![false; vars.len()];
        known[0] = true;
        let mut order = vec![0];
        while !shuffled.is_empty() {
            let next = shuffled.iter().position(|&f| specs[f].admissible(&known)).unwrap();
            let f = shuffled.remove(next);
            for k in specs[f].keys() {
                known[k] = true;
            }
            order.push(f);
        }
        let batches: Vec<Vec<usize>> = order.chunks(batch_size).map(<[usize]>::to_vec).collect();
        check_against_batch(&vars, &specs, &batches);
    }
}

/// Wildfire on a real graph: a clique whose separator holds a variable that changed higher up is
/// solved again even when its parent's frontals did not change (GTSAM's `isDirty`). Replaying
/// intel.g2o at GTSAM's default thresholds then ends within 2e-3 of the χ² of the same replay with
/// every clique back-substituted (a walk that stopped at unchanged parents ended 3.4e-3 above).
#[test]
fn wildfire_follows_changed_separators_on_a_real_graph() {
    use crate::slam::g2o::read_g2o;
    use crate::slam::{G2oReplay, Se2Residual};
    let bytes = std::fs::read(format!("{}/../assets/data/slam/intel.g2o", env!("CARGO_MANIFEST_DIR"))).unwrap();
    let file = read_g2o(&bytes).unwrap();
    let chi2 = |wildfire_threshold: f64| {
        let mut replay = G2oReplay::new(&file, Se2Residual::Log, 1e-3).unwrap();
        let mut isam = Isam2::new(Isam2Params { wildfire_threshold, ..Isam2Params::default() });
        while replay.step(&mut isam).unwrap().is_some() {}
        isam.chi2().unwrap()
    };
    let (partial, full) = (chi2(1e-3), chi2(0.0));
    assert!((partial - full).abs() / full < 2e-3, "partial {partial} vs full {full}");
}

/// GTSAM's batch step: on an odometry chain (its cliques a chain too) a loop closure from the
/// newest pose to pose 10 of 30 has a top of 20 variables, more than 65 %: the whole graph is
/// re-ordered and re-eliminated, and the answer stays the batch one.
#[test]
fn a_top_of_most_of_the_graph_is_re_eliminated_whole() {
    let (vars, all) = graph_2d(30);
    let mut specs: Vec<Spec> =
        all.into_iter().filter(|s| matches!(s, Spec::Prior2(..)) || matches!(s, Spec::Between2(i, j, _) if j == &(i + 1))).collect();
    let batches = per_pose(&specs, 30);
    let (mut isam, id) = replay(&vars, &specs, &batches, exact());
    let n = isam.len();
    // The top an incremental step would take: the cliques from pose 10's to the root.
    let mut top = 0;
    let mut at = Some(isam.clique_of[id[10]]);
    while let Some(c) = at {
        let clique = isam.cliques[c].as_ref().unwrap();
        top += clique.frontals.len();
        at = clique.parent;
    }
    assert!(top * 100 >= 65 * n && top < n, "the case needs a large, partial top: {top} of {n}");
    specs.push(Spec::Between2(10, 29, Se2::new(0.3, -0.5, -0.2)));
    let closure = renumber(&specs[specs.len() - 1], &id).build();
    // Without relinearisation in this update, which would mark every variable that moved.
    isam.params.relinearize_skip = 0;
    let report = isam.update(&[], vec![closure]).unwrap();
    assert_eq!((report.relinearized, report.reeliminated), (0, n));
    isam.params = exact();
    converge(&mut isam);
    let (_, optimum) = batch(&vars[..30], &specs);
    let estimate = isam.estimate();
    for (v, &nv) in id.iter().enumerate().take(30) {
        let d = distance(optimum.get(VarId(v)).unwrap(), estimate.get(VarId(nv)).unwrap());
        assert!(d < 1e-6, "variable {v}: {d:e} from the batch optimum");
    }
}
