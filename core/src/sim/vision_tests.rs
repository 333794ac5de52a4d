//! The SLAM that can fail: the same driven path over texture-rich and texture-free ground, with
//! and without wrong associations, with and without the robust kernel (the landmark smoother),
//! with and without the closure rejection (the pose graph).

use super::localisation::new_localiser;
use super::robot::Twist;
use super::world::{World, WorldSpec};
use super::{Localisation, MissionParams, WorldSim};
use crate::params::Params;
use crate::slam::RobustKernel;

/// A flat 16 m square world whose ground has landmarks with probability `texture` per 10 cm
/// lattice site everywhere (contrast 0: one texture level), no rocks.
fn flat_world(params: &Params, texture: f64) -> World {
    let toml = format!(
        "name = \"flat\"\nstart = [3.0, 3.0, 0.0]\n[terrain]\nkind = \"procedural\"\nseed = 1\nsize_m = 16.0\n\
         [landmarks]\nmax_probability = {texture}\ncontrast = 0.0\n"
    );
    let spec = WorldSpec::from_toml(&toml, "flat.toml").unwrap();
    World::build(&spec, &params.traversability, params.traversability.tau, |n| Err(format!("no file {n}"))).unwrap()
}

/// What one drive of the path gave: the final pose covariance trace (position block, m²), the
/// RMS position error over the control ticks, metres, and the localiser's counters.
struct Drive {
    final_pos_trace: f64,
    ate_rms_m: f64,
    stats: super::localisation::LocalisationStats,
}

/// Drives a 6 m square (four sides, four 90° turns in place) with the landmark smoother.
fn drive_square(world: World, mp: &MissionParams, seed: u64) -> Drive {
    drive_square_with(Localisation::Slam, world, mp, seed)
}

/// … with `localisation`.
fn drive_square_with(localisation: Localisation, world: World, mp: &MissionParams, seed: u64) -> Drive {
    let params = Params::default();
    let mut sim = WorldSim::new(world, mp, &params, seed);
    let mut loc = new_localiser(localisation, &mut sim, &mp.slam, seed).unwrap();
    let dt = mp.dt_s;
    let side = [(Twist { v_mps: 0.4, omega_radps: 0.0 }, 15.0), (Twist { v_mps: 0.0, omega_radps: 0.5 }, std::f64::consts::PI)];
    let (mut sq, mut n) = (0.0, 0usize);
    for _ in 0..4 {
        for (cmd, duration_s) in side {
            for _ in 0..(duration_s / dt).round() as usize {
                let motion = sim.drive(cmd, dt);
                loc.propagate(&mut sim, &motion, dt);
                loc.keyframe(&mut sim);
                let (est, truth) = (loc.body_pose(&sim).0, sim.body_pose().0);
                sq += (est - truth).norm_squared();
                n += 1;
            }
        }
    }
    Drive { final_pos_trace: loc.covariance().pos_trace, ate_rms_m: (sq / n as f64).sqrt(), stats: loc.stats() }
}

#[test]
fn texture_free_ground_loses_tracking_and_the_covariance_grows_far_faster() {
    for localisation in [Localisation::Slam, Localisation::PoseGraph] {
        texture_free_ground_loses_tracking(localisation);
    }
}

fn texture_free_ground_loses_tracking(localisation: Localisation) {
    let params = Params::default();
    let mp = MissionParams::default();
    let rich = drive_square_with(localisation, flat_world(&params, 0.3), &mp, 1);
    let bare = drive_square_with(localisation, flat_world(&params, 0.0), &mp, 1);
    // Rich ground tracks all the way; bare ground never sees a landmark: lost from the first
    // keyframe, on wheel odometry for the whole drive.
    assert_eq!(rich.stats.tracking.losses, 0, "{:?}", rich.stats);
    assert!(rich.stats.landmarks_mapped > 100);
    assert_eq!((bare.stats.tracking.losses, bare.stats.landmarks_mapped), (1, 0), "{:?}", bare.stats);
    assert!(bare.stats.tracking.lost_s > 60.0, "{:?}", bare.stats.tracking);
    let ratio = bare.final_pos_trace / rich.final_pos_trace;
    assert!(ratio >= 10.0, "{localisation}: bare {:.3e} vs rich {:.3e} m²: ratio {ratio:.1}", bare.final_pos_trace, rich.final_pos_trace);
    if localisation == Localisation::PoseGraph {
        // Rich ground: visual odometry links nearly every keyframe and the return to the start
        // closes the loop; bare ground: the wheels link them all.
        let (r, b) = (rich.stats.links, bare.stats.links);
        assert!(r.visual_links > 10 * r.wheel_links.max(1) && r.closures_accepted > 0, "{r:?}");
        assert!(b.visual_links == 0 && b.wheel_links > 30 && b.closures_accepted == 0, "{b:?}");
    }
}

/// Place recognition fooled at every fifth keyframe (aliasing): the gate rejects the wrong
/// closures and the estimate stays as good as without them; without the gate they are accepted
/// and corrupt it.
#[test]
fn the_closure_gate_catches_wrong_loop_closures() {
    let params = Params::default();
    let run = |false_closure_rate: f64, gate_chi2: f64| {
        let mut mp = MissionParams::default();
        mp.slam.pose_graph.false_closure_rate = false_closure_rate;
        mp.slam.pose_graph.closure_gate_chi2 = gate_chi2;
        drive_square_with(Localisation::PoseGraph, flat_world(&params, 0.3), &mp, 5)
    };
    let gate = MissionParams::default().slam.pose_graph.closure_gate_chi2;
    assert!(gate > 0.0);
    let clean = run(0.0, gate);
    let gated = run(0.2, gate);
    let open = run(0.2, 0.0);
    assert_eq!(clean.stats.links.false_closures, 0);
    let (g, o) = (gated.stats.links, open.stats.links);
    assert!(g.false_closures >= 5 && o.false_closures >= 5, "{g:?} {o:?}");
    assert!(g.false_closures_accepted * 5 <= g.false_closures, "the gate let most through: {g:?}");
    assert_eq!(o.false_closures_accepted, o.false_closures, "{o:?}");
    assert!(g.closures_accepted > g.false_closures_accepted, "true closures kept: {g:?}");
    assert!(gated.ate_rms_m <= 2.0 * clean.ate_rms_m, "gated: {:.4} m vs {:.4} m without aliasing", gated.ate_rms_m, clean.ate_rms_m);
    assert!(open.ate_rms_m > 2.0 * clean.ate_rms_m, "no gate: {:.4} m vs {:.4} m without aliasing", open.ate_rms_m, clean.ate_rms_m);
}

#[test]
fn the_robust_kernel_keeps_wrong_associations_out_of_the_estimate() {
    let params = Params::default();
    let run = |outlier_rate: f64, kernel: RobustKernel| {
        let mut mp = MissionParams::default();
        mp.vision.outlier_rate = outlier_rate;
        mp.slam.graph.observation_kernel = kernel;
        drive_square(flat_world(&params, 0.3), &mp, 3)
    };
    let kernel = MissionParams::default().slam.graph.observation_kernel;
    assert!(kernel != RobustKernel::None);
    let default_rate = super::vision::VisionParams::default().outlier_rate;
    let clean = run(0.0, kernel);
    let robust = run(default_rate, kernel);
    let plain = run(default_rate, RobustKernel::None);
    assert_eq!(clean.stats.wrong_associations, 0);
    assert!(robust.stats.wrong_associations > 20, "{:?}", robust.stats);
    assert!(
        robust.ate_rms_m <= 2.0 * clean.ate_rms_m,
        "with the kernel: {:.4} m vs {:.4} m without wrong matches",
        robust.ate_rms_m,
        clean.ate_rms_m
    );
    assert!(
        plain.ate_rms_m > 2.0 * clean.ate_rms_m,
        "without the kernel: {:.4} m vs {:.4} m without wrong matches",
        plain.ate_rms_m,
        clean.ate_rms_m
    );
}
