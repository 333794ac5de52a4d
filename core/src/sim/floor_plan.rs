//! A seeded indoor floor plan: rooms and doors by binary space partition.
//!
//! The free interior of a `size_m` rectangle framed by an outer wall is split, along its longer
//! side, by a wall at a uniformly drawn position that leaves both parts at least
//! `min_room_m` wide; each part is split again until no side is longer than `max_room_m` (or no
//! split fits). Every splitting wall has one door of `door_width_m` (a second with
//! `extra_door_probability`, which makes loops), so every room is reachable: the two halves of a
//! split are connected through its door, and each half is connected by induction. A wall never
//! ends inside an earlier wall's door (positions that would are redrawn), so a door keeps its
//! whole width.

use super::heightfield::Heightfield;
use crate::grid::GridGeometry;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The generator's parameters (the world file's `[terrain] kind = "floor_plan"` keys).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FloorPlanParams {
    /// Outer size [x, y] of the plan, metres, outer walls included.
    pub size_m: [f64; 2],
    /// Shortest side a split may leave a room, metres.
    pub min_room_m: f64,
    /// A room with a side longer than this is split again (if a split fits), metres.
    pub max_room_m: f64,
    /// Clear width of a door, metres.
    pub door_width_m: f64,
    /// Thickness of every wall, metres.
    pub wall_thickness_m: f64,
    /// Probability that a splitting wall long enough for two doors gets a second one, [0, 1].
    pub extra_door_probability: f64,
}

/// An axis-aligned rectangle [min_x, min_y, max_x, max_y], metres.
type Rect = [f64; 4];

/// A door: the wall it pierces runs along `along` (0 = x, 1 = y) at `at_m` on the other axis;
/// the gap spans [from_m, to_m] along `along`.
#[derive(Clone, Copy, Debug)]
struct Door {
    along: usize,
    at_m: f64,
    from_m: f64,
    to_m: f64,
}

/// The plan as rectangles: walls (solid) and doors (cut out of the walls).
#[derive(Clone, Debug, Default)]
pub struct FloorPlan {
    /// Solid wall rectangles, outer frame included.
    pub walls_m: Vec<Rect>,
    /// Door openings, each inside one splitting wall.
    pub doors_m: Vec<Rect>,
    /// The rooms' free interiors.
    pub rooms_m: Vec<Rect>,
}

/// Draws attempts per split before a part is kept as one room.
const SPLIT_ATTEMPTS: usize = 16;

impl FloorPlan {
    /// The plan of `seed` (ChaCha8, the same on every platform).
    pub fn generate(p: &FloorPlanParams, seed: u64) -> Self {
        let t = p.wall_thickness_m;
        let [w, h] = p.size_m;
        let mut plan =
            FloorPlan { walls_m: vec![[0.0, 0.0, w, t], [0.0, h - t, w, h], [0.0, 0.0, t, h], [w - t, 0.0, w, h]], ..Self::default() };
        let mut doors = Vec::new();
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let mut stack = vec![[t, t, w - t, h - t]];
        while let Some(r) = stack.pop() {
            match split(p, &r, &doors, &mut rng) {
                None => plan.rooms_m.push(r),
                Some((axis, at_m)) => {
                    let other = 1 - axis;
                    let (lo, hi) = (at_m - t / 2.0, at_m + t / 2.0);
                    let mut wall = r;
                    wall[axis] = lo;
                    wall[axis + 2] = hi;
                    plan.walls_m.push(wall);
                    for d in door_spans(p, r[other], r[other + 2], &mut rng) {
                        doors.push(Door { along: other, at_m, from_m: d.0, to_m: d.1 });
                        let mut gap = wall;
                        gap[other] = d.0;
                        gap[other + 2] = d.1;
                        plan.doors_m.push(gap);
                    }
                    let (mut a, mut b) = (r, r);
                    a[axis + 2] = lo;
                    b[axis] = hi;
                    // Pushed in a fixed order: the plan is a pure function of the seed.
                    stack.push(b);
                    stack.push(a);
                }
            }
        }
        plan
    }

    /// The plan on cells of `cell_m`: `wall_height_m` where a wall stands (a cell whose centre
    /// lies in a wall and not in a door), 0 elsewhere.
    pub fn heightfield(&self, size_m: [f64; 2], cell_m: f64, wall_height_m: f64) -> Heightfield {
        let (nx, ny) = ((size_m[0] / cell_m).round().max(2.0) as usize, (size_m[1] / cell_m).round().max(2.0) as usize);
        let g = GridGeometry::new(0.0, 0.0, cell_m, nx, ny);
        let inside = |r: &Rect, x: f64, y: f64| r[0] <= x && x <= r[2] && r[1] <= y && y <= r[3];
        Heightfield::from_fn(g, |x, y| {
            let wall = self.walls_m.iter().any(|r| inside(r, x, y)) && !self.doors_m.iter().any(|r| inside(r, x, y));
            if wall { wall_height_m } else { 0.0 }
        })
    }
}

/// Where `r` is split (axis across which the wall stands, its centre), or `None` for a room.
fn split(p: &FloorPlanParams, r: &Rect, doors: &[Door], rng: &mut ChaCha8Rng) -> Option<(usize, f64)> {
    let t = p.wall_thickness_m;
    let (dx, dy) = (r[2] - r[0], r[3] - r[1]);
    if dx.max(dy) <= p.max_room_m {
        return None;
    }
    let axis = if dx >= dy { 0 } else { 1 };
    let other = 1 - axis;
    // The wall's centre leaves min_room_m of free floor on each side.
    let (lo, hi) = (r[axis] + p.min_room_m + t / 2.0, r[axis + 2] - p.min_room_m - t / 2.0);
    if lo > hi {
        return None;
    }
    // The walls the new one ends on are the ones bounding r across `other`, centred t/2 outside.
    let ends = [r[other] - t / 2.0, r[other + 2] + t / 2.0];
    for _ in 0..SPLIT_ATTEMPTS {
        let at_m = rng.random_range(lo..=hi);
        let blocks = |d: &Door| {
            d.along == axis && ends.iter().any(|e| (d.at_m - e).abs() < t) && d.from_m < at_m + t / 2.0 + t && at_m - t / 2.0 - t < d.to_m
        };
        if !doors.iter().any(blocks) {
            return Some((axis, at_m));
        }
    }
    None
}

/// The door gaps [from, to] in a wall spanning [lo_m, hi_m] (one, or two with
/// `extra_door_probability` when the wall holds two doors a door's width apart); none when the
/// wall is shorter than a door plus a wall thickness at each end.
fn door_spans(p: &FloorPlanParams, lo_m: f64, hi_m: f64, rng: &mut ChaCha8Rng) -> Vec<(f64, f64)> {
    let (d, t) = (p.door_width_m, p.wall_thickness_m);
    let (first, last) = (lo_m + t, hi_m - t - d);
    if first > last {
        return Vec::new();
    }
    let two = last - first >= 2.0 * d && rng.random_bool(p.extra_door_probability.clamp(0.0, 1.0));
    if two {
        // The second door starts at least a door's width after the first ends.
        let a = rng.random_range(first..=last - 2.0 * d);
        let b = rng.random_range(a + 2.0 * d..=last);
        vec![(a, a + d), (b, b + d)]
    } else {
        let a = rng.random_range(first..=last);
        vec![(a, a + d)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{FREE, LETHAL, OccupancyGrid, inflate_lethal};

    fn params() -> FloorPlanParams {
        FloorPlanParams {
            size_m: [12.0, 10.0],
            min_room_m: 2.5,
            max_room_m: 5.0,
            door_width_m: 1.2,
            wall_thickness_m: 0.15,
            extra_door_probability: 0.3,
        }
    }

    /// 4-connected components of the cells `free` marks.
    fn components(g: &GridGeometry, free: &[bool]) -> usize {
        let mut seen = vec![false; free.len()];
        let mut count = 0;
        for i0 in 0..free.len() {
            if seen[i0] || !free[i0] {
                continue;
            }
            count += 1;
            seen[i0] = true;
            let mut stack = vec![i0];
            while let Some(i) = stack.pop() {
                let (c, r) = (i % g.width, i / g.width);
                let mut next = Vec::with_capacity(4);
                if c > 0 {
                    next.push(i - 1);
                }
                if c + 1 < g.width {
                    next.push(i + 1);
                }
                if r > 0 {
                    next.push(i - g.width);
                }
                if r + 1 < g.height {
                    next.push(i + g.width);
                }
                for j in next {
                    if free[j] && !seen[j] {
                        seen[j] = true;
                        stack.push(j);
                    }
                }
            }
        }
        count
    }

    #[test]
    fn a_plan_no_longer_than_a_room_is_its_frame() {
        let p = FloorPlanParams { size_m: [4.0, 3.0], ..params() };
        let plan = FloorPlan::generate(&p, 7);
        assert_eq!((plan.walls_m.len(), plan.doors_m.len(), plan.rooms_m.len()), (4, 0, 1));
        assert_eq!(plan.rooms_m[0], [0.15, 0.15, 3.85, 2.85]);
    }

    #[test]
    fn one_split_fits_where_the_room_is_just_too_long() {
        // Interior x from 0.2 to 6.8 (6.6 m > max 5): the wall's centre lies in
        // [0.2 + 3 + 0.1, 6.8 − 3 − 0.1] = [3.3, 3.7]; each half is 3.0–3.4 m ≤ 5, so no more splits.
        let p = FloorPlanParams {
            size_m: [7.0, 4.0],
            min_room_m: 3.0,
            max_room_m: 5.0,
            door_width_m: 1.0,
            wall_thickness_m: 0.2,
            extra_door_probability: 0.0,
        };
        for seed in 0..20 {
            let plan = FloorPlan::generate(&p, seed);
            assert_eq!((plan.walls_m.len(), plan.doors_m.len(), plan.rooms_m.len()), (5, 1, 2), "seed {seed}");
            let wall = plan.walls_m[4];
            let centre = (wall[0] + wall[2]) / 2.0;
            assert!((3.3..=3.7).contains(&centre), "seed {seed}: wall at {centre}");
            assert!((wall[2] - wall[0] - 0.2).abs() < 1e-12 && wall[1] == 0.2 && wall[3] == 3.8);
            // The door: 1.0 m wide, at least a wall thickness from each end of the 3.6 m wall.
            let door = plan.doors_m[0];
            assert!((door[3] - door[1] - 1.0).abs() < 1e-12);
            assert!(door[1] >= 0.4 - 1e-12 && door[3] <= 3.6 + 1e-12, "seed {seed}: door {door:?}");
        }
    }

    #[test]
    fn every_room_is_reachable_by_a_robot_through_the_doors() {
        // Property over seeds: the free cells form one component, and stay one after inflation by
        // a robot radius of 0.25 m + 0.25 m of margin (a door of 1.2 m leaves 0.2 m).
        let p = params();
        let mut rooms_seen = Vec::new();
        for seed in 0..40 {
            let plan = FloorPlan::generate(&p, seed);
            for r in &plan.rooms_m {
                let (dx, dy) = (r[2] - r[0], r[3] - r[1]);
                assert!(dx.min(dy) >= p.min_room_m - 1e-9, "seed {seed}: room {r:?} narrower than min_room_m");
            }
            rooms_seen.push(plan.rooms_m.len());
            let hf = plan.heightfield(p.size_m, 0.05, 1.0);
            let g = hf.geometry;
            let occ = OccupancyGrid { geometry: g, data: hf.heights_m.iter().map(|&z| if z > 0.0 { LETHAL } else { FREE }).collect() };
            let free: Vec<bool> = occ.data.iter().map(|&v| v == FREE).collect();
            assert_eq!(components(&g, &free), 1, "seed {seed}: the free floor is split");
            let inflated = inflate_lethal(&occ, 0.5);
            let free: Vec<bool> = inflated.data.iter().map(|&v| v == FREE).collect();
            assert_eq!(components(&g, &free), 1, "seed {seed}: a robot cannot reach every room");
        }
        // A 12 × 10 m plan with rooms ≤ 5 m has several rooms, and their number varies.
        assert!(rooms_seen.iter().all(|&n| n >= 4), "{rooms_seen:?}");
        assert!(rooms_seen.iter().min() != rooms_seen.iter().max(), "{rooms_seen:?}");
    }

    #[test]
    fn the_plan_is_a_pure_function_of_the_seed() {
        let p = params();
        let field = |seed| FloorPlan::generate(&p, seed).heightfield(p.size_m, 0.05, 1.0).heights_m;
        assert_eq!(field(3), field(3));
        assert_ne!(field(3), field(4));
    }
}
