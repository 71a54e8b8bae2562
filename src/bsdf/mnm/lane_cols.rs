//! Columns of 8 lanes (`[f32; 8]`, `[i32; 8]`: one number per shading point of a stream chunk)
//! written under a lane mask given as bits (bit k: lane k), as the compensated chunk keeps its
//! points' numbers (issue 18). A column written lane by lane under a test of each bit compiled
//! to a branch and two moves per lane; here it is one blend of two 8-wide loads when the CPU
//! has AVX2 (the same bits: a blend copies each lane's bits as they are), else the plain loop.
//!
//! The CPU's answer is a token, [`Cols`], detected once per chunk (or taken from the stream
//! kernel's own `Avx2` token) and handed down: each of its operations is a few instructions
//! inside [`Cols::run`] (one AVX2 region per calling function), where detecting AVX2 and
//! entering a region per blend cost ~20 instructions each (twenty-sixth session's profile).

#[cfg(target_arch = "x86_64")]
use crate::lane::{Avx2, F32x8, Lane};

/// Whether the chunk's columns are blended 8-wide (the CPU has AVX2 and FMA: its token) or
/// lane by lane. Its operations are correct anywhere; they compile to single instructions
/// only inside [`Self::run`] (else each 8-wide operation is a call).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Cols {
    #[cfg(target_arch = "x86_64")]
    avx: Option<Avx2>,
}

/// A column's number type, whose lanes a blend copies as bits (`f32`, `i32`).
pub(crate) trait Col: Copy {
    /// The column as 8 `f32` lanes (the same bits).
    #[cfg(target_arch = "x86_64")]
    fn load(avx: Avx2, a: &[Self; 8]) -> F32x8;
    /// Stores 8 lanes' bits into the column.
    #[cfg(target_arch = "x86_64")]
    fn store(v: F32x8, a: &mut [Self; 8]);
}

impl Col for f32 {
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn load(avx: Avx2, a: &[f32; 8]) -> F32x8 {
        avx.load(a)
    }
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn store(v: F32x8, a: &mut [f32; 8]) {
        v.store(a);
    }
}

impl Col for i32 {
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn load(avx: Avx2, a: &[i32; 8]) -> F32x8 {
        F32x8::from_bits(avx.load_i32(a))
    }
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn store(v: F32x8, a: &mut [i32; 8]) {
        *a = v.to_bits().to_array();
    }
}

impl Cols {
    /// 8-wide when this CPU has AVX2 and FMA, else lane by lane (the tests' chunks; the
    /// stream kernel hands its own token, [`Self::of`]).
    #[cfg(test)]
    pub(crate) fn detect() -> Self {
        Cols {
            #[cfg(target_arch = "x86_64")]
            avx: Avx2::detect(),
        }
    }

    /// Lane by lane (a CPU without AVX2; the tests' reference).
    #[cfg(test)]
    pub(crate) const LOOPS: Cols = Cols {
        #[cfg(target_arch = "x86_64")]
        avx: None,
    };

    /// 8-wide, from a caller's token (the stream kernel runs inside its `Avx2::run`).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn of(avx: Avx2) -> Self {
        Cols { avx: Some(avx) }
    }

    /// The AVX2 token, when 8-wide.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(crate) fn avx(self) -> Option<Avx2> {
        self.avx
    }

    /// `f(cols)` inside one AVX2 region when 8-wide (`Avx2::run`; the token handed to `f` is
    /// known there, so its blends compile without a test), else `f(self)` as it is. Give it a
    /// closure marked `#[inline(always)]` (a closure compiled out of the region makes its
    /// 8-wide operations calls).
    #[inline(always)]
    pub(crate) fn run<R>(self, f: impl FnOnce(Cols) -> R) -> R {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            return avx.run(
                #[inline(always)]
                move || f(Cols::of(avx)),
            );
        }
        f(self)
    }

    /// `dst[k] = src[k]` for each lane k of `on` (bit k), the other lanes of `dst` kept (their
    /// bits as they are: `f32` or `i32` columns, one body).
    #[inline(always)]
    pub(crate) fn blend<T: Col>(self, on: u8, dst: &mut [T; 8], src: &[T; 8]) {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            let m = avx.mask_bits(u32::from(on));
            T::store(F32x8::select(m, T::load(avx, src), T::load(avx, dst)), dst);
            return;
        }
        blend_width1(on, dst, src);
    }

    /// [`Self::blend`] of the three columns of a vector column (`[component][lane]`).
    #[inline(always)]
    pub(crate) fn blend3(self, on: u8, dst: &mut [[f32; 8]; 3], src: &[[f32; 8]; 3]) {
        for (d, s) in dst.iter_mut().zip(src) {
            self.blend(on, d, s);
        }
    }

    /// The lanes (bits) where column `x` is not at most 0 (`!(x <= 0.0)`: above 0, or NaN),
    /// the scalar code's `if x <= 0.0 { continue }` of each lane as one compare.
    #[inline(always)]
    pub(crate) fn not_le_zero(self, x: &[f32; 8]) -> u8 {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            return (!avx.load(x).le(avx.splat(0.0))).bits() as u8;
        }
        let mut bits = 0u8;
        for (k, &v) in x.iter().enumerate() {
            bits |= u8::from(v > 0.0 || v.is_nan()) << k;
        }
        bits
    }

    /// The lanes (bits) where column `x` is above `c` (`x > c`: not NaN), as one compare.
    #[inline(always)]
    pub(crate) fn gt_bits(self, x: &[f32; 8], c: f32) -> u8 {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            return avx.load(x).gt(avx.splat(c)).bits() as u8;
        }
        let mut bits = 0u8;
        for (k, &v) in x.iter().enumerate() {
            bits |= u8::from(v > c) << k;
        }
        bits
    }

    /// The lanes (bits) where |x| of column `x` is below `c` (`x.abs() < c`: not NaN), as one
    /// compare.
    #[inline(always)]
    pub(crate) fn abs_lt_bits(self, x: &[f32; 8], c: f32) -> u8 {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            return avx.load(x).abs().lt(avx.splat(c)).bits() as u8;
        }
        let mut bits = 0u8;
        for (k, &v) in x.iter().enumerate() {
            bits |= u8::from(v.abs() < c) << k;
        }
        bits
    }
}

/// [`Cols::blend`] lane by lane.
#[inline(always)]
fn blend_width1<T: Copy>(on: u8, dst: &mut [T; 8], src: &[T; 8]) {
    for k in 0..8 {
        if on & (1 << k) != 0 {
            dst[k] = src[k];
        }
    }
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
    /// of 8 lanes, on columns with edge values (NaN payloads kept): 8-wide inside one region
    /// ([`Cols::run`]), 8-wide outside it, and the loops ([`Cols::LOOPS`]).
    #[test]
    fn blends_and_tests_equal_the_loops() {
        let mut rng = Pcg32::new(26, 3);
        for on in 0..=255u8 {
            for _ in 0..8 {
                let (d, s) = (column(&mut rng), column(&mut rng));
                let (df, sf) = (d.map(f32::from_bits), s.map(f32::from_bits));
                let (di, si) = (d.map(|x| x as i32), s.map(|x| x as i32));
                let mut want = df;
                blend_width1(on, &mut want, &sf);
                for k in 0..8 {
                    let w = if on & (1 << k) != 0 { s[k] } else { d[k] };
                    assert_eq!(want[k].to_bits(), w, "{on} {k}");
                }
                let mut le = 0u8;
                for (k, &v) in df.iter().enumerate() {
                    if v <= 0.0 {
                        continue;
                    }
                    le |= 1 << k;
                }
                let (d3, s3) = ([df, sf, df], [sf, df, sf]);
                let mut want3 = d3;
                for (w, s) in want3.iter_mut().zip(&s3) {
                    blend_width1(on, w, s);
                }
                for cols in [Cols::detect(), Cols::LOOPS] {
                    for inside in [true, false] {
                        let mut got = df;
                        let mut got_i = di;
                        let mut got3 = d3;
                        let mut bits = 0;
                        let mut body = |c: Cols| {
                            c.blend(on, &mut got, &sf);
                            c.blend(on, &mut got_i, &si);
                            c.blend3(on, &mut got3, &s3);
                            bits = c.not_le_zero(&df);
                        };
                        if inside {
                            cols.run(body);
                        } else {
                            body(cols);
                        }
                        assert_eq!(got.map(f32::to_bits), want.map(f32::to_bits), "{on}");
                        for k in 0..8 {
                            let w = if on & (1 << k) != 0 { si[k] } else { di[k] };
                            assert_eq!(got_i[k], w, "{on} {k}");
                        }
                        assert_eq!(
                            got3.map(|c| c.map(f32::to_bits)),
                            want3.map(|c| c.map(f32::to_bits)),
                            "{on}"
                        );
                        assert_eq!(bits, le, "{df:?}");
                    }
                }
            }
        }
    }

    /// The compares against a constant equal the scalar tests lane by lane, 8-wide and in the
    /// loops: columns with edge values (±0, subnormals, ±∞, NaNs), constants of both signs,
    /// 0, a subnormal, ∞, and lane values equal to the constant (and to its negative).
    #[test]
    fn compares_with_a_constant_equal_the_scalar_tests() {
        let mut rng = Pcg32::new(29, 2);
        let consts = [
            1e-6f32,
            1e-7,
            0.0,
            -0.0,
            -1.0,
            f32::from_bits(1),
            f32::INFINITY,
            0.5,
        ];
        for round in 0..4000 {
            let c = consts[round % consts.len()];
            let mut x = column(&mut rng).map(f32::from_bits);
            for v in x.iter_mut() {
                match rng.next_u32() % 4 {
                    0 => *v = c,
                    1 => *v = -c,
                    2 => *v = c * rng.next_f32() * 2.0,
                    _ => {}
                }
            }
            let (mut gt, mut lt) = (0u8, 0u8);
            for (k, &v) in x.iter().enumerate() {
                gt |= u8::from(v > c) << k;
                lt |= u8::from(v.abs() < c) << k;
            }
            for cols in [Cols::detect(), Cols::LOOPS] {
                let got = cols.run(|c8| (c8.gt_bits(&x, c), c8.abs_lt_bits(&x, c)));
                assert_eq!(got, (gt, lt), "{c} {x:?}");
            }
        }
    }
}
