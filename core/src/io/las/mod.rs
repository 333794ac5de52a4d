//! LAS point clouds (ASPRS LAS 1.0–1.4) through the `las` crate, read from a `Cursor` over the
//! bytes; LAZ when the crate's `laz` feature is enabled (see `core/Cargo.toml`), otherwise a
//! clear "unsupported" error (the feature is on by default: it builds for
//! `wasm32-unknown-unknown`). Coordinates are `raw · scale + offset` in the file's units (no
//! reprojection, no unit conversion); the ASPRS classification is kept. O(points).
//!
//! Before handing the bytes to the crate, the public header is checked here, because the crate
//! trusts it: the point records (offset + count × record length) must lie inside the input for
//! LAS, an extended VLR must fit in the input, and for LAZ the declared count may not exceed
//! 100 × the file size and the chunk table (which the `laz` crate
//! reserves for up front) may not declare more chunks than the file has bytes; and the x, y, z
//! scale factors must be finite and non-zero and the offsets finite; for LAZ, the LASzip items
//! and the layered chunks' sizes too (`laszip.rs`). Points are then read in
//! batches of at most 4 MiB of records (`BATCH_BYTES`), so memory follows the points actually present
//! whatever record length the header declares.
//!
//! The `laz` decoder trusts the compressed stream: corrupt data makes it panic (index out of
//! bounds, failed assertions, arithmetic overflow in debug builds) rather than return an error.
//! Decoding therefore runs inside `catch_unwind`, and such a panic becomes a [`CloudError::Las`]
//! naming the file ("corrupt LAZ data"). The panic's own message still goes to the panic hook
//! (stderr by default); on `wasm32-unknown-unknown`, where panics abort, a corrupt LAZ file
//! still traps.

mod laszip;

use super::CloudError;
use crate::cloud::PointCloud;
use nalgebra::Point3;
use std::io::Cursor;

/// Most points read per batch.
const BATCH_POINTS: u64 = 65_536;
/// Most bytes of point records read per batch (a record is at most 65,535 bytes).
const BATCH_BYTES: u64 = 4 << 20;
/// LAZ compresses a real point to a few bytes; a hundred points per byte is beyond any real file.
pub(crate) const LAZ_MAX_POINTS_PER_BYTE: u64 = 100;

fn las_err(name: &str, detail: impl Into<String>) -> CloudError {
    CloudError::Las { name: name.to_string(), detail: detail.into() }
}

fn u16_at(b: &[u8], at: usize) -> Option<u16> {
    Some(u16::from_le_bytes(b.get(at..at + 2)?.try_into().ok()?))
}
fn u32_at(b: &[u8], at: usize) -> Option<u32> {
    Some(u32::from_le_bytes(b.get(at..at + 4)?.try_into().ok()?))
}
fn u64_at(b: &[u8], at: usize) -> Option<u64> {
    Some(u64::from_le_bytes(b.get(at..at + 8)?.try_into().ok()?))
}
fn f64_at(b: &[u8], at: usize) -> Option<f64> {
    u64_at(b, at).map(f64::from_bits)
}

/// Offsets of the public header's x, y, z scale factors; the x, y, z offsets follow them.
const SCALE_AT: usize = 131;
const OFFSET_AT: usize = 155;

/// Checks the coordinate transforms: each scale factor finite and non-zero (a zero one puts every
/// point on one coordinate), each offset finite.
fn check_transforms(bytes: &[u8], name: &str) -> Result<(), CloudError> {
    let short = || las_err(name, "file shorter than its public header");
    for (k, axis) in ["x", "y", "z"].into_iter().enumerate() {
        let scale = f64_at(bytes, SCALE_AT + 8 * k).ok_or_else(short)?;
        if !scale.is_finite() || scale == 0.0 {
            return Err(CloudError::Header {
                name: name.to_string(),
                detail: format!("LAS header: {axis} scale factor is {scale} (must be a finite non-zero number)"),
            });
        }
        let offset = f64_at(bytes, OFFSET_AT + 8 * k).ok_or_else(short)?;
        if !offset.is_finite() {
            return Err(CloudError::Header {
                name: name.to_string(),
                detail: format!("LAS header: {axis} offset is {offset} (must be a finite number)"),
            });
        }
    }
    Ok(())
}

/// What [`preflight`] reads from the public header.
struct Layout {
    /// Number of point records.
    count: u64,
    /// Bytes per point record.
    record_len: u64,
    /// LAZ: the point data is compressed.
    compressed: bool,
}

/// Checks the fields of the public header block the `las` crate trusts.
fn preflight(bytes: &[u8], name: &str) -> Result<Layout, CloudError> {
    if !bytes.starts_with(b"LASF") {
        return Err(las_err(name, "not a LAS file (no 'LASF' signature)"));
    }
    let short = || las_err(name, "file shorter than its public header");
    let minor = *bytes.get(25).ok_or_else(short)?;
    let offset_to_points = u64::from(u32_at(bytes, 96).ok_or_else(short)?);
    let format_byte = *bytes.get(104).ok_or_else(short)?;
    let record_len = u64::from(u16_at(bytes, 105).ok_or_else(short)?);
    let legacy_count = u64::from(u32_at(bytes, 107).ok_or_else(short)?);
    let compressed = format_byte & 0x80 != 0 || format_byte & 0x40 != 0;
    check_transforms(bytes, name)?;
    let mut count = legacy_count;
    if minor >= 4 {
        let start_of_evlr = u64_at(bytes, 235).ok_or_else(short)?;
        let evlr_count = u32_at(bytes, 243).ok_or_else(short)?;
        let large_count = u64_at(bytes, 247).ok_or_else(short)?;
        if legacy_count == 0 {
            count = large_count;
        }
        if evlr_count > 0 {
            let len = bytes.len() as u64;
            let fits = start_of_evlr
                .checked_add(60)
                .filter(|end| *end <= len)
                .and_then(|end| u64_at(bytes, start_of_evlr as usize + 20).map(|data_len| (end, data_len)))
                .is_some_and(|(end, data_len)| data_len <= len - end);
            if !fits {
                return Err(las_err(name, "extended VLR lies outside the file"));
            }
        }
    }
    let len = bytes.len() as u64;
    if compressed {
        if count > len.saturating_mul(LAZ_MAX_POINTS_PER_BYTE) {
            return Err(CloudError::WrongPointCount {
                name: name.to_string(),
                keyword: "number of point records",
                declared: count,
                found: 0,
            });
        }
        let data_end = check_chunk_table(bytes, offset_to_points, name)?;
        laszip::check_laszip(bytes, record_len, offset_to_points, data_end, name)?;
    } else {
        let end = count.checked_mul(record_len).and_then(|b| b.checked_add(offset_to_points));
        if end.is_none_or(|e| e > len) {
            let found = len.saturating_sub(offset_to_points).checked_div(record_len).unwrap_or(0);
            return Err(CloudError::WrongPointCount { name: name.to_string(), keyword: "number of point records", declared: count, found });
        }
    }
    Ok(Layout { count, record_len, compressed })
}

/// Mirrors laz's `ChunkTable::read_offset`: the i64 at the start of the point data (or, when it
/// does not point forward, the file's last 8 bytes) locates the table `[u32 version, u32 count]`.
/// Returns where the point data ends: at the table, or at the end of the file without one.
fn check_chunk_table(bytes: &[u8], data_start: u64, name: &str) -> Result<u64, CloudError> {
    let len = bytes.len() as u64;
    let i64_at = |at: usize| u64_at(bytes, at).map(|v| v as i64);
    let Ok(start) = usize::try_from(data_start) else { return Ok(len) };
    let forward = |v: Option<i64>| v.filter(|&o| o > data_start as i64);
    let offset = forward(i64_at(start)).or_else(|| forward(bytes.len().checked_sub(8).and_then(i64_at)));
    let chunks = offset.and_then(|o| usize::try_from(o).ok()).and_then(|t| t.checked_add(4)).and_then(|at| u32_at(bytes, at));
    if let Some(chunks) = chunks.filter(|&c| c as usize > bytes.len()) {
        return Err(las_err(name, format!("LAZ chunk table declares {chunks} chunks in a {} byte file", bytes.len())));
    }
    Ok(offset.and_then(|o| u64::try_from(o).ok()).map_or(len, |o| o.min(len)))
}

/// Loads a LAS (or, with the `laz` feature, LAZ) point cloud; `name` is used in messages.
pub(crate) fn load_las(bytes: &[u8], name: &str) -> Result<PointCloud, CloudError> {
    let layout = preflight(bytes, name)?;
    if layout.compressed && !cfg!(feature = "laz") {
        return Err(CloudError::Unsupported {
            name: name.to_string(),
            what: "LAZ (compressed LAS) in this build (convert to .las or .ply)".to_string(),
        });
    }
    if !layout.compressed {
        return read_points(bytes, &layout, name);
    }
    std::panic::catch_unwind(|| read_points(bytes, &layout, name))
        .unwrap_or_else(|_| Err(las_err(name, "corrupt LAZ data (the decoder failed on the compressed points)")))
}

/// Reads every point through the `las` crate, in batches.
fn read_points(bytes: &[u8], layout: &Layout, name: &str) -> Result<PointCloud, CloudError> {
    let count = layout.count;
    // The crate needs an owned, 'static reader; the copy costs one pass over the file.
    let mut reader = las::Reader::new(Cursor::new(bytes.to_vec())).map_err(|e| las_err(name, e.to_string()))?;
    let declared = reader.header().number_of_points();
    if declared != count {
        return Err(las_err(name, format!("header point counts disagree ({declared} vs {count})")));
    }
    let capacity = usize::try_from(count).unwrap_or(usize::MAX).min(bytes.len() / 20 + 1);
    let mut points = Vec::with_capacity(capacity);
    let mut classification = Vec::with_capacity(capacity);
    let per_batch = (BATCH_BYTES / layout.record_len.max(1)).clamp(1, BATCH_POINTS);
    let mut batch = las::PointDataBuilder::new().for_header(reader.header()).build();
    loop {
        let n = reader.fill_points(per_batch, &mut batch).map_err(|e| las_err(name, e.to_string()))?;
        if n == 0 {
            break;
        }
        for ((x, y), z) in batch.x().zip(batch.y()).zip(batch.z()) {
            if !(x.is_finite() && y.is_finite() && z.is_finite()) {
                return Err(CloudError::NonFinitePoint { name: name.to_string(), index: points.len() });
            }
            points.push(Point3::new(x, y, z));
        }
        classification.extend(batch.classification());
    }
    if points.len() as u64 != count {
        return Err(CloudError::WrongPointCount {
            name: name.to_string(),
            keyword: "number of point records",
            declared: count,
            found: points.len() as u64,
        });
    }
    Ok(PointCloud { points, covariances: None, classification: Some(classification) })
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    const VEG: &[u8] = include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/data/lidar/vegetation_1_3.las"));

    #[test]
    fn reads_real_las_with_classes() {
        let c = load_las(VEG, "vegetation_1_3.las").unwrap();
        assert_eq!(c.len(), 10_683);
        let class = c.classification.as_ref().unwrap();
        assert_eq!(class.len(), 10_683);
        assert!(class.iter().all(|&k| k == 11), "SOURCES.md: all class 11");
    }

    #[test]
    fn truncated_and_garbage_are_errors() {
        let e = load_las(&VEG[..VEG.len() - 100], "v.las").unwrap_err();
        assert!(matches!(e, CloudError::WrongPointCount { declared: 10_683, .. }), "{e}");
        assert!(e.to_string().starts_with("v.las: header says number of point records 10683 but the data holds"), "{e}");
        assert!(load_las(b"LASF", "v.las").is_err());
        assert!(load_las(b"PK", "v.las").unwrap_err().to_string().contains("no 'LASF'"));
        // A header claiming 2^32−1 points in a small file.
        let mut m = VEG[..4_000].to_vec();
        m[107..111].copy_from_slice(&u32::MAX.to_le_bytes());
        assert!(matches!(load_las(&m, "v.las"), Err(CloudError::WrongPointCount { .. })));
    }

    /// A zero scale factor once put every point on one coordinate (silently).
    #[test]
    fn zero_or_non_finite_scale_factor_is_an_error() {
        for (at, value, expected) in [
            (147, 0.0, "v.las: LAS header: z scale factor is 0 (must be a finite non-zero number)"),
            (131, 0.0, "v.las: LAS header: x scale factor is 0 (must be a finite non-zero number)"),
            (139, f64::NAN, "v.las: LAS header: y scale factor is NaN (must be a finite non-zero number)"),
            (131, f64::INFINITY, "v.las: LAS header: x scale factor is inf (must be a finite non-zero number)"),
            (171, f64::NAN, "v.las: LAS header: z offset is NaN (must be a finite number)"),
        ] {
            let mut m = VEG.to_vec();
            m[at..at + 8].copy_from_slice(&f64::to_le_bytes(value));
            let e = load_las(&m, "v.las").unwrap_err();
            assert!(matches!(e, CloudError::Header { .. }), "{e:?}");
            assert_eq!(e.to_string(), expected);
        }
    }

    /// The vegetation file re-encoded as LAZ by the las crate's writer.
    #[cfg(feature = "laz")]
    fn vegetation_laz() -> Vec<u8> {
        let mut reader = las::Reader::new(Cursor::new(VEG.to_vec())).unwrap();
        let points = reader.read_all().unwrap();
        let mut builder = las::Builder::from(reader.header().version());
        builder.point_format = *reader.header().point_format();
        builder.point_format.is_compressed = true;
        builder.transforms = *reader.header().transforms();
        let mut writer = las::Writer::new(Cursor::new(Vec::new()), builder.into_header().unwrap()).unwrap();
        writer.write_points(&points).unwrap();
        writer.close().unwrap();
        writer.into_inner().unwrap().into_inner()
    }

    /// The vegetation file rewritten by the las crate as LAS `version` with point `format`.
    fn vegetation_as(version: (u8, u8), format: u8) -> Vec<u8> {
        vegetation_written(version, format, false)
    }
    /// The vegetation cloud written as LAS `version`, point `format`, LAZ when `compressed`;
    /// colour and NIR filled in where the format has them.
    fn vegetation_written(version: (u8, u8), format: u8, compressed: bool) -> Vec<u8> {
        let mut reader = las::Reader::new(Cursor::new(VEG.to_vec())).unwrap();
        let mut points: Vec<las::Point> = reader.read_all().unwrap().points().map(|p| p.unwrap()).collect();
        let mut builder = las::Builder::from(version);
        builder.point_format = las::point::Format::new(format).unwrap();
        builder.point_format.is_compressed = compressed;
        for p in &mut points {
            p.color = builder.point_format.has_color.then(|| las::Color::new(1, 2, 3));
            p.nir = builder.point_format.has_nir.then_some(4);
        }
        builder.transforms = *reader.header().transforms();
        let mut writer = las::Writer::new(Cursor::new(Vec::new()), builder.into_header().unwrap()).unwrap();
        for p in points {
            writer.write_point(p).unwrap();
        }
        writer.close().unwrap();
        writer.into_inner().unwrap().into_inner()
    }

    #[test]
    fn las_versions_1_2_and_1_4_read_alike() {
        let original = load_las(VEG, "v.las").unwrap();
        assert_eq!(VEG[24..26], [1, 3], "the asset is LAS 1.3");
        for (version, format) in [((1, 2), 1), ((1, 4), 6)] {
            let bytes = vegetation_as(version, format);
            assert_eq!(bytes[24..26], [version.0, version.1]);
            assert_eq!(load_las(&bytes, "v.las").unwrap(), original, "LAS {version:?} format {format}");
        }
    }

    #[cfg(feature = "laz")]
    #[test]
    fn layered_laz_reads_like_las_and_a_corrupt_layer_size_is_refused() {
        let original = load_las(VEG, "v.las").unwrap();
        for format in [6, 7, 8] {
            let laz = vegetation_written((1, 4), format, true);
            assert_eq!(load_las(&laz, "v.laz").unwrap(), original, "LAZ format {format}");
        }
        // Format 6: one point14 item (30 bytes, 9 layers). The first chunk's first layer size
        // follows the chunk table offset (8 bytes), the raw first point and the point count.
        let mut laz = vegetation_written((1, 4), 6, true);
        let data_start = u32_at(&laz, 96).unwrap() as usize;
        let size_at = data_start + 8 + 30 + 4;
        laz[size_at..size_at + 4].copy_from_slice(&0xffff_fff0u32.to_le_bytes());
        let e = load_las(&laz, "v.laz").unwrap_err().to_string();
        assert!(e.starts_with("v.laz") && e.contains(&format!("LAZ chunk at byte {} declares", data_start + 8)), "{e}");
        // A header whose point record length disagrees with the LASzip items (point14: 30 bytes).
        let mut laz = vegetation_written((1, 4), 6, true);
        laz[105..107].copy_from_slice(&31u16.to_le_bytes());
        let e = load_las(&laz, "v.laz").unwrap_err().to_string();
        assert!(e.contains("LAZ items describe 30-byte points, the header 31-byte ones"), "{e}");
    }

    #[test]
    #[cfg(feature = "laz")]
    fn laz_reads_like_las() {
        let laz = vegetation_laz();
        assert!(laz.len() < VEG.len(), "LAZ {} bytes vs LAS {}", laz.len(), VEG.len());
        assert_eq!(load_las(&laz, "v.laz").unwrap(), load_las(VEG, "v.las").unwrap());
        assert!(load_las(&laz[..laz.len() / 2], "v.laz").is_err());
    }

    #[cfg(feature = "laz")]
    #[test]
    fn laz_hostile_chunk_table_is_refused() {
        let mut laz = vegetation_laz();
        let start = u32::from_le_bytes(laz[96..100].try_into().unwrap()) as usize;
        let table = u64::from_le_bytes(laz[start..start + 8].try_into().unwrap()) as usize;
        laz[table + 4..table + 8].copy_from_slice(&u32::MAX.to_le_bytes());
        let e = load_las(&laz, "v.laz").unwrap_err();
        assert!(e.to_string().contains("chunk table declares 4294967295 chunks"), "{e}");
    }

    #[cfg(feature = "laz")]
    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]
        #[test]
        fn mutated_laz_never_panics(edits in prop::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..4), cut in any::<prop::sample::Index>()) {
            thread_local!(static LAZ: Vec<u8> = vegetation_laz());
            LAZ.with(|laz| {
                let mut m = laz.clone();
                for (pos, byte) in &edits {
                    let i = pos.index(m.len());
                    m[i] = *byte;
                }
                let _ = load_las(&m, "x.laz");
                let _ = load_las(&laz[..cut.index(laz.len())], "x.laz");
            });
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        #[test]
        fn mutated_header_never_panics(pos in 0usize..400, byte in any::<u8>(), cut in 0usize..3_000) {
            let mut m = VEG[..VEG.len().min(3_000 + cut)].to_vec();
            m[pos] = byte;
            let _ = load_las(&m, "x.las");
        }

        #[test]
        fn arbitrary_bytes_never_panic(tail in prop::collection::vec(any::<u8>(), 0..600)) {
            let mut b = b"LASF".to_vec();
            b.extend_from_slice(&tail);
            let _ = load_las(&b, "x.las");
        }
    }
}
