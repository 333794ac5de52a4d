//! `fitslam select`: one goal decision on a map and a landmark set, printed as a table or JSON.

use crate::load;
use anyhow::{Result, bail};
use clap::Args;
use fitslam_core::{
    frontier::{Blacklist, Boundary},
    params::Strategy,
    select::{CandidateReport, Decision, DecisionInput, DropReason, make_selector},
    utility::LandmarkVoxels,
};
use serde::Serialize;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct SelectArgs {
    /// Map: map_server YAML (+ the PGM/PNG it names), or a bare PNG/PGM.
    #[arg(long)]
    pub map: PathBuf,
    /// Landmark set: .pcd, .ply, .csv (x,y,z[,covariance]), .las.
    #[arg(long)]
    pub landmarks: PathBuf,
    /// Robot pose in the map frame: X,Y,YAW (metres, metres, radians).
    #[arg(long, allow_hyphen_values = true)]
    pub pose: String,
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

pub fn run(args: &SelectArgs) -> Result<()> {
    let mut params = load::params(args.params.as_deref())?;
    if let Some(s) = args.strategy {
        params.selector.strategy = s;
    }
    let robot = load::pose(&args.pose)?;
    let grid = load::map(&args.map, &params)?;
    let cloud = load::cloud(&args.landmarks)?;
    let landmarks = LandmarkVoxels::new(&cloud, params.u2.voxel_m, params.u2.sigma_landmark_m)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.landmarks.display()))?;
    let boundary = args.boundary.as_deref().map(parse_boundary).transpose()?;
    if let (Some(text), Some(b)) = (args.boundary.as_deref(), boundary.as_ref()) {
        // A boundary the map does not reach can hold no frontier: say so rather than rank none.
        let (x0, y0, x1, y1) = grid.geometry.bounds_m();
        let outside = b.vertices_m.iter().all(|v| v[0] <= x0) || b.vertices_m.iter().all(|v| v[0] >= x1);
        if outside || b.vertices_m.iter().all(|v| v[1] <= y0) || b.vertices_m.iter().all(|v| v[1] >= y1) {
            bail!("--boundary {text:?} does not overlap the map {} ([{x0}, {x1}] × [{y0}, {y1}] m)", args.map.display());
        }
    }
    let blacklist = Blacklist::new(params.frontier.blacklist_radius_m);
    let mut input = DecisionInput::new(&grid, &landmarks, robot, &blacklist);
    if let Some(b) = boundary.as_ref() {
        input = input.with_boundary(b);
    }
    let mut selector = make_selector(&params.selector);
    let decision = selector.select(&input, &params).map_err(|e| anyhow::anyhow!("{}: {e}", args.map.display()))?;
    if args.json {
        outln!("{}", serde_json::to_string_pretty(&JsonDecision::from(&decision))?)?;
    } else {
        print_table(&decision)?;
    }
    Ok(())
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
    match d.chosen_candidate() {
        Some(c) => outln!("goal: ({:.2}, {:.2}) heading {:.1}°", c.x_m, c.y_m, c.theta_star_rad.unwrap_or(0.0).to_degrees())?,
        None => outln!("goal: none (no reachable frontier left: end of mission)")?,
    }
    Ok(())
}
