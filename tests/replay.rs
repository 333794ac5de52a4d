//! One policy for every face: at each decision instant of a recorded simulated mission,
//! `fitslam select --bag B --at T` answers with the exploration policy's own action on the
//! instant's map, landmarks and pose (`explore::Explorer` from a fresh start: no trail, no goal
//! reached, no blacklist), not with a bare selector's ranking. The studio's recording view makes
//! the same check in studio/tests/recording_ui.rs.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

use fitslam_core::Params;
use fitslam_core::bag::{Bag, BagTopics};
use fitslam_core::explore::{Action, Explorer, Situation};
use fitslam_core::params::Valid;
use fitslam_core::utility::LandmarkVoxels;
use std::path::PathBuf;
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_fitslam");

/// The goal of an explorer's answer as `select --json` writes it: `[x, y, yaw]`, or `null`
/// with the kind of answer.
fn action_goal(action: &Action) -> serde_json::Value {
    match action {
        Action::Goal(plan) | Action::Keep(plan) => serde_json::json!([plan.goal.goal.x_m, plan.goal.goal.y_m, plan.goal.goal.yaw_rad]),
        _ => serde_json::Value::Null,
    }
}

fn number_list(v: &serde_json::Value) -> Vec<f64> {
    v.as_array().map(|a| a.iter().map(|x| x.as_f64().unwrap()).collect()).unwrap_or_default()
}

fn action_kind(action: &Action) -> &'static str {
    match action {
        Action::Goal(_) | Action::Keep(_) => "goal",
        Action::Done(_) => "done",
        Action::Wait(_) => "wait",
        Action::Recover { .. } => "recover",
    }
}

#[test]
fn select_on_a_recorded_mission_answers_as_the_explorer_at_every_decision_instant() {
    let out = std::env::temp_dir().join(format!("fitslam-replay-{}", std::process::id()));
    let bag_path = out.join("mission.mcap");
    let world = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/worlds/tiny_test.toml");
    let o = Command::new(BIN)
        .args(["explore", "--world", world.to_str().unwrap(), "--seed", "3", "--strategy", "fit", "--out"])
        .arg(&out)
        .arg("--bag")
        .arg(&bag_path)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let bag = Bag::parse(&std::fs::read(&bag_path).unwrap(), "mission.mcap").unwrap();
    let topics = BagTopics::default();
    let instants = bag.decision_instants(&topics).unwrap();
    assert!(instants.len() >= 3, "a mission with several decisions: {instants:?}");
    let mut goals = 0;
    for instant in &instants {
        let t_s = instant.t_s;
        // The policy itself, in process, on the instant's inputs.
        let snap = bag.snapshot(&topics, t_s).unwrap();
        let params = Valid::<Params>::default();
        let voxels = LandmarkVoxels::new(&snap.landmarks, params.u2.voxel_m, params.u2.sigma_landmark_m).unwrap();
        let mut explorer = Explorer::new(Valid::default(), params);
        let traced = explorer.decide_traced(&mut snap.map.clone(), &Situation::one_off(&voxels, snap.robot, None));
        // The command line at the same instant.
        let o =
            Command::new(BIN).args(["select", "--bag", bag_path.to_str().unwrap(), "--at", &t_s.to_string(), "--json"]).output().unwrap();
        assert!(o.status.success(), "at {t_s}: {}", String::from_utf8_lossy(&o.stderr));
        let json: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        assert_eq!(json["action"]["kind"], action_kind(&traced.action), "at {t_s}");
        let shown = if json["action"]["kind"] == "goal" { json["action"]["goal"].clone() } else { serde_json::Value::Null };
        let (a, b) = (number_list(&shown), number_list(&action_goal(&traced.action)));
        // serde_json's reader may round a printed f64 by one ulp: equal to 1e-12.
        assert!(
            a.len() == b.len() && a.iter().zip(&b).all(|(x, y)| (x - y).abs() <= 1e-12),
            "at {t_s}: select shows {a:?}, the explorer {b:?}"
        );
        assert_eq!(json["attempts"].as_array().unwrap().len(), traced.attempts.len(), "at {t_s}");
        // The ranking shown is the one the explorer acted on.
        let ranked = traced.decision().map(|d| d.chosen);
        assert_eq!(json["chosen"].as_u64().map(|c| c as usize), ranked.flatten(), "at {t_s}");
        goals += usize::from(!a.is_empty());
    }
    assert!(goals >= 2, "goals at most instants: {goals} of {}", instants.len());
    std::fs::remove_dir_all(&out).ok();
}
