use super::dijkstra::dijkstra_to;
use super::*;
use crate::grid::{FREE, Grid, GridGeometry, LETHAL, UNKNOWN};
use proptest::prelude::*;

fn grid_from(rows: &[&str]) -> OccupancyGrid {
    // rows[0] is the top row (highest y), as drawn.
    let h = rows.len();
    let w = rows[0].len();
    let mut g = Grid::filled(GridGeometry::new(0.0, 0.0, 0.1, w, h), FREE);
    for (k, line) in rows.iter().enumerate() {
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

#[test]
fn straight_and_diagonal_lengths_are_octile() {
    let g = grid_from(&["......", "......", "......", "......"]);
    let p = astar(&g, Cell::new(0, 0), Cell::new(5, 0), false).unwrap();
    assert!((p.length_m - 0.5).abs() < 1e-12);
    let p = astar(&g, Cell::new(0, 0), Cell::new(3, 3), false).unwrap();
    assert!((p.length_m - 0.3 * std::f64::consts::SQRT_2).abs() < 1e-12);
    assert_eq!(p.cells.len(), 4);
}

#[test]
fn walls_force_a_detour_and_corners_are_not_cut() {
    let g = grid_from(&[".....", ".###.", ".#...", ".#...", "....."]);
    // From inside the pocket (2,1) to (2,4) must go around; no diagonal through the wall corner.
    let p = astar(&g, Cell::new(2, 1), Cell::new(2, 4), false).unwrap();
    for c in &p.cells {
        assert_eq!(*g.get(*c).unwrap(), FREE);
    }
    let d = dijkstra(&g, Cell::new(2, 1), false).unwrap();
    assert!((d.distance_m(Cell::new(2, 4)).unwrap() - p.length_m).abs() < 1e-9);
}

#[test]
fn typed_errors() {
    let g = grid_from(&["..#", ".?#", "..."]);
    assert_eq!(astar(&g, Cell::new(9, 0), Cell::new(0, 0), false).unwrap_err(), PathError::StartOutsideMap);
    assert_eq!(astar(&g, Cell::new(2, 2), Cell::new(0, 0), false).unwrap_err(), PathError::StartLethal);
    assert_eq!(astar(&g, Cell::new(0, 0), Cell::new(1, 1), false).unwrap_err(), PathError::GoalLethal);
    assert!(astar(&g, Cell::new(0, 0), Cell::new(1, 1), true).is_ok());
    let g = grid_from(&["..#..", "..#..", "..#.."]);
    assert_eq!(astar(&g, Cell::new(0, 0), Cell::new(4, 0), false).unwrap_err(), PathError::NoPath);
    assert!(dijkstra(&g, Cell::new(0, 0), false).unwrap().distance_m(Cell::new(4, 0)).is_none());
}

fn arb_grid() -> impl Strategy<Value = (OccupancyGrid, Cell, Cell)> {
    (4usize..24, 4usize..24).prop_flat_map(|(w, h)| {
        (
            proptest::collection::vec(prop_oneof![6 => Just(FREE), 3 => Just(LETHAL), 1 => Just(UNKNOWN)], w * h),
            0..w as i32,
            0..h as i32,
            0..w as i32,
            0..h as i32,
        )
            .prop_map(move |(data, sc, sr, gc, gr)| {
                let mut g = Grid::from_vec(GridGeometry::new(0.0, 0.0, 0.05, w, h), data).unwrap();
                *g.get_mut(Cell::new(sc, sr)).unwrap() = FREE;
                *g.get_mut(Cell::new(gc, gr)).unwrap() = FREE;
                (g, Cell::new(sc, sr), Cell::new(gc, gr))
            })
    })
}

proptest! {
    /// A planned path never touches a lethal or unknown cell, moves between 8-neighbours without
    /// cutting corners, and A* and Dijkstra agree on the optimum.
    #[test]
    fn paths_stay_on_free_cells_and_astar_matches_dijkstra((g, s, t) in arb_grid()) {
        let d = dijkstra(&g, s, false).unwrap();
        match astar(&g, s, t, false) {
            Ok(p) => {
                prop_assert_eq!(p.cells[0], s);
                prop_assert_eq!(*p.cells.last().unwrap(), t);
                let mut len = 0.0;
                for w in p.cells.windows(2) {
                    let (a, b) = (w[0], w[1]);
                    let (dc, dr) = (b.col - a.col, b.row - a.row);
                    prop_assert!(dc.abs() <= 1 && dr.abs() <= 1 && (dc, dr) != (0, 0));
                    if dc != 0 && dr != 0 {
                        prop_assert_eq!(*g.get(Cell::new(a.col + dc, a.row)).unwrap(), FREE);
                        prop_assert_eq!(*g.get(Cell::new(a.col, a.row + dr)).unwrap(), FREE);
                    }
                    len += if dc != 0 && dr != 0 { std::f64::consts::SQRT_2 } else { 1.0 };
                }
                for c in &p.cells {
                    prop_assert_eq!(*g.get(*c).unwrap(), FREE);
                }
                prop_assert!((len * 0.05 - p.length_m).abs() < 1e-9);
                let dd = d.distance_m(t).unwrap();
                prop_assert!((dd - p.length_m).abs() < 1e-9);
                let dp = d.path_to(t).unwrap();
                prop_assert!((dp.length_m - p.length_m).abs() < 1e-9);
            }
            Err(PathError::NoPath) => prop_assert!(d.distance_m(t).is_none()),
            Err(e) => prop_assert!(false, "unexpected {e:?}"),
        }
    }
}

proptest! {
    /// The early-stopping search gives the targets exactly the full search's distances and
    /// paths (the window and the stop change what is stored, not the answer), and its paths are
    /// legal moves over free cells.
    #[test]
    fn dijkstra_to_matches_dijkstra_on_its_targets(
        (g, s, t) in arb_grid(),
        extra in proptest::collection::vec((0i32..24, 0i32..24), 0..6),
    ) {
        let full = dijkstra(&g, s, false).unwrap();
        prop_assert!(full.is_complete());
        let mut targets = vec![t];
        targets.extend(extra.iter().map(|&(c, r)| Cell::new(c, r)));
        let part = dijkstra_to(&g, s, false, &targets).unwrap();
        prop_assert!(part.settled_count() <= full.settled_count());
        for &c in &targets {
            prop_assert_eq!(part.distance_m(c), full.distance_m(c));
            let (pp, fp) = (part.path_to(c), full.path_to(c));
            prop_assert_eq!(pp.as_ref().map(|p| &p.cells), fp.as_ref().map(|p| &p.cells));
            if let Some(p) = pp {
                prop_assert_eq!(p.cells[0], s);
                for w in p.cells.windows(2) {
                    let (dc, dr) = (w[1].col - w[0].col, w[1].row - w[0].row);
                    prop_assert!(dc.abs() <= 1 && dr.abs() <= 1 && (dc, dr) != (0, 0));
                    prop_assert_eq!(*g.get(w[1]).unwrap(), FREE);
                    if dc != 0 && dr != 0 {
                        prop_assert_eq!(*g.get(Cell::new(w[0].col + dc, w[0].row)).unwrap(), FREE);
                        prop_assert_eq!(*g.get(Cell::new(w[0].col, w[0].row + dr)).unwrap(), FREE);
                    }
                }
            }
        }
    }
}

#[test]
fn the_window_is_the_bounding_box_of_the_free_cells() {
    // Free cells only in the middle of a mostly unknown map; a cell outside the window is simply
    // not reached, with or without targets.
    let g = grid_from(&["?????????", "??.....??", "??.#...??", "??.....??", "?????????"]);
    let d = dijkstra(&g, Cell::new(2, 1), false).unwrap();
    assert_eq!(d.settled_count(), 14);
    assert!((d.distance_m(Cell::new(6, 3)).unwrap() - 0.1 * (2.0 * std::f64::consts::SQRT_2 + 2.0)).abs() < 1e-12);
    assert!(d.distance_m(Cell::new(0, 0)).is_none());
    assert!(d.distance_m(Cell::new(20, 0)).is_none());
    // Unknown allowed: the whole map is the window.
    let u = dijkstra(&g, Cell::new(2, 1), true).unwrap();
    assert_eq!(u.settled_count(), 44);
    // A target next to the start stops the search early.
    let near = dijkstra_to(&g, Cell::new(2, 1), false, &[Cell::new(3, 1)]).unwrap();
    assert!(!near.is_complete());
    assert!(near.settled_count() < 14);
    assert_eq!(near.distance_m(Cell::new(3, 1)), Some(0.1));
}

#[test]
fn passable_is_free_or_allowed_unknown_for_every_value() {
    for v in i8::MIN..=i8::MAX {
        let class = crate::grid::CellClass::of(v);
        assert_eq!(passable(v, false), class == crate::grid::CellClass::Free, "{v}");
        assert_eq!(passable(v, true), class != crate::grid::CellClass::Lethal, "{v}");
    }
}

#[test]
fn long_paths_keep_exact_octile_lengths() {
    // 1500 × 1500 open cells: the fixed-point scale is coarsest here among the tests; the corner
    // to corner path is 1499 diagonal moves and a straight edge is 1499 orthogonal ones.
    let g = Grid::filled(GridGeometry::new(0.0, 0.0, 0.05, 1500, 1500), FREE);
    let d = dijkstra(&g, Cell::new(0, 0), false).unwrap();
    let diag = d.distance_m(Cell::new(1499, 1499)).unwrap();
    assert!((diag - 0.05 * 1499.0 * std::f64::consts::SQRT_2).abs() < 1e-9, "{diag}");
    assert!((d.distance_m(Cell::new(1499, 0)).unwrap() - 0.05 * 1499.0).abs() < 1e-12);
    // A knight-like target: 700 diagonal + 300 orthogonal moves.
    let knight = d.distance_m(Cell::new(1000, 700)).unwrap();
    assert!((knight - 0.05 * (300.0 + 700.0 * std::f64::consts::SQRT_2)).abs() < 1e-9, "{knight}");
    let p = d.path_to(Cell::new(1000, 700)).unwrap();
    assert_eq!(p.cells.len(), 1001);
    assert_eq!(p.length_m, knight);
}

/// The corners of a path, by definition: the first and last cells and those where the move
/// changes.
fn corners_of(cells: &[Cell]) -> Vec<Cell> {
    (0..cells.len())
        .filter(|&k| {
            k == 0
                || k + 1 == cells.len()
                || (cells[k].col - cells[k - 1].col, cells[k].row - cells[k - 1].row)
                    != (cells[k + 1].col - cells[k].col, cells[k + 1].row - cells[k].row)
        })
        .map(|k| cells[k])
        .collect()
}

#[test]
fn corners_keep_the_start_the_turns_and_the_target() {
    // From (0, 0): to (5, 0) straight east. To (4, 2) the wall (column 2, rows 1–2) forbids
    // cutting its corner at (2, 0)–(3, 1), so the best is 3 east, 1 north-east, 1 north
    // (4 + √2 cells; over the top costs 4 + 2√2); walking back from (4, 2) the first exact
    // predecessor in move order is (4, 1) (north), then (3, 0) (north-east), then east to the
    // start. The start itself is a one-cell path, a neighbour a two-cell one; the lethal cell
    // and the cell outside have none.
    let g = grid_from(&["......", "..#...", "..#...", "......"]);
    let d = dijkstra(&g, Cell::new(0, 0), false).unwrap();
    let cells = |v: &[(i32, i32)]| v.iter().map(|&(c, r)| Cell::new(c, r)).collect::<Vec<_>>();
    assert_eq!(d.corners_to(Cell::new(5, 0)), Some(cells(&[(0, 0), (5, 0)])));
    assert_eq!(d.corners_to(Cell::new(4, 2)), Some(cells(&[(0, 0), (3, 0), (4, 1), (4, 2)])));
    assert!((d.distance_m(Cell::new(4, 2)).unwrap() - 0.1 * (4.0 + std::f64::consts::SQRT_2)).abs() < 1e-12);
    assert_eq!(d.corners_to(Cell::new(0, 0)), Some(cells(&[(0, 0)])));
    assert_eq!(d.corners_to(Cell::new(1, 1)), Some(cells(&[(0, 0), (1, 1)])));
    assert_eq!((d.corners_to(Cell::new(2, 2)), d.corners_to(Cell::new(9, 9))), (None, None));
}

proptest! {
    /// The corners are exactly those of the whole path, wherever the target.
    #[test]
    fn corners_to_are_the_corners_of_path_to((g, s, t) in arb_grid(), extra in proptest::collection::vec((0i32..24, 0i32..24), 0..20)) {
        let d = dijkstra(&g, s, false).unwrap();
        for c in [t, s].into_iter().chain(extra.iter().map(|&(c, r)| Cell::new(c, r))) {
            prop_assert_eq!(d.corners_to(c), d.path_to(c).map(|p| corners_of(&p.cells)));
        }
    }
}
