//! The exploration policy, one for every face: the simulator's [`crate::sim::Mission`], the robot
//! node and the studio's Mission mode all call [`Explorer::decide`] and act on its [`Action`];
//! they keep only what is theirs (driving or Nav2 goals, sensing or messages, timeouts).
//!
//! | file | what |
//! |---|---|
//! | [`explorer`] | [`Explorer`]: the selector, the blacklist, the goals reached, the retry chain, goal keep/replace, the set-back |
//! | [`action`] | what a decision is given ([`Situation`]) and answers ([`Action`], [`Plan`], [`EndReason`]) |
//! | [`params`] | [`ExploreParams`]: nested as `explore` in the simulator's and the node's files |
//! | [`trail`] | [`Trail`]: where the robot's centre has driven, rasterised on any map |

pub mod action;
pub mod explorer;
pub mod params;
pub mod trail;

pub use action::{Action, ActiveGoal, EndReason, Plan, Situation, WaitReason};

pub use action::ExploreStats;
pub use explorer::AttemptRecord;
pub use explorer::{Attempt, Explorer, TracedDecision};
pub use params::{EXPLORE_KEYS, ExploreParams};
pub use trail::Trail;

#[cfg(test)]
mod tests;
