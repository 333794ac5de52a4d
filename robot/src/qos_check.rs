//! Publishers the node cannot hear: DDS matches a writer to a reader only when every offered
//! QoS policy is at least the requested one (DDS 1.4 §2.2.3: durability, reliability, deadline,
//! liveliness, ownership…), and an incompatible pair stays silent on both sides. The classic
//! case is a VOLATILE map publisher against the node's TRANSIENT_LOCAL subscription (what
//! map_server and the SLAMs offer). This check compares the writers discovered on each
//! subscribed topic with what the node requests and names every incompatible one.

use ros2_client::QosProfile;
use ros2_client::dds::rustdds::{DomainParticipant, QosPolicies};

/// One subscription to watch.
#[derive(Clone, Debug)]
struct Watched {
    /// The ROS name, as configured (`/map`).
    ros_name: String,
    /// The DDS topic (`rt/map`).
    dds_topic: String,
    requested: QosPolicies,
    /// What to do about it, for the warning.
    hint: &'static str,
}

/// The node's subscriptions and what they request.
#[derive(Clone, Debug, Default)]
pub struct QosWatch {
    watched: Vec<Watched>,
}

impl QosWatch {
    /// Watches the subscription `ros_name` (DDS topic `dds_topic`) requesting `qos`.
    pub fn add(&mut self, ros_name: &str, dds_topic: String, qos: &QosProfile, hint: &'static str) {
        self.watched.push(Watched { ros_name: ros_name.to_owned(), dds_topic, requested: QosPolicies::from(qos), hint });
    }

    /// One line per discovered writer whose offered QoS the node's subscription cannot match,
    /// sorted.
    pub fn incompatible(&self, participant: &DomainParticipant) -> Vec<String> {
        let writers = participant.discovered_writers();
        let mut out: Vec<String> = writers
            .iter()
            .flat_map(|w| {
                let data = &w.publication_topic_data;
                let offered = data.qos();
                self.watched.iter().filter(move |s| s.dds_topic == data.topic_name).filter_map(move |s| {
                    let policy = offered.compliance_failure_wrt(&s.requested)?;
                    Some(describe(s, &offered, &format!("{policy:?}")))
                })
            })
            .collect();
        out.sort();
        out.dedup();
        out
    }
}

/// The warning for one incompatible writer on `s`.
fn describe(s: &Watched, offered: &QosPolicies, policy: &str) -> String {
    let durability = |q: &QosPolicies| q.durability().map_or("VOLATILE (default)".to_owned(), |d| screaming(&format!("{d:?}")));
    let reliability = |q: &QosPolicies| q.reliability().map_or("BEST_EFFORT (default)".to_owned(), |r| screaming(&format!("{r:?}")));
    format!(
        "a publisher on {} offers a QoS this node cannot match ({policy}): it offers {}, {}; the node requests {}, {}. {}",
        s.ros_name,
        durability(offered),
        reliability(offered),
        durability(&s.requested),
        reliability(&s.requested),
        s.hint
    )
}

/// A policy value's `Debug` as DDS spells it: `TransientLocal` → `TRANSIENT_LOCAL`,
/// `Reliable { max_blocking_time: … }` → `RELIABLE`.
fn screaming(debug: &str) -> String {
    let name = debug.split([' ', '{', '(']).next().unwrap_or(debug);
    let mut out = String::new();
    for (i, c) in name.chars().enumerate() {
        if c.is_uppercase() && i > 0 {
            out.push('_');
        }
        out.push(c.to_ascii_uppercase());
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ros::{latched, reliable};

    #[test]
    fn a_volatile_offer_cannot_serve_a_transient_local_request_and_the_warning_says_so() {
        let mut w = QosWatch::default();
        w.add("/map", "rt/map".into(), &latched(1), "Publish it TRANSIENT_LOCAL or set map_transient_local: false.");
        let s = &w.watched[0];
        let offered = QosPolicies::from(&reliable(1));
        let policy = offered.compliance_failure_wrt(&s.requested).expect("volatile < transient local");
        let text = describe(s, &offered, &format!("{policy:?}"));
        assert!(text.contains("on /map") && text.contains("offers VOLATILE, RELIABLE"), "{text}");
        assert!(text.contains("requests TRANSIENT_LOCAL, RELIABLE") && text.ends_with("map_transient_local: false."), "{text}");
        assert_eq!(screaming("BestEffort"), "BEST_EFFORT");
        // The reverse is fine: a latched offer serves a volatile request.
        assert!(QosPolicies::from(&latched(1)).compliance_failure_wrt(&QosPolicies::from(&reliable(1))).is_none());
    }
}
