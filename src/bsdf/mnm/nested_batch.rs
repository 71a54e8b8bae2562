//! The compensated first order's nested evaluations in one call (issue 17: "write it on the lane
//! kernels"). One query of the first order evaluates the nested BSDF at up to four (a, b) pairs
//! over the mirror sawtooth (paths \[p\], \[p,t\], \[t,p\], \[t,p,t\]) or three (single scattering on
//! the other microsurfaces); they are collected into a [`Pairs`] and evaluated together:
//! - nested kinds with a lane form (`src/bsdf/lanes.rs`: [`LaneNested`]) in one call at width 8
//!   under the [`Avx2`] token, or pair by pair at width 1 (the same source: the bit-identity rule
//!   of [`crate::lane`] makes the results equal on every machine);
//! - other kinds pair by pair through their scalar `eval_pdf` / `pdf` (the fallback is the
//!   nested BSDF's own code, never something else).
//!
//! The stream kernel batches the queries of 8 shading points at once (`Pairs<CHUNK>`, up to four
//! 8-wide calls: `compensated::lanes`). Unused lanes hold a valid pair (a = b = +z) whose
//! results are never read.

use crate::bsdf::diffuse::Diffuse;
use crate::bsdf::plastic::{base_albedo, splat3};
use crate::bsdf::roughconductor::RoughConductor;
use crate::bsdf::roughplastic::RoughPlastic;
use crate::lane::fresnel::ConductorTerms;
use crate::lane::microfacet::Microfacet;
use crate::lane::vec::V3;
#[cfg(target_arch = "x86_64")]
use crate::lane::{Avx2, F32x8};
use crate::lane::{Lane, LaneMask};
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
    /// What [`Self::eval_pdf_dirs`] shares between the evaluations of one query (the BSDF's
    /// parameters in lanes and the terms that depend on them alone; `()` where none).
    type Shared<L: Lane>: Copy;
    /// What it shares between the evaluations from or toward one direction (`()` where none).
    type Dir<L: Lane>: Copy;
    fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> (V3<L>, L);
    #[inline(always)]
    fn pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> L {
        self.eval_pdf_lanes(wi, wo).1
    }
    /// The terms of one query (the width of `like`).
    fn shared<L: Lane>(&self, like: L) -> Self::Shared<L>;
    /// The terms of direction `v`.
    fn dir<L: Lane>(&self, s: &Self::Shared<L>, v: V3<L>) -> Self::Dir<L>;
    /// `eval_pdf_lanes(wi, wo)` bit for bit, from the query's terms `s` and the directions'
    /// `di` = `dir(s, wi)`, `dout` = `dir(s, wo)` (computed once for several evaluations).
    fn eval_pdf_dirs<L: Lane>(
        &self,
        s: &Self::Shared<L>,
        wi: V3<L>,
        di: &Self::Dir<L>,
        wo: V3<L>,
        dout: &Self::Dir<L>,
    ) -> (V3<L>, L);
}

/// Nothing shared: `eval_pdf_dirs` is `eval_pdf_lanes`.
macro_rules! nothing_shared {
    () => {
        type Shared<L: Lane> = ();
        type Dir<L: Lane> = ();
        #[inline(always)]
        fn shared<L: Lane>(&self, _like: L) {}
        #[inline(always)]
        fn dir<L: Lane>(&self, _s: &(), _v: V3<L>) {}
        #[inline(always)]
        fn eval_pdf_dirs<L: Lane>(
            &self,
            _s: &(),
            wi: V3<L>,
            _di: &(),
            wo: V3<L>,
            _dout: &(),
        ) -> (V3<L>, L) {
            self.eval_pdf_lanes(wi, wo)
        }
    };
}

/// A `roughconductor`'s terms of one query: its parameters in lanes and its index's Fresnel
/// terms (`RoughConductor::eval_pdf_with`'s, computed once).
#[derive(Clone, Copy)]
pub(super) struct ConductorShared<L> {
    spec: V3<L>,
    dist: Microfacet<L>,
    fresnel: ConductorTerms<L>,
}

/// `pdf` is `eval`'s cosine density (both `diffuse.rs`).
impl LaneNested for Diffuse {
    const SEPARATE_PDF: bool = false;
    nothing_shared!();
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
    /// The parameters in lanes (`params_lanes`) and the Fresnel terms of (η, k).
    type Shared<L: Lane> = ConductorShared<L>;
    /// G1 toward the direction's own normal (`Microfacet::smith_g1_of`): the part of G1(v, h)
    /// that does not depend on h.
    type Dir<L: Lane> = L;
    #[inline(always)]
    fn shared<L: Lane>(&self, like: L) -> ConductorShared<L> {
        let (spec, dist) = self.params_lanes(like);
        ConductorShared {
            spec,
            dist,
            fresnel: self.index().lanes(like),
        }
    }
    #[inline(always)]
    fn dir<L: Lane>(&self, s: &ConductorShared<L>, v: V3<L>) -> L {
        s.dist.smith_g1_of(v)
    }
    /// `RoughConductor::eval_pdf_with`'s operations in its order (over `params_lanes`), with
    /// the Fresnel term from the index's terms ([`ConductorTerms::eval`], `fresnel_lanes`'
    /// `conductor` bit for bit) and G1(ωi, h), G1(ωo, h) from the directions' own parts
    /// (`Microfacet::smith_g1_from`, `smith_g1` bit for bit).
    #[inline(always)]
    fn eval_pdf_dirs<L: Lane>(
        &self,
        s: &ConductorShared<L>,
        wi: V3<L>,
        gi: &L,
        wo: V3<L>,
        go: &L,
    ) -> (V3<L>, L) {
        let k = |c: f32| wi.z.splat(c);
        let zero = V3::splat(k(0.0), 0.0, 0.0, 0.0);
        let below = wi.z.le(k(0.0)) | wo.z.le(k(0.0));
        if below.all() {
            return (zero, k(0.0));
        }
        let dist = &s.dist;
        let h = (wi + wo).normalize();
        let d = dist.eval(h);
        let bad = below | d.eq(k(0.0));
        if bad.all() {
            return (zero, k(0.0));
        }
        let g1i = Microfacet::smith_g1_from(*gi, wi, h);
        let f = (s.spec * s.fresnel.eval(wi.dot(h)))
            .scale(d * g1i * Microfacet::smith_g1_from(*go, wo, h) / (k(4.0) * wi.z));
        let pdf = dist.reflection_pdf(wi, wo, h, d, g1i);
        (V3::select(bad, zero, f), L::select(bad, k(0.0), pdf))
    }
}

/// A `roughplastic`'s terms of one query: its reflectances and distribution in lanes, and the
/// base's albedo through the coating (`RoughPlastic::eval_pdf_with`'s, computed once).
#[derive(Clone, Copy)]
pub(super) struct PlasticShared<L> {
    spec: V3<L>,
    dist: Microfacet<L>,
    albedo: V3<L>,
}

/// A `roughplastic`'s terms of one direction v: G1 toward its own normal
/// (`Microfacet::smith_g1_of`) and the coating's transmittance T(θ) at z(v).
#[derive(Clone, Copy)]
pub(super) struct PlasticDir<L> {
    g1: L,
    t: L,
}

/// `pdf` is `eval_pdf`'s density (`roughplastic.rs`).
impl LaneNested for RoughPlastic {
    const SEPARATE_PDF: bool = false;
    #[inline(always)]
    fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> (V3<L>, L) {
        RoughPlastic::eval_pdf_lanes(self, wi, wo)
    }
    type Shared<L: Lane> = PlasticShared<L>;
    type Dir<L: Lane> = PlasticDir<L>;
    #[inline(always)]
    fn shared<L: Lane>(&self, like: L) -> PlasticShared<L> {
        let rho = splat3(like, self.diffuse_reflectance);
        PlasticShared {
            spec: splat3(like, self.specular_reflectance),
            dist: self.distribution_lanes(like),
            albedo: base_albedo(
                rho,
                like.splat(self.table.internal_reflectance),
                self.nonlinear,
            ),
        }
    }
    #[inline(always)]
    fn dir<L: Lane>(&self, s: &PlasticShared<L>, v: V3<L>) -> PlasticDir<L> {
        PlasticDir {
            g1: s.dist.smith_g1_of(v),
            t: self.table.transmittance_lanes(v.z),
        }
    }
    /// `RoughPlastic::eval_pdf_with`'s operations in its order (over `eval_pdf_lanes`'
    /// reflectances), with G1(ωi, h), G1(ωo, h) from the directions' own parts
    /// (`Microfacet::smith_g1_from`, `smith_g1` bit for bit) and T(θi), T(θo) from the
    /// directions' terms (the same `transmittance_lanes`): each direction's terms once for the
    /// query's evaluations that share it.
    #[inline(always)]
    fn eval_pdf_dirs<L: Lane>(
        &self,
        s: &PlasticShared<L>,
        wi: V3<L>,
        di: &PlasticDir<L>,
        wo: V3<L>,
        dout: &PlasticDir<L>,
    ) -> (V3<L>, L) {
        let k = |c: f32| wi.z.splat(c);
        let zero = k(0.0);
        let below = wi.z.le(zero) | wo.z.le(zero);
        if below.all() {
            return (V3::new(zero, zero, zero), zero);
        }
        let dist = &s.dist;
        let h = (wi + wo).normalize();
        let d = dist.eval(h);
        let g1i = Microfacet::smith_g1_from(di.g1, wi, h);
        let f = crate::lane::fresnel::dielectric(wi.dot(h), k(self.eta)).r;
        let g = g1i * Microfacet::smith_g1_from(dout.g1, wo, h);
        let specular = s.spec.scale(f * d * g / (k(4.0) * wi.z));
        let t_i = di.t;
        let t = t_i * dout.t;
        let value = specular
            + s.albedo
                .scale(k(crate::math::INV_PI) * wo.z * t / (k(self.eta) * k(self.eta)));
        let ps = self.prob_specular(t_i);
        let p_spec = dist.reflection_pdf(wi, wo, h, d, g1i);
        let p = ps * p_spec + (k(1.0) - ps) * crate::lane::warp::cosine_hemisphere_pdf(wo);
        let p = L::select(p.is_finite(), p, zero);
        (
            V3::select(below, V3::new(zero, zero, zero), value),
            L::select(below, zero, p),
        )
    }
}

/// Up to `W` direction pairs in a facet's frame (`W` a multiple of [`WIDTH`]: one query's pairs
/// at `W` = 8, the default, or every query of a stream chunk's 8 shading points at `W` =
/// [`CHUNK`]), structure of arrays; bit j of `pdf_only` says that pair j needs only the density
/// (the scalar fallback then calls `pdf`, as the first order always did).
#[derive(Clone, Copy, Debug)]
pub(super) struct Pairs<const W: usize = WIDTH> {
    a: [[f32; W]; 3],
    b: [[f32; W]; 3],
    /// 1 in the lanes of density-only pairs (the lane kernel's mask), else 0.
    po: [f32; W],
    n: u8,
    pdf_only: u32,
}

/// Pairs of a whole stream chunk: 8 shading points with at most 4 pairs each.
pub(super) const CHUNK: usize = 4 * WIDTH;

impl<const W: usize> Pairs<W> {
    #[inline(always)]
    pub(super) fn new() -> Self {
        let z = [[0.0; W], [0.0; W], [1.0; W]];
        Pairs {
            a: z,
            b: z,
            po: [0.0; W],
            n: 0,
            pdf_only: 0,
        }
    }

    /// No pair (the count and the density-only bits reset; the entries keep the pairs they
    /// held, valid pairs whose values a caller past the count does not read).
    #[inline(always)]
    pub(super) fn clear(&mut self) {
        self.n = 0;
        self.pdf_only = 0;
    }

    /// Adds the pair (a, b); returns its index.
    #[inline(always)]
    pub(super) fn push(&mut self, a: Vec3, b: Vec3, pdf_only: bool) -> usize {
        let i = self.n as usize;
        for c in 0..3 {
            self.a[c][i] = a[c];
            self.b[c][i] = b[c];
        }
        self.pdf_only |= u32::from(pdf_only) << i;
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
pub(super) struct Evaluated<const W: usize = WIDTH> {
    f: [[f32; W]; 3],
    p: [f32; W],
}

impl<const W: usize> Evaluated<W> {
    #[inline(always)]
    pub(super) fn zero() -> Self {
        Evaluated {
            f: [[0.0; W]; 3],
            p: [0.0; W],
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

    /// Every pair's f·|cos θo|, `[component][pair]` (for 8-wide gathers by pair index).
    #[inline(always)]
    pub(super) fn f_cols(&self) -> &[[f32; W]; 3] {
        &self.f
    }

    #[inline(always)]
    pub(super) fn p(&self, i: usize) -> f32 {
        self.p[i]
    }
}

/// What one lane call computes, decided per call of 8 pairs (a pair's numbers do not depend on
/// the mode: an evaluated pair always gets `eval_pdf_lanes`, a density-only one the density of
/// `pdf`, and `f` of a density-only pair is never read).
#[derive(Clone, Copy, PartialEq)]
enum Mode {
    /// `eval_pdf_lanes` (every pair, or a BSDF whose `pdf` is that density).
    EvalPdf,
    /// `pdf_lanes` only (every pair is density-only): `f` is left 0.
    Pdf,
    /// Both, the density of density-only lanes from `pdf_lanes`.
    Mixed,
}

impl<const W: usize> Pairs<W> {
    /// The mode of the call over pairs `8c ..` (at most 8 of them).
    #[inline(always)]
    fn mode<B: LaneNested>(&self, c: usize) -> Mode {
        let n = (self.len() - WIDTH * c).min(WIDTH);
        let bits = (self.pdf_only >> (WIDTH * c)) & 0xff;
        let all = bits == ((1u32 << n) - 1);
        match (B::SEPARATE_PDF, bits) {
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

/// Every pair of `pairs` through the lane form of `b`: 8-wide calls (one per 8 pairs) when the
/// CPU has AVX2 and FMA, else pair by pair at width 1 (the same numbers). `f` of a density-only
/// pair is not meaningful (0 or the eval); the caller does not read it.
#[inline(always)]
pub(super) fn eval_pdf_lanes<B: LaneNested, const W: usize>(
    b: &B,
    pairs: &Pairs<W>,
) -> Evaluated<W> {
    let mut out = Evaluated::zero();
    eval_pdf_lanes_into(b, pairs, &mut out);
    out
}

/// [`eval_pdf_lanes`] into `out` (a caller's buffer, not copied): the entries of the pairs of
/// `pairs` written, those past them (to the end of the last call's 8 at width 8) not
/// meaningful.
#[inline(always)]
pub(super) fn eval_pdf_lanes_into<B: LaneNested, const W: usize>(
    b: &B,
    pairs: &Pairs<W>,
    out: &mut Evaluated<W>,
) {
    if pairs.len() == 0 {
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = Avx2::detect() {
        avx.run(
            #[inline(always)]
            || {
                for c in 0..pairs.len().div_ceil(WIDTH) {
                    let r = WIDTH * c..WIDTH * (c + 1);
                    let ld = |x: &[f32; W]| avx.load(x[r.clone()].try_into().unwrap());
                    let v = |x: &[[f32; W]; 3]| V3::<F32x8>::new(ld(&x[0]), ld(&x[1]), ld(&x[2]));
                    let po = ld(&pairs.po);
                    let mode = pairs.mode::<B>(c);
                    let (f, p) = kernel(b, mode, v(&pairs.a), v(&pairs.b), po);
                    let st = |v: F32x8, x: &mut [f32; W]| {
                        v.store((&mut x[r.clone()]).try_into().unwrap())
                    };
                    st(f.x, &mut out.f[0]);
                    st(f.y, &mut out.f[1]);
                    st(f.z, &mut out.f[2]);
                    st(p, &mut out.p);
                }
            },
        );
        return;
    }
    eval_pdf_width1(b, pairs, out)
}

/// [`eval_pdf_lanes_into`] at width 1 (a CPU without AVX2).
#[inline(always)]
fn eval_pdf_width1<B: LaneNested, const W: usize>(b: &B, pairs: &Pairs<W>, out: &mut Evaluated<W>) {
    for i in 0..pairs.len() {
        let mode = pairs.mode::<B>(i / WIDTH);
        let (a, o) = (pairs.a(i).into(), pairs.b(i).into());
        let (f, p) = kernel::<f32, B>(b, mode, a, o, pairs.po[i]);
        out.set(i, f.into(), p);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::microfacet::{MicrofacetDistribution, MicrofacetType};
    use crate::math::warp;
    use crate::sampler::Sampler;

    /// The batch (at the width this machine runs it, and at width 1) against the scalar
    /// `eval_pdf` / `pdf`, bit for bit (NaN as NaN), with every count of used lanes, random
    /// density-only pairs (all, none, mixed) and pairs on both sides of the horizon; one
    /// query's batch (`W` = 8) and a chunk's (`W` = 32: up to four 8-wide calls, each with its
    /// own mode).
    fn check<B: LaneNested>(
        b: &B,
        eval_pdf: impl Fn(Vec3, Vec3) -> (Spectrum, f32),
        pdf: impl Fn(Vec3, Vec3) -> f32,
        seed: u64,
    ) {
        check_width::<B, WIDTH>(b, &eval_pdf, &pdf, seed);
        check_width::<B, CHUNK>(b, &eval_pdf, &pdf, seed + 100);
    }

    fn check_width<B: LaneNested, const W: usize>(
        b: &B,
        eval_pdf: &impl Fn(Vec3, Vec3) -> (Spectrum, f32),
        pdf: &impl Fn(Vec3, Vec3) -> f32,
        seed: u64,
    ) {
        let same = |x: f32, y: f32| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan());
        let mut s = Sampler::from_seed(seed, 4);
        let (mut below, mut modes) = (0, [0; 3]);
        for round in 0..600 {
            let mut pairs = Pairs::<W>::new();
            let n = 1 + round % W;
            for c in 0..n.div_ceil(WIDTH) {
                let share = [0.0, 1.0, 0.5][(round + c) % 3];
                for _ in WIDTH * c..n.min(WIDTH * (c + 1)) {
                    let a = warp::square_to_uniform_sphere(s.next_2d());
                    let o = warp::square_to_uniform_sphere(s.next_2d());
                    below += usize::from(a.z <= 0.0 || o.z <= 0.0);
                    pairs.push(a, o, s.next_1d() < share);
                }
                modes[pairs.mode::<B>(c) as usize] += 1;
            }
            let mut width1 = Evaluated::zero();
            eval_pdf_width1(b, &pairs, &mut width1);
            for ev in [eval_pdf_lanes(b, &pairs), width1] {
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

    /// Edge values for the shared-terms test: zeros of both signs, subnormals, one, huge
    /// values, infinities and NaN.
    const EDGES: [f32; 11] = [
        0.0,
        -0.0,
        1e-40,
        -1e-40,
        1.0,
        -1.0,
        1e30,
        f32::MAX,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
    ];

    /// A direction for the shared-terms test: random (both hemispheres, near-horizon, non-unit
    /// ones: `testing::direction`), or with some components edge values.
    fn edge_direction(r: &mut crate::math::Pcg32) -> Vec3 {
        let mut v = crate::bsdf::lanes::testing::direction(r);
        for c in 0..3 {
            if r.next_f32() < 0.08 {
                v[c] = EDGES[r.next_u32() as usize % EDGES.len()];
            }
        }
        v
    }

    /// `eval_pdf_dirs` from the query's and the directions' terms equals `eval_pdf_lanes` bit
    /// for bit (NaN as NaN), 8-wide on this machine and at width 1, lane by lane: rough
    /// conductors (GGX and Beckmann, visible or all normals, a textured-like reflectance, the
    /// named metals' indices and edge indices: 0, subnormal, huge, ∞), the rough plastic and a
    /// diffuse BSDF, over random directions mixed with ±0, subnormals, huge values, ±∞ and
    /// NaN in their components.
    #[test]
    fn shared_terms_equal_the_plain_evaluation() {
        let mut r = crate::math::Pcg32::new(22, 2);
        let indices = [
            (Vec3::new(0.2, 0.4, 1.4), Vec3::new(3.6, 2.4, 1.8)),
            (Vec3::new(1.66, 0.88, 0.52), Vec3::new(9.2, 6.3, 4.8)),
            (Vec3::new(0.0, -0.0, 1e-40), Vec3::new(1.0, 0.0, 1e-20)),
            (
                Vec3::new(1e20, f32::MAX, 1.0),
                Vec3::new(1e20, 1.0, f32::INFINITY),
            ),
        ];
        let mut compared = 0;
        for (kind, alpha, visible) in [
            (MicrofacetType::Ggx, 0.2, true),
            (MicrofacetType::Ggx, 0.3, false),
            (MicrofacetType::Beckmann, 0.1, true),
            (MicrofacetType::Beckmann, 0.5, false),
        ] {
            for &(eta, k) in &indices {
                let c = RoughConductor {
                    distribution: MicrofacetDistribution::new(kind, alpha, visible),
                    eta,
                    k,
                    specular_reflectance: Vec3::new(1.0, 0.9, 0.8),
                };
                compared += check_shared(&c, &mut r);
            }
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
            compared += check_shared(&p, &mut r);
        }
        let d = Diffuse {
            reflectance: Vec3::new(0.8, 0.35, 0.05),
        };
        compared += check_shared(&d, &mut r);
        assert!(compared > 100_000, "{compared}");
    }

    /// [`shared_terms_equal_the_plain_evaluation`] for one BSDF; the number of pairs compared.
    fn check_shared<B: LaneNested>(b: &B, r: &mut crate::math::Pcg32) -> usize {
        use crate::bsdf::lanes::testing::{same, same3};
        let mut compared = 0;
        for _ in 0..400 {
            let a: [Vec3; 8] = std::array::from_fn(|_| edge_direction(r));
            let o: [Vec3; 8] = std::array::from_fn(|_| edge_direction(r));
            // Width 1: each pair alone.
            for k in 0..8 {
                let (want_f, want_p) = b.eval_pdf_lanes::<f32>(a[k].into(), o[k].into());
                let s = b.shared(1.0f32);
                let (da, dout) = (b.dir(&s, a[k].into()), b.dir(&s, o[k].into()));
                let (f, p) = b.eval_pdf_dirs(&s, a[k].into(), &da, o[k].into(), &dout);
                assert!(same3(f.into(), want_f.into()), "{} {}", a[k], o[k]);
                assert!(same(p, want_p), "{} {}", a[k], o[k]);
                compared += 1;
            }
            #[cfg(target_arch = "x86_64")]
            if let Some(avx) = Avx2::detect() {
                use crate::bsdf::lanes::testing::{lane3, load3};
                avx.run(|| {
                    let (a8, o8) = (load3(avx, &a), load3(avx, &o));
                    let (want_f, want_p) = b.eval_pdf_lanes(a8, o8);
                    let s = b.shared(avx.splat(0.0));
                    let (da, dout) = (b.dir(&s, a8), b.dir(&s, o8));
                    let (f, p) = b.eval_pdf_dirs(&s, a8, &da, o8, &dout);
                    for k in 0..8 {
                        assert!(same3(lane3(f, k), lane3(want_f, k)), "{} {}", a[k], o[k]);
                        assert!(same(p.lane(k), want_p.lane(k)), "{} {}", a[k], o[k]);
                        compared += 1;
                    }
                });
            }
        }
        compared
    }

    /// The conductor's Fresnel terms of one index ([`ConductorTerms`]) give
    /// `lane::fresnel::conductor` bit for bit, and G1 in two steps (`smith_g1_of`,
    /// `smith_g1_from`) gives `smith_g1`, at width 1 over random and edge inputs (both are
    /// lane-generic code: the 8-wide form is checked through `eval_pdf_dirs` above).
    #[test]
    fn fresnel_terms_and_g1_in_two_steps_equal_the_plain_ones() {
        use crate::bsdf::lanes::testing::{same, same3};
        let mut r = crate::math::Pcg32::new(22, 3);
        let value = |r: &mut crate::math::Pcg32, lo: f32, hi: f32| {
            if r.next_f32() < 0.15 {
                EDGES[r.next_u32() as usize % EDGES.len()]
            } else {
                lo + (hi - lo) * r.next_f32()
            }
        };
        for _ in 0..20000 {
            let eta = Vec3::new(
                value(&mut r, 0.0, 3.0),
                value(&mut r, 0.0, 3.0),
                value(&mut r, 0.0, 3.0),
            );
            let k = Vec3::new(
                value(&mut r, 0.0, 10.0),
                value(&mut r, 0.0, 10.0),
                value(&mut r, 0.0, 10.0),
            );
            let cos = value(&mut r, -1.0, 1.0);
            let want = crate::lane::fresnel::conductor::<f32>(cos, eta.into(), k.into());
            let ix = crate::lane::fresnel::ConductorIndex::new(eta.to_array(), k.to_array());
            let got = ix.lanes(cos).eval(cos);
            assert!(same3(got.into(), want.into()), "{eta} {k} {cos}");
        }
        for (kind, visible) in [
            (MicrofacetType::Ggx, true),
            (MicrofacetType::Beckmann, false),
        ] {
            for _ in 0..20000 {
                let dist = Microfacet::<f32> {
                    kind,
                    alpha_u: value(&mut r, 0.01, 1.0),
                    alpha_v: value(&mut r, 0.01, 1.0),
                    sample_visible: visible,
                };
                let (v, m) = (edge_direction(&mut r), edge_direction(&mut r));
                let want = dist.smith_g1(v.into(), m.into());
                let got = Microfacet::smith_g1_from(dist.smith_g1_of(v.into()), v.into(), m.into());
                assert!(same(got, want), "{v} {m}");
            }
        }
    }
}
