//! Random streams that depend on (seed, source, ray index) only.
//!
//! Every ray owns a generator seeded from a hash of those three numbers, so that a ray can be
//! replayed alone and results are the same bits whatever the thread count or the split of a
//! bake into ranges. The generator is xoshiro256++ (from `rand_xoshiro`).

use rand_core::{Rng, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

/// SplitMix64's finaliser: a bijective 64-bit mix with full avalanche.
#[inline]
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A uniform number in [0, 1) that depends on five keys only: the stochastic rounding of one
/// deposit, keyed by (seed, source, ray, receiver, event of the ray). A deposit's rounding then
/// does not depend on which other receivers a run holds, so a bake traced in tiles of receivers
/// gives every receiver the bits of the bake of all of them at once.
#[inline]
pub fn keyed_uniform(seed: u64, source: u64, ray: u64, receiver: u64, event: u64) -> f64 {
    keyed_uniform_of_ray(ray_key(seed, source, ray), receiver, event)
}

/// The part of [`keyed_uniform`]'s key that one ray's deposits share: a tracer computes it
/// once a ray and hands it to [`keyed_uniform_of_ray`] (the same numbers, two mixes a deposit
/// instead of five).
#[inline]
pub fn ray_key(seed: u64, source: u64, ray: u64) -> u64 {
    mix(mix(mix(seed ^ 0x0de9_0517_u64) ^ source.wrapping_mul(0x9e37_79b9_7f4a_7c15)) ^ ray)
}

/// [`keyed_uniform`] from the ray's [`ray_key`].
#[inline]
pub fn keyed_uniform_of_ray(ray_key: u64, receiver: u64, event: u64) -> f64 {
    let k = mix(ray_key ^ receiver.wrapping_mul(0xd1b5_4a32_d192_ed03));
    (mix(k ^ event) >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// The random stream of one ray.
#[derive(Clone, Debug)]
pub struct Stream(Xoshiro256PlusPlus);

impl Stream {
    /// The stream of ray `index` of source `source` in a run seeded with `seed`.
    pub fn new(seed: u64, source: u64, index: u64) -> Stream {
        let key = mix(mix(mix(seed ^ 0x5eed_5011_u64) ^ source.wrapping_mul(0x9e37_79b9_7f4a_7c15)) ^ index);
        Stream(Xoshiro256PlusPlus::seed_from_u64(key))
    }

    #[inline]
    pub fn next_u64(&mut self) -> u64 {
        self.0.next_u64()
    }

    /// Uniform in [0, 1) with 53 random bits.
    #[inline]
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Uniform in [0, 1) as f32 (24 random bits), never rounding up to 1.
    #[inline]
    pub fn uniform_f32(&mut self) -> f32 {
        (self.next_u64() >> 40) as f32 * (1.0 / (1u32 << 24) as f32)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn same_key_same_numbers_other_key_other_numbers() {
        let a: Vec<u64> = (0..4).map({ let mut s = Stream::new(1, 0, 7); move |_| s.next_u64() }).collect();
        let b: Vec<u64> = (0..4).map({ let mut s = Stream::new(1, 0, 7); move |_| s.next_u64() }).collect();
        let c: Vec<u64> = (0..4).map({ let mut s = Stream::new(1, 0, 8); move |_| s.next_u64() }).collect();
        let d: Vec<u64> = (0..4).map({ let mut s = Stream::new(1, 1, 7); move |_| s.next_u64() }).collect();
        assert_eq!(a, b);
        assert_ne!(a, c);
        assert_ne!(a, d);
    }

    #[test]
    fn uniform_is_in_unit_interval_with_mean_one_half() {
        let mut s = Stream::new(3, 0, 0);
        let n = 200_000;
        let mut sum = 0.0;
        for _ in 0..n {
            let u = s.uniform();
            assert!((0.0..1.0).contains(&u));
            sum += u;
        }
        // Standard error of the mean is sqrt(1/12/n) ≈ 6.5e-4; allow 5 of them.
        assert!((sum / n as f64 - 0.5).abs() < 5.0 * (1.0f64 / 12.0 / n as f64).sqrt());
    }
}
