//! Inflation of lethal cells by the robot radius, so that a point robot planning on the result
//! keeps its whole footprint off untraversable ground.
//!
//! Exact Euclidean inflation: a cell becomes lethal if the distance between its centre and the
//! centre of any lethal cell is ≤ `radius_m`. Implemented as a stamp of the precomputed disc (one
//! horizontal span per row offset) around each horizontal run of lethal cells: the discs of the
//! cells a..b of a run cover, at row offset dy, exactly the span [a − h(dy), b + h(dy)], so a run
//! costs 2r + 1 fills whatever its length. Runs are found on a per-row bitmask of the lethal
//! cells, 64 cells per word ([`lethal_mask`]: SSE2 byte compares on x86-64; elsewhere chunks
//! without a lethal cell are skipped on their maximum and the others packed 8 cells at a time), a
//! word at a time. O(cells + R · r) for R runs and r the radius in cells. Unknown cells stay
//! unknown unless a disc covers them (then lethal: they are within reach of an obstacle).

use super::{CellClass, FREE, LETHAL, LETHAL_THRESHOLD, OccupancyGrid};

/// Returns a copy of `grid` with every cell within `radius_m` of a lethal cell set to [`LETHAL`].
pub fn inflate_lethal(grid: &OccupancyGrid, radius_m: f64) -> OccupancyGrid {
    let mut out = OccupancyGrid { geometry: grid.geometry, data: Vec::new() };
    inflate_lethal_into(grid, radius_m, &mut out);
    out
}

/// Frees again, in `inflated` (`raw` inflated), every cell of `traversed` (flat indices) that is
/// free in `raw`: a robot's centre may return to cells it has driven on, whatever lethal cells
/// appeared near them since. Cells lethal or unknown in `raw` itself stay as they are; indices
/// outside the grid are skipped. O(traversed).
pub(crate) fn free_traversed(raw: &OccupancyGrid, traversed: &[usize], inflated: &mut OccupancyGrid) {
    for &i in traversed {
        if let (Some(&v), Some(out)) = (raw.data.get(i), inflated.data.get_mut(i))
            && CellClass::of(v) == CellClass::Free
        {
            *out = FREE;
        }
    }
}

/// [`inflate_lethal`] into `out`, reusing its storage (a planner that decides again and again
/// keeps one, so the copy does not allocate and page-fault a fresh grid each time).
pub(crate) fn inflate_lethal_into(grid: &OccupancyGrid, radius_m: f64, out: &mut OccupancyGrid) {
    out.geometry = grid.geometry;
    out.data.clear();
    out.data.extend_from_slice(&grid.data);
    let g = grid.geometry;
    if radius_m.is_nan() || radius_m <= 0.0 || g.is_empty() {
        return;
    }
    let r_cells = (radius_m / g.resolution_m).floor() as i32;
    if r_cells == 0 {
        return;
    }
    let r2 = (radius_m / g.resolution_m) * (radius_m / g.resolution_m) + 1e-9;
    // The disc as one horizontal span per row offset: (dy, half-width in cells).
    let spans: Vec<(i32, i32)> = (-r_cells..=r_cells)
        .map(|dy| (dy, (0..=r_cells).take_while(|&dx| ((dx * dx + dy * dy) as f64) <= r2).last().unwrap_or(0)))
        .collect();
    let (w, h) = (g.width, g.height as i32);
    let stamp = |out: &mut OccupancyGrid, r: i32, a: usize, b: usize| {
        for &(dy, half) in &spans {
            let nr = r + dy;
            if (0..h).contains(&nr) {
                let half = half as usize;
                let (c0, c1) = (a.saturating_sub(half), (b + half).min(w - 1));
                let row = nr as usize * w;
                out.data[row + c0..=row + c1].fill(LETHAL);
            }
        }
    };
    // Each row as a bitmask of its lethal cells, then its runs of set bits.
    let mut lethal = Vec::with_capacity(w.div_ceil(64));
    for (r, row) in grid.data.chunks_exact(w).enumerate() {
        lethal.clear();
        lethal.extend(row.chunks(64).map(lethal_mask));
        let mut a = next_bit(&lethal, 0, true);
        while a < w {
            let b = next_bit(&lethal, a, false);
            stamp(out, r as i32, a, b - 1);
            a = next_bit(&lethal, b, true);
        }
    }
}

/// Bit k set iff `chunk[k]` (at most 64 cells) is lethal. On x86-64 a whole chunk is four SSE2
/// compares and byte masks (≈ 6× faster than the portable path on the decision bench's grid,
/// docs/benchmarks.md); elsewhere, and for a row's last partial chunk, most chunks have no lethal
/// cell and their (vectorised) maximum says so, the others go through [`lethal_bits`].
#[inline]
fn lethal_mask(chunk: &[i8]) -> u64 {
    #[cfg(target_arch = "x86_64")]
    if let Ok(cells) = <&[i8; 64]>::try_from(chunk) {
        // Signed compare: unknown (−1) is below the threshold, as it must be.
        use safe_arch::{cmp_gt_mask_i8_m128i, load_unaligned_m128i, move_mask_i8_m128i, set_splat_i8_m128i};
        let threshold = set_splat_i8_m128i(LETHAL_THRESHOLD - 1);
        let mut bits = 0u64;
        for (k, sixteen) in cells.as_chunks::<16>().0.iter().enumerate() {
            let v = load_unaligned_m128i(&sixteen.map(|v| v as u8));
            let mask = move_mask_i8_m128i(cmp_gt_mask_i8_m128i(v, threshold));
            bits |= u64::from(mask as u16) << (16 * k);
        }
        return bits;
    }
    if chunk.iter().copied().max().is_some_and(|v| v >= LETHAL_THRESHOLD) { lethal_bits(chunk) } else { 0 }
}

/// Bit k set iff `chunk[k]` (at most 64 cells) is lethal: 8 cells per step, SWAR on their bytes.
fn lethal_bits(chunk: &[i8]) -> u64 {
    const { assert!(LETHAL_THRESHOLD > 0) };
    const LOW7: u64 = 0x7f7f_7f7f_7f7f_7f7f;
    const HIGH: u64 = 0x8080_8080_8080_8080;
    // Bytes b ≤ 127 get their high bit iff b ≥ T once 128 − T is added (no carry between bytes);
    // negative values (unknown) have their own high bit set and are masked out.
    const ADD: u64 = (128 - LETHAL_THRESHOLD as u64) * 0x0101_0101_0101_0101;
    // Gathers bit 7 of each byte into the top byte, byte k to bit 56 + k.
    const GATHER: u64 = 0x0102_0408_1020_4080;
    let mut bits = 0;
    for (j, eight) in chunk.chunks(8).enumerate() {
        let mut bytes = [0u8; 8];
        for (b, &v) in bytes.iter_mut().zip(eight) {
            *b = v as u8;
        }
        let x = u64::from_le_bytes(bytes);
        let ge = ((x & LOW7) + ADD) & HIGH & !x;
        bits |= ((ge >> 7).wrapping_mul(GATHER) >> 56) << (8 * j);
    }
    bits
}

/// Index of the first bit at or after `from` that is set (`set`) or clear (`!set`) in `bits`;
/// `bits.len() · 64` if none.
fn next_bit(bits: &[u64], from: usize, set: bool) -> usize {
    let flip = if set { 0 } else { u64::MAX };
    let mut word = from / 64;
    let Some(&first) = bits.get(word) else { return bits.len() * 64 };
    let mut m = (first ^ flip) & (u64::MAX << (from % 64));
    loop {
        if m != 0 {
            return word * 64 + m.trailing_zeros() as usize;
        }
        word += 1;
        match bits.get(word) {
            Some(&b) => m = b ^ flip,
            None => return bits.len() * 64,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::{Cell, FREE, Grid, GridGeometry};

    #[test]
    fn traversed_cells_free_before_inflation_are_free_after_it() {
        let g = GridGeometry::new(0.0, 0.0, 0.1, 11, 11);
        let mut grid = Grid::filled(g, FREE);
        grid.data[5 * 11 + 5] = LETHAL;
        grid.data[5 * 11 + 8] = crate::grid::UNKNOWN;
        let mut inflated = inflate_lethal(&grid, 0.25);
        assert_eq!(inflated.data[5 * 11 + 6], LETHAL);
        // A trail over the lethal cell, a cell its inflation covers, an unknown cell and an index
        // outside the grid.
        free_traversed(&grid, &[5 * 11 + 5, 5 * 11 + 6, 5 * 11 + 8, 121], &mut inflated);
        assert_eq!(inflated.data[5 * 11 + 5], LETHAL, "lethal before inflation: stays");
        assert_eq!(inflated.data[5 * 11 + 6], FREE, "free before inflation: freed");
        assert_eq!(inflated.data[5 * 11 + 8], crate::grid::UNKNOWN, "unknown: stays unknown");
        assert_eq!(inflated.data[5 * 11 + 4], LETHAL, "off the trail: unchanged");
    }

    #[test]
    fn single_obstacle_inflates_to_a_disc() {
        let g = GridGeometry::new(0.0, 0.0, 0.1, 11, 11);
        let mut grid = Grid::filled(g, FREE);
        *grid.get_mut(Cell::new(5, 5)).unwrap() = LETHAL;
        let out = inflate_lethal(&grid, 0.2);
        let n = out.data.iter().filter(|&&v| v == LETHAL).count();
        // cells with dx²+dy² ≤ 4: 13 cells
        assert_eq!(n, 13);
        assert_eq!(*out.get(Cell::new(7, 5)).unwrap(), LETHAL);
        assert_eq!(*out.get(Cell::new(7, 6)).unwrap(), FREE);
    }

    #[test]
    fn lethal_bits_and_next_bit_match_their_definitions() {
        // Every value at every position of chunks of every length (64: the SSE2 path on x86-64).
        for len in 1..=64usize {
            for v in i8::MIN..=i8::MAX {
                for at in [0, len / 2, len - 1] {
                    let mut chunk = vec![0i8; len];
                    chunk[at] = v;
                    let want = if v >= LETHAL_THRESHOLD { 1u64 << at } else { 0 };
                    assert_eq!(lethal_bits(&chunk), want, "len {len}, value {v} at {at}");
                    assert_eq!(lethal_mask(&chunk), want, "mask: len {len}, value {v} at {at}");
                }
            }
        }
        let bits = [0b1011_0000u64, 0, u64::MAX, 1 << 63];
        let naive = |from: usize, set: bool| (from..256).find(|&i| (bits[i / 64] >> (i % 64) & 1 == 1) == set).unwrap_or(256);
        for from in 0..260 {
            for set in [true, false] {
                assert_eq!(next_bit(&bits, from, set), naive(from, set), "from {from}, set {set}");
            }
        }
    }

    proptest::proptest! {
        /// The span stamp agrees with the definition: lethal iff lethal before or within
        /// `radius_m` (centre to centre) of a lethal cell. Rows of 130 cells: runs cross the
        /// bitmask's words and end in a partial one.
        #[test]
        fn inflation_matches_the_definition(
            cells in proptest::collection::vec(proptest::prop_oneof![8 => proptest::strategy::Just(FREE), 1 => proptest::strategy::Just(LETHAL), 1 => proptest::strategy::Just(crate::grid::UNKNOWN)], 130 * 11),
            radius_cells in 0.0f64..4.5,
        ) {
            let (w, h) = (130i32, 11i32);
            let g = GridGeometry::new(0.0, 0.0, 0.05, w as usize, h as usize);
            let grid = Grid { geometry: g, data: cells };
            let out = inflate_lethal(&grid, radius_cells * 0.05);
            for r in 0..h {
                for c in 0..w {
                    let near = (r - 5..=r + 5).any(|rr| (c - 5..=c + 5).any(|cc| {
                        let d2 = ((cc - c) * (cc - c) + (rr - r) * (rr - r)) as f64;
                        grid.get(Cell::new(cc, rr)) == Some(&LETHAL) && d2 <= radius_cells * radius_cells + 1e-9
                    }));
                    let expected = if near { LETHAL } else { *grid.get(Cell::new(c, r)).unwrap() };
                    proptest::prop_assert_eq!(*out.get(Cell::new(c, r)).unwrap(), expected, "cell ({}, {})", c, r);
                }
            }
        }
    }
}
