//! The flood itself: Dial's bucket queue over the window with canonical ordering (module doc of
//! [`super`]): straight moves scanned without queueing, diagonal steps and forced neighbours
//! queued with the moves that reached them.

use super::*;

/// How many queue entries ahead [`prefetch_rows`] looks.
const PREFETCH_AHEAD: usize = 16;

/// Asks for the three cost rows around `p` ahead of use: a bucket's cells are scattered around
/// the wavefront, so their rows are often not in L1 (the search is mostly bound by its own work,
/// but this hides some of the misses: 0.3–1.5 ms on the decision bench, docs/benchmarks.md).
#[inline(always)]
pub(super) fn prefetch_rows(cost: &[u64], p: usize, pw: usize) {
    #[cfg(target_arch = "x86_64")]
    for q in [p.wrapping_sub(pw), p, p + pw] {
        // A hint: it never faults and changes no result.
        if let Some(c) = cost.get(q) {
            safe_arch::prefetch_t0(c);
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (cost, p, pw);
}

/// Move bits, in [`MOVES`]' order: the four straight moves, then the four diagonals.
const E: u8 = 1;
const W: u8 = 2;
const N: u8 = 4;
const S: u8 = 8;
const NE: u8 = 16;
const NW: u8 = 32;
const SE: u8 = 64;
const SW: u8 = 128;

/// `SUCCESSORS[arrivals][blocked]`: the moves worth making from a cell reached at its optimal cost
/// by the moves in `arrivals`, when its corner cells NE, NW, SE, SW (bits 0–3 of `blocked`) are
/// impassable (canonical ordering, as in jump point search without corner cutting): after a
/// diagonal, the diagonal and its two components; after a straight move, the same move, plus the
/// side move and the diagonal towards a side whose corner behind is blocked (a forced neighbour).
/// Any other neighbour is reached from the parent at most as cheaply, and then diagonal first.
pub(super) const SUCCESSORS: [[u8; 16]; 256] = {
    let mut t = [[0u8; 16]; 256];
    let mut a = 0;
    while a < 256 {
        let mut b = 0;
        while b < 16 {
            let (bne, bnw, bse, bsw) = (b & 1 != 0, b & 2 != 0, b & 4 != 0, b & 8 != 0);
            let arr = a as u8;
            let mut m = 0u8;
            if arr & E != 0 {
                m |= E | if bnw { N | NE } else { 0 } | if bsw { S | SE } else { 0 };
            }
            if arr & W != 0 {
                m |= W | if bne { N | NW } else { 0 } | if bse { S | SW } else { 0 };
            }
            if arr & N != 0 {
                m |= N | if bsw { W | NW } else { 0 } | if bse { E | NE } else { 0 };
            }
            if arr & S != 0 {
                m |= S | if bnw { W | SW } else { 0 } | if bne { E | SE } else { 0 };
            }
            if arr & NE != 0 {
                m |= NE | N | E;
            }
            if arr & NW != 0 {
                m |= NW | N | W;
            }
            if arr & SE != 0 {
                m |= SE | S | E;
            }
            if arr & SW != 0 {
                m |= SW | S | W;
            }
            t[a][b] = m;
            b += 1;
        }
        a += 1;
    }
    t
};

/// The search's state over the padded window.
pub(super) struct Flood<'a> {
    cost: Vec<u64>,
    /// Per cell: the moves that reached it at its current cost (low byte) and those whose
    /// successors were already made (high byte).
    arrivals: Vec<u16>,
    queue: BucketQueue,
    scale: Scale,
    pw: usize,
    frontier: Option<&'a mut Vec<usize>>,
    is_target: Vec<u64>,
    targets_left: usize,
}

impl Flood<'_> {
    fn into_field(self, geometry: GridGeometry, start: Cell, window: Window, settled_below: u64) -> DistanceField {
        DistanceField {
            geometry,
            start,
            window,
            scale: self.scale,
            cost: self.cost,
            settled_below,
            arrivals: self.arrivals,
            queue: self.queue,
        }
    }

    /// Bookkeeping of a cell's first cost: frontier (an unknown 4-neighbour) and targets.
    #[inline]
    fn first_reach(&mut self, y: usize) {
        let c = &self.cost;
        if (c[y + 1] == UNKNOWN) | (c[y - 1] == UNKNOWN) | (c[y + self.pw] == UNKNOWN) | (c[y - self.pw] == UNKNOWN)
            && let Some(f) = self.frontier.as_deref_mut()
        {
            f.push(y);
        }
        if !self.is_target.is_empty() && self.is_target[y / 64] & (1 << (y % 64)) != 0 {
            self.targets_left -= 1;
        }
    }

    /// Move `mv` reaching `y` at cost `c`: true when it improves `y` (its marks then restart at
    /// `mv`) or ties without that move yet (added); false otherwise (impassable, or not better).
    #[inline]
    fn arrive(&mut self, y: usize, c: u64, mv: u8) -> bool {
        let cy = self.cost[y];
        if c < cy {
            if cy == UNREACHED {
                self.first_reach(y);
            }
            self.cost[y] = c;
            self.arrivals[y] = u16::from(mv);
            true
        } else if c == cy && self.arrivals[y] & u16::from(mv) == 0 {
            self.arrivals[y] |= u16::from(mv);
            true
        } else {
            false
        }
    }

    /// Straight moves from `i` along `off` (`perp` across it), one cell after another while they
    /// improve (or tie without this move yet): such a cell's only successor is the next one,
    /// unless a corner behind it is blocked with its side open, and then it is queued.
    #[inline]
    fn scan(&mut self, i: usize, off: isize, perp: isize, mv: u8) {
        let (mut y, mut c) = (i.wrapping_add_signed(off), self.cost[i] + self.scale.orth);
        loop {
            if !self.arrive(y, c, mv) {
                return;
            }
            let at = |d: isize| self.cost[y.wrapping_add_signed(d)];
            let forced = (at(perp - off) < START && at(perp) >= START) || (at(-perp - off) < START && at(-perp) >= START);
            if forced {
                self.queue.push(self.scale.bucket(c), y);
            }
            y = y.wrapping_add_signed(off);
            c += self.scale.orth;
        }
    }

    /// A diagonal move to `j` at cost `c`: queued when it improves, or ties without this move.
    #[inline]
    fn diagonal(&mut self, j: usize, c: u64, mv: u8) {
        if self.arrive(j, c, mv) {
            self.queue.push(self.scale.bucket(c), j);
        }
    }

    /// Makes the successors of a queued cell for the arrivals not yet expanded.
    #[inline]
    fn expand(&mut self, i: usize) {
        let a = self.arrivals[i];
        let new = (a as u8) & !((a >> 8) as u8);
        if new == 0 {
            return;
        }
        self.arrivals[i] = a | (u16::from(new) << 8);
        let pw = self.pw;
        let open = |p: usize| self.cost[p] >= START;
        let (e, w, n, s) = (open(i + 1), open(i - 1), open(i + pw), open(i - pw));
        let blocked = usize::from(!open(i + pw + 1))
            | usize::from(!open(i + pw - 1)) << 1
            | usize::from(!open(i - pw + 1)) << 2
            | usize::from(!open(i - pw - 1)) << 3;
        let next = SUCCESSORS[usize::from(new)][blocked];
        let pwi = pw as isize;
        for (mv, off, perp) in [(E, 1, pwi), (W, -1, pwi), (N, pwi, 1), (S, -pwi, 1)] {
            if next & mv != 0 {
                self.scan(i, off, perp, mv);
            }
        }
        // Diagonals, without cutting corners: both orthogonal neighbours must be passable.
        let c = self.cost[i] + self.scale.diag;
        for (mv, ok, j) in [(NE, e && n, i + pw + 1), (NW, w && n, i + pw - 1), (SE, e && s, i - pw + 1), (SW, w && s, i - pw - 1)] {
            if ok && next & mv != 0 {
                self.diagonal(j, c, mv);
            }
        }
    }
}

pub(super) fn search(
    grid: &OccupancyGrid,
    start: Cell,
    allow_unknown: bool,
    goals: Goals,
    buffers: SearchBuffers,
) -> Result<DistanceField, PathError> {
    let SearchBuffers { mut cost, mut arrivals, mut queue } = buffers;
    let Goals { targets, frontier } = goals;
    let g = grid.geometry;
    check_start(grid, start, allow_unknown)?;
    let win = passable_window(grid, allow_unknown, start);
    let pw = win.padded_width();
    let n = pw * (win.height + 2);
    let scale = Scale::for_cells(n);
    fill_window(grid, &win, allow_unknown, &mut cost);
    // Target marks, one bit per window cell.
    let mut is_target = vec![0u64; if targets.is_some() { n.div_ceil(64) } else { 0 }];
    let mut target_cells = Vec::new();
    if let Some(targets) = targets {
        for &t in targets {
            if let Some(p) = win.index(t).filter(|_| g.index(t).is_some())
                && cost[p] == UNREACHED
                && is_target[p / 64] & (1 << (p % 64)) == 0
            {
                is_target[p / 64] |= 1 << (p % 64);
                target_cells.push(p);
            }
        }
    }
    let s = win.index(start).ok_or(PathError::StartOutsideMap)?;
    let targets_left = if targets.is_some() { target_cells.len() } else { usize::MAX };
    // Written before read: a cell's marks when it is first reached, the queue as it is filled.
    arrivals.resize(n, 0);
    queue.clear();
    let mut flood = Flood { cost, arrivals, queue, scale, pw, frontier, is_target, targets_left };
    // Targets given but none passable: nothing to search for.
    if flood.targets_left == 0 {
        return Ok(flood.into_field(g, start, win, START));
    }
    flood.first_reach(s);
    flood.cost[s] = START;
    flood.arrivals[s] = u16::from(u8::MAX);
    flood.queue.push(0, s);
    let mut blocks = BlockOrder::new(n);
    let mut settled_below = UNREACHED;
    let mut k = 0u64;
    while flood.queue.pending > 0 {
        // Every cost below bucket k is final: stop once every target's is.
        if flood.targets_left == 0 && target_cells.iter().all(|&p| flood.cost[p] < k << scale.shift) {
            settled_below = k << scale.shift;
            break;
        }
        let mut bucket = flood.queue.take(k);
        blocks.order(&mut bucket);
        for (t, &iu) in bucket.iter().enumerate() {
            if let Some(&ahead) = bucket.get(t + PREFETCH_AHEAD) {
                prefetch_rows(&flood.cost, ahead as usize, pw);
            }
            let i = iu as usize;
            // A cell is queued in each bucket its cost passes through; only its final one counts.
            if scale.bucket(flood.cost[i]) == k {
                flood.expand(i);
            }
        }
        flood.queue.recycle(bucket);
        k += 1;
    }
    Ok(flood.into_field(g, start, win, settled_below))
}
