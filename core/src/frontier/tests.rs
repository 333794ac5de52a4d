//! Tests of the whole detection pipeline (WFD + clustering) on hand-drawn maps, property tests
//! against the planner's reachability, and an ignored timing run for docs/benchmarks.md.

use super::blacklist::end_of_mission;
use super::cluster::split_lengths;
use super::wfd::detect_frontiers;
use super::*;
use crate::grid::GridGeometry;
use crate::grid::{CellClass, FREE, Grid, LETHAL, OccupancyGrid, UNKNOWN};
use crate::params::FrontierParams;
use crate::path::dijkstra;
use proptest::prelude::*;
use std::collections::BTreeSet;

/// Map from ASCII art: rows[0] is the top row (highest y); '#' lethal, '?' unknown, else free.
/// Resolution 0.1 m, origin (0, 0).
fn grid_from(rows: &[&str]) -> OccupancyGrid {
    let h = rows.len();
    let w = rows[0].len();
    let mut g = Grid::filled(GridGeometry::new(0.0, 0.0, 0.1, w, h), FREE);
    for (k, line) in rows.iter().enumerate() {
        assert_eq!(line.len(), w, "ragged test map");
        let r = (h - 1 - k) as i32;
        for (c, ch) in line.chars().enumerate() {
            *g.get_mut(Cell::new(c as i32, r)).unwrap() = match ch {
                '#' => LETHAL,
                '?' => UNKNOWN,
                _ => FREE,
            };
        }
    }
    g
}

fn params(min: usize, max: usize) -> FrontierParams {
    FrontierParams { min_cluster_cells: min, max_cluster_cells: max, ..FrontierParams::default() }
}

fn cells(v: &[(i32, i32)]) -> Vec<Cell> {
    v.iter().map(|&(c, r)| Cell::new(c, r)).collect()
}

const ROOM: [&str; 7] = [
    "?????????????", // row 6
    "?####.....##?", // row 5: the opening, cols 5..=9
    "?#.........#?",
    "?#.........#?",
    "?#.........#?",
    "?###########?",
    "?????????????", // row 0
];

#[test]
fn room_with_one_opening_gives_one_cluster_centred_on_it() {
    let g = grid_from(&ROOM);
    let out = detect_frontiers(&g, Cell::new(3, 3), None, &FrontierParams::default()).unwrap();
    // Only the opening's cells touch unknown space (row 6 above them); the walls shield the rest.
    // The chain is walked from its smallest index (5,5); the median of 5 cells is the 3rd.
    assert_eq!(out.len(), 1);
    assert_eq!(out[0].cells, cells(&[(5, 5), (6, 5), (7, 5), (8, 5), (9, 5)]));
    assert_eq!(out[0].candidate, Cell::new(7, 5));
    assert_eq!(out[0].candidate_m(&g.geometry), [0.75, 0.55]);
    assert_eq!(frontier_cells(&g, Cell::new(3, 3), None).unwrap(), out[0].cells);
}

#[test]
fn frontier_cells_outside_the_boundary_are_excluded() {
    // A corridor open to unknown space at both ends.
    let g = grid_from(&["############", "?..........?", "?..........?", "############"]);
    let p = params(1, 40);
    let all = detect_frontiers(&g, Cell::new(5, 1), None, &p).unwrap();
    assert_eq!(all.len(), 2);
    assert_eq!(all[0].cells, cells(&[(1, 1), (1, 2)]));
    assert_eq!(all[1].cells, cells(&[(10, 1), (10, 2)]));
    // Boundary x ∈ [0, 0.6): column 1 (centre x = 0.15) is in, column 10 (1.05) is out.
    let left = Boundary::from_bounds(0.0, 0.0, 0.6, 0.4);
    let out = detect_frontiers(&g, Cell::new(5, 1), Some(&left), &p).unwrap();
    assert_eq!(out, vec![all[0].clone()]);
    // A boundary that ends between the two cells of a frontier splits it: only (1,1) (y = 0.15).
    let low = Boundary::from_bounds(0.0, 0.0, 2.0, 0.2);
    assert_eq!(frontier_cells(&g, Cell::new(5, 1), Some(&low)).unwrap(), cells(&[(1, 1), (10, 1)]));
}

#[test]
fn unreachable_frontiers_are_not_detected() {
    // The right half touches unknown space but a wall separates it from the robot.
    let g = grid_from(&["######???", "###.#...?", "#...#...?", "#...#...?", "#########"]);
    assert!(detect_frontiers(&g, Cell::new(1, 1), None, &params(1, 40)).unwrap().is_empty());
    // From the right half it is there (so the test above could have failed); (5,3) is under a
    // wall, not under unknown space.
    let right = detect_frontiers(&g, Cell::new(6, 2), None, &params(1, 40)).unwrap();
    let got: BTreeSet<Cell> = right.iter().flat_map(|c| c.cells.iter().copied()).collect();
    let want: BTreeSet<Cell> = cells(&[(6, 3), (7, 3), (7, 2), (7, 1)]).into_iter().collect();
    assert_eq!(got, want);
}

#[test]
fn diagonal_gaps_are_not_crossed() {
    // (3,3) touches the robot's pocket only through the corner of (2,2): the planner may not cut
    // it, so (3,3), under unknown (3,4), is not a reachable frontier cell.
    let g = grid_from(&["###?#", "###.#", "#..##", "#..##", "#####"]);
    assert!(frontier_cells(&g, Cell::new(1, 1), None).unwrap().is_empty());
    assert!(!dijkstra(&g, Cell::new(1, 1), false).unwrap().reachable(Cell::new(3, 3)));
}

#[test]
fn long_straight_frontier_splits_into_nearly_equal_pieces() {
    // 100 free columns under unknown space: row 1 is a 100-cell chain, walked from col 0.
    // ⌈100/40⌉ = 3 pieces of 34, 33, 33 cells; medians at 0+17, 34+16, 67+16.
    let rows = ["?".repeat(100), ".".repeat(100), ".".repeat(100)];
    let rows: Vec<&str> = rows.iter().map(String::as_str).collect();
    let g = grid_from(&rows);
    let out = detect_frontiers(&g, Cell::new(50, 0), None, &params(5, 40)).unwrap();
    let lens: Vec<usize> = out.iter().map(FrontierCluster::len).collect();
    assert_eq!(lens, vec![34, 33, 33]);
    let firsts: Vec<i32> = out.iter().map(|c| c.cells[0].col).collect();
    assert_eq!(firsts, vec![0, 34, 67]);
    let candidates: Vec<Cell> = out.iter().map(|c| c.candidate).collect();
    assert_eq!(candidates, cells(&[(17, 1), (50, 1), (83, 1)]));
    for c in &out {
        assert!(c.cells.windows(2).all(|p| p[1].col == p[0].col + 1 && p[1].row == 1));
    }
}

#[test]
fn small_clusters_are_dropped() {
    // Two openings: 4 cells (cols 1..=4) and 6 cells (cols 6..=11).
    let g = grid_from(&["?????????????", "#....#......#", "#...........#", "#############"]);
    let out = detect_frontiers(&g, Cell::new(3, 1), None, &params(5, 40)).unwrap();
    assert_eq!(out.len(), 1);
    assert_eq!(out[0].cells, cells(&[(6, 2), (7, 2), (8, 2), (9, 2), (10, 2), (11, 2)]));
    assert_eq!(out[0].candidate, Cell::new(9, 2));
    // With min 4 both stay; with max 3 the 6-cell chain splits 3 + 3 and the 4-cell one 2 + 2,
    // which min 3 then drops.
    assert_eq!(detect_frontiers(&g, Cell::new(3, 1), None, &params(4, 40)).unwrap().len(), 2);
    let out = detect_frontiers(&g, Cell::new(3, 1), None, &params(3, 3)).unwrap();
    let lens: Vec<usize> = out.iter().map(FrontierCluster::len).collect();
    assert_eq!(lens, vec![3, 3]);
    assert_eq!(out[0].candidate, Cell::new(7, 2));
    assert_eq!(out[1].candidate, Cell::new(10, 2));
}

#[test]
fn typed_errors() {
    let g = grid_from(&ROOM);
    let p = FrontierParams::default();
    assert_eq!(detect_frontiers(&g, Cell::new(13, 3), None, &p), Err(FrontierError::RobotOutsideMap(Cell::new(13, 3))));
    assert_eq!(detect_frontiers(&g, Cell::new(1, 3), None, &p), Err(FrontierError::RobotNotFree(Cell::new(1, 3))));
    assert_eq!(detect_frontiers(&g, Cell::new(0, 3), None, &p), Err(FrontierError::RobotNotFree(Cell::new(0, 3))));
    assert_eq!(detect_frontiers(&g, Cell::new(3, 3), None, &params(0, 0)), Err(FrontierError::ZeroMaxClusterCells));
    let mut bad = g.clone();
    bad.data.pop();
    assert_eq!(detect_frontiers(&bad, Cell::new(3, 3), None, &p), Err(FrontierError::GridSizeMismatch { data_len: 90, cells: 91 }));
}

#[test]
fn end_of_mission_once_every_candidate_is_blacklisted() {
    let g = grid_from(&ROOM);
    let p = FrontierParams::default();
    let out = detect_frontiers(&g, Cell::new(3, 3), None, &p).unwrap();
    let mut b = Blacklist::new(p.blacklist_radius_m);
    assert!(!end_of_mission(&out, &b, &g.geometry));
    // The next map update moves the median by a cell: still the same goal within 0.5 m.
    b.add(0.85, 0.55, BlacklistReason::Reselected);
    assert!(end_of_mission(&out, &b, &g.geometry));
}

// ---- property tests -------------------------------------------------------------------------

fn arb_case() -> impl Strategy<Value = (OccupancyGrid, Cell, Option<Boundary>, usize, usize)> {
    (3usize..28, 3usize..28).prop_flat_map(|(w, h)| {
        (
            proptest::collection::vec(prop_oneof![6 => Just(FREE), 2 => Just(LETHAL), 3 => Just(UNKNOWN)], w * h),
            0..w as i32,
            0..h as i32,
            proptest::option::of((0.0..1.0f64, 0.0..1.0f64, 0.0..3.0f64, 0.0..3.0f64)),
            1usize..8,
            1usize..12,
        )
            .prop_map(move |(mut data, c, r, b, min, max)| {
                data[r as usize * w + c as usize] = FREE;
                let g = Grid::from_vec(GridGeometry::new(0.0, 0.0, 0.1, w, h), data).unwrap();
                let boundary = b.map(|(x0, y0, dx, dy)| Boundary::from_bounds(x0, y0, x0 + dx, y0 + dy));
                (g, Cell::new(c, r), boundary, min.min(max), max)
            })
    })
}

/// Brute force: free, reachable by the planner, an unknown 4-neighbour, centre in the boundary.
fn brute_force_frontier(g: &OccupancyGrid, robot: Cell, boundary: Option<&Boundary>) -> BTreeSet<Cell> {
    let field = dijkstra(g, robot, false).unwrap();
    let mut set = BTreeSet::new();
    for i in 0..g.geometry.len() {
        let c = g.geometry.cell_at(i);
        let unknown_nb = [(1, 0), (-1, 0), (0, 1), (0, -1)]
            .iter()
            .any(|&(dc, dr)| g.get(Cell::new(c.col + dc, c.row + dr)).is_some_and(|&v| CellClass::of(v) == CellClass::Unknown));
        let (x, y) = g.geometry.center_of(c);
        if CellClass::of(g.data[i]) == CellClass::Free && field.reachable(c) && unknown_nb && boundary.is_none_or(|b| b.contains(x, y)) {
            set.insert(c);
        }
    }
    set
}

proptest! {
    #[test]
    fn clusters_obey_the_definition((g, robot, boundary, min, max) in arb_case()) {
        let p = params(min, max);
        let out = detect_frontiers(&g, robot, boundary.as_ref(), &p).unwrap();
        let truth = brute_force_frontier(&g, robot, boundary.as_ref());
        let mut seen = BTreeSet::new();
        for cl in &out {
            prop_assert!(cl.len() >= min && cl.len() <= max, "size {} not in [{min}, {max}]", cl.len());
            prop_assert!(cl.cells.contains(&cl.candidate));
            prop_assert_eq!(cl.candidate, cl.cells[cl.len() / 2]);
            for c in &cl.cells {
                // Free, unknown 4-neighbour, reachable per path::dijkstra, inside the boundary.
                prop_assert!(truth.contains(c), "{c:?} is not a reachable frontier cell");
                prop_assert!(seen.insert(*c), "{c:?} in two clusters");
            }
        }
        prop_assert_eq!(out.clone(), detect_frontiers(&g, robot, boundary.as_ref(), &p).unwrap());
    }

    #[test]
    fn with_min_one_every_frontier_cell_is_clustered((g, robot, boundary, _min, max) in arb_case()) {
        let out = detect_frontiers(&g, robot, boundary.as_ref(), &params(1, max)).unwrap();
        let got: BTreeSet<Cell> = out.iter().flat_map(|c| c.cells.iter().copied()).collect();
        let n: usize = out.iter().map(FrontierCluster::len).sum();
        prop_assert_eq!(n, got.len());
        prop_assert_eq!(&got, &brute_force_frontier(&g, robot, boundary.as_ref()));
        let listed: BTreeSet<Cell> = frontier_cells(&g, robot, boundary.as_ref()).unwrap().into_iter().collect();
        prop_assert_eq!(&got, &listed);
    }

    /// The planner's one flood (`dijkstra_with_frontiers`) finds WFD's frontier cells, and
    /// clustering them gives exactly `detect_frontiers`' clusters; its distances are the plain
    /// Dijkstra's. The cost and state buffers are reused dirty (a first flood, a clustering).
    #[test]
    fn one_flood_gives_wfd_clusters_and_dijkstra_distances((g, robot, boundary, min, max) in arb_case()) {
        let p = params(min, max);
        let mut state = vec![7u8; 5];
        let (warm, _) = crate::path::dijkstra_with_frontiers(&g, robot, Default::default()).unwrap();
        let (field, frontier) = crate::path::dijkstra_with_frontiers(&g, robot, warm.into_buffers()).unwrap();
        let listed: Vec<usize> = frontier_cells(&g, robot, None).unwrap().iter().map(|&c| g.geometry.index(c).unwrap()).collect();
        prop_assert_eq!(&frontier, &listed);
        let clusters = cluster_frontier_cells(&g.geometry, &frontier, boundary.as_ref(), &p, &mut state).unwrap();
        prop_assert_eq!(clusters, detect_frontiers(&g, robot, boundary.as_ref(), &p).unwrap());
        let again = cluster_frontier_cells(&g.geometry, &frontier, boundary.as_ref(), &p, &mut state).unwrap();
        prop_assert_eq!(again, detect_frontiers(&g, robot, boundary.as_ref(), &p).unwrap());
        let full = dijkstra(&g, robot, false).unwrap();
        prop_assert!(field.is_complete());
        for i in 0..g.geometry.len() {
            let c = g.geometry.cell_at(i);
            prop_assert_eq!(field.distance_m(c), full.distance_m(c));
            prop_assert_eq!(field.path_to(c).map(|p| p.cells), full.path_to(c).map(|p| p.cells));
        }
    }

    #[test]
    fn split_lengths_cover_and_respect_the_max(n in 0usize..500, max in 1usize..60) {
        let l = split_lengths(n, max);
        prop_assert_eq!(l.iter().sum::<usize>(), n);
        prop_assert_eq!(l.len(), n.div_ceil(max));
        prop_assert!(l.iter().all(|&k| k <= max && k > 0));
        prop_assert!(l.windows(2).all(|p| p[0] == p[1] || p[0] == p[1] + 1));
    }
}

// ---- timing (docs/benchmarks.md) -----------------------------------------------------------------

/// splitmix64: a dependency-free, seeded generator for the synthetic map.
fn splitmix(state: &mut u64) -> u64 {
    *state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
    let mut z = *state;
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// 100 m × 100 m at 0.05 m (2000 × 2000): left half explored up to a ragged edge (a random walk
/// per row), 300 lethal discs and 300 unknown holes (rings of frontier) in the explored part,
/// lethal inflated by 0.25 m as in a mission.
fn synthetic_half_explored() -> OccupancyGrid {
    let n = 2000usize;
    let geometry = GridGeometry::new(0.0, 0.0, 0.05, n, n);
    let mut g = Grid::filled(geometry, UNKNOWN);
    let mut rng = 7u64;
    let mut edge = 1000i64;
    for r in 0..n {
        edge = (edge + (splitmix(&mut rng) % 9) as i64 - 4).clamp(800, 1200);
        for c in 0..edge as usize {
            g.data[r * n + c] = FREE;
        }
    }
    let disc = |g: &mut OccupancyGrid, value: i8, rng: &mut u64| {
        let cx = (splitmix(rng) % 900) as i64;
        let cy = (splitmix(rng) % 2000) as i64;
        let rad = 3 + (splitmix(rng) % 15) as i64;
        for dy in -rad..=rad {
            for dx in -rad..=rad {
                if dx * dx + dy * dy <= rad * rad
                    && let Some(v) = g.get_mut(Cell::new((cx + dx) as i32, (cy + dy) as i32))
                {
                    *v = value;
                }
            }
        }
    };
    for _ in 0..300 {
        disc(&mut g, LETHAL, &mut rng);
        disc(&mut g, UNKNOWN, &mut rng);
    }
    crate::grid::inflate_lethal(&g, 0.25)
}

/// `cargo test -p fitslam-core --release frontier::tests::bench -- --ignored --nocapture`
#[test]
#[ignore = "timing run for docs/benchmarks.md"]
fn bench_detect_frontiers_2000x2000() {
    let g = synthetic_half_explored();
    let mut robot = Cell::new(500, 1000);
    while g.get(robot).is_some_and(|&v| v != FREE) {
        robot.col += 1;
    }
    let p = FrontierParams::default();
    let mut best = f64::INFINITY;
    let mut out = Vec::new();
    for _ in 0..5 {
        let t = std::time::Instant::now();
        out = detect_frontiers(&g, robot, None, &p).unwrap();
        best = best.min(t.elapsed().as_secs_f64());
    }
    let n_cells: usize = out.iter().map(FrontierCluster::len).sum();
    println!("frontier detection 2000x2000: {} clusters, {} frontier cells, best of 5: {:.1} ms", out.len(), n_cells, best * 1e3);
    assert!(!out.is_empty());
}
