//! `fitslam params`: prints the default parameters (or a file's, validated) as TOML or YAML.

use crate::load;
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct ParamsArgs {
    /// Parameter file to validate and print; default: the paper's defaults.
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Print YAML (the robot node's parameter file) instead of TOML.
    #[arg(long)]
    pub yaml: bool,
}

pub fn run(args: &ParamsArgs) -> Result<()> {
    let p = load::params(args.params.as_deref())?;
    {
        use std::io::Write as _;
        write!(std::io::stdout().lock(), "{}", if args.yaml { p.to_yaml() } else { p.to_toml() })?;
    }
    Ok(())
}
