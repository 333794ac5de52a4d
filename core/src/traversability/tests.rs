//! Scenario tests of the whole traversability pipeline on synthetic terrain with hand-derived
//! expectations (notes §2).

use nalgebra::Point3;
use proptest::prelude::*;

use super::disc_sums::disc_offsets;
use super::moments::CellMoments;
use super::plane::fit_plane;
use super::*;
use crate::grid::{Cell, FREE, Grid, GridGeometry, LETHAL, UNKNOWN, inflate_lethal};
use crate::params::TraversabilityParams;

const RES: f64 = 0.05;
const N_CELLS: usize = 40;
/// Points every 1 cm at ((i + ½) cm, (j + ½) cm): 5 × 5 points per 5 cm cell.
const SPACING: f64 = 0.01;

fn geometry() -> GridGeometry {
    GridGeometry::new(0.0, 0.0, RES, N_CELLS, N_CELLS)
}

fn surface(f: impl Fn(f64, f64) -> f64) -> Vec<Point3<f64>> {
    let n = (N_CELLS as f64 * RES / SPACING).round() as usize;
    let mut v = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let (x, y) = ((i as f64 + 0.5) * SPACING, (j as f64 + 0.5) * SPACING);
            v.push(Point3::new(x, y, f(x, y)));
        }
    }
    v
}

fn layers_of(points: &[Point3<f64>], p: &TraversabilityParams) -> TraversabilityLayers {
    let mut map = TraversabilityMap::new(geometry()).unwrap();
    map.insert_points(points.iter().copied());
    map.compute(p)
}

/// Cells whose whole disc lies inside the sampled area (disc radius 3 cells by default).
fn interior() -> impl Iterator<Item = Cell> {
    (3..N_CELLS as i32 - 3).flat_map(|r| (3..N_CELLS as i32 - 3).map(move |c| Cell::new(c, r)))
}

/// Bitwise equality of every layer (NaN equals NaN).
pub(crate) fn assert_same(a: &TraversabilityLayers, b: &TraversabilityLayers) {
    for (x, y) in [
        (&a.slope_rad, &b.slope_rad),
        (&a.step_m, &b.step_m),
        (&a.roughness_m, &b.roughness_m),
        (&a.hazard, &b.hazard),
        (&a.score, &b.score),
        (&a.ground_z_m, &b.ground_z_m),
    ] {
        assert_eq!(x.geometry, y.geometry);
        assert!(x.data.iter().zip(&y.data).all(|(u, v)| u.to_bits() == v.to_bits()));
    }
    let bits = |g: &[f32; 2]| [g[0].to_bits(), g[1].to_bits()];
    assert!(a.ground_gradient.data.iter().zip(&b.ground_gradient.data).all(|(u, v)| bits(u) == bits(v)));
    assert_eq!(a.cell_points, b.cell_points);
    assert_eq!(a.disc_points, b.disc_points);
    assert_eq!(a.params(), b.params());
}

fn at(layer: &Grid<f32>, c: Cell) -> f64 {
    f64::from(*layer.get(c).unwrap())
}

#[test]
fn default_disc_has_29_cells() {
    // r = 0.15 m / 0.05 m = 3 cells: lattice points with dx² + dy² ≤ 9 → 1 + 4·3 + 4·(2 + 2 + 1 + 1)… = 29.
    assert_eq!(disc_offsets(0.15, 0.05).len(), 29);
    assert_eq!(disc_offsets(0.01, 0.05), vec![(0, 0)]);
    assert_eq!(disc_offsets(0.05, 0.05).len(), 5);
    assert_eq!(disc_offsets(f64::NAN, 0.05), vec![(0, 0)]);
}

#[test]
fn fifteen_degree_ramp_has_its_slope_and_is_free() {
    let t = 15f64.to_radians().tan();
    let p = TraversabilityParams::default();
    let layers = layers_of(&surface(|x, _| t * x), &p);
    let occ = layers.to_occupancy(p.tau);
    // Plane-relative step: in every cell the 5 point columns sit at mean ± 0.02 m, so the
    // residuals span ±0.02·tan 15° → step = 0.04·tan 15°.
    let step_rel = 0.04 * t;
    let hazard = (15f64 / 35.0).max(step_rel / p.max_step_m);
    for c in interior() {
        assert!((at(&layers.slope_rad, c) - 15f64.to_radians()).abs() < 1e-5, "{c:?}");
        assert!(at(&layers.roughness_m, c) < 1e-4);
        assert!((at(&layers.step_m, c) - step_rel).abs() < 1e-6, "{c:?} {}", at(&layers.step_m, c));
        assert!((at(&layers.score, c) - (1.0 - hazard)).abs() < 1e-5);
        assert_eq!(*occ.get(c).unwrap(), FREE);
        assert_eq!(*layers.disc_points.get(c).unwrap(), 29 * 25);
        assert_eq!(*layers.cell_points.get(c).unwrap(), 25);
    }
    // The notes' literal step (max z − min z in the disc): the disc's points span 7 cells less
    // one point spacing in x, 0.34 m, so the step is 0.34·tan 15° = 9.1 cm.
    let raw = TraversabilityParams { step_relative_to_plane: false, ..p.clone() };
    let layers = layers_of(&surface(|x, _| t * x), &raw);
    for c in interior() {
        assert!((at(&layers.step_m, c) - 0.34 * t).abs() < 1e-6, "{}", at(&layers.step_m, c));
    }
}

#[test]
fn the_ground_layers_hold_the_fitted_plane() {
    // z = 3 + 0.2 x − 0.1 y: every interior cell's ground is the plane at its centre, with
    // gradient (0.2, −0.1); the ground model evaluates the plane between centres too.
    let plane = |x: f64, y: f64| 3.0 + 0.2 * x - 0.1 * y;
    let layers = layers_of(&surface(plane), &TraversabilityParams::default());
    let g = geometry();
    for c in interior() {
        let (x, y) = g.center_of(c);
        assert!((at(&layers.ground_z_m, c) - plane(x, y)).abs() < 1e-5, "{c:?}");
        let [gx, gy] = layers.ground_gradient.data[g.index(c).unwrap()];
        assert!((f64::from(gx) - 0.2).abs() < 1e-5 && (f64::from(gy) + 0.1).abs() < 1e-5, "{c:?}");
    }
    let (z, _) = layers.ground().at(1.0, 1.01).unwrap();
    assert!((z - plane(1.0, 1.01)).abs() < 1e-5);
    // Unknown ground (outside the points' discs) is unknown.
    assert_eq!(layers.ground().at(-1.0, 0.5), None);
}

#[test]
fn ten_centimetre_step_has_its_height_and_is_lethal() {
    // Floor z = 0 for x < 1 m (columns 0–19), z = 0.1 m from x = 1 m (columns 20–39).
    let h = 0.1;
    let pts = surface(|x, _| if x < 1.0 { 0.0 } else { h });
    let raw = TraversabilityParams { step_relative_to_plane: false, ..TraversabilityParams::default() };
    let layers = layers_of(&pts, &raw);
    for c in interior() {
        // A disc (columns col−3..=col+3) sees the step iff it spans columns 19 and 20.
        let expected = if (17..=22).contains(&c.col) { h } else { 0.0 };
        assert!((at(&layers.step_m, c) - expected).abs() < 1e-6, "{c:?}");
    }

    let p = TraversabilityParams::default();
    let layers = layers_of(&pts, &p);
    let occ = layers.to_occupancy(p.tau);
    for row in 3..N_CELLS as i32 - 3 {
        for col in [19, 20] {
            let c = Cell::new(col, row);
            // Each cell is flat, so relative to a plane of gradient b = tan(slope) the residual
            // jumps by h − b·0.05 between the cell means either side of the step (0.975 / 1.025 m).
            let b = at(&layers.slope_rad, c).tan();
            assert!(at(&layers.step_m, c) >= h - 0.05 * b - 1e-6, "{c:?}");
            assert_eq!(*occ.get(c).unwrap(), LETHAL, "{c:?} score {}", at(&layers.score, c));
        }
        for col in [3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 25, 26, 27, 28, 29, 30, 31, 32, 33, 34, 35, 36] {
            let c = Cell::new(col, row);
            assert_eq!(at(&layers.score, c), 1.0, "{c:?}");
            assert_eq!(*occ.get(c).unwrap(), FREE);
        }
    }
    // After inflation by the robot radius the step is a wall 2·0.25 m thick.
    let inflated = inflate_lethal(&occ, 0.25);
    assert_eq!(*inflated.get(Cell::new(15, 20)).unwrap(), LETHAL);
}

#[test]
fn plus_minus_sigma_points_give_roughness_sigma() {
    // Every (x, y) carries two points, z = +σ and z = −σ: the plane is z = 0 and every point is
    // exactly σ from it.
    let sigma = 0.02;
    let mut pts = surface(|_, _| sigma);
    pts.extend(surface(|_, _| -sigma));
    let p = TraversabilityParams::default();
    let layers = layers_of(&pts, &p);
    for c in interior() {
        assert!((at(&layers.roughness_m, c) - sigma).abs() < 1e-7);
        assert!(at(&layers.slope_rad, c) < 1e-6);
        // hazard = max(0, 2σ / max_step, σ / max_roughness) = max(0.267, 0.4)
        let hazard = (2.0 * sigma / p.max_step_m).max(sigma / p.max_roughness_m);
        assert!((at(&layers.hazard, c) - hazard).abs() < 1e-6);
    }
}

#[test]
fn registration_noise_is_discounted_from_roughness_and_step() {
    // Two layers ±3 cm apart (roughness σ = 3 cm, relative step 6 cm): lethal as measured
    // (σ / max_roughness = 0.6 > 1 − τ). Inserted with vertical noise variance v = (1 cm)², the
    // hazard uses √(σ² − k²v) = √(9 − 4) cm = 2.236 cm and 6 − 2√2 cm = 3.17 cm (k = 2):
    // hazard = max(0.02236 / 0.05, 0.03172 / 0.15) = 0.447, free. The layers keep 3 cm and 6 cm.
    let sigma = 0.03;
    let mut pts = surface(|_, _| sigma);
    pts.extend(surface(|_, _| -sigma));
    let p = TraversabilityParams::default();
    let measured = layers_of(&pts, &p);
    let mut map = TraversabilityMap::new(geometry()).unwrap();
    map.insert_points_with_variance(pts.iter().map(|&q| (q, 1e-4)));
    let mut noisy = map.compute(&p);
    let mut no_discount = p.clone();
    no_discount.noise_discount_sigmas = 0.0;
    let undiscounted = map.compute(&no_discount);
    let hazard = (0.0005f64.sqrt() / p.max_roughness_m).max((0.06 - 2.0 * 0.0002f64.sqrt()) / p.max_step_m);
    assert!((hazard - 0.4472).abs() < 1e-4);
    for c in interior() {
        assert!((at(&measured.hazard, c) - 0.6).abs() < 1e-6);
        assert_eq!(at(&undiscounted.hazard, c), at(&measured.hazard, c));
        assert!((at(&noisy.hazard, c) - hazard).abs() < 1e-6, "{}", at(&noisy.hazard, c));
        assert!((at(&noisy.roughness_m, c) - sigma).abs() < 1e-7 && (at(&noisy.step_m, c) - 2.0 * sigma).abs() < 1e-6);
        assert_eq!(*noisy.to_occupancy(p.tau).get(c).unwrap(), FREE);
        assert_eq!(*measured.to_occupancy(p.tau).get(c).unwrap(), LETHAL);
    }
    // The disc sums keep the variance through a rebuild (another disc radius and back).
    map.update(&TraversabilityParams { disc_radius_m: 0.1, ..p.clone() }, &mut noisy);
    map.update(&p, &mut noisy);
    assert!(interior().all(|c| (at(&noisy.hazard, c) - hazard).abs() < 1e-6));
}
#[test]
fn sparse_or_strip_shaped_discs_are_unknown() {
    let g = GridGeometry::new(0.0, 0.0, RES, 20, 20);
    let p = TraversabilityParams::default();
    let mut map = TraversabilityMap::new(g).unwrap();
    // Four points at the corners of a 0.1 m square around (0.5, 0.5), in cells (9|11, 9|11):
    // fewer than min_points = 5 in any disc, so the whole map is unknown.
    map.insert_points([(0.45, 0.45), (0.55, 0.45), (0.45, 0.55), (0.55, 0.55)].map(|(x, y)| Point3::new(x, y, 0.0)));
    let layers = map.compute(&p);
    assert_eq!(layers.known_cells(), 0);
    assert!(layers.to_occupancy(p.tau).data.iter().all(|&v| v == UNKNOWN));
    assert_eq!(*layers.cell_points.get(Cell::new(9, 9)).unwrap(), 1);
    assert_eq!(*layers.disc_points.get(Cell::new(10, 10)).unwrap(), 4);
    // A fifth point at the centre, cell (10, 10). Horizontal spread: σ_x = σ_y = √(4·0.05²/5)
    // = 4.5 cm ≥ 0.2 · 0.15 m. The discs holding all five cells are those of the 3 × 3 block
    // around (10, 10) (from (10, 12), cell (9, 9) is 1² + 3² = 10 > 9 cells² away): 9 known cells.
    map.insert_points([Point3::new(0.5, 0.5, 0.0)]);
    let layers = map.compute(&p);
    assert_eq!(layers.known_cells(), 9);
    let occ = layers.to_occupancy(p.tau);
    for r in 9..=11 {
        for c in 9..=11 {
            assert_eq!(*occ.get(Cell::new(c, r)).unwrap(), FREE);
        }
    }
    // Thirty points on a line (one scan ring crossing the discs): spread 0 across it, so the
    // tilt across the line is undetermined and every cell stays unknown.
    let mut line = TraversabilityMap::new(g).unwrap();
    line.insert_points((0..30).map(|k| Point3::new(0.2 + k as f64 * 0.02, 0.51, 0.0)));
    assert_eq!(line.compute(&p).known_cells(), 0);
    // Without the spread test the least-sloped plane through the line is used: horizontal, free.
    let lax = TraversabilityParams { min_spread_ratio: 0.0, ..p.clone() };
    let layers = line.compute(&lax);
    assert!(layers.known_cells() > 0);
    assert_eq!(*layers.to_occupancy(p.tau).get(Cell::new(10, 10)).unwrap(), FREE);
}

#[test]
fn occupancy_thresholds_at_tau() {
    let g = GridGeometry::new(0.0, 0.0, 1.0, 5, 1);
    let score = Grid::from_vec(g, vec![f32::NAN, 0.2, 0.5, 0.9, 0.0]).unwrap();
    assert_eq!(to_occupancy(&score, 0.5).data, vec![UNKNOWN, LETHAL, FREE, FREE, LETHAL]);
    assert_eq!(to_occupancy(&score, 0.0).data, vec![UNKNOWN, FREE, FREE, FREE, FREE]);
}

#[test]
fn score_image_is_top_row_first() {
    let g = GridGeometry::new(0.0, 0.0, 1.0, 2, 2);
    let mut layers = TraversabilityLayers::unknown(g, &TraversabilityParams::default());
    layers.score.data = vec![1.0, 0.0, 0.5, f32::NAN]; // row 0 (bottom): green, red; row 1: yellow, unknown
    assert_eq!(score_to_rgb(&layers), vec![255, 255, 0, 128, 128, 128, 0, 255, 0, 255, 0, 0]);
}

#[test]
fn utm_coordinates_give_the_same_layers() {
    let t = 10f64.to_radians().tan();
    let pts = surface(|x, y| t * x + 0.02 * (40.0 * y).sin());
    let p = TraversabilityParams::default();
    let near = layers_of(&pts, &p);
    let (ox, oy, oz) = (512_345.0, 5_123_456.0, 1_234.0);
    let g = GridGeometry::new(ox, oy, RES, N_CELLS, N_CELLS);
    let mut map = TraversabilityMap::new(g).unwrap();
    map.insert_points(pts.iter().map(|q| Point3::new(q.x + ox, q.y + oy, q.z + oz)));
    let far = map.compute(&p);
    for (a, b) in near.score.data.iter().zip(&far.score.data) {
        assert!((a - b).abs() < 1e-5, "{a} vs {b}");
    }
    for (a, b) in near.roughness_m.data.iter().zip(&far.roughness_m.data) {
        assert!((a - b).abs() < 1e-6, "{a} vs {b}");
    }
}

#[test]
fn incremental_update_equals_full_compute() {
    let pts = surface(|x, y| 0.05 * (5.0 * x).sin() * (3.0 * y).cos() + if x > 1.3 { 0.08 } else { 0.0 });
    let p = TraversabilityParams::default();
    let batch = layers_of(&pts, &p);

    let mut map = TraversabilityMap::new(geometry()).unwrap();
    let mut layers = map.compute(&p);
    let (a, b) = pts.split_at(pts.len() / 2);
    assert_eq!(map.update(&p, &mut layers), N_CELLS * N_CELLS); // never updated: full compute
    map.insert_points(a.iter().copied());
    map.update(&p, &mut layers);
    map.insert_points(b.iter().copied());
    map.update(&p, &mut layers);
    assert_same(&layers, &batch);

    // A small local change recomputes only the discs around it, and still equals compute.
    map.insert_points([Point3::new(0.51, 0.51, 0.3)]);
    assert_eq!(map.update(&p, &mut layers), 29);
    assert_same(&layers, &map.compute(&p));
    assert_eq!(map.update(&p, &mut layers), 0);

    // Other parameters, or a clear, recompute everything.
    let p2 = TraversabilityParams { disc_radius_m: 0.1, ..p.clone() };
    assert_eq!(map.update(&p2, &mut layers), N_CELLS * N_CELLS);
    assert_same(&layers, &map.compute(&p2));
    map.clear();
    map.insert_points(pts.iter().copied());
    assert_eq!(map.update(&p, &mut layers), N_CELLS * N_CELLS);
    assert_same(&layers, &batch);
}

#[test]
fn a_forgotten_disc_is_as_if_its_points_never_came() {
    // A wall spike at (0.5, 0.5) on a flat floor, forgotten with a 0.2 m disc around it: the 5 × 5
    // points of each 5 cm cell whose centre is within 0.2 m go (centres at 0.025 + 0.05 k), and
    // the layers (and known flags) then equal those of a map that never had them, bit for bit.
    let p = TraversabilityParams::default();
    let mut pts = surface(|_, _| 0.0);
    pts.push(Point3::new(0.51, 0.51, 0.4));
    let n = N_CELLS * N_CELLS;
    let (mut known, mut fresh_known) = (vec![false; n], vec![false; n]);
    let mut map = TraversabilityMap::new(geometry()).unwrap();
    map.insert_points(pts.iter().copied());
    let mut layers = map.compute(&p);
    map.update(&p, &mut layers);
    map.refresh_known(&p, |i, k| known[i] = k);
    let known_before = known.iter().filter(|&&k| k).count();
    let g = geometry();
    let near = |i: usize| {
        let (cx, cy) = g.center_of(g.cell_at(i));
        (cx - 0.5).hypot(cy - 0.5) <= 0.2
    };
    let kept: Vec<_> = pts.iter().copied().filter(|q| !near(g.index(g.cell_of(q.x, q.y).unwrap()).unwrap())).collect();
    let cells = (0..n).filter(|&i| near(i)).count();
    // Centres 0.025 + 0.05 k: offsets (a, b) · 0.025 m with odd a, b and a² + b² ≤ 64, 13 per quadrant.
    assert_eq!(cells, 52);
    assert_eq!(map.forget_disc(0.5, 0.5, 0.2), (cells * 25 + 1) as u64);
    assert_eq!(map.point_count(), kept.len() as u64);
    assert_eq!(map.update(&p, &mut layers), n, "every cell is re-estimated");
    let mut fresh = TraversabilityMap::new(geometry()).unwrap();
    fresh.insert_points(kept.iter().copied());
    assert_same(&layers, &fresh.compute(&p));
    map.refresh_known(&p, |i, k| known[i] = k);
    fresh.refresh_known(&p, |i, k| fresh_known[i] = k);
    assert_eq!(known, fresh_known);
    assert!(known.iter().filter(|&&k| k).count() < known_before, "the forgotten cells became unknown");
    assert_eq!(map.forget_disc(0.5, 0.5, 0.2), 0, "nothing left there");
    assert_eq!(map.forget_disc(f64::NAN, 0.5, 0.2), 0);
    assert_eq!(map.forget_disc(0.5, 0.5, -1.0), 0);
}

#[test]
fn bad_parameters_do_not_panic() {
    let pts = surface(|x, _| 0.1 * x);
    let p = TraversabilityParams {
        disc_radius_m: -1.0,
        max_slope_rad: 0.0,
        max_step_m: f64::NAN,
        max_roughness_m: 0.0,
        min_points: 0,
        tau: 2.0,
        step_relative_to_plane: true,
        min_spread_ratio: f64::NAN,
        noise_discount_sigmas: f64::NAN,
    };
    let layers = layers_of(&pts, &p);
    // Zero limits: any positive slope is fully hazardous.
    assert_eq!(at(&layers.hazard, Cell::new(10, 10)), 1.0);
    assert!(layers.score.data.iter().all(|s| s.is_nan() || (0.0..=1.0).contains(s)));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(24))]

    /// Insertion order does not change the layers (beyond rounding).
    #[test]
    fn insertion_order_does_not_matter(
        pts in proptest::collection::vec((0.0f64..0.5, 0.0f64..0.5, -0.1f64..0.1), 20..300),
        seed in any::<u64>(),
    ) {
        let g = GridGeometry::new(0.0, 0.0, RES, 10, 10);
        let p = TraversabilityParams::default();
        let pts: Vec<Point3<f64>> = pts.into_iter().map(|(x, y, z)| Point3::new(x, y, z)).collect();
        let mut shuffled = pts.clone();
        // Deterministic Fisher–Yates from the seed (a small LCG).
        let mut s = seed;
        for i in (1..shuffled.len()).rev() {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            shuffled.swap(i, ((s >> 33) % (i as u64 + 1)) as usize);
        }
        let mut a = TraversabilityMap::new(g).unwrap();
        a.insert_points(pts.iter().copied());
        let mut b = TraversabilityMap::new(g).unwrap();
        b.insert_points(shuffled.iter().copied());
        let (la, lb) = (a.compute(&p), b.compute(&p));
        prop_assert_eq!(&la.disc_points, &lb.disc_points);
        for (x, y) in [(&la.score, &lb.score), (&la.step_m, &lb.step_m), (&la.roughness_m, &lb.roughness_m)] {
            for (u, v) in x.data.iter().zip(&y.data) {
                prop_assert!(u.is_nan() == v.is_nan() && (u.is_nan() || (u - v).abs() < 1e-4), "{} vs {}", u, v);
            }
        }
    }
}

/// The straightforward estimate of one cell, as first written (and as notes §2 reads): gather
/// the disc's non-empty cells, fuse them one by one with [`CellMoments::merge`], fit, and take the
/// relative step over the gathered cells. The optimised path must agree with it to rounding.
/// Also returns whether the plane is well conditioned (λ_mid − λ_min ≥ 10⁻³ λ_max), i.e. whether
/// rounding-level differences in the moments can only move the estimate by rounding.
fn reference_estimate(map: &TraversabilityMap, p: &TraversabilityParams, index: usize) -> ([f64; 6], bool) {
    let g = map.geometry();
    let moments = map.moments();
    let (col, row) = ((index % g.width) as i32, (index / g.width) as i32);
    let cells: Vec<&CellMoments> = disc_offsets(p.disc_radius_m, g.resolution_m)
        .into_iter()
        .filter_map(|(dx, dy)| g.index(Cell::new(col + dx, row + dy)))
        .map(|j| &moments[j])
        .filter(|m| m.count > 0)
        .collect();
    let mut fused = CellMoments::EMPTY;
    for m in &cells {
        fused.merge(m);
    }
    let n = fused.count;
    let unknown = ([f64::NAN, f64::NAN, f64::NAN, f64::NAN, f64::NAN, n as f64], true);
    if n == 0 || n < u64::from(p.min_points) {
        return unknown;
    }
    let k = 1.0 / fused.count as f64;
    let (a, b, c) = (fused.scatter[0] * k, fused.scatter[1] * k, fused.scatter[3] * k);
    let lambda_xy = 0.5 * (a + c) - (0.25 * (a - c) * (a - c) + b * b).sqrt();
    let min_spread = p.min_spread_ratio * p.disc_radius_m;
    let spread = lambda_xy.max(0.0).sqrt();
    if min_spread > 0.0 && (spread.is_nan() || spread < min_spread) {
        return unknown;
    }
    let Some(plane) = fit_plane(&fused) else { return unknown };
    let raw = fused.z_max - fused.z_min;
    let mut step = raw;
    if p.step_relative_to_plane && plane.height_at(0.0, 0.0).is_some() {
        let (mut hi, mut lo) = (f64::NEG_INFINITY, f64::INFINITY);
        for m in &cells {
            let Some(z) = plane.height_at(m.mean[0], m.mean[1]) else { continue };
            hi = hi.max(m.z_max - z);
            lo = lo.min(m.z_min - z);
        }
        if hi >= lo {
            step = (hi - lo).min(raw);
        }
    }
    let ratio = |x: f64, limit: f64| {
        if limit > 0.0 {
            x / limit
        } else if x > 0.0 {
            1.0
        } else {
            0.0
        }
    };
    let hazard = ratio(plane.slope_rad, p.max_slope_rad)
        .max(ratio(step, p.max_step_m))
        .max(ratio(plane.roughness_m, p.max_roughness_m))
        .clamp(0.0, 1.0);
    let c = fused.covariance();
    let eig = nalgebra::SymmetricEigen::new(nalgebra::Matrix3::from_fn(|i, j| c[i][j])).eigenvalues;
    let (lo, mid, hi) = (eig.min(), eig.sum() - eig.min() - eig.max(), eig.max());
    ([plane.slope_rad, step, plane.roughness_m, hazard, 1.0 - hazard, fused.count as f64], mid - lo >= 1e-3 * hi)
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// The optimised estimate (disc sums kept up to date at insertion, lazy single-cell
    /// refreshes, row-major incremental update) agrees with the straightforward one to rounding on
    /// random clouds — tilted, stepped, noisy, sparse, partly outside the grid — and random
    /// parameters (where the plane is well conditioned; unknown-ness and counts always);
    /// `update` after random batches and refreshes equals `compute` bit for bit; and the known
    /// flags are exactly the cells whose score is not NaN.
    #[test]
    fn optimised_estimate_agrees_with_straightforward_reference(
        pts in proptest::collection::vec((-0.1f64..0.9, -0.1f64..0.9, -0.05f64..0.05), 1..600),
        tilt in (-0.6f64..0.6, -0.6f64..0.6),
        step_at in 0.0f64..0.8,
        step_m in prop_oneof![Just(0.0), 0.0f64..0.3],
        radius_cells in 0.5f64..4.5,
        relative in any::<bool>(),
        min_points in 0u32..20,
        min_spread_ratio in prop_oneof![Just(0.0), 0.0f64..0.4],
        split in 0usize..600,
        refresh in proptest::collection::vec(0usize..256, 0..20),
    ) {
        let g = GridGeometry::new(0.0, 0.0, RES, 16, 16);
        let p = TraversabilityParams {
            disc_radius_m: radius_cells * RES,
            step_relative_to_plane: relative,
            min_points,
            min_spread_ratio,
            ..TraversabilityParams::default()
        };
        let pts: Vec<Point3<f64>> = pts
            .into_iter()
            .map(|(x, y, n)| Point3::new(x, y, 2.0 + tilt.0 * x + tilt.1 * y + n + if x > step_at { step_m } else { 0.0 }))
            .collect();
        let mut map = TraversabilityMap::new(g).unwrap();
        let mut layers = map.compute(&p);
        let mut known = vec![false; g.len()];
        let (a, b) = pts.split_at(split.min(pts.len()));
        map.insert_points(a.iter().copied());
        map.update(&p, &mut layers);
        map.refresh_known(&p, |i, k| known[i] = k);
        map.insert_points(b.iter().copied());
        map.refresh_cells(refresh.iter().copied(), &p, &mut layers);
        map.refresh_known(&p, |i, k| known[i] = k);
        map.update(&p, &mut layers);
        let full = map.compute(&p);
        assert_same(&layers, &full);
        for (i, k) in known.iter().enumerate() {
            prop_assert_eq!(*k, !full.score.data[i].is_nan(), "cell {}", i);
        }
        let sums = map.discs.as_ref().unwrap();
        for i in 0..g.len() {
            let e = estimate::estimate_cell(sums, map.moments(), &g, i, &p);
            let got = [e.slope_rad, e.step_m, e.roughness_m, e.hazard, e.score, e.disc_points as f64];
            let (want, well_conditioned) = reference_estimate(&map, &p, i);
            prop_assert_eq!(got[5], want[5]);
            prop_assert_eq!(got[0].is_nan(), want[0].is_nan(), "cell {}: {:?} vs {:?}", i, got, want);
            if well_conditioned && !want[0].is_nan() {
                for (u, v) in got.iter().zip(want) {
                    prop_assert!((u - v).abs() <= 1e-7, "cell {}: {:?} vs {:?}", i, got, want);
                }
            }
        }
    }
}
