//! Columns of 8 lanes (`[f32; 8]`, `[i32; 8]`: one number per shading point of a stream chunk)
//! written under a lane mask given as bits (bit k: lane k), as the compensated chunk keeps its
//! points' numbers (issue 18). A column written lane by lane under a test of each bit compiled
//! to a branch and two moves per lane; here it is one blend of two 8-wide loads when the CPU
//! has AVX2 (the same bits: a blend copies each lane's bits as they are), else the plain loop.

#[cfg(target_arch = "x86_64")]
use crate::lane::{Avx2, F32x8, Lane};

/// `dst[k] = src[k]` for each lane k of `on` (bit k), the other lanes of `dst` kept.
#[inline(always)]
pub(crate) fn blend(on: u8, dst: &mut [f32; 8], src: &[f32; 8]) {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = Avx2::detect() {
        avx.run(
            #[inline(always)]
            || {
                let m = avx.mask_bits(u32::from(on));
                F32x8::select(m, avx.load(src), avx.load(dst)).store(dst);
            },
        );
        return;
    }
    blend_width1(on, dst, src);
}

/// [`blend`] lane by lane.
#[inline(always)]
fn blend_width1<T: Copy>(on: u8, dst: &mut [T; 8], src: &[T; 8]) {
    for k in 0..8 {
        if on & (1 << k) != 0 {
            dst[k] = src[k];
        }
    }
}

/// [`blend`] of the three columns of a vector column (`[component][lane]`).
#[inline(always)]
pub(crate) fn blend3(on: u8, dst: &mut [[f32; 8]; 3], src: &[[f32; 8]; 3]) {
    for (d, s) in dst.iter_mut().zip(src) {
        blend(on, d, s);
    }
}

/// [`blend`] of integer columns (the bits of each lane copied as they are).
#[inline(always)]
pub(crate) fn blend_i32(on: u8, dst: &mut [i32; 8], src: &[i32; 8]) {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = Avx2::detect() {
        avx.run(
            #[inline(always)]
            || {
                let m = avx.mask_bits(u32::from(on));
                let (a, b) = (
                    F32x8::from_bits(avx.load_i32(src)),
                    F32x8::from_bits(avx.load_i32(dst)),
                );
                *dst = F32x8::select(m, a, b).to_bits().to_array();
            },
        );
        return;
    }
    blend_width1(on, dst, src);
}

/// The lanes (bits) where column `x` is not at most 0 (`!(x <= 0.0)`: above 0, or NaN), the
/// scalar code's `if x <= 0.0 { continue }` of each lane as one compare.
#[inline(always)]
pub(crate) fn not_le_zero(x: &[f32; 8]) -> u8 {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = Avx2::detect() {
        return avx.run(
            #[inline(always)]
            || (!avx.load(x).le(avx.splat(0.0))).bits() as u8,
        );
    }
    let mut bits = 0u8;
    for (k, &v) in x.iter().enumerate() {
        bits |= u8::from(v > 0.0 || v.is_nan()) << k;
    }
    bits
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Pcg32;

    /// Edge values: zeros of both signs, subnormals, ±∞, NaNs with payloads, ordinary numbers.
    const EDGES: [u32; 10] = [
        0x0000_0000,
        0x8000_0000,
        0x0000_0001,
        0x8000_0001,
        0x7f80_0000,
        0xff80_0000,
        0x7fc0_0000,
        0xffc1_2345,
        0x3f80_0000,
        0xbf00_0000,
    ];

    fn column(rng: &mut Pcg32) -> [u32; 8] {
        std::array::from_fn(|_| match rng.next_u32() % 3 {
            0 => EDGES[rng.next_u32() as usize % EDGES.len()],
            _ => rng.next_u32(),
        })
    }

    /// The blends and the sign test equal the lane-by-lane loops bit for bit, for every mask
    /// of 8 lanes, on columns with edge values (NaN payloads kept).
    #[test]
    fn blends_and_tests_equal_the_loops() {
        let mut rng = Pcg32::new(26, 3);
        for on in 0..=255u8 {
            for _ in 0..8 {
                let (d, s) = (column(&mut rng), column(&mut rng));
                let (df, sf) = (d.map(f32::from_bits), s.map(f32::from_bits));
                let (mut got, mut want) = (df, df);
                blend(on, &mut got, &sf);
                blend_width1(on, &mut want, &sf);
                assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "{on}");
                for k in 0..8 {
                    let want = if on & (1 << k) != 0 { s[k] } else { d[k] };
                    assert_eq!(got[k].to_bits(), want, "{on} {k}");
                }
                let (di, si) = (d.map(|x| x as i32), s.map(|x| x as i32));
                let mut got = di;
                blend_i32(on, &mut got, &si);
                for k in 0..8 {
                    let want = if on & (1 << k) != 0 { si[k] } else { di[k] };
                    assert_eq!(got[k], want, "{on} {k}");
                }
                let mut want = 0u8;
                for (k, &v) in df.iter().enumerate() {
                    if v <= 0.0 {
                        continue;
                    }
                    want |= 1 << k;
                }
                assert_eq!(not_le_zero(&df), want, "{df:?}");
            }
        }
    }
}
