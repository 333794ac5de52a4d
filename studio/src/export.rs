//! What the studio writes out: the ranking as CSV or JSON, the parameters as the robot node's
//! YAML (`Params::to_yaml`, exactly the struct the node reads), and a one-line digest of the
//! ranking (the browser's `document.title`, the native window title).

use fitslam_core::params::Strategy;
use fitslam_core::select::{CandidateReport, Decision, DropReason};
use serde::Serialize;

/// The score a strategy ranks by, for display and digests: u2 (FIT-SLAM), u1 (u1-only),
/// ρ (greedy, smaller is better), u1 for random (it draws uniformly; u1 is informative), u2 for
/// the length-matched controls (they draw at FIT-SLAM's distance; u2 shows what they left), u2
/// with the path length for `u2_length`.
pub fn final_score(strategy: Strategy, c: &CandidateReport) -> Option<f64> {
    match strategy {
        Strategy::Fit | Strategy::Matched | Strategy::MatchedTop | Strategy::U2Length | Strategy::U2Truth => c.u2,
        Strategy::U1 | Strategy::Random => c.u1,
        Strategy::Greedy => c.rho_m,
    }
}

/// Short digest: `fitslam: chosen=3 top=[(3,0.712),(5,0.660),(1,0.601)]` (candidate index and
/// the strategy's score, best first, at most `top` entries); `fitslam: no goal` without one.
pub fn digest(decision: &Decision, top: usize) -> String {
    let Some(chosen) = decision.chosen else { return "fitslam: no goal".to_string() };
    let items: Vec<String> = decision
        .ranking()
        .into_iter()
        .take(top)
        .map(|i| format!("({},{:.3})", i, final_score(decision.strategy, &decision.candidates[i]).unwrap_or(f64::NAN)))
        .collect();
    format!("fitslam: chosen={chosen} top=[{}]", items.join(","))
}

/// Why a candidate was dropped, as a short word for tables and CSV.
pub fn drop_text(d: Option<DropReason>) -> String {
    match d {
        None => String::new(),
        Some(DropReason::NoPath) => "no_path".into(),
        Some(DropReason::NotInTopN) => "not_in_top_n".into(),
        Some(DropReason::Blacklisted(r)) => {
            format!("blacklisted_{}", serde_json::to_value(r).ok().and_then(|v| v.as_str().map(str::to_string)).unwrap_or_default())
        }
    }
}

fn opt(v: Option<f64>) -> String {
    v.map(|x| format!("{x}")).unwrap_or_default()
}

/// The ranking as CSV, one row per candidate in rank order (unranked ones last, by index).
pub fn ranking_csv(decision: &Decision) -> String {
    let mut s = String::from(
        "index,rank,u1_rank,chosen,x_m,y_m,cluster_size,rho_m,delta_e_bits,theta_star_rad,u1,path_info_raw,path_info,u2,waypoints,dropped\n",
    );
    for i in ordered(decision) {
        let c = &decision.candidates[i];
        s += &format!(
            "{i},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            c.rank.map(|r| r.to_string()).unwrap_or_default(),
            c.u1_rank.map(|r| r.to_string()).unwrap_or_default(),
            u8::from(decision.chosen == Some(i)),
            c.x_m,
            c.y_m,
            c.cluster_size,
            opt(c.rho_m),
            opt(c.delta_e_bits),
            opt(c.theta_star_rad),
            opt(c.u1),
            opt(c.path_info_raw),
            opt(c.path_info),
            opt(c.u2),
            c.waypoints.len(),
            drop_text(c.dropped),
        );
    }
    s
}

/// Candidate indices: ranked ones by rank, then the rest by index.
pub fn ordered(decision: &Decision) -> Vec<usize> {
    let mut r = decision.ranking();
    r.extend((0..decision.candidates.len()).filter(|&i| decision.candidates[i].rank.is_none()));
    r
}

#[derive(Serialize)]
struct RankingExport<'a> {
    map: &'a str,
    landmarks: &'a str,
    params: &'a fitslam_core::Params,
    /// Candidate indices in rank order.
    ranking: Vec<usize>,
    decision: &'a Decision,
}

/// The ranking as JSON: the map and landmark names, the parameters, the rank order and the
/// whole decision (every candidate's ρ, ΔE, Θ*, rays, u1, waypoints, I_p, u2).
pub fn ranking_json(decision: &Decision, params: &fitslam_core::Params, map: &str, landmarks: &str) -> String {
    let e = RankingExport { map, landmarks, params, ranking: decision.ranking(), decision };
    serde_json::to_string_pretty(&e).unwrap_or_else(|err| format!("{{\"error\": \"{err}\"}}"))
}

/// A compact JSON of the ranking for page scripts: chosen index, and per ranked candidate its
/// index, rank, position and scores.
pub fn ranking_brief_json(decision: &Decision) -> String {
    #[derive(Serialize)]
    struct Row {
        index: usize,
        rank: Option<usize>,
        x_m: f64,
        y_m: f64,
        rho_m: Option<f64>,
        delta_e_bits: Option<f64>,
        u1: Option<f64>,
        path_info: Option<f64>,
        u2: Option<f64>,
    }
    #[derive(Serialize)]
    struct Brief {
        strategy: Strategy,
        chosen: Option<usize>,
        candidates: usize,
        ranked: Vec<Row>,
    }
    let ranked = decision
        .ranking()
        .into_iter()
        .map(|i| {
            let c = &decision.candidates[i];
            Row {
                index: i,
                rank: c.rank,
                x_m: c.x_m,
                y_m: c.y_m,
                rho_m: c.rho_m,
                delta_e_bits: c.delta_e_bits,
                u1: c.u1,
                path_info: c.path_info,
                u2: c.u2,
            }
        })
        .collect();
    serde_json::to_string(&Brief { strategy: decision.strategy, chosen: decision.chosen, candidates: decision.candidates.len(), ranked })
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;
    use fitslam_core::{Cell, Pose2};

    fn decision() -> Decision {
        let mut a = CandidateReport::new(Cell::new(1, 1), 1.0, 1.0, vec![Cell::new(1, 1)]);
        a.u1 = Some(0.5);
        a.u2 = Some(0.25);
        a.rank = Some(2);
        a.rho_m = Some(3.0);
        let mut b = CandidateReport::new(Cell::new(2, 2), 2.0, 2.0, vec![Cell::new(2, 2)]);
        b.u1 = Some(0.9);
        b.u2 = Some(0.75);
        b.rank = Some(1);
        b.rho_m = Some(1.5);
        let mut c = CandidateReport::new(Cell::new(3, 3), 3.0, 3.0, vec![Cell::new(3, 3)]);
        c.dropped = Some(DropReason::NoPath);
        Decision {
            strategy: Strategy::Fit,
            chosen: Some(1),
            goal: Some(Pose2::new(2.0, 2.0, 0.0)),
            robot: Pose2::new(0.0, 0.0, 0.0),
            robot_cell: Cell::new(0, 0),
            requested_robot_cell: Cell::new(0, 0),
            start_snapped: false,
            ray_angles_rad: vec![],
            candidates: vec![a, b, c],
        }
    }

    #[test]
    fn digest_lists_the_ranking_best_first() {
        assert_eq!(digest(&decision(), 3), "fitslam: chosen=1 top=[(1,0.750),(0,0.250)]");
        assert_eq!(digest(&decision(), 1), "fitslam: chosen=1 top=[(1,0.750)]");
        let mut d = decision();
        d.chosen = None;
        assert_eq!(digest(&d, 3), "fitslam: no goal");
        d.strategy = Strategy::Greedy;
        d.chosen = Some(1);
        assert_eq!(digest(&d, 1), "fitslam: chosen=1 top=[(1,1.500)]");
    }

    #[test]
    fn csv_rows_follow_the_rank_then_the_unranked() {
        let csv = ranking_csv(&decision());
        let rows: Vec<&str> = csv.lines().collect();
        assert_eq!(rows.len(), 4);
        assert!(rows[0].starts_with("index,rank,"));
        assert!(rows[1].starts_with("1,1,,1,2,2,1,1.5,"), "{}", rows[1]);
        assert!(rows[2].starts_with("0,2,,0,"), "{}", rows[2]);
        assert!(rows[3].starts_with("2,,,0,") && rows[3].ends_with(",0,no_path"), "{}", rows[3]);
        assert_eq!(rows.iter().map(|r| r.split(',').count()).collect::<Vec<_>>(), vec![16; 4]);
    }

    #[test]
    fn brief_json_has_the_ranked_candidates() {
        let v: serde_json::Value = serde_json::from_str(&ranking_brief_json(&decision())).unwrap();
        assert_eq!(v["chosen"], 1);
        assert_eq!(v["candidates"], 3);
        assert_eq!(v["ranked"].as_array().unwrap().iter().map(|r| r["index"].as_u64().unwrap()).collect::<Vec<_>>(), vec![1, 0]);
    }
}
