//! Deterministic per-path random streams. A [`Sampler`] is keyed by (seed, pixel index, sample
//! index): the same key always gives the same numbers, whichever thread draws them, so a render is
//! bit-identical for a given seed at any thread count.
//!
//! `independent` draws plain uniform numbers. `stratified` (Mitsuba's name) jitters the first two
//! 2-D dimensions of each pixel's samples over a √N × √N grid, using a per-pixel permutation of
//! the strata, and falls back to independent numbers afterwards.

use crate::math::rng::{mix64, Pcg32};
use glam::Vec2;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SamplerKind {
    Independent,
    Stratified { jitter: bool },
}

/// The scene's sampler description: kind, samples per pixel, seed.
#[derive(Clone, Debug)]
pub struct SamplerDesc {
    pub kind: SamplerKind,
    pub sample_count: u32,
    pub seed: u64,
}

/// One path's random stream.
#[derive(Clone, Debug)]
pub struct Sampler {
    rng: Pcg32,
    /// Stratum of this sample in the first dimensions (stratified only).
    strata: Option<(u32, u32, bool)>,
    dim2: u32,
}

impl Sampler {
    /// The stream of sample `sample_index` of pixel `pixel_index`.
    pub fn for_sample(desc: &SamplerDesc, pixel_index: u64, sample_index: u32) -> Sampler {
        let key = mix64(desc.seed ^ mix64(pixel_index.wrapping_mul(0x9E37_79B9) ^ 0x5851_F42D));
        let rng = Pcg32::new(key, (sample_index as u64) << 1 | 1);
        let strata = match desc.kind {
            SamplerKind::Independent => None,
            SamplerKind::Stratified { jitter } => {
                let res = (desc.sample_count as f64).sqrt().floor() as u32;
                if res * res == desc.sample_count && res > 1 {
                    // Per-pixel random permutation of the strata: a bijective hash of the index.
                    let perm = permute(sample_index, res * res, key as u32);
                    Some((perm, res, jitter))
                } else {
                    None
                }
            }
        };
        Sampler {
            rng,
            strata,
            dim2: 0,
        }
    }

    /// A free-standing stream (tests, tools).
    pub fn from_seed(seed: u64, stream: u64) -> Sampler {
        Sampler {
            rng: Pcg32::new(seed, stream),
            strata: None,
            dim2: 0,
        }
    }

    /// The PCG32 (state, increment) of this stream when every number it draws from now on is a
    /// plain PCG32 float (`next_1d` one, `next_2d` two, x then y): always for `independent`,
    /// for `stratified` once its stratified 2-D draws are spent; `None` before that. With
    /// [`Self::resume`], the stream renderer draws 8 paths' numbers 8-wide
    /// (`lane::pcg::Pcg::from_parts`) in each path's scalar order.
    #[inline]
    pub fn plain_parts(&self) -> Option<(u64, u64)> {
        match self.strata {
            Some(_) if self.dim2 < 2 => None,
            _ => Some(self.rng.parts()),
        }
    }

    /// Continues this stream from the raw PCG32 `state` and `inc` that [`Self::plain_parts`]
    /// gave, after drawing from them elsewhere.
    #[inline]
    pub fn resume(&mut self, state: u64, inc: u64) {
        self.rng = Pcg32::from_parts(state, inc);
    }

    #[inline]
    pub fn next_1d(&mut self) -> f32 {
        self.rng.next_f32()
    }

    #[inline]
    pub fn next_2d(&mut self) -> Vec2 {
        if let Some((stratum, res, jitter)) = self.strata {
            if self.dim2 < 2 {
                self.dim2 += 1;
                let sx = stratum % res;
                let sy = stratum / res;
                let (jx, jy) = if jitter {
                    (self.rng.next_f32(), self.rng.next_f32())
                } else {
                    (0.5, 0.5)
                };
                let inv = 1.0 / res as f32;
                return Vec2::new(
                    ((sx as f32 + jx) * inv).min(1.0 - f32::EPSILON / 2.0),
                    ((sy as f32 + jy) * inv).min(1.0 - f32::EPSILON / 2.0),
                );
            }
        }
        Vec2::new(self.rng.next_f32(), self.rng.next_f32())
    }

    /// A derived independent generator for stochastic BSDF evaluation (random walks): it consumes
    /// one draw of this stream, so it stays deterministic per path.
    pub fn fork(&mut self) -> Pcg32 {
        let a = self.rng.next_u32() as u64;
        let b = self.rng.next_u32() as u64;
        Pcg32::new(mix64(a << 32 | b), 0x2545_F491)
    }
}

/// A bijective permutation of `0..n` selected by `seed` (Kensler 2013, "Correlated Multi-Jittered
/// Sampling", the cycle-walking hash).
fn permute(mut i: u32, n: u32, seed: u32) -> u32 {
    let mut w = n - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    loop {
        i ^= seed;
        i = i.wrapping_mul(0xe170893d);
        i ^= seed >> 16;
        i ^= (i & w) >> 4;
        i ^= seed >> 8;
        i = i.wrapping_mul(0x0929eb3f);
        i ^= seed >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | seed >> 27);
        i = i.wrapping_mul(0x6935fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dcb303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e501cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860a3df);
        i &= w;
        i ^= i >> 5;
        if i < n {
            break;
        }
    }
    (i.wrapping_add(seed)) % n
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn same_key_same_numbers() {
        let d = SamplerDesc {
            kind: SamplerKind::Independent,
            sample_count: 4,
            seed: 3,
        };
        let mut a = Sampler::for_sample(&d, 10, 2);
        let mut b = Sampler::for_sample(&d, 10, 2);
        let mut c = Sampler::for_sample(&d, 10, 3);
        let xa: Vec<f32> = (0..8).map(|_| a.next_1d()).collect();
        let xb: Vec<f32> = (0..8).map(|_| b.next_1d()).collect();
        let xc: Vec<f32> = (0..8).map(|_| c.next_1d()).collect();
        assert_eq!(xa, xb);
        assert_ne!(xa, xc);
    }

    /// `plain_parts` is `None` exactly while stratified 2-D draws are pending; drawing from the
    /// parts gives the sampler's own numbers (`next_1d`, then `next_2d` x and y), and `resume`
    /// continues the stream from there.
    #[test]
    fn plain_parts_continue_the_stream() {
        for (kind, pending) in [
            (SamplerKind::Independent, 0),
            (SamplerKind::Stratified { jitter: true }, 2),
        ] {
            let d = SamplerDesc {
                kind,
                sample_count: 16,
                seed: 5,
            };
            let mut s = Sampler::for_sample(&d, 3, 7);
            let mut n = 0;
            while s.plain_parts().is_none() {
                s.next_2d();
                n += 1;
            }
            assert_eq!(n, pending, "{kind:?}");
            let (state, inc) = s.plain_parts().expect("plain");
            let mut r = Pcg32::from_parts(state, inc);
            let mut t = s.clone();
            let drawn = [r.next_f32(), r.next_f32(), r.next_f32()];
            let (x, v) = (t.next_1d(), t.next_2d());
            assert_eq!(drawn, [x, v.x, v.y], "{kind:?}");
            s.resume(r.parts().0, inc);
            assert_eq!(s.next_2d(), t.next_2d(), "{kind:?}");
        }
    }

    #[test]
    fn stratified_covers_every_stratum_once() {
        let d = SamplerDesc {
            kind: SamplerKind::Stratified { jitter: true },
            sample_count: 16,
            seed: 0,
        };
        let mut seen = [0u32; 16];
        for s in 0..16 {
            let mut sm = Sampler::for_sample(&d, 77, s);
            let u = sm.next_2d();
            let cell = (u.x * 4.0) as usize + 4 * (u.y * 4.0) as usize;
            seen[cell] += 1;
        }
        assert!(seen.iter().all(|&c| c == 1), "{seen:?}");
    }
}
