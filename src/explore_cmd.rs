//! `fitslam explore`: one whole headless mission in a world file (notes §8), its files written
//! by [`crate::mission_run::run_and_write`]. A progress bar (simulated time) shows on a terminal.

use crate::mission_run::{ExtraOutputs, MissionArgs, RunOutput, create_out_dir, end_reason, progress_bar, run_and_write};
use anyhow::Result;
use clap::Args;
use fitslam_core::params::Strategy;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct ExploreArgs {
    #[command(flatten)]
    pub mission: MissionArgs,
    /// Goal selection strategy.
    #[arg(long, value_enum, default_value = "fit")]
    pub strategy: Strategy,
    /// Seed of the sensors' noise and of the random strategy.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Member N of the world file's family: terrain, rocks, landmarks, texture and start drawn
    /// from N (as `compare --world-seeds` draws them); default: the file's world as written.
    #[arg(long)]
    pub world_seed: Option<u64>,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
    /// Also record the mission as a rosbag2 MCAP bag with the node's topics (/tf, /map,
    /// /cloud_map, /fitslam/status), which `select --bag` and `bag-info` read.
    #[arg(long)]
    pub bag: Option<PathBuf>,
    /// Also write the SLAM's factor graph at the end as g2o, in replay order (per keyframe its
    /// new landmarks, then its pose), so that `optimize --incremental --g2o` and
    /// `scripts/compare_isam2.py` replay the mission's updates. The anchor, the gravity factors
    /// and the robust kernel have no g2o form and are left out.
    #[arg(long)]
    pub slam_g2o: Option<PathBuf>,
}

pub fn run(args: &ExploreArgs) -> Result<()> {
    let setup = args.mission.load(args.world_seed)?;
    create_out_dir(&args.out)?;
    let strategy = args.strategy;
    let progress = progress_bar(setup.time_limit_s().ceil() as u64, "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} s simulated");
    let extra = ExtraOutputs { bag: args.bag.as_deref(), slam_g2o: args.slam_g2o.as_deref() };
    let run = run_and_write(&setup, strategy, args.seed, args.mission.localisation, &args.out, &progress, extra);
    progress.finish_and_clear();
    let RunOutput { summary, wall_s, .. } = run?;
    outln!(
        "{}: {} seed {} — {:.0} s simulated in {:.2} s, {:.1} % unexplored, {:.1} m, {} goals, {} GT violations, {} safety stops, {} trap recoveries, end {}",
        args.out.display(),
        strategy,
        args.seed,
        summary.time_s,
        wall_s,
        summary.unexplored_pct,
        summary.distance_m,
        summary.goals_reached,
        summary.gt_violations,
        summary.safety_stops,
        summary.trap_recoveries,
        end_reason(summary.end_reason)
    )?;
    Ok(())
}
