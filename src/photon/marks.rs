//! What a camera pass gathered from each photon: per slot of a photon map, the largest square of
//! the photon's contributions to a pixel it was gathered for (a measure of its share of the
//! image's second moment). The estimates record it for every photon that contributes; the pilot
//! pass of photon guiding reads it to find which light paths matter to the image, and `haze
//! bench` to report what fraction of the stored photons are ever used. A maximum, not a sum:
//! taken concurrently in any order it is the same number, so the pilot — and the images it
//! guides — do not depend on the thread count.

use std::sync::atomic::{AtomicU32, Ordering};

/// Per-slot maxima, updated concurrently.
pub(crate) struct Tally {
    sums: Vec<AtomicU32>,
}

impl Tally {
    /// Zero over `len` slots.
    pub(crate) fn new(len: usize) -> Self {
        Self { sums: (0..len).map(|_| AtomicU32::new(0)).collect() }
    }

    /// Records the square of `contribution` (a photon's contribution to one pixel) in slot `i`
    /// if it is the largest so far.
    #[inline]
    pub(crate) fn add(&self, i: usize, contribution: f32) {
        let v = contribution * contribution;
        if !(v > 0.0 && v.is_finite()) {
            return;
        }
        // Positive floats order as their bit patterns do. Read first: most contributions do not
        // raise the maximum, and a read leaves the cache line shared between the threads that
        // gather the same photon, where a read-modify-write would take it from them each time.
        let (slot, bits) = (&self.sums[i], v.to_bits());
        if bits > slot.load(Ordering::Relaxed) {
            slot.fetch_max(bits, Ordering::Relaxed);
        }
    }

    /// The value of slot `i`.
    pub(crate) fn get(&self, i: usize) -> f32 {
        f32::from_bits(self.sums[i].load(Ordering::Relaxed))
    }

    /// The slots gathered at least once.
    pub(crate) fn count(&self) -> usize {
        self.sums.iter().filter(|s| s.load(Ordering::Relaxed) != 0).count()
    }

    /// The number of slots.
    pub(crate) fn len(&self) -> usize {
        self.sums.len()
    }
}

/// The tallies of one camera pass: surface photons and volume photons (of whichever volume map
/// the pass queries).
pub(crate) struct GatherMarks {
    pub(crate) surface: Tally,
    pub(crate) volume: Tally,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tallies_keep_the_largest_square_from_many_threads() {
        let t = Tally::new(10);
        std::thread::scope(|s| {
            for j in 0..4 {
                let t = &t;
                s.spawn(move || {
                    for k in 0..1000 {
                        t.add(k % 10, 0.001 * (k + j) as f32);
                    }
                });
            }
        });
        t.add(3, 0.0);
        for i in 0..10 {
            let largest = 0.001 * (990 + i + 3) as f32;
            assert_eq!(t.get(i), largest * largest, "slot {i}");
        }
        assert_eq!((t.count(), t.len()), (10, 10));
    }
}
