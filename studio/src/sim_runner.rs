//! Runs simulated missions for the *Mission* mode: one `fitslam_core::sim::Mission` per strategy
//! in the same built-in world with the same seed, advanced side by side under a per-frame compute
//! budget (no threads: the browser has none to spare), at a chosen speed in simulated seconds per
//! real second. The core does every simulation step; this module only schedules them.
//!
//! Scheduling (one call of [`SimRunner::advance`] per frame): while playing, the target simulated
//! time grows by `speed × frame dt`; the least advanced running lane is stepped (one 0.1 s tick)
//! until every lane has reached the target or the budget (≈ 8 ms) is used. The target never runs
//! ahead of what was computed (no debt), so a slow machine plays slower, never jerkily catches
//! up. Cost per frame: the budget, plus at most one tick (a decision tick can take tens of ms).
//!
//! Worlds are the repository's `assets/worlds/*.toml`, embedded with the files they name.

use fitslam_core::Params;
use fitslam_core::params::{Strategy, Valid};
use fitslam_core::sim::{EndReason, Localisation, Mission, MissionParams, StepOutcome, World, WorldSpec};
use fitslam_core::slam::Factorisation;
use std::collections::VecDeque;

macro_rules! world_file {
    ($path:literal) => {
        include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/", $path))
    };
}

/// A built-in simulated world: its TOML and the files it names (as named in the TOML).
#[derive(Clone, Copy, Debug)]
pub struct BuiltInWorld {
    pub name: &'static str,
    pub description: &'static str,
    toml: &'static [u8],
    files: &'static [(&'static str, &'static [u8])],
}

static WORLDS: [BuiltInWorld; 4] = [
    BuiltInWorld {
        name: "paper_unstructured_20m",
        description: "20 m × 20 m of procedural hills and ridges, rocks, a box and a ramp (paper-like)",
        toml: world_file!("worlds/paper_unstructured_20m.toml"),
        files: &[],
    },
    BuiltInWorld {
        name: "dem_jacksboro_16m",
        description: "the real Jacksboro fault DEM scaled to a 16 m square, rocks",
        toml: world_file!("worlds/dem_jacksboro_16m.toml"),
        files: &[("../data/terrain/jacksboro_fault_dem.png", world_file!("data/terrain/jacksboro_fault_dem.png"))],
    },
    BuiltInWorld {
        name: "indoor_rooms",
        description: "12 m × 10 m, four rooms from a map_server map, 1 m walls",
        toml: world_file!("worlds/indoor_rooms.toml"),
        files: &[("rooms.yaml", world_file!("worlds/rooms.yaml")), ("rooms.pgm", world_file!("worlds/rooms.pgm"))],
    },
    BuiltInWorld {
        name: "tiny_test",
        description: "5 m × 5 m, gentle hills, two boxes (fast)",
        toml: world_file!("worlds/tiny_test.toml"),
        files: &[],
    },
];

/// Every built-in world; the first is the default.
pub fn worlds() -> &'static [BuiltInWorld] {
    &WORLDS
}

/// Looks a built-in world up by name.
pub fn world(name: &str) -> Option<&'static BuiltInWorld> {
    WORLDS.iter().find(|w| w.name == name)
}

impl BuiltInWorld {
    /// Parses and builds the world with the planner's traversability parameters (the ground
    /// truth uses the same estimator and τ as the robot's map).
    pub fn build(&self, params: &Params) -> Result<World, String> {
        let text = std::str::from_utf8(self.toml).map_err(|e| format!("{}: {e}", self.name))?;
        let spec = WorldSpec::from_toml(text, self.name).map_err(|e| e.to_string())?;
        let world = World::build(&spec, &params.traversability, params.traversability.tau, |name| {
            self.files
                .iter()
                .find(|(n, _)| *n == name)
                .map(|(_, b)| b.to_vec())
                .ok_or_else(|| format!("not embedded in the studio: {name}"))
        })
        .map_err(|e| format!("{}: {e}", self.name))?;
        world.check_start(params.robot.radius_m).map_err(|e| format!("{}: {e}", self.name))?;
        Ok(world)
    }
}

/// Short name of a localisation mode.
pub fn localisation_label(l: Localisation) -> String {
    match l {
        Localisation::GroundTruth => "ground truth".into(),
        Localisation::Odometry => "odometry".into(),
        Localisation::Slam => "landmark SLAM".into(),
        Localisation::PoseGraph => "pose-graph SLAM".into(),
    }
}

/// What to run.
#[derive(Clone, Debug, PartialEq)]
pub struct MissionConfig {
    /// Built-in world name.
    pub world: String,
    /// One lane per strategy, in this order.
    pub strategies: Vec<Strategy>,
    /// Sensor-noise (and random-strategy) seed, the same for every lane.
    pub seed: u64,
    pub localisation: Localisation,
    /// The batch SLAM solver's reproducible factorisation: the same bits on every CPU, in the
    /// browser and in `fitslam explore` with `factorisation = "reproducible"` (README, "Same
    /// seed, same run"); the default incremental solver does not factorise with faer and is the
    /// same everywhere without it.
    pub reproducible_slam: bool,
    /// Simulator parameters as `fitslam explore --sim-params` reads them: TOML over the
    /// defaults (a key left out keeps its default); empty or blank: the defaults.
    pub sim_params_toml: String,
}

impl MissionConfig {
    /// The simulator parameters of this configuration, or the message of what is wrong with
    /// `sim_params_toml` (naming the line or the key).
    pub fn mission_params(&self) -> Result<Valid<MissionParams>, String> {
        let mut p = match self.sim_params_toml.trim() {
            "" => MissionParams::default(),
            _ => MissionParams::from_toml(&self.sim_params_toml, "simulator parameters").map_err(|e| e.to_string())?.into_inner(),
        };
        if self.reproducible_slam {
            p.slam.graph.optimizer.factorisation = Factorisation::Reproducible;
        }
        Valid::new(p).map_err(|e| format!("simulator parameters: {e}"))
    }
}

impl Default for MissionConfig {
    fn default() -> Self {
        Self {
            world: WORLDS[0].name.into(),
            strategies: vec![Strategy::Fit, Strategy::Greedy, Strategy::Random],
            seed: 0,
            localisation: Localisation::GroundTruth,
            reproducible_slam: false,
            sim_params_toml: String::new(),
        }
    }
}

/// One mission of the side-by-side run.
pub struct Lane {
    pub strategy: Strategy,
    pub mission: Mission,
    /// Set once the mission has ended.
    pub end: Option<EndReason>,
    /// Decisions made so far (for "step to the next decision").
    pub decisions: u64,
    /// Times the robot, walled in by its map, forgot it around itself (`trap_recoveries`).
    pub trap_recoveries: u64,
    /// Paths planned with a tight inflation when the full one left no goal (`tight_plans`).
    pub tight_plans: u64,
}

impl Lane {
    pub fn running(&self) -> bool {
        self.end.is_none()
    }

    fn step(&mut self) {
        if let StepOutcome::Finished(r) = self.mission.step() {
            self.end = Some(r);
        }
        let s = self.mission.summary();
        (self.decisions, self.trap_recoveries, self.tight_plans) = (s.decisions, s.trap_recoveries, s.tight_plans);
    }
}

/// Play state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RunState {
    Paused,
    Playing,
    /// Every running lane steps until it has made one more decision, then pauses.
    StepDecision,
}

/// Default compute budget per frame, milliseconds.
pub const DEFAULT_BUDGET_MS: f64 = 8.0;

/// The side-by-side missions and their scheduler.
pub struct SimRunner {
    pub config: MissionConfig,
    /// Planner parameters the missions were started with.
    pub params: Valid<Params>,
    world: World,
    pub lanes: Vec<Lane>,
    pub state: RunState,
    /// Simulated seconds per real second; `f64::INFINITY` = as fast as the budget allows.
    pub speed: f64,
    /// Compute budget per frame, milliseconds.
    pub budget_ms: f64,
    target_s: f64,
    /// Ticks run in total and in the last `advance`.
    pub ticks: u64,
    pub last_frame_ticks: u64,
    /// Milliseconds spent in the last `advance`.
    pub last_frame_ms: f64,
    /// (real s, simulated s of the least advanced running lane) while playing, last ~2 s.
    meter: VecDeque<(f64, f64)>,
    /// Target decision counts of a "step to the next decision".
    decision_targets: Vec<u64>,
}

impl SimRunner {
    /// Builds the world and one mission per strategy.
    pub fn new(config: MissionConfig, params: &Params) -> Result<Self, String> {
        let w = world(&config.world).ok_or_else(|| format!("no built-in world named '{}'", config.world))?;
        let params = Valid::new(params.clone()).map_err(|e| format!("planner parameters: {e}"))?;
        let world = w.build(&params)?;
        let mut r = Self {
            config,
            params,
            world,
            lanes: Vec::new(),
            state: RunState::Paused,
            speed: 20.0,
            budget_ms: DEFAULT_BUDGET_MS,
            target_s: 0.0,
            ticks: 0,
            last_frame_ticks: 0,
            last_frame_ms: 0.0,
            meter: VecDeque::new(),
            decision_targets: Vec::new(),
        };
        r.reset()?;
        Ok(r)
    }

    /// The world (ground truth) the lanes run in.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// Restarts every lane from time 0 with the same configuration (the world is not rebuilt).
    pub fn reset(&mut self) -> Result<(), String> {
        let mission_params = self.config.mission_params()?;
        let mut lanes = Vec::with_capacity(self.config.strategies.len());
        for &s in &self.config.strategies {
            let mission = Mission::new(
                self.world.clone(),
                self.params.clone(),
                mission_params.clone(),
                s,
                self.config.seed,
                self.config.localisation,
            )
            .map_err(|e| format!("{} / {}: {e}", self.config.world, s.name()))?;
            let decisions = mission.summary().decisions;
            let mut lane = Lane { strategy: s, mission, end: None, decisions, trap_recoveries: 0, tight_plans: 0 };
            lane.mission.set_clock(Box::new(|| web_time::Instant::now().duration_since(clock_origin()).as_secs_f64() * 1e3));
            lanes.push(lane);
        }
        self.lanes = lanes;
        self.state = RunState::Paused;
        self.target_s = 0.0;
        self.ticks = 0;
        self.meter.clear();
        self.decision_targets.clear();
        Ok(())
    }

    /// Simulated time of the least advanced running lane (of the most advanced if all ended).
    pub fn time_s(&self) -> f64 {
        let running = self.lanes.iter().filter(|l| l.running()).map(|l| l.mission.time_s());
        let t = running.fold(f64::INFINITY, f64::min);
        if t.is_finite() { t } else { self.lanes.iter().map(|l| l.mission.time_s()).fold(0.0, f64::max) }
    }

    /// Whether every lane has ended.
    pub fn finished(&self) -> bool {
        self.lanes.iter().all(|l| !l.running())
    }

    pub fn play(&mut self) {
        if !self.finished() {
            self.target_s = self.time_s();
            self.meter.clear();
            self.state = RunState::Playing;
        }
    }

    pub fn pause(&mut self) {
        self.state = RunState::Paused;
        self.meter.clear();
    }

    /// One control tick (0.1 s simulated) of every running lane, now.
    pub fn step_tick(&mut self) {
        self.pause();
        for lane in self.lanes.iter_mut().filter(|l| l.running()) {
            lane.step();
            self.ticks += 1;
        }
        self.target_s = self.time_s();
    }

    /// Runs every running lane until it has made its next decision (over the next frames,
    /// within the budget), then pauses.
    pub fn step_decision(&mut self) {
        self.decision_targets = self.lanes.iter().map(|l| l.decisions + 1).collect();
        self.meter.clear();
        self.state = RunState::StepDecision;
    }

    /// Advances the lanes for one frame of `frame_dt_s` real seconds; `now_ms` is a wall clock
    /// in milliseconds (used for the budget and the speed meter only: the simulation itself is
    /// deterministic). Returns whether anything was stepped.
    pub fn advance(&mut self, frame_dt_s: f64, mut now_ms: impl FnMut() -> f64) -> bool {
        let t0 = now_ms();
        let deadline = t0 + self.budget_ms;
        let before = self.ticks;
        match self.state {
            RunState::Paused => {}
            RunState::Playing => {
                self.target_s += self.speed * frame_dt_s.clamp(0.0, 0.1);
                loop {
                    // The least advanced running lane below the target (ties: first lane).
                    let next = self
                        .lanes
                        .iter()
                        .enumerate()
                        .filter(|(_, l)| l.running() && l.mission.time_s() + 0.5 * l.mission.mission_params().dt_s <= self.target_s)
                        .min_by(|a, b| a.1.mission.time_s().total_cmp(&b.1.mission.time_s()))
                        .map(|(i, _)| i);
                    let Some(i) = next else { break };
                    self.lanes[i].step();
                    self.ticks += 1;
                    if now_ms() >= deadline {
                        break;
                    }
                }
                // No debt: the target never runs ahead of what was computed.
                self.target_s = self.target_s.min(self.time_s());
                if self.finished() {
                    self.state = RunState::Paused;
                }
            }
            RunState::StepDecision => {
                'budget: loop {
                    let mut any = false;
                    for (lane, &target) in self.lanes.iter_mut().zip(&self.decision_targets) {
                        if lane.running() && lane.decisions < target {
                            lane.step();
                            self.ticks += 1;
                            any = true;
                        }
                    }
                    if !any {
                        self.state = RunState::Paused;
                        break;
                    }
                    if now_ms() >= deadline {
                        break 'budget;
                    }
                }
                self.target_s = self.time_s();
            }
        }
        let t1 = now_ms();
        self.last_frame_ticks = self.ticks - before;
        self.last_frame_ms = t1 - t0;
        if self.state == RunState::Playing {
            self.meter.push_back((t1 * 1e-3, self.time_s()));
            while self.meter.len() > 2 && self.meter.front().is_some_and(|(t, _)| t1 * 1e-3 - t > 2.0) {
                self.meter.pop_front();
            }
        }
        self.last_frame_ticks > 0
    }

    /// Simulated seconds per real second achieved over the last ~2 s of play (per lane: every
    /// lane advances at this rate), or None before enough frames.
    pub fn achieved_speed(&self) -> Option<f64> {
        let (&(r0, s0), &(r1, s1)) = (self.meter.front()?, self.meter.back()?);
        (r1 - r0 > 0.25).then(|| (s1 - s0) / (r1 - r0))
    }
}

/// The outputs of one whole mission that the CLI writes too, to compare them file for file.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct WholeMission {
    /// As `fitslam explore` writes `metrics.csv`.
    pub metrics_csv: String,
    /// As `fitslam explore` writes `trajectory_est.tum`.
    pub trajectory_est_tum: String,
    pub end: String,
}

/// Runs one mission on a built-in world from start to end at once (default planner parameters;
/// `mission_params`, as `fitslam explore --sim-params`): for page scripts, and for the browser
/// test's check that a whole mission in wasm is the CLI's, to the bit. O(the mission).
pub fn run_to_end(
    world_name: &str,
    strategy: Strategy,
    seed: u64,
    localisation: Localisation,
    mission_params: Valid<MissionParams>,
) -> Result<WholeMission, String> {
    let w = world(world_name).ok_or_else(|| format!("no built-in world named '{world_name}'"))?;
    let params = Valid::<Params>::default();
    let mut mission = Mission::new(w.build(&params)?, params, mission_params, strategy, seed, localisation)
        .map_err(|e| format!("{world_name} / {}: {e}", strategy.name()))?;
    let end = mission.run().end_reason;
    Ok(WholeMission {
        metrics_csv: fitslam_core::sim::metrics_csv(mission.rows()),
        trajectory_est_tum: fitslam_core::sim::tum(mission.trajectory_est()),
        end: end.map_or_else(String::new, |e| format!("{e:?}")),
    })
}

/// A fixed origin for the missions' wall clock (`plan_ms` only).
fn clock_origin() -> web_time::Instant {
    use std::sync::OnceLock;
    static ORIGIN: OnceLock<web_time::Instant> = OnceLock::new();
    *ORIGIN.get_or_init(web_time::Instant::now)
}

/// Milliseconds since [`clock_origin`] (the budget's clock).
pub fn now_ms() -> f64 {
    web_time::Instant::now().duration_since(clock_origin()).as_secs_f64() * 1e3
}

#[cfg(test)]
mod tests {
    use super::*;

    fn config(strategies: Vec<Strategy>, seed: u64) -> MissionConfig {
        MissionConfig { world: "tiny_test".into(), strategies, seed, localisation: Localisation::Odometry, ..MissionConfig::default() }
    }

    /// A fake clock that never runs out of budget: `advance` then stops only at the target.
    fn frozen() -> impl FnMut() -> f64 {
        || 0.0
    }

    #[test]
    fn a_whole_mission_at_once_is_the_lane_run_to_its_end() {
        let whole = run_to_end("tiny_test", Strategy::Greedy, 2, Localisation::GroundTruth, Default::default()).unwrap();
        let mut lane = SimRunner::new(
            MissionConfig {
                world: "tiny_test".into(),
                strategies: vec![Strategy::Greedy],
                seed: 2,
                localisation: Localisation::GroundTruth,
                ..MissionConfig::default()
            },
            &Params::default(),
        )
        .unwrap();
        while lane.lanes[0].running() {
            lane.lanes[0].step();
        }
        assert_eq!(whole.metrics_csv, fitslam_core::sim::metrics_csv(lane.lanes[0].mission.rows()));
        assert_eq!(whole.end, format!("{:?}", lane.lanes[0].end.unwrap()));
        assert!(whole.metrics_csv.lines().count() > 10 && whole.trajectory_est_tum.lines().count() > 10);
        assert!(run_to_end("nowhere", Strategy::Fit, 1, Localisation::GroundTruth, Default::default()).is_err());
    }

    #[test]
    fn the_reproducible_switch_sets_the_slam_factorisation_and_nothing_else() {
        let mut c = config(vec![Strategy::Fit], 1);
        assert_eq!(c.mission_params().map(Valid::into_inner), Ok(MissionParams::default()));
        c.reproducible_slam = true;
        let mut expected = MissionParams::default();
        expected.slam.graph.optimizer.factorisation = Factorisation::Reproducible;
        assert_eq!(c.mission_params().map(Valid::into_inner), Ok(expected.clone()));
        assert_ne!(expected, MissionParams::default());
    }

    /// The simulator-parameter text is read as `--sim-params` is: keys it names change, the rest
    /// keep their defaults; a blank text is the defaults; a bad one stops the runner with a
    /// message naming the line, or the key.
    #[test]
    fn the_simulator_parameter_text_is_read_over_the_defaults() {
        let mut c = config(vec![Strategy::Greedy], 1);
        c.sim_params_toml = " \n".into();
        assert_eq!(c.mission_params().map(Valid::into_inner), Ok(MissionParams::default()));
        c.sim_params_toml = "[explore]\ntight_inflations_m = [0.2, 0.1]\n[lidar]\nmax_range_m = 8.0\n".into();
        let p = c.mission_params().unwrap();
        assert_eq!((p.explore.tight_inflations_m.as_slice(), p.lidar.max_range_m), ([0.2, 0.1].as_slice(), 8.0));
        assert_eq!(p.drive, MissionParams::default().drive);
        c.sim_params_toml = "[lidar]\nmax_range_m = \"far\"\n".into();
        let e = c.mission_params().unwrap_err();
        assert!(e.contains("simulator parameters") && e.contains("line 2"), "{e}");
        c.sim_params_toml = "tight_inflations_m = [0.1, 0.2]".into();
        let e = c.mission_params().unwrap_err();
        assert!(e.contains("`tight_inflations_m` has moved") && e.contains("[explore]"), "{e}");
        c.sim_params_toml = "[explore]\ntight_inflations_m = [0.1, 0.2]".into();
        let e = SimRunner::new(c, &Params::default()).err().unwrap();
        assert!(e.contains("tight_inflations_m[1] must be smaller"), "{e}");
    }

    #[test]
    fn every_builtin_world_builds() {
        for w in worlds() {
            let world = w.build(&Params::default()).unwrap_or_else(|e| panic!("{e}"));
            assert!(world.explorable_count > 0, "{}", w.name);
        }
    }

    #[test]
    fn same_seed_same_rows_through_the_runner() {
        let run = || {
            let mut r = SimRunner::new(config(vec![Strategy::Fit, Strategy::Random], 3), &Params::default()).unwrap();
            r.speed = 30.0;
            r.play();
            // 20 frames of 0.05 s at 30× = 30 s simulated.
            for _ in 0..20 {
                r.advance(0.05, frozen());
            }
            r.lanes.iter().map(|l| fitslam_core::sim::metrics_csv(l.mission.rows())).collect::<Vec<_>>()
        };
        let (a, b) = (run(), run());
        assert_eq!(a, b);
        // 30 s: a header line, then one row per simulated second from t = 0 (31 rows).
        assert!(a.iter().all(|csv| csv.lines().count() >= 32), "{a:?}");
    }

    #[test]
    fn playing_advances_every_lane_to_the_target_in_lockstep() {
        let mut r = SimRunner::new(config(vec![Strategy::Fit, Strategy::Greedy], 1), &Params::default()).unwrap();
        r.speed = 10.0;
        r.advance(0.1, frozen());
        assert_eq!(r.time_s(), 0.0, "paused: nothing moves");
        r.play();
        r.advance(0.1, frozen()); // target 1 s
        for l in &r.lanes {
            assert!((l.mission.time_s() - 1.0).abs() < 1e-6, "{}", l.mission.time_s());
        }
        assert_eq!(r.last_frame_ticks, 20);
    }

    #[test]
    fn an_exhausted_budget_stops_the_frame_without_debt() {
        let mut r = SimRunner::new(config(vec![Strategy::Fit], 1), &Params::default()).unwrap();
        r.speed = 100.0;
        r.play();
        // Every clock reading is 1 s later: the budget is gone after the first tick.
        let mut t = 0.0;
        r.advance(0.1, || {
            t += 1000.0;
            t
        });
        assert_eq!(r.last_frame_ticks, 1);
        assert!((r.time_s() - 0.1).abs() < 1e-9);
        // The 10 s not computed are not owed: the next frame aims at 0.1 + 100 × 0.01 = 1.1 s.
        r.advance(0.01, frozen());
        assert!((r.time_s() - 1.1).abs() < 1e-6, "{}", r.time_s());
    }

    #[test]
    fn step_tick_and_step_decision() {
        let mut r = SimRunner::new(config(vec![Strategy::Fit, Strategy::Greedy], 2), &Params::default()).unwrap();
        r.step_tick();
        assert!(r.lanes.iter().all(|l| (l.mission.time_s() - 0.1).abs() < 1e-9));
        assert_eq!(r.state, RunState::Paused);
        let before: Vec<u64> = r.lanes.iter().map(|l| l.mission.summary().decisions).collect();
        r.step_decision();
        for _ in 0..1000 {
            if r.state == RunState::Paused {
                break;
            }
            r.advance(0.016, frozen());
        }
        assert_eq!(r.state, RunState::Paused);
        for (l, b) in r.lanes.iter().zip(before) {
            assert!(l.end.is_some() || l.mission.summary().decisions == b + 1, "{:?}", l.strategy);
            assert!(l.mission.last_decision().is_some());
        }
    }
}
