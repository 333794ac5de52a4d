use super::{BlockOrder, LETHAL_THRESHOLD, Scale, code, extend_codes, passability_key};
use crate::grid::{FREE, LETHAL, UNKNOWN};
use proptest::prelude::*;

#[test]
fn the_passability_key_orders_like_passable() {
    for allow_unknown in [false, true] {
        let threshold = passability_key(LETHAL_THRESHOLD, allow_unknown);
        for v in i8::MIN..=i8::MAX {
            assert_eq!(passability_key(v, allow_unknown) < threshold, crate::path::passable(v, allow_unknown), "{v} {allow_unknown}");
        }
    }
}

proptest! {
    /// Whole-word runs or cell by cell, the codes are each cell's: runs of the three thresholded
    /// values (and of others) of every length, at every alignment.
    #[test]
    fn extend_codes_codes_every_cell(runs in prop::collection::vec((prop_oneof![Just(FREE), Just(LETHAL), Just(UNKNOWN), any::<i8>()], 1usize..20), 0..30), allow_unknown: bool) {
        let cells: Vec<i8> = runs.iter().flat_map(|&(v, len)| std::iter::repeat_n(v, len)).collect();
        let mut cost = vec![7];
        extend_codes(&mut cost, &cells, allow_unknown);
        let expected: Vec<u64> = std::iter::once(7).chain(cells.iter().map(|&v| code(v, allow_unknown))).collect();
        prop_assert_eq!(cost, expected);
    }

    /// Block order is a stable sort on the block index, whatever the runs of equal blocks.
    #[test]
    fn block_order_is_a_stable_sort_by_block(runs in prop::collection::vec((0u32..8, 1usize..40), 1..60), jitter in 0u32..1024) {
        let bucket: Vec<u32> = runs.iter().enumerate()
            .flat_map(|(i, &(b, len))| (0..len).map(move |k| (b << BlockOrder::BLOCK_SHIFT) + (jitter + (i * 40 + k) as u32) % 1024))
            .collect();
        let mut expected = bucket.clone();
        expected.sort_by_key(|&p| p >> BlockOrder::BLOCK_SHIFT);
        let mut blocks = BlockOrder::new(8 << BlockOrder::BLOCK_SHIFT);
        let mut sorted = bucket.clone();
        blocks.order(&mut sorted);
        if bucket.len() >= 64 {
            prop_assert_eq!(sorted, expected);
        } else {
            prop_assert_eq!(sorted, bucket);
        }
    }
}

#[test]
fn the_scale_is_the_finest_that_cannot_overflow() {
    let n = 2002 * 2002;
    let s = Scale::for_cells(n);
    assert_eq!(s.shift, 41);
    assert!((2 * n as u128 + 2) << s.shift <= u64::MAX as u128);
    assert!((2 * n as u128 + 2) << (s.shift + 1) > u64::MAX as u128);
    assert!((s.diag as f64 - std::f64::consts::SQRT_2 * 2f64.powi(41)).abs() <= 0.5);
    assert_eq!(Scale::for_cells(100).shift, 52);
    assert_eq!(s.cells(super::START + 3 * s.orth), 3.0);
}
