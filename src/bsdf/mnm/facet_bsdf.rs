//! The primitives every microfacet normal-map model is built from: the nested BSDF queried on one
//! facet of the microsurface (both directions in the macro shading frame, converted to the
//! facet's frame), and the sawtooth's mirror wall. `explicit.rs` (closed forms) and `walk.rs`
//! (random walks) use only these to reach the nested BSDF.

use super::MicrofacetNormalMap;
use crate::bsdf::{Bsdf, BsdfContext, BsdfSample};
use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use glam::Vec3;

impl MicrofacetNormalMap {
    #[inline]
    pub(super) fn is_mirror(&self, k: usize) -> bool {
        self.mirror_wall && k == 1
    }

    /// Mirror image across the wall's plane: R(ω) = ω − 2(ω·ωt)ωt.
    #[inline]
    pub(super) fn reflect_wall(&self, w: Vec3) -> Vec3 {
        reflect_across(w, self.surface.normal(1))
    }

    /// Nested eval with both directions in facet k's frame: F_k(a, b) (includes |b·m_k|).
    #[inline]
    pub(super) fn f(
        &self,
        nested: &Bsdf,
        k: usize,
        ctx: &BsdfContext,
        a: Vec3,
        b: Vec3,
        s: &mut Sampler,
    ) -> Spectrum {
        debug_assert!(!self.is_mirror(k), "the mirror wall has no frame");
        let fr = &self.frames[k];
        nested.eval(ctx, fr.to_local(a), fr.to_local(b), s)
    }

    /// Nested pdf in facet k's frame: P_k(a, b).
    #[inline]
    pub(super) fn p(&self, nested: &Bsdf, k: usize, ctx: &BsdfContext, a: Vec3, b: Vec3) -> f32 {
        debug_assert!(!self.is_mirror(k), "the mirror wall has no frame");
        let fr = &self.frames[k];
        nested.pdf(ctx, fr.to_local(a), fr.to_local(b))
    }

    /// Nested eval and pdf in facet k's frame in one fused call: (F_k(a, b), P_k(a, b)). The
    /// nested `eval_pdf` shares the half vector, D and G1 between the two (rough models).
    #[inline]
    pub(super) fn fp(
        &self,
        nested: &Bsdf,
        k: usize,
        ctx: &BsdfContext,
        a: Vec3,
        b: Vec3,
        s: &mut Sampler,
    ) -> (Spectrum, f32) {
        debug_assert!(!self.is_mirror(k), "the mirror wall has no frame");
        let fr = &self.frames[k];
        nested.eval_pdf(ctx, fr.to_local(a), fr.to_local(b), s)
    }

    /// Nested sample in facet k's frame from `a`; the sample's direction comes back in the macro
    /// frame (weight, pdf, η and lobe as the nested BSDF reports them).
    #[inline]
    pub(super) fn sample_facet(
        &self,
        nested: &Bsdf,
        k: usize,
        ctx: &BsdfContext,
        a: Vec3,
        s: &mut Sampler,
    ) -> Option<BsdfSample> {
        debug_assert!(!self.is_mirror(k), "the mirror wall has no frame");
        let fr = &self.frames[k];
        let mut bs = nested.sample(ctx, fr.to_local(a), s)?;
        bs.wo = fr.to_world(bs.wo);
        Some(bs)
    }
}

/// Mirror image of `w` across the plane of unit normal `wt`: ω − 2(ω·ωt)ωt (the wall's
/// [`MicrofacetNormalMap::reflect_wall`], and the stream kernel's points whose wall normal is
/// kept in columns, `compensated::lanes`).
#[inline(always)]
pub(super) fn reflect_across(w: Vec3, wt: Vec3) -> Vec3 {
    w - 2.0 * w.dot(wt) * wt
}
