//! Deterministic random streams. Every random decision in a render draws from a stream keyed by
//! (seed, iteration, item) — never by thread — so the image does not depend on how the work is
//! split between threads.

use glam::Vec2;
use rand::rngs::Xoshiro256PlusPlus;
use rand::{Rng, SeedableRng};

/// What a stream is used for; part of the key so that photon and camera streams never coincide.
#[derive(Clone, Copy, Debug)]
#[repr(u64)]
pub enum Purpose {
    /// Light paths of the photon pass.
    Photon = 1,
    /// Eye paths of the camera pass.
    Camera = 2,
    /// Anything else (tests).
    #[cfg(test)]
    Other = 3,
    /// Russian-roulette thinning of dense photon cells.
    Thinning = 4,
    /// The ray sets of `haze bench rays`.
    Benchmark = 5,
    /// The pool of emitter points an iteration's next-event estimates towards emitting media
    /// choose their candidates from.
    EmitterPool = 6,
    /// Where the combined integrator's light-path pilot puts its pixels.
    Pilot = 7,
    /// The copies a light path splits into (`photon/importance.rs`), keyed by the path and the
    /// copy's number.
    Split = 8,
}

/// A portable seeded generator (xoshiro256++), with the float helpers the renderer needs.
pub struct Sampler(Xoshiro256PlusPlus);

/// SplitMix64 finaliser: a bijective 64-bit mixer.
#[inline]
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

impl Sampler {
    /// The stream for `item` (a photon or pixel index) of `iteration` under `seed`.
    pub fn new(seed: u64, purpose: Purpose, iteration: u64, item: u64) -> Self {
        let key = mix(mix(mix(seed ^ 0x6a09_e667_f3bc_c909) ^ purpose as u64) ^ iteration)
            ^ item.wrapping_mul(0x9e37_79b9_7f4a_7c15);
        Self(Xoshiro256PlusPlus::seed_from_u64(key))
    }

    /// Uniform in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        // 24 random mantissa bits: exactly representable, never 1.0.
        (self.0.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    /// Uniform in [0, 1) with 53 random bits, for choices among millions of entries of a
    /// cumulative table (24 bits would leave their chances off by whole steps).
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        (self.0.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Two uniforms in [0, 1).
    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        Vec2::new(self.next_f32(), self.next_f32())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_reproducible_and_distinct() {
        let a: Vec<f32> = {
            let mut s = Sampler::new(7, Purpose::Photon, 3, 11);
            (0..4).map(|_| s.next_f32()).collect()
        };
        let b: Vec<f32> = {
            let mut s = Sampler::new(7, Purpose::Photon, 3, 11);
            (0..4).map(|_| s.next_f32()).collect()
        };
        let c: Vec<f32> = {
            let mut s = Sampler::new(7, Purpose::Camera, 3, 11);
            (0..4).map(|_| s.next_f32()).collect()
        };
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert!(a.iter().all(|&x| (0.0..1.0).contains(&x)));
    }
}
