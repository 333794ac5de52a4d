//! PCD point clouds (PCL's format, v0.6 and v0.7): `DATA ascii`, `binary` and
//! `binary_compressed` (LZF), reader and an ascii / binary writer.
//!
//! Header keywords: `VERSION` (any), `FIELDS`, `SIZE`, `TYPE` (`I` 1/2/4/8, `U` 1/2/4/8, `F` 4/8),
//! `COUNT` (default 1 each), `WIDTH`, `HEIGHT` (default 1), `VIEWPOINT` (ignored: points are
//! returned as stored), `POINTS` (default WIDTH·HEIGHT; must equal it), `DATA`. `#` lines are
//! comments. Fields used: see [`crate::io`] (`x y z` required, `classification`, `cov_*`); a
//! field with COUNT > 1 contributes its first element; other fields (`rgb`, `normal_x`, `_`
//! padding, …) are skipped. Data is little-endian, as PCL writes it on every platform it runs on.
//! A point whose x, y and z are all NaN is PCL's "no return" (organised clouds, `is_dense`
//! false) and is left out; a partly NaN or infinite point is an error.
//!
//! `binary_compressed`: two little-endian u32 (compressed size, uncompressed size) then LZF data
//! which decompresses to the fields stored one after the other (all x, then all y, …). The
//! declared uncompressed size must equal POINTS × record size and may not exceed 88 × the
//! compressed size (LZF's maximum expansion), so hostile headers cannot make us allocate.
//! O(file size).

use super::{COV_NAMES, CloudBuilder, CloudError, FieldMap};
use crate::cloud::PointCloud;

/// LZF expands at most 264 output bytes per 3 input bytes.
const LZF_MAX_RATIO: usize = 88;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Signed,
    Unsigned,
    Float,
}

#[derive(Clone, Debug)]
struct Field {
    name: String,
    size: usize,
    kind: Kind,
    count: usize,
}

impl Field {
    /// Reads one little-endian value (exactly `self.size` bytes).
    #[inline]
    fn read(&self, b: &[u8]) -> f64 {
        let mut a = [0u8; 8];
        a[..self.size].copy_from_slice(&b[..self.size]);
        match (self.kind, self.size) {
            (Kind::Float, 4) => f64::from(f32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            (Kind::Float, _) => f64::from_le_bytes(a),
            (Kind::Unsigned, 1) => f64::from(a[0]),
            (Kind::Unsigned, 2) => f64::from(u16::from_le_bytes([a[0], a[1]])),
            (Kind::Unsigned, 4) => f64::from(u32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            (Kind::Unsigned, _) => u64::from_le_bytes(a) as f64,
            (Kind::Signed, 1) => f64::from(a[0] as i8),
            (Kind::Signed, 2) => f64::from(i16::from_le_bytes([a[0], a[1]])),
            (Kind::Signed, 4) => f64::from(i32::from_le_bytes([a[0], a[1], a[2], a[3]])),
            (Kind::Signed, _) => i64::from_le_bytes(a) as f64,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Data {
    Ascii,
    Binary,
    BinaryCompressed,
}

struct Header {
    fields: Vec<Field>,
    points: u64,
    data: Data,
    data_start: usize,
    /// 1-based file line of the first data line.
    first_data_line: usize,
}

fn header_err(name: &str, detail: impl Into<String>) -> CloudError {
    CloudError::Header { name: name.to_string(), detail: detail.into() }
}

fn parse_header(bytes: &[u8], name: &str) -> Result<Header, CloudError> {
    let mut pos = 0usize;
    let mut line_no = 0usize;
    let mut names: Option<Vec<String>> = None;
    let mut sizes: Option<Vec<usize>> = None;
    let mut types: Option<Vec<Kind>> = None;
    let mut counts: Option<Vec<usize>> = None;
    let (mut width, mut height, mut points): (Option<u64>, Option<u64>, Option<u64>) = (None, None, None);
    let data = loop {
        let rest = &bytes[pos..];
        if rest.is_empty() {
            return Err(header_err(name, "header has no DATA line"));
        }
        // The DATA line may be the last line without a newline (an empty ascii cloud).
        let nl = rest.iter().position(|&b| b == b'\n').unwrap_or(rest.len());
        line_no += 1;
        let line = std::str::from_utf8(&rest[..nl]).map_err(|_| header_err(name, format!("header line {line_no} is not text")))?.trim();
        pos = (pos + nl + 1).min(bytes.len());
        let mut words = line.split_ascii_whitespace();
        let Some(key) = words.next() else { continue };
        if key.starts_with('#') {
            continue;
        }
        let bad = |what: &str| header_err(name, format!("header line {line_no} ({key}): {what}"));
        let list: Vec<&str> = words.collect();
        let one_number = |list: &[&str]| -> Result<u64, CloudError> {
            match list {
                [v] => v.parse::<u64>().map_err(|_| bad("expected a non-negative integer")),
                _ => Err(bad("expected one integer")),
            }
        };
        match key.to_ascii_uppercase().as_str() {
            "VERSION" | "VIEWPOINT" => {}
            "FIELDS" | "COLUMNS" => names = Some(list.iter().map(|s| s.to_string()).collect()),
            "SIZE" => {
                sizes = Some(
                    list.iter()
                        .map(|s| match *s {
                            "1" => Ok(1),
                            "2" => Ok(2),
                            "4" => Ok(4),
                            "8" => Ok(8),
                            _ => Err(bad(&format!("size '{s}' is not 1, 2, 4 or 8"))),
                        })
                        .collect::<Result<_, _>>()?,
                )
            }
            "TYPE" => {
                types = Some(
                    list.iter()
                        .map(|s| match *s {
                            "I" | "i" => Ok(Kind::Signed),
                            "U" | "u" => Ok(Kind::Unsigned),
                            "F" | "f" => Ok(Kind::Float),
                            _ => Err(bad(&format!("type '{s}' is not I, U or F"))),
                        })
                        .collect::<Result<_, _>>()?,
                )
            }
            "COUNT" => {
                counts = Some(
                    list.iter()
                        .map(|s| {
                            s.parse::<u32>()
                                .ok()
                                .filter(|c| *c >= 1)
                                .map(|c| c as usize)
                                .ok_or_else(|| bad(&format!("count '{s}' is not a positive integer")))
                        })
                        .collect::<Result<_, _>>()?,
                )
            }
            "WIDTH" => width = Some(one_number(&list)?),
            "HEIGHT" => height = Some(one_number(&list)?),
            "POINTS" => points = Some(one_number(&list)?),
            "DATA" => {
                break match list.as_slice() {
                    ["ascii"] => Data::Ascii,
                    ["binary"] => Data::Binary,
                    ["binary_compressed"] => Data::BinaryCompressed,
                    _ => return Err(bad("expected ascii, binary or binary_compressed")),
                };
            }
            _ => return Err(bad("unknown header keyword")),
        }
        if pos >= bytes.len() {
            return Err(header_err(name, "header has no DATA line"));
        }
    };
    let names = names.ok_or_else(|| header_err(name, "header has no FIELDS line"))?;
    let sizes = sizes.ok_or_else(|| header_err(name, "header has no SIZE line"))?;
    let types = types.ok_or_else(|| header_err(name, "header has no TYPE line"))?;
    let counts = counts.unwrap_or_else(|| vec![1; names.len()]);
    let n = names.len();
    if sizes.len() != n || types.len() != n || counts.len() != n {
        return Err(header_err(
            name,
            format!("FIELDS has {n} entries but SIZE has {}, TYPE {} and COUNT {}", sizes.len(), types.len(), counts.len()),
        ));
    }
    let mut fields = Vec::with_capacity(n);
    for (((fname, size), kind), count) in names.into_iter().zip(sizes).zip(types).zip(counts) {
        if kind == Kind::Float && size < 4 {
            return Err(header_err(name, format!("field '{fname}': TYPE F needs SIZE 4 or 8, got {size}")));
        }
        fields.push(Field { name: fname, size, kind, count });
    }
    let width = width.ok_or_else(|| header_err(name, "header has no WIDTH line"))?;
    let height = height.unwrap_or(1);
    let wh = width.checked_mul(height).ok_or_else(|| header_err(name, "WIDTH × HEIGHT overflows"))?;
    let points = points.unwrap_or(wh);
    if points != wh {
        return Err(header_err(name, format!("WIDTH × HEIGHT = {width} × {height} = {wh} but POINTS {points}")));
    }
    Ok(Header { fields, points, data, data_start: pos, first_data_line: line_no + 1 })
}

fn wrong_count(name: &str, declared: u64, found: u64) -> CloudError {
    CloudError::WrongPointCount { name: name.to_string(), keyword: "POINTS", declared, found }
}

/// Loads a PCD point cloud; `name` is used in messages.
pub fn load_pcd(bytes: &[u8], name: &str) -> Result<PointCloud, CloudError> {
    let bytes = super::without_bom(bytes);
    let header = parse_header(bytes, name)?;
    let map = FieldMap::find(header.fields.iter().map(|f| f.name.as_str()), name, "FIELDS", "field")?;
    let data = &bytes[header.data_start..];
    match header.data {
        Data::Ascii => read_ascii(data, &header, map, name),
        Data::Binary | Data::BinaryCompressed => read_binary(data, &header, map, name),
    }
}

fn read_ascii(data: &[u8], header: &Header, map: FieldMap, name: &str) -> Result<PointCloud, CloudError> {
    let line_err = |line: usize, detail: String| CloudError::Line { name: name.to_string(), line, detail };
    // Index of each field's first value within a line's values.
    let mut first_value = Vec::with_capacity(header.fields.len());
    let mut total = 0usize;
    for f in &header.fields {
        first_value.push(total);
        total = total.checked_add(f.count).ok_or_else(|| header_err(name, "COUNT total overflows"))?;
    }
    // Every point needs at least two bytes (a digit and a line break).
    let capacity = usize::try_from(header.points).unwrap_or(usize::MAX).min(data.len() / 2 + 1);
    let mut builder = CloudBuilder::new(name, map, capacity).skipping_no_returns();
    let mut values: Vec<f64> = Vec::with_capacity(total.min(data.len()));
    let mut found = 0u64;
    for (i, raw) in data.split(|&b| b == b'\n').enumerate() {
        let line_no = header.first_data_line + i;
        let Ok(line) = std::str::from_utf8(raw) else {
            return Err(line_err(line_no, "not text".to_string()));
        };
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        found += 1;
        if found > header.points {
            continue; // counted for the error message only
        }
        values.clear();
        for tok in line.split_ascii_whitespace() {
            if values.len() == total {
                values.push(0.0); // one too many: reported below
                break;
            }
            let v = tok
                .parse::<f64>()
                .map_err(|_| line_err(line_no, format!("'{}' is not a number", tok.chars().take(40).collect::<String>())))?;
            values.push(v);
        }
        if values.len() != total {
            return Err(line_err(
                line_no,
                format!(
                    "expected {total} values, found {}",
                    if values.len() > total { "more".to_string() } else { values.len().to_string() }
                ),
            ));
        }
        builder.push(|k| values[first_value[k]]).map_err(|e| match e {
            CloudError::NonFinitePoint { .. } => line_err(line_no, "non-finite coordinate".to_string()),
            CloudError::Attribute { detail, .. } => line_err(line_no, detail),
            other => other,
        })?;
    }
    if found != header.points {
        return Err(wrong_count(name, header.points, found));
    }
    Ok(builder.finish())
}

fn read_binary(data: &[u8], header: &Header, map: FieldMap, name: &str) -> Result<PointCloud, CloudError> {
    let too_large = || header_err(name, "record size overflows");
    let mut record = 0usize;
    for f in &header.fields {
        record = f.size.checked_mul(f.count).and_then(|b| record.checked_add(b)).ok_or_else(too_large)?;
    }
    if record == 0 {
        return Err(header_err(name, "empty record"));
    }
    let declared = header.points;
    let need = usize::try_from(declared).ok().and_then(|p| p.checked_mul(record));
    let decompressed;
    // (bytes, offset of field k's first value for point 0, stride between points per field)
    let (body, offsets, strides): (&[u8], Vec<usize>, Vec<usize>) = if header.data == Data::Binary {
        let found = (data.len() / record) as u64;
        if found != declared {
            return Err(wrong_count(name, declared, found));
        }
        let mut offsets = Vec::with_capacity(header.fields.len());
        let mut o = 0;
        for f in &header.fields {
            offsets.push(o);
            o += f.size * f.count;
        }
        (data, offsets, vec![record; header.fields.len()])
    } else {
        let word = |at: usize| data.get(at..at + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize);
        let (Some(compressed), Some(uncompressed)) = (word(0), word(4)) else {
            return Err(header_err(name, "binary_compressed data has no size words"));
        };
        let payload = data.get(8..8 + compressed).ok_or_else(|| {
            header_err(
                name,
                format!(
                    "binary_compressed data truncated: {compressed} compressed bytes declared, {} present",
                    data.len().saturating_sub(8)
                ),
            )
        })?;
        if need != Some(uncompressed) {
            // The size word is the file's claim, not data found: say so (a count derived from it
            // read as if the data held that many points).
            return Err(header_err(
                name,
                format!(
                    "binary_compressed: the uncompressed size word says {uncompressed} bytes, but POINTS {declared} × {record}-byte records make {}",
                    u128::from(declared) * record as u128
                ),
            ));
        }
        if uncompressed > compressed.saturating_mul(LZF_MAX_RATIO) {
            return Err(header_err(name, format!("binary_compressed: {uncompressed} bytes cannot come from {compressed} LZF bytes")));
        }
        decompressed = lzf_decompress(payload, uncompressed).ok_or_else(|| header_err(name, "binary_compressed: corrupt LZF data"))?;
        // Structure of arrays: field k occupies points × size × count bytes.
        let points = uncompressed / record;
        let mut offsets = Vec::with_capacity(header.fields.len());
        let mut o = 0;
        for f in &header.fields {
            offsets.push(o);
            o += points * f.size * f.count;
        }
        (&decompressed[..], offsets, header.fields.iter().map(|f| f.size * f.count).collect())
    };
    let n = declared as usize; // fits: checked against the data above
    let mut builder = CloudBuilder::new(name, map, n).skipping_no_returns();
    let fields = &header.fields;
    for i in 0..n {
        builder.push(|k| {
            let at = offsets[k] + i * strides[k];
            fields[k].read(&body[at..at + fields[k].size])
        })?;
    }
    Ok(builder.finish())
}

/// LZF decompression (liblzf's format, as PCL uses): exactly `out_len` bytes or `None`.
pub(crate) fn lzf_decompress(input: &[u8], out_len: usize) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(out_len);
    let mut ip = 0usize;
    while ip < input.len() {
        let ctrl = usize::from(input[ip]);
        ip += 1;
        if ctrl < 32 {
            let len = ctrl + 1;
            let literal = input.get(ip..ip + len)?;
            if out.len() + len > out_len {
                return None;
            }
            out.extend_from_slice(literal);
            ip += len;
        } else {
            let mut len = ctrl >> 5;
            if len == 7 {
                len += usize::from(*input.get(ip)?);
                ip += 1;
            }
            len += 2;
            let back = ((ctrl & 0x1f) << 8) + usize::from(*input.get(ip)?) + 1;
            ip += 1;
            if back > out.len() || out.len() + len > out_len {
                return None;
            }
            let start = out.len() - back;
            for k in 0..len {
                let b = out[start + k];
                out.push(b);
            }
        }
    }
    (out.len() == out_len).then_some(out)
}

/// How [`write_pcd`] stores the points.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PcdEncoding {
    /// `DATA ascii`: one text line per point.
    Ascii,
    /// `DATA binary`: little-endian records, uncompressed.
    Binary,
}

/// PCD v0.7: fields `x y z` (F 8), `classification` (U 1) if present, the six `cov_*` (F 8) if
/// present; WIDTH = POINTS, HEIGHT 1. Ascii numbers use the shortest exact representation. An
/// attribute whose length differs from the number of points is not written.
pub fn write_pcd(cloud: &PointCloud, encoding: PcdEncoding) -> Vec<u8> {
    let (class, cov) = super::writable_attributes(cloud);
    let mut fields = vec!["x", "y", "z"];
    let mut sizes = vec!["8"; 3];
    let mut types = vec!["F"; 3];
    if class.is_some() {
        fields.push("classification");
        sizes.push("1");
        types.push("U");
    }
    if cov.is_some() {
        fields.extend(COV_NAMES);
        sizes.extend(["8"; 6]);
        types.extend(["F"; 6]);
    }
    let n = cloud.points.len();
    let mut out = format!(
        "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS {}\nSIZE {}\nTYPE {}\nCOUNT {}\nWIDTH {n}\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS {n}\nDATA {}\n",
        fields.join(" "),
        sizes.join(" "),
        types.join(" "),
        vec!["1"; fields.len()].join(" "),
        if encoding == PcdEncoding::Ascii { "ascii" } else { "binary" }
    )
    .into_bytes();
    for (i, p) in cloud.points.iter().enumerate() {
        let upper = cov.map(|c| super::cov_to_upper(&c[i]));
        match encoding {
            PcdEncoding::Ascii => {
                let mut line = format!("{:?} {:?} {:?}", p.x, p.y, p.z);
                if let Some(c) = class {
                    line.push_str(&format!(" {}", c[i]));
                }
                for v in upper.iter().flatten() {
                    line.push_str(&format!(" {v:?}"));
                }
                line.push('\n');
                out.extend_from_slice(line.as_bytes());
            }
            PcdEncoding::Binary => {
                for v in [p.x, p.y, p.z] {
                    out.extend_from_slice(&v.to_le_bytes());
                }
                if let Some(c) = class {
                    out.push(c[i]);
                }
                for v in upper.iter().flatten() {
                    out.extend_from_slice(&v.to_le_bytes());
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests;
