//! Width 8: the operations of the film's exact 128-bit fixed-point sums (`film::sum`): variable
//! 32-bit shifts, the join of four 32-bit words per lane into eight `i128`s (into a column of a
//! per-lane table, or into registers, [`I128x8`]), and the addition of eight `i128` addends to
//! a pixel's eight (biased) sums in four registers (two sums each); and the lane permutes that
//! lay a splat's footprint of filter weights out in lanes.
//!
//! A child of `avx2` (it reads the private fields of [`I32x8`]); the same soundness argument:
//! its values and the [`Avx2`] token exist only when the CPU has AVX2.

use super::{Avx2, F32x8, I32x8};
use core::arch::x86_64::*;

/// Eight `i128`s in four AVX2 registers, two per register: value 2j in the low and 2j + 1 in
/// the high 128-bit half of register j (the layout of a `[i128; 8]` in memory), so that they
/// are added to a pixel's eight sums without a trip through memory
/// ([`Avx2::add_i128x8_biased_regs`]).
#[derive(Clone, Copy)]
pub struct I128x8([__m256i; 4]);

impl I128x8 {
    /// The eight values of `a` (four 32-byte loads).
    #[inline(always)]
    pub fn load(_avx: Avx2, a: &[i128; 8]) -> I128x8 {
        let p = a.as_ptr().cast::<__m256i>();
        // SAFETY: the token proves AVX; each load reads two consecutive `i128`s of `a`.
        I128x8(unsafe { core::array::from_fn(|j| _mm256_loadu_si256(p.add(j))) })
    }
    /// The eight values (tests).
    #[inline(always)]
    pub fn to_array(self) -> [i128; 8] {
        let mut a = [0i128; 8];
        let p = a.as_mut_ptr().cast::<__m256i>();
        // SAFETY: an I128x8 exists only with AVX2; each store writes two `i128`s of `a`.
        unsafe {
            for (j, v) in self.0.into_iter().enumerate() {
                _mm256_storeu_si256(p.add(j), v);
            }
        }
        a
    }
}

impl F32x8 {
    /// Lane k of the result is lane `idx[k] & 7` of `self` (`vpermps`).
    #[inline(always)]
    pub fn permute(self, idx: I32x8) -> F32x8 {
        // SAFETY: an F32x8 exists only with AVX2 (module doc).
        F32x8(unsafe { _mm256_permutevar8x32_ps(self.0, idx.0) })
    }
}

impl I32x8 {
    /// Lane k of the result is lane `idx[k] & 7` of `self` (`vpermd`).
    #[inline(always)]
    pub fn permute(self, idx: I32x8) -> I32x8 {
        // SAFETY: an I32x8 exists only with AVX2 (module doc).
        I32x8(unsafe { _mm256_permutevar8x32_epi32(self.0, idx.0) })
    }
    /// Per lane `self << n` (`vpsllvd`): 0 where `n` ≥ 32 as an unsigned number (so also
    /// where `n` is negative).
    #[inline(always)]
    pub fn shl_var(self, n: I32x8) -> I32x8 {
        // SAFETY: an I32x8 exists only with AVX2 (module doc); likewise below.
        I32x8(unsafe { _mm256_sllv_epi32(self.0, n.0) })
    }
    /// Per lane arithmetic `self >> n` (`vpsravd`): the sign in every bit where `n` ≥ 32 as an
    /// unsigned number (so also where `n` is negative).
    #[inline(always)]
    pub fn sar_var(self, n: I32x8) -> I32x8 {
        I32x8(unsafe { _mm256_srav_epi32(self.0, n.0) })
    }
    /// Per lane: `a` where `self` is negative, else `b` (`vblendvps` on the sign bits).
    #[inline(always)]
    pub fn select_neg(self, a: I32x8, b: I32x8) -> I32x8 {
        unsafe {
            I32x8(_mm256_castps_si256(_mm256_blendv_ps(
                _mm256_castsi256_ps(b.0),
                _mm256_castsi256_ps(a.0),
                _mm256_castsi256_ps(self.0),
            )))
        }
    }
    /// Per lane the smaller as unsigned numbers (`vpminud`).
    #[inline(always)]
    pub fn min_u32(self, o: I32x8) -> I32x8 {
        I32x8(unsafe { _mm256_min_epu32(self.0, o.0) })
    }
    /// The eight 128-bit integers whose 32-bit words (least significant first) are lane `k` of
    /// `words[0]`, …, `words[3]`, value k from lane k, in registers: the 4×4 transpose of
    /// [`I32x8::join_words_into`] (eight unpacks), then four `vperm2i128` that pair the
    /// 128-bit halves (lanes 0 and 1, 2 and 3, …) instead of its eight stores.
    #[inline(always)]
    pub fn join_words(words: [I32x8; 4]) -> I128x8 {
        let [p0, p1, p2, p3] = transpose_words(words);
        // SAFETY: as above.
        unsafe {
            I128x8([
                _mm256_permute2x128_si256::<0x20>(p0, p1),
                _mm256_permute2x128_si256::<0x20>(p2, p3),
                _mm256_permute2x128_si256::<0x31>(p0, p1),
                _mm256_permute2x128_si256::<0x31>(p2, p3),
            ])
        }
    }
    /// Writes the 128-bit integer whose 32-bit words (least significant first) are lane `k` of
    /// `words[0]`, …, `words[3]` to `out[k][j]`, for the eight `k`: a 4×4 transpose of 32-bit
    /// words in each 128-bit half (eight unpacks), then eight 16-byte stores. (A column of a
    /// per-lane table, so that lane `k`'s row `out[k]` is read with full-width loads.)
    ///
    /// # Panics
    /// If `j` ≥ 8.
    #[inline(always)]
    pub fn join_words_into(words: [I32x8; 4], out: &mut [[i128; 8]; 8], j: usize) {
        assert!(j < 8);
        let p = transpose_words(words);
        // SAFETY: as above; each 16-byte store writes `out[k][j]` (k < 8, j < 8).
        unsafe {
            for (k, v) in p.into_iter().enumerate() {
                let lo: *mut i128 = &mut out[k][j];
                let hi: *mut i128 = &mut out[k + 4][j];
                _mm_storeu_si128(lo.cast(), _mm256_castsi256_si128(v));
                _mm_storeu_si128(hi.cast(), _mm256_extracti128_si256::<1>(v));
            }
        }
    }
}

/// The 4×4 transposes of 32-bit words in each 128-bit half of `words` (eight unpacks): lane k's
/// four words (least significant first) as one 128-bit value, in the order [lane 0 | lane 4],
/// [1 | 5], [2 | 6], [3 | 7].
#[inline(always)]
fn transpose_words(words: [I32x8; 4]) -> [__m256i; 4] {
    // SAFETY: an I32x8 exists only with AVX2.
    unsafe {
        let [r0, r1, r2, r3] = [words[0].0, words[1].0, words[2].0, words[3].0];
        // Per half (lanes 0–3, lanes 4–7): t0 = [r0₀ r1₀ r0₁ r1₁], t1 = [r0₂ r1₂ r0₃ r1₃], …
        let t0 = _mm256_unpacklo_epi32(r0, r1);
        let t1 = _mm256_unpackhi_epi32(r0, r1);
        let t2 = _mm256_unpacklo_epi32(r2, r3);
        let t3 = _mm256_unpackhi_epi32(r2, r3);
        [
            _mm256_unpacklo_epi64(t0, t2),
            _mm256_unpackhi_epi64(t0, t2),
            _mm256_unpacklo_epi64(t1, t3),
            _mm256_unpackhi_epi64(t1, t3),
        ]
    }
}

/// The bias of a biased sum ([`Avx2::add_i128x8_biased`]): bit 63, the sign bit of the low
/// 64-bit word, flipped (the film's `sum::LOW_BIAS`).
const LOW_BIAS: i128 = 1 << 63;

impl Avx2 {
    /// Adds eight `i128` addends to eight sums held *biased* (each sum s stored as
    /// s ^ [`LOW_BIAS`], its low word's top bit flipped): s = s.wrapping_add(x[i]), then
    /// s = `i128::MAX` where bit `i` of `SAT` is set and s is negative (the film's saturating
    /// sums of non-negative addends, `film::sum::add_unsigned`). Two sums per register: the
    /// 64-bit words are added (`vpaddq`); flipping the top bit of the low word a is adding 2⁶³
    /// mod 2⁶⁴, so the biased low word plus x is the biased low sum s', and the carry out of
    /// the low word, s <ᵤ a, is the signed s' < a' — one `vpcmpgtq` on the values at hand (the
    /// bias spares the two sign flips an unsigned compare needs). The carry is moved onto the
    /// high word (`vpslldq` by 8 bytes, inside each 128-bit half) and added there; the
    /// saturation test is one `vptest` of the selected sums' sign bits (the high words carry
    /// no bias).
    #[inline(always)]
    pub fn add_i128x8_biased<const SAT: u32>(self, acc: &mut [i128; 8], x: &[i128; 8]) {
        self.add_i128x8_biased_regs::<SAT>(acc, I128x8::load(self, x));
    }

    /// [`Avx2::add_i128x8_biased`] of addends held in registers.
    #[inline(always)]
    pub fn add_i128x8_biased_regs<const SAT: u32>(self, acc: &mut [i128; 8], x: I128x8) {
        let mut any = false;
        // SAFETY: the token proves AVX2. The 32-byte loads and stores read and write two
        // consecutive `i128`s of `acc`.
        unsafe {
            let p = acc.as_mut_ptr().cast::<__m256i>();
            let mut neg = _mm256_setzero_si256();
            for (j, xj) in x.0.into_iter().enumerate() {
                let a = _mm256_loadu_si256(p.add(j));
                let s = _mm256_add_epi64(a, xj);
                // Carry out of the low word: s' <ₛ a' (only the low words' result is kept).
                let c = _mm256_cmpgt_epi64(a, s);
                let s = _mm256_sub_epi64(s, _mm256_bslli_epi128::<8>(c));
                _mm256_storeu_si256(p.add(j), s);
                let (a, b) = ((SAT >> (2 * j)) & 1, (SAT >> (2 * j + 1)) & 1);
                if a | b != 0 {
                    // The sign bits of the high words of the selected sums.
                    let m = _mm256_setr_epi64x(0, -(a as i64) << 63, 0, -(b as i64) << 63);
                    neg = _mm256_or_si256(neg, _mm256_and_si256(s, m));
                }
            }
            if SAT != 0 {
                any = _mm256_testz_si256(neg, neg) == 0;
            }
        }
        if any {
            saturate::<SAT>(acc);
        }
    }
}

/// The rare saturation of [`Avx2::add_i128x8_biased`] (on biased sums: the sign is the high
/// word's, and the maximum is stored biased).
#[cold]
#[inline(never)]
fn saturate<const SAT: u32>(acc: &mut [i128; 8]) {
    for (i, a) in acc.iter_mut().enumerate() {
        if SAT >> i & 1 != 0 && *a < 0 {
            *a = i128::MAX ^ LOW_BIAS;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Values that stress carries and signs: 0, ±1, the 64-bit word boundaries and extremes.
    fn edge() -> Vec<i128> {
        let mut v = vec![
            0i128,
            1,
            -1,
            i128::MAX,
            i128::MIN,
            i128::MAX - 1,
            i128::MIN + 1,
        ];
        for k in [31, 32, 63, 64, 65, 96, 126] {
            let p = 1i128 << k;
            v.extend([p, p - 1, p + 1, -p, -p + 1, -p - 1]);
        }
        v.push(u64::MAX as i128);
        v.push(-(u64::MAX as i128));
        v
    }

    #[test]
    fn add_i128x8_biased_equals_scalar_adds() {
        let Some(avx) = Avx2::detect() else {
            return;
        };
        let e = edge();
        let mut z = 0x853c_49e6_748f_ea9bu64;
        let mut next = || {
            z = z
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            z
        };
        for round in 0..20000 {
            let mut pick = || -> i128 {
                let r = next();
                match r % 4 {
                    0 => e[(r >> 8) as usize % e.len()],
                    1 => (((next() as u128) << 64) | next() as u128) as i128,
                    2 => (next() >> (r >> 58)) as i128 * if r & 1 << 20 != 0 { -1 } else { 1 },
                    _ => (i128::MAX - (next() >> 40) as i128) * (r >> 21 & 1) as i128,
                }
            };
            let acc0: [i128; 8] = core::array::from_fn(|_| pick());
            let x: [i128; 8] = core::array::from_fn(|_| pick());
            // The sums go in biased and come out biased.
            let mut got = acc0.map(|a| a ^ LOW_BIAS);
            let want_wrap: [i128; 8] = core::array::from_fn(|i| acc0[i].wrapping_add(x[i]));
            if round % 2 == 0 {
                avx.run(|| avx.add_i128x8_biased::<0>(&mut got, &x));
                assert_eq!(got.map(|s| s ^ LOW_BIAS), want_wrap, "{acc0:?} + {x:?}");
            } else {
                const SAT: u32 = 0b1111_1000;
                avx.run(|| avx.add_i128x8_biased::<SAT>(&mut got, &x));
                let want: [i128; 8] = core::array::from_fn(|i| {
                    let s = want_wrap[i];
                    if SAT >> i & 1 != 0 && s < 0 {
                        i128::MAX
                    } else {
                        s
                    }
                });
                assert_eq!(got.map(|s| s ^ LOW_BIAS), want, "{acc0:?} + {x:?}");
            }
        }
    }

    #[test]
    fn variable_shifts_blend_permutes_and_join_match_scalar() {
        let Some(avx) = Avx2::detect() else {
            return;
        };
        let mut z = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..20000 {
            let mut arr = || {
                core::array::from_fn::<i32, 8, _>(|_| {
                    z = z
                        .wrapping_mul(6364136223846793005)
                        .wrapping_add(1442695040888963407);
                    let r = (z >> 32) as i32;
                    // Small counts often, any pattern otherwise.
                    if z & 3 == 0 {
                        r
                    } else {
                        r % 40
                    }
                })
            };
            let (a, n, w2, w3) = (arr(), arr(), arr(), arr());
            avx.run(|| {
                let (va, vn) = (avx.load_i32(&a), avx.load_i32(&n));
                let (shl, sar) = (va.shl_var(vn).to_array(), va.sar_var(vn).to_array());
                let sel = vn.select_neg(va, vn).to_array();
                let min = va.min_u32(vn).to_array();
                let perm = va.permute(vn).to_array();
                let fa: [f32; 8] = core::array::from_fn(|k| a[k] as f32 * 0.5);
                let fperm = avx.load(&fa).permute(vn).to_array();
                for k in 0..8 {
                    let c = n[k] as u32;
                    assert_eq!(shl[k], if c < 32 { a[k] << c } else { 0 });
                    assert_eq!(sar[k], a[k] >> c.min(31));
                    assert_eq!(sel[k], if n[k] < 0 { a[k] } else { n[k] });
                    assert_eq!(min[k] as u32, (a[k] as u32).min(c));
                    assert_eq!(perm[k], a[(c & 7) as usize]);
                    assert_eq!(fperm[k].to_bits(), fa[(c & 7) as usize].to_bits());
                }
                let words = [va, vn, avx.load_i32(&w2), avx.load_i32(&w3)];
                let col = (z >> 20) as usize % 8;
                let mut t = [[7i128; 8]; 8];
                I32x8::join_words_into(words, &mut t, col);
                let regs = I32x8::join_words(words).to_array();
                for (k, row) in t.iter().enumerate() {
                    let want = (a[k] as u32 as u128)
                        | (n[k] as u32 as u128) << 32
                        | (w2[k] as u32 as u128) << 64
                        | (w3[k] as u32 as u128) << 96;
                    for (j, &v) in row.iter().enumerate() {
                        assert_eq!(v, if j == col { want as i128 } else { 7 });
                    }
                    assert_eq!(regs[k], want as i128);
                }
                // The registers' layout is the array's: load and store are inverses.
                let vals: [i128; 8] = core::array::from_fn(|k| t[k][col] ^ (k as i128) << 100);
                assert_eq!(I128x8::load(avx, &vals).to_array(), vals);
            });
        }
    }
}
