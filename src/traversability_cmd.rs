//! `fitslam traversability`: a point cloud to a thresholded map (map_server YAML + PGM) and a PNG
//! of the score.

use crate::load;
use anyhow::{Context, Result};
use clap::Args;
use fitslam_core::{
    grid::inflate_lethal,
    io,
    traversability::{DiscSampling, TraversabilityMap, score_to_rgb},
};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct TraversabilityArgs {
    /// Registered point cloud (.pcd, .ply, .las, .laz, .csv), metres.
    #[arg(long)]
    pub cloud: PathBuf,
    /// Output map YAML; the PGM and the score PNG are written beside it.
    #[arg(long)]
    pub out: PathBuf,
    /// Parameter file (TOML or YAML); defaults are the paper's.
    #[arg(long)]
    pub params: Option<PathBuf>,
    /// Also inflate lethal cells by the robot radius in the written map.
    #[arg(long)]
    pub inflate: bool,
}

pub fn run(args: &TraversabilityArgs) -> Result<()> {
    let params = load::params(args.params.as_deref())?;
    let cloud = load::cloud(&args.cloud)?;
    let warned = warn_if_sparse(&args.cloud, &cloud.points, &params);
    let map = TraversabilityMap::from_cloud(&cloud, &params).with_context(|| args.cloud.display().to_string())?;
    let layers = map.compute(&params.traversability);
    if layers.known_cells() == 0 && !warned {
        let t = &params.traversability;
        eprintln!(
            "warning: {}: no cell is known: no disc of radius {} m holds {} points (min_points) spread at least {} m across (a single point or identical points?); the map is all unknown",
            args.cloud.display(),
            t.disc_radius_m,
            t.min_points,
            t.min_spread_ratio * t.disc_radius_m
        );
    }
    let mut grid = layers.to_occupancy(params.traversability.tau);
    if args.inflate {
        grid = inflate_lethal(&grid, params.robot.radius_m);
    }
    let stem = args.out.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_else(|| "map".into());
    let pgm_name = format!("{stem}.pgm");
    let (yaml, pgm) = io::save_map(&grid, &pgm_name);
    let dir = args.out.parent().filter(|d| !d.as_os_str().is_empty()).map(PathBuf::from).unwrap_or_default();
    load::write(&args.out, yaml.as_bytes())?;
    load::write(&dir.join(&pgm_name), &pgm)?;
    let g = layers.geometry();
    let png = io::write_png_rgb8(g.width, g.height, &score_to_rgb(&layers))?;
    let png_path = dir.join(format!("{stem}_score.png"));
    load::write(&png_path, &png)?;
    let known = layers.known_cells();
    let free = grid.data.iter().filter(|&&v| v == 0).count();
    outln!(
        "{}: {} points → {} × {} cells at {} m; {} known, {} free ({:.1}% of known); wrote {}, {}, {}",
        args.cloud.display(),
        cloud.len(),
        g.width,
        g.height,
        g.resolution_m,
        known,
        free,
        100.0 * free as f64 / known.max(1) as f64,
        args.out.display(),
        dir.join(&pgm_name).display(),
        png_path.display()
    )?;
    Ok(())
}

/// One warning line (returns true) when the cloud is too sparse for the disc — a disc holds fewer than
/// `min_points` of its points on average, so most cells will be unknown (an airborne cloud at
/// the rover's defaults) — with a disc radius that holds 4 × `min_points`.
fn warn_if_sparse(path: &std::path::Path, points: &[nalgebra::Point3<f64>], params: &fitslam_core::Params) -> bool {
    let t = &params.traversability;
    let Some(sampling) = DiscSampling::of(points) else { return false };
    let in_disc = sampling.points_in_disc(t.disc_radius_m);
    let needed = f64::from(t.min_points);
    if in_disc >= needed {
        return false;
    }
    let radius_m = sampling.radius_holding(4.0 * needed);
    eprintln!(
        "warning: {}: the points are about {:.2} m apart in x-y, so a disc of radius {} m holds about {:.1} of them, \
         fewer than min_points ({}): most cells will be unknown. For a cloud this sparse, a --params file with [traversability] \
         disc_radius_m = {:.2} and [grid] resolution_m = {:.2} gives each disc enough points (the slope, step and roughness limits stay the robot's).",
        path.display(),
        sampling.spacing_m,
        t.disc_radius_m,
        in_disc,
        t.min_points,
        radius_m,
        radius_m / 2.0
    );
    true
}
