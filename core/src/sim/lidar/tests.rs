//! The LiDAR model: ray casting on the heightfield and obstacles, beam pattern, noise.

use super::*;
use crate::grid::GridGeometry;
use proptest::prelude::*;
use rand::SeedableRng;

/// The previous marcher, kept as the reference: samples the ray every cell length, skipping
/// 8 × 8-cell blocks whose (dilated) highest sample is below the ray, and bisects the first
/// sample found below the terrain 8 times. It misses crossings thinner than a step.
fn reference_cast(field: &Heightfield, origin: Point3<f64>, dir: Vector3<f64>, max_range_m: f64) -> Option<f64> {
    const BLOCK: usize = 8;
    let g = field.geometry;
    let (bx, by) = (g.width.div_ceil(BLOCK), g.height.div_ceil(BLOCK));
    let mut block_max_m = vec![f64::NEG_INFINITY; bx * by];
    for row in 0..g.height {
        for col in 0..g.width {
            let z = field.heights_m[row * g.width + col];
            let (c0, c1) = ((col.saturating_sub(1)) / BLOCK, ((col + 1).min(g.width - 1)) / BLOCK);
            let (r0, r1) = ((row.saturating_sub(1)) / BLOCK, ((row + 1).min(g.height - 1)) / BLOCK);
            for br in r0..=r1 {
                for bc in c0..=c1 {
                    let m = &mut block_max_m[br * bx + bc];
                    *m = m.max(z);
                }
            }
        }
    }
    let res = g.resolution_m;
    let block_m = res * BLOCK as f64;
    let above = |t: f64| -> Option<bool> {
        let p = origin + dir * t;
        field.height_at(p.x, p.y).map(|h| p.z > h)
    };
    if !above(0.0)? {
        return Some(0.0);
    }
    let mut t = 0.0;
    let horiz = dir.x.hypot(dir.y);
    while t < max_range_m {
        let p = origin + dir * t;
        let fx = (p.x - g.origin_x_m) / block_m;
        let fy = (p.y - g.origin_y_m) / block_m;
        if fx < 0.0 || fy < 0.0 {
            return None;
        }
        let (bc, br) = (fx as usize, fy as usize);
        if bc >= bx || br >= by {
            return None;
        }
        let exit = if horiz < 1e-12 {
            max_range_m
        } else {
            let tx = if dir.x > 1e-12 {
                ((bc + 1) as f64 * block_m + g.origin_x_m - p.x) / dir.x
            } else if dir.x < -1e-12 {
                (bc as f64 * block_m + g.origin_x_m - p.x) / dir.x
            } else {
                f64::INFINITY
            };
            let ty = if dir.y > 1e-12 {
                ((br + 1) as f64 * block_m + g.origin_y_m - p.y) / dir.y
            } else if dir.y < -1e-12 {
                (br as f64 * block_m + g.origin_y_m - p.y) / dir.y
            } else {
                f64::INFINITY
            };
            t + tx.min(ty).max(1e-6)
        };
        let exit = exit.min(max_range_m);
        let z_low = p.z.min(origin.z + dir.z * exit);
        if z_low > block_max_m[br * bx + bc] {
            t = exit;
            continue;
        }
        while t < exit {
            let next = (t + res).min(exit);
            match above(next) {
                None => return None,
                Some(true) => t = next,
                Some(false) => {
                    let (mut a, mut b) = (t, next);
                    for _ in 0..8 {
                        let m = 0.5 * (a + b);
                        if above(m).unwrap_or(false) { a = m } else { b = m }
                    }
                    return Some(0.5 * (a + b));
                }
            }
        }
        t = exit;
    }
    None
}

/// Random terrain: smooth hills, a ridge, a box and a kerb (bilinear between samples).
fn terrain(seed: (f64, f64, f64, f64), res: f64, n: usize) -> Heightfield {
    let (a, b, c, d) = seed;
    Heightfield::from_fn(GridGeometry::new(-0.3, 0.2, res, n, n), move |x, y| {
        let hills = a * (0.9 * x + c).sin() * (0.7 * y - d).cos() + 0.3 * b * (2.3 * x - 1.7 * y).sin();
        let rock = if (x - 2.0 - c).hypot(y - 2.5 - d) < 0.3 { 0.4 * b.abs() + 0.1 } else { 0.0 };
        let kerb = if x + 0.3 * y > 3.0 + d { 0.15 } else { 0.0 };
        hills + rock + kerb
    })
}

/// Whether the ray is above the terrain at every 1 mm sample of [t0, t1] inside the map.
fn clear_between(field: &Heightfield, o: Point3<f64>, dir: Vector3<f64>, t0: f64, t1: f64) -> bool {
    let mut s = t0;
    while s < t1 {
        let p = o + dir * s;
        if let Some(h) = field.height_at(p.x, p.y)
            && p.z <= h - 1e-9
        {
            return false;
        }
        s += 0.001;
    }
    true
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// The mip-map caster finds the exact first crossing of the bilinear surface: its hit
    /// lies on the surface, the ray is above the terrain before it (1 mm samples), and
    /// wherever the reference marcher hits, the exact hit is no later (the reference's
    /// bisection is accurate to 0.2 mm, and it can only miss slivers, not add crossings).
    #[test]
    fn exact_caster_agrees_with_the_reference_marcher(
        shape in (0.05f64..0.6, -0.5f64..0.5, 0.0f64..3.0, 0.0f64..3.0),
        res in prop_oneof![Just(0.05), Just(0.1), Just(0.037)],
        origin in (0.5f64..5.0, 0.8f64..5.0, 0.05f64..1.0),
        az in 0.0f64..std::f64::consts::TAU,
        el in -0.6f64..0.4,
        range in 0.2f64..8.0,
    ) {
        let n = (6.0 / res) as usize;
        let field = terrain(shape, res, n);
        let caster = RayCaster::new(&field);
        let Some(ground) = field.height_at(origin.0, origin.1) else { return Ok(()) };
        let o = Point3::new(origin.0, origin.1, ground + origin.2);
        let dir = Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
        let fast = caster.cast(&field, o, dir, range);
        let slow = reference_cast(&field, o, dir, range);
        if let Some(tr) = slow {
            let tf = fast.expect("the reference hit, so there is a crossing");
            prop_assert!(tf <= tr + 2e-4, "exact {} after reference {}", tf, tr);
        }
        match fast {
            Some(t) => {
                prop_assert!(t <= range + 1e-9);
                let p = o + dir * t;
                let h = field.height_at(p.x, p.y).unwrap();
                prop_assert!((p.z - h).abs() < 1e-7, "hit {} m off the surface", p.z - h);
                prop_assert!(clear_between(&field, o, dir, 0.0, t - 1e-6));
            }
            None => prop_assert!(clear_between(&field, o, dir, 0.0, range)),
        }
    }
}

/// The walk before the estimated crossings and the horizon, kept as the reference: every node's
/// crossings are exact quotients and a node is skipped exactly when the ray is above it.
fn node_by_node_walk(caster: &RayCaster, field: &Heightfield, origin: RayOrigin, dir: Vector3<f64>, max_range_m: f64) -> Option<f64> {
    let (au, av, oz, mut p, mut q) = match origin {
        RayOrigin::Outside => return None,
        RayOrigin::Below => return Some(0.0),
        RayOrigin::Above { au, av, oz, p, q } => (au, av, oz, p, q),
    };
    if max_range_m.is_nan() || max_range_m <= 0.0 || !dir.iter().all(|v| v.is_finite()) {
        return None;
    }
    let g = caster.geometry;
    let (w, h) = (g.width, g.height);
    let inv_res = 1.0 / g.resolution_m;
    let (bu, bv, dz) = (dir.x * inv_res, dir.y * inv_res, dir.z);
    let top = caster.levels.len() - 1;
    let mut level = 0usize;
    let mut t = 0.0f64;
    loop {
        let (ni, nj) = (p >> level, q >> level);
        // The node's patch range and its u, v extent, clipped to the grid.
        let (p_lo, p_hi) = (ni << level, (((ni + 1) << level) - 1).min(w));
        let (q_lo, q_hi) = (nj << level, (((nj + 1) << level) - 1).min(h));
        let (u_lo, u_hi) = ((p_lo as f64 - 1.0).max(-0.5), (p_hi as f64).min(w as f64 - 0.5));
        let (v_lo, v_hi) = ((q_lo as f64 - 1.0).max(-0.5), (q_hi as f64).min(h as f64 - 0.5));
        let tx = if bu > 0.0 {
            (u_hi - au) / bu
        } else if bu < 0.0 {
            (u_lo - au) / bu
        } else {
            f64::INFINITY
        };
        let ty = if bv > 0.0 {
            (v_hi - av) / bv
        } else if bv < 0.0 {
            (v_lo - av) / bv
        } else {
            f64::INFINITY
        };
        let t_exit = tx.min(ty).max(t);
        let seg_end = t_exit.min(max_range_m);
        let z_low = oz + dz * if dz < 0.0 { seg_end } else { t };
        let node_max = f64::from(caster.levels[level].max_m(ni, nj));
        if z_low <= node_max {
            if level > 0 {
                level -= 1;
                continue;
            }
            if let Some(hit) = patch_hit(field, p, q, [au, bu, av, bv, oz, dz], t, seg_end) {
                return Some(hit);
            }
        }
        if seg_end >= max_range_m {
            return None;
        }
        // Step into the next node along the exit side(s); the other index follows the ray,
        // kept inside this node's range against rounding.
        t = t_exit;
        p = next_patch(tx <= ty, p, (p_lo, p_hi), au + bu * t, bu, w)?;
        q = next_patch(ty <= tx, q, (q_lo, q_hi), av + bv * t, bv, h)?;
        level = (level + 1).min(top);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// The walk on estimated crossings, with or without the sweep's horizon, answers what the
    /// node-by-node walk on exact crossings answers, bit for bit: the same first patch, tested
    /// over the same exact span. Except at a tie, a ray through a patch corner to the last bit
    /// (here: from a corner along a diagonal), where the reference itself enters the diagonal
    /// patch at the crossing of one side or the other depending on its rounding and its level:
    /// then both agree to rounding (the span starts an ulp apart).
    #[test]
    fn the_walk_answers_as_the_exact_node_by_node_walk_bit_for_bit(
        shape in (0.05f64..0.6, -0.5f64..0.5, 0.0f64..3.0, 0.0f64..3.0),
        res in prop_oneof![Just(0.05), Just(0.1), Just(0.037)],
        origin in (0.5f64..5.0, 0.8f64..5.0, 0.02f64..1.0),
        on_corner in proptest::bool::ANY,
        az in prop_oneof![0.0f64..std::f64::consts::TAU, (0..8).prop_map(|k| k as f64 * std::f64::consts::FRAC_PI_4)],
        el in -0.6f64..0.4,
        range in prop_oneof![0.2f64..8.0, Just(100.0)],
    ) {
        let n = (6.0 / res) as usize;
        let field = terrain(shape, res, n);
        let caster = RayCaster::new(&field);
        let g = field.geometry;
        // A sample centre (a patch corner) sits at u = (x − x₀)/res − ½ integer.
        let snap = |x: f64, x0: f64| if on_corner { x0 + (((x - x0) / res - 0.5).round() + 0.5) * res } else { x };
        let (x, y) = (snap(origin.0, g.origin_x_m), snap(origin.1, g.origin_y_m));
        let Some(ground) = field.height_at(x, y) else { return Ok(()) };
        let o = Point3::new(x, y, ground + origin.2);
        let dir = Vector3::new(math::cos(el) * math::cos(az), math::cos(el) * math::sin(az), math::sin(el));
        let start = caster.ray_origin(&field, o);
        let reference = node_by_node_walk(&caster, &field, start, dir, range);
        let tie = on_corner && (az / std::f64::consts::FRAC_PI_4).fract() == 0.0;
        let agrees = |got: Option<f64>| match (got, reference) {
            _ if !tie => got.map(f64::to_bits) == reference.map(f64::to_bits),
            (Some(a), Some(b)) => (a - b).abs() <= 1e-12 * b.abs().max(1.0),
            (a, b) => a == b,
        };
        let got = caster.cast(&field, o, dir, range);
        prop_assert!(agrees(got), "{:?} vs {:?}", got, reference);
        if let RayOrigin::Above { au, av, .. } = start {
            let horizon = Horizon::new(&caster, au, av, range);
            let got = caster.cast_from(&field, start, dir, range, horizon.as_ref());
            prop_assert!(agrees(got), "{:?} vs {:?} with the horizon", got, reference);
        }
    }
}

#[test]
fn whole_sweeps_hit_where_the_exact_node_by_node_walk_hits_bit_for_bit() {
    // Every ray of tilted sweeps from on, above and beside rough terrain (rocks, a kerb), long and
    // short ranges: the sweep's walk (horizon, estimated crossings) against the reference walk.
    let mut points = 0;
    for (shape, res) in [((0.5, 0.4, 1.0, 0.5), 0.05), ((0.1, -0.3, 2.0, 1.5), 0.037), ((0.3, 0.5, 0.2, 2.5), 0.1)] {
        let field = terrain(shape, res, (6.0 / res) as usize);
        let caster = RayCaster::new(&field);
        for (x, y, above, range) in [(1.0, 1.5, 0.3, 4.0), (3.0, 3.0, 0.05, 10.0), (4.5, 2.0, 1.5, 2.5), (2.2, 2.7, 0.3, 10.0)] {
            let rot = Rotation3::from_euler_angles(0.1 * x - 0.2, 0.05 * y - 0.1, x + y);
            let o = Point3::new(x, y, field.height_at(x, y).unwrap() + above);
            let p = LidarParams { max_range_m: range, ..LidarParams::default() };
            let start = caster.ray_origin(&field, o);
            let (mut swept, mut single) = (Vec::new(), Vec::new());
            scan(&field, &caster, o, &rot, &p, &mut ChaCha8Rng::seed_from_u64(9), &mut swept);
            let mut rng = ChaCha8Rng::seed_from_u64(9);
            for k in 0..p.rings {
                let el = ring_elevation_rad(&p, k);
                for a in 0..180 {
                    let az = a as f64 * p.azimuth_step_rad;
                    let dir = rot * Vector3::new(math::cos(el) * math::cos(az), math::cos(el) * math::sin(az), math::sin(el));
                    if let Some(r) = node_by_node_walk(&caster, &field, start, dir, range) {
                        let noisy = r + p.range_sigma_m * gaussian(&mut rng);
                        if r >= p.min_range_m {
                            single.push(o + dir * noisy);
                        }
                    }
                }
            }
            assert_eq!(swept, single);
            points += swept.len();
        }
    }
    assert!(points > 5_000, "{points} points");
}

#[test]
fn exact_caster_matches_the_reference_on_almost_every_scan_ray() {
    // Whole sweeps over rough terrain: both agree within 0.2 mm except where the reference's
    // samples straddle a sliver of terrain (then the exact hit is earlier).
    let field = terrain((0.5, 0.4, 1.0, 0.5), 0.05, 120);
    let caster = RayCaster::new(&field);
    let p = LidarParams { max_range_m: 4.0, ..LidarParams::default() };
    let (mut both, mut differ) = (0, 0);
    for (x, y) in [(1.0, 1.5), (3.0, 3.0), (4.5, 2.0)] {
        let o = Point3::new(x, y, field.height_at(x, y).unwrap() + 0.3);
        for k in 0..p.rings {
            let el = ring_elevation_rad(&p, k);
            for a in 0..180 {
                let az = a as f64 * p.azimuth_step_rad;
                let dir = Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
                match (caster.cast(&field, o, dir, p.max_range_m), reference_cast(&field, o, dir, p.max_range_m)) {
                    (Some(f), Some(r)) if (f - r).abs() <= 2e-4 => both += 1,
                    (None, None) => both += 1,
                    (Some(f), r) => {
                        assert!(r.is_none_or(|r| f < r), "{f} vs {r:?}");
                        differ += 1;
                    }
                    (None, Some(r)) => panic!("reference hit at {r}, exact caster missed"),
                }
            }
        }
    }
    assert!(differ * 100 <= both, "{differ} of {} rays differ", both + differ);
}

#[test]
fn border_half_patches_and_vertical_rays() {
    // A slope rising along +x; rays near and along the map's edges, and straight down.
    let field = Heightfield::from_fn(GridGeometry::new(0.0, 0.0, 0.1, 30, 20), |x, _| 0.2 * x);
    let caster = RayCaster::new(&field);
    // Straight down from 1 m above (x = 1.23): hits at 1 − 0 = distance to the plane there.
    let o = Point3::new(1.23, 0.02, 1.0);
    let t = caster.cast(&field, o, Vector3::new(0.0, 0.0, -1.0), 5.0).unwrap();
    assert!((t - (1.0 - 0.2 * 1.23)).abs() < 1e-9, "{t}");
    // Inside the outer half cell (x < 0.05) the height is clamped to the first sample's 0.01.
    let o = Point3::new(0.01, 1.0, 0.5);
    let t = caster.cast(&field, o, Vector3::new(0.0, 0.0, -1.0), 5.0).unwrap();
    assert!((t - (0.5 - 0.01)).abs() < 1e-9, "{t}");
    // Along the bottom edge towards −x: the terrain falls away, the ray leaves the map.
    assert!(caster.cast(&field, Point3::new(2.0, 0.01, 0.5), Vector3::new(-1.0, 0.0, 0.0), 10.0).is_none());
    // Towards +x it meets the slope where 0.2·x = 0.5 → x = 2.5 (2.5 − 2.0 = 0.5 m).
    let t = caster.cast(&field, Point3::new(2.0, 0.01, 0.5), Vector3::new(1.0, 0.0, 0.0), 10.0).unwrap();
    assert!((t - 0.5).abs() < 1e-9, "{t}");
    // Out of range first; starting below ground; starting outside.
    assert!(caster.cast(&field, Point3::new(2.0, 1.0, 0.5), Vector3::new(1.0, 0.0, 0.0), 0.4).is_none());
    assert_eq!(caster.cast(&field, Point3::new(2.0, 1.0, 0.3), Vector3::new(1.0, 0.0, 0.0), 1.0), Some(0.0));
    assert!(caster.cast(&field, Point3::new(-1.0, 1.0, 0.5), Vector3::new(1.0, 0.0, 0.0), 9.0).is_none());
}

#[test]
fn lowest_ring_hits_flat_ground_at_h_over_tan15() {
    let field = Heightfield::from_fn(GridGeometry::new(-10.0, -10.0, 0.05, 400, 400), |_, _| 0.0);
    let caster = RayCaster::new(&field);
    let el = -15f64.to_radians();
    for az in [0.0f64, 1.0, 2.5, 4.0] {
        let dir = Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
        let t = caster.cast(&field, Point3::new(0.0, 0.0, 0.3), dir, 10.0).unwrap();
        let hit = Point3::new(0.0, 0.0, 0.3) + dir * t;
        let expected = 0.3 / 15f64.to_radians().tan(); // 1.1196 m
        assert!((hit.x.hypot(hit.y) - expected).abs() < 1e-3, "{} vs {expected}", hit.x.hypot(hit.y));
        assert!(hit.z.abs() < 1e-3);
    }
    // Upward rays never hit a flat floor.
    assert!(caster.cast(&field, Point3::new(0.0, 0.0, 0.3), Vector3::new(1.0, 0.0, 0.1).normalize(), 9.0).is_none());
}

#[test]
fn a_wall_stops_horizontal_rays_and_block_skipping_matches_brute_force() {
    // A 1 m wall at x ≥ 6 m; hills elsewhere.
    let field = Heightfield::from_fn(GridGeometry::new(0.0, 0.0, 0.05, 200, 200), |x, y| {
        if x >= 6.0 { 1.0 } else { 0.2 * (x * 0.7).sin() * (y * 0.5).cos() }
    });
    let caster = RayCaster::new(&field);
    let o = Point3::new(1.0, 5.0, 0.5);
    let t = caster.cast(&field, o, Vector3::new(1.0, 0.0, 0.0), 10.0).unwrap();
    // Random rays from the centre, staying inside the map (range 4.5 m).
    let o = Point3::new(5.0, 5.0, 0.5);
    // Bilinear: the wall rises between the centres 5.975 and 6.025.
    assert!((1.0 + t - 6.0).abs() < 0.05, "{}", 1.0 + t);
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for _ in 0..200 {
        let az: f64 = rng.random::<f64>() * std::f64::consts::TAU;
        let el: f64 = -0.3 + 0.4 * rng.random::<f64>();
        let dir = Vector3::new(el.cos() * az.cos(), el.cos() * az.sin(), el.sin());
        let fast = caster.cast(&field, o, dir, 4.5);
        // Brute force at 1 mm steps.
        let mut brute = None;
        let mut s = 0.0;
        while s < 4.5 {
            let p = o + dir * s;
            match field.height_at(p.x, p.y) {
                None => break,
                Some(h) if p.z <= h => {
                    brute = Some(s);
                    break;
                }
                _ => {}
            }
            s += 0.001;
        }
        match (fast, brute) {
            (Some(a), Some(b)) => assert!((a - b).abs() < 0.01, "{a} vs {b}"),
            (None, None) => {}
            // A grazing ray may touch within one fine step: tolerate only near-misses.
            (a, b) => panic!("fast {a:?} vs brute {b:?} (az {az}, el {el})"),
        }
    }
}

#[test]
fn a_sweep_hits_where_each_ray_cast_on_its_own_hits() {
    // `scan` prepares the origin once per sweep: the same points, bit for bit, as casting
    // every ray with `cast` and the same noise.
    let field = terrain((0.5, 0.4, 1.0, 0.5), 0.05, 120);
    let caster = RayCaster::new(&field);
    let p = LidarParams { max_range_m: 4.0, ..LidarParams::default() };
    let rot = Rotation3::from_euler_angles(0.1, -0.05, 0.7);
    for (x, y) in [(1.0, 1.5), (3.0, 3.0), (-1.0, 1.0)] {
        let o = Point3::new(x, y, field.height_at(x, y).map_or(0.3, |z| z + 0.3));
        let (mut swept, mut single) = (Vec::new(), Vec::new());
        scan(&field, &caster, o, &rot, &p, &mut ChaCha8Rng::seed_from_u64(5), &mut swept);
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let n_az = (std::f64::consts::TAU / p.azimuth_step_rad).round() as usize;
        for k in 0..p.rings {
            let el = ring_elevation_rad(&p, k);
            for a in 0..n_az {
                let az = a as f64 * p.azimuth_step_rad;
                let dir = rot * Vector3::new(math::cos(el) * math::cos(az), math::cos(el) * math::sin(az), math::sin(el));
                if let Some(r) = caster.cast(&field, o, dir, p.max_range_m) {
                    let noisy = r + p.range_sigma_m * gaussian(&mut rng);
                    if r >= p.min_range_m {
                        single.push(o + dir * noisy);
                    }
                }
            }
        }
        assert_eq!(swept, single);
        assert_eq!(swept.is_empty(), x < 0.0, "{} points from ({x}, {y})", swept.len());
    }
}

#[test]
fn a_scan_has_the_expected_ring_count_on_flat_ground() {
    let field = Heightfield::from_fn(GridGeometry::new(-12.0, -12.0, 0.05, 480, 480), |_, _| 0.0);
    let caster = RayCaster::new(&field);
    let p = LidarParams::default();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut out = Vec::new();
    let rays = scan(&field, &caster, Point3::new(0.0, 0.0, 0.3), &Rotation3::identity(), &p, &mut rng, &mut out);
    assert_eq!(rays, 16 * 180);
    // Rings below 0°: elevations −15 + 2k; those hitting within 10 m: tan(el) ≥ 0.03 → 7 rings.
    assert_eq!(out.len(), 7 * 180);
}
