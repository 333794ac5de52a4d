//! Exploration (temporary).

use fitslam_core::traversability::TraversabilityMap;
use fitslam_core::{io, Params};

fn load(name: &str) -> fitslam_core::PointCloud {
    let path = format!("{}/assets/data/lidar/{name}", env!("CARGO_MANIFEST_DIR"));
    let bytes = std::fs::read(&path).unwrap();
    io::load_cloud(&bytes, name).unwrap()
}

fn pct(v: &mut Vec<f32>, q: f64) -> f32 {
    v.sort_by(|a, b| a.total_cmp(b));
    if v.is_empty() { return f32::NAN; }
    v[((v.len() - 1) as f64 * q).round() as usize]
}

fn summary(name: &str, l: &fitslam_core::traversability::TraversabilityLayers) {
    for (lname, layer) in [("slope_deg", &l.slope_rad), ("step", &l.step_m), ("rough", &l.roughness_m), ("score", &l.score)] {
        let mut v: Vec<f32> = layer.data.iter().copied().filter(|x| !x.is_nan()).collect();
        let scale = if lname == "slope_deg" { 57.29578 } else { 1.0 };
        eprintln!("{name} {lname}: n={} p5={:.4} p50={:.4} p95={:.4} max={:.4}", v.len(), pct(&mut v, 0.05) * scale, pct(&mut v, 0.5) * scale, pct(&mut v, 0.95) * scale, pct(&mut v, 1.0) * scale);
    }
}

#[test]
fn explore() {
    let p = Params::default();
    for name in ["plane.ply", "vegetation_1_3.ply"] {
        let c = load(name);
        let zs: Vec<f64> = c.points.iter().map(|p| p.z).collect();
        eprintln!("{name}: {} pts z {:.3}..{:.3}", c.len(), zs.iter().cloned().fold(f64::INFINITY, f64::min), zs.iter().cloned().fold(f64::NEG_INFINITY, f64::max));
        let m = TraversabilityMap::from_cloud(&c, &p).unwrap();
        let l = m.compute(&p.traversability);
        let occ = l.to_occupancy(p.traversability.tau);
        let known = l.known_cells();
        let free = occ.data.iter().filter(|&&v| v == 0).count();
        eprintln!("{name}: geom {:?} known {known} free {free}", m.geometry());
        summary(name, &l);
    }
    let c = load("autzen_trim.ply");
    let cls = c.classification.clone().unwrap();
    for res in [1.0, 1.5] {
        for disc in [1.5, 2.0, 3.0] {
            for minp in [5u32, 8] {
                let mut p = Params::default();
                p.grid.resolution_m = res;
                p.traversability.disc_radius_m = disc;
                p.traversability.min_points = minp;
                p.traversability.max_step_m = 1.0;
                p.traversability.max_roughness_m = 0.3;
                p.robot.radius_m = 0.0;
                let t = std::time::Instant::now();
                let m = TraversabilityMap::from_cloud(&c, &p).unwrap();
                let l = m.compute(&p.traversability);
                let dt = t.elapsed();
                let g = m.geometry();
                let mut ground = vec![0u32; g.len()];
                let mut total = vec![0u32; g.len()];
                for (q, k) in c.points.iter().zip(&cls) {
                    let i = g.index(g.cell_of(q.x, q.y).unwrap()).unwrap();
                    total[i] += 1;
                    if *k == 2 { ground[i] += 1; }
                }
                let (mut tp, mut fp, mut fneg, mut tn) = (0, 0, 0, 0);
                let mut gs = vec![]; let mut ns = vec![];
                let mut gstep = vec![]; let mut grough = vec![]; let mut gslope = vec![];
                for i in 0..g.len() {
                    let s = l.score.data[i];
                    if s.is_nan() || total[i] == 0 { continue; }
                    let is_ground = 2 * ground[i] > total[i];
                    let trav = f64::from(s) >= p.traversability.tau;
                    if is_ground { gs.push(s); gstep.push(l.step_m.data[i]); grough.push(l.roughness_m.data[i]); gslope.push(l.slope_rad.data[i].to_degrees()); } else { ns.push(s); }
                    match (trav, is_ground) { (true, true) => tp += 1, (true, false) => fp += 1, (false, true) => fneg += 1, _ => tn += 1 }
                }
                eprintln!("autzen res {res} disc {disc} minp {minp}: {:?} {dt:?} tp {tp} fp {fp} fn {fneg} tn {tn} P {:.3} R {:.3}", (g.width, g.height), tp as f64 / (tp + fp) as f64, tp as f64 / (tp + fneg) as f64);
                eprintln!("   ground step p50 {:.3} p90 {:.3}; rough p50 {:.3} p90 {:.3}; slope p50 {:.1} p90 {:.1}", pct(&mut gstep, 0.5), pct(&mut gstep, 0.9), pct(&mut grough, 0.5), pct(&mut grough, 0.9), pct(&mut gslope, 0.5), pct(&mut gslope, 0.9));
            }
        }
    }
}
