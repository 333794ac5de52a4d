//! Whether the path ahead of a driving robot is blocked (notes §8: replan when the map shows an
//! obstacle on the way).
//!
//! The path is sampled every cell length along each segment. A sample within the robot radius r
//! of the robot is skipped (the robot's own footprint); a sample outside the grid blocks; a
//! sample on a cell of the robot's trail (a cell its centre has driven on) is blocked only if
//! that cell itself is lethal; and any other sample is blocked by a lethal cell (score < τ, not
//! NaN) whose centre lies within r of it. The
//! cells are looked at in the sample's (2⌈r/res⌉ + 1)² square, row by row, and the first lethal
//! one within r answers.
//!
//! A cell found not lethal cannot block any sample, so [`CorridorCheck`] marks it for the rest of
//! the call and overlapping squares read its score once: the answer is the one of reading every
//! square whole, for O(samples × square) mark reads plus O(corridor cells) score reads.

use crate::grid::{Cell, GridGeometry};
use crate::math;

/// The marks of one corridor check, reused across calls (no allocation per call).
#[derive(Clone, Debug, Default)]
pub(crate) struct CorridorCheck {
    /// Per cell, the call that found it not lethal.
    marks: Vec<u32>,
    pass: u32,
}

impl CorridorCheck {
    /// Whether the polyline `ahead` (world metres) is blocked for a robot of radius `radius_m` at
    /// `robot_m`. `lethal(i)` says whether cell `i` is lethal (its traversability score below τ;
    /// unknown is not). `on_trail[i]` says whether the robot's centre has driven on cell `i`
    /// (empty or short: no cell). Only the cells in the squares of the samples up to the first
    /// blocked one are asked for, and a cell that is not lethal only once per call.
    pub fn blocked(
        &mut self,
        g: &GridGeometry,
        ahead: impl IntoIterator<Item = [f64; 2]>,
        robot_m: [f64; 2],
        radius_m: f64,
        on_trail: &[bool],
        mut lethal: impl FnMut(usize) -> bool,
    ) -> bool {
        let rc = (radius_m / g.resolution_m).ceil() as i32;
        if self.marks.len() != g.len() {
            self.marks = vec![0; g.len()];
        }
        self.pass = match self.pass.checked_add(1) {
            Some(p) => p,
            None => {
                self.marks.fill(0);
                1
            }
        };
        let mut ahead = ahead.into_iter();
        let Some(mut a) = ahead.next() else { return false };
        for b in ahead {
            let n = (math::hypot(b[0] - a[0], b[1] - a[1]) / g.resolution_m).ceil().max(1.0) as usize;
            for k in 0..=n {
                let t = k as f64 / n as f64;
                let (x, y) = (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]));
                if math::hypot(x - robot_m[0], y - robot_m[1]) < radius_m {
                    continue;
                }
                let Some(c) = g.cell_of(x, y) else { return true };
                if let Some(i) = g.index(c).filter(|&i| on_trail.get(i) == Some(&true)) {
                    if self.marks[i] != self.pass {
                        if lethal(i) {
                            return true;
                        }
                        self.marks[i] = self.pass;
                    }
                    continue;
                }
                for dr in -rc..=rc {
                    for dc in -rc..=rc {
                        let cell = Cell::new(c.col + dc, c.row + dr);
                        let Some(i) = g.index(cell) else { continue };
                        if self.marks[i] == self.pass {
                            continue;
                        }
                        if !lethal(i) {
                            self.marks[i] = self.pass;
                        } else {
                            let (cx, cy) = g.center_of(cell);
                            if math::hypot(cx - x, cy - y) <= radius_m {
                                return true;
                            }
                        }
                    }
                }
            }
            a = b;
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The definition, read whole: every sample against every cell within r.
    fn blocked_by_definition(
        g: &GridGeometry,
        path: &[[f64; 2]],
        robot: [f64; 2],
        r: f64,
        tau: f32,
        trail: &[bool],
        scores: &[f32],
    ) -> bool {
        for w in path.windows(2) {
            let (a, b) = (w[0], w[1]);
            let n = (math::hypot(b[0] - a[0], b[1] - a[1]) / g.resolution_m).ceil().max(1.0) as usize;
            for k in 0..=n {
                let t = k as f64 / n as f64;
                let (x, y) = (a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1]));
                if math::hypot(x - robot[0], y - robot[1]) < r {
                    continue;
                }
                let Some(c) = g.cell_of(x, y) else { return true };
                let own = g.index(c).unwrap();
                if trail[own] {
                    if scores[own] < tau {
                        return true;
                    }
                    continue;
                }
                let lethal_within = (0..g.len()).any(|i| {
                    let (cx, cy) = g.center_of(g.cell_at(i));
                    scores[i] < tau && math::hypot(cx - x, cy - y) <= r
                });
                if lethal_within {
                    return true;
                }
            }
        }
        false
    }

    fn geometry() -> GridGeometry {
        GridGeometry::new(-1.0, -1.0, 0.1, 20, 20)
    }

    #[test]
    fn a_lethal_cell_behind_the_robot_or_beside_the_corridor_does_not_block() {
        let g = geometry();
        let mut scores = vec![1.0f32; g.len()];
        let lethal = |scores: &mut Vec<f32>, x: f64, y: f64| scores[g.index(g.cell_of(x, y).unwrap()).unwrap()] = 0.0;
        lethal(&mut scores, 0.55, 0.85); // 0.8 m beside the path y = 0.05
        let path = [[-0.5, 0.05], [0.75, 0.05]];
        let mut check = CorridorCheck::default();
        let mut asked = 0;
        let blocked = check.blocked(&g, path, [-0.5, 0.05], 0.25, &[], |i| {
            asked += 1;
            scores[i] < 0.5
        });
        assert!(!blocked);
        // Every cell of the corridor once: the samples kept run from x = −0.21 m (the first one
        // at least r from the robot) to 0.75 m, columns 7–17; ± 3 cells (r = 0.25 m) gives
        // columns 4–19 (the grid's last) × rows 7–13.
        assert_eq!(asked, 16 * 7);
        lethal(&mut scores, 0.25, 0.15); // 0.1 m off the path, ahead
        assert!(check.blocked(&g, path, [-0.5, 0.05], 0.25, &[], |i| scores[i] < 0.5));
        // The robot past it, at the path's end: what is behind it no longer matters.
        assert!(!check.blocked(&g, [[0.7, 0.05], [0.75, 0.05]], [0.7, 0.05], 0.25, &[], |i| scores[i] < 0.5));
        // Leaving the grid blocks; an empty path does not.
        assert!(check.blocked(&g, [[0.5, 0.5], [1.5, 0.5]], [0.5, 0.5], 0.25, &[], |_| false));
        assert!(!check.blocked(&g, [], [0.0, 0.0], 0.25, &[], |_| true));
    }

    #[test]
    fn on_its_trail_the_robot_is_blocked_only_by_the_trail_cell_itself() {
        let g = geometry();
        let mut scores = vec![1.0f32; g.len()];
        let idx = |x: f64, y: f64| g.index(g.cell_of(x, y).unwrap()).unwrap();
        // A doorway jamb 0.15 m beside the path y = 0.05, ahead of the robot.
        scores[idx(0.25, 0.2)] = 0.0;
        let path = [[-0.5, 0.05], [0.75, 0.05]];
        let mut check = CorridorCheck::default();
        assert!(check.blocked(&g, path, [-0.5, 0.05], 0.25, &[], |i| scores[i] < 0.5));
        // The robot drove along y = 0.05 before: the jamb no longer blocks...
        let mut trail = vec![false; g.len()];
        for k in 0..13 {
            trail[idx(-0.45 + 0.1 * k as f64, 0.05)] = true;
        }
        assert!(!check.blocked(&g, path, [-0.5, 0.05], 0.25, &trail, |i| scores[i] < 0.5));
        // ...but a trail cell its map now holds lethal does.
        scores[idx(0.35, 0.05)] = 0.2;
        assert!(check.blocked(&g, path, [-0.5, 0.05], 0.25, &trail, |i| scores[i] < 0.5));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(200))]
        #[test]
        fn the_marked_check_answers_as_the_definition(
            lethal in prop::collection::vec(0usize..400, 0..12),
            unknown in prop::collection::vec(0usize..400, 0..40),
            path in prop::collection::vec((-1.2f64..1.2, -1.2f64..1.2), 1..6),
            robot in (-1.0f64..1.0, -1.0f64..1.0),
            r in 0.05f64..0.4,
            trail_cells in prop::collection::vec(0usize..400, 0..60),
        ) {
            let g = geometry();
            let mut scores = vec![0.9f32; g.len()];
            for &i in &unknown { scores[i] = f32::NAN; }
            for &i in &lethal { scores[i] = 0.1; }
            let path: Vec<[f64; 2]> = path.into_iter().map(|(x, y)| [x, y]).collect();
            let robot = [robot.0, robot.1];
            let mut trail = vec![false; g.len()];
            for &i in &trail_cells { trail[i] = true; }
            let mut check = CorridorCheck::default();
            let mut asked = vec![0u32; g.len()];
            let got = check.blocked(&g, path.iter().copied(), robot, r, &trail, |i| { asked[i] += 1; scores[i] < 0.5 });
            prop_assert_eq!(got, blocked_by_definition(&g, &path, robot, r, 0.5, &trail, &scores));
            prop_assert!(asked.iter().zip(&scores).all(|(&n, &s)| n <= 1 || s < 0.5), "only lethal cells are asked twice");
            // A second call on the same marks answers the same.
            prop_assert_eq!(check.blocked(&g, path.iter().copied(), robot, r, &trail, |i| scores[i] < 0.5), got);
        }
    }
}
