//! CSV point clouds and landmark sets: one point per line, `x,y,z` in metres, optionally with
//! its position covariance. O(file size).
//!
//! Accepted:
//! - separators: commas (spaces around them are ignored); a line without any comma is split on
//!   whitespace instead;
//! - `#` starts a comment (whole line or trailing); blank lines are skipped; CRLF is fine;
//! - a header: the first non-blank, non-comment line, when it holds names, not numbers.
//!
//! The first line is data when all its fields are numbers, a header when it names `x`, `y` and
//! `z`, and a positional header (dropped; the columns stay positional) when it holds names only,
//! none of them `x`, `y` or `z` (`east,north,up`). Otherwise it is an error naming its line: a
//! line with some numbers (`1.0,2.0,abc`, `1,1,0,`) is read as data and fails as any later line
//! would, a header naming some of x, y, z lacks a column (`x,y,intensity`: no `z`), and a line
//! joined by another separator (`1;1;0`) says so.
//!
//! A header that names `x`, `y` and `z` (case-insensitive; quotes and CloudCompare's leading
//! `//` are ignored) selects the columns **by name**, as PLY properties and PCD fields are: an
//! optional `classification` (integer 0–255) and the optional covariance `cov_xx cov_xy cov_xz
//! cov_yy cov_yz cov_zz` (m², all six or none); every other column (intensity, colour, labels) is
//! ignored unread. Every line then has the header's number of fields.
//!
//! Without a header the columns are **positional**, the same number of numbers on every line:
//!   - 3: `x y z` (no covariance);
//!   - 4: `x y z σ`: isotropic standard deviation σ ≥ 0 in metres, covariance σ²·I;
//!   - 6: `x y z vxx vyy vzz`: diagonal variances (m²);
//!   - 9: `x y z cxx cxy cxz cyy cyz czz`: upper triangle of the symmetric covariance (m²);
//!   - 12: `x y z` and the full 3×3 covariance row by row (must be symmetric to 1e-9 relative).
//!
//! Errors name the 1-based line: non-numbers (including empty fields and fields joined by another
//! separator such as `;`), non-finite coordinates, a wrong or changing number of columns, negative
//! variances, bad classifications, a first line that is neither data nor a header naming x, y, z.

use super::{CloudBuilder, CloudError, FieldMap, check_cov, cov_from_upper};
use crate::cloud::PointCloud;
use nalgebra::{Matrix3, Point3};

/// Loads a CSV point cloud; `name` is used in messages.
pub fn load_csv(bytes: &[u8], name: &str) -> Result<PointCloud, CloudError> {
    let text = std::str::from_utf8(super::without_bom(bytes))
        .map_err(|e| CloudError::Header { name: name.to_string(), detail: format!("not UTF-8 text ({e})") })?;
    // (1-based line number, content without comment and surrounding blanks)
    let mut lines = text.lines().enumerate().filter_map(|(i, raw)| {
        let content = raw.split('#').next().unwrap_or("").trim();
        (!content.is_empty()).then_some((i + 1, content))
    });
    let Some((first_no, first)) = lines.next() else {
        return Ok(PointCloud::from_points(Vec::new()));
    };
    let mut fields = Vec::new();
    split_fields(first, &mut fields);
    if fields.iter().all(|f| f.parse::<f64>().is_ok()) {
        return load_positional(std::iter::once((first_no, first)).chain(lines), name);
    }
    let header: Vec<String> = fields.iter().map(|f| column_name(f)).collect();
    let missing = ["x", "y", "z"].into_iter().find(|axis| !header.iter().any(|h| h == axis));
    let Some(missing) = missing else {
        return load_named(lines, &header, first_no, name);
    };
    if fields.iter().any(|f| f.parse::<f64>().is_ok()) {
        // Numbers with a non-number among them: a data line, which fails as a later one would.
        return load_positional(std::iter::once((first_no, first)).chain(lines), name);
    }
    if header.iter().any(|h| matches!(h.as_str(), "x" | "y" | "z")) {
        let detail = format!("the header has no '{missing}' column (a header names the x, y and z columns)");
        return Err(line_error(name, first_no, detail));
    }
    if !separator_hint(first).is_empty() {
        let shown: String = first.chars().take(40).collect();
        return Err(line_error(name, first_no, format!("'{shown}' is neither numbers nor a header{}", separator_hint(first))));
    }
    // Names only, none of them x, y or z (`east,north,up`): the columns stay positional.
    load_positional(lines, name)
}

/// A hint when `text` holds a separator this reader does not split on.
fn separator_hint(text: &str) -> &'static str {
    if text.contains([';', '|']) { " (fields are separated by commas or whitespace)" } else { "" }
}

/// The fields of a line: split on commas if it has any, else on whitespace.
fn split_fields<'a>(content: &'a str, out: &mut Vec<&'a str>) {
    out.clear();
    if content.contains(',') {
        out.extend(content.split(',').map(str::trim));
    } else {
        out.extend(content.split_ascii_whitespace());
    }
}

/// A header field as a column name: lower case, without quotes or CloudCompare's leading `//`.
fn column_name(field: &str) -> String {
    let f = field.trim().trim_matches(|c| c == '"' || c == '\'');
    f.trim_start_matches("//").trim().to_ascii_lowercase()
}

fn line_error(name: &str, line: usize, detail: String) -> CloudError {
    CloudError::Line { name: name.to_string(), line, detail }
}

fn not_a_number(name: &str, line: usize, field: &str) -> CloudError {
    if field.is_empty() {
        return line_error(name, line, "empty field where a number is expected (a trailing or doubled comma?)".to_string());
    }
    let shown: String = field.chars().take(40).collect();
    line_error(name, line, format!("'{shown}' is not a number{}", separator_hint(field)))
}

/// Columns chosen by the header's names (see the module doc).
fn load_named<'a>(
    lines: impl Iterator<Item = (usize, &'a str)>,
    header: &[String],
    header_line: usize,
    name: &str,
) -> Result<PointCloud, CloudError> {
    let map = FieldMap::find(header.iter().map(String::as_str), name, "the header", "column")?;
    let used: Vec<usize> = map.xyz.into_iter().chain(map.classification).chain(map.cov.into_iter().flatten()).collect();
    let mut values = vec![f64::NAN; header.len()];
    let mut builder = CloudBuilder::new(name, map, 0);
    let mut fields = Vec::with_capacity(header.len());
    for (line_no, content) in lines {
        split_fields(content, &mut fields);
        if fields.len() != header.len() {
            return Err(line_error(
                name,
                line_no,
                format!("{} fields, but the header (line {header_line}) names {} columns", fields.len(), header.len()),
            ));
        }
        for &i in &used {
            values[i] = fields[i].parse().map_err(|_| not_a_number(name, line_no, fields[i]))?;
        }
        builder.push(|i| values[i]).map_err(|e| match e {
            CloudError::NonFinitePoint { .. } => line_error(name, line_no, "non-finite coordinate".to_string()),
            CloudError::Attribute { detail, .. } => line_error(name, line_no, detail),
            other => other,
        })?;
    }
    Ok(builder.finish())
}

/// Columns by position: 3, 4, 6, 9 or 12 numbers per line (see the module doc).
fn load_positional<'a>(lines: impl Iterator<Item = (usize, &'a str)>, name: &str) -> Result<PointCloud, CloudError> {
    let line_err = |line: usize, detail: String| line_error(name, line, detail);
    let mut points = Vec::new();
    let mut covariances: Vec<Matrix3<f64>> = Vec::new();
    // (column count, line that set it)
    let mut columns: Option<(usize, usize)> = None;
    let mut fields = Vec::new();
    let mut values: Vec<f64> = Vec::with_capacity(12);
    for (line_no, content) in lines {
        split_fields(content, &mut fields);
        values.clear();
        for f in &fields {
            values.push(f.parse().map_err(|_| not_a_number(name, line_no, f))?);
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
            check_cov(&m).map_err(|e| line_err(line_no, e.to_string()))?;
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
    fn a_header_naming_x_y_z_selects_columns_by_name() {
        // Reordered columns and a label column that is never read.
        let c = load_csv(b"id,Z,x,y,label\n0,3,1,2,rock\n1, 6 ,4,5,sand\n", "n.csv").unwrap();
        assert_eq!(c.points, vec![Point3::new(1.0, 2.0, 3.0), Point3::new(4.0, 5.0, 6.0)]);
        assert_eq!((c.covariances, c.classification), (None, None));
        // A fourth column named otherwise is not a σ (positionally it would be).
        let c = load_csv(b"x,y,z,intensity\n1,2,3,200\n", "i.csv").unwrap();
        assert_eq!(c.covariances, None);
        // CloudCompare's export, whitespace-separated, colours ignored.
        let c = load_csv(b"//X Y Z R G B\n1 2 3 255 0 0\n", "cc.txt.csv").unwrap();
        assert_eq!(c.points, vec![Point3::new(1.0, 2.0, 3.0)]);
        assert_eq!(c.covariances, None);
        // Classification and covariance by name, in any order.
        let text = "\"cov_zz\",cov_yz,cov_yy,cov_xz,cov_xy,cov_xx,Classification,z,y,x\n3,0.3,2,0.2,0.1,1,2,9,8,7\n";
        let c = load_csv(text.as_bytes(), "c.csv").unwrap();
        assert_eq!(c.points, vec![Point3::new(7.0, 8.0, 9.0)]);
        assert_eq!(c.classification, Some(vec![2]));
        assert_eq!(c.covariances, Some(vec![Matrix3::new(1.0, 0.1, 0.2, 0.1, 2.0, 0.3, 0.2, 0.3, 3.0)]));
    }

    #[test]
    fn a_header_without_x_y_z_keeps_columns_positional() {
        let c = load_csv(b"east,north,up,sigma\n1,2,3,0.5\n", "p.csv").unwrap();
        assert_eq!(c.points, vec![Point3::new(1.0, 2.0, 3.0)]);
        assert_eq!(c.covariances, Some(vec![Matrix3::from_diagonal_element(0.25)]));
    }

    /// A bad first line was once taken for a header and dropped, the file read without it.
    #[test]
    fn a_bad_first_line_is_an_error_not_a_header() {
        let e = load_csv(b"1.0,2.0,abc\n4,5,6\n", "b.csv").unwrap_err();
        assert_eq!(e.to_string(), "b.csv: line 1: 'abc' is not a number");
        // A trailing comma fails on line 1 as on any later line.
        let e = load_csv(b"1,1,0,\n", "b.csv").unwrap_err();
        assert_eq!(e.to_string(), "b.csv: line 1: empty field where a number is expected (a trailing or doubled comma?)");
        let e = load_csv(b"# c\n1,1,0,\n2,2,0,\n", "b.csv").unwrap_err();
        assert_eq!(e.to_string(), "b.csv: line 2: empty field where a number is expected (a trailing or doubled comma?)");
        let e = load_csv(b"1,1,0\n2,2,0,\n", "b.csv").unwrap_err();
        assert_eq!(e.to_string(), "b.csv: line 2: empty field where a number is expected (a trailing or doubled comma?)");
        // A header naming x and y but no z.
        for header in ["x,y,intensity", "x,y,zz", "X Y label"] {
            let e = load_csv(format!("{header}\n1,2,3\n").as_bytes(), "h.csv").unwrap_err();
            assert_eq!(e.to_string(), "h.csv: line 1: the header has no 'z' column (a header names the x, y and z columns)", "{header}");
        }
        let e = load_csv(b"z,x\n1,2\n", "h.csv").unwrap_err();
        assert!(e.to_string().starts_with("h.csv: line 1: the header has no 'y' column"), "{e}");
        // A separator the reader does not split on: one field, not a number.
        let e = load_csv(b"1;1;0\n", "s.csv").unwrap_err();
        assert_eq!(e.to_string(), "s.csv: line 1: '1;1;0' is neither numbers nor a header (fields are separated by commas or whitespace)");
        let e = load_csv(b"1,1,0\n1;1;0\n", "s.csv").unwrap_err();
        assert_eq!(e.to_string(), "s.csv: line 2: '1;1;0' is not a number (fields are separated by commas or whitespace)");
    }

    #[test]
    fn named_columns_errors_name_the_line() {
        let e = load_csv(b"x,y,z,label\n1,2,3,a\n1,2,3\n", "n.csv").unwrap_err();
        assert_eq!(e.to_string(), "n.csv: line 3: 3 fields, but the header (line 1) names 4 columns");
        let e = load_csv(b"# c\nx,y,z,label\n1,2,q,a\n", "n.csv").unwrap_err();
        assert_eq!(e.to_string(), "n.csv: line 3: 'q' is not a number");
        let e = load_csv(b"x,y,z\n1,inf,3\n", "n.csv").unwrap_err();
        assert_eq!(e.to_string(), "n.csv: line 2: non-finite coordinate");
        let e = load_csv(b"x,y,z,classification\n1,2,3,2.5\n", "n.csv").unwrap_err();
        assert_eq!(e.to_string(), "n.csv: line 2: classification 2.5 is not an integer in 0..=255");
        let e = load_csv(b"x,y,z,cov_xx,cov_yy,cov_zz\n1,2,3,1,1,1\n", "n.csv").unwrap_err();
        assert!(e.to_string().starts_with("n.csv: the header has some covariance columns but no 'cov_xy'"), "{e}");
        let e = load_csv(b"x,y,z,cov_xx,cov_xy,cov_xz,cov_yy,cov_yz,cov_zz\n0,0,0,-1,0,0,1,0,1\n", "n.csv").unwrap_err();
        assert_eq!(e.to_string(), "n.csv: line 2: negative variance on the covariance diagonal");
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

        /// Named headers (any subset and order of the known names and others) over arbitrary
        /// rows: an error or a cloud whose attributes have one entry per point.
        #[test]
        fn named_headers_over_arbitrary_rows_never_panic(
            header in prop::sample::subsequence(
                vec!["x", "y", "z", "Classification", "cov_xx", "cov_xy", "cov_xz", "cov_yy", "cov_yz", "cov_zz", "label", "//X"], 0..12
            ).prop_shuffle(),
            rows in "[0-9,. #\\n\\-eEnaifab]{0,200}",
        ) {
            let text = format!("{}\n{rows}", header.join(","));
            if let Ok(c) = load_csv(text.as_bytes(), "n.csv") {
                prop_assert!(c.covariances.as_ref().is_none_or(|v| v.len() == c.points.len()));
                prop_assert!(c.classification.as_ref().is_none_or(|v| v.len() == c.points.len()));
            }
        }
    }
}
