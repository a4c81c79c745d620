//! What a camera pass gathered from each photon: per slot of a photon map, the sum of the squares
//! of the photon's contributions to the pixels it was gathered for (its share of the image's
//! second moment). The estimates add to it for every photon that contributes; the pilot pass of
//! photon guiding reads it to find which light paths matter to the image, and `haze bench` to
//! report what fraction of the stored photons are ever used.

use std::sync::atomic::{AtomicU32, Ordering};

/// Per-slot sums, added to concurrently.
pub(crate) struct Tally {
    sums: Vec<AtomicU32>,
}

impl Tally {
    /// Zero over `len` slots.
    pub(crate) fn new(len: usize) -> Self {
        Self { sums: (0..len).map(|_| AtomicU32::new(0)).collect() }
    }

    /// Adds the square of `contribution` to slot `i` (a photon's contribution to one pixel).
    #[inline]
    pub(crate) fn add(&self, i: usize, contribution: f32) {
        let v = contribution * contribution;
        if !(v > 0.0 && v.is_finite()) {
            return;
        }
        let cell = &self.sums[i];
        let mut old = cell.load(Ordering::Relaxed);
        loop {
            let new = (f32::from_bits(old) + v).to_bits();
            match cell.compare_exchange_weak(old, new, Ordering::Relaxed, Ordering::Relaxed) {
                Ok(_) => return,
                Err(now) => old = now,
            }
        }
    }

    /// The sum of slot `i`.
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
    fn tallies_sum_squares_from_many_threads() {
        let t = Tally::new(10);
        std::thread::scope(|s| {
            for _ in 0..4 {
                s.spawn(|| {
                    for k in 0..1000 {
                        t.add(k % 10, 0.5);
                    }
                });
            }
        });
        t.add(3, 0.0);
        assert!((0..10).all(|i| (t.get(i) - 100.0).abs() < 1e-3));
        assert_eq!((t.count(), t.len()), (10, 10));
    }
}
