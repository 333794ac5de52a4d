//! What the mission benches share: their command line and the world they run in.

use fitslam_core::params::Params;
use fitslam_core::sim::{World, WorldSpec};

/// The bench's arguments (without cargo's `--bench`).
pub struct Args(Vec<String>);

impl Args {
    pub fn from_env() -> Self {
        Self(std::env::args().skip(1).filter(|a| a != "--bench").collect())
    }

    /// The number after `--name`, if given.
    pub fn value(&self, name: &str) -> Option<f64> {
        self.text(name).map(|v| v.parse::<f64>().unwrap_or_else(|_| panic!("{name} takes a number, not {v}")))
    }

    /// The word after `--name`, if given.
    pub fn text(&self, name: &str) -> Option<&str> {
        let i = self.0.iter().position(|a| a == name)?;
        self.0.get(i + 1).map(String::as_str)
    }

    /// The first argument ending in `.toml`, or `default`.
    pub fn world_file(&self, default: &str) -> String {
        self.0.iter().find(|a| a.ends_with(".toml")).cloned().unwrap_or(default.into())
    }
}

/// The world of `world_file` (its images read next to it) at the default planner parameters.
pub fn load_world(world_file: &str, params: &Params) -> World {
    let dir = std::path::Path::new(world_file).parent().unwrap_or(std::path::Path::new(".")).to_path_buf();
    let text = std::fs::read_to_string(world_file).expect("world file");
    let spec = WorldSpec::from_toml(&text, world_file).expect("world");
    World::build(&spec, &params.traversability, params.traversability.tau, |name| std::fs::read(dir.join(name)).map_err(|e| e.to_string()))
        .expect("world builds")
}
