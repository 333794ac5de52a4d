//! Parameter defaults, ranges and files.

use super::check::MAX_RAYS;
use super::*;

/// Messages print a value as Rust does, but huge and tiny ones in scientific notation.
#[test]
fn messages_print_numbers_short() {
    let shown = |v: f64| Num(v).to_string();
    assert_eq!(shown(0.25), "0.25");
    assert_eq!(shown(-3.0), "-3");
    assert_eq!(shown(0.0), "0");
    assert_eq!(shown(123456789.0), "123456789");
    assert_eq!(shown(1e9), "1e9");
    assert_eq!(shown(-1e300), "-1e300");
    assert_eq!(shown(1.5e-5), "1.5e-5");
    assert_eq!(shown(1e-4), "0.0001");
    assert_eq!((shown(f64::NAN), shown(f64::INFINITY)), ("NaN".to_string(), "inf".to_string()));
    assert_eq!(check_non_negative("x", -1e300).unwrap_err().to_string(), "x must be a finite number ≥ 0 (got -1e300)");
}

#[test]
fn defaults_are_the_papers() {
    let p = Params::default();
    assert_eq!(p.u1.alpha, 0.35);
    assert_eq!(p.u2.beta, 0.4);
    assert!((p.u1.delta_theta_rad.to_degrees() - 8.5).abs() < 1e-12);
    assert_eq!(p.u2.top_n, 7);
    assert_eq!(p.grid.resolution_m, 0.05);
    assert_eq!(p.u2.voxel_m, 0.25);
    assert!((p.camera.hfov_rad.to_degrees() - 87.0).abs() < 1e-12);
    assert!(p.validate().is_ok());
}

/// Values whose work or memory has no useful bound are rejected (they hung or aborted a
/// decision: 1e-9 rad between rays asked for 6e9 rays).
#[test]
fn values_beyond_the_work_bounds_are_rejected() {
    let check = |edit: fn(&mut Params), needle: &str| {
        let mut p = Params::default();
        edit(&mut p);
        let e = p.validate().unwrap_err().to_string();
        assert!(e.contains(needle), "{e}");
    };
    check(|p| p.u1.delta_theta_rad = 1e-9, "at most 4096 rays");
    check(|p| p.robot.radius_m = 50.01, "robot.radius_m (50.01 m) is 1000 cells");
    check(|p| p.traversability.disc_radius_m = 1e6, "traversability.disc_radius_m");
    check(|p| p.u2.waypoint_spacing_m = Some(0.04), "at least a grid cell (0.05 m)");
    // The bounds themselves are allowed.
    let mut p = Params::default();
    p.u1.delta_theta_rad = std::f64::consts::TAU / MAX_RAYS as f64;
    p.robot.radius_m = 49.99;
    p.u2.waypoint_spacing_m = Some(0.05);
    assert_eq!(p.validate(), Ok(()));
}

#[test]
fn toml_and_yaml_round_trip() {
    let mut p = Params::default();
    p.u1.alpha = 0.5;
    p.selector.strategy = Strategy::Greedy;
    p.u2.waypoint_spacing_m = Some(2.0);
    assert_eq!(*Params::from_toml(&p.to_toml(), "t.toml").unwrap(), p);
    assert_eq!(*Params::from_yaml(&p.to_yaml(), "t.yaml").unwrap(), p);
}

#[test]
fn partial_files_keep_defaults_and_unknown_keys_are_rejected() {
    let p = Params::from_toml("[u1]\nalpha = 0.2\n", "p.toml").unwrap();
    assert_eq!(p.u1.alpha, 0.2);
    assert_eq!(p.u2.beta, 0.4);
    let e = Params::from_toml("[u1]\nalpah = 0.2\n", "p.toml").unwrap_err().to_string();
    assert!(e.contains("p.toml") && e.contains("alpah"), "{e}");
    let e = Params::from_yaml("u2:\n  bta: 0.1\n", "p.yaml").unwrap_err().to_string();
    assert!(e.contains("p.yaml") && e.contains("bta"), "{e}");
    let e = Params::from_toml("[u1]\nalpha = 2.0\n", "p.toml").unwrap_err().to_string();
    assert!(e.contains("u1.alpha"), "{e}");
}

/// `Valid` is only made from checked values, and a tight radius keeps the ranges valid.
#[test]
fn valid_params_are_checked_once_and_stay_valid() {
    let mut p = Params::default();
    p.u1.alpha = 1.5;
    assert_eq!(Valid::new(p).unwrap_err().key, "u1.alpha");
    let v = Valid::new(Params::default()).unwrap();
    let tight = v.with_robot_radius_m(0.1);
    assert_eq!(tight.robot.radius_m, 0.1);
    assert_eq!(tight.validate(), Ok(()));
    // Out of [0, robot.radius_m]: clamped, so still valid.
    assert_eq!(v.with_robot_radius_m(-1.0).robot.radius_m, 0.0);
    assert_eq!(v.with_robot_radius_m(1e9).robot.radius_m, v.robot.radius_m);
    assert_eq!(*Valid::<Params>::default(), Params::default());
}
