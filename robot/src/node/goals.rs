//! Goals sent to the navigation stack: sending, what the stack says about them, and their
//! supervision every poll — no answer from the action server, not reached in time, or a cell the
//! latest map no longer holds free. Each ending is told to the explorer: reached (remembered),
//! failed (blacklisted) or dropped (may be chosen again).

use super::{Command, ExplorerNode, GoalEvent, NodeGoal};
use fitslam_core::Pose2;
use fitslam_core::explore::Plan;

/// How a goal ended, for the explorer.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Ending {
    Reached,
    Failed,
    Dropped,
}

impl ExplorerNode {
    /// Sends the plan's goal: the set-back end of its path, facing Θ*.
    pub(super) fn send(&mut self, plan: &Plan, now_s: f64) -> Command {
        let g = plan.goal;
        self.send_goal(plan.target(), [g.goal.x_m, g.goal.y_m], g.inflation_m, g.on_trail, now_s)
    }

    /// Sends `goal`, serving the frontier candidate at `frontier_m`, supervised at `inflation_m`
    /// (and with the trail open when `on_trail`).
    pub(super) fn send_goal(&mut self, goal: Pose2, frontier_m: [f64; 2], inflation_m: f64, on_trail: bool, now_s: f64) -> Command {
        let id = self.next_goal_id;
        self.next_goal_id += 1;
        let accepted_s = self.topic_goals().then_some(now_s);
        let frontier_m = Some(frontier_m);
        self.goal = Some(NodeGoal { id, goal, frontier_m, sent_s: now_s, accepted_s, heard_s: None, inflation_m, on_trail });
        self.stats.goals_sent += 1;
        self.info(now_s, format!("goal {id}: ({:.2}, {:.2}) m, heading {:.0}°", goal.x_m, goal.y_m, goal.yaw_rad.to_degrees()));
        Command::SendGoal { id, goal }
    }

    /// What the navigation stack said about goal `id`. Events for other ids (an old goal) are
    /// ignored.
    pub fn on_goal_event(&mut self, id: u64, event: GoalEvent, now_s: f64) {
        let Some(g) = self.goal.filter(|g| g.id == id) else { return };
        let (x, y) = (g.goal.x_m, g.goal.y_m);
        match event {
            GoalEvent::Accepted => {
                if let Some(g) = &mut self.goal {
                    g.accepted_s.get_or_insert(now_s);
                    g.heard_s = Some(now_s);
                }
            }
            GoalEvent::Feedback => {
                if let Some(g) = &mut self.goal {
                    g.heard_s = Some(now_s);
                }
            }
            GoalEvent::Succeeded => {
                self.stats.succeeded += 1;
                self.info(now_s, format!("goal {id} at ({x:.2}, {y:.2}) reached"));
                self.end_goal(Ending::Reached, true);
            }
            GoalEvent::Rejected => {
                self.stats.rejected += 1;
                self.warn("goal", now_s, format!("goal {id} at ({x:.2}, {y:.2}) rejected: blacklisted"));
                self.end_goal(Ending::Failed, true);
            }
            GoalEvent::Aborted(why) => {
                self.stats.failed += 1;
                self.warn("goal", now_s, format!("goal {id} at ({x:.2}, {y:.2}) aborted ({why}): blacklisted"));
                self.end_goal(Ending::Failed, true);
            }
            GoalEvent::Canceled => {
                self.stats.failed += 1;
                self.warn("goal", now_s, format!("goal {id} at ({x:.2}, {y:.2}) cancelled by another client: blacklisted"));
                self.end_goal(Ending::Failed, true);
            }
            GoalEvent::Lost(why) => {
                self.stats.lost += 1;
                self.warn("goal_lost", now_s, format!("goal {id} at ({x:.2}, {y:.2}) lost ({why}): will plan again"));
                self.end_goal(Ending::Dropped, false);
            }
        }
    }

    fn end_goal(&mut self, ending: Ending, replan_now: bool) {
        if self.returning.is_some() {
            // The goal back to the start: not the explorer's.
            if self.goal.take().is_some() {
                self.return_outcome = Some(match ending {
                    Ending::Reached => "returned to the start",
                    Ending::Failed => "the return to the start failed",
                    Ending::Dropped => "the return to the start was dropped",
                });
            }
            return;
        }
        if self.goal.take().is_some() {
            match ending {
                Ending::Reached => self.explorer.goal_reached(),
                Ending::Failed => self.explorer.goal_failed(),
                Ending::Dropped => self.explorer.goal_dropped(),
            }
        }
        self.replan_now |= replan_now;
    }

    /// Every poll: the goal's answer and progress, and whether its cell is still free.
    pub(super) fn supervise_goal(&mut self, now_s: f64, out: &mut Vec<Command>) {
        let Some(g) = self.goal else { return };
        let (x, y) = (g.goal.x_m, g.goal.y_m);
        match g.accepted_s {
            None if now_s - g.sent_s > self.cfg.goal_response_timeout_s => {
                self.stats.lost += 1;
                let text = format!(
                    "no answer from the navigation server within {} s for goal {} at ({x:.2}, {y:.2}): dropped, will send again",
                    self.cfg.goal_response_timeout_s, g.id
                );
                self.warn("goal_lost", now_s, text);
                out.push(Command::CancelGoal { id: g.id });
                self.end_goal(Ending::Dropped, false);
                return;
            }
            Some(t) if now_s - t > self.cfg.goal_timeout_s => {
                self.stats.timed_out += 1;
                let text =
                    format!("goal {} at ({x:.2}, {y:.2}) not reached within {} s: cancelled, blacklisted", g.id, self.cfg.goal_timeout_s);
                self.warn("goal", now_s, text);
                out.push(Command::CancelGoal { id: g.id });
                self.end_goal(Ending::Failed, true);
                return;
            }
            _ => {}
        }
        let silence = self.cfg.goal_feedback_timeout_s;
        if let Some(heard) = g.heard_s
            && silence > 0.0
            && now_s - heard > silence
        {
            self.stats.lost += 1;
            let text = format!(
                "no feedback from the navigation server for {silence} s on goal {} at ({x:.2}, {y:.2}) (server restarted or gone?): dropped, will plan again",
                g.id
            );
            self.warn("goal_lost", now_s, text);
            out.push(Command::CancelGoal { id: g.id });
            self.end_goal(Ending::Dropped, true);
            return;
        }
        if !self.goal_is_free(x, y, g.inflation_m, g.on_trail) {
            let text = format!("goal {} at ({x:.2}, {y:.2}) is no longer free on the latest map: cancelled", g.id);
            self.warn("goal_lethal", now_s, text);
            out.push(Command::CancelGoal { id: g.id });
            self.stats.replaced += 1;
            self.end_goal(Ending::Dropped, true);
            return;
        }
        if self.topic_goals()
            && let Ok(p) = self.robot_pose(now_s)
            && (p.x_m - x).hypot(p.y_m - y) <= self.cfg.goal_tolerance_m
        {
            self.on_goal_event(g.id, GoalEvent::Succeeded, now_s);
        }
    }
}
