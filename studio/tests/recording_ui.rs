//! Headless UI tests of a recorded mission in the Planner mode (egui_kittest): a bag built from
//! the jacksboro map and landmarks with the core's MCAP writer, opened as a dropped file, stepped
//! through its decision instants with the timeline's buttons, and exported as a scene. The
//! oracle is the core's selector on the core's snapshot of the bag (what `fitslam select --bag`
//! runs), not the studio's code.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use fitslam_core::bag::{Bag, BagTopics, McapWriter};
use fitslam_core::explore::{Explorer, Situation};
use fitslam_core::params::Valid;
use fitslam_core::ros::{cloud_of_points, msg_of_occupancy, transform_of_pose2};
use fitslam_core::select::Decision;
use fitslam_core::utility::LandmarkVoxels;
use fitslam_core::{OccupancyGrid, Params, PointCloud, Pose2, io};
use fitslam_msgs::{Header, OccupancyGrid as MapMsg, PointCloud2, StringMsg, TFMessage, Time, TransformStamped, cdr};
use fitslam_studio::StudioApp;
use fitslam_studio::files::{IncomingFile, Intent};

const S: u64 = 1_000_000_000;
const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/maps/jacksboro/");

fn read(f: &str) -> Vec<u8> {
    std::fs::read(format!("{DIR}{f}")).unwrap()
}

/// The robot's pose at second `k` of the recording (map frame, through map → odom → base_link).
fn robot_at(k: u64) -> Pose2 {
    Pose2::new(3.0 + 0.3 * k as f64, 3.0, 0.3 * k as f64)
}

/// The explorer's decision on `grid`, `cloud` at `robot` with default parameters, whole map, no
/// blacklist, from a fresh start: what `fitslam select` computes.
fn core_decision(grid: &OccupancyGrid, cloud: &PointCloud, robot: Pose2) -> Decision {
    let params = Valid::<Params>::default();
    let voxels = LandmarkVoxels::new(cloud, params.u2.voxel_m, params.u2.sigma_landmark_m).unwrap();
    let traced = Explorer::new(Valid::default(), params).decide_traced(&mut grid.clone(), &Situation::one_off(&voxels, robot, None));
    traced.decision().cloned().unwrap()
}

/// A 6 s recording: the jacksboro map and landmarks at 1 s, tf every second (odom drifting
/// 0.2 m from map), and the node's status at 1 s and 4 s. The first status names the frontier
/// the core chooses then; the second one a point 2 m from the robot.
fn recording() -> (Vec<u8>, [f64; 2]) {
    let grid = io::load_map(&read("map.yaml"), "map.yaml", &read("map.pgm"), "map.pgm").unwrap();
    let cloud = io::load_cloud(&read("landmarks.csv"), "landmarks.csv").unwrap();
    let mut w = McapWriter::new("studio test");
    let (map, tf, lm, status) = (
        w.channel::<MapMsg>("/map"),
        w.channel::<TFMessage>("/tf"),
        w.channel::<PointCloud2>("/cloud_map"),
        w.channel::<StringMsg>("/fitslam/status"),
    );
    let h = |f: &str| Header::new(Time::from_secs_f64(1.0), f);
    for k in 0..=6u64 {
        let r = robot_at(k);
        let odom = transform_of_pose2(Pose2::new(0.2, 0.0, 0.0));
        let transforms = vec![
            TransformStamped { header: h("map"), child_frame_id: "odom".into(), transform: odom },
            TransformStamped {
                header: h("odom"),
                child_frame_id: "base_link".into(),
                transform: transform_of_pose2(Pose2::new(r.x_m - 0.2, r.y_m, r.yaw_rad)),
            },
        ];
        w.message(tf, k * S, &cdr::to_vec(&TFMessage { transforms }).unwrap());
    }
    w.message(map, S, &cdr::to_vec(&msg_of_occupancy(&grid, h("map"))).unwrap());
    w.message(lm, S, &cdr::to_vec(&cloud_of_points(&cloud.points, h("map"))).unwrap());
    let first = core_decision(&grid, &cloud, robot_at(1));
    let c = first.chosen_candidate().expect("a goal on jacksboro");
    let chosen = [c.x_m, c.y_m];
    let later = [robot_at(4).x_m + 2.0, robot_at(4).y_m];
    for (t, id, [x, y]) in [(1, 1, chosen), (4, 2, later)] {
        let json = serde_json::json!({
            "phase": "navigating",
            "goal": { "id": id, "goal": { "x_m": x, "y_m": y, "yaw_rad": 0.0 }, "frontier_m": [x, y] },
        });
        w.message(status, t * S + 1000, &cdr::to_vec(&StringMsg { data: json.to_string() }).unwrap());
    }
    (w.finish(), chosen)
}

fn harness() -> Harness<'static, StudioApp> {
    let ctx = egui::Context::default();
    let app = StudioApp::new(&ctx, Some("courtyard"));
    Harness::builder().with_size(egui::vec2(1400.0, 900.0)).build_ui_state(|ui, app: &mut StudioApp| app.show(ui), app)
}

fn chosen_xy(h: &Harness<'_, StudioApp>) -> [f64; 2] {
    let c = h.state().planner.pipeline.ok_decision().and_then(Decision::chosen_candidate).cloned().expect("a goal");
    [c.x_m, c.y_m]
}

#[test]
fn a_dropped_bag_opens_at_its_first_decision_and_reranks_as_the_cli_does() {
    let (bytes, robot_chosen) = recording();
    let mut h = harness();
    h.state_mut().load_files(vec![IncomingFile { name: "mission.mcap".into(), bytes: Ok(bytes.clone()), intent: Intent::Any }]);
    h.run_ok();
    let app = h.state();
    let rec = app.recording.as_ref().expect("the recording is open");
    assert_eq!(rec.instants().len(), 2);
    assert!((rec.t_s - 1.000_001).abs() < 1e-9, "opens at the first decision: {}", rec.t_s);
    assert!(app.planner.scene.map.source.starts_with("mission.mcap at t = 1.000"), "{}", app.planner.scene.map.source);
    let r = app.planner.scene.robot;
    assert!((r.x_m - robot_at(1).x_m).abs() < 1e-9 && (r.y_m - 3.0).abs() < 1e-9 && (r.yaw_rad - 0.3).abs() < 1e-9, "{r:?}");
    assert_eq!(app.planner.scene.landmarks.cloud.len(), 1196);
    assert_eq!(app.planner.recorded_goal_m, Some(robot_chosen));

    // The oracle: the core's own snapshot of the bag and the core's selector.
    let s = Bag::parse(&bytes, "mission.mcap").unwrap().snapshot(&BagTopics::default(), rec.t_s).unwrap();
    let d = core_decision(&s.map, &s.landmarks, s.robot);
    let c = d.chosen_candidate().unwrap();
    assert_eq!(chosen_xy(&h), [c.x_m, c.y_m]);
    assert_eq!(fitslam_studio::recording_view::choice_gap_m(rec, app.planner.pipeline.action()), Some(0.0));
    h.get_by_label("the same goal");

    // Next decision: the robot has moved; its choice then is 2 m ahead of it.
    h.get_by_label("next decision >").click();
    h.run_ok();
    let app = h.state();
    let rec = app.recording.as_ref().unwrap();
    assert!((rec.t_s - 4.000_001).abs() < 1e-9, "{}", rec.t_s);
    assert!((app.planner.scene.robot.x_m - robot_at(4).x_m).abs() < 1e-9);
    assert_eq!(app.planner.recorded_goal_m, Some([robot_at(4).x_m + 2.0, 3.0]));
    let s = Bag::parse(&bytes, "m").unwrap().snapshot(&BagTopics::default(), rec.t_s).unwrap();
    let c = core_decision(&s.map, &s.landmarks, s.robot).chosen_candidate().cloned().unwrap();
    assert_eq!(chosen_xy(&h), [c.x_m, c.y_m]);

    // And back.
    h.get_by_label("< previous decision").click();
    h.run_ok();
    assert!((h.state().recording.as_ref().unwrap().t_s - 1.000_001).abs() < 1e-9);

    // A parameter change re-ranks the same instant: α = 1 ranks by path length alone.
    h.state_mut().planner.params.u1.alpha = 1.0;
    h.run_ok();
    let d = h.state().planner.pipeline.ok_decision().unwrap();
    let rho = |i: usize| d.candidates[i].rho_m.unwrap();
    let ranked: Vec<usize> = (0..d.candidates.len()).filter(|&i| d.candidates[i].u1.is_some()).collect();
    let nearest = ranked.iter().copied().min_by(|&a, &b| rho(a).total_cmp(&rho(b))).unwrap();
    assert_eq!(d.candidates[d.chosen.unwrap()].rho_m, Some(rho(nearest)));
}

#[test]
fn an_exported_instant_is_a_scene_select_reads_with_the_same_decision() {
    let (bytes, _) = recording();
    let mut h = harness();
    h.state_mut().load_files(vec![IncomingFile { name: "m.mcap".into(), bytes: Ok(bytes), intent: Intent::Recording }]);
    h.run_ok();
    let app = h.state();
    let grid = app.planner.pipeline.occupancy().unwrap();
    let files = fitslam_studio::recording::scene_files(grid, &app.planner.scene.landmarks, app.planner.scene.robot, "m_t1s");
    let names: Vec<&str> = files.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["m_t1s_map.yaml", "m_t1s_map.pgm", "m_t1s_landmarks.csv", "m_t1s_select.txt"]);
    let get = |n: &str| files.iter().find(|(f, _)| f == n).map(|(_, b)| b.as_slice()).unwrap();
    let map = io::load_map(get("m_t1s_map.yaml"), "m_t1s_map.yaml", get("m_t1s_map.pgm"), "m_t1s_map.pgm").unwrap();
    assert_eq!(map.geometry, grid.geometry);
    assert_eq!(map.data, grid.data);
    let cloud = io::load_cloud(get("m_t1s_landmarks.csv"), "m_t1s_landmarks.csv").unwrap();
    assert_eq!(cloud.points, app.planner.scene.landmarks.cloud.points);
    let command = std::str::from_utf8(get("m_t1s_select.txt")).unwrap();
    let pose = command.split("--pose ").nth(1).unwrap().trim();
    let v: Vec<f64> = pose.split(',').map(|x| x.parse().unwrap()).collect();
    assert_eq!(Pose2::new(v[0], v[1], v[2]), app.planner.scene.robot, "{command}");
    assert!(command.starts_with("fitslam select --map m_t1s_map.yaml --landmarks m_t1s_landmarks.csv --pose "), "{command}");
    let c = core_decision(&map, &cloud, app.planner.scene.robot).chosen_candidate().cloned().unwrap();
    assert_eq!(chosen_xy(&h), [c.x_m, c.y_m]);
}

#[test]
fn a_broken_bag_gives_one_message_naming_it_and_keeps_the_scene() {
    let (bytes, _) = recording();
    let mut h = harness();
    let before = h.state().planner.scene.map.source.clone();
    for (name, b) in [("cut.mcap", bytes[..bytes.len() / 2].to_vec()), ("text.mcap", b"not a bag".to_vec())] {
        h.state_mut().load_files(vec![IncomingFile { name: name.into(), bytes: Ok(b), intent: Intent::Any }]);
        h.run_ok();
        let app = h.state();
        assert!(app.recording.is_none());
        assert_eq!(app.planner.scene.map.source, before);
        let last = app.messages.last().unwrap();
        assert!(last.error && last.text.starts_with(name), "{:?}", last);
    }
}

/// A whole simulated mission recorded as the node's topics, opened in the studio: at every
/// decision instant the recording view shows the exploration policy's own answer on the
/// instant's inputs (a fresh explorer: no trail, no goal reached, no blacklist), as `fitslam
/// select --bag` does (tests/bag.rs).
#[test]
fn at_every_instant_of_a_recorded_mission_the_view_shows_the_explorers_answer() {
    use fitslam_core::sim::recorder::MissionRecorder;
    use fitslam_core::sim::{Localisation, Mission, World, WorldSpec};
    let spec = WorldSpec::from_toml(
        &std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/worlds/tiny_test.toml")).unwrap(),
        "tiny_test.toml",
    )
    .unwrap();
    let params = Valid::<Params>::default();
    let world = World::build(&spec, &params.traversability, params.traversability.tau, |f| Err(format!("{f}: no files here"))).unwrap();
    let mut mission =
        Mission::new(world, params, Valid::default(), fitslam_core::params::Strategy::Fit, 3, Localisation::GroundTruth).unwrap();
    let mut recorder = MissionRecorder::new();
    while mission.end().is_none() {
        mission.step();
        recorder.record(&mut mission);
    }
    let bytes = recorder.finish();
    let bag = Bag::parse(&bytes, "mission.mcap").unwrap();
    let instants = bag.decision_instants(&BagTopics::default()).unwrap();
    assert!(instants.len() >= 3, "{instants:?}");

    let mut h = harness();
    h.state_mut().load_files(vec![IncomingFile { name: "mission.mcap".into(), bytes: Ok(bytes), intent: Intent::Recording }]);
    h.run_ok();
    for (k, instant) in instants.iter().enumerate() {
        if k > 0 {
            h.get_by_label("next decision >").click();
            h.run_ok();
        }
        let app = h.state();
        let t_s = app.recording.as_ref().unwrap().t_s;
        assert!((t_s - instant.t_s).abs() < 1e-9, "instant {k}: {t_s} vs {}", instant.t_s);
        let s = bag.snapshot(&BagTopics::default(), t_s).unwrap();
        let params = Valid::<Params>::default();
        let voxels = LandmarkVoxels::new(&s.landmarks, params.u2.voxel_m, params.u2.sigma_landmark_m).unwrap();
        let traced = Explorer::new(Valid::default(), params).decide_traced(&mut s.map.clone(), &Situation::one_off(&voxels, s.robot, None));
        assert_eq!(app.planner.pipeline.action(), Some(&traced.action), "instant {k} at {t_s} s");
    }
}
