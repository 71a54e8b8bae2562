//! The compensated first order's nested evaluations in one call (issue 17: "write it on the lane
//! kernels"). One query of the first order evaluates the nested BSDF at up to four (a, b) pairs
//! over the mirror sawtooth (paths [p], [p,t], [t,p], [t,p,t]) or three (single scattering on
//! the other microsurfaces); they are collected into a [`Pairs`] and evaluated together:
//! - nested kinds with a lane form (`src/bsdf/lanes.rs`: [`LaneNested`]) in one call at width 8
//!   under the [`Avx2`] token, or pair by pair at width 1 (the same source: the bit-identity rule
//!   of [`crate::lane`] makes the results equal on every machine);
//! - other kinds pair by pair through their scalar `eval_pdf` / `pdf` (the fallback is the
//!   nested BSDF's own code, never something else).
//!
//! Unused lanes hold a valid pair (a = b = +z) whose results are never read.

use crate::bsdf::diffuse::Diffuse;
use crate::lane::vec::V3;
use crate::lane::Lane;
#[cfg(target_arch = "x86_64")]
use crate::lane::{Avx2, F32x8};
use crate::spectrum::Spectrum;
use glam::Vec3;

/// Lanes of one batch: enough for every query of the first order (4 over the mirror sawtooth,
/// `MAX_FACETS` = 3 otherwise).
pub(super) const WIDTH: usize = 8;

/// A nested BSDF with a lane form: `eval_pdf_lanes` as the convention of `src/bsdf/lanes.rs`
/// states it (f·|cos θo| and the density of `sample`, bit for bit the scalar `eval_pdf` at
/// width 1, with that density equal to the scalar `pdf`).
pub(super) trait LaneNested {
    fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> (V3<L>, L);
}

impl LaneNested for Diffuse {
    #[inline(always)]
    fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> (V3<L>, L) {
        Diffuse::eval_pdf_lanes(self, wi, wo)
    }
}

/// Up to [`WIDTH`] direction pairs in a facet's frame, structure of arrays; bit j of `pdf_only`
/// says that pair j needs only the density (the scalar fallback then calls `pdf`, as the first
/// order always did).
#[derive(Clone, Copy, Debug)]
pub(super) struct Pairs {
    a: [[f32; WIDTH]; 3],
    b: [[f32; WIDTH]; 3],
    n: u8,
    pdf_only: u8,
}

impl Pairs {
    #[inline(always)]
    pub(super) fn new() -> Pairs {
        let z = [[0.0; WIDTH], [0.0; WIDTH], [1.0; WIDTH]];
        Pairs {
            a: z,
            b: z,
            n: 0,
            pdf_only: 0,
        }
    }

    /// Adds the pair (a, b); returns its index.
    #[inline(always)]
    pub(super) fn push(&mut self, a: Vec3, b: Vec3, pdf_only: bool) -> usize {
        let i = self.n as usize;
        for c in 0..3 {
            self.a[c][i] = a[c];
            self.b[c][i] = b[c];
        }
        self.pdf_only |= u8::from(pdf_only) << i;
        self.n += 1;
        i
    }

    #[inline(always)]
    pub(super) fn len(&self) -> usize {
        self.n as usize
    }

    #[inline(always)]
    pub(super) fn a(&self, i: usize) -> Vec3 {
        Vec3::new(self.a[0][i], self.a[1][i], self.a[2][i])
    }

    #[inline(always)]
    pub(super) fn b(&self, i: usize) -> Vec3 {
        Vec3::new(self.b[0][i], self.b[1][i], self.b[2][i])
    }

    #[inline(always)]
    pub(super) fn pdf_only(&self, i: usize) -> bool {
        self.pdf_only & (1 << i) != 0
    }
}

/// The nested `(f·|cos θo|, pdf)` of each pair of a [`Pairs`], by index.
#[derive(Clone, Copy, Debug)]
pub(super) struct Evaluated {
    f: [[f32; WIDTH]; 3],
    p: [f32; WIDTH],
}

impl Evaluated {
    #[inline(always)]
    pub(super) fn zero() -> Evaluated {
        Evaluated {
            f: [[0.0; WIDTH]; 3],
            p: [0.0; WIDTH],
        }
    }

    #[inline(always)]
    pub(super) fn set(&mut self, i: usize, f: Spectrum, p: f32) {
        for c in 0..3 {
            self.f[c][i] = f[c];
        }
        self.p[i] = p;
    }

    #[inline(always)]
    pub(super) fn f(&self, i: usize) -> Spectrum {
        Vec3::new(self.f[0][i], self.f[1][i], self.f[2][i])
    }

    #[inline(always)]
    pub(super) fn p(&self, i: usize) -> f32 {
        self.p[i]
    }
}

/// Every pair of `pairs` through the lane form of `b`: one 8-wide call when the CPU has AVX2 and
/// FMA, else pair by pair at width 1 (the same numbers).
#[inline(always)]
pub(super) fn eval_pdf_lanes<B: LaneNested>(b: &B, pairs: &Pairs) -> Evaluated {
    let mut out = Evaluated::zero();
    if pairs.len() == 0 {
        return out;
    }
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = Avx2::detect() {
        avx.run(
            #[inline(always)]
            || {
                let v = |c: &[[f32; WIDTH]; 3]| {
                    V3::<F32x8>::new(avx.load(&c[0]), avx.load(&c[1]), avx.load(&c[2]))
                };
                let (f, p) = b.eval_pdf_lanes(v(&pairs.a), v(&pairs.b));
                f.x.store(&mut out.f[0]);
                f.y.store(&mut out.f[1]);
                f.z.store(&mut out.f[2]);
                p.store(&mut out.p);
            },
        );
        return out;
    }
    eval_pdf_width1(b, pairs)
}

/// [`eval_pdf_lanes`] at width 1 (a CPU without AVX2).
#[inline(always)]
fn eval_pdf_width1<B: LaneNested>(b: &B, pairs: &Pairs) -> Evaluated {
    let mut out = Evaluated::zero();
    for i in 0..pairs.len() {
        let (f, p) = b.eval_pdf_lanes::<f32>(pairs.a(i).into(), pairs.b(i).into());
        out.set(i, f.into(), p);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::warp;
    use crate::sampler::Sampler;

    /// The batch over a diffuse nested BSDF equals its scalar `eval` and `pdf` bit for bit, at
    /// the width this machine runs it and at width 1, with every count of used lanes and pairs
    /// on both sides of the horizon (z ≤ 0 gives 0).
    #[test]
    fn diffuse_batch_equals_the_scalar_bsdf_bit_for_bit() {
        let d = Diffuse {
            reflectance: Vec3::new(0.8, 0.35, 0.05),
        };
        let mut s = Sampler::from_seed(17, 4);
        let mut below = 0;
        for round in 0..400 {
            let mut pairs = Pairs::new();
            let n = 1 + round % WIDTH;
            for _ in 0..n {
                let a = warp::square_to_uniform_sphere(s.next_2d());
                let b = warp::square_to_uniform_sphere(s.next_2d());
                below += usize::from(a.z <= 0.0 || b.z <= 0.0);
                pairs.push(a, b, false);
            }
            for ev in [eval_pdf_lanes(&d, &pairs), eval_pdf_width1(&d, &pairs)] {
                for i in 0..n {
                    let (a, b) = (pairs.a(i), pairs.b(i));
                    let f = d.eval(a, b).to_array().map(f32::to_bits);
                    assert_eq!(ev.f(i).to_array().map(f32::to_bits), f, "{a} {b}");
                    assert_eq!(ev.p(i).to_bits(), d.pdf(a, b).to_bits(), "{a} {b}");
                }
            }
        }
        assert!(below > 500, "{below}");
    }
}
