#![no_main]
//! Any bytes given to the rosbag2 MCAP reader give a bag or an error, never a panic; a bag that
//! parses is asked for its topics, decision instants and the inputs at its start and end.
use fitslam_core::bag::{Bag, BagTopics};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(bag) = Bag::parse(data, "fuzz.mcap") {
        let topics = BagTopics::default();
        let _ = bag.topics();
        let _ = bag.decision_instants(&topics);
        let _ = bag.snapshot(&topics, 0.0);
        let _ = bag.snapshot(&topics, bag.duration_s());
    }
});
