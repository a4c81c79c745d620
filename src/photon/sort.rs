//! A stable counting sort of items by bucket, in parallel: the photon maps' builds put photons in
//! bucket order with it.
//!
//! The serial counting sort (count, prefix-sum, scatter) is one pass that no thread can share, and
//! on many cores it becomes the longest part of a map build. Here the buckets are split into at
//! most [`GROUPS`] contiguous groups and the items into work items ([`ITEMS_PER_THREAD`] per
//! thread, of at least [`ITEMS_MIN`] items): each work item
//! first orders its own items by group (in parallel), then each group orders its items, gathered
//! from the work items in order, by bucket (in parallel). Both steps are stable, so the result is
//! the serial sort's exactly — bucket by bucket, items in index order — whatever the thread count.

use rayon::prelude::*;

/// Most groups of buckets (fewer where there are fewer buckets).
const GROUPS: usize = 1024;
/// Work items per thread (a fixed size of 16384 items made 13 for 200 000 photons, too few to
/// keep 16 threads busy) …
const ITEMS_PER_THREAD: usize = 8;
/// … of at least this many items (each work item's group starts are read by every group).
const ITEMS_MIN: usize = 1 << 12;
/// Below this many items, one thread sorts (the parallel sort's bookkeeping would cost more).
const SERIAL_BELOW: usize = 1 << 15;

/// Buffers of the sort, kept between sorts so that a render's builds reuse them.
#[derive(Clone, Debug, Default)]
pub(crate) struct CountingSort {
    /// Work item k's items, ordered by group.
    local: Vec<Vec<u32>>,
    /// Work item k's group starts in `local[k]` (`groups + 1` entries).
    local_start: Vec<Vec<u32>>,
}

impl CountingSort {
    /// Sorts the items `0..keys.len()` by their bucket `keys[i] < buckets`, stably: afterwards
    /// `start` has `buckets + 1` entries, `start[b]..start[b + 1]` being the slots of bucket b,
    /// and `order[slot]` is the item in `slot`.
    pub(crate) fn sort(
        &mut self,
        keys: &[u32],
        buckets: usize,
        start: &mut Vec<u32>,
        order: &mut Vec<u32>,
    ) {
        // Every slot is written: the buffer's earlier contents need no clearing.
        crate::buffers::scratch(order, keys.len(), 0);
        self.run(keys, buckets, start, Some(order));
    }

    /// The bucket starts of [`Self::sort`] alone, without ordering the items (a histogram).
    pub(crate) fn starts(&mut self, keys: &[u32], buckets: usize, start: &mut Vec<u32>) {
        self.run(keys, buckets, start, None);
    }

    fn run(
        &mut self,
        keys: &[u32],
        buckets: usize,
        start: &mut Vec<u32>,
        order: Option<&mut [u32]>,
    ) {
        debug_assert!(keys.par_iter().all(|&k| (k as usize) < buckets));
        crate::buffers::fill(start, buckets + 1, 0);
        start[buckets] = keys.len() as u32;
        if keys.len() < SERIAL_BELOW || buckets < 2 {
            let pairs = || keys.iter().enumerate().map(|(i, &k)| (i as u32, k as usize));
            place(pairs, &mut start[..buckets], order);
            return;
        }
        let per = buckets.div_ceil(GROUPS.min(buckets));
        let groups = buckets.div_ceil(per);
        self.group_work_items(keys, per, groups);
        let group_start = self.group_starts(groups);
        // Each group orders its items by bucket, into its own part of `order` and of `start`.
        let mut parts = Vec::with_capacity(groups);
        let mut starts = &mut start[..buckets];
        let mut rest = order;
        for g in 0..groups {
            let size = (group_start[g + 1] - group_start[g]) as usize;
            let part = rest.take().map(|r| {
                let (part, tail) = r.split_at_mut(size);
                rest = Some(tail);
                part
            });
            let (s, s_tail) = starts.split_at_mut(per.min(starts.len()));
            parts.push((g, part, s));
            starts = s_tail;
        }
        parts.into_par_iter().with_max_len(1).for_each(|(g, out, st)| {
            let lo = g * per;
            // Group g's items, gathered from the work items in order.
            let pairs = || {
                let each = self.local.iter().zip(&self.local_start);
                let items = each.flat_map(move |(l, at)| &l[at[g] as usize..at[g + 1] as usize]);
                items.map(move |&i| (i, keys[i as usize] as usize - lo))
            };
            place(pairs, st, out);
            for s in st.iter_mut() {
                *s += group_start[g];
            }
        });
    }

    /// Orders each work item's items by group (`per` buckets a group), in parallel.
    fn group_work_items(&mut self, keys: &[u32], per: usize, groups: usize) {
        let size = crate::buffers::piece(keys.len(), ITEMS_PER_THREAD, ITEMS_MIN);
        let items = keys.len().div_ceil(size);
        // To exactly `items`, dropping any left from a larger sort: every group reads them all.
        self.local.resize_with(items, Vec::new);
        self.local_start.resize_with(items, Vec::new);
        let work = keys.par_chunks(size).zip(&mut self.local).zip(&mut self.local_start);
        work.enumerate().with_max_len(1).for_each(|(k, ((keys, local), at))| {
            at.clear();
            at.resize(groups + 1, 0);
            at[groups] = keys.len() as u32;
            local.clear();
            local.resize(keys.len(), 0);
            let first = (k * size) as u32;
            let pairs =
                || keys.iter().enumerate().map(|(i, &key)| (first + i as u32, key as usize / per));
            place(pairs, &mut at[..groups], Some(local));
        });
    }

    /// Where each group's items go: the groups in order, each as large as its work items' parts
    /// together (`groups + 1` entries).
    fn group_starts(&self, groups: usize) -> Vec<u32> {
        let mut group_start = vec![0u32; groups + 1];
        for at in &self.local_start {
            for g in 0..groups {
                group_start[g + 1] += at[g + 1] - at[g];
            }
        }
        for g in 0..groups {
            group_start[g + 1] += group_start[g];
        }
        group_start
    }
}

/// The counting sort itself, on `(item, bucket)` pairs that `pairs` lists (the same each call):
/// counts them into `counts` (zeroed, one entry per bucket), then places each item in `out` by
/// bucket, keeping their order within a bucket; `counts[b]` ends as bucket b's first slot, with or
/// without `out`.
fn place<I: DoubleEndedIterator<Item = (u32, usize)>>(
    pairs: impl Fn() -> I,
    counts: &mut [u32],
    out: Option<&mut [u32]>,
) {
    for (_, b) in pairs() {
        counts[b] += 1;
    }
    // The buckets' ends …
    for b in 1..counts.len() {
        counts[b] += counts[b - 1];
    }
    // … and their starts: backwards, each item one slot below the last placed in its bucket.
    match out {
        Some(out) => {
            for (item, b) in pairs().rev() {
                counts[b] -= 1;
                out[counts[b] as usize] = item;
            }
        }
        None => {
            for b in (1..counts.len()).rev() {
                counts[b] = counts[b - 1];
            }
            if let Some(first) = counts.first_mut() {
                *first = 0;
            }
        }
    }
}

/// Items per piece of a [`split`]: a constant, so that its result does not depend on the number of
/// threads.
const SPLIT_PIECE: usize = 1 << 13;

/// Writes `items`, mapped by `map`, into `out` (as long) grouped by `key` (0..`buckets`), each
/// group in the items' order (a stable partition), and returns where each group starts, and the
/// end. In parallel over pieces of the items: each piece counts its items per group, then writes
/// them to its share of each group's range. Meant for a few groups (the quadrants of a node, a
/// scene's lights): each piece holds a part of `out` per group, where [`CountingSort`] sorts into
/// millions of buckets through index lists.
pub(crate) fn split<S: Sync, T: Send>(
    items: &[S],
    out: &mut [T],
    buckets: usize,
    key: impl Fn(&S) -> usize + Sync,
    map: impl Fn(&S) -> T + Sync,
) -> Vec<usize> {
    assert_eq!(items.len(), out.len(), "a split writes every item");
    let counts: Vec<Vec<usize>> = items
        .par_chunks(SPLIT_PIECE)
        .map(|piece| {
            let mut count = vec![0; buckets];
            piece.iter().for_each(|s| count[key(s)] += 1);
            count
        })
        .collect();
    let mut start = vec![0; buckets + 1];
    for b in 0..buckets {
        start[b + 1] = start[b] + counts.iter().map(|c| c[b]).sum::<usize>();
    }
    // Each piece's parts of `out`: its share of each group's range, pieces in order.
    let mut groups: Vec<&mut [T]> = Vec::with_capacity(buckets);
    let mut rest = out;
    for b in 0..buckets {
        let (group, tail) = rest.split_at_mut(start[b + 1] - start[b]);
        groups.push(group);
        rest = tail;
    }
    let mut parts: Vec<Vec<&mut [T]>> = Vec::with_capacity(counts.len());
    for count in &counts {
        let mut piece = Vec::with_capacity(buckets);
        for (group, &n) in groups.iter_mut().zip(count) {
            let (part, tail) = std::mem::take(group).split_at_mut(n);
            *group = tail;
            piece.push(part);
        }
        parts.push(piece);
    }
    items.par_chunks(SPLIT_PIECE).zip(parts).for_each(|(piece, mut parts)| {
        let mut at = vec![0; buckets];
        for s in piece {
            let b = key(s);
            parts[b][at[b]] = map(s);
            at[b] += 1;
        }
    });
    start
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::{Purpose, Sampler};

    /// A serial counting sort written apart from [`place`] (forwards, with a cursor per bucket),
    /// the reference (`start` and `order` sized and zeroed).
    fn serial(keys: &[u32], start: &mut [u32], order: &mut [u32]) {
        for &k in keys {
            start[k as usize + 1] += 1;
        }
        for b in 1..start.len() {
            start[b] += start[b - 1];
        }
        let buckets = start.len() - 1;
        let mut cursor = start[..buckets].to_vec();
        for (i, &k) in keys.iter().enumerate() {
            let c = &mut cursor[k as usize];
            order[*c as usize] = i as u32;
            *c += 1;
        }
    }

    /// A split groups the items by key, each group in the items' order, on any thread count.
    #[test]
    fn a_split_is_the_stable_partition_on_any_thread_count() {
        let mut s = Sampler::new(13, Purpose::Other, 0, 0);
        for (n, buckets) in [(0, 3), (10, 1), (5000, 4), (70_001, 4), (100_000, 17)] {
            // Skewed keys: the low buckets crowd.
            let keys: Vec<u32> =
                (0..n).map(|_| (s.next_f32().powi(3) * buckets as f32) as u32).collect();
            let (mut start, mut order) = (vec![0; buckets + 1], vec![0; n]);
            serial(&keys, &mut start, &mut order);
            for threads in [1, 4] {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                let mut out = vec![u32::MAX; n];
                let index: Vec<u32> = (0..n as u32).collect();
                let got = pool.install(|| {
                    split(&index, &mut out, buckets, |&i| keys[i as usize] as usize, |&i| i)
                });
                let want: Vec<usize> = start.iter().map(|&s| s as usize).collect();
                assert_eq!(got, want, "{n} items, {buckets} buckets, {threads} threads");
                assert!(out == order, "{n} items, {buckets} buckets, {threads} threads");
            }
        }
    }

    fn check(keys: &[u32], buckets: usize) {
        let (mut start, mut order, mut starts) = (Vec::new(), Vec::new(), Vec::new());
        let mut sort = CountingSort::default();
        sort.sort(keys, buckets, &mut start, &mut order);
        sort.starts(keys, buckets, &mut starts);
        assert_eq!(starts, start, "starts alone, {} keys, {buckets} buckets", keys.len());
        let mut want_start = vec![0; buckets + 1];
        let mut want_order = vec![0; keys.len()];
        serial(keys, &mut want_start, &mut want_order);
        assert_eq!(start, want_start, "{} keys, {buckets} buckets", keys.len());
        assert_eq!(order, want_order, "{} keys, {buckets} buckets", keys.len());
        // And the serial sort is a stable sort by key.
        let mut by_key: Vec<u32> = (0..keys.len() as u32).collect();
        by_key.sort_by_key(|&i| keys[i as usize]);
        assert_eq!(order, by_key);
    }

    #[test]
    fn the_parallel_sort_is_the_serial_stable_sort() {
        let mut s = Sampler::new(3, Purpose::Other, 0, 0);
        for (n, buckets) in [
            (0, 1),
            (10, 7),
            (100_000, 1),
            (100_000, 3),
            (100_000, 1000),
            (100_000, 1 << 18),
            (200_003, 777_777),
            (70_000, 1025),
        ] {
            let uniform: Vec<u32> =
                (0..n).map(|_| (s.next_f32() * buckets as f32) as u32 % buckets as u32).collect();
            check(&uniform, buckets);
            // Most items in a few buckets, as photons in a bright spot.
            let skewed: Vec<u32> = (0..n)
                .map(|_| {
                    let u = s.next_f32();
                    let b = if u < 0.9 { u * 3.0 } else { s.next_f32() * buckets as f32 };
                    b as u32 % buckets as u32
                })
                .collect();
            check(&skewed, buckets);
        }
    }

    /// The work items depend on the thread count; the sort does not.
    #[test]
    fn the_sort_does_not_depend_on_the_thread_count() {
        let mut s = Sampler::new(5, Purpose::Other, 0, 0);
        let keys: Vec<u32> = (0..150_000).map(|_| (s.next_f32() * 3000.0) as u32).collect();
        let mut want = (vec![0; 3001], vec![0; keys.len()]);
        serial(&keys, &mut want.0, &mut want.1);
        for threads in [1, 3, 16, 64] {
            let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
            let mut sort = CountingSort::default();
            let (mut start, mut order) = (Vec::new(), Vec::new());
            pool.install(|| sort.sort(&keys, 3000, &mut start, &mut order));
            assert_eq!((start, order), want, "{threads} threads");
        }
    }

    #[test]
    fn buffers_are_reused_across_sorts_of_other_sizes() {
        let mut sort = CountingSort::default();
        let (mut start, mut order) = (Vec::new(), Vec::new());
        for (n, buckets) in [(300_000usize, 5000usize), (40_000, 90_000), (120_000, 17)] {
            let keys: Vec<u32> = (0..n).map(|i| ((i * 7919) % buckets) as u32).collect();
            sort.sort(&keys, buckets, &mut start, &mut order);
            let mut want_start = vec![0; buckets + 1];
            let mut want_order = vec![0; n];
            serial(&keys, &mut want_start, &mut want_order);
            assert_eq!((start.clone(), order.clone()), (want_start, want_order));
        }
    }
}
