//! Keyframe clouds: the sensor points of every keyframe in its body frame, and the map rebuilt
//! from them after a loop closure moved the keyframes.

use nalgebra::{Matrix3, Matrix6, Point3, Vector3};
use std::collections::HashSet;

use crate::cache::prefetch;
use crate::grid::{Cell, GridGeometry};
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
    /// Which map cell each stored point falls in at its keyframe's registered pose
    /// ([`CellIndex`]); `None` until the first partial re-registration.
    index: Option<CellIndex>,
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

/// The stored points of each map cell: for every cell of one grid, the indices of the points
/// that fall in it at their keyframe's registered pose, in increasing (stored) order, so that a
/// cell is rebuilt from its own points, in the order a whole rebuild would insert them.
#[derive(Clone, Debug)]
struct CellIndex {
    geometry: GridGeometry,
    members: Vec<Vec<u32>>,
    /// Points `0..indexed` are in `members` (or outside the grid).
    indexed: usize,
    /// The point list of the last rebuild (its allocation, reused).
    scratch: Vec<u32>,
}

/// How many points ahead of its use a rebuild asks the cache for a point.
const GATHER_AHEAD: usize = 16;

impl KeyframeClouds {
    /// No keyframe yet.
    pub fn new(voxel_m: f64) -> Self {
        Self {
            voxel_m,
            points: Vec::new(),
            starts: Vec::new(),
            tilt_var_rad2: Vec::new(),
            index: None,
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

    /// The points stored before this index that fall in `cell` of `g` are forgotten (0: none).
    fn forgotten_before(&self, cell: Cell, g: &GridGeometry) -> usize {
        let (cx, cy) = g.center_of(cell);
        self.forgotten
            .iter()
            .filter(|f| math::hypot(cx - f.centre_m[0], cy - f.centre_m[1]) <= f.radius_m)
            .map(|f| f.before)
            .max()
            .unwrap_or(0)
    }

    /// Starts the cloud of a new keyframe (later points belong to it) whose roll/pitch variance
    /// is `tilt_var_rad2`.
    pub(crate) fn start_keyframe(&mut self, tilt_var_rad2: f64) {
        self.starts.push(self.points.len());
        self.tilt_var_rad2.push(tilt_var_rad2);
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

    /// Keyframe `k`'s stored points, `a..b` (empty when out of range).
    fn range_of(&self, k: usize) -> std::ops::Range<usize> {
        let Some(&a) = self.starts.get(k) else { return 0..0 };
        a..self.starts.get(k + 1).copied().unwrap_or(self.points.len())
    }

    /// Keyframe `k`'s points (empty when out of range).
    #[cfg(test)]
    pub(crate) fn points_of(&self, k: usize) -> &[[f32; 3]] {
        &self.points[self.range_of(k)]
    }

    /// The keyframe stored point `i` belongs to.
    fn keyframe_of(&self, i: usize) -> usize {
        self.starts.partition_point(|&s| s <= i).saturating_sub(1)
    }

    /// Takes the cell index on `g` (made anew if it was for another grid) out of the clouds, with
    /// every point stored since added at its keyframe's pose in `registered` (points of keyframes
    /// without one wait); the caller puts it back.
    fn take_index(&mut self, g: &GridGeometry, registered: &[Se3]) -> CellIndex {
        let mut index = match self.index.take() {
            Some(index) if index.geometry == *g => index,
            _ => CellIndex { geometry: *g, members: vec![Vec::new(); g.len()], indexed: 0, scratch: Vec::new() },
        };
        let end = self.starts.get(registered.len()).copied().unwrap_or(self.points.len());
        while index.indexed < end {
            let k = self.keyframe_of(index.indexed);
            let (r, t) = (registered[k].rotation_matrix(), registered[k].translation);
            let to = self.range_of(k).end.min(end);
            for i in index.indexed..to {
                if let Some(c) = cell_index(g, &r, &t, &self.points[i]) {
                    index.members[c].push(point_id(i));
                }
            }
            index.indexed = to;
        }
        index
    }
}

/// The stored point index `i` as the index's u32 (a cloud of 2³² points would be 48 GB).
fn point_id(i: usize) -> u32 {
    debug_assert!(u32::try_from(i).is_ok());
    i as u32
}

/// The flat index of the cell of `g` holding body point `p` registered with rotation `r` and
/// translation `t`, if inside.
#[inline]
fn cell_index(g: &GridGeometry, r: &Matrix3<f64>, t: &Vector3<f64>, p: &[f32; 3]) -> Option<usize> {
    let w = r * Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2])) + t;
    g.cell_of(w.x, w.y).and_then(|c| g.index(c))
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
    let points = world_from_keyframe.iter().enumerate().take(clouds.keyframes()).flat_map(|(k, pose)| {
        let (r, t) = (pose.rotation_matrix(), pose.translation);
        clouds.range_of(k).filter_map(move |i| {
            let q = Vector3::new(f64::from(clouds.points[i][0]), f64::from(clouds.points[i][1]), f64::from(clouds.points[i][2]));
            let w = r * q + t;
            let forgotten = g.cell_of(w.x, w.y).is_some_and(|c| i < clouds.forgotten_before(c, &g));
            (!forgotten).then(|| (Point3::from(w), height_variance(clouds.tilt_var_rad2[k], &q)))
        })
    });
    map.insert_points_with_variance(points).inserted
}

/// Re-registers the keyframes that moved: every keyframe k for which `moved(registered[k],
/// now[k])` holds takes its pose `now[k]`; the map cells its points fall in, at the old pose
/// and at the new one, are rebuilt from the points each holds at their keyframes' registered
/// poses ([`TraversabilityMap::rebuild_cells`]), so that they hold what a rebuild of the whole
/// map would give them; the other cells keep theirs. The clouds' cell index says which points
/// each rebuilt cell holds, so only those are read. Returns how many keyframes moved.
/// O(points stored since the last call + moved points · cell occupancy + points in the rebuilt
/// cells + rebuilt cells × disc²).
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
    let mut index = clouds.take_index(&g, &registered[..n]);
    let mut cells: Vec<u32> = Vec::new();
    for &k in &moving {
        let (r0, t0) = (registered[k].rotation_matrix(), registered[k].translation);
        let (r1, t1) = (now[k].rotation_matrix(), now[k].translation);
        for i in clouds.range_of(k) {
            let p = &clouds.points[i];
            let (from, to) = (cell_index(&g, &r0, &t0, p), cell_index(&g, &r1, &t1, p));
            if from == to {
                cells.extend(from.map(|c| c as u32));
                continue;
            }
            cells.extend(from.into_iter().chain(to).map(|c| c as u32));
            let id = point_id(i);
            if let Some(list) = from.map(|c| &mut index.members[c])
                && let Ok(at) = list.binary_search(&id)
            {
                list.remove(at);
            }
            if let Some(list) = to.map(|c| &mut index.members[c])
                && let Err(at) = list.binary_search(&id)
            {
                list.insert(at, id);
            }
        }
        registered[k] = now[k];
    }
    cells.sort_unstable();
    cells.dedup();
    let rotations: Vec<Matrix3<f64>> = registered[..n].iter().map(Se3::rotation_matrix).collect();
    // The rebuilt cells' points, cell by cell, each cell's in stored order, less the forgotten.
    let mut ids = std::mem::take(&mut index.scratch);
    ids.clear();
    for &c in &cells {
        let c = c as usize;
        let forgotten = clouds.forgotten_before(Cell::new((c % g.width) as i32, (c / g.width) as i32), &g);
        let list = &index.members[c];
        ids.extend_from_slice(&list[list.partition_point(|&i| (i as usize) < forgotten)..]);
    }
    let clouds_ref = &*clouds;
    let points = ids.iter().enumerate().map(|(j, &i)| {
        // The points are spread over the whole store: ask for one a few reads ahead.
        if let Some(&ahead) = ids.get(j + GATHER_AHEAD) {
            prefetch(&clouds_ref.points[ahead as usize]);
        }
        let (i, k) = (i as usize, clouds_ref.keyframe_of(i as usize));
        let p = &clouds_ref.points[i];
        let q = Vector3::new(f64::from(p[0]), f64::from(p[1]), f64::from(p[2]));
        (Point3::from(rotations[k] * q + registered[k].translation), height_variance(clouds_ref.tilt_var_rad2[k], &q))
    });
    map.rebuild_cells(&cells, points);
    index.scratch = ids;
    clouds.index = Some(index);
    moving.len()
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
