//! PLY reading and writing: headers, encodings, attributes, hostile input.

use super::*;
use nalgebra::{Matrix3, Point3};
use proptest::prelude::*;

fn le(values: &[f32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

#[test]
fn ascii_with_faces_and_lists_skipped() {
    let text = "ply\r\nformat ascii 1.0\r\ncomment hi\r\nelement vertex 2\r\nproperty float x\r\nproperty list uchar int idx\r\nproperty float y\r\nproperty double z\r\nproperty uchar classification\r\nelement face 1\r\nproperty list uchar int vertex_indices\r\nend_header\r\n1 2 7 8 2.5 -3 2\r\n4 0 5 6e1 11\r\n3 0 1 1\r\n";
    let c = load_ply(text.as_bytes(), "a.ply").unwrap();
    assert_eq!(c.points, vec![Point3::new(1.0, 2.5, -3.0), Point3::new(4.0, 5.0, 60.0)]);
    assert_eq!(c.classification, Some(vec![2, 11]));
    assert_eq!(c.covariances, None);
}

#[test]
fn binary_big_endian_ints_and_leading_element() {
    let mut b = b"ply\nformat binary_big_endian 1.0\nelement camera 1\nproperty list uchar float k\nproperty short s\nelement vertex 2\nproperty int x\nproperty ushort y\nproperty char z\nend_header\n".to_vec();
    b.extend_from_slice(&[2, 0, 0, 0, 0, 0, 0, 0, 0, 0xAB, 0xCD]); // camera: list of 2 floats, a short
    for (x, y, z) in [(-7i32, 65_535u16, -128i8), (100_000, 3, 127)] {
        b.extend_from_slice(&x.to_be_bytes());
        b.extend_from_slice(&y.to_be_bytes());
        b.push(z as u8);
    }
    let c = load_ply(&b, "be.ply").unwrap();
    assert_eq!(c.points, vec![Point3::new(-7.0, 65_535.0, -128.0), Point3::new(100_000.0, 3.0, 127.0)]);
}

#[test]
fn binary_le_with_covariance() {
    let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float cov_xx\nproperty float cov_xy\nproperty float cov_xz\nproperty float cov_yy\nproperty float cov_yz\nproperty float cov_zz\nproperty float intensity\nend_header\n".to_vec();
    b.extend(le(&[1.0, 2.0, 3.0, 4.0, 0.5, 0.25, 5.0, 0.125, 6.0, 99.0]));
    let c = load_ply(&b, "c.ply").unwrap();
    assert_eq!(c.points, vec![Point3::new(1.0, 2.0, 3.0)]);
    assert_eq!(c.covariances, Some(vec![Matrix3::new(4.0, 0.5, 0.25, 0.5, 5.0, 0.125, 0.25, 0.125, 6.0)]));
}

/// More vertex records than the header declares, when the vertices are the last element: an
/// error naming the line (ascii) or the bytes left (binary), not points dropped silently.
/// Trailing whitespace is not data.
#[test]
fn records_beyond_the_declared_count_are_an_error() {
    let ascii = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    let e = load_ply(format!("{ascii}1 2 3\n4 5 6\n").as_bytes(), "a.ply").unwrap_err();
    assert_eq!(e.to_string(), "a.ply: line 9: data after the last element: the header declares 1 vertices");
    assert_eq!(load_ply(format!("{ascii}1 2 3\n\n \r\n").as_bytes(), "a.ply").unwrap().points.len(), 1);
    let binary = ascii.replace("ascii", "binary_little_endian");
    let mut b = binary.as_bytes().to_vec();
    b.extend(le(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]));
    let e = load_ply(&b, "b.ply").unwrap_err();
    assert_eq!(e.to_string(), "b.ply: 12 bytes of data after the last element: the header declares 1 vertices");
    b.truncate(b.len() - 12);
    b.push(b'\n');
    assert_eq!(load_ply(&b, "b.ply").unwrap().points.len(), 1);
    // Lists make records of varying size (the slow path): the same.
    let list = binary.replace("property float z\n", "property float z\nproperty list uchar int idx\n");
    let mut b = list.as_bytes().to_vec();
    for _ in 0..2 {
        b.extend(le(&[1.0, 2.0, 3.0]));
        b.push(0);
    }
    let e = load_ply(&b, "l.ply").unwrap_err();
    assert_eq!(e.to_string(), "l.ply: 13 bytes of data after the last element: the header declares 1 vertices");
}

#[test]
fn errors_are_clear() {
    let e = load_ply(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nend_header\n1 2\n", "cloud.ply")
        .unwrap_err();
    assert_eq!(e.to_string(), "cloud.ply: vertex element has no 'z' property");
    let hdr =
        "ply\nformat binary_little_endian 1.0\nelement vertex 100\nproperty float x\nproperty float y\nproperty float z\nend_header\n";
    let mut b = hdr.as_bytes().to_vec();
    b.extend(le(&[0.0; 3 * 37 + 2]));
    let e = load_ply(&b, "landmarks.ply").unwrap_err();
    assert_eq!(e.to_string(), "landmarks.ply: header says element vertex 100 but the data holds 37 points");
    let mut b = hdr.replace("100", "2").into_bytes();
    b.extend(le(&[0.0, 0.0, 0.0, 1.0, f32::NAN, 2.0]));
    let e = load_ply(&b, "n.ply").unwrap_err();
    assert_eq!(e.to_string(), "n.ply: point 1: non-finite coordinate");
    let e = load_ply(
        b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n4 inf 6\n",
        "a.ply",
    )
    .unwrap_err();
    assert_eq!(e.to_string(), "a.ply: line 9: non-finite coordinate");
    let e = load_ply(
        b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 3\n4 5\n",
        "a.ply",
    )
    .unwrap_err();
    assert_eq!(e.to_string(), "a.ply: header says element vertex 2 but the data holds 1 points");
    let e = load_ply(
        b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nend_header\n1 2 x\n",
        "a.ply",
    )
    .unwrap_err();
    assert_eq!(e.to_string(), "a.ply: line 8: 'x' is not a number");
    let e = load_ply(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float classification\nend_header\n1 2 3 2.5\n", "a.ply").unwrap_err();
    assert!(e.to_string().contains("classification 2.5 is not an integer"), "{e}");
    let e = load_ply(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\nproperty float z\nproperty float cov_xx\nend_header\n1 2 3 2.5\n", "a.ply").unwrap_err();
    assert!(e.to_string().contains("no 'cov_xy'"), "{e}");
    let e = load_ply(b"ply\nformat binary_middle_endian 1.0\nend_header\n", "a.ply").unwrap_err();
    assert!(e.to_string().contains("unknown format"), "{e}");
    let e = load_ply(b"ply\nformat ascii 1.0\nelement face 1\nproperty list uchar int v\nend_header\n0\n", "a.ply").unwrap_err();
    assert_eq!(e.to_string(), "a.ply: no 'vertex' element");
    let e = load_ply(b"PK\x03\x04", "a.ply").unwrap_err();
    assert!(e.to_string().contains("not a PLY file"), "{e}");
    let e = load_ply(b"ply\nformat ascii 1.0\nelement vertex 1\n", "a.ply").unwrap_err();
    assert!(e.to_string().contains("no 'end_header'"), "{e}");
}

#[test]
fn hostile_counts_do_not_allocate() {
    let b = b"ply\nformat binary_little_endian 1.0\nelement vertex 18446744073709551615\nproperty double x\nproperty double y\nproperty double z\nend_header\n\x00\x00";
    assert!(matches!(load_ply(b, "h.ply"), Err(CloudError::WrongPointCount { found: 0, .. })));
    let b = b"ply\nformat binary_little_endian 1.0\nelement face 18446744073709551615\nproperty list uint uint v\nelement vertex 1\nproperty double x\nproperty double y\nproperty double z\nend_header\n\xff\xff\xff\xff";
    assert!(load_ply(b, "h.ply").is_err());
    let b = b"ply\nformat ascii 1.0\nelement vertex 18446744073709551615\nproperty double x\nproperty double y\nproperty double z\nend_header\n1 2 3\n";
    assert!(matches!(load_ply(b, "h.ply"), Err(CloudError::WrongPointCount { found: 1, .. })));
    // An element with no properties and a huge count costs nothing.
    let b = b"ply\nformat ascii 1.0\nelement empty 18446744073709551615\nelement vertex 1\nproperty double x\nproperty double y\nproperty double z\nend_header\n1 2 3\n";
    assert_eq!(load_ply(b, "h.ply").unwrap().len(), 1);
}

fn cloud_strategy() -> impl Strategy<Value = PointCloud> {
    (0usize..40, any::<bool>(), any::<bool>()).prop_flat_map(|(n, with_class, with_cov)| {
        (
            prop::collection::vec((-1e6f64..1e6, -1e6f64..1e6, -1e6f64..1e6), n),
            prop::collection::vec(any::<u8>(), n),
            prop::collection::vec((0.0f64..10.0, -1.0f64..1.0, -1.0f64..1.0, 0.0f64..10.0, -1.0f64..1.0, 0.0f64..10.0), n),
        )
            .prop_map(move |(pts, class, cov)| PointCloud {
                points: pts.into_iter().map(|(x, y, z)| Point3::new(x, y, z)).collect(),
                classification: with_class.then_some(class),
                covariances: with_cov
                    .then(|| cov.into_iter().map(|(a, b, c, d, e, f)| super::super::cov_from_upper([a, b, c, d, e, f])).collect()),
            })
    })
}

pub(crate) fn valid_files() -> Vec<Vec<u8>> {
    let mut v = vec![
        b"ply\nformat ascii 1.0\nelement vertex 2\nproperty float x\nproperty list uchar int idx\nproperty float y\nproperty double z\nproperty uchar classification\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n1 2 7 8 2.5 -3 2\n4 0 5 6e1 11\n3 0 1 1\n".to_vec(),
    ];
    let mut c = PointCloud::from_points(vec![Point3::new(1.0, 2.0, 3.0), Point3::new(-4.0, 5.0, 6.5)]);
    c.classification = Some(vec![2, 9]);
    v.push(write_ply_binary(&c));
    v
}

proptest! {
    #[test]
    fn binary_roundtrip(cloud in cloud_strategy()) {
        let back = load_ply(&write_ply_binary(&cloud), "r.ply").unwrap();
        prop_assert_eq!(back, cloud);
    }

    #[test]
    fn arbitrary_bytes_never_panic(prefix in prop::sample::select(vec![&b""[..], b"ply\nformat ascii 1.0\n", b"ply\nformat binary_big_endian 1.0\nelement vertex 3\n"]), tail in prop::collection::vec(any::<u8>(), 0..300)) {
        let mut bytes = prefix.to_vec();
        bytes.extend_from_slice(&tail);
        let _ = load_ply(&bytes, "x.ply");
    }

    #[test]
    fn mutated_files_never_panic(which in 0usize..2, pos in any::<prop::sample::Index>(), byte in any::<u8>(), cut in any::<prop::sample::Index>()) {
        let f = &valid_files()[which];
        let mut m = f.clone();
        let i = pos.index(m.len());
        m[i] = byte;
        let _ = load_ply(&m, "x.ply");
        let _ = load_ply(&f[..cut.index(f.len())], "x.ply");
    }
}
