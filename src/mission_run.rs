//! One whole mission from files, shared by `fitslam explore` and `fitslam compare`: the options
//! they share ([`MissionArgs`]), the world and parameters read and built once ([`Setup`]), and a
//! run that writes every output file ([`run_and_write`]): `metrics.csv` (byte-identical for a
//! seed), `timing.csv` (wall time of the decisions), `tracking_losses.csv` (each loss of visual
//! tracking and its ground), `trajectory_est.tum` / `trajectory_gt.tum`,
//! `summary.json`, the final maps (map_server YAML + PGM: the robot's map and the ground truth),
//! and plots of % unexplored and cov_trace over time (SVG and PNG, [`crate::plot`]).

use crate::load;
use crate::plot::{self, Curve};
use anyhow::{Context, Result, bail};
use clap::Args;
use fitslam_core::explore::EndReason;
use fitslam_core::io;
use fitslam_core::params::{Params, Strategy, Valid};
use fitslam_core::sim::recorder::MissionRecorder;
use fitslam_core::sim::{
    Localisation, MetricsRow, Mission, MissionParams, StepOutcome, Summary, World, WorldSpec, metrics_csv, timing_csv, tracking_losses_csv,
    tum,
};
use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::path::{Path, PathBuf};

/// The options `explore` and `compare` share: the world, the parameters, the localisation.
#[derive(Args, Debug)]
pub struct MissionArgs {
    /// World file (TOML, see assets/worlds/).
    #[arg(long, alias = "worlds")]
    pub world: PathBuf,
    /// Planner parameters (TOML or YAML); default: the paper's.
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Simulator parameters (TOML, `MissionParams`); default: built-in.
    #[arg(long)]
    pub sim_params: Option<PathBuf>,
    /// Localisation.
    #[arg(long, value_enum, default_value = "slam")]
    pub localisation: Localisation,
    /// Overrides the world's time limit, seconds.
    #[arg(long)]
    pub time_limit_s: Option<f64>,
}

impl MissionArgs {
    /// Reads and builds the world and the parameters; with a world seed, the member of the world
    /// file's family drawn for it (`WorldSpec::with_world_seed`) with a start drawn on it
    /// (`World::draw_start`).
    pub fn load(&self, world_seed: Option<u64>) -> Result<Setup> {
        load_setup(&self.world, self.params.as_deref(), self.sim_params.as_deref(), self.time_limit_s, world_seed)
    }
}

/// Creates the output folder before a mission runs, so that a path that cannot be one (an
/// existing file, no permission) fails at once rather than after the mission.
pub fn create_out_dir(out: &std::path::Path) -> Result<()> {
    std::fs::create_dir_all(out).with_context(|| format!("--out {}: cannot create the output folder", out.display()))
}

/// The end reason as `summary.json` and `summary.csv` name it.
pub fn end_reason(r: Option<EndReason>) -> &'static str {
    r.map_or("none", EndReason::as_str)
}

/// A progress bar of `len` steps drawn on stderr, hidden unless stdout and stderr are terminals.
pub fn progress_bar(len: u64, template: &str) -> ProgressBar {
    if !(std::io::stdout().is_terminal() && std::io::stderr().is_terminal()) {
        return ProgressBar::hidden();
    }
    let bar = ProgressBar::new(len);
    if let Ok(style) = ProgressStyle::with_template(template) {
        bar.set_style(style);
    }
    bar
}

/// What every mission in one world shares: the built world and the parameters.
pub struct Setup {
    pub world_name: String,
    pub world: World,
    pub params: Valid<Params>,
    pub mission_params: Valid<MissionParams>,
}

impl Setup {
    /// The mission's time limit: the simulator parameters' override, else the world's.
    pub fn time_limit_s(&self) -> f64 {
        self.mission_params.time_limit_s.unwrap_or(self.world.spec.time_limit_s)
    }
}

/// Reads and checks a world file (nothing built yet).
pub fn read_world_spec(world: &Path) -> Result<WorldSpec> {
    let name = world.display().to_string();
    let text = String::from_utf8(load::read(world)?).with_context(|| format!("{name}: not UTF-8"))?;
    Ok(WorldSpec::from_toml(&text, &name)?)
}

/// The simulator parameters from `sim_params` (default: built-in), with `time_limit_s`
/// overriding the world's, checked.
pub fn load_mission_params(sim_params: Option<&Path>, time_limit_s: Option<f64>) -> Result<Valid<MissionParams>> {
    let mut mission_params = match sim_params {
        None => MissionParams::default(),
        Some(p) => {
            let text = String::from_utf8(load::read(p)?).with_context(|| format!("{}: not UTF-8", p.display()))?;
            MissionParams::from_toml(&text, &p.display().to_string())?.into_inner()
        }
    };
    if let Some(t) = time_limit_s {
        if !(t.is_finite() && t > 0.0) {
            bail!("--time-limit-s {t}: must be a positive number of seconds");
        }
        mission_params.time_limit_s = Some(t);
    }
    Ok(Valid::new(mission_params)?)
}

/// Reads and builds a world with the planner (`params`, default: the paper's) and simulator
/// (`sim_params`, default: built-in) parameters; `time_limit_s` overrides the world's.
pub fn load_setup(
    world: &Path,
    params: Option<&Path>,
    sim_params: Option<&Path>,
    time_limit_s: Option<f64>,
    world_seed: Option<u64>,
) -> Result<Setup> {
    build_setup(world, load::params(params)?, load_mission_params(sim_params, time_limit_s)?, world_seed)
}

/// Builds the world of the file `world` (with a world seed: the member of its family drawn for
/// it, with a start drawn on it) for these parameters.
pub fn build_setup(world: &Path, params: Valid<Params>, mission_params: Valid<MissionParams>, world_seed: Option<u64>) -> Result<Setup> {
    let world_name = world.display().to_string();
    let spec = read_world_spec(world)?;
    let dir = world.parent().map(Path::to_path_buf).unwrap_or_default();
    let build = |spec: &WorldSpec, name: &str| {
        World::build(spec, &params.traversability, params.traversability.tau, |file| {
            std::fs::read(dir.join(file)).map_err(|e| format!("cannot read {}: {e}", dir.join(file).display()))
        })
        .with_context(|| name.to_string())
    };
    let (world, world_name) = match world_seed {
        None => (build(&spec, &world_name)?, world_name),
        Some(w) => {
            let name = format!("{world_name} (world seed {w})");
            let mut member = spec.with_world_seed(w);
            if !spec.family.keep_start {
                member.start = build(&member, &name)?
                    .draw_start(w, params.robot.radius_m)
                    .with_context(|| format!("{name}: no cell where the robot fits to start from"))?;
            }
            (build(&member, &name)?, name)
        }
    };
    world.check_start(params.robot.radius_m).with_context(|| world_name.clone())?;
    Ok(Setup { world_name, world, params, mission_params })
}

/// One finished mission.
pub struct RunOutput {
    pub summary: Summary,
    /// Wall time of the mission (not of the writing), seconds.
    pub wall_s: f64,
}

/// Files a mission writes besides those in its output folder.
#[derive(Clone, Copy, Debug, Default)]
pub struct ExtraOutputs<'a> {
    /// A rosbag2 MCAP bag of the mission.
    pub bag: Option<&'a Path>,
    /// The SLAM's factor graph at the end, as g2o in replay order (`GraphSlam::to_g2o`).
    pub slam_g2o: Option<&'a Path>,
}

/// Runs one mission of `setup` and writes every output file into `out`; `progress` follows the
/// simulated time in seconds.
pub fn run_and_write(
    setup: &Setup,
    strategy: Strategy,
    seed: u64,
    localisation: Localisation,
    out: &Path,
    progress: &ProgressBar,
    extra: ExtraOutputs,
) -> Result<RunOutput> {
    if extra.slam_g2o.is_some() && !localisation.is_slam() {
        anyhow::bail!("--slam-g2o needs --localisation slam or pose-graph (this mission has no factor graph)");
    }
    let bag = extra.bag;
    let world_name = &setup.world_name;
    let mut mission = Mission::new(setup.world.clone(), setup.params.clone(), setup.mission_params.clone(), strategy, seed, localisation)
        .map_err(|e| anyhow::anyhow!("{world_name}: {e}"))?;
    let t0 = std::time::Instant::now();
    mission.set_clock(Box::new(move || t0.elapsed().as_secs_f64() * 1e3));
    let wall = std::time::Instant::now();
    let mut recorder = bag.map(|_| MissionRecorder::new());
    loop {
        let outcome = mission.step();
        if let Some(r) = recorder.as_mut() {
            r.record(&mut mission);
        }
        if outcome != StepOutcome::Running {
            break;
        }
        progress.set_position(mission.time_s() as u64);
    }
    let summary = mission.summary();
    let wall_s = wall.elapsed().as_secs_f64();

    if let (Some(path), Some(r)) = (bag, recorder) {
        load::write(path, &r.finish())?;
    }
    if let (Some(path), Some(fe)) = (extra.slam_g2o, mission.slam_frontend()) {
        let (file, left_out) = fe.backend().to_g2o();
        load::write(path, fitslam_core::slam::g2o::write_g2o(&file).as_bytes())?;
        eprintln!(
            "{}: {} vertices, {} edges ({left_out} factors without a g2o form left out)",
            path.display(),
            file.vertices.len(),
            file.edges.len()
        );
    }
    load::write(&out.join("metrics.csv"), metrics_csv(mission.rows()).as_bytes())?;
    load::write(&out.join("timing.csv"), timing_csv(mission.rows()).as_bytes())?;
    load::write(&out.join("tracking_losses.csv"), tracking_losses_csv(mission.tracking_losses()).as_bytes())?;
    load::write(&out.join("trajectory_gt.tum"), tum(mission.trajectory_gt()).as_bytes())?;
    load::write(&out.join("trajectory_est.tum"), tum(mission.trajectory_est()).as_bytes())?;
    let mut json = serde_json::to_value(&summary)?;
    json["wall_time_s"] = serde_json::json!(wall_s);
    load::write(&out.join("summary.json"), serde_json::to_string_pretty(&json)?.as_bytes())?;
    let (yaml, pgm) = io::save_map(&mission.occupancy(), "map.pgm");
    load::write(&out.join("map.yaml"), yaml.as_bytes())?;
    load::write(&out.join("map.pgm"), &pgm)?;
    let (yaml, pgm) = io::save_map(&mission.world().gt_occupancy, "map_gt.pgm");
    load::write(&out.join("map_gt.yaml"), yaml.as_bytes())?;
    load::write(&out.join("map_gt.pgm"), &pgm)?;
    let rows = mission.rows().to_vec();
    let label = format!("{strategy} seed {seed}");
    let t: Vec<f64> = rows.iter().map(|r| r.time_s).collect();
    let curve = |y: Vec<f64>| Curve { label: label.clone(), x: t.clone(), y, band: None };
    let subject = format!("{} — {label}", setup.world.spec.name);
    let curves = |f: fn(&MetricsRow) -> f64| vec![curve(rows.iter().map(f).collect())];
    plot::write_mission_figures(out, &subject, curves(|r| r.unexplored_pct), curves(|r| r.cov_trace))?;
    Ok(RunOutput { summary, wall_s })
}
