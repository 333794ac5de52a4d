//! `fitslam-robot`: the FIT-SLAM exploration node (ROS 2 over DDS, no ROS installation needed).
//! See `robot/README.md`.

use anyhow::{Context as _, Result};
use clap::Parser;
use fitslam_robot::config::ConfigFile;
use fitslam_robot::ros::{self, NoObserver, Observer};
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

/// FIT-SLAM exploration node for ROS 2 (LeoRover defaults).
#[derive(Parser, Debug)]
#[command(version, about)]
struct Cli {
    /// Configuration YAML with `node:` and `fitslam:` sections (both optional; defaults are the
    /// LeoRover's and the paper's).
    #[arg(long, short)]
    config: Option<PathBuf>,
    /// A plain planner parameter file (fitslam_core::Params, e.g. the studio's export; .yaml,
    /// .yml or .toml). Replaces the config file's `fitslam:` section.
    #[arg(long)]
    params: Option<PathBuf>,
    /// Print the effective configuration as YAML and exit.
    #[arg(long)]
    print_config: bool,
    /// Save a rerun recording (.rrd) of the map, landmarks, candidates, path and metrics.
    #[arg(long, value_name = "FILE.rrd")]
    rerun_save: Option<PathBuf>,
    /// Stream to a rerun viewer at this URL (e.g. rerun+http://127.0.0.1:9876/proxy).
    #[arg(long, value_name = "URL")]
    rerun_connect: Option<String>,
    /// DDS domain (overrides ROS_DOMAIN_ID and the config).
    #[arg(long)]
    domain_id: Option<u16>,
    /// Only talk on 127.0.0.1 (overrides ROS_LOCALHOST_ONLY and the config).
    #[arg(long)]
    localhost_only: bool,
}

fn load(cli: &Cli) -> Result<ConfigFile> {
    let mut cfg = match &cli.config {
        Some(p) => {
            let text = std::fs::read_to_string(p).with_context(|| format!("reading {}", p.display()))?;
            ConfigFile::from_yaml(&text, &p.display().to_string())?
        }
        None => ConfigFile::default(),
    };
    if let Some(p) = &cli.params {
        let bytes = std::fs::read(p).with_context(|| format!("reading {}", p.display()))?;
        cfg.fitslam = fitslam_core::Params::from_bytes(&bytes, &p.display().to_string())?.into_inner();
    }
    if cli.domain_id.is_some() {
        cfg.node.domain_id = cli.domain_id;
    }
    if cli.localhost_only {
        cfg.node.localhost_only = Some(true);
    }
    fitslam_core::params::Validate::validate(&cfg)?;
    Ok(cfg)
}

#[cfg(feature = "rerun")]
fn observer(cli: &Cli, cfg: &ConfigFile) -> Result<Box<dyn Observer>> {
    if cli.rerun_save.is_none() && cli.rerun_connect.is_none() {
        return Ok(Box::new(NoObserver));
    }
    let logger = fitslam_robot::rerun_log::RerunLogger::new(cli.rerun_save.as_deref(), cli.rerun_connect.as_deref(), cfg)?;
    Ok(Box::new(logger))
}

#[cfg(not(feature = "rerun"))]
fn observer(cli: &Cli, _cfg: &ConfigFile) -> Result<Box<dyn Observer>> {
    if cli.rerun_save.is_some() || cli.rerun_connect.is_some() {
        anyhow::bail!("this build has no rerun support (built with --no-default-features)");
    }
    Ok(Box::new(NoObserver))
}

fn main() -> Result<()> {
    let cli = Cli::parse();
    let cfg = load(&cli)?;
    if cli.print_config {
        print!("{}", cfg.to_yaml());
        return Ok(());
    }
    let mut obs = observer(&cli, &cfg)?;
    let stop = Arc::new(AtomicBool::new(false));
    let flag = Arc::clone(&stop);
    ctrlc::set_handler(move || flag.store(true, Ordering::Relaxed)).context("installing the Ctrl-C handler")?;
    let summary = ros::run(&cfg, obs.as_mut(), &stop)?;
    drop(obs); // flushes the rerun recording
    eprintln!(
        "fitslam-robot: {} after {:.1} s; status {}",
        if summary.mission_complete { "mission complete" } else { "stopped" },
        summary.duration_s,
        summary.status_json
    );
    Ok(())
}
