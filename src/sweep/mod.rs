//! Index-addressable sweeps: a plan of missions that any machine can run one entry at a time.
//!
//! `fitslam plan <compare's options> --out DIR` writes `DIR/plan.json` (the sweep: its command,
//! world name, strategies, localisation, code version, entry count) and `DIR/plan.jsonl`, one
//! [`Entry`] per line: strategy, world file and its SHA-256, world seed, noise seed, localisation,
//! every planner and simulator parameter, the code version and the entry's hash of all of it.
//! `fitslam run DIR --index I` ([`run`]) runs entries into `DIR/<out>` as `compare` always
//! did; `fitslam collect DIR` ([`collect`]) writes the report from the runs' files. `compare`
//! is plan + run on threads + collect, so the two paths cannot drift.

pub mod collect;
pub mod run;

use crate::load;
use crate::mission_run::{MissionArgs, load_mission_params, read_world_spec};
use anyhow::{Context, Result, bail};
use clap::Args;
use fitslam_core::params::{Params, Strategy};
use fitslam_core::sim::{Localisation, MAX_WORLD_SEEDS, MissionParams};
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::path::{Path, PathBuf};

/// The code a plan's runs must come from (build.rs): package version and git commit.
pub const CODE: &str = env!("FITSLAM_CODE");

/// The options that define a sweep (`plan` and `compare`).
#[derive(Args, Debug)]
pub struct PlanArgs {
    #[command(flatten)]
    pub mission: MissionArgs,
    /// Comma-separated strategies: fit, greedy, random, u1, matched (random at fit's path length),
    /// matched_top (the same among u1's N best), u2_length (u2 with the path length for I_p).
    #[arg(long, default_value = "fit,greedy,random")]
    pub strategies: String,
    /// Number of seeds per strategy (seeds seed_start ..= seed_start + N − 1).
    #[arg(long, default_value_t = 20)]
    pub seeds: u64,
    /// First seed.
    #[arg(long, default_value_t = 1)]
    pub seed_start: u64,
    /// World seeds A..B (inclusive) or one N: every run in each member of the world file's
    /// family (as `explore --world-seed`); default: the file's `world_seeds` if it names them,
    /// else the file's world as written.
    #[arg(long)]
    pub world_seeds: Option<String>,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
}

/// `DIR/plan.json`: the sweep as a whole.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Sweep {
    /// The `fitslam compare` command that makes this sweep (without `--out` and `--jobs`).
    pub command: String,
    /// The world file's `name`.
    pub world_name: String,
    /// In the order given: the report's row order.
    pub strategies: Vec<Strategy>,
    pub localisation: Localisation,
    /// [`CODE`] of the `fitslam` that planned it.
    pub code: String,
    /// Lines of `plan.jsonl`.
    pub entries: usize,
}

/// One mission of a plan: a line of `DIR/plan.jsonl`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Entry {
    /// Its line, from 0.
    pub index: usize,
    pub strategy: Strategy,
    /// The world file as given to `plan` (relative paths: to the folder `run` is started in).
    pub world: PathBuf,
    /// SHA-256 of the world file's bytes (hex).
    pub world_sha256: String,
    /// The member of the world file's family, if any.
    pub world_seed: Option<u64>,
    /// The noise seed.
    pub seed: u64,
    pub localisation: Localisation,
    /// Every planner parameter.
    pub params: Params,
    /// Every simulator parameter (the time limit override in it).
    pub sim_params: MissionParams,
    /// Its output folder, relative to the plan's: `[world_<w>/]<strategy>/seed_<s>`.
    pub out: String,
    /// [`CODE`] of the `fitslam` that planned it.
    pub code: String,
    /// SHA-256 (hex) of this entry's JSON with `hash` empty and keys sorted.
    pub hash: String,
}

impl Entry {
    /// The hash of everything else in the entry.
    fn digest(&self) -> Result<String> {
        let mut bare = self.clone();
        bare.hash.clear();
        // Through a `Value`: its maps sort their keys, so the hash does not depend on field order.
        Ok(hex(&Sha256::digest(serde_json::to_vec(&serde_json::to_value(&bare)?)?)))
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// SHA-256 (hex) of a file's bytes.
pub fn file_sha256(path: &Path) -> Result<String> {
    Ok(hex(&Sha256::digest(load::read(path)?)))
}

/// The sweep `args` define and its entries (strategy, then world seed, then seed).
pub fn plan(args: &PlanArgs) -> Result<(Sweep, Vec<Entry>)> {
    let strategies = parse_strategies(&args.strategies)?;
    if args.seeds == 0 {
        bail!("--seeds 0: at least one seed is needed");
    }
    let Some(seed_end) = args.seed_start.checked_add(args.seeds - 1) else {
        bail!("--seed-start {} --seeds {}: the seeds overflow u64", args.seed_start, args.seeds);
    };
    let m = &args.mission;
    let spec = read_world_spec(&m.world)?;
    // `--world-seeds`, else the family the world file names, else the file's world as written.
    let world_seeds: Vec<Option<u64>> = match (&args.world_seeds, spec.world_seeds) {
        (Some(text), _) => parse_world_seeds(text)?.into_iter().map(Some).collect(),
        (None, Some([first, last])) => (first..=last).map(Some).collect(),
        (None, None) => vec![None],
    };
    let params = load::params(m.params.as_deref())?.into_inner();
    let sim_params = load_mission_params(m.sim_params.as_deref(), m.time_limit_s)?.into_inner();
    let world_sha256 = file_sha256(&m.world)?;
    let mut entries = Vec::new();
    for &strategy in &strategies {
        for &world_seed in &world_seeds {
            for seed in args.seed_start..=seed_end {
                let base = world_seed.map_or_else(String::new, |w| format!("world_{w}/"));
                let mut e = Entry {
                    index: entries.len(),
                    strategy,
                    world: m.world.clone(),
                    world_sha256: world_sha256.clone(),
                    world_seed,
                    seed,
                    localisation: m.localisation,
                    params: params.clone(),
                    sim_params: sim_params.clone(),
                    out: format!("{base}{}/seed_{seed}", strategy.name()),
                    code: CODE.into(),
                    hash: String::new(),
                };
                e.hash = e.digest()?;
                entries.push(e);
            }
        }
    }
    let sweep = Sweep {
        command: command(args),
        world_name: spec.name,
        strategies,
        localisation: m.localisation,
        code: CODE.into(),
        entries: entries.len(),
    };
    Ok((sweep, entries))
}

/// The `fitslam compare` command of a sweep, from its options (the same whichever of `plan` or
/// `compare` was typed, and wherever the output goes).
fn command(args: &PlanArgs) -> String {
    let m = &args.mission;
    let mut s = format!("fitslam compare --world {}", m.world.display());
    if let Some(p) = &m.params {
        s += &format!(" --params {}", p.display());
    }
    if let Some(p) = &m.sim_params {
        s += &format!(" --sim-params {}", p.display());
    }
    s += &format!(" --localisation {}", m.localisation.name());
    if let Some(t) = m.time_limit_s {
        s += &format!(" --time-limit-s {t}");
    }
    s += &format!(" --strategies {} --seeds {} --seed-start {}", args.strategies, args.seeds, args.seed_start);
    if let Some(w) = &args.world_seeds {
        s += &format!(" --world-seeds {w}");
    }
    s
}

/// Whether [`write_plan`] may replace a different plan already in the folder.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OtherPlan {
    /// Refuse it (`fitslam plan`: a plan is run by many workers; changing it under them is wrong).
    Refuse,
    /// Replace it (`fitslam compare`, which runs the whole plan itself; runs of the old plan are
    /// still refused by `run`, folder by folder).
    Replace,
}

/// Writes `plan.json` and `plan.jsonl` into `dir` (created), each aside and renamed into place.
pub fn write_plan(dir: &Path, sweep: &Sweep, entries: &[Entry], other: OtherPlan) -> Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("--out {}: cannot create the output folder", dir.display()))?;
    let mut jsonl = String::new();
    for e in entries {
        jsonl += &serde_json::to_string(e)?;
        jsonl.push('\n');
    }
    if other == OtherPlan::Refuse && dir.join("plan.jsonl").exists() {
        let old = load::read(&dir.join("plan.jsonl"))?;
        if old != jsonl.as_bytes() {
            bail!("{}: holds another plan (plan.jsonl differs); plan into a new folder", dir.display());
        }
    }
    write_atomic(&dir.join("plan.jsonl"), jsonl.as_bytes())?;
    write_atomic(&dir.join("plan.json"), format!("{}\n", serde_json::to_string_pretty(sweep)?).as_bytes())
}

/// Writes `bytes` to `path` through a file beside it renamed into place: a reader sees the old
/// file or the new one, never a part.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<()> {
    let tmp = path.with_extension(format!("part-{}", std::process::id()));
    load::write(&tmp, bytes)?;
    std::fs::rename(&tmp, path).with_context(|| format!("{}: cannot rename into place", path.display()))
}

/// Reads `DIR/plan.json` and `DIR/plan.jsonl` and checks them: every line parses, its index is its
/// line, its hash is its content's, and the sweep's count matches.
pub fn read_plan(dir: &Path) -> Result<(Sweep, Vec<Entry>)> {
    let name = dir.join("plan.json");
    let sweep: Sweep = serde_json::from_slice(&load::read(&name)?).with_context(|| format!("{}: not a plan", name.display()))?;
    let name = dir.join("plan.jsonl");
    let bytes = load::read(&name)?;
    let text = std::str::from_utf8(&bytes).with_context(|| format!("{}: not UTF-8", name.display()))?;
    let mut entries = Vec::new();
    for (k, line) in text.lines().enumerate() {
        let e: Entry = serde_json::from_str(line).with_context(|| format!("{} line {}: not a plan entry", name.display(), k + 1))?;
        if e.index != k {
            bail!("{} line {}: index {} (expected {k})", name.display(), k + 1, e.index);
        }
        if e.digest()? != e.hash {
            bail!("{} line {}: its hash does not match its content (edited?)", name.display(), k + 1);
        }
        entries.push(e);
    }
    if entries.len() != sweep.entries {
        bail!("{}: {} entries, plan.json says {}", name.display(), entries.len(), sweep.entries);
    }
    Ok((sweep, entries))
}

/// Parses the option `flag`'s `A..B` (inclusive, A ≤ B) or `N` (one `what`) as (A, B).
fn parse_inclusive(flag: &str, text: &str, what: &str) -> Result<(u64, u64)> {
    let bad = || anyhow::anyhow!("{flag} {text:?}: expected A..B (inclusive, A ≤ B) or one {what} N");
    let num = |t: &str| t.trim().parse::<u64>().map_err(|_| bad());
    let (a, b) = match text.split_once("..") {
        Some((a, b)) => (num(a)?, num(b)?),
        None => (num(text)?, num(text)?),
    };
    if a > b {
        return Err(bad());
    }
    Ok((a, b))
}

/// Parses `A..B` (inclusive, A ≤ B) or `N`.
fn parse_world_seeds(text: &str) -> Result<Vec<u64>> {
    let (a, b) = parse_inclusive("--world-seeds", text, "seed")?;
    if b - a >= MAX_WORLD_SEEDS {
        bail!("--world-seeds {text:?}: at most {MAX_WORLD_SEEDS} worlds");
    }
    Ok((a..=b).collect())
}

/// Parses `fit,greedy,…` (no duplicates, at least one).
fn parse_strategies(text: &str) -> Result<Vec<Strategy>> {
    let mut out = Vec::new();
    for part in text.split(',').map(str::trim) {
        let s = part.to_ascii_lowercase().parse::<Strategy>().map_err(|_| {
            anyhow::anyhow!("--strategies {text:?}: unknown strategy {part:?} (expected fit, greedy, random, u1 or matched)")
        })?;
        if out.contains(&s) {
            bail!("--strategies {text:?}: {part:?} is listed twice");
        }
        out.push(s);
    }
    Ok(out)
}

/// Parses `A..B` (inclusive) or `N` as the indices of a plan of `len` entries.
pub fn parse_indices(text: &str, len: usize) -> Result<std::ops::RangeInclusive<usize>> {
    let (a, b) = parse_inclusive("--indices", text, "index")?;
    if b >= len as u64 {
        bail!("--indices {text:?}: the plan has entries 0..{}", len.saturating_sub(1));
    }
    Ok(a as usize..=b as usize)
}

/// `fitslam plan`: writes the plan of a sweep.
pub fn plan_cmd(args: &PlanArgs) -> Result<()> {
    let (sweep, entries) = plan(args)?;
    write_plan(&args.out, &sweep, &entries, OtherPlan::Refuse)?;
    outln!(
        "{}: plan of {} runs ({}); run them with `fitslam run {} --indices 0..{}`, then `fitslam collect {}`",
        args.out.display(),
        entries.len(),
        sweep.code,
        args.out.display(),
        entries.len() - 1,
        args.out.display()
    )?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strategies_parse_and_reject() {
        assert_eq!(parse_strategies("fit, greedy,U1").unwrap(), vec![Strategy::Fit, Strategy::Greedy, Strategy::U1]);
        assert!(parse_strategies("fit,best").unwrap_err().to_string().contains("\"best\""));
        assert!(parse_strategies("fit,fit").is_err());
        assert!(parse_strategies("").is_err());
    }

    #[test]
    fn world_seeds_parse_as_inclusive_ranges() {
        assert_eq!(parse_world_seeds("1..10").unwrap(), (1..=10).collect::<Vec<u64>>());
        assert_eq!(parse_world_seeds(" 7 ").unwrap(), vec![7]);
        assert_eq!(parse_world_seeds("3..3").unwrap(), vec![3]);
        for bad in ["4..3", "..3", "1..", "x", "1..2..3", "0..1000"] {
            assert!(parse_world_seeds(bad).unwrap_err().to_string().contains("--world-seeds"), "{bad}");
        }
        assert_eq!(parse_world_seeds("0..999").unwrap().len(), 1000);
    }

    #[test]
    fn indices_parse_within_the_plan() {
        assert_eq!(parse_indices("0..4", 5).unwrap(), 0..=4);
        assert_eq!(parse_indices(" 3 ", 5).unwrap(), 3..=3);
        for bad in ["4..3", "..3", "1..", "x", "0..5", "5"] {
            assert!(parse_indices(bad, 5).unwrap_err().to_string().contains("--indices"), "{bad}");
        }
    }
}
