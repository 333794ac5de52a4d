//! PLY point clouds: `ascii`, `binary_little_endian` and `binary_big_endian`, reader and a binary
//! little-endian writer.
//!
//! The `vertex` element gives the points: `x`, `y`, `z` of any scalar type (`char`/`int8`,
//! `uchar`/`uint8`, `short`/`int16`, `ushort`/`uint16`, `int`/`int32`, `uint`/`uint32`,
//! `float`/`float32`, `double`/`float64`); optional `classification` and covariance properties
//! as described in [`crate::io`]. Other properties of the vertex element (scalar or list) and
//! other elements (faces, …, before or after the vertices) are skipped. O(file size).
//!
//! Hostile headers: element counts are checked against the bytes left (a binary record of a
//! known size must fit; an ascii record needs at least one byte per property) before reserving.

use super::{COV_NAMES, CloudBuilder, CloudError, FieldMap};
use crate::cloud::PointCloud;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(s: &str) -> Option<Self> {
        Some(match s {
            "char" | "int8" => Self::I8,
            "uchar" | "uint8" => Self::U8,
            "short" | "int16" => Self::I16,
            "ushort" | "uint16" => Self::U16,
            "int" | "int32" => Self::I32,
            "uint" | "uint32" => Self::U32,
            "float" | "float32" => Self::F32,
            "double" | "float64" => Self::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Self::I8 | Self::U8 => 1,
            Self::I16 | Self::U16 => 2,
            Self::I32 | Self::U32 | Self::F32 => 4,
            Self::F64 => 8,
        }
    }

    fn is_integer(self) -> bool {
        !matches!(self, Self::F32 | Self::F64)
    }

    /// Reads one value from `b` (exactly `self.size()` bytes).
    #[inline]
    fn read(self, b: &[u8], big_endian: bool) -> f64 {
        macro_rules! get {
            ($t:ty, $n:literal) => {{
                let mut a = [0u8; $n];
                a.copy_from_slice(&b[..$n]);
                if big_endian { <$t>::from_be_bytes(a) } else { <$t>::from_le_bytes(a) }
            }};
        }
        match self {
            Self::I8 => f64::from(b[0] as i8),
            Self::U8 => f64::from(b[0]),
            Self::I16 => f64::from(get!(i16, 2)),
            Self::U16 => f64::from(get!(u16, 2)),
            Self::I32 => f64::from(get!(i32, 4)),
            Self::U32 => f64::from(get!(u32, 4)),
            Self::F32 => f64::from(get!(f32, 4)),
            Self::F64 => get!(f64, 8),
        }
    }
}

#[derive(Clone, Debug)]
enum PropKind {
    Scalar(Scalar),
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
struct Property {
    name: String,
    kind: PropKind,
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: u64,
    properties: Vec<Property>,
}

impl Element {
    /// Bytes of one binary record when it has no list property.
    fn fixed_size(&self) -> Option<usize> {
        self.properties
            .iter()
            .map(|p| match p.kind {
                PropKind::Scalar(s) => Some(s.size()),
                PropKind::List { .. } => None,
            })
            .sum()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

struct Header {
    format: Format,
    elements: Vec<Element>,
    /// Byte offset of the first data byte.
    data_start: usize,
}

fn header_err(name: &str, detail: impl Into<String>) -> CloudError {
    CloudError::Header { name: name.to_string(), detail: detail.into() }
}

fn parse_header(bytes: &[u8], name: &str) -> Result<Header, CloudError> {
    if !bytes.starts_with(b"ply") {
        return Err(header_err(name, "not a PLY file (no 'ply' magic)"));
    }
    let mut pos = 0usize;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut line_no = 0usize;
    loop {
        let rest = &bytes[pos..];
        let Some(nl) = rest.iter().position(|&b| b == b'\n') else {
            return Err(header_err(name, "header has no 'end_header' line"));
        };
        line_no += 1;
        let line_bytes = &rest[..nl];
        pos += nl + 1;
        let line = std::str::from_utf8(line_bytes)
            .map_err(|_| header_err(name, format!("header line {line_no} is not text")))?
            .trim_end_matches('\r');
        let mut words = line.split_ascii_whitespace();
        let bad = |what: &str| header_err(name, format!("header line {line_no}: {what}: '{}'", line.chars().take(80).collect::<String>()));
        match words.next() {
            None => {}
            Some("ply") if line_no == 1 => {}
            Some("comment") | Some("obj_info") => {}
            Some("format") => {
                format = Some(match words.next() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::BinaryLe,
                    Some("binary_big_endian") => Format::BinaryBe,
                    _ => return Err(bad("unknown format")),
                });
            }
            Some("element") => {
                let (Some(ename), Some(count), None) = (words.next(), words.next(), words.next()) else {
                    return Err(bad("expected 'element <name> <count>'"));
                };
                let count: u64 = count.parse().map_err(|_| bad("element count is not a non-negative integer"))?;
                elements.push(Element { name: ename.to_string(), count, properties: Vec::new() });
            }
            Some("property") => {
                let element = elements.last_mut().ok_or_else(|| bad("property before any element"))?;
                let w: Vec<&str> = words.collect();
                let (kind, pname) = match w.as_slice() {
                    ["list", c, i, n] => {
                        let count =
                            Scalar::parse(c).filter(|s| s.is_integer()).ok_or_else(|| bad("list count type must be an integer type"))?;
                        let item = Scalar::parse(i).ok_or_else(|| bad("unknown list item type"))?;
                        (PropKind::List { count, item }, *n)
                    }
                    [t, n] => (PropKind::Scalar(Scalar::parse(t).ok_or_else(|| bad("unknown property type"))?), *n),
                    _ => return Err(bad("expected 'property <type> <name>' or 'property list <count type> <item type> <name>'")),
                };
                element.properties.push(Property { name: pname.to_string(), kind });
            }
            Some("end_header") => break,
            Some(_) => return Err(bad("unknown header keyword")),
        }
    }
    let format = format.ok_or_else(|| header_err(name, "header has no 'format' line"))?;
    Ok(Header { format, elements, data_start: pos })
}

/// Loads a PLY point cloud from its bytes; `name` is used in messages.
pub fn load_ply(bytes: &[u8], name: &str) -> Result<PointCloud, CloudError> {
    let header = parse_header(bytes, name)?;
    let Some(vertex_index) = header.elements.iter().position(|e| e.name == "vertex") else {
        return Err(CloudError::MissingField { name: name.to_string(), detail: "no 'vertex' element".to_string() });
    };
    let vertex = &header.elements[vertex_index];
    let map = FieldMap::find(vertex.properties.iter().map(|p| p.name.as_str()), name, "vertex element", "property")?;
    let used = map.xyz.into_iter().chain(map.classification).chain(map.cov.into_iter().flatten());
    for i in used {
        if let PropKind::List { .. } = vertex.properties[i].kind {
            return Err(header_err(name, format!("vertex property '{}' is a list, expected a scalar", vertex.properties[i].name)));
        }
    }
    let data = &bytes[header.data_start..];
    match header.format {
        Format::Ascii => {
            let first_data_line = bytes[..header.data_start].iter().filter(|&&b| b == b'\n').count() + 1;
            read_ascii(data, first_data_line, &header, vertex_index, map, name)
        }
        Format::BinaryLe => read_binary(data, &header, vertex_index, map, name, false),
        Format::BinaryBe => read_binary(data, &header, vertex_index, map, name, true),
    }
}

fn wrong_count(name: &str, declared: u64, found: usize) -> CloudError {
    CloudError::WrongPointCount { name: name.to_string(), keyword: "element vertex", declared, found: found as u64 }
}

fn read_binary(
    data: &[u8],
    header: &Header,
    vertex_index: usize,
    map: FieldMap,
    name: &str,
    big_endian: bool,
) -> Result<PointCloud, CloudError> {
    let mut pos = 0usize;
    let truncated_elem = |e: &Element| header_err(name, format!("data truncated inside element '{}'", e.name));
    for (k, element) in header.elements.iter().enumerate() {
        if k == vertex_index {
            let vertex = element;
            let min_size = vertex
                .properties
                .iter()
                .map(|p| match p.kind {
                    PropKind::Scalar(s) => s.size(),
                    PropKind::List { count, .. } => count.size(),
                })
                .sum::<usize>()
                .max(1);
            let left = data.len() - pos;
            let capacity = usize::try_from(vertex.count).unwrap_or(usize::MAX).min(left / min_size);
            let mut builder = CloudBuilder::new(name, map, capacity);
            if let Some(size) = vertex.fixed_size() {
                // Fast path: fixed-size records, only the used properties decoded.
                let available = (left / size) as u64;
                if available < vertex.count {
                    return Err(wrong_count(name, vertex.count, available as usize));
                }
                let mut offsets = Vec::with_capacity(vertex.properties.len());
                let mut scalars = Vec::with_capacity(vertex.properties.len());
                let mut o = 0;
                for p in &vertex.properties {
                    if let PropKind::Scalar(s) = p.kind {
                        offsets.push(o);
                        scalars.push(s);
                        o += s.size();
                    }
                }
                let records = &data[pos..pos + size * capacity];
                for rec in records.chunks_exact(size) {
                    builder.push(|i| scalars[i].read(&rec[offsets[i]..], big_endian))?;
                }
                return finish_last(builder, &data[pos + size * capacity..], k + 1 == header.elements.len(), vertex.count, name);
            }
            let mut values = vec![0.0f64; vertex.properties.len()];
            for _ in 0..vertex.count {
                for (slot, p) in values.iter_mut().zip(&vertex.properties) {
                    match record_value(data, &mut pos, &p.kind, big_endian) {
                        Some(v) => *slot = v,
                        None => return Err(wrong_count(name, vertex.count, builder.len())),
                    }
                }
                builder.push(|i| values[i])?;
            }
            // Elements after the vertices are not read: they cannot change the cloud.
            return finish_last(builder, &data[pos..], k + 1 == header.elements.len(), vertex.count, name);
        }
        if element.properties.is_empty() || element.count == 0 {
            continue;
        }
        if let Some(size) = element.fixed_size() {
            let need = u64::try_from(size).ok().and_then(|s| s.checked_mul(element.count)).and_then(|n| usize::try_from(n).ok());
            match need {
                Some(n) if n <= data.len() - pos => pos += n,
                _ => return Err(truncated_elem(element)),
            }
        } else {
            for _ in 0..element.count {
                for p in &element.properties {
                    if record_value(data, &mut pos, &p.kind, big_endian).is_none() {
                        return Err(truncated_elem(element));
                    }
                }
            }
        }
    }
    // The vertex element exists (checked by the caller), so the loop returned.
    Err(header_err(name, "no 'vertex' element"))
}

/// Reads one property of a binary record at `pos`, advancing it; a scalar's value, or 0 for a
/// skipped list. `None` if the data ends first.
#[inline]
fn record_value(data: &[u8], pos: &mut usize, kind: &PropKind, big_endian: bool) -> Option<f64> {
    match *kind {
        PropKind::Scalar(s) => {
            let b = data.get(*pos..*pos + s.size())?;
            *pos += s.size();
            Some(s.read(b, big_endian))
        }
        PropKind::List { count, item } => {
            let b = data.get(*pos..*pos + count.size())?;
            let n = count.read(b, big_endian);
            if n < 0.0 {
                return None;
            }
            *pos += count.size();
            let len = (n as usize).checked_mul(item.size())?;
            if len > data.len() - *pos {
                return None;
            }
            *pos += len;
            Some(0.0)
        }
    }
}

/// Whitespace-separated tokens with their 1-based line numbers.
struct Tokens<'a> {
    data: &'a [u8],
    pos: usize,
    line: usize,
}

impl<'a> Tokens<'a> {
    fn next_token(&mut self) -> Option<(&'a [u8], usize)> {
        while let Some(&b) = self.data.get(self.pos) {
            if b == b'\n' {
                self.line += 1;
            } else if !b.is_ascii_whitespace() {
                break;
            }
            self.pos += 1;
        }
        let start = self.pos;
        while self.data.get(self.pos).is_some_and(|b| !b.is_ascii_whitespace()) {
            self.pos += 1;
        }
        (self.pos > start).then(|| (&self.data[start..self.pos], self.line))
    }
}

fn parse_number(tok: &[u8]) -> Option<f64> {
    std::str::from_utf8(tok).ok()?.parse::<f64>().ok()
}

fn read_ascii(
    data: &[u8],
    first_data_line: usize,
    header: &Header,
    vertex_index: usize,
    map: FieldMap,
    name: &str,
) -> Result<PointCloud, CloudError> {
    let mut tokens = Tokens { data, pos: 0, line: first_data_line };
    let line_err = |line: usize, detail: String| CloudError::Line { name: name.to_string(), line, detail };
    for (k, element) in header.elements.iter().enumerate() {
        if element.properties.is_empty() {
            continue;
        }
        let is_vertex = k == vertex_index;
        // Each record needs at least one token of at least one byte plus a separator per property.
        let min_bytes = element.properties.len() as u64;
        let left = (data.len() - tokens.pos) as u64;
        let plausible = element.count.saturating_mul(min_bytes) <= left.saturating_add(1);
        if !is_vertex && !plausible {
            return Err(header_err(name, format!("data truncated inside element '{}'", element.name)));
        }
        let capacity = if is_vertex { usize::try_from(element.count.min(left / min_bytes + 1)).unwrap_or(0) } else { 0 };
        let mut builder = CloudBuilder::new(name, map, capacity);
        let mut values = vec![0.0f64; element.properties.len()];
        for _ in 0..element.count {
            for (slot, p) in values.iter_mut().zip(&element.properties) {
                let Some((tok, line)) = tokens.next_token() else {
                    return Err(if is_vertex {
                        wrong_count(name, element.count, builder.len())
                    } else {
                        header_err(name, format!("data truncated inside element '{}'", element.name))
                    });
                };
                let v = parse_number(tok)
                    .ok_or_else(|| line_err(line, format!("'{}' is not a number", String::from_utf8_lossy(&tok[..tok.len().min(40)]))))?;
                match p.kind {
                    PropKind::Scalar(_) => *slot = v,
                    PropKind::List { .. } => {
                        if !(v >= 0.0 && v.fract() == 0.0) {
                            return Err(line_err(line, format!("list length '{v}' is not a non-negative integer")));
                        }
                        // Each list item is one token, so a count above the bytes left is truncated data.
                        if v > (data.len() - tokens.pos) as f64 {
                            return Err(line_err(line, format!("list length {v} exceeds the data")));
                        }
                        for _ in 0..v as usize {
                            let Some((item, line)) = tokens.next_token() else {
                                return Err(line_err(line, "list truncated".to_string()));
                            };
                            parse_number(item).ok_or_else(|| line_err(line, "list item is not a number".to_string()))?;
                        }
                    }
                }
            }
            if is_vertex {
                let line = tokens.line;
                builder.push(|i| values[i]).map_err(|e| match e {
                    CloudError::NonFinitePoint { .. } => line_err(line, "non-finite coordinate".to_string()),
                    CloudError::Attribute { detail, .. } => line_err(line, detail),
                    other => other,
                })?;
            }
        }
        if is_vertex {
            // More records than declared after the last element: name the line.
            if k + 1 == header.elements.len()
                && let Some((_, line)) = tokens.next_token()
            {
                return Err(line_err(line, format!("data after the last element: the header declares {} vertices", element.count)));
            }
            return Ok(builder.finish());
        }
    }
    Err(header_err(name, "no 'vertex' element"))
}

/// The cloud of `builder` (binary data), unless the vertex element was the file's `last` and
/// bytes other than whitespace follow it (`rest`): more records than the header declares, whose
/// points would be dropped without a word (a header's count written before the data was
/// complete).
fn finish_last(builder: CloudBuilder, rest: &[u8], last: bool, declared: u64, name: &str) -> Result<PointCloud, CloudError> {
    if last && !rest.iter().all(u8::is_ascii_whitespace) {
        return Err(header_err(
            name,
            format!("{} bytes of data after the last element: the header declares {declared} vertices", rest.len()),
        ));
    }
    Ok(builder.finish())
}

/// Binary little-endian PLY: `double x y z`, then `uchar classification` if present, then
/// `double cov_xx cov_xy cov_xz cov_yy cov_yz cov_zz` if covariances are present. An attribute
/// whose length differs from the number of points is not written.
pub fn write_ply_binary(cloud: &PointCloud) -> Vec<u8> {
    let (class, cov) = super::writable_attributes(cloud);
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\ncomment written by fitslam\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\n",
        cloud.points.len()
    );
    if class.is_some() {
        header.push_str("property uchar classification\n");
    }
    if cov.is_some() {
        for c in COV_NAMES {
            header.push_str(&format!("property double {c}\n"));
        }
    }
    header.push_str("end_header\n");
    let record = 24 + usize::from(class.is_some()) + if cov.is_some() { 48 } else { 0 };
    let mut out = Vec::with_capacity(header.len() + record * cloud.points.len());
    out.extend_from_slice(header.as_bytes());
    for (i, p) in cloud.points.iter().enumerate() {
        for v in [p.x, p.y, p.z] {
            out.extend_from_slice(&v.to_le_bytes());
        }
        if let Some(c) = class {
            out.push(c[i]);
        }
        if let Some(cov) = cov {
            for v in super::cov_to_upper(&cov[i]) {
                out.extend_from_slice(&v.to_le_bytes());
            }
        }
    }
    out
}

#[cfg(test)]
mod tests;
