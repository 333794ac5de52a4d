//! The Victoria Park data set as GTSAM's `load2D` reads it (gtsam/slam/dataset.cpp):
//!
//! - `ODOMETRY i j dx dy dθ v1..v6`: a `Pose2` between factor. The six numbers are a
//!   *covariance* whose layout GTSAM's `NoiseFormatAUTO` guesses: `v1 ≠ 0, v2 = 0, v3 = 0,
//!   v4 ≠ 0, v5 = 0, v6 ≠ 0` is COV, `[[v1, v2, v3], [v2, v4, v5], [v3, v5, v6]]`;
//!   `v1 ≠ 0, v2 = 0, v3 ≠ 0, v4 ≠ 0, v5 = v6 = 0` is GRAPH (TORO order),
//!   `[[v1, v2, v5], [v2, v3, v6], [v5, v6, v4]]`; anything else is an error.
//! - `LANDMARK i l x y v1 v2 v3`: landmark `l` seen from pose `i` at (x, y) in the robot frame,
//!   turned into a bearing-range factor with bearing `atan2(y, x)`, range `√(x² + y²)` and,
//!   when |v1 − v3| < 1e-4, σ_bearing = √(v1/10) rad, σ_range = √v1 m (GTSAM: "assume it
//!   describes the uncertainty at a range of 10 m"); otherwise σ = 1 for both.
//!
//! Initial values follow `load2D` in file order: an unknown pose `i` starts at the identity, an
//! unknown `j` at `x_i · z_ij`, an unknown landmark at `x_i · (x, y)`. Reading is one pass,
//! O(size); errors name the 1-based line.

use std::collections::BTreeMap;

use nalgebra::{Matrix3, Vector2};
use thiserror::Error;

use super::factors::{BearingRange2, BetweenSe2, GaussianNoise, NoiseError, Se2Residual};
use super::lie::Se2;
use super::problem::{Gauge, GaugeError, Problem};
use super::values::{VarId, Variable};
use crate::math;

/// Why a Victoria Park file could not be read or turned into a [`Problem`].
#[derive(Clone, Debug, Error, PartialEq)]
pub enum VictoriaError {
    /// A line is not valid UTF-8.
    #[error("line {line}: not valid UTF-8")]
    NotUtf8 {
        /// 1-based line number.
        line: usize,
    },
    /// A line starts with a tag other than `ODOMETRY` and `LANDMARK`.
    #[error("line {line}: unknown tag `{tag}`")]
    UnknownTag {
        /// 1-based line number.
        line: usize,
        /// The tag.
        tag: String,
    },
    /// A line has the wrong number of fields after its tag.
    #[error("line {line}: {tag} needs {expected} fields, found {found}")]
    FieldCount {
        /// 1-based line number.
        line: usize,
        /// The line's tag.
        tag: &'static str,
        /// Fields the tag needs after it.
        expected: usize,
        /// Fields the line has after its tag.
        found: usize,
    },
    /// A field is not a finite number (or, where an id is expected, not an unsigned integer).
    #[error("line {line}: field {field} (`{text}`) is not a finite number or id")]
    BadNumber {
        /// 1-based line number.
        line: usize,
        /// 1-based position of the field after the tag.
        field: usize,
        /// The field's text.
        text: String,
    },
    /// An `ODOMETRY` covariance in neither of GTSAM's COV and GRAPH layouts.
    #[error("line {line}: unrecognised covariance layout (neither GTSAM COV nor GRAPH)")]
    UnknownNoiseFormat {
        /// 1-based line number.
        line: usize,
    },
    /// The covariance or sigmas cannot make a noise model (not positive definite, not finite).
    #[error("line {line}: noise: {source}")]
    Noise {
        /// 1-based line number.
        line: usize,
        /// What is wrong with the noise.
        source: NoiseError,
    },
    /// An `ODOMETRY` line from a pose to itself.
    #[error("line {line}: odometry connects pose {id} to itself")]
    SelfLoop {
        /// 1-based line number.
        line: usize,
        /// The pose id.
        id: u64,
    },
    /// The gauge (which variables are held fixed) could not be applied.
    #[error("gauge: {0}")]
    Gauge(#[from] GaugeError),
}

/// One line of the file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VictoriaRecord {
    /// `ODOMETRY`: a relative pose between two poses.
    Odometry {
        /// The pose the measurement is taken from.
        from: u64,
        /// The pose measured.
        to: u64,
        /// Pose of `to` in the frame of `from` (x, y in metres, θ in radians).
        measurement: Se2,
        /// Its noise, from the line's covariance.
        noise: GaussianNoise,
    },
    /// `LANDMARK`: a landmark seen from a pose, as bearing and range in the robot frame.
    Landmark {
        /// The pose id.
        pose: u64,
        /// The landmark id.
        landmark: u64,
        /// Bearing from the robot's x axis, radians.
        bearing_rad: f64,
        /// Range, metres.
        range_m: f64,
        /// Noise of (bearing, range) (see the module doc).
        noise: GaussianNoise,
    },
}

/// The records in file order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VictoriaPark {
    /// One record per `ODOMETRY` or `LANDMARK` line, in file order.
    pub records: Vec<VictoriaRecord>,
}

fn parse_num(tokens: &[&str], i: usize, line: usize) -> Result<f64, VictoriaError> {
    match tokens[i].parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(VictoriaError::BadNumber { line, field: i + 1, text: tokens[i].to_string() }),
    }
}

fn parse_id(tokens: &[&str], i: usize, line: usize) -> Result<u64, VictoriaError> {
    tokens[i].parse().map_err(|_| VictoriaError::BadNumber { line, field: i + 1, text: tokens[i].to_string() })
}

/// GTSAM's `NoiseFormatAUTO` guess, as a covariance matrix.
fn auto_covariance(v: [f64; 6], line: usize) -> Result<Matrix3<f64>, VictoriaError> {
    let nz = |x: f64| x != 0.0;
    if nz(v[0]) && !nz(v[1]) && nz(v[2]) && nz(v[3]) && !nz(v[4]) && !nz(v[5]) {
        Ok(Matrix3::new(v[0], v[1], v[4], v[1], v[2], v[5], v[4], v[5], v[3]))
    } else if nz(v[0]) && !nz(v[1]) && !nz(v[2]) && nz(v[3]) && !nz(v[4]) && nz(v[5]) {
        Ok(Matrix3::new(v[0], v[1], v[2], v[1], v[3], v[4], v[2], v[4], v[5]))
    } else {
        Err(VictoriaError::UnknownNoiseFormat { line })
    }
}

/// Parses the Victoria Park text format.
pub fn read_victoria(bytes: &[u8]) -> Result<VictoriaPark, VictoriaError> {
    let mut out = VictoriaPark::default();
    for (n, raw) in crate::io::without_bom(bytes).split(|&b| b == b'\n').enumerate() {
        let line = n + 1;
        let text = std::str::from_utf8(raw).map_err(|_| VictoriaError::NotUtf8 { line })?;
        let mut it = text.split_ascii_whitespace();
        let Some(tag) = it.next() else { continue };
        let t: Vec<&str> = it.collect();
        let count = |tag: &'static str, expected: usize| {
            if t.len() == expected { Ok(()) } else { Err(VictoriaError::FieldCount { line, tag, expected, found: t.len() }) }
        };
        match tag {
            "ODOMETRY" => {
                count("ODOMETRY", 11)?;
                let (from, to) = (parse_id(&t, 0, line)?, parse_id(&t, 1, line)?);
                if from == to {
                    return Err(VictoriaError::SelfLoop { line, id: from });
                }
                let measurement = Se2::new(parse_num(&t, 2, line)?, parse_num(&t, 3, line)?, parse_num(&t, 4, line)?);
                let mut v = [0.0; 6];
                for (k, slot) in v.iter_mut().enumerate() {
                    *slot = parse_num(&t, 5 + k, line)?;
                }
                let cov = auto_covariance(v, line)?;
                let noise = GaussianNoise::from_covariance(&cov).map_err(|source| VictoriaError::Noise { line, source })?;
                out.records.push(VictoriaRecord::Odometry { from, to, measurement, noise });
            }
            "LANDMARK" => {
                count("LANDMARK", 7)?;
                let (pose, landmark) = (parse_id(&t, 0, line)?, parse_id(&t, 1, line)?);
                let (x, y) = (parse_num(&t, 2, line)?, parse_num(&t, 3, line)?);
                let (v1, v3) = (parse_num(&t, 4, line)?, parse_num(&t, 6, line)?);
                parse_num(&t, 5, line)?;
                let (sb, sr) = if (v1 - v3).abs() < 1e-4 { ((v1 / 10.0).sqrt(), v1.sqrt()) } else { (1.0, 1.0) };
                let noise = GaussianNoise::from_sigmas(&[sb, sr]).map_err(|source| VictoriaError::Noise { line, source })?;
                out.records.push(VictoriaRecord::Landmark {
                    pose,
                    landmark,
                    bearing_rad: math::atan2(y, x),
                    range_m: (x * x + y * y).sqrt(),
                    noise,
                });
            }
            other => return Err(VictoriaError::UnknownTag { line, tag: other.to_string() }),
        }
    }
    Ok(out)
}

impl VictoriaPark {
    /// Builds the factor graph and initial values (as `load2D`), then applies `gauge`.
    pub fn to_problem(&self, gauge: Gauge, se2_residual: Se2Residual) -> Result<Problem, VictoriaError> {
        let mut poses: BTreeMap<u64, Se2> = BTreeMap::new();
        let mut landmarks: BTreeMap<u64, Vector2<f64>> = BTreeMap::new();
        for r in &self.records {
            match r {
                VictoriaRecord::Odometry { from, to, measurement, .. } => {
                    let xi = *poses.entry(*from).or_insert_with(Se2::identity);
                    poses.entry(*to).or_insert(xi * *measurement);
                }
                VictoriaRecord::Landmark { pose, landmark, bearing_rad, range_m, .. } => {
                    let xi = *poses.entry(*pose).or_insert_with(Se2::identity);
                    let local = Vector2::new(math::cos(*bearing_rad), math::sin(*bearing_rad)) * *range_m;
                    landmarks.entry(*landmark).or_insert_with(|| xi.transform_point(&local));
                }
            }
        }
        let mut problem = Problem::default();
        let mut pose_var: BTreeMap<u64, VarId> = BTreeMap::new();
        let mut lm_var: BTreeMap<u64, VarId> = BTreeMap::new();
        for (id, p) in &poses {
            let v = problem.values.push(Variable::Se2(*p));
            pose_var.insert(*id, v);
            problem.poses.push((*id, v));
        }
        for (id, m) in &landmarks {
            let v = problem.values.push(Variable::Point2(*m));
            lm_var.insert(*id, v);
            problem.landmarks.push((*id, v));
        }
        let get = |map: &BTreeMap<u64, VarId>, id: &u64| map.get(id).copied().unwrap_or(VarId(usize::MAX));
        for r in &self.records {
            let added = match r {
                VictoriaRecord::Odometry { from, to, measurement, noise } => problem
                    .graph
                    .add(BetweenSe2::new(get(&pose_var, from), get(&pose_var, to), *measurement, *noise).with_residual(se2_residual)),
                VictoriaRecord::Landmark { pose, landmark, bearing_rad, range_m, noise } => {
                    problem.graph.add(BearingRange2::new(get(&pose_var, pose), get(&lm_var, landmark), *bearing_rad, *range_m, *noise))
                }
            };
            added.map_err(|g| VictoriaError::Gauge(GaugeError::Graph(g)))?;
        }
        problem.apply_gauge(gauge)?;
        Ok(problem)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_gtsam_semantics() {
        let text = b"ODOMETRY 0 1 1.0 0 0.5 0.0001 0 0 4e-06 0 4e-06\nLANDMARK 1 7 3 4 0.4 0 0.4\n";
        let vp = read_victoria(text).unwrap();
        let VictoriaRecord::Odometry { noise, .. } = vp.records[0] else { panic!("odometry") };
        // COV layout: σ = (0.01, 0.002, 0.002) → information diag (1e4, 2.5e5, 2.5e5).
        let info = noise.information();
        assert!((info[(0, 0)] - 1e4).abs() < 1e-6 && (info[(1, 1)] - 2.5e5).abs() < 1e-4 && (info[(2, 2)] - 2.5e5).abs() < 1e-4);
        let VictoriaRecord::Landmark { bearing_rad, range_m, noise, .. } = vp.records[1] else { panic!("landmark") };
        assert!((bearing_rad - 4f64.atan2(3.0)).abs() < 1e-15 && (range_m - 5.0).abs() < 1e-15);
        // σ_b = √0.04 = 0.2, σ_r = √0.4.
        let info = noise.information();
        assert!((info[(0, 0)] - 25.0).abs() < 1e-9 && (info[(1, 1)] - 2.5).abs() < 1e-9);
        // Initial values: x1 = (1, 0, 0.5); landmark = x1 · (3, 4).
        let p = vp.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
        let m = p.values.point2(p.landmarks[0].1).unwrap();
        let expected = Se2::new(1.0, 0.0, 0.5).transform_point(&Vector2::new(3.0, 4.0));
        assert!((m - expected).norm() < 1e-12);
        assert!(p.graph.chi2(&p.values).unwrap() < 1e-20);
    }

    #[test]
    fn errors_name_the_line() {
        assert_eq!(read_victoria(b"ODOMETRY 0 1 1 0 0 1 2 3 4 5 6\n"), Err(VictoriaError::UnknownNoiseFormat { line: 1 }));
        assert_eq!(read_victoria(b"\nLANDMARK 0 1 2 y 0.4 0 0.4\n"), Err(VictoriaError::BadNumber { line: 2, field: 4, text: "y".into() }));
        assert!(matches!(read_victoria(b"BR 0 1 0 1 1 1\n"), Err(VictoriaError::UnknownTag { line: 1, .. })));
    }

    #[test]
    fn real_file_counts() {
        let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/data/slam/victoria_park.txt");
        let vp = read_victoria(&std::fs::read(path).unwrap()).unwrap();
        assert_eq!(vp.records.len(), 6968 + 3640);
        let p = vp.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
        assert_eq!(p.poses.len(), 6969);
        assert!(!p.landmarks.is_empty());
    }
}
