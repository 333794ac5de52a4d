//! PCD reading and writing: headers, encodings (ascii, binary, binary_compressed), hostile input.

use super::*;
use nalgebra::Point3;
use proptest::prelude::*;

const HEAD: &str = "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\nSIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS 2\n";

#[test]
fn ascii_reads_xyz_and_skips_other_fields() {
    let text = format!("{HEAD}DATA ascii\n1 2 3 4278190080\n-1.5 0 1e2 0\n");
    let c = load_pcd(text.as_bytes(), "a.pcd").unwrap();
    assert_eq!(c.points, vec![Point3::new(1.0, 2.0, 3.0), Point3::new(-1.5, 0.0, 100.0)]);
}

#[test]
fn all_nan_points_are_missing_returns_and_left_out() {
    // An organised 2 × 2 cloud (a depth camera's) with one missing return: NaN x, y and z.
    let h = "VERSION 0.7\nFIELDS x y z classification\nSIZE 4 4 4 1\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 2\nHEIGHT 2\nPOINTS 4\n";
    let rows = [(1.0f32, 2.0f32, 3.0f32, 2u8), (f32::NAN, f32::NAN, f32::NAN, 0), (4.0, 5.0, 6.0, 6), (7.0, 8.0, 9.0, 2)];
    let mut binary = format!("{h}DATA binary\n").into_bytes();
    let mut ascii = format!("{h}DATA ascii\n");
    for (x, y, z, c) in rows {
        for v in [x, y, z] {
            binary.extend_from_slice(&v.to_le_bytes());
        }
        binary.push(c);
        ascii += &format!("{x} {y} {z} {c}\n");
    }
    for bytes in [binary, ascii.into_bytes()] {
        let cloud = load_pcd(&bytes, "organised.pcd").unwrap();
        assert_eq!(cloud.points, vec![Point3::new(1.0, 2.0, 3.0), Point3::new(4.0, 5.0, 6.0), Point3::new(7.0, 8.0, 9.0)]);
        assert_eq!(cloud.classification, Some(vec![2, 6, 2]), "attributes stay with their points");
    }
}

#[test]
fn binary_with_count_and_signed_fields() {
    // fields: normal (F 4 ×3), x (I 2), y (U 1), z (F 8)
    let h = "VERSION .7\nFIELDS normal x y z\nSIZE 4 2 1 8\nTYPE F I U F\nCOUNT 3 1 1 1\nWIDTH 1\nHEIGHT 2\nPOINTS 2\nDATA binary\n";
    let mut b = h.as_bytes().to_vec();
    for (x, y, z) in [(-300i16, 7u8, 0.25f64), (5, 255, -8.0)] {
        b.extend_from_slice(&[0u8; 12]);
        b.extend_from_slice(&x.to_le_bytes());
        b.push(y);
        b.extend_from_slice(&z.to_le_bytes());
    }
    let c = load_pcd(&b, "b.pcd").unwrap();
    assert_eq!(c.points, vec![Point3::new(-300.0, 7.0, 0.25), Point3::new(5.0, 255.0, -8.0)]);
}

#[test]
fn lzf_known_stream() {
    // literal "abc" (ctrl 2), then a back-reference of length 6 at distance 3 (ctrl (4 << 5) | 0, off 2).
    let out = lzf_decompress(&[2, b'a', b'b', b'c', 4 << 5, 2], 9).unwrap();
    assert_eq!(out, b"abcabcabc");
    // long match: len field 7 + extra 3 → 12 bytes, distance 1.
    let out = lzf_decompress(&[0, b'z', 7 << 5, 3, 0], 13).unwrap();
    assert_eq!(out, vec![b'z'; 13]);
    assert_eq!(lzf_decompress(&[4 << 5, 2], 6), None); // reference before the start
    assert_eq!(lzf_decompress(&[2, b'a', b'b'], 3), None); // truncated literal
    assert_eq!(lzf_decompress(&[0, b'a'], 2), None); // wrong length
}

#[test]
fn binary_compressed_is_structure_of_arrays() {
    // 2 points, fields x y z F 4: uncompressed = x0 x1 y0 y1 z0 z1 as f32, stored as literals.
    let soa: Vec<u8> = [1.0f32, 4.0, 2.0, 5.0, 3.0, 6.0].iter().flat_map(|v| v.to_le_bytes()).collect();
    let mut lzf = vec![23u8]; // literal of 24 bytes
    lzf.extend_from_slice(&soa);
    let mut b = b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nPOINTS 2\nDATA binary_compressed\n".to_vec();
    b.extend_from_slice(&(lzf.len() as u32).to_le_bytes());
    b.extend_from_slice(&24u32.to_le_bytes());
    b.extend_from_slice(&lzf);
    let c = load_pcd(&b, "c.pcd").unwrap();
    assert_eq!(c.points, vec![Point3::new(1.0, 2.0, 3.0), Point3::new(4.0, 5.0, 6.0)]);
    // Uncompressed size that does not match POINTS.
    let mut bad = b.clone();
    let at = bad.len() - lzf.len() - 4;
    bad[at..at + 4].copy_from_slice(&12u32.to_le_bytes());
    let e = load_pcd(&bad, "c.pcd").unwrap_err().to_string();
    assert!(e.ends_with("binary_compressed: the uncompressed size word says 12 bytes, but POINTS 2 × 12-byte records make 24"), "{e}");
}

#[test]
fn errors_are_clear() {
    let mut b = HEAD.replace("WIDTH 2", "WIDTH 100").replace("POINTS 2", "POINTS 100").into_bytes();
    b.extend_from_slice(b"DATA binary\n");
    b.extend(vec![0u8; 16 * 37 + 5]);
    assert_eq!(
        load_pcd(&b, "landmarks.pcd").unwrap_err().to_string(),
        "landmarks.pcd: header says POINTS 100 but the data holds 37 points"
    );
    let t = format!("{HEAD}DATA ascii\n1 2 3 4\n");
    assert_eq!(load_pcd(t.as_bytes(), "a.pcd").unwrap_err().to_string(), "a.pcd: header says POINTS 2 but the data holds 1 points");
    let t = format!("{HEAD}DATA ascii\n1 2 3 4\n1 2 3 4\n1 2 3 4\n");
    assert_eq!(load_pcd(t.as_bytes(), "a.pcd").unwrap_err().to_string(), "a.pcd: header says POINTS 2 but the data holds 3 points");
    let t = format!("{HEAD}DATA ascii\n1 2 3 4\nnan 2 3 4\n");
    assert_eq!(load_pcd(t.as_bytes(), "a.pcd").unwrap_err().to_string(), "a.pcd: line 13: non-finite coordinate");
    let t = format!("{HEAD}DATA ascii\n1 2 3 4\nnan nan inf 4\n");
    assert_eq!(load_pcd(t.as_bytes(), "a.pcd").unwrap_err().to_string(), "a.pcd: line 13: non-finite coordinate");
    let t = format!("{HEAD}DATA ascii\n1 2 3\n1 2 3 4\n");
    assert_eq!(load_pcd(t.as_bytes(), "a.pcd").unwrap_err().to_string(), "a.pcd: line 12: expected 4 values, found 3");
    let t = HEAD.replace("POINTS 2", "POINTS 3") + "DATA ascii\n";
    assert!(load_pcd(t.as_bytes(), "a.pcd").unwrap_err().to_string().contains("WIDTH × HEIGHT = 2 × 1 = 2 but POINTS 3"));
    let t = HEAD.replace("FIELDS x y z rgb", "FIELDS x y w rgb") + "DATA ascii\n";
    assert_eq!(load_pcd(t.as_bytes(), "a.pcd").unwrap_err().to_string(), "a.pcd: FIELDS has no 'z' field");
    let t = HEAD.replace("SIZE 4 4 4 4", "SIZE 4 4 4") + "DATA ascii\n";
    assert!(load_pcd(t.as_bytes(), "a.pcd").unwrap_err().to_string().contains("SIZE has 3"));
    let t = HEAD.to_string() + "DATA binary_zstd\n";
    assert!(load_pcd(t.as_bytes(), "a.pcd").is_err());
    assert!(load_pcd(HEAD.as_bytes(), "a.pcd").unwrap_err().to_string().contains("no DATA line"));
}

#[test]
fn hostile_counts_do_not_allocate() {
    let t = "FIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nWIDTH 4294967295\nHEIGHT 4294967295\nDATA binary\n\x00";
    assert!(matches!(load_pcd(t.as_bytes(), "h.pcd"), Err(CloudError::WrongPointCount { found: 0, .. })));
    let t = "FIELDS x y z\nSIZE 8 8 8\nTYPE F F F\nCOUNT 4294967295 4294967295 4294967295\nWIDTH 1\nDATA binary\n\x00";
    assert!(load_pcd(t.as_bytes(), "h.pcd").is_err());
    let mut b = b"FIELDS x y z\nSIZE 1 1 1\nTYPE U U U\nWIDTH 1000000000\nDATA binary_compressed\n".to_vec();
    b.extend_from_slice(&2u32.to_le_bytes());
    b.extend_from_slice(&3_000_000_000u32.to_le_bytes());
    b.extend_from_slice(&[0, 0]);
    assert!(load_pcd(&b, "h.pcd").is_err());
}

fn cloud_strategy() -> impl Strategy<Value = PointCloud> {
    (0usize..30, any::<bool>(), any::<bool>()).prop_flat_map(|(n, with_class, with_cov)| {
        (
            prop::collection::vec((-1e7f64..1e7, -1e7f64..1e7, -1e7f64..1e7), n),
            prop::collection::vec(any::<u8>(), n),
            prop::collection::vec((0.0f64..10.0, -1.0f64..1.0, 0.0f64..10.0), n),
        )
            .prop_map(move |(pts, class, cov)| PointCloud {
                points: pts.into_iter().map(|(x, y, z)| Point3::new(x, y, z)).collect(),
                classification: with_class.then_some(class),
                covariances: with_cov
                    .then(|| cov.into_iter().map(|(a, b, c)| super::super::cov_from_upper([a, b, -b, c, 0.5 * b, a + c])).collect()),
            })
    })
}

proptest! {
    #[test]
    fn roundtrip_both_encodings(cloud in cloud_strategy(), ascii in any::<bool>()) {
        let enc = if ascii { PcdEncoding::Ascii } else { PcdEncoding::Binary };
        let back = load_pcd(&write_pcd(&cloud, enc), "r.pcd").unwrap();
        prop_assert_eq!(back, cloud);
    }

    #[test]
    fn arbitrary_bytes_never_panic(prefix in prop::sample::select(vec![&b""[..], b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 3\nDATA binary_compressed\n", b"FIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nWIDTH 2\nDATA ascii\n"]), tail in prop::collection::vec(any::<u8>(), 0..300)) {
        let mut bytes = prefix.to_vec();
        bytes.extend_from_slice(&tail);
        let _ = load_pcd(&bytes, "x.pcd");
    }

    #[test]
    fn arbitrary_lzf_never_panics(input in prop::collection::vec(any::<u8>(), 0..200), out_len in 0usize..2000) {
        let _ = lzf_decompress(&input, out_len);
    }

    #[test]
    fn mutated_files_never_panic(ascii in any::<bool>(), pos in any::<prop::sample::Index>(), byte in any::<u8>(), cut in any::<prop::sample::Index>()) {
        let mut c = PointCloud::from_points(vec![Point3::new(1.0, 2.0, 3.0), Point3::new(4.0, 5.0, 6.0)]);
        c.classification = Some(vec![1, 2]);
        let f = write_pcd(&c, if ascii { PcdEncoding::Ascii } else { PcdEncoding::Binary });
        let mut m = f.clone();
        let i = pos.index(m.len());
        m[i] = byte;
        let _ = load_pcd(&m, "x.pcd");
        let _ = load_pcd(&f[..cut.index(f.len())], "x.pcd");
    }
}
