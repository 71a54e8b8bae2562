//! PCG32 (O'Neill 2014, "PCG: A Family of Simple Fast Space-Efficient Statistically Good Algorithms
//! for Random Number Generation"), and a 64-bit mixer to derive independent stream seeds.

use crate::lane::pcg::Pcg;

/// The PCG32 generator (XSH-RR output, 64-bit LCG state): `lane::pcg::Pcg` at width 1, so a
/// pixel's stream is the same in the 1-lane and the 8-lane renderers.
#[derive(Clone, Debug)]
pub struct Pcg32(Pcg<f32>);

impl Pcg32 {
    /// A generator on stream `stream` starting from `seed`.
    pub fn new(seed: u64, stream: u64) -> Pcg32 {
        Pcg32(Pcg::new(seed, stream))
    }

    /// The generator with raw LCG state `state` and increment `inc` (as [`Self::parts`]
    /// returns them).
    #[inline]
    pub fn from_parts(state: u64, inc: u64) -> Pcg32 {
        Pcg32(Pcg::from_parts(state, inc))
    }

    /// The raw LCG state and increment: with [`Self::from_parts`], how the stream renderer
    /// gathers 8 paths' generators into one `lane::pcg::Pcg` at width 8 and scatters them back.
    #[inline]
    pub fn parts(&self) -> (u64, u64) {
        self.0.parts()
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        self.0.next_u32() as u32
    }

    /// A float uniformly distributed in [0, 1): 24 random mantissa bits, exactly
    /// representable, never 1.0.
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        self.0.next_f32()
    }

    /// A double uniformly distributed in [0, 1).
    #[inline]
    pub fn next_f64(&mut self) -> f64 {
        let hi = (self.next_u32() as u64) << 21;
        let lo = (self.next_u32() >> 11) as u64;
        (hi | lo) as f64 * (1.0 / 9_007_199_254_740_992.0)
    }
}

/// SplitMix64 finaliser: a bijective 64-bit mixer, used to turn (seed, pixel, sample) into seeds
/// (`lane::mix::mix64` at width 1: the stream renderer keys 8 paths at once with the same code).
#[inline]
pub fn mix64(z: u64) -> u64 {
    crate::lane::mix::mix64(z)
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn uniform_mean_and_range() {
        let mut r = Pcg32::new(7, 3);
        let n = 200_000;
        let mut sum = 0.0f64;
        for _ in 0..n {
            let x = r.next_f32();
            assert!((0.0..1.0).contains(&x));
            sum += x as f64;
        }
        // mean of U(0,1): sd of the mean = sqrt(1/12/n) ≈ 6.5e-4; 5 sd.
        assert!((sum / n as f64 - 0.5).abs() < 5.0 * (1.0f64 / 12.0 / n as f64).sqrt());
    }
    /// A generator rebuilt from its parts continues the same stream.
    #[test]
    fn parts_round_trip() {
        let mut a = Pcg32::new(11, 5);
        a.next_u32();
        let (s, i) = a.parts();
        let mut b = Pcg32::from_parts(s, i);
        for _ in 0..16 {
            assert_eq!(a.next_u32(), b.next_u32());
        }
    }
    #[test]
    fn streams_differ() {
        let a: Vec<u32> = (0..4)
            .scan(Pcg32::new(1, 1), |r, _| Some(r.next_u32()))
            .collect();
        let b: Vec<u32> = (0..4)
            .scan(Pcg32::new(1, 2), |r, _| Some(r.next_u32()))
            .collect();
        assert_ne!(a, b);
    }
}
