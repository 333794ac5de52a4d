//! Colour rendering of the score layer for images (CLI PNG, studio textures).
//!
//! Unknown cells are grey; known cells go from red (score 0, lethal) through yellow to green
//! (score 1, free) linearly. O(cells).

use super::estimate::TraversabilityLayers;

/// RGB of unknown cells.
pub const UNKNOWN_RGB: [u8; 3] = [128, 128, 128];

/// RGB of one score value (NaN: [`UNKNOWN_RGB`]).
pub fn score_rgb(score: f32) -> [u8; 3] {
    if score.is_nan() {
        return UNKNOWN_RGB;
    }
    let s = score.clamp(0.0, 1.0);
    // Red → yellow over [0, 0.5], yellow → green over [0.5, 1].
    let r = (2.0 * (1.0 - s)).min(1.0);
    let g = (2.0 * s).min(1.0);
    [(r * 255.0).round() as u8, (g * 255.0).round() as u8, 0]
}

/// The score layer as 8-bit RGB, `width × height × 3` bytes, **top row first** (image order: the
/// grid's last row, highest y, comes first).
pub fn score_to_rgb(layers: &TraversabilityLayers) -> Vec<u8> {
    let g = layers.geometry();
    let mut out = Vec::with_capacity(g.len() * 3);
    for row in (0..g.height).rev() {
        for &s in &layers.score.data[row * g.width..(row + 1) * g.width] {
            out.extend_from_slice(&score_rgb(s));
        }
    }
    out
}
