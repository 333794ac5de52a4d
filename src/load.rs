//! File loading for the CLI: read bytes, hand them to the core's parsers, name the file in errors.

use anyhow::{Context, Result, bail};
use fitslam_core::params::Valid;
use fitslam_core::{OccupancyGrid, Params, PointCloud, Pose2, io};
use std::path::{Path, PathBuf};

/// Reads a whole file, naming it on failure.
pub fn read(path: &Path) -> Result<Vec<u8>> {
    std::fs::read(path).with_context(|| format!("{}: cannot read", path.display()))
}

/// Loads a map_server map (YAML + the image it names, relative to the YAML) or a bare PNG/PGM
/// (then with the default resolution and origin).
pub fn map(path: &Path, params: &Params) -> Result<OccupancyGrid> {
    let name = path.display().to_string();
    let bytes = read(path)?;
    let lower = name.to_ascii_lowercase();
    if lower.ends_with(".yaml") || lower.ends_with(".yml") {
        let yaml = io::MapYaml::parse(&bytes, &name)?;
        let image_path = resolve(path, &yaml.image);
        let image_bytes = read(&image_path)?;
        Ok(io::load_map(&bytes, &name, &image_bytes, &image_path.display().to_string())?)
    } else if lower.ends_with(".png") || lower.ends_with(".pgm") {
        Ok(io::load_map_image(&bytes, &name, params.grid.resolution_m, [0.0, 0.0], &io::MapThresholds::default())?)
    } else {
        bail!("{name}: unknown map extension (expected .yaml, .png or .pgm)")
    }
}

/// A path named in a file, taken relative to that file's folder.
fn resolve(relative_to: &Path, named: &str) -> PathBuf {
    let p = Path::new(named);
    if p.is_absolute() { p.to_path_buf() } else { relative_to.parent().unwrap_or(Path::new(".")).join(p) }
}

/// Loads a point cloud or landmark set (.pcd, .ply, .csv, .las, .laz).
pub fn cloud(path: &Path) -> Result<PointCloud> {
    let bytes = read(path)?;
    Ok(io::load_cloud(&bytes, &path.display().to_string())?)
}

/// Loads and checks parameters (TOML or YAML), or the defaults.
pub fn params(path: Option<&Path>) -> Result<Valid<Params>> {
    match path {
        None => Ok(Valid::default()),
        Some(p) => Ok(Params::from_bytes(&read(p)?, &p.display().to_string())?),
    }
}

/// Parses `X,Y,YAW` (metres, metres, radians).
pub fn pose(text: &str) -> Result<Pose2> {
    let parts: Vec<&str> = text.split(',').map(str::trim).collect();
    if parts.len() != 3 {
        bail!("--pose {text:?}: expected X,Y,YAW (metres, metres, radians)");
    }
    let mut v = [0.0; 3];
    for (k, part) in parts.iter().enumerate() {
        v[k] = part.parse::<f64>().with_context(|| format!("--pose {text:?}: {part:?} is not a number"))?;
        if !v[k].is_finite() {
            bail!("--pose {text:?}: {part:?} is not finite");
        }
    }
    Ok(Pose2::new(v[0], v[1], v[2]))
}

/// Writes bytes, naming the file on failure and creating its folder.
pub fn write(path: &Path, bytes: &[u8]) -> Result<()> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("{}: cannot create folder", dir.display()))?;
    }
    std::fs::write(path, bytes).with_context(|| format!("{}: cannot write", path.display()))
}
