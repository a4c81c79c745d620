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
}
