use super::*;
use crate::slam::optimizer::{LevenbergMarquardt, Optimizer, OptimizerParams};
use nalgebra::{Quaternion, UnitQuaternion};

const SMALL_2D: &str = "# two poses\nVERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1.5 0.1 0.2\n\
    EDGE_SE2 0 1 1.4 0.0 0.25 100 0 0 100 0 400\nFIX 0\n";

#[test]
fn reads_2d_with_values() {
    let f = read_g2o(SMALL_2D.as_bytes()).unwrap();
    assert_eq!(f.vertices.len(), 2);
    assert_eq!(f.is_3d, Some(false));
    assert_eq!(f.fixed, vec![0]);
    let G2oEdge::Se2 { from, to, measurement, information } = f.edges[0] else { panic!("2D edge") };
    assert_eq!((from, to), (0, 1));
    assert_eq!(measurement, Se2::new(1.4, 0.0, 0.25));
    assert_eq!(information, Matrix3::new(100.0, 0.0, 0.0, 0.0, 100.0, 0.0, 0.0, 0.0, 400.0));
    // χ² at the file's values by hand: z⁻¹ x₁ = (0.1, 0.1, −0.05) rotated by −0.25
    let p = f.to_problem(Gauge::FixFirst, Se2Residual::Vector).unwrap();
    let (s, c) = (-0.25f64).sin_cos();
    let e = [c * 0.1 - s * 0.1, s * 0.1 + c * 0.1, -0.05];
    let expected = 100.0 * e[0] * e[0] + 100.0 * e[1] * e[1] + 400.0 * e[2] * e[2];
    assert!((p.graph.chi2(&p.values).unwrap() - expected).abs() < 1e-12);
    assert!(p.values.is_fixed(VarId(0)) && !p.values.is_fixed(VarId(1)));
}

#[test]
fn fix_lines_replace_the_first_pose_gauge() {
    // FIX 1 anchors the graph: pose 0 stays free and moves to satisfy the edge from pose 1.
    let text = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nFIX 1\nEDGE_SE2 0 1 1.2 0 0.1 1 0 0 1 0 1\n";
    let f = read_g2o(text.as_bytes()).unwrap();
    let mut p = f.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
    assert!(!p.values.is_fixed(VarId(0)) && p.values.is_fixed(VarId(1)));
    LevenbergMarquardt::new(OptimizerParams::default()).optimize(&p.graph, &mut p.values).unwrap();
    assert!(p.graph.chi2(&p.values).unwrap() < 1e-18);
    assert_eq!(p.values.se2(VarId(1)).unwrap(), Se2::new(1.0, 0.0, 0.0));
    // Without FIX lines the first pose is the gauge.
    let q = read_g2o(text.replace("FIX 1\n", "").as_bytes()).unwrap().to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
    assert!(q.values.is_fixed(VarId(0)) && !q.values.is_fixed(VarId(1)));
}

#[test]
fn errors_name_the_line() {
    assert_eq!(read_g2o(b"VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 0 x 0\n"), Err(G2oError::BadNumber { line: 2, field: 3, text: "x".into() }));
    assert_eq!(
        read_g2o(b"\nEDGE_SE2 0 1 0 0 0 1 0 0 1 0\n"),
        Err(G2oError::FieldCount { line: 2, tag: "EDGE_SE2", expected: 11, found: 10 })
    );
    // Other tags are skipped, as g2o and GTSAM skip them, and listed.
    let f = read_g2o(b"VERTEX_XY 1 2 3\nEDGE_PRIOR_SE2 1\nTUTORIAL_PARAMS 0\nEDGE_PRIOR_SE2 2 1 1\n").unwrap();
    assert_eq!(f.vertices.len(), 1);
    let skipped = |tag: &str, lines, first_line| SkippedTag { tag: tag.into(), lines, first_line };
    assert_eq!(f.skipped, vec![skipped("EDGE_PRIOR_SE2", 2, 2), skipped("TUTORIAL_PARAMS", 1, 3)]);
    assert_eq!(read_g2o(b"VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_XY 1 2 3\n"), Err(G2oError::MixedDimensions { line: 2 }));
    let offset = b"PARAMS_SE3OFFSET 0 0 0 0 0 0 0 1\n";
    assert_eq!(read_g2o(&[&offset[..], offset].concat()), Err(G2oError::DuplicateOffset { line: 2, id: 0 }));
    assert!(matches!(read_g2o(b"EDGE_SE2 0 1 0 0 0 1 0 0 -1 0 1\n"), Err(G2oError::Information { line: 1, .. })));
    assert_eq!(read_g2o(b"VERTEX_SE2 0 0 0 0\nVERTEX_SE3:QUAT 1 0 0 0 0 0 0 1\n"), Err(G2oError::MixedDimensions { line: 2 }));
    assert_eq!(read_g2o(b"VERTEX_SE2 3 0 0 0\nVERTEX_SE2 3 1 0 0\n"), Err(G2oError::DuplicateVertex { line: 2, id: 3 }));
    assert_eq!(read_g2o(b"VERTEX_SE3:QUAT 1 0 0 0 0 0 0 0\n"), Err(G2oError::ZeroQuaternion { line: 1 }));
    assert!(matches!(read_g2o(b"VERTEX_SE2 0 nan 0 0\n"), Err(G2oError::BadNumber { line: 1, field: 2, .. })));
    assert!(read_g2o(&[b'V', 0xff, b'\n']).is_err());
}

#[test]
fn landmark_edges_on_the_wrong_vertex_kind_or_offset_are_errors() {
    let f = read_g2o(b"VERTEX_SE2 0 0 0 0\nVERTEX_XY 1 2 3\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n").unwrap();
    assert_eq!(
        f.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap_err(),
        G2oError::VertexKind { edge: 0, id: 1, expected: "SE2 pose", found: "2D point" }
    );
    let f = read_g2o(b"VERTEX_SE3:QUAT 0 0 0 0 0 0 0 1\nVERTEX_TRACKXYZ 1 1 2 3\nEDGE_SE3_TRACKXYZ 0 1 7 1 2 3 1 0 0 1 0 1\n").unwrap();
    assert_eq!(f.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap_err(), G2oError::UnknownOffset { edge: 0, id: 7 });
}

#[test]
fn landmarks_2d_hand_chi2_and_optimum() {
    // Pose 0 at the origin, pose 1 at (2, 0) facing +y; landmark 5 at (2, 3): seen at (2, 3)
    // from pose 0 and at (3, 0) from pose 1.
    let text = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 2 0 1.5707963267948966\nVERTEX_XY 5 2.5 2.5\n\
        EDGE_SE2 0 1 2 0 1.5707963267948966 100 0 0 100 0 100\n\
        EDGE_SE2_XY 0 5 2 3 4 0 25\nEDGE_SE2_XY 1 5 3 0 9 1 16\n";
    let f = read_g2o(text.as_bytes()).unwrap();
    assert_eq!(f.is_3d, Some(false));
    let mut p = f.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
    assert_eq!((p.poses.len(), p.landmarks.len(), p.graph.len()), (2, 1, 3));
    // At the file's values: from pose 0, e = (0.5, −0.5), χ² = 4·0.25 + 25·0.25 = 7.25; from
    // pose 1, p = Rᵀ(0.5, 2.5) = (2.5, −0.5), e = (−0.5, −0.5), χ² = 9·0.25 + 2·1·0.25 + 16·0.25
    // = 6.75; the odometry edge is exact.
    assert!((p.graph.chi2(&p.values).unwrap() - 14.0).abs() < 1e-12);
    let s = LevenbergMarquardt::new(OptimizerParams::default()).optimize(&p.graph, &mut p.values).unwrap();
    assert!(s.final_chi2 < 1e-16, "{s:?}");
    let m = p.values.point2(p.landmarks[0].1).unwrap();
    assert!((m - Vector2::new(2.0, 3.0)).norm() < 1e-8);
    // Round trip, with the optimised landmark written back.
    let back = read_g2o(write_g2o(&f.with_poses(&p, &p.values)).as_bytes()).unwrap();
    assert_eq!(back.edges, f.edges);
    assert!(matches!(back.vertices[2], G2oVertex::Point2 { id: 5, point } if (point - Vector2::new(2.0, 3.0)).norm() < 1e-8));
}

#[test]
fn landmarks_3d_through_a_sensor_offset_match_g2os_error() {
    // Sensor 3 sits 0.2 m ahead of the robot, turned −π/2 about z (looking right).
    let text = "PARAMS_SE3OFFSET 3 0.2 0 0 0 0 -0.7071067811865476 0.7071067811865476\n\
        VERTEX_SE3:QUAT 0 1 2 0 0 0 0.3894183423086505 0.9210609940028851\n\
        VERTEX_TRACKXYZ 9 4 5 1\n\
        EDGE_SE3_TRACKXYZ 0 9 3 0.5 1.5 0.8 4 1 0 9 -2 16\n";
    let f = read_g2o(text.as_bytes()).unwrap();
    let p = f.to_problem(Gauge::Free, Se2Residual::Log).unwrap();
    // g2o's error, by hand from its definition: e = (x o)⁻¹ m − z, χ² = eᵀ Ω e.
    let x = Se3::new(
        UnitQuaternion::from_quaternion(Quaternion::new(0.9210609940028851, 0.0, 0.0, 0.3894183423086505)),
        Vector3::new(1.0, 2.0, 0.0),
    );
    let o = Se3::new(
        UnitQuaternion::from_quaternion(Quaternion::new(std::f64::consts::FRAC_1_SQRT_2, 0.0, 0.0, -std::f64::consts::FRAC_1_SQRT_2)),
        Vector3::new(0.2, 0.0, 0.0),
    );
    let e = (x * o).inverse_transform_point(&Vector3::new(4.0, 5.0, 1.0)) - Vector3::new(0.5, 1.5, 0.8);
    let omega = Matrix3::new(4.0, 1.0, 0.0, 1.0, 9.0, -2.0, 0.0, -2.0, 16.0);
    let expected = (e.transpose() * omega * e)[0];
    assert!(expected > 1.0, "a test point with a real error: {expected}");
    assert!((p.graph.chi2(&p.values).unwrap() - expected).abs() < 1e-10 * expected);
    // A missing landmark vertex in a file with vertices is an error (it was once invented).
    let missing = text.replace("VERTEX_TRACKXYZ 9 4 5 1\n", "");
    assert_eq!(read_g2o(missing.as_bytes()), Err(G2oError::UndefinedVertex { line: 3, tag: "EDGE_SE3_TRACKXYZ", id: 9 }));
    // In a file of bare edges the landmark starts where the edge puts it: zero error.
    let bare = read_g2o(missing.replace("VERTEX_SE3:QUAT 0 1 2 0 0 0 0.3894183423086505 0.9210609940028851\n", "").as_bytes()).unwrap();
    assert!(bare.vertices.is_empty());
    let q = bare.to_problem(Gauge::Free, Se2Residual::Log).unwrap();
    assert!(q.graph.chi2(&q.values).unwrap() < 1e-20);
    let back = read_g2o(write_g2o(&f).as_bytes()).unwrap();
    assert_eq!((back.offsets.len(), back.edges.len()), (1, 1));
    assert_eq!(back.edges, f.edges);
}

proptest::proptest! {
    /// Mutated and truncated files give a problem or a typed error, never a panic.
    #[test]
    fn mutated_files_never_panic(edits in proptest::collection::vec((proptest::prelude::any::<proptest::sample::Index>(), proptest::prelude::any::<u8>()), 1..4), cut in proptest::prelude::any::<proptest::sample::Index>(), three_d in proptest::prelude::any::<bool>()) {
        let text: &[u8] = if three_d {
            b"PARAMS_SE3OFFSET 3 0.2 0 0 0 0 0 1\nVERTEX_SE3:QUAT 0 1 2 0 0 0 0 1\nVERTEX_TRACKXYZ 9 4 5 1\nEDGE_SE3_TRACKXYZ 0 9 3 0.5 1.5 0.8 4 1 0 9 -2 16\nEDGE_SE3:QUAT 0 1 1 0 0 0 0 0 1 1 0 0 0 0 0 1 0 0 0 0 1 0 0 0 1 0 0 1 0 1\nFIX 0\n"
        } else {
            b"VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 2 0 1.5\nVERTEX_XY 5 2.5 2.5\nEDGE_SE2 0 1 2 0 1.5 100 0 0 100 0 100\nEDGE_SE2_XY 0 5 2 3 4 0 25\nFIX 1\n"
        };
        let mut m = text.to_vec();
        for (pos, byte) in edits {
            let i = pos.index(m.len());
            m[i] = byte;
        }
        m.truncate(cut.index(m.len() + 1));
        if let Ok(f) = read_g2o(&m) {
            let _ = f.to_problem(Gauge::FixFirst, Se2Residual::Log);
        }
    }
}

/// An edge to a vertex no VERTEX line defines was once given an invented vertex (reported as
/// the last pose); in a file with vertex lines it is an error naming the first such edge.
#[test]
fn edges_to_undefined_vertices_are_errors() {
    let text = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nVERTEX_SE2 2 2 0 0\n\
        EDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nEDGE_SE2 1 2 1 0 0 1 0 0 1 0 1\nEDGE_SE2 1 7 1 0 0 1 0 0 1 0 1\n";
    let e = read_g2o(text.as_bytes()).unwrap_err();
    assert_eq!(e, G2oError::UndefinedVertex { line: 6, tag: "EDGE_SE2", id: 7 });
    assert_eq!(e.to_string(), "line 6: EDGE_SE2 uses vertex 7, which no VERTEX line defines");
    // The first offending edge in file order, its `from` before its `to`.
    let two = "VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 9 1 0 0 1 0 0 1 0 1\nEDGE_SE2 8 3 1 0 0 1 0 0 1 0 1\n";
    assert_eq!(read_g2o(two.as_bytes()), Err(G2oError::UndefinedVertex { line: 2, tag: "EDGE_SE2", id: 9 }));
    let two = "VERTEX_SE2 0 0 0 0\nEDGE_SE2 8 3 1 0 0 1 0 0 1 0 1\n";
    assert_eq!(read_g2o(two.as_bytes()), Err(G2oError::UndefinedVertex { line: 2, tag: "EDGE_SE2", id: 8 }));
    // A landmark edge to an undefined landmark.
    let lm = "VERTEX_SE2 0 0 0 0\nVERTEX_XY 5 1 1\nEDGE_SE2_XY 0 5 1 1 1 0 1\nEDGE_SE2_XY 0 6 1 1 1 0 1\n";
    assert_eq!(read_g2o(lm.as_bytes()), Err(G2oError::UndefinedVertex { line: 4, tag: "EDGE_SE2_XY", id: 6 }));
    // A vertex defined after the edge that uses it is fine, as before.
    let late = "VERTEX_SE2 0 0 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\nVERTEX_SE2 1 1 0 0\n";
    let p = read_g2o(late.as_bytes()).unwrap().to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
    assert_eq!(p.poses.len(), 2);
    assert!(p.graph.chi2(&p.values).unwrap() < 1e-20);
}

#[test]
fn bare_edges_chain_like_gtsam() {
    // No vertices: x0 = I, x1 = x0 z01, x2 = x1 z12.
    let f = read_g2o(b"EDGE_SE2 0 1 1 0 1.5707963267948966 1 0 0 1 0 1\nEDGE_SE2 1 2 2 0 0 1 0 0 1 0 1\n").unwrap();
    let p = f.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
    let x2 = p.values.se2(p.poses[2].1).unwrap();
    assert!((x2.x_m - 1.0).abs() < 1e-12 && (x2.y_m - 2.0).abs() < 1e-12);
    assert!(p.graph.chi2(&p.values).unwrap() < 1e-20);
}

fn roundtrip(path: &str) {
    let bytes = std::fs::read(path).unwrap();
    let a = read_g2o(&bytes).unwrap();
    let b = read_g2o(write_g2o(&a).as_bytes()).unwrap();
    assert_eq!(a.vertices.len(), b.vertices.len());
    assert_eq!(a.edges.len(), b.edges.len());
    for (u, v) in a.vertices.iter().zip(&b.vertices) {
        match (u, v) {
            (G2oVertex::Se2 { .. }, G2oVertex::Se2 { .. }) => assert_eq!(u, v),
            (G2oVertex::Se3 { id: i, pose: p }, G2oVertex::Se3 { id: j, pose: q }) => {
                assert_eq!(i, j);
                assert_eq!(p.translation, q.translation);
                assert!((p.rotation.coords - q.rotation.coords).amax() < 1e-15);
            }
            _ => panic!("vertex kind changed"),
        }
    }
    for (u, v) in a.edges.iter().zip(&b.edges) {
        match (u, v) {
            (G2oEdge::Se2 { .. }, G2oEdge::Se2 { .. }) => assert_eq!(u, v),
            (
                G2oEdge::Se3 { from: f1, to: t1, measurement: m1, information: i1 },
                G2oEdge::Se3 { from: f2, to: t2, measurement: m2, information: i2 },
            ) => {
                assert_eq!((f1, t1, i1), (f2, t2, i2));
                assert_eq!(m1.translation, m2.translation);
                assert!((m1.rotation.coords - m2.rotation.coords).amax() < 1e-15);
            }
            _ => panic!("edge kind changed"),
        }
    }
}

#[test]
fn roundtrip_real_2d_and_3d_files() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/data/slam/");
    roundtrip(&format!("{dir}intel.g2o"));
    roundtrip(&format!("{dir}smallGrid3D.g2o"));
}

#[test]
fn real_file_sizes() {
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/data/slam/");
    let f = read_g2o(&std::fs::read(format!("{dir}parking-garage.g2o")).unwrap()).unwrap();
    assert_eq!((f.vertices.len(), f.edges.len(), f.is_3d), (1661, 6275, Some(true)));
    let f = read_g2o(&std::fs::read(format!("{dir}CSAIL.g2o")).unwrap()).unwrap();
    assert_eq!((f.vertices.len(), f.edges.len()), (0, 1172));
    let p = f.to_problem(Gauge::FixFirst, Se2Residual::Log).unwrap();
    assert_eq!(p.values.len(), 1045);
}
