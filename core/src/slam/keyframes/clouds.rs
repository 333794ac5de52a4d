//! Keyframe clouds: the sensor points of every keyframe in its body frame, and the map rebuilt
//! from them after a loop closure moved the keyframes.

use nalgebra::{Matrix6, Point3, Vector3};
use std::collections::HashSet;

use crate::grid::GridGeometry;
use crate::math;
use crate::slam::Se3;
use crate::traversability::TraversabilityMap;

/// Sensor points of every keyframe, in that keyframe's body frame (f32, flat), one per voxel
/// per keyframe.
#[derive(Clone, Debug)]
pub struct KeyframeClouds {
    voxel_m: f64,
    points: Vec<[f32; 3]>,
    /// Keyframe k's points are `starts[k]..starts[k + 1]` (the last one runs to the end).
    starts: Vec<usize>,
    /// Keyframe k's roll/pitch variance, rad² (for the points' height noise at re-registration).
    tilt_var_rad2: Vec<f64>,
    /// Keyframe k's points ordered by the map block they fall in at its registered pose, as
    /// runs ([`Self::index_keyframe`]); empty while not indexed.
    runs: Vec<Vec<Run>>,
    /// Voxels already holding a point of the latest keyframe (membership only, never iterated).
    occupied: HashSet<[i32; 3]>,
    /// Discs whose points stored before them [`reregister`] leaves out ([`Self::forget_disc`]).
    forgotten: Vec<ForgottenDisc>,
}

/// Points stored before `before` whose map cell's centre lies within `radius_m` of `centre_m`
/// (world frame) are forgotten.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ForgottenDisc {
    centre_m: [f64; 2],
    radius_m: f64,
    before: usize,
}

impl KeyframeClouds {
    /// No keyframe yet.
    pub fn new(voxel_m: f64) -> Self {
        Self {
            voxel_m,
            points: Vec::new(),
            starts: Vec::new(),
            tilt_var_rad2: Vec::new(),
            runs: Vec::new(),
            occupied: HashSet::new(),
            forgotten: Vec::new(),
        }
    }

    /// Forgets, for every later `reregister`, the points stored so far that it would put in a
    /// map cell whose centre lies within `radius_m` of (`x_m`, `y_m`), world frame (as
    /// [`TraversabilityMap::forget_disc`] does to the map itself). Points stored later are kept.
    pub fn forget_disc(&mut self, x_m: f64, y_m: f64, radius_m: f64) {
        self.forgotten.push(ForgottenDisc { centre_m: [x_m, y_m], radius_m, before: self.points.len() });
    }

    /// Whether the stored point `index`, registered at world (`x_m`, `y_m`), is forgotten on the
    /// grid `g`.
    fn is_forgotten(&self, index: usize, x_m: f64, y_m: f64, g: &GridGeometry) -> bool {
        // Most points (every one before the first recovery) are older than no disc: no cell lookup.
        if !self.forgotten.iter().any(|f| index < f.before) {
            return false;
        }
        let Some(c) = g.cell_of(x_m, y_m) else { return false };
        let (cx, cy) = g.center_of(c);
        self.forgotten.iter().any(|f| index < f.before && math::hypot(cx - f.centre_m[0], cy - f.centre_m[1]) <= f.radius_m)
    }

    /// Starts the cloud of a new keyframe (later points belong to it) whose roll/pitch variance
    /// is `tilt_var_rad2`.
    pub(crate) fn start_keyframe(&mut self, tilt_var_rad2: f64) {
        self.starts.push(self.points.len());
        self.tilt_var_rad2.push(tilt_var_rad2);
        self.runs.push(Vec::new());
        self.occupied.clear();
    }

    /// Stores a point of the latest keyframe (its body frame) unless its voxel already has one
    /// or there is no keyframe; returns whether it was stored.
    pub fn push(&mut self, point_in_keyframe: &Vector3<f64>) -> bool {
        if self.starts.is_empty() || !point_in_keyframe.iter().all(|v| v.is_finite()) {
            return false;
        }
        let key = point_in_keyframe.map(|v| (v / self.voxel_m).floor().clamp(i32::MIN as f64, i32::MAX as f64) as i32);
        if !self.occupied.insert([key.x, key.y, key.z]) {
            return false;
        }
        self.points.push([point_in_keyframe.x as f32, point_in_keyframe.y as f32, point_in_keyframe.z as f32]);
        true
    }

    /// Number of keyframes started.
    pub fn keyframes(&self) -> usize {
        self.starts.len()
    }

    /// Points stored over all keyframes.
    pub fn len(&self) -> usize {
        self.points.len()
    }

    /// Whether no point is stored.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// Orders keyframe `k`'s points by the block of `g` ([`BLOCK_CELLS`]²) each falls in when
    /// registered at `pose`, and records the runs, so that a partial re-registration reads only
    /// the runs of the blocks it rebuilds. Points keep their side of every forgotten disc's
    /// boundary (each stretch between two boundaries is ordered on its own); the order within a
    /// block is the stored order. The latest keyframe, still filling, is never indexed.
    fn index_keyframe(&mut self, k: usize, pose: &Se3, g: &GridGeometry) {
        if k + 1 >= self.keyframes() {
            return;
        }
        let (a, b) = (self.starts[k], self.starts[k + 1]);
        let (r, t) = (pose.rotation_matrix(), pose.translation);
        let blocks_per_row = g.width.div_ceil(BLOCK_CELLS);
        let block_of = |p: &[f32; 3]| {
            let w = r * Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])) + t;
            g.cell_of(w.x, w.y).map_or(u32::MAX, |c| {
                let (col, row) = (c.col as usize / BLOCK_CELLS, c.row as usize / BLOCK_CELLS);
                (row * blocks_per_row + col) as u32
            })
        };
        let mut bounds: Vec<usize> = self.forgotten.iter().map(|f| f.before).filter(|&x| x > a && x < b).collect();
        bounds.extend([a, b]);
        bounds.sort_unstable();
        bounds.dedup();
        let mut runs = Vec::new();
        for w in bounds.windows(2) {
            let (lo, hi) = (w[0], w[1]);
            let mut keyed: Vec<(u32, [f32; 3])> = self.points[lo..hi].iter().map(|p| (block_of(p), *p)).collect();
            keyed.sort_by_key(|e| e.0); // stable: the stored order within a block
            for (j, (block, p)) in keyed.iter().enumerate() {
                self.points[lo + j] = *p;
                match runs.last_mut() {
                    Some(Run { block: last, end, .. }) if *last == *block && *end == lo + j => *end += 1,
                    _ => runs.push(Run { block: *block, start: lo + j, end: lo + j + 1 }),
                }
            }
        }
        self.runs[k] = runs;
    }

    /// The stored ranges of keyframe `k`'s points that can fall in a block `blocks` flags (all
    /// of them while `k` is not indexed), in stored order.
    fn ranges_in(&self, k: usize, blocks: Option<&RegionBlocks>) -> Vec<(usize, usize)> {
        let whole = || vec![(self.starts[k], self.starts.get(k + 1).copied().unwrap_or(self.points.len()))];
        match blocks {
            Some(bl) if !self.runs[k].is_empty() => self.runs[k].iter().filter(|r| bl.has(r.block)).map(|r| (r.start, r.end)).collect(),
            _ => whole(),
        }
    }

    /// Keyframe `k`'s points (empty when out of range).
    pub(crate) fn points_of(&self, k: usize) -> &[[f32; 3]] {
        let Some(&a) = self.starts.get(k) else { return &[] };
        let b = self.starts.get(k + 1).copied().unwrap_or(self.points.len());
        &self.points[a..b]
    }
}

/// Rebuilds `map` from every keyframe cloud registered with `world_from_keyframe`, less the
/// forgotten points ([`KeyframeClouds::forget_disc`]) (keyframes beyond the shorter of the two
/// are skipped), each point with its height noise ([`height_variance`]); the next `update`
/// recomputes every cell. Returns the number of points inserted. O(points). The reference
/// [`reregister_moved`] is tested against.
#[cfg(test)]
pub(crate) fn reregister(map: &mut TraversabilityMap, clouds: &KeyframeClouds, world_from_keyframe: &[Se3]) -> usize {
    map.clear();
    let g = map.geometry();
    map.insert_points_with_variance(registered_points(clouds, world_from_keyframe, &g, None)).inserted
}

/// Re-registers the keyframes that moved: every keyframe k for which `moved(registered[k],
/// now[k])` holds takes its pose `now[k]`; the map cells its points fall in, at the old pose
/// and at the new one, are rebuilt from every keyframe's points at its registered pose
/// ([`TraversabilityMap::rebuild_cells`]), so that they hold what a rebuild of the whole map
/// would give them; the other cells keep theirs. Only the runs of the blocks holding a rebuilt
/// cell are read ([`KeyframeClouds::index_keyframe`]). Returns how many keyframes moved.
/// O(moved points · log + points in the rebuilt blocks + runs + rebuilt cells × disc²).
pub(crate) fn reregister_moved(
    map: &mut TraversabilityMap,
    clouds: &mut KeyframeClouds,
    registered: &mut [Se3],
    now: &[Se3],
    moved: impl Fn(&Se3, &Se3) -> bool,
) -> usize {
    let g = map.geometry();
    let n = registered.len().min(now.len()).min(clouds.keyframes());
    let moving: Vec<usize> = (0..n).filter(|&k| moved(&registered[k], &now[k])).collect();
    if moving.is_empty() {
        return 0;
    }
    let mut cells: Vec<u32> = Vec::new();
    for &k in &moving {
        for pose in [registered[k], now[k]] {
            let (r, t) = (pose.rotation_matrix(), pose.translation);
            cells.extend(clouds.points_of(k).iter().filter_map(|p| {
                let w = r * Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])) + t;
                g.cell_of(w.x, w.y).and_then(|c| g.index(c)).map(|i| i as u32)
            }));
        }
        registered[k] = now[k];
        clouds.index_keyframe(k, &now[k], &g);
    }
    for (k, pose) in registered.iter().enumerate().take(n) {
        if clouds.runs[k].is_empty() && !clouds.points_of(k).is_empty() {
            clouds.index_keyframe(k, pose, &g);
        }
    }
    cells.sort_unstable();
    cells.dedup();
    let blocks = RegionBlocks::new(&g, &cells);
    map.rebuild_cells(&cells, registered_points(clouds, registered, &g, Some(&blocks)));
    moving.len()
}

/// Edge of the blocks a keyframe's points are ordered by, cells.
const BLOCK_CELLS: usize = 16;

/// One stretch of a keyframe's stored points in one block (`u32::MAX`: outside the grid).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Run {
    block: u32,
    start: usize,
    end: usize,
}

/// The blocks of `BLOCK_CELLS` × `BLOCK_CELLS` cells holding at least one cell of a region.
struct RegionBlocks {
    flags: Vec<bool>,
}

impl RegionBlocks {
    fn new(g: &GridGeometry, cells: &[u32]) -> Self {
        let cols = g.width.div_ceil(BLOCK_CELLS);
        let mut flags = vec![false; cols * g.height.div_ceil(BLOCK_CELLS)];
        for &c in cells {
            let (col, row) = (c as usize % g.width, c as usize / g.width);
            flags[row / BLOCK_CELLS * cols + col / BLOCK_CELLS] = true;
        }
        Self { flags }
    }

    fn has(&self, block: u32) -> bool {
        self.flags.get(block as usize).copied().unwrap_or(false)
    }
}

/// Every stored point registered with its keyframe's pose in `world_from_keyframe` (keyframes
/// beyond the shorter of the two skipped), less the forgotten ones, with its height variance;
/// with `blocks`, only the runs that can fall in a flagged block. In stored order.
fn registered_points<'a>(
    clouds: &'a KeyframeClouds,
    world_from_keyframe: &'a [Se3],
    g: &'a GridGeometry,
    blocks: Option<&'a RegionBlocks>,
) -> impl Iterator<Item = (Point3<f64>, f64)> + 'a {
    world_from_keyframe.iter().enumerate().take(clouds.keyframes()).flat_map(move |(k, pose)| {
        let r = pose.rotation_matrix();
        let t = pose.translation;
        let tilt_var = clouds.tilt_var_rad2[k];
        clouds.ranges_in(k, blocks).into_iter().flat_map(move |(lo, hi)| {
            clouds.points[lo..hi].iter().enumerate().filter_map(move |(j, p)| {
                let q = Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
                let w = r * q + t;
                (!clouds.is_forgotten(lo + j, w.x, w.y, g)).then(|| (Point3::from(w), height_variance(tilt_var, &q)))
            })
        })
    })
}

/// Variance of a registered point's height from the pose's tilt uncertainty, m²: a small roll /
/// pitch error δφ moves the point `b` (body frame) by δφ × b, whose vertical part has variance
/// σ_t²·(b_x² + b_y²) for isotropic roll/pitch variance σ_t². (The pose's own height error is
/// common to the whole scan and left out: it shifts a scan, it does not make it rough.)
pub(crate) fn height_variance(tilt_var_rad2: f64, point_in_body: &Vector3<f64>) -> f64 {
    tilt_var_rad2 * (point_in_body.x * point_in_body.x + point_in_body.y * point_in_body.y)
}

/// Mean roll/pitch variance of a 6×6 body-frame covariance (ξ = (δt, δφ)), rad².
pub(super) fn tilt_variance(cov: &Matrix6<f64>) -> f64 {
    (0.5 * (cov[(3, 3)] + cov[(4, 4)])).max(0.0)
}
