//! Real-data and cross-format tests of the loaders (data in `assets/data/lidar`, provenance in
//! `assets/data/SOURCES.md`).

use super::*;
use nalgebra::Point3;

macro_rules! lidar {
    ($file:literal) => {
        include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/../assets/data/lidar/", $file))
    };
}

fn min_corner(points: &[Point3<f64>]) -> Point3<f64> {
    points
        .iter()
        .fold(Point3::new(f64::INFINITY, f64::INFINITY, f64::INFINITY), |m, p| Point3::new(m.x.min(p.x), m.y.min(p.y), m.z.min(p.z)))
}

fn extent(points: &[Point3<f64>]) -> [f64; 3] {
    let lo = min_corner(points);
    let hi = points.iter().fold(lo, |m, p| Point3::new(m.x.max(p.x), m.y.max(p.y), m.z.max(p.z)));
    [hi.x - lo.x, hi.y - lo.y, hi.z - lo.z]
}

#[test]
fn plane_ply_has_all_points() {
    let c = load_cloud(lidar!("plane.ply"), "plane.ply").unwrap();
    assert_eq!(c.len(), 28_185);
    assert_eq!(c.classification.as_ref().map(Vec::len), Some(28_185));
    // SOURCES.md: a 2.2 m × 2.0 m plane, z spread 4 cm, origin at the minimum corner.
    let lo = min_corner(&c.points);
    assert!(lo.coords.norm() < 1e-6, "min corner {lo:?}");
    let [dx, dy, dz] = extent(&c.points);
    assert!((dx - 2.2).abs() < 0.1 && (dy - 2.0).abs() < 0.1 && dz < 0.06, "extent {dx} {dy} {dz}");
}

#[test]
fn autzen_ply_counts_ground() {
    let c = load_cloud(lidar!("autzen_trim.ply"), "autzen_trim.PLY").unwrap();
    assert_eq!(c.len(), 110_000);
    let class = c.classification.unwrap();
    assert_eq!(class.iter().filter(|&&k| k == 2).count(), 26_107);
    assert_eq!(class.iter().filter(|&&k| k == 1).count(), 83_893);
}

#[cfg(feature = "las")]
#[test]
fn vegetation_las_and_ply_agree_after_min_corner() {
    let las = load_cloud(lidar!("vegetation_1_3.las"), "vegetation_1_3.las").unwrap();
    let ply = load_cloud(lidar!("vegetation_1_3.ply"), "vegetation_1_3.ply").unwrap();
    assert_eq!(las.len(), 10_683);
    assert_eq!(ply.len(), 10_683);
    assert_eq!(las.classification, ply.classification);
    let (a0, b0) = (min_corner(&las.points), min_corner(&ply.points));
    let mut worst = 0.0f64;
    for (a, b) in las.points.iter().zip(&ply.points) {
        worst = worst.max(((a - a0) - (b - b0)).amax());
    }
    // The PLY stores f32 metres of up to ~6 m: ≤ 0.5 µm rounding.
    assert!(worst < 1e-5, "largest LAS/PLY difference {worst} m");
    let [dx, dy, dz] = extent(&ply.points);
    assert!((dx - 3.8).abs() < 0.1 && (dy - 6.0).abs() < 0.1 && (dz - 4.9).abs() < 0.1, "extent {dx} {dy} {dz}");
}

#[test]
fn dispatch_on_extension() {
    let csv = b"1,2,3\n";
    assert_eq!(load_cloud(csv, "dir.v2/pts.CSV").unwrap().len(), 1);
    let e = load_cloud(csv, "pts.txt").unwrap_err();
    assert_eq!(e.to_string(), "pts.txt: unknown point-cloud extension (expected .pcd, .ply, .csv, .las or .laz)");
    assert!(matches!(load_cloud(csv, "dir.d/noext"), Err(CloudError::UnknownExtension { .. })));
    let pcd = pcd::write_pcd(&PointCloud::from_points(vec![Point3::new(1.0, 2.0, 3.0)]), pcd::PcdEncoding::Binary);
    assert_eq!(load_cloud(&pcd, "a.Pcd").unwrap().points, vec![Point3::new(1.0, 2.0, 3.0)]);
    assert!(load_cloud(b"not las", "a.LAZ").is_err());
}

#[test]
fn ply_from_one_format_reads_same_in_others() {
    let c = load_cloud(lidar!("plane.ply"), "plane.ply").unwrap();
    let small = PointCloud {
        points: c.points[..500].to_vec(),
        covariances: None,
        classification: c.classification.as_ref().map(|k| k[..500].to_vec()),
    };
    let via_ply = ply::load_ply(&ply::write_ply_binary(&small), "a.ply").unwrap();
    let via_pcd = pcd::load_pcd(&pcd::write_pcd(&small, pcd::PcdEncoding::Ascii), "a.pcd").unwrap();
    let via_csv = csv::load_csv(csv::write_csv(&small).as_bytes(), "a.csv").unwrap();
    assert_eq!(via_ply, small);
    assert_eq!(via_pcd, small);
    assert_eq!(via_csv.points, small.points);
}

/// Load time of the largest real cloud. Run with
/// `cargo test --release -p fitslam-core io::tests::bench_autzen_load -- --ignored --nocapture`.
#[test]
#[ignore]
fn bench_autzen_load() {
    let bytes = lidar!("autzen_trim.ply");
    let runs = 50;
    let start = std::time::Instant::now();
    let mut n = 0;
    for _ in 0..runs {
        n += load_cloud(std::hint::black_box(bytes), "autzen_trim.ply").unwrap().len();
    }
    let per = start.elapsed().as_secs_f64() / runs as f64;
    assert_eq!(n, 110_000 * runs);
    println!("autzen_trim.ply: {:.2} ms per load ({:.1} Mpoints/s)", per * 1e3, 0.11 / per);
    let big = ply::write_ply_binary(&load_cloud(bytes, "a.ply").unwrap());
    let start = std::time::Instant::now();
    for _ in 0..runs {
        std::hint::black_box(ply::load_ply(std::hint::black_box(&big), "a.ply").unwrap());
    }
    println!("same cloud as double PLY: {:.2} ms per load", start.elapsed().as_secs_f64() / runs as f64 * 1e3);
}

/// Some editors start text files with a UTF-8 byte-order mark: every text loader reads such a
/// file as the same file without it (a CSV header was once read by position instead, swapping
/// its columns, and a map YAML was refused).
#[test]
fn a_byte_order_mark_is_read_past_by_every_text_loader() {
    fn with_bom(text: &str) -> Vec<u8> {
        [b"\xEF\xBB\xBF".as_slice(), text.as_bytes()].concat()
    }
    let csv = "z,x,y\n0.1,10,20\n0.2,12,21\n";
    let plain = load_csv(csv.as_bytes(), "c.csv").unwrap();
    assert_eq!(plain.points[0], Point3::new(10.0, 20.0, 0.1));
    assert_eq!(load_csv(&with_bom(csv), "c.csv").unwrap(), plain);

    let pcd =
        "# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2 3\n";
    assert_eq!(load_pcd(&with_bom(pcd), "c.pcd").unwrap(), load_pcd(pcd.as_bytes(), "c.pcd").unwrap());

    let yaml = "image: m.pgm\nresolution: 0.05\norigin: [1.0, -2.0, 0.0]\nnegate: 0\noccupied_thresh: 0.65\nfree_thresh: 0.196\n";
    assert_eq!(MapYaml::parse(&with_bom(yaml), "m.yaml").unwrap(), MapYaml::parse(yaml.as_bytes(), "m.yaml").unwrap());

    let g2o = "VERTEX_SE2 0 0 0 0\nVERTEX_SE2 1 1 0 0\nEDGE_SE2 0 1 1 0 0 1 0 0 1 0 1\n";
    let read_g2o = crate::slam::g2o::read_g2o;
    assert_eq!(read_g2o(&with_bom(g2o)).unwrap(), read_g2o(g2o.as_bytes()).unwrap());
    assert!(read_g2o(&with_bom(g2o)).unwrap().skipped.is_empty());

    let victoria = "ODOMETRY 0 1 1 0 0.1 1 0 0 1 0 1\n";
    let read_victoria = crate::slam::victoria::read_victoria;
    assert_eq!(read_victoria(&with_bom(victoria)).unwrap(), read_victoria(victoria.as_bytes()).unwrap());

    for (text, name) in [("[u1]\nalpha = 0.5\n", "p.toml"), ("u1:\n  alpha: 0.5\n", "p.yaml")] {
        let p = crate::Params::from_bytes(&with_bom(text), name).unwrap();
        assert_eq!(p, crate::Params::from_bytes(text.as_bytes(), name).unwrap());
        assert_ne!(*p, crate::Params::default(), "{name} was read");
    }

    let sim = "[explore]\nmax_failed_decisions = 7\n";
    let bom_sim = String::from_utf8(with_bom(sim)).unwrap();
    let m = crate::sim::MissionParams::from_toml(&bom_sim, "m.toml").unwrap();
    assert_eq!((m.explore.max_failed_decisions, &m), (7, &crate::sim::MissionParams::from_toml(sim, "m.toml").unwrap()));

    let world = include_str!("../../../assets/worlds/tiny_test.toml");
    let bom_world = String::from_utf8(with_bom(world)).unwrap();
    let spec = crate::sim::WorldSpec::from_toml;
    assert_eq!(spec(&bom_world, "w.toml").unwrap(), spec(world, "w.toml").unwrap());
}
