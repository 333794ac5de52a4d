use super::*;
use crate::grid::{Grid, GridGeometry, FREE, LETHAL, UNKNOWN};
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
