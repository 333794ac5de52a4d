//! `fitslam explore`: one whole headless mission in a world file (notes §8). Writes
//! `metrics.csv` (byte-identical for a seed), `timing.csv` (wall time of the decisions),
//! `trajectory_est.tum` / `trajectory_gt.tum`, `summary.json`, the final maps (map_server YAML +
//! PGM: the robot's map and the ground truth), and plots of % unexplored and cov_trace over time
//! (SVG and PNG, drawn by hand: no plotting dependency).

use crate::load;
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use fitslam_core::{
    io,
    params::Strategy,
    sim::{Localisation, Mission, MissionParams, World, WorldSpec},
};
use std::path::{Path, PathBuf};

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum StrategyArg {
    Fit,
    Greedy,
    Random,
    U1,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum LocalisationArg {
    /// The true pose (no SLAM).
    GroundTruth,
    /// Dead-reckoned odometry + IMU yaw.
    Odometry,
}

#[derive(Args, Debug)]
pub struct ExploreArgs {
    /// World file (TOML, see assets/worlds/).
    #[arg(long)]
    pub world: PathBuf,
    /// Goal selection strategy.
    #[arg(long, value_enum, default_value = "fit")]
    pub strategy: StrategyArg,
    /// Seed of the sensors' noise and of the random strategy.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Planner parameters (TOML or YAML); default: the paper's.
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Simulator parameters (TOML, `MissionParams`); default: built-in.
    #[arg(long)]
    pub sim_params: Option<PathBuf>,
    /// Localisation.
    #[arg(long, value_enum, default_value = "ground-truth")]
    pub localisation: LocalisationArg,
    /// Overrides the world's time limit, seconds.
    #[arg(long)]
    pub time_limit_s: Option<f64>,
}

pub fn run(args: &ExploreArgs) -> Result<()> {
    let params = load::params(args.params.as_deref())?;
    let mut mission_params = match &args.sim_params {
        None => MissionParams::default(),
        Some(p) => {
            let text = String::from_utf8(load::read(p)?).with_context(|| format!("{}: not UTF-8", p.display()))?;
            MissionParams::from_toml(&text, &p.display().to_string()).map_err(anyhow::Error::msg)?
        }
    };
    if let Some(t) = args.time_limit_s {
        mission_params.time_limit_s = Some(t);
    }
    let world_name = args.world.display().to_string();
    let text = String::from_utf8(load::read(&args.world)?).with_context(|| format!("{world_name}: not UTF-8"))?;
    let spec = WorldSpec::from_toml(&text, &world_name)?;
    let dir = args.world.parent().map(Path::to_path_buf).unwrap_or_default();
    let world = World::build(&spec, &params.traversability, params.traversability.tau, |name| {
        std::fs::read(dir.join(name)).map_err(|e| format!("cannot read {}: {e}", dir.join(name).display()))
    })?;
    if world.explorable_count == 0 {
        bail!("{world_name}: the start is not on ground-truth traversable terrain");
    }
    let strategy = match args.strategy {
        StrategyArg::Fit => Strategy::Fit,
        StrategyArg::Greedy => Strategy::Greedy,
        StrategyArg::Random => Strategy::Random,
        StrategyArg::U1 => Strategy::U1,
    };
    let localisation = match args.localisation {
        LocalisationArg::GroundTruth => Localisation::GroundTruth,
        LocalisationArg::Odometry => Localisation::Odometry,
    };
    let mut mission = Mission::new(world, params, mission_params, strategy, args.seed, localisation)
        .map_err(|e| anyhow::anyhow!("{world_name}: {e}"))?;
    let t0 = std::time::Instant::now();
    mission.set_clock(Box::new(move || t0.elapsed().as_secs_f64() * 1e3));
    let wall = std::time::Instant::now();
    let summary = mission.run();
    let wall_s = wall.elapsed().as_secs_f64();

    let out = &args.out;
    load::write(&out.join("metrics.csv"), mission.metrics_csv().as_bytes())?;
    load::write(&out.join("timing.csv"), mission.timing_csv().as_bytes())?;
    load::write(&out.join("trajectory_gt.tum"), Mission::tum(&mission.trajectory_gt).as_bytes())?;
    load::write(&out.join("trajectory_est.tum"), Mission::tum(&mission.trajectory_est).as_bytes())?;
    let mut json = serde_json::to_value(&summary)?;
    json["wall_time_s"] = serde_json::json!(wall_s);
    load::write(&out.join("summary.json"), serde_json::to_string_pretty(&json)?.as_bytes())?;
    let (yaml, pgm) = io::save_map(&mission.occupancy(), "map.pgm");
    load::write(&out.join("map.yaml"), yaml.as_bytes())?;
    load::write(&out.join("map.pgm"), &pgm)?;
    let (yaml, pgm) = io::save_map(&mission.world.gt_occupancy, "map_gt.pgm");
    load::write(&out.join("map_gt.yaml"), yaml.as_bytes())?;
    load::write(&out.join("map_gt.pgm"), &pgm)?;
    let t: Vec<f64> = mission.rows.iter().map(|r| r.time_s).collect();
    let unexplored: Vec<f64> = mission.rows.iter().map(|r| r.unexplored_pct).collect();
    let cov: Vec<f64> = mission.rows.iter().map(|r| r.cov_trace).collect();
    for (name, ys, label) in [("unexplored", &unexplored, "unexplored (%)"), ("cov_trace", &cov, "cov_trace (m² + rad²)")] {
        load::write(&out.join(format!("{name}.svg")), svg_plot(&t, ys, label).as_bytes())?;
        load::write(&out.join(format!("{name}.png")), &png_plot(&t, ys)?)?;
    }
    println!(
        "{}: {:?} seed {} — {:.0} s simulated in {:.2} s, {:.1} % unexplored, {:.1} m, {} goals, {} GT violations, end {:?}",
        out.display(),
        strategy,
        args.seed,
        summary.time_s,
        wall_s,
        summary.unexplored_pct,
        summary.distance_m,
        summary.goals_reached,
        summary.gt_violations,
        summary.end_reason
    );
    Ok(())
}

const W: f64 = 640.0;
const H: f64 = 400.0;
const MARGIN: [f64; 4] = [70.0, 20.0, 20.0, 50.0]; // left, right, top, bottom

fn range(v: &[f64]) -> (f64, f64) {
    let lo = v.iter().cloned().filter(|x| x.is_finite()).fold(f64::INFINITY, f64::min);
    let hi = v.iter().cloned().filter(|x| x.is_finite()).fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() {
        return (0.0, 1.0);
    }
    let lo = lo.min(0.0);
    if hi - lo < 1e-12 { (lo, lo + 1.0) } else { (lo, hi) }
}

fn to_px(t: f64, y: f64, tr: (f64, f64), yr: (f64, f64)) -> (f64, f64) {
    let px = MARGIN[0] + (t - tr.0) / (tr.1 - tr.0) * (W - MARGIN[0] - MARGIN[1]);
    let py = H - MARGIN[3] - (y - yr.0) / (yr.1 - yr.0) * (H - MARGIN[2] - MARGIN[3]);
    (px, py)
}

/// A line plot of `ys` over time as an SVG document, with axes and tick labels.
fn svg_plot(t: &[f64], ys: &[f64], label: &str) -> String {
    let (tr, yr) = (range(t), range(ys));
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{W}\" height=\"{H}\" font-family=\"sans-serif\" font-size=\"12\">\n\
         <rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
    );
    let (x0, y0) = to_px(tr.0, yr.0, tr, yr);
    let (x1, y1) = to_px(tr.1, yr.1, tr, yr);
    s += &format!("<rect x=\"{x0:.1}\" y=\"{y1:.1}\" width=\"{:.1}\" height=\"{:.1}\" fill=\"none\" stroke=\"black\"/>\n", x1 - x0, y0 - y1);
    for k in 0..=4 {
        let f = k as f64 / 4.0;
        let tv = tr.0 + f * (tr.1 - tr.0);
        let yv = yr.0 + f * (yr.1 - yr.0);
        let (px, _) = to_px(tv, yr.0, tr, yr);
        let (_, py) = to_px(tr.0, yv, tr, yr);
        s += &format!("<text x=\"{px:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{tv:.0}</text>\n", y0 + 18.0);
        s += &format!("<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>\n", x0 - 6.0, py + 4.0, fmt_tick(yv));
    }
    s += &format!("<text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"middle\">time (s)</text>\n", (x0 + x1) / 2.0, H - 8.0);
    s += &format!("<text x=\"14\" y=\"{:.1}\" transform=\"rotate(-90 14 {:.1})\" text-anchor=\"middle\">{label}</text>\n", (y0 + y1) / 2.0, (y0 + y1) / 2.0);
    s += "<polyline fill=\"none\" stroke=\"#1f77b4\" stroke-width=\"1.5\" points=\"";
    for (&tv, &yv) in t.iter().zip(ys) {
        let (px, py) = to_px(tv, yv, tr, yr);
        s += &format!("{px:.1},{py:.1} ");
    }
    s += "\"/>\n</svg>\n";
    s
}

fn fmt_tick(v: f64) -> String {
    if v != 0.0 && (v.abs() < 0.01 || v.abs() >= 1e4) { format!("{v:.1e}") } else { format!("{v:.2}") }
}

/// The same plot as a PNG (frame and curve, no text).
fn png_plot(t: &[f64], ys: &[f64]) -> Result<Vec<u8>> {
    let (w, h) = (W as usize, H as usize);
    let mut rgb = vec![255u8; w * h * 3];
    let mut put = |x: f64, y: f64, c: [u8; 3]| {
        let (xi, yi) = (x.round() as i64, y.round() as i64);
        if xi >= 0 && yi >= 0 && (xi as usize) < w && (yi as usize) < h {
            let o = (yi as usize * w + xi as usize) * 3;
            rgb[o..o + 3].copy_from_slice(&c);
        }
    };
    let (tr, yr) = (range(t), range(ys));
    let (x0, y0) = to_px(tr.0, yr.0, tr, yr);
    let (x1, y1) = to_px(tr.1, yr.1, tr, yr);
    let mut line = |a: (f64, f64), b: (f64, f64), c: [u8; 3]| {
        let n = ((b.0 - a.0).abs().max((b.1 - a.1).abs()).ceil() as usize).max(1);
        for k in 0..=n {
            let f = k as f64 / n as f64;
            put(a.0 + f * (b.0 - a.0), a.1 + f * (b.1 - a.1), c);
        }
    };
    let black = [0, 0, 0];
    line((x0, y0), (x1, y0), black);
    line((x0, y1), (x1, y1), black);
    line((x0, y0), (x0, y1), black);
    line((x1, y0), (x1, y1), black);
    let blue = [31, 119, 180];
    for (a, b) in t.iter().zip(ys).zip(t.iter().zip(ys).skip(1)) {
        line(to_px(*a.0, *a.1, tr, yr), to_px(*b.0, *b.1, tr, yr), blue);
    }
    Ok(io::write_png_rgb8(w, h, &rgb)?)
}
