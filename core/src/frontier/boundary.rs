//! The exploration boundary (notes §3): a closed polygon in the map frame; frontier cells count
//! only if their centre lies inside it.
//!
//! Point-in-polygon by the even-odd (crossing-number) rule: cast a ray towards +x and count the
//! edges it crosses. An edge (a, b) counts when `(a.y > y) != (b.y > y)` and the crossing lies
//! strictly right of the point, which makes an axis-aligned rectangle half-open,
//! `[min_x, max_x) × [min_y, max_y)`. Self-intersecting polygons follow the even-odd rule.
//! O(V) per query for V vertices.

use serde::{Deserialize, Serialize};

/// A closed polygon in the map frame (metres); exploration boundary. The last vertex connects
/// back to the first (do not repeat it). Fewer than 3 vertices contain nothing.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Boundary {
    /// The vertices [x, y], map frame, metres, in order around the polygon.
    pub vertices_m: Vec<[f64; 2]>,
}

impl Boundary {
    /// A polygon from its vertices (map frame, metres).
    pub fn new(vertices_m: Vec<[f64; 2]>) -> Self {
        Self { vertices_m }
    }

    /// The axis-aligned rectangle `[min_x_m, max_x_m) × [min_y_m, max_y_m)`, counter-clockwise.
    pub fn from_bounds(min_x_m: f64, min_y_m: f64, max_x_m: f64, max_y_m: f64) -> Self {
        Self { vertices_m: vec![[min_x_m, min_y_m], [max_x_m, min_y_m], [max_x_m, max_y_m], [min_x_m, max_y_m]] }
    }

    /// Whether (x_m, y_m) lies inside (even-odd rule). Non-finite input is outside.
    pub fn contains(&self, x_m: f64, y_m: f64) -> bool {
        let v = &self.vertices_m;
        if v.len() < 3 || !x_m.is_finite() || !y_m.is_finite() {
            return false;
        }
        let mut inside = false;
        let mut j = v.len() - 1;
        for i in 0..v.len() {
            let ([xi, yi], [xj, yj]) = (v[i], v[j]);
            if (yi > y_m) != (yj > y_m) {
                // yi != yj here, so the division is safe.
                let x_cross = xi + (y_m - yi) * (xj - xi) / (yj - yi);
                if x_m < x_cross {
                    inside = !inside;
                }
            }
            j = i;
        }
        inside
    }

    /// Area enclosed (shoelace formula, absolute value), square metres. Self-intersecting
    /// polygons give the net signed area's magnitude.
    pub fn area_m2(&self) -> f64 {
        let v = &self.vertices_m;
        if v.len() < 3 {
            return 0.0;
        }
        let mut twice = 0.0;
        for i in 0..v.len() {
            let [x0, y0] = v[i];
            let [x1, y1] = v[(i + 1) % v.len()];
            twice += x0 * y1 - x1 * y0;
        }
        0.5 * twice.abs()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rectangle_is_half_open() {
        let b = Boundary::from_bounds(0.0, 0.0, 10.0, 5.0);
        assert!(b.contains(5.0, 2.5));
        assert!(b.contains(0.0, 0.0));
        assert!(!b.contains(10.0, 2.5));
        assert!(!b.contains(5.0, 5.0));
        assert!(!b.contains(-0.01, 2.5));
        assert!(!b.contains(f64::NAN, 2.5));
        assert_eq!(b.area_m2(), 50.0);
    }

    #[test]
    fn concave_polygon_excludes_its_notch() {
        // An L: the square [0,4]² minus its top-right quarter [2,4]×[2,4].
        let b = Boundary::new(vec![[0.0, 0.0], [4.0, 0.0], [4.0, 2.0], [2.0, 2.0], [2.0, 4.0], [0.0, 4.0]]);
        assert!(b.contains(1.0, 3.0));
        assert!(b.contains(3.0, 1.0));
        assert!(!b.contains(3.0, 3.0));
        assert_eq!(b.area_m2(), 12.0);
    }

    #[test]
    fn even_odd_rule_on_a_self_intersecting_pentagram() {
        // Pentagram through every second vertex of a regular pentagon: the centre is crossed twice
        // (even) → outside; a tip is crossed once → inside.
        let p: Vec<[f64; 2]> = (0..5)
            .map(|k| {
                let a = std::f64::consts::FRAC_PI_2 + (2 * k) as f64 * std::f64::consts::TAU / 5.0;
                [a.cos(), a.sin()]
            })
            .collect();
        let b = Boundary::new(p);
        assert!(!b.contains(0.0, 0.0));
        assert!(b.contains(0.0, 0.8));
    }

    #[test]
    fn degenerate_polygons_contain_nothing() {
        assert!(!Boundary::new(vec![]).contains(0.0, 0.0));
        assert!(!Boundary::new(vec![[0.0, 0.0], [1.0, 1.0]]).contains(0.5, 0.5));
    }
}
