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
use crate::bsdf::roughconductor::RoughConductor;
use crate::bsdf::roughplastic::RoughPlastic;
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
/// width 1) and `pdf_lanes`, bit for bit the scalar `pdf` (which the first order calls for
/// the pairs that need only a density).
pub(super) trait LaneNested {
    /// True when `pdf_lanes` may differ from `eval_pdf_lanes`' density in the last bits (then a
    /// batch with density-only pairs computes both; otherwise one call serves all pairs).
    const SEPARATE_PDF: bool;
    fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> (V3<L>, L);
    #[inline(always)]
    fn pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> L {
        self.eval_pdf_lanes(wi, wo).1
    }
}

/// `pdf` is `eval`'s cosine density (both `diffuse.rs`).
impl LaneNested for Diffuse {
    const SEPARATE_PDF: bool = false;
    #[inline(always)]
    fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> (V3<L>, L) {
        Diffuse::eval_pdf_lanes(self, wi, wo)
    }
}

/// `pdf` has its own code (no D = 0 test, G1(ωi) only with visible-normal sampling).
impl LaneNested for RoughConductor {
    const SEPARATE_PDF: bool = true;
    #[inline(always)]
    fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> (V3<L>, L) {
        RoughConductor::eval_pdf_lanes(self, wi, wo)
    }
    #[inline(always)]
    fn pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> L {
        RoughConductor::pdf_lanes(self, wi, wo)
    }
}

/// `pdf` is `eval_pdf`'s density (`roughplastic.rs`).
impl LaneNested for RoughPlastic {
    const SEPARATE_PDF: bool = false;
    #[inline(always)]
    fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> (V3<L>, L) {
        RoughPlastic::eval_pdf_lanes(self, wi, wo)
    }
}

/// Up to [`WIDTH`] direction pairs in a facet's frame, structure of arrays; bit j of `pdf_only`
/// says that pair j needs only the density (the scalar fallback then calls `pdf`, as the first
/// order always did).
#[derive(Clone, Copy, Debug)]
pub(super) struct Pairs {
    a: [[f32; WIDTH]; 3],
    b: [[f32; WIDTH]; 3],
    /// 1 in the lanes of density-only pairs (the lane kernel's mask), else 0.
    po: [f32; WIDTH],
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
            po: [0.0; WIDTH],
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
        self.po[i] = f32::from(u8::from(pdf_only));
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

/// What one lane call computes, decided once per batch.
#[derive(Clone, Copy, PartialEq)]
enum Mode {
    /// `eval_pdf_lanes` (every pair, or a BSDF whose `pdf` is that density).
    EvalPdf,
    /// `pdf_lanes` only (every pair is density-only): `f` is left 0.
    Pdf,
    /// Both, the density of density-only lanes from `pdf_lanes`.
    Mixed,
}

impl Pairs {
    #[inline(always)]
    fn mode<B: LaneNested>(&self) -> Mode {
        let all = self.pdf_only == ((1u16 << self.n) - 1) as u8;
        match (B::SEPARATE_PDF, self.pdf_only) {
            (false, _) | (true, 0) => Mode::EvalPdf,
            (true, _) if all => Mode::Pdf,
            _ => Mode::Mixed,
        }
    }
}

/// The lane kernel at either width (`po`: 1 in density-only lanes).
#[inline(always)]
fn kernel<L: Lane, B: LaneNested>(b: &B, mode: Mode, a: V3<L>, o: V3<L>, po: L) -> (V3<L>, L) {
    match mode {
        Mode::EvalPdf => b.eval_pdf_lanes(a, o),
        Mode::Pdf => {
            let z = po.splat(0.0);
            (V3::new(z, z, z), b.pdf_lanes(a, o))
        }
        Mode::Mixed => {
            let (f, p) = b.eval_pdf_lanes(a, o);
            (f, L::select(po.gt(po.splat(0.0)), b.pdf_lanes(a, o), p))
        }
    }
}

/// Every pair of `pairs` through the lane form of `b`: one 8-wide call when the CPU has AVX2 and
/// FMA, else pair by pair at width 1 (the same numbers). `f` of a density-only pair is not
/// meaningful (0 or the eval); the caller does not read it.
#[inline(always)]
pub(super) fn eval_pdf_lanes<B: LaneNested>(b: &B, pairs: &Pairs) -> Evaluated {
    let mut out = Evaluated::zero();
    if pairs.len() == 0 {
        return out;
    }
    let mode = pairs.mode::<B>();
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = Avx2::detect() {
        avx.run(
            #[inline(always)]
            || {
                let v = |c: &[[f32; WIDTH]; 3]| {
                    V3::<F32x8>::new(avx.load(&c[0]), avx.load(&c[1]), avx.load(&c[2]))
                };
                let po = avx.load(&pairs.po);
                let (f, p) = kernel(b, mode, v(&pairs.a), v(&pairs.b), po);
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
    let mode = pairs.mode::<B>();
    let mut out = Evaluated::zero();
    for i in 0..pairs.len() {
        let (a, o) = (pairs.a(i).into(), pairs.b(i).into());
        let (f, p) = kernel::<f32, B>(b, mode, a, o, pairs.po[i]);
        out.set(i, f.into(), p);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::microfacet::{MicrofacetDistribution, MicrofacetType};
    use crate::math::warp;
    use crate::sampler::Sampler;

    /// The batch (at the width this machine runs it, and at width 1) against the scalar
    /// `eval_pdf` / `pdf`, bit for bit (NaN as NaN), with every count of used lanes, random
    /// density-only pairs (all, none, mixed) and pairs on both sides of the horizon.
    fn check<B: LaneNested>(
        b: &B,
        eval_pdf: impl Fn(Vec3, Vec3) -> (Spectrum, f32),
        pdf: impl Fn(Vec3, Vec3) -> f32,
        seed: u64,
    ) {
        let same = |x: f32, y: f32| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan());
        let mut s = Sampler::from_seed(seed, 4);
        let (mut below, mut modes) = (0, [0; 3]);
        for round in 0..600 {
            let mut pairs = Pairs::new();
            let n = 1 + round % WIDTH;
            let share = [0.0, 1.0, 0.5][round % 3];
            for _ in 0..n {
                let a = warp::square_to_uniform_sphere(s.next_2d());
                let o = warp::square_to_uniform_sphere(s.next_2d());
                below += usize::from(a.z <= 0.0 || o.z <= 0.0);
                pairs.push(a, o, s.next_1d() < share);
            }
            modes[pairs.mode::<B>() as usize] += 1;
            for ev in [eval_pdf_lanes(b, &pairs), eval_pdf_width1(b, &pairs)] {
                for i in 0..n {
                    let (a, o) = (pairs.a(i), pairs.b(i));
                    if pairs.pdf_only(i) {
                        assert!(same(ev.p(i), pdf(a, o)), "{a} {o}");
                    } else {
                        let (f, p) = eval_pdf(a, o);
                        for c in 0..3 {
                            assert!(same(ev.f(i)[c], f[c]), "{a} {o}");
                        }
                        assert!(same(ev.p(i), p), "{a} {o}");
                    }
                }
            }
        }
        assert!(below > 1000, "{below}");
        assert!(modes[0] > 0 && (!B::SEPARATE_PDF || modes[1] > 0 && modes[2] > 0));
    }

    #[test]
    fn batches_equal_the_scalar_bsdfs_bit_for_bit() {
        let d = Diffuse {
            reflectance: Vec3::new(0.8, 0.35, 0.05),
        };
        check(
            &d,
            |a, o| (d.eval(a, o), d.pdf(a, o)),
            |a, o| d.pdf(a, o),
            1,
        );
        for (kind, alpha, visible) in [
            (MicrofacetType::Ggx, 0.2, true),
            (MicrofacetType::Ggx, 0.3, false),
            (MicrofacetType::Beckmann, 0.1, true),
        ] {
            let c = RoughConductor {
                distribution: MicrofacetDistribution::new(kind, alpha, visible),
                eta: Vec3::new(0.2, 0.4, 1.4),
                k: Vec3::new(3.6, 2.4, 1.8),
                specular_reflectance: Vec3::new(1.0, 0.9, 0.8),
            };
            check(&c, |a, o| c.eval_pdf(a, o), |a, o| c.pdf(a, o), 2);
            let p = RoughPlastic::new(
                kind,
                alpha,
                visible,
                Vec3::new(0.5, 0.2, 0.1),
                Vec3::ONE,
                1.5,
                1.0,
                false,
            );
            check(&p, |a, o| p.eval_pdf(a, o), |a, o| p.pdf(a, o), 3);
        }
    }
}
