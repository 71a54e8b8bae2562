//! Slice entry points: a lane function applied over whole slices at width 1 or width 8, the
//! 8-wide loop compiled inside [`Avx2::run`]. Tests and benches use them; a renderer would put
//! its own loops inside `run` the same way. A slice length that is not a multiple of 8 has its
//! tail run at width 1 (the same bits, by the bit-identity rule).

use super::Lane;
#[cfg(target_arch = "x86_64")]
use super::{Avx2, F32x8};

/// `out[i] = f(a[i])` at width 1.
#[inline(always)]
pub fn map1_scalar(a: &[f32], out: &mut [f32], f: impl Fn(f32) -> f32) {
    for (o, &x) in out.iter_mut().zip(a) {
        *o = f(x);
    }
}

/// `out[i] = f(a[i], b[i])` at width 1.
#[inline(always)]
pub fn map2_scalar(a: &[f32], b: &[f32], out: &mut [f32], f: impl Fn(f32, f32) -> f32) {
    for ((o, &x), &y) in out.iter_mut().zip(a).zip(b) {
        *o = f(x, y);
    }
}

/// `out[i] = f(a[i])` over chunks of 8, with the tail at width 1. `f` is generic code called
/// at both widths: pass the same function twice (`sin::<F32x8>`, `sin::<f32>`).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn map1_avx2(
    avx: Avx2,
    a: &[f32],
    out: &mut [f32],
    f8: impl Fn(F32x8) -> F32x8,
    f1: impl Fn(f32) -> f32,
) {
    avx.run(
        #[inline(always)]
        || {
            let n = a.len().min(out.len());
            let mut ca = a[..n].chunks_exact(8);
            let mut co = out[..n].chunks_exact_mut(8);
            for (x, o) in (&mut ca).zip(&mut co) {
                let x = avx.load(x.try_into().expect("chunk of 8"));
                f8(x).store(o.try_into().expect("chunk of 8"));
            }
            map1_scalar(ca.remainder(), co.into_remainder(), f1);
        },
    )
}

/// `out[i] = f(a[i], b[i])` over chunks of 8, with the tail at width 1.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
pub fn map2_avx2(
    avx: Avx2,
    a: &[f32],
    b: &[f32],
    out: &mut [f32],
    f8: impl Fn(F32x8, F32x8) -> F32x8,
    f1: impl Fn(f32, f32) -> f32,
) {
    avx.run(
        #[inline(always)]
        || {
            let n = a.len().min(b.len()).min(out.len());
            let mut ca = a[..n].chunks_exact(8);
            let mut cb = b[..n].chunks_exact(8);
            let mut co = out[..n].chunks_exact_mut(8);
            for ((x, y), o) in (&mut ca).zip(&mut cb).zip(&mut co) {
                let x = avx.load(x.try_into().expect("chunk of 8"));
                let y = avx.load(y.try_into().expect("chunk of 8"));
                f8(x, y).store(o.try_into().expect("chunk of 8"));
            }
            map2_scalar(ca.remainder(), cb.remainder(), co.into_remainder(), f1);
        },
    )
}

/// Lane `i` of each of `vals` (helper for comparing lanes in tests).
pub fn lanes<L: Lane>(v: L) -> Vec<f32> {
    (0..L::WIDTH).map(|i| v.lane(i)).collect()
}
