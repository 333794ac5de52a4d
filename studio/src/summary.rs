//! One candidate's numbers as a small grid: the canvas' tooltip and the details panel show it.

use crate::export::drop_text;
use fitslam_core::select::{CandidateReport, Decision};

/// `v` with `decimals` decimals, or a dash when the candidate has no such number.
pub fn fmt(v: Option<f64>, decimals: usize) -> String {
    v.map(|x| format!("{x:.decimals$}")).unwrap_or_else(|| "—".into())
}

/// ρ, ΔE, Θ*, u1, I_p, u2 of one candidate (tooltip and details panel).
pub fn candidate_summary(ui: &mut egui::Ui, d: &Decision, i: usize, c: &CandidateReport) {
    let title = match c.rank {
        Some(r) if d.chosen == Some(i) => format!("Candidate {i} — rank {r} (chosen)"),
        Some(r) => format!("Candidate {i} — rank {r}"),
        None => format!("Candidate {i} — not ranked ({})", drop_text(c.dropped)),
    };
    ui.label(egui::RichText::new(title).strong());
    egui::Grid::new(("summary", i)).num_columns(2).show(ui, |ui| {
        let mut row = |k: &str, v: String| {
            ui.label(k);
            ui.label(v);
            ui.end_row();
        };
        row("position", format!("({:.2}, {:.2}) m", c.x_m, c.y_m));
        row("ρ (path)", format!("{} m", fmt(c.rho_m, 2)));
        row("ΔE", format!("{} bits", fmt(c.delta_e_bits, 2)));
        row("Θ*", format!("{}°", fmt(c.theta_star_rad.map(f64::to_degrees), 1)));
        row("u1", format!("{} (rank {})", fmt(c.u1, 3), c.u1_rank.map(|r| r.to_string()).unwrap_or_else(|| "—".into())));
        row("I_p", format!("{} (raw {})", fmt(c.path_info, 3), fmt(c.path_info_raw, 1)));
        row("u2", fmt(c.u2, 3));
        row("cluster", format!("{} cells", c.cluster_size));
    });
}
