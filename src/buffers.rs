//! Buffers grown in parallel. `Vec::resize` writes its new elements on one thread, and where a
//! buffer grows by megabytes — a photon map's entries, an iteration's photons, a frame — that
//! write, and the page faults of memory touched for the first time, is serial work in every
//! iteration or at the start of every render (cumulus's beam map spent 0.11 s of 0.56 s resizing
//! on one thread of two). These write the new elements from every thread of the pool.

use rayon::prelude::*;

/// Below this many new elements a buffer grows on the calling thread (handing the work out
/// would cost more than it saves).
const PARALLEL_FROM: usize = 1 << 15;

/// [`Vec::resize`], with the new elements written in parallel: the elements already there are
/// kept, the buffer is truncated if longer.
pub(crate) fn resize<T: Clone + Send + Sync>(v: &mut Vec<T>, n: usize, value: T) {
    if n < v.len() + PARALLEL_FROM {
        v.resize(n, value);
    } else {
        let more = n - v.len();
        v.par_extend(rayon::iter::repeat_n(value, more));
    }
}

/// Sets `v` to `n` copies of `value`, written in parallel.
pub(crate) fn fill<T: Clone + Send + Sync>(v: &mut Vec<T>, n: usize, value: T) {
    v.truncate(n);
    if n < PARALLEL_FROM {
        v.fill(value.clone());
    } else {
        v.par_iter_mut().for_each(|x| *x = value.clone());
    }
    resize(v, n, value);
}

/// A vector of `n` copies of `value`, written in parallel.
pub(crate) fn filled<T: Clone + Send + Sync>(n: usize, value: T) -> Vec<T> {
    let mut v = Vec::new();
    resize(&mut v, n, value);
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grows_and_fills_as_the_serial_calls_do() {
        for (before, n) in
            [(0, 0), (0, 10), (0, 100_000), (5, 100_000), (100_000, 7), (70_000, 140_000)]
        {
            let old: Vec<u32> = (0..before as u32).collect();
            let (mut a, mut b) = (old.clone(), old.clone());
            resize(&mut a, n, 9);
            b.resize(n, 9);
            assert_eq!(a, b);
            let (mut a, mut b) = (old.clone(), old.clone());
            fill(&mut a, n, 3);
            b.clear();
            b.resize(n, 3);
            assert_eq!(a, b);
            assert_eq!(filled(n, 4u32), vec![4; n]);
        }
    }
}
