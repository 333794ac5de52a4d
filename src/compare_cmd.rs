//! `fitslam compare`: the paper's experiment (notes §8) on one machine. It is `fitslam plan`
//! ([`crate::sweep`]: every strategy × world seed × seed, one `explore` mission each, into
//! `DIR/[world_<w>/]<strategy>/seed_<s>/`), then `fitslam run` over every entry on `--jobs`
//! threads, then `fitslam collect` ([`crate::report`]: summary.csv, summary.md and the figures
//! from the runs' files), so its output is byte for byte what those three give wherever the runs
//! were made. Runs already done in DIR (same plan) are kept; a plan already in DIR is replaced,
//! and a run folder of another plan is refused (remove it).

use crate::mission_run::progress_bar;
use crate::report;
use crate::sweep::run::{MAX_JOBS, Ran, run_entries};
use crate::sweep::{OtherPlan, PlanArgs, collect::collect, plan, write_plan};
use anyhow::{Result, bail};
use clap::Args;

#[derive(Args, Debug)]
pub struct CompareArgs {
    #[command(flatten)]
    pub plan: PlanArgs,
    /// Parallel runs (rayon threads), at most 1024 and never more than the runs; default: the
    /// available cores.
    #[arg(long)]
    pub jobs: Option<usize>,
}

pub fn run(args: &CompareArgs) -> Result<()> {
    let jobs = match args.jobs {
        Some(0) => bail!("--jobs 0: at least one thread is needed"),
        Some(j) if j > MAX_JOBS => bail!("--jobs {j}: at most {MAX_JOBS} (each run holds its own world and maps)"),
        Some(j) => j,
        None => std::thread::available_parallelism().map(usize::from).unwrap_or(1),
    };
    let (sweep, entries) = plan(&args.plan)?;
    let out = &args.plan.out;
    write_plan(out, &sweep, &entries, OtherPlan::Replace)?;
    let bar = progress_bar(entries.len() as u64, "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} runs {msg}");
    let wall = std::time::Instant::now();
    let all: Vec<_> = entries.iter().collect();
    let ran = run_entries(out, &all, jobs.min(entries.len()), &bar)?;
    bar.finish_and_clear();
    let wall_s = wall.elapsed().as_secs_f64();
    let run_wall_s: f64 = ran.iter().map(|r| if let Ran::Now { wall_s } = r { *wall_s } else { 0.0 }).sum();
    let (_, figures) = collect(out)?;
    let worlds = entries.iter().map(|e| e.world_seed).collect::<std::collections::BTreeSet<_>>().len();
    outln!(
        "{}: {} runs ({} strategies × {} × {} seeds) in {:.1} s wall on {} threads ({:.1} s of missions); {}",
        out.display(),
        figures.len(),
        sweep.strategies.len(),
        if worlds == 1 { "1 world".to_string() } else { format!("{worlds} worlds") },
        args.plan.seeds,
        wall_s,
        jobs.min(entries.len()),
        run_wall_s,
        report::files(&figures)
    )?;
    Ok(())
}
