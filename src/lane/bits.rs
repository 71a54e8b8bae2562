//! Lane masks as arrays of `bool`: the eight low bits of a movemask spread to eight bytes
//! with a few integer operations, instead of a shift, test and store per lane (the kernels
//! turn masks into `[bool; W]` for their per-lane loops; measured 4.4 M instructions of
//! `metal_plastic`'s 160 M with the per-lane form, `docs/bench/README.md`, fourteenth session).

/// The number of set bits of each byte value: a lane mask's lane count by one load (the lanes'
/// target features have no `popcnt`, where `count_ones` is spelled out in ~12 instructions).
pub const BYTE_COUNTS: [u8; 256] = {
    let mut t = [0u8; 256];
    let mut b = 0;
    while b < 256 {
        t[b] = (b as u32).count_ones() as u8;
        b += 1;
    }
    t
};

/// The booleans of the low eight bits of `m`: element `k` is bit `k`.
#[inline(always)]
pub fn bools8(m: u32) -> [bool; 8] {
    // The byte broadcast (no carries: m < 256), each byte keeping its own bit (byte k: bit k,
    // value 0 or 2^k), then 0x7f added per byte (no carry out of a byte: 2^k + 0x7f ≤ 0xff),
    // so that a byte's top bit is set exactly when its bit was: shifted down to bit 0.
    let b = ((m & 0xff) as u64 * 0x0101_0101_0101_0101) & 0x8040_2010_0804_0201;
    let b = ((b + 0x7f7f_7f7f_7f7f_7f7f) >> 7) & 0x0101_0101_0101_0101;
    // SAFETY: every byte is 0 or 1, the two valid bit patterns of `bool` (same size and
    // alignment as `u8`).
    unsafe { core::mem::transmute::<[u8; 8], [bool; 8]>(b.to_le_bytes()) }
}

/// [`bools8`] of the low sixteen bits: element `k` is bit `k`.
#[inline(always)]
pub fn bools16(m: u32) -> [bool; 16] {
    let (lo, hi) = (bools8(m), bools8(m >> 8));
    core::array::from_fn(|k| if k < 8 { lo[k] } else { hi[k - 8] })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_byte_and_word_gives_its_bits() {
        for m in 0..256u32 {
            assert_eq!(
                bools8(m),
                core::array::from_fn(|k| m >> k & 1 == 1),
                "{m:#x}"
            );
            // Bits above the eighth are ignored.
            assert_eq!(bools8(m | 0xff00), bools8(m));
        }
        for m in (0..1u32 << 16).step_by(7).chain([0xffff, 0x8001, 0x7ffe]) {
            assert_eq!(
                bools16(m),
                core::array::from_fn(|k| m >> k & 1 == 1),
                "{m:#x}"
            );
        }
    }

    /// `Avx2::mask_bits` sets lane `k` exactly when bit `k` is set (bits above the eighth
    /// ignored): `M8::bits` and `Avx2::mask` agree with it on every byte.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn a_mask_from_bits_has_those_bits() {
        let Some(avx) = crate::lane::Avx2::detect() else {
            return;
        };
        for m in 0..256u32 {
            let (a, b) = (avx.mask_bits(m | 0x7f00), avx.mask(&bools8(m)));
            assert_eq!((a.bits(), b.bits()), (m, m), "{m:#x}");
            assert_eq!(a.to_array(), bools8(m));
        }
    }
}
