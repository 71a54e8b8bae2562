//! Width 8: the operations of the film's exact 128-bit fixed-point sums (`film::sum`): variable
//! 32-bit shifts, the join of four 32-bit words per lane into eight `i128`s held as separate
//! low and high 64-bit words (into two slots of a per-lane table, or into registers,
//! [`I128x8`]), and the addition of eight `i128` addends to a pixel's eight (biased) sums held
//! the same way; and the lane permutes that lay a splat's footprint of filter weights out in
//! lanes.
//!
//! The split layout, `[[u64; 8]; 2]` (the eight low words, then the eight high words, value i
//! in slot i of each): a 128-bit add is a 64-bit add of the low words, the carry out of them
//! (one compare) and two 64-bit adds of the high words, all in the same lane, so no byte
//! shift moves the carry from one half of a register to the other; the sign bits a saturation
//! test reads sit in two registers; and a 4×4 word transpose's first unpacks give the layout
//! as they are.
//!
//! A child of `avx2` (it reads the private fields of [`I32x8`]); the same soundness argument:
//! its values and the [`Avx2`] token exist only when the CPU has AVX2.

use super::{Avx2, F32x8, I32x8};
use core::arch::x86_64::*;

/// Eight `i128`s as their words: `[0]` the low 64-bit words, `[1]` the high ones (two's
/// complement), value i in slot i of each (the film's `Acc` sums and per-lane table rows).
pub type Words8 = [[u64; 8]; 2];

/// The lane of a [`I32x8::join_words`] input that gives value i of its [`I128x8`]: the first
/// unpacks of a 4×4 word transpose pair lanes 0, 1 (and 4, 5 in the upper half) and lanes 2, 3
/// (6, 7), so a row conversion takes its values in this order.
pub const ROW_LANES: [usize; 8] = [0, 1, 4, 5, 2, 3, 6, 7];

/// Eight `i128`s in four AVX2 registers as [`Words8`] holds them: the low words of values 0–3,
/// of values 4–7, then the high words of values 0–3 and 4–7, so that they are added to a
/// pixel's eight sums without a trip through memory ([`Avx2::add_i128x8_biased_regs`]).
#[derive(Clone, Copy)]
pub struct I128x8([__m256i; 4]);

impl I128x8 {
    /// The eight values of `a` (four 32-byte loads).
    #[inline(always)]
    pub fn load(_avx: Avx2, a: &Words8) -> I128x8 {
        let p = a.as_ptr().cast::<__m256i>();
        // SAFETY: the token proves AVX; load j reads words 4j to 4j + 3 of the 16 in `a`. (Four
        // loads written out: `array::from_fn`'s closure may be compiled out of line.)
        I128x8(unsafe {
            [
                _mm256_loadu_si256(p),
                _mm256_loadu_si256(p.add(1)),
                _mm256_loadu_si256(p.add(2)),
                _mm256_loadu_si256(p.add(3)),
            ]
        })
    }
    /// The eight values' words (tests).
    #[inline(always)]
    pub fn to_words(self) -> Words8 {
        let mut a = [[0u64; 8]; 2];
        let p = a.as_mut_ptr().cast::<__m256i>();
        // SAFETY: an I128x8 exists only with AVX2; store j writes words 4j to 4j + 3 of `a`.
        unsafe {
            for (j, v) in self.0.into_iter().enumerate() {
                _mm256_storeu_si256(p.add(j), v);
            }
        }
        a
    }
}

/// Four `i128`s in two AVX2 registers: the low 64-bit words of values 0–3, then their high
/// words (the first four values of an [`I128x8`]): a film pixel's first four sums' addends,
/// one lane's row of [`I32x8::rows4`], added by [`Avx2::add_i128x4_biased_row`].
#[derive(Clone, Copy)]
pub struct I128x4([__m256i; 2]);

impl I128x4 {
    /// The four values' words in the first four slots of each half of a [`Words8`] (tests).
    #[inline(always)]
    pub fn to_words(self) -> Words8 {
        let z = Avx2::zero_reg();
        I128x8([self.0[0], z, self.0[1], z]).to_words()
    }

    /// The first four values of `a` (slots 0–3 of each half; tests).
    #[inline(always)]
    pub fn load(avx: Avx2, a: &Words8) -> I128x4 {
        let x = I128x8::load(avx, a).0;
        I128x4([x[0], x[2]])
    }

    /// The wrapping sums of the eight rows, value by value: value c of the result is
    /// Σₖ `rows[k]` value c mod 2¹²⁸ (a film pixel's eight samples' addends, added once;
    /// integer addition mod 2¹²⁸ is associative, so this equals eight wrapping adds one by one).
    /// The running low words are kept biased (top bit flipped), so the carry out of each low
    /// add is one signed compare, as in [`Avx2::add_i128x4_biased_row`]: 4 instructions a row.
    #[inline(always)]
    pub fn sum8(rows: &[I128x4; 8]) -> I128x4 {
        Self::sum(rows)
    }

    /// The wrapping sums of the `N` rows (`N` ≥ 1), value by value, as [`I128x4::sum8`] does
    /// for eight: a film pixel's two or four samples' addends in a chunk of eight lanes that
    /// covers four or two pixels (a render at 2 or 4 samples a pixel), added once a pixel.
    #[inline(always)]
    pub fn sum<const N: usize>(rows: &[I128x4; N]) -> I128x4 {
        // SAFETY: an I128x4 exists only with AVX2 (module doc).
        unsafe {
            let bias = _mm256_set1_epi64x(LOW_BIAS as i64);
            let mut lo = _mm256_xor_si256(rows[0].0[0], bias);
            let mut hi = rows[0].0[1];
            for r in &rows[1..] {
                let s = _mm256_add_epi64(lo, r.0[0]);
                // Carry out of the low word: s' <ₛ lo', −1 where it carries.
                let c = _mm256_cmpgt_epi64(lo, s);
                hi = _mm256_sub_epi64(_mm256_add_epi64(hi, r.0[1]), c);
                lo = s;
            }
            I128x4([_mm256_xor_si256(lo, bias), hi])
        }
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
    /// `words[0]`, …, `words[3]`, in registers as [`Words8`] holds them, value i from lane
    /// [`ROW_LANES`]`[i]`: the first half of a 4×4 word transpose (four unpacks) gives the low
    /// words of lanes 0, 1, 4, 5 and of lanes 2, 3, 6, 7, and the high words likewise.
    #[inline(always)]
    pub fn join_words(words: [I32x8; 4]) -> I128x8 {
        // SAFETY: an I32x8 exists only with AVX2.
        unsafe {
            let [w0, w1, w2, w3] = [words[0].0, words[1].0, words[2].0, words[3].0];
            I128x8([
                _mm256_unpacklo_epi32(w0, w1),
                _mm256_unpackhi_epi32(w0, w1),
                _mm256_unpacklo_epi32(w2, w3),
                _mm256_unpackhi_epi32(w2, w3),
            ])
        }
    }
    /// Writes the 128-bit integers whose 32-bit words (least significant first) are lane `k`
    /// of `a[0]`, …, `a[3]` and of `b[0]`, …, `b[3]` to slots `s` and `s + 1` of `out[k]`,
    /// for the eight `k` (two columns of a per-lane table, so that lane `k`'s row `out[k]` is
    /// read with full-width loads): per word pair, unpacks of the 32-bit words give lanes
    /// [0, 1 | 4, 5] and [2, 3 | 6, 7] of each column as 64-bit words, unpacks of the two
    /// columns' 64-bit words put a lane's two values side by side ([a | b] of lane 0 and
    /// lane 4 in one register, …), and 16-byte stores write them: 16 unpacks and 16 stores
    /// for the two columns, as many as a column of whole `i128`s took.
    ///
    /// # Panics
    /// If `s` ≥ 7.
    #[inline(always)]
    pub fn join_pair_into(a: [I32x8; 4], b: [I32x8; 4], out: &mut [Words8; 8], s: usize) {
        assert!(s < 7);
        // SAFETY: as above; each 16-byte store writes `out[k][h][s]` and `out[k][h][s + 1]`
        // (k < 8, h < 2, s + 1 < 8).
        unsafe {
            for h in 0..2 {
                let (a0, a1, b0, b1) = (a[2 * h].0, a[2 * h + 1].0, b[2 * h].0, b[2 * h + 1].0);
                // Word h of lanes [0, 1 | 4, 5] and [2, 3 | 6, 7] of each column.
                let (a01, a23) = (_mm256_unpacklo_epi32(a0, a1), _mm256_unpackhi_epi32(a0, a1));
                let (b01, b23) = (_mm256_unpacklo_epi32(b0, b1), _mm256_unpackhi_epi32(b0, b1));
                // Lane k and lane k + 4: [a | b] in each half.
                let p = [
                    _mm256_unpacklo_epi64(a01, b01),
                    _mm256_unpackhi_epi64(a01, b01),
                    _mm256_unpacklo_epi64(a23, b23),
                    _mm256_unpackhi_epi64(a23, b23),
                ];
                for (k, v) in p.into_iter().enumerate() {
                    let lo = out[k][h][s..s + 2].as_mut_ptr();
                    let hi = out[k + 4][h][s..s + 2].as_mut_ptr();
                    _mm_storeu_si128(lo.cast(), _mm256_castsi256_si128(v));
                    _mm_storeu_si128(hi.cast(), _mm256_extracti128_si256::<1>(v));
                }
            }
        }
    }
}

impl I32x8 {
    /// Eight lanes' rows of four 128-bit integers, in registers: value c of row k is the
    /// integer whose 32-bit words (least significant first) are lane k of `cols[c][0]`, …,
    /// `cols[c][3]` (four columns of `film::sum::Fixed8`'s words; a film pixel's w·v and w per
    /// lane). A transpose without memory: per column, the unpacks of [`I32x8::join_words`] give
    /// the low and the high 64-bit words of lanes [0, 1 | 4, 5] and [2, 3 | 6, 7]; per such
    /// register of the four columns, two unpacks of 64-bit words pair the columns lane by lane
    /// and two cross-half permutes (`vperm2i128`) give four lanes' rows. 48 shuffles for the 32
    /// values, where [`I32x8::join_pair_into`] takes 32 unpacks, 16 extracts and 32 stores
    /// into a per-lane table that each lane's add then reads back.
    #[inline(always)]
    pub fn rows4(cols: [[I32x8; 4]; 4]) -> [I128x4; 8] {
        let [a, b, c, d] = [
            I32x8::join_words(cols[0]).0,
            I32x8::join_words(cols[1]).0,
            I32x8::join_words(cols[2]).0,
            I32x8::join_words(cols[3]).0,
        ];
        let z = Avx2::zero_reg();
        let mut out = [I128x4([z, z]); 8];
        // SAFETY: an I32x8 exists only with AVX2 (module doc).
        unsafe {
            // Register r = 2h + q of a column: word half h (0 low, 1 high) of lanes
            // [2q, 2q + 1 | 2q + 4, 2q + 5].
            for h in 0..2 {
                for q in 0..2 {
                    let r = 2 * h + q;
                    // Lanes 2q and 2q + 4: [a, b | a, b] and [c, d | c, d].
                    let (ab0, cd0) = (
                        _mm256_unpacklo_epi64(a[r], b[r]),
                        _mm256_unpacklo_epi64(c[r], d[r]),
                    );
                    // Lanes 2q + 1 and 2q + 5.
                    let (ab1, cd1) = (
                        _mm256_unpackhi_epi64(a[r], b[r]),
                        _mm256_unpackhi_epi64(c[r], d[r]),
                    );
                    let k = 2 * q;
                    out[k].0[h] = _mm256_permute2x128_si256::<0x20>(ab0, cd0);
                    out[k + 4].0[h] = _mm256_permute2x128_si256::<0x31>(ab0, cd0);
                    out[k + 1].0[h] = _mm256_permute2x128_si256::<0x20>(ab1, cd1);
                    out[k + 5].0[h] = _mm256_permute2x128_si256::<0x31>(ab1, cd1);
                }
            }
        }
        out
    }
}

/// The bias of a biased sum ([`Avx2::add_i128x8_biased`]): bit 63 of the low word, the top
/// bit, flipped (the film's `sum::LOW_BIAS`).
const LOW_BIAS: u64 = 1 << 63;

impl Avx2 {
    /// Adds eight `i128` addends to eight sums held *biased* (each sum s stored as
    /// s ^ [`LOW_BIAS`], its low word's top bit flipped), both as [`Words8`]:
    /// s = s.wrapping_add(`x[i]`), then s = `i128::MAX` where bit `i` of `SAT` is set and s is
    /// negative (the film's saturating sums of non-negative addends,
    /// `film::sum::add_unsigned`). Four sums per register: the low words are added
    /// (`vpaddq`); flipping the top bit of the low word a is adding 2⁶³ mod 2⁶⁴, so the biased
    /// low word plus x is the biased low sum s', and the carry out of the low word, s <ᵤ a, is
    /// the signed s' < a' — one `vpcmpgtq` on the values at hand, −1 where it carries. The
    /// high words are added and the carry subtracted, in the same lane. The saturation test is
    /// one `vtestpd` of the selected sums' high words' sign bits (the high words carry no
    /// bias).
    #[inline(always)]
    pub fn add_i128x8_biased<const SAT: u32>(self, acc: &mut Words8, x: &Words8) {
        self.add_i128x8_biased_regs::<SAT>(acc, I128x8::load(self, x));
    }

    /// [`Avx2::add_i128x8_biased`] of addends held in registers.
    #[inline(always)]
    pub fn add_i128x8_biased_regs<const SAT: u32>(self, acc: &mut Words8, x: I128x8) {
        self.add_biased_halves::<SAT, 2>(acc, x.0);
    }

    /// [`Avx2::add_i128x8_biased`] of the first four values only (values 0–3 of `x` added to
    /// sums 0–3 of `acc`; sums 4–7 untouched): two registers' adds instead of four, for a
    /// film that keeps only its first four sums (`film::FilmDesc::second_moments` false).
    /// `SAT`'s bits 4–7 select nothing here.
    #[inline(always)]
    pub fn add_i128x4_biased<const SAT: u32>(self, acc: &mut Words8, x: &Words8) {
        let p = x.as_ptr().cast::<__m256i>();
        // SAFETY: the token proves AVX; the loads read words 0–3 and 8–11 of the 16 in `x`.
        let (lo, hi) = unsafe { (_mm256_loadu_si256(p), _mm256_loadu_si256(p.add(2))) };
        let z = self.zero_i256();
        self.add_biased_halves::<SAT, 1>(acc, [lo, z, hi, z]);
    }

    /// [`Avx2::add_i128x4_biased`] of addends held in registers (values 0–3 of `x`).
    #[inline(always)]
    pub fn add_i128x4_biased_regs<const SAT: u32>(self, acc: &mut Words8, x: I128x8) {
        self.add_biased_halves::<SAT, 1>(acc, x.0);
    }

    /// [`Avx2::add_i128x4_biased`] of one lane's row of [`I32x8::rows4`] (values 0–3 of `x`
    /// to sums 0–3 of `acc`), from registers.
    #[inline(always)]
    pub fn add_i128x4_biased_row<const SAT: u32>(self, acc: &mut Words8, x: I128x4) {
        let z = self.zero_i256();
        self.add_biased_halves::<SAT, 1>(acc, [x.0[0], z, x.0[1], z]);
    }

    /// An all-zero register (the unused operands of a half add).
    #[inline(always)]
    fn zero_i256(self) -> __m256i {
        Self::zero_reg()
    }

    /// An all-zero register, for code that holds AVX2 values but no token.
    #[inline(always)]
    fn zero_reg() -> __m256i {
        // SAFETY: only called where a value of this module's types (or the token) proves AVX;
        // `vpxor` of a register with itself needs nothing else.
        unsafe { _mm256_setzero_si256() }
    }

    /// The biased adds of [`Avx2::add_i128x8_biased`] on the first `HALVES` (1 or 2) groups of
    /// four values: registers `x[j]` (low words) and `x[2 + j]` (high words) for j < `HALVES`.
    #[inline(always)]
    fn add_biased_halves<const SAT: u32, const HALVES: usize>(
        self,
        acc: &mut Words8,
        x: [__m256i; 4],
    ) {
        let mut any = false;
        // SAFETY: the token proves AVX2. The 32-byte loads and stores read and write words
        // 4j to 4j + 3 and 8 + 4j to 8 + 4j + 3 of the 16 in `acc` (j < HALVES ≤ 2).
        unsafe {
            let p = acc.as_mut_ptr().cast::<__m256i>();
            let mut neg = _mm256_setzero_si256();
            for j in 0..HALVES {
                let a = _mm256_loadu_si256(p.add(j));
                let s = _mm256_add_epi64(a, x[j]);
                // Carry out of the low word: s' <ₛ a', −1 where it carries.
                let c = _mm256_cmpgt_epi64(a, s);
                _mm256_storeu_si256(p.add(j), s);
                let h = _mm256_add_epi64(_mm256_loadu_si256(p.add(2 + j)), x[2 + j]);
                let h = _mm256_sub_epi64(h, c);
                _mm256_storeu_si256(p.add(2 + j), h);
                // The high words of the selected sums (their sign bits are tested).
                let sel = (SAT >> (4 * j)) & 15;
                if sel == 15 {
                    neg = _mm256_or_si256(neg, h);
                } else if sel != 0 {
                    let bit = |i: u32| -((sel >> i & 1) as i64);
                    let m = _mm256_setr_epi64x(bit(0), bit(1), bit(2), bit(3));
                    if HALVES == 1 {
                        // One group: `vtestpd` reads the selection as its mask operand, so
                        // h & m is not formed in a register first.
                        any = _mm256_testz_pd(_mm256_castsi256_pd(h), _mm256_castsi256_pd(m)) == 0;
                    } else {
                        neg = _mm256_or_si256(neg, _mm256_and_si256(h, m));
                    }
                }
            }
            let mask = if HALVES == 1 { SAT & 15 } else { SAT & 0xff };
            // (One group's partial selection was tested above.)
            if mask != 0 && !(HALVES == 1 && mask != 15) {
                let n = _mm256_castsi256_pd(neg);
                any = _mm256_testz_pd(n, n) == 0;
            }
        }
        if any {
            saturate::<SAT>(acc, 4 * HALVES);
        }
    }
}

/// The rare saturation of [`Avx2::add_i128x8_biased`] (on biased sums: the sign is the high
/// word's, and the maximum is stored biased).
#[cold]
#[inline(never)]
fn saturate<const SAT: u32>(acc: &mut Words8, n: usize) {
    let [lo, hi] = acc;
    for (i, (lo, hi)) in lo.iter_mut().zip(hi.iter_mut()).enumerate().take(n) {
        if SAT >> i & 1 != 0 && (*hi as i64) < 0 {
            (*lo, *hi) = (u64::MAX ^ LOW_BIAS, i64::MAX as u64);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `v`'s values as words.
    fn split(v: [i128; 8]) -> Words8 {
        [v.map(|x| x as u64), v.map(|x| (x >> 64) as u64)]
    }

    /// The values of words.
    fn join(w: Words8) -> [i128; 8] {
        core::array::from_fn(|i| ((w[1][i] as i128) << 64) | w[0][i] as i128)
    }

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

    /// The split add equals scalar wrapping adds, and saturating ones where `SAT` selects a
    /// sum: with the film's selection (sums 3 to 7), with none, with every sum, and with one
    /// in each register; the half adds likewise on sums 0–3, leaving sums 4–7 as they were.
    #[test]
    fn add_i128x8_biased_equals_scalar_adds() {
        let Some(avx) = Avx2::detect() else {
            eprintln!("no AVX2: add_i128x8_biased not tested");
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
        fn check<const SAT: u32>(avx: Avx2, acc0: [i128; 8], x: [i128; 8]) {
            // The sums go in biased and come out biased.
            let mut got = split(acc0.map(|a| a ^ LOW_BIAS as i128));
            avx.run(|| avx.add_i128x8_biased::<SAT>(&mut got, &split(x)));
            let want: [i128; 8] = core::array::from_fn(|i| {
                let s = acc0[i].wrapping_add(x[i]);
                if SAT >> i & 1 != 0 && s < 0 {
                    i128::MAX
                } else {
                    s
                }
            });
            let got = join(got).map(|s| s ^ LOW_BIAS as i128);
            assert_eq!(got, want, "SAT {SAT:#b}: {acc0:?} + {x:?}");
            // The half adds: sums 0–3 as above, sums 4–7 as they were (from memory and from
            // registers).
            let half: [i128; 8] = core::array::from_fn(|i| if i < 4 { want[i] } else { acc0[i] });
            for form in 0..3 {
                let mut got = split(acc0.map(|a| a ^ LOW_BIAS as i128));
                avx.run(|| match form {
                    0 => avx.add_i128x4_biased::<SAT>(&mut got, &split(x)),
                    1 => {
                        let r = I128x8::load(avx, &split(x));
                        avx.add_i128x4_biased_regs::<SAT>(&mut got, r);
                    }
                    _ => {
                        // One lane's row of `rows4`: x[0..4] as lane 0 of four columns.
                        let col = |v: i128| -> [I32x8; 4] {
                            core::array::from_fn(|w| {
                                avx.load_i32(&[(v >> (32 * w)) as i32, 1, 2, 3, 4, 5, 6, 7])
                            })
                        };
                        let rows = I32x8::rows4([col(x[0]), col(x[1]), col(x[2]), col(x[3])]);
                        avx.add_i128x4_biased_row::<SAT>(&mut got, rows[0]);
                    }
                });
                let got = join(got).map(|s| s ^ LOW_BIAS as i128);
                assert_eq!(
                    got, half,
                    "half, form {form}, SAT {SAT:#b}: {acc0:?} + {x:?}"
                );
            }
        }
        let mut saturated = 0;
        for round in 0..40000 {
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
            saturated += acc0.iter().zip(&x).any(|(a, b)| a.wrapping_add(*b) < 0) as u32;
            match round % 4 {
                0 => check::<0>(avx, acc0, x),
                1 => check::<0b1111_1000>(avx, acc0, x),
                2 => check::<0b1111_1111>(avx, acc0, x),
                _ => check::<0b0010_0100>(avx, acc0, x),
            }
        }
        assert!(saturated > 1000, "{saturated}");
    }

    #[test]
    fn variable_shifts_blend_permutes_and_join_match_scalar() {
        let Some(avx) = Avx2::detect() else {
            eprintln!("no AVX2: the lane operations not tested");
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
            let (b0, b1, b2, b3) = (arr(), arr(), arr(), arr());
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
                let bw = [b0, b1, b2, b3].map(|w| avx.load_i32(&w));
                let value = |w: [[i32; 8]; 4], k: usize| {
                    ((w[0][k] as u32 as u128)
                        | (w[1][k] as u32 as u128) << 32
                        | (w[2][k] as u32 as u128) << 64
                        | (w[3][k] as u32 as u128) << 96) as i128
                };
                let s = (z >> 20) as usize % 7;
                let mut t = [[[7u64; 8]; 2]; 8];
                I32x8::join_pair_into(words, bw, &mut t, s);
                let regs = join(I32x8::join_words(words).to_words());
                for (k, row) in t.iter().enumerate() {
                    let row = join(*row);
                    for (j, &v) in row.iter().enumerate() {
                        let want = match j {
                            _ if j == s => value([a, n, w2, w3], k),
                            _ if j == s + 1 => value([b0, b1, b2, b3], k),
                            _ => (7 << 64) | 7,
                        };
                        assert_eq!(v, want, "lane {k} slot {j} (s = {s})");
                    }
                    // The row conversion: value i from lane ROW_LANES[i].
                    let i = ROW_LANES.iter().position(|&l| l == k).unwrap();
                    assert_eq!(regs[i], value([a, n, w2, w3], k));
                }
                // The rows of four columns: value c of row k from lane k of column c (the
                // columns: the two above, and two more from the same inputs reordered).
                let cw = [
                    [a, n, w2, w3],
                    [b0, b1, b2, b3],
                    [w3, b2, a, n],
                    [n, w2, b3, b0],
                ];
                let cols = cw.map(|c| c.map(|w| avx.load_i32(&w)));
                for (k, row) in I32x8::rows4(cols).into_iter().enumerate() {
                    let got = join(row.to_words());
                    for (c, w) in cw.iter().enumerate() {
                        assert_eq!(got[c], value(*w, k), "rows4: lane {k} column {c}");
                    }
                    assert_eq!(got[4..], [0; 4], "rows4: lane {k} beyond its four values");
                }
                // The registers' layout is the words': load and store are inverses.
                let vals: [i128; 8] = core::array::from_fn(|k| regs[k] ^ (k as i128) << 100);
                assert_eq!(join(I128x8::load(avx, &split(vals)).to_words()), vals);
            });
        }
    }
}
