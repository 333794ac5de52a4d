//! `fitslam build-asset`: builds a realistic planning scene from a real DEM (scaled to rover size)
//! with the core's own tools: rocks, the ground a LiDAR saw from a few viewpoints, the
//! traversability map of those points, and the visual landmarks mapped from the same viewpoints.
//! Writes map.yaml + map.pgm, landmarks.ply and landmarks.csv, and scene.toml (start pose, how
//! it was made).

use crate::load;
use anyhow::{Context, Result, bail};
use clap::Args;
use fitslam_core::{
    Params, PointCloud,
    grid::GridGeometry,
    io,
    params::Num,
    sim::{
        DemScaling, Heightfield, LandmarkDensity, line_of_sight, scatter_landmarks, scatter_rocks, visible_ground_points, world::RockSpec,
    },
    traversability::TraversabilityMap,
};
use nalgebra::{Matrix3, Point3};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct BuildAssetArgs {
    /// Grey PNG DEM (pixel value = metres).
    #[arg(long)]
    pub dem: PathBuf,
    /// Ground size of a DEM pixel, metres, as X,Y.
    #[arg(long, default_value = "74,93")]
    pub dem_pixel_m: String,
    /// Edge of the square world, metres.
    #[arg(long, default_value_t = 20.0)]
    pub size_m: f64,
    /// Robot positions the scene was observed from, metres: "X,Y;X,Y;…" (the first is the start).
    #[arg(long, default_value = "3,3;6.5,4;4.5,7.5")]
    pub viewpoints: String,
    /// LiDAR range, metres.
    #[arg(long, default_value_t = 8.0)]
    pub lidar_range_m: f64,
    /// Fraction of the DEM's shorter side mapped onto the world.
    #[arg(long, default_value_t = 0.1)]
    pub crop_fraction: f64,
    /// Vertical scale relative to the horizontal one (1 keeps the real slopes; the default 0.6
    /// brings the fault's ridges within reach of a LeoRover).
    #[arg(long, default_value_t = 0.6)]
    pub relief_scale: f64,
    /// Seed for rocks, noise and landmarks.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output folder.
    #[arg(long)]
    pub out: PathBuf,
}

/// Largest world edge, metres (as world files: `terrain.size_m`).
const MAX_SIZE_M: f64 = 500.0;
/// Longest LiDAR range, metres (a VLP-16's).
const MAX_LIDAR_RANGE_M: f64 = 100.0;

/// "A,B" as two finite numbers; errors name `option` and the text.
fn pair(option: &str, text: &str) -> Result<[f64; 2]> {
    let v: Vec<f64> = text
        .split(',')
        .map(|s| s.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("{option} {text:?}: expected two numbers X,Y"))?;
    match v[..] {
        [x, y] if x.is_finite() && y.is_finite() => Ok([x, y]),
        _ => bail!("{option} {text:?}: expected two finite numbers X,Y"),
    }
}

pub fn run(args: &BuildAssetArgs) -> Result<()> {
    let params = Params::default();
    let px = pair("--dem-pixel-m", &args.dem_pixel_m)?;
    if px.iter().any(|&v| v <= 0.0) {
        bail!("--dem-pixel-m {:?}: both pixel sizes must be > 0 m", args.dem_pixel_m);
    }
    if !(args.size_m > 0.0 && args.size_m <= MAX_SIZE_M) {
        bail!("--size-m {}: must be in (0, {MAX_SIZE_M}] m", Num(args.size_m));
    }
    if !(args.crop_fraction > 0.0 && args.crop_fraction <= 1.0) {
        bail!("--crop-fraction {}: must be in (0, 1]", Num(args.crop_fraction));
    }
    if !(args.lidar_range_m > 0.0 && args.lidar_range_m <= MAX_LIDAR_RANGE_M) {
        bail!("--lidar-range-m {}: must be in (0, {MAX_LIDAR_RANGE_M}] m", Num(args.lidar_range_m));
    }
    let viewpoints: Vec<(f64, f64)> = args
        .viewpoints
        .split(';')
        .map(|v| pair("--viewpoints", v).map(|[x, y]| (x, y)))
        .collect::<Result<_>>()
        .with_context(|| format!("--viewpoints {:?}: expected X,Y;X,Y;…", args.viewpoints))?;
    let bytes = load::read(&args.dem)?;
    let scaling = DemScaling {
        pixel_x_m: px[0],
        pixel_y_m: px[1],
        world_size_m: args.size_m,
        cell_m: params.grid.resolution_m,
        crop_fraction: args.crop_fraction,
        ..DemScaling::CENTRAL
    };
    let mut field = Heightfield::from_dem_png(&bytes, &args.dem.display().to_string(), scaling)?;
    if !(args.relief_scale.is_finite() && args.relief_scale >= 0.0) {
        bail!("--relief-scale must be ≥ 0");
    }
    field.heights_m.iter_mut().for_each(|z| *z *= args.relief_scale);
    let start = viewpoints[0];
    let spec = RockSpec { spacing_m: 1.6, density: 0.3, radius_m: [0.15, 0.45], height_m: [0.25, 0.7], keep_clear_m: 1.2 };
    let rocks = scatter_rocks(&mut field, args.seed, &spec, start);
    // The map frame is where a SLAM would put it: z = 0 at the ground under the start pose.
    let z0 = field
        .height_at(start.0, start.1)
        .with_context(|| format!("--viewpoints: the start {},{} is outside the {} m world", start.0, start.1, args.size_m))?;
    field.heights_m.iter_mut().for_each(|z| *z -= z0);

    // Ground seen by the LiDAR (mounted 0.3 m up) from each viewpoint; no ray goes further than
    // the world's diagonal.
    let range_m = args.lidar_range_m.min(args.size_m * std::f64::consts::SQRT_2);
    let mut ground = Vec::new();
    for (k, &(x, y)) in viewpoints.iter().enumerate() {
        let z = field.height_at(x, y).with_context(|| format!("--viewpoints: {x},{y} is outside the {} m world", args.size_m))?;
        visible_ground_points(&field, Point3::new(x, y, z + 0.3), range_m, 0.025, 0.01, args.seed + k as u64, &mut ground);
    }
    let geometry = GridGeometry::new(0.0, 0.0, params.grid.resolution_m, field.geometry.width, field.geometry.height);
    let mut tmap = TraversabilityMap::new(geometry)?;
    tmap.insert_points(ground.iter().copied());
    let layers = tmap.compute(&params.traversability);
    let grid = layers.to_occupancy(params.traversability.tau);

    // Landmarks the camera (0.2 m up) could have mapped from the viewpoints.
    let camera_range_m = 2.0 * params.camera.max_depth_m;
    let all = scatter_landmarks(&field, &rocks, &LandmarkDensity::default(), args.seed);
    let mapped: Vec<Point3<f64>> = all
        .into_iter()
        .filter(|p| {
            viewpoints.iter().any(|&(x, y)| {
                let z = field.height_at(x, y).unwrap_or(0.0) + params.robot.camera_height_m;
                (p.x - x).hypot(p.y - y) <= camera_range_m
                    && line_of_sight(&field, Point3::new(x, y, z), *p + nalgebra::Vector3::new(0.0, 0.0, 0.05), 0.025)
            })
        })
        .collect();
    let sigma2 = params.u2.sigma_landmark_m.powi(2);
    let landmarks =
        PointCloud { covariances: Some(vec![Matrix3::identity() * sigma2; mapped.len()]), points: mapped, classification: None };

    let (yaml, pgm) = io::save_map(&grid, "map.pgm");
    load::write(&args.out.join("map.yaml"), yaml.as_bytes())?;
    load::write(&args.out.join("map.pgm"), &pgm)?;
    load::write(&args.out.join("landmarks.ply"), &io::ply::write_ply_binary(&landmarks))?;
    load::write(&args.out.join("landmarks.csv"), io::csv::write_csv(&landmarks).as_bytes())?;
    let scene = format!(
        "# Planning scene built by `fitslam build-asset` (see README).\n\
         # DEM: {} (pixel {} m), central {} crop scaled to {} m, relief × {}; seed {}.\n\
         map = \"map.yaml\"\nlandmarks = \"landmarks.ply\"\n\
         # Start pose X, Y (m), yaw (rad), map frame.\nstart = [{:.2}, {:.2}, 0.0]\n\
         viewpoints = {:?}\nrocks = {}\nlandmark_count = {}\nlidar_points = {}\n",
        args.dem.file_name().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
        args.dem_pixel_m,
        args.crop_fraction,
        args.size_m,
        args.relief_scale,
        args.seed,
        start.0,
        start.1,
        viewpoints.iter().map(|&(x, y)| [x, y]).collect::<Vec<_>>(),
        rocks.len(),
        landmarks.len(),
        ground.len()
    );
    load::write(&args.out.join("scene.toml"), scene.as_bytes())?;
    let g = layers.geometry();
    let png = io::write_png_rgb8(g.width, g.height, &fitslam_core::traversability::score_to_rgb(&layers))?;
    load::write(&args.out.join("score.png"), &png)?;
    let count = |v: i8| grid.data.iter().filter(|&&c| c == v).count();
    outln!(
        "{}: {} rocks, {} LiDAR points, {} × {} cells ({} free, {} lethal, {} unknown), {} landmarks",
        args.out.display(),
        rocks.len(),
        ground.len(),
        g.width,
        g.height,
        count(0),
        count(100),
        count(-1),
        landmarks.len()
    )?;
    Ok(())
}
