//! `fitslam`: the command-line face of fitslam-core. Thin: it reads files, calls the core, and
//! prints or writes the result. Errors print one line and exit non-zero.

/// `println!` that returns the write's error instead of panicking on it: a reader that stops
/// early (`fitslam select … | head`) closes the pipe, and `main` then ends quietly.
macro_rules! outln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        writeln!(std::io::stdout().lock(), $($arg)*)
    }};
}

mod asset_cmd;
mod bag_cmd;
mod compare_cmd;
mod explore_cmd;
mod load;
mod mission_run;
mod optimize;
mod params_cmd;
mod plot;
mod report;
mod select_cmd;
mod stats;
mod sweep;
mod traversability_cmd;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

/// FIT-SLAM active SLAM for ground robots.
#[derive(Parser, Debug)]
#[command(name = "fitslam", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Print the default parameters (or validate and print a parameter file).
    Params(params_cmd::ParamsArgs),
    /// Rank the frontier candidates of a map and pick the next goal.
    Select(select_cmd::SelectArgs),
    /// List a rosbag2 MCAP recording's topics, types, counts, duration and decision instants.
    BagInfo(bag_cmd::BagInfoArgs),
    /// Build a thresholded traversability map (map_server YAML + PGM) and a score PNG from a cloud.
    Traversability(traversability_cmd::TraversabilityArgs),
    /// Build a planning scene (map + landmarks) from a real DEM scaled to rover size.
    BuildAsset(asset_cmd::BuildAssetArgs),
    /// Optimise a pose graph (g2o or Victoria Park) and report chi2, time and the last pose's marginal.
    Optimize(optimize::OptimizeArgs),
    /// Run one whole simulated exploration mission in a world file and write metrics, trajectories, maps and plots.
    Explore(explore_cmd::ExploreArgs),
    /// Run every strategy × seed in a world in parallel and compare them (the paper's experiment):
    /// per-run outputs, mean/band figures over time, summary.csv and summary.md with tests.
    Compare(compare_cmd::CompareArgs),
    /// Write the plan of a sweep (compare's options): DIR/plan.jsonl, one mission per line, each
    /// runnable alone with `fitslam run DIR --index I` (a Slurm array task, a Kubernetes Indexed
    /// Job pod, a Ray task).
    Plan(sweep::PlanArgs),
    /// Run entries of a plan into its folder: idempotent, atomic, safe to retry after a kill.
    Run(sweep::run::RunArgs),
    /// Write a plan's report (summary.md, summary.csv, figures) once every entry has run.
    Collect(sweep::collect::CollectArgs),
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match &cli.command {
        Command::Params(a) => params_cmd::run(a),
        Command::Select(a) => select_cmd::run(a),
        Command::BagInfo(a) => bag_cmd::run(a),
        Command::Traversability(a) => traversability_cmd::run(a),
        Command::BuildAsset(a) => asset_cmd::run(a),
        Command::Optimize(a) => optimize::run(a),
        Command::Explore(a) => explore_cmd::run(a),
        Command::Compare(a) => compare_cmd::run(a),
        Command::Plan(a) => sweep::plan_cmd(a),
        Command::Run(a) => sweep::run::run(a),
        Command::Collect(a) => sweep::collect::run(a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if closed_stdout(&e) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {}", one_line(&e));
            ExitCode::FAILURE
        }
    }
}

/// Whether `e` is a write to a pipe whose reader has gone: the reader wanted no more, which is
/// not a failure.
fn closed_stdout(e: &anyhow::Error) -> bool {
    e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe))
}

/// The error and its causes on one line, `a: b: c`, leaving out a cause whose text the message
/// before it already ends with (library errors that print their source, as many do).
fn one_line(e: &anyhow::Error) -> String {
    let mut line = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if line.is_empty() {
            line = text;
        } else if !line.ends_with(&text) {
            line = format!("{line}: {text}");
        }
    }
    line
}

#[cfg(test)]
mod tests {
    #[test]
    fn one_line_drops_causes_the_message_already_holds() {
        /// An error that prints its source, as `#[error("line 3: {0}")]` with `#[from]` does.
        #[derive(Debug)]
        struct Outer(std::io::Error);
        impl std::fmt::Display for Outer {
            fn fmt(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                write!(f, "line 3: {}", self.0)
            }
        }
        impl std::error::Error for Outer {
            fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
                Some(&self.0)
            }
        }
        let e = anyhow::Error::new(Outer(std::io::Error::other("noise is bad"))).context("file.g2o");
        assert_eq!(super::one_line(&e), "file.g2o: line 3: noise is bad");
        let plain = anyhow::Error::new(std::io::Error::other("disk")).context("reading x");
        assert_eq!(super::one_line(&plain), "reading x: disk");
    }
}
