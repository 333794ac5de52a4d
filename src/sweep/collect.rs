//! `fitslam collect DIR`: the report of a plan whose entries have all run, from their files
//! (`summary.json`, `metrics.csv`), wherever and in whatever order they ran.

use super::run::done;
use super::{Sweep, read_plan};
use crate::load;
use crate::report::{self, Heading, RunFigures};
use anyhow::{Context, Result, bail};
use clap::Args;
use fitslam_core::sim::{Summary, read_metrics_csv};
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct CollectArgs {
    /// The plan's folder (`fitslam plan --out DIR`), every entry run.
    pub dir: PathBuf,
}

/// Writes the report of the plan in `dir` into `dir`; returns the sweep and its runs' figures.
pub fn collect(dir: &Path) -> Result<(Sweep, Vec<RunFigures>)> {
    let (sweep, entries) = read_plan(dir)?;
    // A folder made by another plan or damaged is named first; an absent one is just not run yet.
    let mut missing = Vec::new();
    for e in &entries {
        if !done(&dir.join(&e.out), e)? {
            missing.push(e.index);
        }
    }
    if let Some(&first) = missing.first() {
        bail!(
            "{}: {} of {} entries have not run (the first: {first}); run them (`fitslam run {} --index {first}`) and collect again",
            dir.display(),
            missing.len(),
            entries.len(),
            dir.display()
        );
    }
    let mut figures = Vec::with_capacity(entries.len());
    for e in &entries {
        let folder = dir.join(&e.out);
        let name = folder.join("summary.json");
        let summary: Summary =
            serde_json::from_slice(&load::read(&name)?).with_context(|| format!("{}: not a mission summary", name.display()))?;
        let name = folder.join("metrics.csv");
        let rows = read_metrics_csv(&load::read(&name)?).with_context(|| name.display().to_string())?;
        figures.push(RunFigures::new(e.strategy, e.world_seed, e.seed, summary, rows));
    }
    let heading =
        Heading { world: &sweep.world_name, strategies: &sweep.strategies, command: &sweep.command, localisation: sweep.localisation };
    report::write(dir, &heading, &figures)?;
    Ok((sweep, figures))
}

/// `fitslam collect`.
pub fn run(args: &CollectArgs) -> Result<()> {
    let (_, figures) = collect(&args.dir)?;
    outln!("{}: {} runs; {}", args.dir.display(), figures.len(), report::files(&figures))?;
    Ok(())
}
