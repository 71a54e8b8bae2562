//! The SplitMix64 finaliser per 64-bit lane (Steele, Lea, Flood 2014): the bijective mixer that
//! turns (seed, pixel) into a path's stream key (`sampler::stream_key`). One definition at both
//! widths: `math::rng::mix64` is this function at width 1 (`u64`), and the stream renderer sets up
//! 8 paths' streams at once with it at width 8 ([`super::U64x8`], whose 64-bit multiply is
//! emulated with `vpmuludq`, 32×32→64, the low 64 bits of the product exactly as
//! `u64::wrapping_mul`).

use super::LaneU64;

/// `mix64(z)` per lane: add the golden-ratio increment, then two xor-shift-multiply rounds and a
/// final xor-shift (all wrapping).
#[inline(always)]
pub fn mix64<U: LaneU64>(z: U) -> U {
    let z = z.add(z.splat(0x9E37_79B9_7F4A_7C15));
    let z = z.xor(z.shr::<30>()).mul(z.splat(0xBF58_476D_1CE4_E5B9));
    let z = z.xor(z.shr::<27>()).mul(z.splat(0x94D0_49BB_1331_11EB));
    z.xor(z.shr::<31>())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A reference written out with `u64`'s own wrapping operations (not through `LaneU64`).
    fn reference(mut z: u64) -> u64 {
        z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Edge values and a pseudo-random walk over the 64-bit range (carries across the 32-bit
    /// halves, all-ones, zero).
    fn values() -> Vec<u64> {
        let mut v = vec![
            0,
            1,
            u32::MAX as u64,
            1 << 32,
            u64::MAX,
            u64::MAX - 1,
            1 << 63,
        ];
        let mut z = 0x1234_5678_9ABC_DEF0u64;
        for _ in 0..4096 {
            z = reference(z);
            v.push(z);
        }
        v
    }

    #[test]
    fn width_one_is_splitmix() {
        for z in values() {
            assert_eq!(mix64(z), reference(z), "{z:#x}");
        }
    }

    /// Width 8: the emulated 64-bit lane multiply equals `u64::wrapping_mul` in every lane, and
    /// `mix64` equals the reference in every lane.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn width_eight_equals_width_one() {
        let Some(avx) = super::super::Avx2::detect() else {
            eprintln!("no AVX2/FMA: skipping the 8-wide half");
            return;
        };
        let v = values();
        for (a, b) in v.chunks_exact(8).zip(v.chunks_exact(8).rev()) {
            let (a, b): ([u64; 8], [u64; 8]) = (a.try_into().unwrap(), b.try_into().unwrap());
            let (prod, mixed) = avx.run(
                #[inline(always)]
                || {
                    let (x, y) = (avx.load_u64(&a), avx.load_u64(&b));
                    (x.mul(y).to_array(), mix64(x).to_array())
                },
            );
            for k in 0..8 {
                assert_eq!(
                    prod[k],
                    a[k].wrapping_mul(b[k]),
                    "{:#x} × {:#x}",
                    a[k],
                    b[k]
                );
                assert_eq!(mixed[k], reference(a[k]), "{:#x}", a[k]);
            }
        }
    }
}
