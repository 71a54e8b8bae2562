//! The BSDF at one shading point, queried in world space: the one place that converts directions
//! between the world and the shading frame and applies the geometric side test.
//!
//! A direction whose side with respect to the true geometric normal disagrees with its side in
//! the shading frame carries no light (Veach 1997, §5.3, "strict normals"): this keeps smooth
//! shading normals from leaking light through a surface. The test applies to the incident
//! direction when the point is built ([`SurfaceBsdf::new`]) and to every outgoing direction
//! evaluated or sampled.

use super::{Bsdf, BsdfContext, Lobes};
use crate::math::Frame;
use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use glam::Vec3;

/// A BSDF built at a surface point, with the point's shading frame, true normal and incident
/// direction.
#[derive(Clone, Copy)]
pub struct SurfaceBsdf<'a> {
    bsdf: Bsdf<'a>,
    frame: Frame,
    ng: Vec3,
    /// The incident direction in the shading frame.
    wi: Vec3,
}

/// A sampled outgoing direction in world space (see [`super::BsdfSample`] for the fields).
#[derive(Clone, Copy, Debug)]
pub struct SurfaceSample {
    /// Sampled direction, world space.
    pub wo: Vec3,
    pub pdf: f32,
    pub weight: Spectrum,
    pub eta: f32,
    pub lobe: Lobes,
}

impl<'a> SurfaceBsdf<'a> {
    /// `bsdf` at a point with shading frame `frame` and true normal `ng`, seen from the world
    /// direction `wi`; `None` when `wi`'s sides disagree (no light scatters toward it).
    #[inline]
    pub fn new(bsdf: Bsdf<'a>, frame: Frame, ng: Vec3, wi_world: Vec3) -> Option<Self> {
        let wi = frame.to_local(wi_world);
        if wi_world.dot(ng) * wi.z <= 0.0 {
            return None;
        }
        Some(SurfaceBsdf {
            bsdf,
            frame,
            ng,
            wi,
        })
    }

    /// The lobes the BSDF can produce.
    #[inline]
    pub fn lobes(&self) -> Lobes {
        self.bsdf.lobes()
    }

    /// The local BSDF and the incident direction in its frame (for tests and tools).
    pub fn local(&self) -> (Bsdf<'a>, Vec3) {
        (self.bsdf, self.wi)
    }

    /// A world direction agrees in its side of the surface with its shading-frame value.
    #[inline]
    fn consistent(&self, w_world: Vec3, w_local: Vec3) -> bool {
        w_world.dot(self.ng) * w_local.z > 0.0
    }

    /// `f · |cos θo|` and the sampling density toward the world direction `wo`; `None` when
    /// `wo`'s sides disagree. `sampler` feeds stochastic BSDFs only.
    #[inline]
    pub fn eval_pdf(
        &self,
        ctx: &BsdfContext,
        wo_world: Vec3,
        sampler: &mut Sampler,
    ) -> Option<(Spectrum, f32)> {
        let wo = self.local_wo(wo_world)?;
        Some(self.bsdf.eval_pdf(ctx, self.wi, wo, sampler))
    }

    /// The world direction `wo` in the shading frame; `None` when its sides disagree (what
    /// [`Self::eval_pdf`] evaluates the local BSDF at: for kernels that evaluate it themselves).
    #[inline]
    pub fn local_wo(&self, wo_world: Vec3) -> Option<Vec3> {
        let wo = self.frame.to_local(wo_world);
        self.consistent(wo_world, wo).then_some(wo)
    }

    /// Importance-sample an outgoing world direction; `None` when the BSDF samples nothing or
    /// the sample's sides disagree.
    #[inline]
    pub fn sample(&self, ctx: &BsdfContext, sampler: &mut Sampler) -> Option<SurfaceSample> {
        let bs = self.bsdf.sample(ctx, self.wi, sampler)?;
        self.world_sample(bs)
    }

    /// A sample of the local BSDF (at this point's ωi) in world space; `None` when its sides
    /// disagree ([`Self::sample`]'s end: for kernels that sample the local BSDF themselves).
    #[inline]
    pub(crate) fn world_sample(&self, bs: super::BsdfSample) -> Option<SurfaceSample> {
        let wo = self.frame.to_world(bs.wo);
        if !self.consistent(wo, bs.wo) {
            return None;
        }
        Some(SurfaceSample {
            wo,
            pdf: bs.pdf,
            weight: bs.weight,
            eta: bs.eta,
            lobe: bs.lobe,
        })
    }
}
