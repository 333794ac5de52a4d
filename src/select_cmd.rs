//! `fitslam select`: one goal decision on a map and a landmark set, printed as a table or JSON.
//! The decision is the exploration policy's (`explore::Explorer`, from a fresh start: no trail,
//! no goal reached), so it is the goal the robot node and the simulator would choose.

use crate::{bag_cmd, load};
use anyhow::{Result, bail};
use clap::Args;
use fitslam_core::{
    OccupancyGrid, PointCloud, Pose2,
    bag::{PoseSource, Snapshot},
    explore::{Action, Attempt, ExploreParams, Explorer, Situation, TracedDecision, WaitReason},
    frontier::Boundary,
    params::{Strategy, Valid},
    select::{CandidateReport, Decision, DropReason},
    utility::LandmarkVoxels,
};
use serde::Serialize;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct SelectArgs {
    /// Map: map_server YAML (+ the PGM/PNG it names), or a bare PNG/PGM.
    #[arg(long, required_unless_present = "bag", conflicts_with = "bag")]
    pub map: Option<PathBuf>,
    /// Landmark set: .pcd, .ply, .csv (x,y,z[,covariance]), .las.
    #[arg(long, required_unless_present = "bag", conflicts_with = "bag")]
    pub landmarks: Option<PathBuf>,
    /// Robot pose in the map frame: X,Y,YAW (metres, metres, radians).
    #[arg(long, allow_hyphen_values = true, required_unless_present = "bag", conflicts_with = "bag")]
    pub pose: Option<String>,
    /// Take the map, landmarks and pose from a rosbag2 MCAP recording, as the robot had them at
    /// `--at`.
    #[arg(long, requires = "at")]
    pub bag: Option<PathBuf>,
    /// Instant of the bag, seconds from its first message.
    #[arg(long, requires = "bag", allow_hyphen_values = true)]
    pub at: Option<f64>,
    #[command(flatten)]
    pub topics: bag_cmd::TopicArgs,
    /// Parameter file (TOML or YAML); defaults are the paper's.
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Goal selector (overrides the parameter file).
    #[arg(long, value_enum)]
    pub strategy: Option<Strategy>,
    /// Exploration boundary as MIN_X,MIN_Y,MAX_X,MAX_Y (metres); default: the whole map.
    #[arg(long, allow_hyphen_values = true)]
    pub boundary: Option<String>,
    /// Print the whole ranking as JSON.
    #[arg(long)]
    pub json: bool,
}

/// The inputs of one decision, from files or from a bag at an instant.
struct Inputs {
    grid: OccupancyGrid,
    cloud: PointCloud,
    robot: Pose2,
    /// Named in errors: the map file, or the bag.
    source: String,
    /// The bag's instant, when the inputs come from one.
    snapshot: Option<Snapshot>,
}

fn inputs(args: &SelectArgs, params: &fitslam_core::Params) -> Result<Inputs> {
    if let (Some(path), Some(t_s)) = (args.bag.as_deref(), args.at) {
        let bag = bag_cmd::open(path)?;
        let s = bag.snapshot(&args.topics.topics(), t_s)?;
        let (grid, cloud) = (s.map.clone(), s.landmarks.clone());
        return Ok(Inputs { grid, cloud, robot: s.robot, source: path.display().to_string(), snapshot: Some(s) });
    }
    let (Some(map), Some(landmarks), Some(pose)) = (args.map.as_deref(), args.landmarks.as_deref(), args.pose.as_deref()) else {
        bail!("give --map, --landmarks and --pose, or --bag and --at");
    };
    let robot = load::pose(pose)?;
    let grid = load::map(map, params)?;
    let cloud = load::cloud(landmarks)?;
    Ok(Inputs { grid, cloud, robot, source: map.display().to_string(), snapshot: None })
}

pub fn run(args: &SelectArgs) -> Result<()> {
    let mut params = load::params(args.params.as_deref())?;
    if let Some(s) = args.strategy {
        params = params.with_selector(fitslam_core::params::SelectorParams { strategy: s, ..params.selector.clone() });
    }
    let Inputs { grid, cloud, robot, source, snapshot } = inputs(args, &params)?;
    let landmarks_name = args.landmarks.as_deref().map_or_else(|| source.clone(), |p| p.display().to_string());
    let landmarks =
        LandmarkVoxels::new(&cloud, params.u2.voxel_m, params.u2.sigma_landmark_m).map_err(|e| anyhow::anyhow!("{landmarks_name}: {e}"))?;
    let boundary = args.boundary.as_deref().map(parse_boundary).transpose()?;
    if let (Some(text), Some(b)) = (args.boundary.as_deref(), boundary.as_ref()) {
        // A boundary the map does not reach can hold no frontier: say so rather than rank none.
        let (x0, y0, x1, y1) = grid.geometry.bounds_m();
        let outside = b.vertices_m.iter().all(|v| v[0] <= x0) || b.vertices_m.iter().all(|v| v[0] >= x1);
        if outside || b.vertices_m.iter().all(|v| v[1] <= y0) || b.vertices_m.iter().all(|v| v[1] >= y1) {
            bail!("--boundary {text:?} does not overlap the map {source} ([{x0}, {x1}] × [{y0}, {y1}] m)");
        }
    }
    let situation = Situation::one_off(&landmarks, robot, boundary.as_ref());
    let mut explorer = Explorer::new(Valid::<ExploreParams>::default(), params);
    let traced = explorer.decide_traced(&mut grid.clone(), &situation);
    // A selector error the retries could not get past is the input's fault: say so and fail.
    if let Action::Wait(WaitReason::NoPlan(e)) = &traced.action {
        bail!("{source}: {e}");
    }
    let Some(decision) = traced.decision() else { bail!("{source}: no decision was made") };
    if args.json {
        let mut json = serde_json::to_value(JsonDecision::from(decision))?;
        json["action"] = action_json(&traced.action);
        json["attempts"] = attempts_json(&traced);
        if let Some(s) = &snapshot {
            json["bag"] = bag_json(s, landmarks.len());
        }
        outln!("{}", serde_json::to_string_pretty(&json)?)?;
    } else {
        if let Some(s) = &snapshot {
            print_snapshot(s, landmarks.len())?;
        }
        print_table(decision)?;
        print_action(&traced)?;
    }
    Ok(())
}

/// The explorer's answer as JSON: `kind` (`goal`, `done`, `wait`, `recover`) and its details.
fn action_json(action: &Action) -> serde_json::Value {
    match action {
        Action::Goal(plan) | Action::Keep(plan) => {
            let g = plan.goal.goal;
            let t = plan.target();
            serde_json::json!({
                "kind": "goal",
                "goal": [g.x_m, g.y_m, g.yaw_rad],
                "target": [t.x_m, t.y_m, t.yaw_rad],
                "candidate": plan.candidate,
                "inflation_m": plan.goal.inflation_m,
                "tight": plan.tight,
                "on_trail": plan.goal.on_trail,
            })
        }
        Action::Done(reason) => serde_json::json!({ "kind": "done", "reason": reason }),
        Action::Wait(why) => serde_json::json!({ "kind": "wait", "reason": format!("{why:?}") }),
        Action::Recover { radius_m } => serde_json::json!({ "kind": "recover", "radius_m": radius_m }),
    }
}

/// Each attempt of the retry ladder: its step and what the selector answered.
fn attempts_json(traced: &TracedDecision) -> serde_json::Value {
    let attempts: Vec<serde_json::Value> = traced
        .attempts
        .iter()
        .map(|a| {
            let mut v = serde_json::to_value(a.attempt).unwrap_or_default();
            match &a.outcome {
                Ok(d) => v["chosen"] = serde_json::json!(d.chosen),
                Err(e) => v["error"] = serde_json::json!(e.to_string()),
            }
            v
        })
        .collect();
    serde_json::Value::Array(attempts)
}

/// The explorer's answer below the table: the goal it sends (and on which step of the ladder).
fn print_action(traced: &TracedDecision) -> std::io::Result<()> {
    let last = traced.attempts.last().map(|a| a.attempt);
    let how = match last {
        Some(Attempt::Plain | Attempt::Reselected { .. }) | None => String::new(),
        Some(Attempt::ClearFootprint) => " (after clearing the robot's footprint)".to_string(),
        Some(Attempt::OpenTrail) => " (with the robot's trail open)".to_string(),
        Some(Attempt::TightInflation { radius_m, .. }) => format!(" (at the tight inflation {radius_m} m)"),
    };
    match &traced.action {
        Action::Goal(plan) | Action::Keep(plan) => {
            let g = plan.goal.goal;
            outln!("goal: ({:.2}, {:.2}) heading {:.1}°{how}", g.x_m, g.y_m, g.yaw_rad.to_degrees())
        }
        Action::Done(reason) => outln!("goal: none ({reason:?}: end of mission){how}"),
        Action::Wait(why) => outln!("goal: none now ({why:?}){how}"),
        Action::Recover { radius_m } => outln!("goal: none: trapped by its own map (forget it within {radius_m} m){how}"),
    }
}

/// The bag's instant as JSON: when each input was recorded and what the robot chose.
fn bag_json(s: &Snapshot, voxels: usize) -> serde_json::Value {
    serde_json::json!({
        "t_s": s.t_s,
        "map_t_s": s.map_t_s,
        "map_cells": [s.map.geometry.width, s.map.geometry.height],
        "landmarks_t_s": s.landmarks_t_s,
        "landmark_voxels": voxels,
        "pose_source": s.pose_source,
        "pose_t_s": s.pose_t_s,
        "robot_choice": s.robot_choice,
    })
}

fn print_snapshot(s: &Snapshot, voxels: usize) -> std::io::Result<()> {
    outln!(
        "bag at {:.3} s: map of {} × {} cells from {:.3} s, {} landmark voxels{}, pose from {} ({:.3} s)",
        s.t_s,
        s.map.geometry.width,
        s.map.geometry.height,
        s.map_t_s,
        voxels,
        s.landmarks_t_s.map_or_else(|| " (none recorded)".to_string(), |t| format!(" from {t:.3} s")),
        match s.pose_source {
            PoseSource::Tf => "tf",
            PoseSource::Topic => "the pose topic",
        },
        s.pose_t_s
    )?;
    match &s.robot_choice {
        Some(c) => {
            let frontier = c.frontier_m.map_or_else(String::new, |[x, y]| format!(" for the frontier ({x:.2}, {y:.2})"));
            outln!("robot's choice (status at {:.3} s): goal ({:.2}, {:.2}){frontier}", c.t_s, c.goal.x_m, c.goal.y_m)
        }
        None => outln!("robot's choice: none recorded (no status with a goal before this instant)"),
    }
}

fn parse_boundary(text: &str) -> Result<Boundary> {
    let v: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .map_err(|_| anyhow::anyhow!("--boundary {text:?}: expected MIN_X,MIN_Y,MAX_X,MAX_Y"))?;
    if v.len() != 4 || v.iter().any(|x| !x.is_finite()) || v[0] >= v[2] || v[1] >= v[3] {
        bail!("--boundary {text:?}: expected finite MIN_X,MIN_Y,MAX_X,MAX_Y with MIN < MAX");
    }
    Ok(Boundary::from_bounds(v[0], v[1], v[2], v[3]))
}

/// The JSON face of a decision: the documented keys (`x`, `y`, `theta_star`, `rho_m`, `delta_e`,
/// `u1`, `path_info`, `u2`, `rank`, `path`, `dropped`) plus the rest of the report.
#[derive(Serialize)]
struct JsonDecision<'a> {
    strategy: Strategy,
    chosen: Option<usize>,
    goal: Option<[f64; 3]>,
    robot: [f64; 3],
    start_snapped: bool,
    ray_angles_rad: &'a [f64],
    candidates: Vec<JsonCandidate<'a>>,
}

#[derive(Serialize)]
struct JsonCandidate<'a> {
    x: f64,
    y: f64,
    theta_star: Option<f64>,
    rho_m: Option<f64>,
    delta_e: Option<f64>,
    u1: Option<f64>,
    path_info: Option<f64>,
    u2: Option<f64>,
    rank: Option<usize>,
    path: &'a [[f64; 2]],
    dropped: Option<DropReason>,
    cell: [i32; 2],
    cluster_size: usize,
    u1_rank: Option<usize>,
    path_info_raw: Option<f64>,
    waypoints: &'a [fitslam_core::utility::WaypointReport],
    ray_gains_bits: &'a [f64],
}

impl<'a> From<&'a Decision> for JsonDecision<'a> {
    fn from(d: &'a Decision) -> Self {
        Self {
            strategy: d.strategy,
            chosen: d.chosen,
            goal: d.goal.map(|g| [g.x_m, g.y_m, g.yaw_rad]),
            robot: [d.robot.x_m, d.robot.y_m, d.robot.yaw_rad],
            start_snapped: d.start_snapped,
            ray_angles_rad: &d.ray_angles_rad,
            candidates: d.candidates.iter().map(JsonCandidate::from).collect(),
        }
    }
}

impl<'a> From<&'a CandidateReport> for JsonCandidate<'a> {
    fn from(c: &'a CandidateReport) -> Self {
        Self {
            x: c.x_m,
            y: c.y_m,
            theta_star: c.theta_star_rad,
            rho_m: c.rho_m,
            delta_e: c.delta_e_bits,
            u1: c.u1,
            path_info: c.path_info,
            u2: c.u2,
            rank: c.rank,
            path: &c.path_m,
            dropped: c.dropped,
            cell: [c.cell.col, c.cell.row],
            cluster_size: c.cluster_size,
            u1_rank: c.u1_rank,
            path_info_raw: c.path_info_raw,
            waypoints: &c.waypoints,
            ray_gains_bits: &c.ray_gains_bits,
        }
    }
}

fn print_table(d: &Decision) -> std::io::Result<()> {
    let opt = |v: Option<f64>, p: usize| v.map_or_else(|| "-".to_string(), |x| format!("{x:.p$}"));
    outln!(
        "strategy {:?}; robot ({:.2}, {:.2}, {:.2} rad){}; {} candidates",
        d.strategy,
        d.robot.x_m,
        d.robot.y_m,
        d.robot.yaw_rad,
        if d.start_snapped { ", start snapped to the nearest free cell" } else { "" },
        d.candidates.len()
    )?;
    outln!(
        "{:>4} {:>4} {:>8} {:>8} {:>7} {:>8} {:>7} {:>6} {:>6} {:>6}  note",
        "rank",
        "idx",
        "x_m",
        "y_m",
        "rho_m",
        "dE_bits",
        "theta*",
        "u1",
        "I_p",
        "u2"
    )?;
    let mut order = d.ranking();
    order.extend((0..d.candidates.len()).filter(|&i| d.candidates[i].rank.is_none()));
    for i in order {
        let c = &d.candidates[i];
        let note = match (d.chosen == Some(i), c.dropped) {
            (true, _) => "chosen".to_string(),
            (false, Some(r)) => format!("{r:?}"),
            (false, None) => String::new(),
        };
        outln!(
            "{:>4} {:>4} {:>8.2} {:>8.2} {:>7} {:>8} {:>7} {:>6} {:>6} {:>6}  {}",
            c.rank.map_or("-".into(), |r| r.to_string()),
            i,
            c.x_m,
            c.y_m,
            opt(c.rho_m, 2),
            opt(c.delta_e_bits, 1),
            c.theta_star_rad.map_or("-".into(), |t| format!("{:.1}°", t.to_degrees())),
            opt(c.u1, 3),
            opt(c.path_info, 3),
            opt(c.u2, 3),
            note
        )?;
    }
    Ok(())
}
