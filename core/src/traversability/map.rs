//! The traversability map's moments layer: registered 3D points binned into grid cells.
//!
//! Notes §2: points from LiDAR scans registered in the world are binned into a grid; each cell
//! keeps its [`CellMoments`]. Insertion is O(1) per point and allocation-free; the map does **not
//! grow**: points outside the geometry (or non-finite) are ignored and counted in the returned
//! [`InsertStats`]. Size the map up front ([`TraversabilityMap::from_cloud`] sizes it to a
//! cloud's extent plus a margin). [`TraversabilityMap::clear`] empties it for re-registration
//! after the SLAM graph is re-optimised. Once a disc radius is known (the first update), every
//! point also joins the [`DiscSums`] of the cells whose disc holds it, and those cells are marked
//! stale, so that [`TraversabilityMap::update`] recomputes only them, a few cells can be refreshed
//! on their own ([`TraversabilityMap::refresh_cells`]) and the known cells can be counted without
//! estimating anything ([`TraversabilityMap::refresh_known`]).
//!
//! Precision: moments are stored relative to a per-map local origin — (x, y) of the grid's
//! lower-left corner and z of the first point ever inserted — so UTM-sized coordinates lose
//! nothing.

use nalgebra::Point3;

use super::TraversabilityError;
use super::disc_sums::{DiscSum, DiscSums};
use super::moments::CellMoments;
use crate::cache::prefetch;
use crate::cloud::PointCloud;
use crate::grid::{GridGeometry, MAX_CELLS};
use crate::params::Params;

/// Points binned per chunk by [`TraversabilityMap::insert_points_with_variance`].
const INSERT_CHUNK: usize = 64;
/// How many points ahead of its update a point's cells are prefetched (a DRAM latency is about
/// the time of that many insertions).
const INSERT_AHEAD: usize = 6;
/// How many cells ahead of its visit [`StaleCells::drain_in_order`] offers a cell for prefetching.
pub(super) const DRAIN_AHEAD: usize = 16;

/// What happened to the points given to [`TraversabilityMap::insert_points`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct InsertStats {
    /// Points binned into a cell.
    pub inserted: usize,
    /// Points outside the grid or with a non-finite coordinate.
    pub ignored: usize,
}

/// Geometry + per-cell moments of the registered points (flat, row-major).
#[derive(Clone, Debug)]
pub struct TraversabilityMap {
    pub(super) geometry: GridGeometry,
    /// Local origin z, metres; set by the first inserted point.
    pub(super) z_origin_m: Option<f64>,
    pub(super) moments: Vec<CellMoments>,
    /// Per-cell disc sums for one disc radius; `None` until the first estimate and after
    /// [`TraversabilityMap::clear`] (then built from `moments`).
    pub(super) discs: Option<DiscSums>,
    /// The allocation of the disc sums last dropped, reused by the next build (empty otherwise).
    disc_buffer: Vec<DiscSum>,
    /// Cells whose disc changed since their last estimate.
    pub(super) stale_estimate: StaleCells,
    /// Cells whose disc changed since their last known-check, and the known flags.
    pub(super) stale_known: StaleCells,
    pub(super) known: Vec<bool>,
    /// (disc radius, min_points, min_spread_ratio) the known flags were computed with.
    pub(super) known_with: Option<(u64, u32, u64)>,
    /// Scratch flags of [`Self::rebuild_cells`] (empty until used; all false between calls).
    region: Vec<bool>,
    around: Vec<bool>,
}

/// A set of cells — a flag per cell and the list of flagged ones, in marking order — or all.
#[derive(Clone, Debug)]
pub(super) struct StaleCells {
    pub(super) flag: Vec<bool>,
    pub(super) list: Vec<u32>,
    pub(super) all: bool,
}

impl StaleCells {
    fn new(cells: usize) -> Self {
        Self { flag: vec![false; cells], list: Vec::new(), all: true }
    }

    #[inline]
    fn mark(&mut self, i: usize) {
        if !self.all && !self.flag[i] {
            self.flag[i] = true;
            self.list.push(i as u32);
        }
    }

    pub(super) fn mark_all(&mut self) {
        self.clear();
        self.all = true;
    }

    pub(super) fn clear(&mut self) {
        for &i in &self.list {
            self.flag[i as usize] = false;
        }
        self.list.clear();
        self.all = false;
    }

    /// Calls `f` once with every flagged cell, in increasing (row-major) order, so that
    /// neighbouring discs share cache lines, and empties the set (`all` is the caller's to handle
    /// first); before `f` sees a cell, `ahead` sees the cell [`DRAIN_AHEAD`] places later (for
    /// prefetching). A cell unflagged since it was listed is skipped. Sorts the list when it is
    /// short, else scans the flags 64 at a time: O(min(k log k, cells / 64 + k)) for k listed cells.
    pub(super) fn drain_in_order(&mut self, mut ahead: impl FnMut(usize), mut f: impl FnMut(usize)) {
        let flag = &mut self.flag;
        if self.list.len() * 64 < flag.len() {
            self.list.sort_unstable();
            // Unflags as it goes, so a cell listed twice stays once.
            self.list.retain(|&i| std::mem::take(&mut flag[i as usize]));
        } else {
            self.list.clear();
            for (k, chunk) in flag.chunks_mut(64).enumerate() {
                // A branch-free OR over the chunk (vectorised), then the flagged cells.
                if chunk.iter().fold(false, |any, &b| any | b) {
                    for (j, b) in chunk.iter_mut().enumerate() {
                        if std::mem::take(b) {
                            self.list.push((k * 64 + j) as u32);
                        }
                    }
                }
            }
        }
        for &i in self.list.iter().take(DRAIN_AHEAD) {
            ahead(i as usize);
        }
        for (k, &i) in self.list.iter().enumerate() {
            if let Some(&a) = self.list.get(k + DRAIN_AHEAD) {
                ahead(a as usize);
            }
            f(i as usize);
        }
        self.list.clear();
        self.all = false;
    }
}

impl TraversabilityMap {
    /// An empty map over `geometry`.
    pub fn new(geometry: GridGeometry) -> Result<Self, TraversabilityError> {
        let finite = geometry.origin_x_m.is_finite() && geometry.origin_y_m.is_finite();
        if !finite || !geometry.resolution_m.is_finite() || geometry.resolution_m <= 0.0 {
            return Err(TraversabilityError::BadGeometry);
        }
        let cells = geometry.width.checked_mul(geometry.height).filter(|&n| n <= MAX_CELLS && n <= u32::MAX as usize);
        let Some(cells) = cells else {
            return Err(TraversabilityError::TooManyCells { width: geometry.width, height: geometry.height, limit: MAX_CELLS });
        };
        Ok(Self {
            geometry,
            z_origin_m: None,
            moments: vec![CellMoments::EMPTY; cells],
            discs: None,
            disc_buffer: Vec::new(),
            stale_estimate: StaleCells::new(cells),
            stale_known: StaleCells::new(cells),
            known: vec![false; cells],
            known_with: None,
            region: Vec::new(),
            around: Vec::new(),
        })
    }

    /// A map sized to the finite points of `cloud` plus a margin of
    /// `traversability.disc_radius_m + robot.radius_m` (rounded up to whole cells, plus one) on
    /// every side, at `grid.resolution_m`, with the cloud's points inserted.
    pub fn from_cloud(cloud: &PointCloud, params: &Params) -> Result<Self, TraversabilityError> {
        let res = params.grid.resolution_m;
        if !(res.is_finite() && res > 0.0) {
            return Err(TraversabilityError::BadGeometry);
        }
        let (mut lo_x, mut lo_y, mut hi_x, mut hi_y) = (f64::INFINITY, f64::INFINITY, f64::NEG_INFINITY, f64::NEG_INFINITY);
        for p in cloud.points.iter().filter(|p| p.coords.iter().all(|v| v.is_finite())) {
            lo_x = lo_x.min(p.x);
            lo_y = lo_y.min(p.y);
            hi_x = hi_x.max(p.x);
            hi_y = hi_y.max(p.y);
        }
        if lo_x > hi_x {
            return Err(TraversabilityError::EmptyCloud);
        }
        let margin_m = params.traversability.disc_radius_m.max(0.0) + params.robot.radius_m.max(0.0);
        // The small tolerance keeps an exact multiple (0.4 m / 0.1 m) from rounding up a whole cell.
        let margin_cells = (margin_m / res - 1e-9).ceil().max(0.0) + 1.0;
        let span = |lo: f64, hi: f64| ((hi - lo) / res).floor() + 1.0 + 2.0 * margin_cells;
        let (w, h) = (span(lo_x, hi_x), span(lo_y, hi_y));
        let too_many = || TraversabilityError::TooManyCells {
            width: if w.is_finite() { w as usize } else { usize::MAX },
            height: if h.is_finite() { h as usize } else { usize::MAX },
            limit: MAX_CELLS,
        };
        if !(w.is_finite() && h.is_finite()) || w * h > MAX_CELLS as f64 {
            return Err(too_many());
        }
        let geometry = GridGeometry::new(lo_x - margin_cells * res, lo_y - margin_cells * res, res, w as usize, h as usize);
        let mut map = Self::new(geometry)?;
        map.insert_points(cloud.points.iter().copied());
        Ok(map)
    }

    /// The grid geometry shared by every layer.
    pub fn geometry(&self) -> GridGeometry {
        self.geometry
    }

    #[cfg(test)]
    /// The local origin (x, y, z) the moments are relative to, metres (z is 0 before the first
    /// point).
    pub(crate) fn local_origin_m(&self) -> [f64; 3] {
        [self.geometry.origin_x_m, self.geometry.origin_y_m, self.z_origin_m.unwrap_or(0.0)]
    }

    #[cfg(test)]
    /// Per-cell moments, row-major, relative to [`Self::local_origin_m`].
    pub(crate) fn moments(&self) -> &[CellMoments] {
        &self.moments
    }

    /// Total number of points binned.
    pub fn point_count(&self) -> u64 {
        self.moments.iter().map(|m| m.count).sum()
    }

    /// Bins world points (metres) into their cells and, once the map has disc sums, into the
    /// discs that hold them. O(disc cells) per point, no allocation beyond the stale lists'
    /// amortised growth. Points outside the grid or non-finite are ignored.
    pub fn insert_points<I: IntoIterator<Item = Point3<f64>>>(&mut self, world_points: I) -> InsertStats {
        self.insert_points_with_variance(world_points.into_iter().map(|p| (p, 0.0)))
    }

    /// As [`Self::insert_points`], each point with the variance of its height's registration
    /// noise, m² (e.g. a SLAM pose's tilt uncertainty times the squared range): the hazard
    /// discounts the roughness and step that noise explains
    /// ([`crate::params::TraversabilityParams::noise_discount_sigmas`]). A negative or
    /// non-finite variance counts as 0.
    pub fn insert_points_with_variance<I: IntoIterator<Item = (Point3<f64>, f64)>>(&mut self, world_points: I) -> InsertStats {
        let mut stats = InsertStats::default();
        let g = self.geometry;
        // Points are binned a chunk at a time so that each point's cells can be prefetched
        // `INSERT_AHEAD` points before they are updated (in the input order: the sums are the
        // same, bit for bit).
        let mut chunk = [(0usize, [0.0f64; 3], 0.0f64); INSERT_CHUNK];
        let mut points = world_points.into_iter();
        loop {
            let mut n = 0;
            for (p, var_m2) in points.by_ref() {
                let var_m2 = if var_m2.is_finite() { var_m2.max(0.0) } else { 0.0 };
                if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
                    stats.ignored += 1;
                    continue;
                }
                let Some(i) = g.cell_of(p.x, p.y).and_then(|c| g.index(c)) else {
                    stats.ignored += 1;
                    continue;
                };
                let z0 = *self.z_origin_m.get_or_insert(p.z);
                chunk[n] = (i, [p.x - g.origin_x_m, p.y - g.origin_y_m, p.z - z0], var_m2);
                n += 1;
                if n == INSERT_CHUNK {
                    break;
                }
            }
            if n == 0 {
                return stats;
            }
            let chunk = &chunk[..n];
            for &(i, _, _) in chunk.iter().take(INSERT_AHEAD) {
                self.prefetch_cell(i);
            }
            for (k, &(i, q, var_m2)) in chunk.iter().enumerate() {
                if let Some(&(ahead, _, _)) = chunk.get(k + INSERT_AHEAD) {
                    self.prefetch_cell(ahead);
                }
                self.moments[i].add_with_variance(q, var_m2);
                if let Some(d) = self.discs.as_mut() {
                    let (se, sk) = (&mut self.stale_estimate, &mut self.stale_known);
                    d.add_point(&g, i, q, var_m2, |c| {
                        se.mark(c);
                        sk.mark(c);
                    });
                }
            }
            stats.inserted += n;
        }
    }

    /// Prefetches what inserting a point of cell `index` updates: its moments and its disc's sums.
    #[inline]
    fn prefetch_cell(&self, index: usize) {
        let m = &self.moments[index];
        prefetch(m);
        prefetch(&m.scatter[3]);
        prefetch(&m.var_sum_m2);
        if let Some(d) = &self.discs {
            d.prefetch_disc(index);
        }
    }

    /// Re-registers part of the map: empties the moments of `cells` (each listed once), bins
    /// into them the points of `world_points` that fall in one of them (the others are
    /// skipped), and recomputes the disc sums of every cell whose disc meets them; those become
    /// stale. Each rebuilt cell then holds what [`Self::clear`] and inserting the same points
    /// would give it, bit for bit. O(points + |cells| × disc cells²).
    pub fn rebuild_cells<I: IntoIterator<Item = (Point3<f64>, f64)>>(&mut self, cells: &[u32], world_points: I) -> InsertStats {
        let g = self.geometry;
        self.region.resize(g.len(), false);
        let cells: Vec<u32> = cells.iter().copied().filter(|&c| (c as usize) < g.len()).collect();
        for &c in &cells {
            self.region[c as usize] = true;
            self.moments[c as usize] = CellMoments::EMPTY;
        }
        let mut stats = InsertStats::default();
        for (p, var_m2) in world_points {
            let var_m2 = if var_m2.is_finite() { var_m2.max(0.0) } else { 0.0 };
            let cell =
                (p.x.is_finite() && p.y.is_finite() && p.z.is_finite()).then(|| g.cell_of(p.x, p.y).and_then(|c| g.index(c))).flatten();
            let Some(i) = cell.filter(|&i| self.region[i]) else {
                stats.ignored += 1;
                continue;
            };
            let z0 = *self.z_origin_m.get_or_insert(p.z);
            self.moments[i].add_with_variance([p.x - g.origin_x_m, p.y - g.origin_y_m, p.z - z0], var_m2);
            stats.inserted += 1;
        }
        for &c in &cells {
            self.region[c as usize] = false;
        }
        if let Some(d) = self.discs.as_mut() {
            let (se, sk) = (&mut self.stale_estimate, &mut self.stale_known);
            d.rebuild_around(&g, &self.moments, &cells, &mut self.around, |c| {
                se.mark(c);
                sk.mark(c);
            });
        }
        stats
    }

    /// Removes every point (e.g. before re-registering all scans after a loop closure). Keeps
    /// the geometry and the local origin; the next [`Self::update`] recomputes everything.
    pub fn clear(&mut self) {
        self.moments.fill(CellMoments::EMPTY);
        self.drop_discs();
    }

    /// Forgets the points of every cell whose centre lies within `radius_m` of (`x_m`, `y_m`)
    /// (a clear-costmap recovery: mapped again by the next scans). The disc sums are rebuilt from
    /// the moments at the next estimate and every cell is re-estimated. Returns the number of
    /// points forgotten. O(radius² / resolution²), plus the rebuild if any point went.
    pub fn forget_disc(&mut self, x_m: f64, y_m: f64, radius_m: f64) -> u64 {
        let g = self.geometry;
        let mut forgotten = 0;
        for (i, _) in crate::grid::cells_in_disc(&g, x_m, y_m, radius_m) {
            forgotten += self.moments[i].count;
            self.moments[i] = CellMoments::EMPTY;
        }
        if forgotten > 0 {
            self.drop_discs();
        }
        forgotten
    }

    /// Drops the disc sums after points were removed (they are rebuilt from the moments at the
    /// next estimate) and makes every cell stale.
    fn drop_discs(&mut self) {
        if let Some(d) = self.discs.take() {
            self.disc_buffer = d.sums;
        }
        self.stale_estimate.mark_all();
        self.stale_known.mark_all();
    }

    /// Builds the disc sums for `radius_m` from the cell moments unless the map has them; a
    /// rebuild makes every cell stale. O(cells × disc cells) when building, else O(1).
    pub(super) fn ensure_discs(&mut self, radius_m: f64) {
        if self.discs.as_ref().is_some_and(|d| d.radius_m.to_bits() == radius_m.to_bits()) {
            return;
        }
        let buffer = match self.discs.take() {
            Some(d) => d.sums,
            None => std::mem::take(&mut self.disc_buffer),
        };
        self.discs = Some(DiscSums::from_moments_in(radius_m, &self.geometry, &self.moments, buffer));
        self.stale_estimate.mark_all();
        self.stale_known.mark_all();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::Cell;
    use proptest::prelude::*;

    proptest! {
        /// Whichever way it orders them (a sorted short list, or a scan of the flags for a long
        /// one), the drain visits exactly the still-flagged cells once each, in increasing order,
        /// and leaves the set empty.
        #[test]
        fn drain_visits_the_flagged_cells_once_in_order(
            cells in 1usize..700,
            marks in proptest::collection::vec(0usize..700, 0..400),
            unflag in proptest::collection::vec(0usize..700, 0..40),
        ) {
            let mut s = StaleCells::new(cells);
            s.clear();
            for &m in &marks {
                s.mark(m % cells);
            }
            for &u in &unflag {
                s.flag[u % cells] = false;
            }
            let mut want: Vec<usize> = (0..cells).filter(|&i| s.flag[i]).collect();
            want.dedup();
            let (mut got, mut offered) = (Vec::new(), Vec::new());
            s.drain_in_order(|i| offered.push(i), |i| got.push(i));
            prop_assert_eq!(&got, &want);
            // Each cell is offered for prefetching once, DRAIN_AHEAD visits early at most.
            prop_assert_eq!(offered, want);
            prop_assert!(s.list.is_empty() && !s.all && s.flag.iter().all(|&f| !f));
        }
    }

    #[test]
    fn points_are_binned_relative_to_the_local_origin() {
        let g = GridGeometry::new(500_000.0, 4_000_000.0, 0.5, 4, 3);
        let mut m = TraversabilityMap::new(g).unwrap();
        let s = m.insert_points([
            Point3::new(500_000.25, 4_000_000.25, 120.0),
            Point3::new(500_001.9, 4_000_001.4, 121.0),
            Point3::new(500_002.0, 4_000_000.0, 0.0), // x at the right edge: outside
            Point3::new(f64::NAN, 4_000_000.0, 0.0),
        ]);
        assert_eq!(s, InsertStats { inserted: 2, ignored: 2 });
        assert_eq!(m.local_origin_m(), [500_000.0, 4_000_000.0, 120.0]);
        let c0 = &m.moments()[g.index(Cell::new(0, 0)).unwrap()];
        assert_eq!((c0.count, c0.mean), (1, [0.25, 0.25, 0.0]));
        let c1 = &m.moments()[g.index(Cell::new(3, 2)).unwrap()];
        assert_eq!(c1.count, 1);
        assert!((c1.mean[0] - 1.9).abs() < 1e-9 && (c1.mean[2] - 1.0).abs() < 1e-12);
        assert_eq!(m.point_count(), 2);
        m.clear();
        assert_eq!(m.point_count(), 0);
    }

    #[test]
    fn from_cloud_covers_the_cloud_with_a_margin() {
        let mut p = Params::default();
        p.grid.resolution_m = 0.1;
        p.traversability.disc_radius_m = 0.15;
        p.robot.radius_m = 0.25;
        let cloud = PointCloud::from_points(vec![Point3::new(-1.0, 2.0, 0.0), Point3::new(1.0, 3.0, 0.5)]);
        let m = TraversabilityMap::from_cloud(&cloud, &p).unwrap();
        let g = m.geometry();
        // margin = ceil(0.4 / 0.1) + 1 = 5 cells on each side; span = floor(2/0.1) + 1 = 21.
        assert_eq!((g.width, g.height), (21 + 10, 11 + 10));
        assert!((g.origin_x_m - (-1.5)).abs() < 1e-12 && (g.origin_y_m - 1.5).abs() < 1e-12);
        assert_eq!(m.point_count(), 2);
        assert_eq!(TraversabilityMap::from_cloud(&PointCloud::default(), &p).unwrap_err(), TraversabilityError::EmptyCloud);
        let far = PointCloud::from_points(vec![Point3::new(0.0, 0.0, 0.0), Point3::new(1e7, 1e7, 0.0)]);
        assert!(matches!(TraversabilityMap::from_cloud(&far, &p), Err(TraversabilityError::TooManyCells { .. })));
        p.grid.resolution_m = 0.0;
        assert_eq!(TraversabilityMap::from_cloud(&cloud, &p).unwrap_err(), TraversabilityError::BadGeometry);
    }
}
