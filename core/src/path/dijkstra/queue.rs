//! The search's queue: one bucket of cells per cost unit ([`BucketQueue`]), and the block-wise
//! memory order a bucket is expanded in ([`BlockOrder`]).

/// Puts a bucket into memory order block by block (a counting sort on `index >> BLOCK_SHIFT`), so
/// that the wavefront is processed a few rows at a time and a block's costs stay in cache: most of
/// a full sort's locality at a fraction of its cost.
pub(super) struct BlockOrder {
    counts: Vec<u32>,
    scratch: Vec<u32>,
}

impl BlockOrder {
    /// 1024 cells (8 KiB of costs, about a row of a typical window): measured against 4096 and
    /// 16384 on the decision bench, 1–2 ms faster (docs/benchmarks.md).
    pub(super) const BLOCK_SHIFT: u32 = 10;

    pub(super) fn new(cells: usize) -> Self {
        Self { counts: vec![0; (cells >> Self::BLOCK_SHIFT) + 2], scratch: Vec::new() }
    }

    /// A stable counting sort. Consecutive entries mostly share a block (a bucket is filled in
    /// the previous one's block order), so each pass keeps the current block's counter in a
    /// register and writes it back only when the block changes: a counter in memory, incremented
    /// entry after entry, would make every entry wait for the previous one's store.
    pub(super) fn order(&mut self, bucket: &mut Vec<u32>) {
        if bucket.len() < 64 {
            return;
        }
        let block = |p: u32| (p >> Self::BLOCK_SHIFT) as usize;
        self.counts.fill(0);
        let (mut current, mut run) = (block(bucket[0]), 0u32);
        for &p in bucket.iter() {
            if block(p) != current {
                self.counts[current + 1] += run;
                (current, run) = (block(p), 0);
            }
            run += 1;
        }
        self.counts[current + 1] += run;
        for b in 1..self.counts.len() {
            self.counts[b] += self.counts[b - 1];
        }
        self.scratch.clear();
        self.scratch.resize(bucket.len(), 0);
        let (mut current, mut slot) = (block(bucket[0]), self.counts[block(bucket[0])]);
        for &p in bucket.iter() {
            if block(p) != current {
                self.counts[current] = slot;
                current = block(p);
                slot = self.counts[current];
            }
            self.scratch[slot as usize] = p;
            slot += 1;
        }
        std::mem::swap(bucket, &mut self.scratch);
    }
}

/// Buckets of queued cells, one per cost unit (a scan queues cells far ahead of the current
/// bucket), their storage recycled.
#[derive(Clone, Debug, Default)]
pub(super) struct BucketQueue {
    buckets: Vec<Vec<u32>>,
    spare: Vec<Vec<u32>>,
    pub(super) pending: usize,
}

impl BucketQueue {
    #[inline]
    pub(super) fn push(&mut self, bucket: u64, p: usize) {
        let b = bucket as usize;
        if b >= self.buckets.len() {
            self.buckets.resize_with(b + 1, Vec::new);
        }
        let v = &mut self.buckets[b];
        if v.capacity() == 0
            && let Some(s) = self.spare.pop()
        {
            *v = s;
        }
        v.push(p as u32);
        self.pending += 1;
    }

    pub(super) fn take(&mut self, bucket: u64) -> Vec<u32> {
        let v = self.buckets.get_mut(bucket as usize).map(std::mem::take).unwrap_or_default();
        self.pending -= v.len();
        v
    }

    /// Empties every bucket, keeping the storage.
    pub(super) fn clear(&mut self) {
        for mut v in self.buckets.drain(..) {
            if v.capacity() > 0 {
                v.clear();
                self.spare.push(v);
            }
        }
        self.pending = 0;
    }

    pub(super) fn recycle(&mut self, mut v: Vec<u32>) {
        v.clear();
        self.spare.push(v);
    }
}
