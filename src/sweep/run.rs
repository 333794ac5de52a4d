//! `fitslam run DIR --index I` / `--indices A..B`: runs plan entries, each into its folder.
//!
//! Idempotent: an entry whose folder holds `entry.json` with its hash is skipped. Atomic: a run
//! writes into `DIR/.partial/<index>-<pid>-<n>/` and renames that into place when every file,
//! `entry.json` last, is written, so a folder is whole or absent; a run killed mid-way leaves only
//! its `.partial` folder, which nothing reads, and is simply run again.

use super::{CODE, Entry, file_sha256, parse_indices, read_plan};
use crate::load;
use crate::mission_run::{ExtraOutputs, Setup, build_setup, progress_bar, run_and_write};
use anyhow::{Context, Result, bail};
use clap::Args;
use fitslam_core::params::Valid;
use indicatif::ProgressBar;
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

#[derive(Args, Debug)]
pub struct RunArgs {
    /// The plan's folder (`fitslam plan --out DIR`).
    pub dir: PathBuf,
    /// One entry (a line of plan.jsonl, from 0): e.g. `$SLURM_ARRAY_TASK_ID`,
    /// `$JOB_COMPLETION_INDEX`.
    #[arg(long, conflicts_with = "indices")]
    pub index: Option<usize>,
    /// Entries A..B (inclusive) or N; default: every entry.
    #[arg(long)]
    pub indices: Option<String>,
    /// Parallel runs (threads); default 1.
    #[arg(long, default_value_t = 1)]
    pub jobs: usize,
    /// Run nothing: print the indices (of those chosen) whose output is not in place yet, one
    /// per line (what a driver such as scripts/ray-compare submits).
    #[arg(long)]
    pub pending: bool,
}

/// Most `--jobs` accepted.
pub const MAX_JOBS: usize = 1024;

/// What running one entry did.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Ran {
    /// Ran now; the mission's own wall time, seconds.
    Now { wall_s: f64 },
    /// Its folder already held its output.
    Before,
}

/// Whether `folder` holds the whole output of `entry`: `Ok(true)` if its `entry.json` carries the
/// entry's hash, `Ok(false)` if there is no such folder, an error naming the folder otherwise.
pub fn done(folder: &Path, entry: &Entry) -> Result<bool> {
    if !folder.exists() {
        return Ok(false);
    }
    let marker = folder.join("entry.json");
    let made: Entry = serde_json::from_slice(&load::read(&marker).with_context(|| {
        format!(
            "{}: an output folder without its entry.json (corrupt, or not made by `fitslam run`); remove it and run again",
            folder.display()
        )
    })?)
    .with_context(|| format!("{}: not a plan entry; remove the folder and run again", marker.display()))?;
    if made.hash != entry.hash {
        bail!(
            "{}: made by another plan entry (hash {}, this plan's entry {} has {}); remove it or plan into a new folder",
            folder.display(),
            &made.hash[..made.hash.len().min(12)],
            entry.index,
            &entry.hash[..entry.hash.len().min(12)]
        );
    }
    Ok(true)
}

/// The worlds of `entries`, each built once (in parallel on the current pool), keyed by
/// [`world_key`].
pub fn build_worlds(entries: &[&Entry]) -> Result<BTreeMap<String, Setup>> {
    let mut firsts: BTreeMap<String, &Entry> = BTreeMap::new();
    for e in entries {
        firsts.entry(world_key(e)?).or_insert(e);
    }
    let firsts: Vec<(String, &Entry)> = firsts.into_iter().collect();
    firsts
        .par_iter()
        .map(|(key, e)| {
            if file_sha256(&e.world)? != e.world_sha256 {
                bail!("{}: changed since the plan was made (its SHA-256 differs); plan again", e.world.display());
            }
            let params = Valid::new(e.params.clone()).with_context(|| format!("plan entry {}: planner parameters", e.index))?;
            let sim = Valid::new(e.sim_params.clone()).with_context(|| format!("plan entry {}: simulator parameters", e.index))?;
            Ok((key.clone(), build_setup(&e.world, params, sim, e.world_seed)?))
        })
        .collect()
}

/// What an entry's world depends on: its file, member and parameters.
fn world_key(e: &Entry) -> Result<String> {
    Ok(serde_json::to_string(&(&e.world, &e.world_sha256, e.world_seed, &e.params, &e.sim_params))?)
}

/// Refuses an entry planned by another build of fitslam.
fn check_code(entry: &Entry) -> Result<()> {
    if entry.code != CODE {
        bail!("plan entry {}: planned by {}, this is {}; plan again with this fitslam", entry.index, entry.code, CODE);
    }
    Ok(())
}

/// Runs `entry` of the plan in `dir` (its world in `worlds`) unless its folder holds its output.
pub fn run_entry(dir: &Path, entry: &Entry, worlds: &BTreeMap<String, Setup>) -> Result<Ran> {
    check_code(entry)?;
    let folder = dir.join(&entry.out);
    if done(&folder, entry)? {
        return Ok(Ran::Before);
    }
    let Some(setup) = worlds.get(&world_key(entry)?) else { bail!("plan entry {}: its world was not built", entry.index) };
    static N: AtomicU64 = AtomicU64::new(0);
    let partial = dir.join(".partial").join(format!("{}-{}-{}", entry.index, std::process::id(), N.fetch_add(1, Ordering::Relaxed)));
    let result = (|| {
        std::fs::create_dir_all(&partial).with_context(|| format!("{}: cannot create", partial.display()))?;
        let out = run_and_write(
            setup,
            entry.strategy,
            entry.seed,
            entry.localisation,
            &partial,
            &ProgressBar::hidden(),
            ExtraOutputs::default(),
        )?;
        load::write(&partial.join("entry.json"), serde_json::to_string_pretty(entry)?.as_bytes())?;
        if let Some(parent) = folder.parent() {
            std::fs::create_dir_all(parent).with_context(|| format!("{}: cannot create", parent.display()))?;
        }
        if std::fs::rename(&partial, &folder).is_err() {
            // Another worker finished the same entry first: theirs stands if it is this entry's.
            if done(&folder, entry)? {
                std::fs::remove_dir_all(&partial).ok();
                return Ok(Ran::Before);
            }
            bail!("{}: cannot move the run into place", folder.display());
        }
        Ok(Ran::Now { wall_s: out.wall_s })
    })();
    if result.is_err() {
        std::fs::remove_dir_all(&partial).ok();
    }
    result.with_context(|| format!("plan entry {} ({})", entry.index, entry.out))
}

/// Runs `entries` of the plan in `dir` on `jobs` threads; `bar` counts them.
pub fn run_entries(dir: &Path, entries: &[&Entry], jobs: usize, bar: &ProgressBar) -> Result<Vec<Ran>> {
    if jobs == 0 || jobs > MAX_JOBS {
        bail!("--jobs {jobs}: between 1 and {MAX_JOBS} (each run holds its own world and maps)");
    }
    let pool =
        rayon::ThreadPoolBuilder::new().num_threads(jobs.min(entries.len().max(1))).build().context("cannot start the thread pool")?;
    let ran = pool.install(|| {
        let worlds = build_worlds(entries)?;
        entries
            .par_iter()
            .map(|e| {
                let ran = run_entry(dir, e, &worlds)?;
                bar.inc(1);
                bar.set_message(format!("(last: {})", e.out));
                Ok(ran)
            })
            .collect()
    });
    // Gone once no run is under way or left by a kill (a non-empty one stays).
    std::fs::remove_dir(dir.join(".partial")).ok();
    ran
}

/// `fitslam run`.
pub fn run(args: &RunArgs) -> Result<()> {
    let (_, entries) = read_plan(&args.dir)?;
    let range = match (args.index, &args.indices) {
        (Some(i), _) => parse_indices(&i.to_string(), entries.len())?,
        (None, Some(text)) => parse_indices(text, entries.len())?,
        (None, None) if entries.is_empty() => bail!("{}: the plan has no entry", args.dir.display()),
        (None, None) => 0..=entries.len() - 1,
    };
    let chosen: Vec<&Entry> = entries[range.clone()].iter().collect();
    if args.pending {
        for e in chosen {
            check_code(e)?;
            if !done(&args.dir.join(&e.out), e)? {
                outln!("{}", e.index)?;
            }
        }
        return Ok(());
    }
    let bar = progress_bar(chosen.len() as u64, "{spinner} [{elapsed_precise}] {bar:40} {pos}/{len} runs {msg}");
    let ran = run_entries(&args.dir, &chosen, args.jobs, &bar)?;
    bar.finish_and_clear();
    let now: Vec<f64> = ran.iter().filter_map(|r| if let Ran::Now { wall_s } = r { Some(*wall_s) } else { None }).collect();
    outln!(
        "{}: entries {}..{}: {} run ({:.1} s of missions), {} already done",
        args.dir.display(),
        range.start(),
        range.end(),
        now.len(),
        now.iter().fold(0.0, |a, b| a + b),
        ran.len() - now.len()
    )?;
    Ok(())
}
