//! Wire-format interoperability with an independent DDS implementation: Eclipse Cyclone DDS
//! through PyPI `cyclonedds` (the DDS under ROS 2's rmw_cyclonedds), driven by
//! `tests/interop/cyclone_peer.py`. Cyclone publishes an OccupancyGrid map, a big-endian
//! float64 PointCloud2 of landmarks and /tf; the node must answer with a PoseStamped goal on
//! /goal_pose that Cyclone decodes, in the map frame, on a free cell, at the frontier FIT-SLAM
//! prefers. Loopback only, on a private domain.
//!
//! Needs `cyclonedds` for python3; without it this test FAILS and says how to install it.

#![allow(clippy::unwrap_used, clippy::expect_used)] // a test: a failure should stop it

mod common;

use common::{NodeProcess, private_domain, scratch_dir};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

const PEER_TIMEOUT_S: f64 = 60.0;

/// Cyclone DDS on 127.0.0.1 only, no multicast, discovery by unicast to local participants.
const CYCLONE_LOOPBACK: &str = "<CycloneDDS><Domain id=\"any\"><General><Interfaces>\
<NetworkInterface address=\"127.0.0.1\"/></Interfaces><AllowMulticast>false</AllowMulticast></General>\
<Discovery><ParticipantIndex>auto</ParticipantIndex><MaxAutoParticipantIndex>40</MaxAutoParticipantIndex>\
<Peers><Peer address=\"127.0.0.1\"/></Peers></Discovery></Domain></CycloneDDS>";

#[test]
fn cyclone_dds_peer_receives_a_goal_for_its_map() {
    let has_cyclone = Command::new("python3")
        .args(["-c", "import cyclonedds"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    assert!(
        has_cyclone,
        "this test needs the Python package cyclonedds (an independent DDS): \
         `python3 -m pip install cyclonedds==11.0.1` (CI's .ci/run installs it)"
    );
    let domain = private_domain(10, 80);
    let dir = scratch_dir("cyclone-interop");
    let config = dir.join("node.yaml");
    std::fs::write(&config, "node:\n  goal_interface: topic\n  replan_period_s: 0.5\n  map_transient_local: true\n").unwrap();
    let node = NodeProcess::start(&config, domain, &dir);
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/interop/cyclone_peer.py");
    let peer_log = dir.join("peer.log");
    let mut peer = Command::new("python3")
        .arg(script)
        .arg(domain.to_string())
        .arg(PEER_TIMEOUT_S.to_string())
        .env("CYCLONEDDS_URI", CYCLONE_LOOPBACK)
        .stdout(Stdio::from(std::fs::File::create(&peer_log).unwrap()))
        .stderr(Stdio::from(std::fs::File::create(dir.join("peer.err")).unwrap()))
        .spawn()
        .expect("python3");
    let t0 = Instant::now();
    let status = loop {
        if let Ok(Some(s)) = peer.try_wait() {
            break Some(s);
        }
        if t0.elapsed().as_secs_f64() > PEER_TIMEOUT_S + 30.0 {
            let _ = peer.kill();
            let _ = peer.wait();
            break None;
        }
        std::thread::sleep(Duration::from_millis(100));
    };
    let out = std::fs::read_to_string(&peer_log).unwrap_or_default();
    let err = std::fs::read_to_string(dir.join("peer.err")).unwrap_or_default();
    let node_log = node.log();
    drop(node);
    eprintln!("{out}");
    assert!(
        status.is_some_and(|s| s.success()) && out.contains("INTEROP OK"),
        "Cyclone DDS peer: {status:?}\n--- peer stdout ---\n{out}\n--- peer stderr ---\n{err}\n--- node log ---\n{node_log}"
    );
}
