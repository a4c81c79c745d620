//! Buffers grown in parallel. `Vec::resize` writes its new elements on one thread, and where a
//! buffer grows by megabytes — a photon map's entries, an iteration's photons, a frame — that
//! write, and the page faults of memory touched for the first time, is serial work in every
//! iteration or at the start of every render (cumulus's beam map spent 0.11 s of 0.56 s resizing
//! on one thread of two). These write the new elements from every thread of the pool, and a
//! buffer that outgrows its capacity is replaced rather than reallocated where its contents are
//! to be overwritten (a reallocation copies them, on one thread). [`piece`] sizes the pieces work
//! in parallel is cut into.

use rayon::prelude::*;

/// Below this many new elements a buffer grows on the calling thread (handing the work out
/// would cost more than it saves).
const PARALLEL_FROM: usize = 1 << 15;

/// Makes room for `n` elements in `v`, whose contents are about to be overwritten: where its
/// capacity is short, the buffer is freed and a larger one taken, so that growing never copies
/// the old contents (a reallocation copies them on one thread: 5 MB in a pass of the beam map's
/// entries). The new buffer has room for an eighth more, and at least twice the old capacity (as
/// `Vec` grows), so that passes whose sizes vary or grow do not reallocate every time.
fn make_room<T>(v: &mut Vec<T>, n: usize) {
    if n > v.capacity() {
        let room = (n + n / 8).max(2 * v.capacity());
        *v = Vec::new();
        v.reserve_exact(room);
    }
}

/// Sets `v` to `n` elements whose values do not matter, because the caller overwrites every one:
/// the elements already there are kept, new ones are `value` (written in parallel), and the old
/// contents are never copied ([`make_room`]).
pub(crate) fn scratch<T: Clone + Send + Sync>(v: &mut Vec<T>, n: usize, value: T) {
    make_room(v, n);
    if n < v.len() + PARALLEL_FROM {
        v.resize(n, value);
    } else {
        let more = n - v.len();
        v.par_extend(rayon::iter::repeat_n(value, more));
    }
}

/// Sets `v` to `n` copies of `value`, written in parallel.
pub(crate) fn fill<T: Clone + Send + Sync>(v: &mut Vec<T>, n: usize, value: T) {
    make_room(v, n);
    v.truncate(n);
    if v.len() < PARALLEL_FROM {
        v.fill(value.clone());
    } else {
        v.par_iter_mut().for_each(|x| *x = value.clone());
    }
    scratch(v, n, value);
}

/// Sets `v` to the items of `items`, written in parallel
/// ([`IndexedParallelIterator::collect_into_vec`]) into room made without copying `v`'s old
/// contents ([`make_room`]).
pub(crate) fn collect<T: Send>(v: &mut Vec<T>, items: impl IndexedParallelIterator<Item = T>) {
    v.clear();
    make_room(v, items.len());
    items.collect_into_vec(v);
}

/// The length of the pieces that `n` items are cut into to be worked on in parallel: about
/// `per_thread` pieces for each thread of the current pool, of at least `min` items (the last
/// piece perhaps shorter). A fixed length caps the threads that can share the work (16 384
/// photons a piece cut cornell-fog's 112 000 volume photons into 7).
pub(crate) fn piece(n: usize, per_thread: usize, min: usize) -> usize {
    n.div_ceil(per_thread * rayon::current_num_threads()).max(min)
}

/// Terms per partial sum of [`sum`]: a constant, so that the sum is the same on any number of
/// threads.
const SUM_PIECE: usize = 1 << 13;

/// The sum of `term(i)` for i in 0..n, added in pieces of a fixed length (in parallel where they
/// are many) and the pieces' sums then added in order: the same bits on any number of threads (a
/// float sum's rounding depends on the order of its terms, and rayon's own `sum` splits where
/// the threads steal). The bits of a serial loop only where the partial sums are exact (counts,
/// or values of 0 and 1) or the terms fit one piece.
pub(crate) fn sum(n: usize, term: impl Fn(usize) -> f64 + Sync) -> f64 {
    let piece = |k: usize| (k * SUM_PIECE..n.min((k + 1) * SUM_PIECE)).map(&term).sum::<f64>();
    let pieces = n.div_ceil(SUM_PIECE);
    if n < PARALLEL_FROM {
        return (0..pieces).map(piece).sum();
    }
    let parts: Vec<f64> = (0..pieces).into_par_iter().map(piece).collect();
    parts.iter().sum()
}

/// A vector of `n` copies of `value`, written in parallel.
///
/// Also the way to make a buffer of zeros that is read before it is written (sums added to):
/// `vec![0; n]` asks for zeroed memory, whose pages map the system's one page of zeros until
/// first written, and the first write to each then replaces a read-only mapping, which the
/// kernel announces to every processor running the process (a TLB shootdown: an interrupt per
/// page and processor). Written here, every page is first touched by a write.
pub(crate) fn filled<T: Clone + Send + Sync>(n: usize, value: T) -> Vec<T> {
    let mut v = Vec::with_capacity(n);
    scratch(&mut v, n, value);
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn buffers_have_the_size_and_values_asked_for() {
        for (before, n) in
            [(0, 0), (0, 10), (0, 100_000), (5, 100_000), (100_000, 7), (70_000, 140_000)]
        {
            let old: Vec<u32> = (0..before as u32).collect();
            // Scratch space: the old elements where they fit, or none of them, then `value`.
            let mut a = old.clone();
            scratch(&mut a, n, u32::MAX);
            assert_eq!(a.len(), n);
            let kept = a.iter().take_while(|&&x| x != u32::MAX).count();
            assert!(a[..kept] == old[..kept] && a[kept..].iter().all(|&x| x == u32::MAX));
            let mut a = old.clone();
            fill(&mut a, n, 3);
            assert_eq!(a, vec![3; n]);
            assert_eq!(filled(n, 4u32), vec![4; n]);
            let mut a = old.clone();
            collect(&mut a, (0..n as u32).into_par_iter().map(|i| i * 3));
            assert_eq!(a, (0..n as u32).map(|i| i * 3).collect::<Vec<_>>());
        }
    }

    /// The sum in pieces has the same bits on 1, 2 and 7 threads, also where the order of the
    /// terms shows in the rounding, and it is the sum: within a few ulps of an exact one (here
    /// of fractions whose exact sum is known).
    #[test]
    fn a_sum_is_the_same_on_any_thread_count() {
        for n in [0usize, 1, 5000, 100_000, 1_000_003] {
            // Terms 1/3 · 10^(k mod 7): every addition rounds, and terms of different sizes
            // make the order matter.
            let items: Vec<f64> = (0..n).map(|k| 10f64.powi((k % 7) as i32) / 3.0).collect();
            let on = |threads: usize| {
                let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
                pool.install(|| sum(items.len(), |i| items[i]))
            };
            let one = on(1);
            assert_eq!(on(2).to_bits(), one.to_bits(), "{n} items");
            assert_eq!(on(7).to_bits(), one.to_bits(), "{n} items");
            // Σ over whole cycles of 7 terms (1 + 10 + … + 10⁶)/3 = 1111111/3, plus the rest.
            let exact = (n / 7) as f64 * 1_111_111.0 / 3.0
                + (0..n % 7).map(|k| 10f64.powi(k as i32)).sum::<f64>() / 3.0;
            assert!((one - exact).abs() <= 1e-12 * exact.max(1.0), "{n}: {one} vs {exact}");
        }
    }
}
