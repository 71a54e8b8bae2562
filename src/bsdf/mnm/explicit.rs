//! Closed-form evaluation (§4 and §3 of the spec): Variant M for the sawtooth with a mirror wall
//! (the paper's model: paths i→p→o, i→p→t→o, i→t→p→o, exact pdf, reciprocal), the complete first
//! order over the mirror wall (`explicit4`: Variant M plus i→t→p→t→o, every path with exactly one
//! non-delta vertex; `shared/spec/mnm_fast.md` §2.1), and single scattering when every facet
//! carries the nested BSDF. All sample with weight = eval / pdf (decision 2), so the weight
//! equals eval/pdf pointwise.
//!
//! The complete first order, with entries e ∈ {direct: a = ωi, weight λp(ωi); via the wall:
//! a = R(ωi), weight λt(ωi)} and exits x ∈ {direct: c = ωo, factor 1; via the wall: c = R(ωo),
//! factor [ωo·ωt > 0](1 − G1(R(ωo)))}: f·z(ωo) = G1(ωo) Σ_e Σ_x w_e b_x F_p(a_e, c_x). It is
//! reciprocal term by term ((i,o) and (t,t) each symmetric, (i,t) ↔ (t,o)), and over a
//! Lambertian of albedo ρ it is exactly ρ cosθp z(ωo)/π for every ωi (the exit identity of
//! `lambert.rs`), where Variant M loses energy depending on ωi. Its sampler picks the entry by
//! w_e, samples the nested BSDF from a_e and sends the direction u out directly with probability
//! G1(u), else through the wall (R(u)); density Σ_e w_e [G1(ωo) P_p(a_e, ωo) + b_t(ωo)
//! P_p(a_e, R(ωo))] (R has unit Jacobian).

use super::facets::MAX_FACETS;
use super::map_view::MapView;
use super::walk::Terms;
use super::MicrofacetNormalMap;
use crate::bsdf::{Bsdf, BsdfContext, BsdfSample, Lobes};
use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use glam::Vec3;

/// Exact density of [`sample_mirror`] (§4.2).
pub(super) fn pdf_mirror(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
) -> f32 {
    PdfTerms::mirror(m, wi, wo).total(m, nested, ctx)
}

/// A density written as a short sum Σ_j w_j · P_{k_j}(a_j, b_j) of nested pdfs in facet frames:
/// Variant M's three paths (§4.2) or single scattering's one term per facet (§3). Listing the
/// terms before evaluating them lets a caller that also evaluates the nested BSDF at some of the
/// same (facet, a, b) — the random walk's next-event estimate at its first vertices — take both
/// from one fused nested `eval_pdf` (`PdfTerms`' [`Terms::f`]). Fixed capacity: no allocation.
#[derive(Clone, Copy, Debug)]
pub(super) struct PdfTerms {
    k: [usize; MAX_FACETS],
    a: [Vec3; MAX_FACETS],
    b: [Vec3; MAX_FACETS],
    w: [f32; MAX_FACETS],
    /// P_j once known.
    p: [Option<f32>; MAX_FACETS],
    n: usize,
    /// G1(ωo) and G1(R(ωo)) when [`Self::mirror`] computed them: the walk's next-event
    /// estimate needs the same masking values ([`Terms::g1_wo`], [`Terms::g1_rwo`]).
    g1o: Option<f32>,
    g1r: Option<f32>,
}

impl PdfTerms {
    /// No terms (density 0; [`Self::f`] is then a plain nested eval).
    pub(super) fn empty() -> Self {
        PdfTerms {
            k: [0; MAX_FACETS],
            a: [Vec3::ZERO; MAX_FACETS],
            b: [Vec3::ZERO; MAX_FACETS],
            w: [0.0; MAX_FACETS],
            p: [None; MAX_FACETS],
            n: 0,
            g1o: None,
            g1r: None,
        }
    }

    fn push(&mut self, k: usize, a: Vec3, b: Vec3, w: f32) {
        self.k[self.n] = k;
        self.a[self.n] = a;
        self.b[self.n] = b;
        self.w[self.n] = w;
        self.n += 1;
    }

    /// The terms of [`pdf_mirror`] (§4.2): i→p→o with weight λp(ωi)·G1(ωo), i→p→t→o with
    /// λp(ωi)·(1 − G1(R(ωo))), i→t→p→o with λt(ωi).
    /// (Over a map or a view of one, [`MapView`]: one code for both.)
    pub(super) fn mirror<V: MapView + ?Sized>(m: &V, wi: Vec3, wo: Vec3) -> Self {
        let mut t = Self::empty();
        t.mirror_into(m, wi, wo);
        t
    }

    /// No term, nothing known: [`Self::empty`]'s state where it is read (the count, the known
    /// densities, the G1 values; a term's entries are written before they are read).
    #[inline(always)]
    fn reset(&mut self) {
        self.p = [None; MAX_FACETS];
        self.n = 0;
        self.g1o = None;
        self.g1r = None;
    }

    /// [`Self::mirror`]'s terms written in place (the stream kernel's per-render buffer,
    /// `walk_pdf_lanes`: built there instead of returned and copied, ~160 bytes a lane).
    #[inline(always)]
    pub(super) fn mirror_into<V: MapView + ?Sized>(&mut self, m: &V, wi: Vec3, wo: Vec3) {
        let surf = m.surface();
        let wt = surf.normal(1);
        let [lp, lt, _] = surf.lambdas(wi);
        self.reset();
        if lp > 0.0 {
            let g1o = self.g1_wo_of(m, wo);
            self.push(0, wi, wo, lp * g1o);
            if wo.dot(wt) > 0.0 {
                let rwo = m.reflect_wall(wo);
                let g1r = self.g1_rwo_of(m, rwo);
                self.push(0, wi, rwo, lp * (1.0 - g1r));
            }
        }
        if wi.dot(wt) > 0.0 {
            self.push(0, m.reflect_wall(wi), wo, lt);
        }
    }

    /// [`Self::mirror`]'s terms from their values computed elsewhere (the stream kernel's
    /// lanes, `walk_density_lanes`): `l` = λ(ωi) (λp, λt), `g1o` = G1(ωo), `wall_o` = (R(ωo),
    /// G1(R(ωo))) where ωo faces the wall (ωo·ωt > 0), `rwi` = R(ωi) where ωi does. The same
    /// terms in the same order as `mirror` from the same values, G1(ωo) and G1(R(ωo)) kept
    /// where `mirror` keeps them.
    #[inline(always)]
    pub(super) fn mirror_of(
        wi: Vec3,
        wo: Vec3,
        l: [f32; MAX_FACETS],
        g1o: f32,
        wall_o: Option<(Vec3, f32)>,
        rwi: Option<Vec3>,
    ) -> Self {
        let [lp, lt, _] = l;
        let mut t = Self::empty();
        if lp > 0.0 {
            t.g1o = Some(g1o);
            t.push(0, wi, wo, lp * g1o);
            if let Some((rwo, g1r)) = wall_o {
                t.g1r = Some(g1r);
                t.push(0, wi, rwo, lp * (1.0 - g1r));
            }
        }
        if let Some(rwi) = rwi {
            t.push(0, rwi, wo, lt);
        }
        t
    }

    /// The terms of [`pdf_single`] (§3): λ_k(ωi) · P_k(ωi, ωo) for every facet seen from ωi.
    pub(super) fn single<V: MapView + ?Sized>(m: &V, wi: Vec3, wo: Vec3) -> Self {
        let surf = m.surface();
        Self::single_of(wi, wo, surf.lambdas(wi), surf.len())
    }

    /// [`Self::single`]'s terms written in place (as [`Self::mirror_into`]).
    #[inline(always)]
    pub(super) fn single_into<V: MapView + ?Sized>(&mut self, m: &V, wi: Vec3, wo: Vec3) {
        let surf = m.surface();
        let l = surf.lambdas(wi);
        self.reset();
        for (k, &lk) in l.iter().enumerate().take(surf.len()) {
            if lk > 0.0 {
                self.push(k, wi, wo, lk);
            }
        }
    }

    /// [`Self::single`]'s terms from λ(ωi) = `l` over the microsurface's `n` facets (the
    /// stream kernel's lanes compute λ 8-wide, `walk_density_lanes`).
    #[inline(always)]
    pub(super) fn single_of(wi: Vec3, wo: Vec3, l: [f32; MAX_FACETS], n: usize) -> Self {
        let mut t = Self::empty();
        for (k, &lk) in l.iter().enumerate().take(n) {
            if lk > 0.0 {
                t.push(k, wi, wo, lk);
            }
        }
        t
    }

    /// How many terms.
    #[inline(always)]
    pub(super) fn len(&self) -> usize {
        self.n
    }

    /// Term j's density P_j when known ([`Self::know`], or from a fused call of [`Terms::f`]).
    #[inline(always)]
    pub(super) fn known(&self, j: usize) -> Option<f32> {
        self.p[j]
    }

    /// Term j's facet and pair (k, a, b).
    #[inline(always)]
    pub(super) fn pair(&self, j: usize) -> (usize, Vec3, Vec3) {
        (self.k[j], self.a[j], self.b[j])
    }

    /// G1(ωo) of map (or view) `m` (the `wo` these terms were built for), computed once.
    #[inline(always)]
    pub(super) fn g1_wo_of<V: MapView + ?Sized>(&mut self, m: &V, wo: Vec3) -> f32 {
        *self.g1o.get_or_insert_with(|| m.surface().g1(wo))
    }

    /// G1(R(ωo)) of map (or view) `m` (`rwo` = R(ωo) of the `wo` these terms were built
    /// for), computed once.
    #[inline(always)]
    pub(super) fn g1_rwo_of<V: MapView + ?Sized>(&mut self, m: &V, rwo: Vec3) -> f32 {
        *self.g1r.get_or_insert_with(|| m.surface().g1(rwo))
    }

    /// Σ_j w_j P_j with P_j = `p(j)` for every term, in [`Self::total`]'s operations and order
    /// (the stream kernel's lanes, which know every term's density before the sum).
    #[inline(always)]
    pub(super) fn total_of(&self, p: impl Fn(usize) -> f32) -> f32 {
        let mut t = 0.0;
        for j in 0..self.n {
            t += self.w[j] * p(j);
        }
        t
    }

    /// Record P_k(a, b) = `pdf` when (k, a, b) is a term (e.g. the nested sample's own density of
    /// the direction it sampled).
    pub(super) fn know(&mut self, k: usize, a: Vec3, b: Vec3, pdf: f32) {
        for j in 0..self.n {
            if self.p[j].is_none() && self.k[j] == k && self.a[j] == a && self.b[j] == b {
                self.p[j] = Some(pdf);
                return;
            }
        }
    }

    /// Σ_j w_j P_j, evaluating the P_j not yet known.
    pub(super) fn total(&self, m: &MicrofacetNormalMap, nested: &Bsdf, ctx: &BsdfContext) -> f32 {
        let mut p = 0.0;
        for j in 0..self.n {
            let pj = match self.p[j] {
                Some(pj) => pj,
                None => m.p(nested, self.k[j], ctx, self.a[j], self.b[j]),
            };
            p += self.w[j] * pj;
        }
        p
    }
}

/// The walk's view of the terms ([`super::walk::eval`]): G1(ωo) and G1(R(ωo)) computed once
/// and kept beside the terms, and each nested eval of the walk fused with its term's density
/// where the pair is a term whose P is still unknown.
impl Terms for PdfTerms {
    /// G1(ωo) (the `wo` these terms were built for), computed once.
    #[inline]
    fn g1_wo(&mut self, m: &MicrofacetNormalMap, wo: Vec3) -> f32 {
        self.g1_wo_of(m, wo)
    }

    /// G1(R(ωo)) (`rwo` = R(ωo) of the `wo` these terms were built for), computed once.
    #[inline]
    fn g1_rwo(&mut self, m: &MicrofacetNormalMap, rwo: Vec3) -> f32 {
        self.g1_rwo_of(m, rwo)
    }

    /// F_k(a, b) (nested eval in facet k's frame); when (k, a, b) is a term whose P is still
    /// unknown, P comes from the same fused nested `eval_pdf` call.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    fn f(
        &mut self,
        m: &MicrofacetNormalMap,
        nested: &Bsdf,
        k: usize,
        ctx: &BsdfContext,
        a: Vec3,
        b: Vec3,
        s: &mut Sampler,
    ) -> Spectrum {
        for j in 0..self.n {
            if self.p[j].is_none() && self.k[j] == k && self.a[j] == a && self.b[j] == b {
                let (f, p) = m.fp(nested, k, ctx, a, b, s);
                self.p[j] = Some(p);
                return f;
            }
        }
        m.f(nested, k, ctx, a, b, s)
    }
}

/// Variant M eval (§4.1; facet 0 is ωp, facet 1 the mirror wall ωt) together with its density
/// [`pdf_mirror`] (§4.2): the three paths i→p→o, i→p→t→o, i→t→p→o share λ(ωi), G1(ωo),
/// G1(R(ωo)), and each path's nested eval and pdf come from one fused `eval_pdf` of the same
/// frame pair. The pdf equals [`pdf_mirror`] up to rounding; eval alone is this function's `.0`.
pub(super) fn eval_pdf_mirror(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> (Spectrum, f32) {
    let surf = &m.surface;
    let wt = surf.normal(1);
    let g1o = surf.g1(wo);
    if g1o <= 0.0 {
        return (Spectrum::ZERO, pdf_mirror(m, nested, ctx, wi, wo));
    }
    let [lp, lt, _] = surf.lambdas(wi);
    let mut v = Spectrum::ZERO;
    let mut p = 0.0;
    if lp > 0.0 {
        let (f, pd) = m.fp(nested, 0, ctx, wi, wo, s);
        v += lp * f;
        p += lp * pd * g1o;
        if wo.dot(wt) > 0.0 {
            // i → p → t → o.
            let rwo = m.reflect_wall(wo);
            let blocked = 1.0 - surf.g1(rwo);
            let (f, pd) = m.fp(nested, 0, ctx, wi, rwo, s);
            v += (lp * blocked) * f;
            p += lp * blocked * pd;
        }
    }
    if wi.dot(wt) > 0.0 {
        // i → t → p → o.
        let (f, pd) = m.fp(nested, 0, ctx, m.reflect_wall(wi), wo, s);
        v += lt * f;
        p += lt * pd;
    }
    (v * g1o, p)
}

/// Exact density of [`sample_complete`] (module doc).
pub(super) fn pdf_complete(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
) -> f32 {
    let surf = &m.surface;
    let wt = surf.normal(1);
    let [lp, lt, _] = surf.lambdas(wi);
    let g1o = surf.g1(wo);
    let exit_t = (wo.dot(wt) > 0.0).then(|| {
        let rwo = m.reflect_wall(wo);
        (rwo, 1.0 - surf.g1(rwo))
    });
    let mut p = 0.0;
    let mut entry = |a: Vec3, w: f32| {
        p += w * g1o * m.p(nested, 0, ctx, a, wo);
        if let Some((rwo, bt)) = exit_t {
            if bt > 0.0 {
                p += w * bt * m.p(nested, 0, ctx, a, rwo);
            }
        }
    };
    if lp > 0.0 {
        entry(wi, lp);
    }
    if lt > 0.0 && wi.dot(wt) > 0.0 {
        entry(m.reflect_wall(wi), lt);
    }
    p
}

/// The complete first order's eval (module doc) with its density [`pdf_complete`]: each of
/// the (up to) four paths takes its nested eval and pdf from one fused `eval_pdf`.
pub(super) fn eval_pdf_complete(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> (Spectrum, f32) {
    let surf = &m.surface;
    let wt = surf.normal(1);
    let g1o = surf.g1(wo);
    if g1o <= 0.0 {
        return (Spectrum::ZERO, pdf_complete(m, nested, ctx, wi, wo));
    }
    let [lp, lt, _] = surf.lambdas(wi);
    let exit_t = (wo.dot(wt) > 0.0).then(|| {
        let rwo = m.reflect_wall(wo);
        (rwo, 1.0 - surf.g1(rwo))
    });
    let mut v = Spectrum::ZERO;
    let mut p = 0.0;
    let mut entry = |a: Vec3, w: f32, s: &mut Sampler| {
        let (f, pd) = m.fp(nested, 0, ctx, a, wo, s);
        v += w * f;
        p += w * g1o * pd;
        if let Some((rwo, bt)) = exit_t {
            if bt > 0.0 {
                let (f, pd) = m.fp(nested, 0, ctx, a, rwo, s);
                v += (w * bt) * f;
                p += w * bt * pd;
            }
        }
    };
    if lp > 0.0 {
        entry(wi, lp, s);
    }
    if lt > 0.0 && wi.dot(wt) > 0.0 {
        entry(m.reflect_wall(wi), lt, s);
    }
    (v * g1o, p)
}

/// The complete first order's sampler (module doc), independent random numbers per decision.
pub(super) fn sample_complete(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<BsdfSample> {
    let wo = draw_complete(m, nested, ctx, wi, s)?;
    finish(m, nested, ctx, wi, wo, s, Form::Complete)
}

/// The direction [`sample_complete`] draws (density [`pdf_complete`]); `None` for a failed
/// sample (nested sample failed, or below the macro surface).
pub(super) fn draw_complete(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<Vec3> {
    let surf = &m.surface;
    let a = if s.next_1d() < surf.lambda(0, wi) {
        wi
    } else {
        m.reflect_wall(wi)
    };
    let u = m.sample_facet(nested, 0, ctx, a, s)?.wo;
    let wo = if s.next_1d() < surf.g1(u) {
        u
    } else {
        m.reflect_wall(u) // blocked: the ray hits the mirror wall
    };
    (wo.z > 0.0).then_some(wo)
}

/// Variant M sampling (§4.3) with independent random numbers for each decision.
pub(super) fn sample_mirror(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<BsdfSample> {
    let surf = &m.surface;
    let wo = if s.next_1d() < surf.lambda(0, wi) {
        let w = m.sample_facet(nested, 0, ctx, wi, s)?.wo;
        if s.next_1d() >= surf.g1(w) {
            m.reflect_wall(w) // blocked: the ray hits the mirror wall
        } else {
            w
        }
    } else {
        m.sample_facet(nested, 0, ctx, m.reflect_wall(wi), s)?.wo
    };
    if wo.z <= 0.0 {
        return None;
    }
    finish(m, nested, ctx, wi, wo, s, Form::Mirror)
}

/// Density of [`sample_single`]: Σ_k λ_k(ωi) P_k(ωi, ωo) for ωo above the macro surface (the
/// escape probability G1 is a weight, not a decision, so no sample is thrown away).
pub(super) fn pdf_single(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
) -> f32 {
    PdfTerms::single(m, wi, wo).total(m, nested, ctx)
}

/// Single scattering on every facet (§3), Σ_k λ_k(ωi) F_k(ωi, ωo) χ(ωo·m_k) G1(ωo), together
/// with its density [`pdf_single`]: λ(ωi) once, and one fused nested `eval_pdf` per facet that
/// contributes to both. The pdf equals [`pdf_single`] up to rounding; eval alone is `.0`.
pub(super) fn eval_pdf_single(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
) -> (Spectrum, f32) {
    let surf = &m.surface;
    let g1o = surf.g1(wo);
    if g1o <= 0.0 {
        return (Spectrum::ZERO, pdf_single(m, nested, ctx, wi, wo));
    }
    let l = surf.lambdas(wi);
    let mut v = Spectrum::ZERO;
    let mut p = 0.0;
    for (k, &lk) in l.iter().enumerate().take(surf.len()) {
        if lk <= 0.0 {
            continue;
        }
        if wo.dot(surf.normal(k)) > 0.0 {
            let (f, pd) = m.fp(nested, k, ctx, wi, wo, s);
            v += lk * f;
            p += lk * pd;
        } else {
            p += lk * m.p(nested, k, ctx, wi, wo);
        }
    }
    (v * g1o, p)
}

pub(super) fn sample_single(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<BsdfSample> {
    let wo = draw_single(m, nested, ctx, wi, s)?;
    finish(m, nested, ctx, wi, wo, s, Form::Single)
}

/// The direction [`sample_single`] draws (density [`pdf_single`]); `None` for a failed sample.
pub(super) fn draw_single(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    s: &mut Sampler,
) -> Option<Vec3> {
    let (k, _) = m.surface.pick(wi, s.next_1d())?;
    let wo = m.sample_facet(nested, k, ctx, wi, s)?.wo;
    (wo.z > 0.0).then_some(wo)
}

/// Which closed form a sample finishes with.
#[derive(Clone, Copy)]
enum Form {
    Single,
    Mirror,
    Complete,
}

/// weight = eval / pdf at the sampled direction (decision 2).
fn finish(
    m: &MicrofacetNormalMap,
    nested: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
    form: Form,
) -> Option<BsdfSample> {
    let (f, pdf) = match form {
        Form::Mirror => eval_pdf_mirror(m, nested, ctx, wi, wo, s),
        Form::Complete => eval_pdf_complete(m, nested, ctx, wi, wo, s),
        Form::Single => eval_pdf_single(m, nested, ctx, wi, wo, s),
    };
    if !(pdf.is_finite() && pdf > 0.0) {
        return None;
    }
    Some(BsdfSample {
        wo,
        pdf,
        weight: f / pdf,
        eta: 1.0,
        lobe: lobe_of(nested.lobes()),
    })
}

/// The macro BSDF reports the nested BSDF's non-delta reflection lobes (`nested`: the nested
/// BSDF's [`Bsdf::lobes`]).
pub(super) fn lobe_of(nested: Lobes) -> Lobes {
    let f = nested & (Lobes::DIFFUSE_REFLECTION | Lobes::GLOSSY_REFLECTION);
    if f.intersects(Lobes::GLOSSY_REFLECTION) {
        Lobes::GLOSSY_REFLECTION
    } else {
        Lobes::DIFFUSE_REFLECTION
    }
}
