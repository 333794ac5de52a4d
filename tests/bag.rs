//! `fitslam select --bag` and `fitslam bag-info` on rosbag2 MCAP bags written by a third-party
//! writer (PyPI rosbags 0.11.9, zstd chunks; tests/bags/write_bag.py wrote tests/data/*.mcap):
//! at several instants the chosen goal is a free cell of the map the robot had, its path runs
//! over free cells from the robot; bad bags give one error line naming the file and a non-zero
//! exit. `fitslam explore --bag` writes a mission that reads back the same way (and that rosbags
//! reads, when its venv is installed), and at every decision instant of it `select --bag` shows
//! the exploration policy's own answer.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

use fitslam_core::Params;
use fitslam_core::bag::{Bag, BagTopics};
use fitslam_core::explore::{Action, Explorer, Situation};
use fitslam_core::grid::CellClass;
use fitslam_core::params::Valid;
use fitslam_core::utility::LandmarkVoxels;
use std::path::{Path, PathBuf};
use std::process::Command;

const BIN: &str = env!("CARGO_BIN_EXE_fitslam");

fn data(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data").join(name)
}

fn run(args: &[&str]) -> std::process::Output {
    Command::new(BIN).args(args).output().expect("run fitslam")
}

/// Checks the decision `select --bag B --at t --json` makes against the map of the bag at t.
fn check_select(bag_path: &Path, t_s: f64) -> serde_json::Value {
    let p = bag_path.display().to_string();
    let o = run(&["select", "--bag", &p, "--at", &t_s.to_string(), "--json"]);
    assert!(o.status.success(), "at {t_s}: {}", String::from_utf8_lossy(&o.stderr));
    let d: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let bag = Bag::parse(&std::fs::read(bag_path).unwrap(), &p).unwrap();
    let snap = bag.snapshot(&BagTopics::default(), t_s).unwrap();
    let class = |x: f64, y: f64| CellClass::of(*snap.map.at_world(x, y).expect("inside the map"));
    let chosen = d["chosen"].as_u64().unwrap_or_else(|| panic!("at {t_s}: no goal: {d}")) as usize;
    let c = &d["candidates"][chosen];
    assert_eq!(c["rank"], 1);
    let (gx, gy) = (c["x"].as_f64().unwrap(), c["y"].as_f64().unwrap());
    assert_eq!(class(gx, gy), CellClass::Free, "at {t_s}: goal ({gx}, {gy}) not on a free cell");
    let path = c["path"].as_array().unwrap();
    assert!(path.len() >= 2, "at {t_s}: no path");
    let xy = |v: &serde_json::Value| (v[0].as_f64().unwrap(), v[1].as_f64().unwrap());
    let (sx, sy) = xy(&path[0]);
    let robot = (d["robot"][0].as_f64().unwrap(), d["robot"][1].as_f64().unwrap());
    assert!(((sx - robot.0).powi(2) + (sy - robot.1).powi(2)).sqrt() < 0.5, "at {t_s}: path starts away from the robot");
    let (ex, ey) = xy(path.last().unwrap());
    assert!((ex - gx).abs() < 1e-6 && (ey - gy).abs() < 1e-6, "at {t_s}: path does not end at the goal");
    for v in path {
        let (x, y) = xy(v);
        assert_eq!(class(x, y), CellClass::Free, "at {t_s}: path point ({x}, {y}) not free");
    }
    assert!((d["bag"]["t_s"].as_f64().unwrap() - t_s).abs() < 1e-9);
    assert!(d["bag"]["map_t_s"].as_f64().unwrap() <= t_s + 1e-9);
    d
}

#[test]
fn select_at_several_instants_of_a_rosbags_bag_with_tf_gives_valid_rankings() {
    let bag = data("jacksboro_rosbags.mcap");
    for t in [1.0, 7.5, 12.0, 24.0] {
        let d = check_select(&bag, t);
        assert_eq!(d["bag"]["pose_source"], "tf");
        assert!(d["bag"]["landmark_voxels"].as_u64().unwrap() > 0, "landmarks moved from odom into map");
        assert!(d["bag"]["robot_choice"]["goal"]["x_m"].is_number());
    }
}

#[test]
fn select_on_a_simulated_mission_bag_with_a_pose_topic() {
    let bag = data("sim_mission_rosbags.mcap");
    for t in [2.0, 15.0, 30.0] {
        let d = check_select(&bag, t);
        assert_eq!(d["bag"]["pose_source"], "topic");
    }
}

#[test]
fn bag_info_lists_topics_and_decision_instants() {
    let o = run(&["bag-info", data("jacksboro_rosbags.mcap").to_str().unwrap(), "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let topics: Vec<&str> = v["topics"].as_array().unwrap().iter().map(|t| t["topic"].as_str().unwrap()).collect();
    assert_eq!(topics, ["/cloud_map", "/fitslam/status", "/map", "/tf", "/tf_static"]);
    assert_eq!(v["topics"][2]["msg_type"], "nav_msgs/msg/OccupancyGrid");
    assert_eq!(v["decision_instants"].as_array().unwrap().len(), 3);
    assert_eq!(v["decision_instants"][0]["source"], "new_goal");
    let o = run(&["bag-info", data("sim_mission_rosbags.mcap").to_str().unwrap()]);
    let text = String::from_utf8(o.stdout).unwrap();
    assert!(text.contains("/localization_pose") && text.contains("geometry_msgs/msg/PoseWithCovarianceStamped"), "{text}");
}

#[test]
fn malformed_bags_give_one_error_line_and_a_non_zero_exit() {
    let good = std::fs::read(data("jacksboro_rosbags.mcap")).unwrap();
    let dir = std::env::temp_dir().join(format!("fitslam-bag-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut corrupt = good.clone();
    // Inside the first chunk's zstd data.
    for b in &mut corrupt[200..260] {
        *b ^= 0x5a;
    }
    let cases: [(&str, Vec<u8>, &str); 4] = [
        ("truncated.mcap", good[..good.len() / 2].to_vec(), "truncated"),
        ("corrupt.mcap", corrupt, "zstd"),
        ("text.mcap", b"not a bag\n".to_vec(), "not an MCAP file"),
        ("empty.mcap", Vec::new(), "empty file"),
    ];
    for (name, bytes, expect) in cases {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        for args in [vec!["bag-info", path.to_str().unwrap()], vec!["select", "--bag", path.to_str().unwrap(), "--at", "1"]] {
            let o = run(&args);
            assert!(!o.status.success(), "{name}: exit 0");
            let err = String::from_utf8(o.stderr).unwrap();
            assert_eq!(err.lines().count(), 1, "{name}: {err}");
            assert!(err.starts_with(&format!("error: {}", path.display())) && err.contains(expect), "{name}: {err}");
        }
    }
    let o = run(&["select", "--bag", data("jacksboro_rosbags.mcap").to_str().unwrap(), "--at", "1", "--map-topic", "/tf"]);
    assert!(!o.status.success() && String::from_utf8_lossy(&o.stderr).contains("has type tf2_msgs/msg/TFMessage"));
}

/// `fitslam explore` on the tiny world with `args`, recorded as a bag: (its output folder, the bag).
fn explore_with_bag(tag: &str, args: &[&str]) -> (PathBuf, PathBuf) {
    let out = std::env::temp_dir().join(format!("fitslam-{tag}-{}", std::process::id()));
    let bag_path = out.join("mission.mcap");
    let world = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/worlds/tiny_test.toml");
    let o = Command::new(BIN)
        .args(["explore", "--world", world.to_str().unwrap()])
        .args(args)
        .arg("--out")
        .arg(&out)
        .arg("--bag")
        .arg(&bag_path)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (out, bag_path)
}

#[test]
fn explore_writes_a_bag_that_reads_back_and_replays() {
    let (out, bag_path) = explore_with_bag("explore-bag", &["--time-limit-s", "60", "--seed", "1"]);
    let bytes = std::fs::read(&bag_path).unwrap();
    let bag = Bag::parse(&bytes, "mission.mcap").unwrap();
    let topics: Vec<(String, String)> = bag.topics().into_iter().map(|t| (t.topic, t.msg_type)).collect();
    for (topic, ty) in [
        ("/map", "nav_msgs/msg/OccupancyGrid"),
        ("/tf", "tf2_msgs/msg/TFMessage"),
        ("/cloud_map", "sensor_msgs/msg/PointCloud2"),
        ("/fitslam/status", "std_msgs/msg/String"),
    ] {
        assert!(topics.contains(&(topic.to_string(), ty.to_string())), "{topic} missing: {topics:?}");
    }
    let instants = bag.decision_instants(&BagTopics::default()).unwrap();
    assert!(instants.len() >= 2, "{instants:?}");
    // The robot's pose at the end, through tf, is where the trajectory ends.
    let snap = bag.snapshot(&BagTopics::default(), bag.duration_s()).unwrap();
    let tum = std::fs::read_to_string(out.join("trajectory_est.tum")).unwrap();
    let last: Vec<f64> = tum.lines().last().unwrap().split(' ').map(|v| v.parse().unwrap()).collect();
    assert!((snap.robot.x_m - last[1]).abs() < 0.05 && (snap.robot.y_m - last[2]).abs() < 0.05, "{:?} vs {last:?}", snap.robot);
    // The first decision is made again from the bag: a valid ranking.
    check_select(&bag_path, instants[0].t_s);
    // A third-party reader opens it too: PyPI rosbags, in the venv scripts/ros2-jazzy-venv
    // installs (scripts/test runs it; or FITSLAM_ROS2_VENV). Without it this test fails.
    let venv = std::env::var_os("FITSLAM_ROS2_VENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("target/ros2-jazzy-venv"));
    let python = venv.join("bin/python");
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/bags/write_bag.py");
    let o = Command::new(&python).arg(script).arg("check").arg(&bag_path).output();
    let o =
        o.unwrap_or_else(|e| panic!("{}: {e}: run scripts/ros2-jazzy-venv (scripts/test does), which installs rosbags", python.display()));
    assert!(o.status.success(), "rosbags (run scripts/ros2-jazzy-venv if it is missing): {}", String::from_utf8_lossy(&o.stderr));
    let listing = String::from_utf8(o.stdout).unwrap();
    assert!(listing.contains("/map nav_msgs/msg/OccupancyGrid") && listing.contains("/tf tf2_msgs/msg/TFMessage"), "{listing}");
}

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

/// One policy for every face: at each decision instant of a recorded simulated mission,
/// `select --bag` answers with the exploration policy's own action on the instant's map,
/// landmarks and pose (`explore::Explorer` from a fresh start), not a bare selector's ranking.
/// The studio's recording view makes the same check (studio/tests/recording_ui.rs).
#[test]
fn select_on_a_recorded_mission_answers_as_the_explorer_at_every_decision_instant() {
    let (out, bag_path) = explore_with_bag("replay", &["--seed", "3", "--strategy", "fit"]);
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
