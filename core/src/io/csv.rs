//! CSV point clouds and landmark sets: one point per line, `x,y,z` in metres, optionally followed
//! by its position covariance. O(file size).
//!
//! Accepted:
//! - separators: commas (spaces around them are ignored); a line without any comma is split on
//!   whitespace instead;
//! - `#` starts a comment (whole line or trailing); blank lines are skipped; CRLF is fine;
//! - an optional header: the first non-blank, non-comment line is skipped if one of its fields
//!   is not a number (column names are not interpreted: columns are positional);
//! - the number of numbers per line, the same on every line:
//!   - 3: `x y z` (no covariance);
//!   - 4: `x y z σ`: isotropic standard deviation σ ≥ 0 in metres, covariance σ²·I;
//!   - 6: `x y z vxx vyy vzz`: diagonal variances (m²);
//!   - 9: `x y z cxx cxy cxz cyy cyz czz`: upper triangle of the symmetric covariance (m²);
//!   - 12: `x y z` and the full 3×3 covariance row by row (must be symmetric to 1e-9 relative).
//!
//! Errors name the 1-based line: non-numbers, non-finite coordinates, a wrong or changing number
//! of columns, negative variances.

use super::{CloudError, check_cov, cov_from_upper};
use crate::cloud::PointCloud;
use nalgebra::{Matrix3, Point3};

/// Loads a CSV point cloud; `name` is used in messages.
pub fn load_csv(bytes: &[u8], name: &str) -> Result<PointCloud, CloudError> {
    let text =
        std::str::from_utf8(bytes).map_err(|e| CloudError::Header { name: name.to_string(), detail: format!("not UTF-8 text ({e})") })?;
    let line_err = |line: usize, detail: String| CloudError::Line { name: name.to_string(), line, detail };
    let mut points = Vec::new();
    let mut covariances: Vec<Matrix3<f64>> = Vec::new();
    // (column count, line that set it)
    let mut columns: Option<(usize, usize)> = None;
    let mut seen_content = false;
    let mut values: Vec<f64> = Vec::with_capacity(12);
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let content = raw.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let first_content = !seen_content;
        seen_content = true;
        values.clear();
        let mut bad_field = None;
        let mut push = |f: &str| match f.trim().parse::<f64>() {
            Ok(v) => values.push(v),
            Err(_) => {
                if bad_field.is_none() {
                    bad_field = Some(f.trim().chars().take(40).collect::<String>());
                }
            }
        };
        if content.contains(',') {
            content.split(',').for_each(&mut push);
        } else {
            content.split_ascii_whitespace().for_each(&mut push);
        }
        if let Some(field) = bad_field {
            if first_content {
                continue; // a header line
            }
            return Err(line_err(line_no, format!("'{field}' is not a number")));
        }
        let n = values.len();
        if !matches!(n, 3 | 4 | 6 | 9 | 12) {
            return Err(line_err(
                line_no,
                format!("expected 3 (x y z), 4 (+ σ), 6 (+ variances), 9 (+ upper triangle) or 12 (+ full 3×3) numbers, found {n}"),
            ));
        }
        match columns {
            None => columns = Some((n, line_no)),
            Some((m, first)) if m != n => {
                return Err(line_err(line_no, format!("{n} numbers, but line {first} has {m}")));
            }
            Some(_) => {}
        }
        let p = Point3::new(values[0], values[1], values[2]);
        if !(p.x.is_finite() && p.y.is_finite() && p.z.is_finite()) {
            return Err(line_err(line_no, "non-finite coordinate".to_string()));
        }
        let c = &values[3..];
        let cov = match n {
            3 => None,
            4 => {
                if !(c[0].is_finite() && c[0] >= 0.0) {
                    return Err(line_err(line_no, format!("σ {} is not a finite non-negative number", c[0])));
                }
                Some(Matrix3::from_diagonal_element(c[0] * c[0]))
            }
            6 => Some(Matrix3::from_diagonal(&nalgebra::Vector3::new(c[0], c[1], c[2]))),
            9 => Some(cov_from_upper([c[0], c[1], c[2], c[3], c[4], c[5]])),
            _ => {
                let m = Matrix3::from_row_slice(c);
                let asym = (m - m.transpose()).abs().max();
                if asym.is_nan() || asym > 1e-9 * m.abs().max().max(1.0) {
                    return Err(line_err(line_no, "the 3×3 covariance is not symmetric".to_string()));
                }
                Some((m + m.transpose()) * 0.5)
            }
        };
        if let Some(m) = cov {
            check_cov(&m).map_err(|d| line_err(line_no, d))?;
            covariances.push(m);
        }
        points.push(p);
    }
    let has_cov = columns.is_some_and(|(n, _)| n > 3);
    Ok(PointCloud { points, covariances: has_cov.then_some(covariances), classification: None })
}

/// Writes `x,y,z` per line, plus the 6 upper-triangle covariance entries when the cloud has
/// covariances (9 numbers), with a header line. Numbers use the shortest exact representation,
/// so [`load_csv`] reads back the same values.
pub fn write_csv(cloud: &PointCloud) -> String {
    let (_, cov) = super::writable_attributes(cloud);
    let mut out = String::from(if cov.is_some() { "x,y,z,cov_xx,cov_xy,cov_xz,cov_yy,cov_yz,cov_zz\n" } else { "x,y,z\n" });
    for (i, p) in cloud.points.iter().enumerate() {
        out.push_str(&format!("{:?},{:?},{:?}", p.x, p.y, p.z));
        if let Some(cov) = cov {
            for v in super::cov_to_upper(&cov[i]) {
                out.push_str(&format!(",{v:?}"));
            }
        }
        out.push('\n');
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn plain_with_header_comments_blanks() {
        let text = "# landmarks\nx, y, z\n\n1,2,3\n 4 , 5 , 6 # trailing\r\n7 8 9\n";
        let c = load_csv(text.as_bytes(), "l.csv").unwrap();
        assert_eq!(c.points, vec![Point3::new(1.0, 2.0, 3.0), Point3::new(4.0, 5.0, 6.0), Point3::new(7.0, 8.0, 9.0)]);
        assert_eq!(c.covariances, None);
        assert_eq!(c.classification, None);
    }

    #[test]
    fn each_covariance_form() {
        let c = load_csv(b"0,0,0,0.5\n", "s.csv").unwrap();
        assert_eq!(c.covariances, Some(vec![Matrix3::from_diagonal_element(0.25)]));
        let c = load_csv(b"0,0,0,1,2,3\n", "d.csv").unwrap();
        assert_eq!(c.covariances, Some(vec![Matrix3::new(1.0, 0.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0, 3.0)]));
        let c = load_csv(b"0,0,0,1,0.1,0.2,2,0.3,3\n", "u.csv").unwrap();
        assert_eq!(c.covariances, Some(vec![Matrix3::new(1.0, 0.1, 0.2, 0.1, 2.0, 0.3, 0.2, 0.3, 3.0)]));
        let c = load_csv(b"0,0,0,1,0.1,0.2,0.1,2,0.3,0.2,0.3,3\n", "f.csv").unwrap();
        assert_eq!(c.covariances, Some(vec![Matrix3::new(1.0, 0.1, 0.2, 0.1, 2.0, 0.3, 0.2, 0.3, 3.0)]));
    }

    #[test]
    fn errors_name_the_line() {
        let e = load_csv(b"x,y,z\n1,2,3\n\n1,nan,3\n", "x.csv").unwrap_err();
        assert_eq!(e.to_string(), "x.csv: line 4: non-finite coordinate");
        let e = load_csv(b"1,2,3\n1,2,z\n", "x.csv").unwrap_err();
        assert_eq!(e.to_string(), "x.csv: line 2: 'z' is not a number");
        let e = load_csv(b"1,2,3,4,5\n", "x.csv").unwrap_err();
        assert!(e.to_string().starts_with("x.csv: line 1: expected 3"), "{e}");
        let e = load_csv(b"1,2,3\n1,2,3,4\n", "x.csv").unwrap_err();
        assert_eq!(e.to_string(), "x.csv: line 2: 4 numbers, but line 1 has 3");
        let e = load_csv(b"1,2,3,-1\n", "x.csv").unwrap_err();
        assert!(e.to_string().contains("σ -1"), "{e}");
        let e = load_csv(b"1,2,3,-1,1,1\n", "x.csv").unwrap_err();
        assert!(e.to_string().contains("negative variance"), "{e}");
        let e = load_csv(b"0,0,0,1,0.1,0.2,0.5,2,0.3,0.2,0.3,3\n", "x.csv").unwrap_err();
        assert!(e.to_string().contains("not symmetric"), "{e}");
        let e = load_csv(b"1,2,inf\n", "x.csv").unwrap_err();
        assert_eq!(e.to_string(), "x.csv: line 1: non-finite coordinate");
        assert!(load_csv(b"\xff\xfe", "x.csv").is_err());
    }

    #[test]
    fn empty_file_is_an_empty_cloud() {
        assert!(load_csv(b"", "e.csv").unwrap().is_empty());
        assert!(load_csv(b"x,y,z\n# nothing\n", "e.csv").unwrap().is_empty());
    }

    proptest! {
        #[test]
        fn roundtrip(pts in prop::collection::vec((-1e9f64..1e9, -1e9f64..1e9, -1e9f64..1e9, 0.0f64..5.0, -1.0f64..1.0), 0..30), with_cov in any::<bool>()) {
            let mut cloud = PointCloud::from_points(pts.iter().map(|p| Point3::new(p.0, p.1, p.2)).collect());
            if with_cov && !pts.is_empty() {
                cloud.covariances = Some(pts.iter().map(|p| cov_from_upper([p.3, p.4, 0.0, p.3 + 1.0, -p.4, 2.0])).collect());
            }
            let back = load_csv(write_csv(&cloud).as_bytes(), "r.csv").unwrap();
            prop_assert_eq!(back, cloud);
        }

        #[test]
        fn arbitrary_text_never_panics(s in "[0-9,. #\\n\\-eEnaif]{0,200}") {
            let _ = load_csv(s.as_bytes(), "x.csv");
        }

        #[test]
        fn arbitrary_bytes_never_panic(b in prop::collection::vec(any::<u8>(), 0..200)) {
            let _ = load_csv(&b, "x.csv");
        }
    }
}
