//! `diffuse`: the Lambertian reflector, f = ρ/π (Mitsuba's `diffuse`, one-sided: light arriving
//! from below the shading frame is not reflected).
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `reflectance` | spectrum or texture | 0.5 | albedo ρ |
//!
//! Lane form (`src/bsdf/lanes.rs`): [`Diffuse::eval_pdf_lanes`], [`Diffuse::sample_lanes`], equal
//! to [`Diffuse::eval`] / [`Diffuse::pdf`] / [`Diffuse::sample`] bit for bit at every width.

use super::lanes::LaneBsdfSample;
use super::{BsdfSample, Lobes};
use crate::lane::vec::{V2, V3};
use crate::lane::{warp as lw, Lane};
use crate::math::warp;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

#[derive(Clone, Copy, Debug)]
pub struct Diffuse {
    pub reflectance: Spectrum,
}

impl Diffuse {
    #[inline]
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Spectrum {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Spectrum::ZERO;
        }
        self.reflectance * (crate::math::INV_PI * wo.z)
    }

    #[inline]
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        warp::cosine_hemisphere_pdf(wo)
    }

    #[inline]
    pub fn sample(&self, wi: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        let wo = warp::square_to_cosine_hemisphere(u);
        let pdf = warp::cosine_hemisphere_pdf(wo);
        if pdf <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wo,
            pdf,
            weight: self.reflectance,
            eta: 1.0,
            lobe: Lobes::DIFFUSE_REFLECTION,
        })
    }

    /// `(eval, pdf)` per lane: the operations of [`Diffuse::eval`] and [`Diffuse::pdf`] in the
    /// same order (a pair with either z ≤ 0 gives 0 and 0; a NaN z is evaluated, as there).
    #[inline(always)]
    pub fn eval_pdf_lanes<L: Lane>(&self, wi: V3<L>, wo: V3<L>) -> (V3<L>, L) {
        Self::eval_pdf_with(self.splat(wi.z), wi, wo)
    }

    /// [`Diffuse::eval_pdf_lanes`] with the reflectance per lane (`rho`: a textured
    /// reflectance gathered lane by lane, as `Materials::build_at` evaluates it).
    #[inline(always)]
    pub(crate) fn eval_pdf_with<L: Lane>(rho: V3<L>, wi: V3<L>, wo: V3<L>) -> (V3<L>, L) {
        let zero = wi.z.splat(0.0);
        let ok = !(wi.z.le(zero) | wo.z.le(zero));
        let c = wo.z.splat(crate::math::INV_PI) * wo.z;
        let f = V3::new(rho.x * c, rho.y * c, rho.z * c);
        (
            V3::select(ok, f, V3::new(zero, zero, zero)),
            L::select(ok, lw::cosine_hemisphere_pdf(wo), zero),
        )
    }

    /// [`Diffuse::sample`] per lane (`u1` unused: one lobe).
    #[allow(dead_code)] // the lane convention's sampler; the kernels call `sample_with`
    #[inline(always)]
    pub(crate) fn sample_lanes<L: Lane>(&self, wi: V3<L>, _u1: L, u: V2<L>) -> LaneBsdfSample<L> {
        Self::sample_with(self.splat(wi.z), wi, u)
    }

    /// [`Diffuse::sample_lanes`] with the reflectance per lane (see [`Self::eval_pdf_with`]).
    #[inline(always)]
    pub(crate) fn sample_with<L: Lane>(rho: V3<L>, wi: V3<L>, u: V2<L>) -> LaneBsdfSample<L> {
        let zero = wi.z.splat(0.0);
        let wo = lw::square_to_cosine_hemisphere(u);
        let pdf = lw::cosine_hemisphere_pdf(wo);
        LaneBsdfSample {
            ok: !(wi.z.le(zero) | pdf.le(zero)),
            wo,
            pdf,
            weight: rho,
        }
    }

    /// The reflectance in every lane (`like` gives the lane type).
    #[inline(always)]
    fn splat<L: Lane>(&self, like: L) -> V3<L> {
        let r = self.reflectance;
        V3::new(like.splat(r.x), like.splat(r.y), like.splat(r.z))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Sampler;

    /// The lane form at width 1 is the scalar BSDF bit for bit (the width-8 form equals width 1
    /// by the lane rule; the batch test in `mnm::nested_batch` runs it at width 8).
    #[test]
    fn lane_form_is_the_scalar_bsdf_bit_for_bit() {
        let d = Diffuse {
            reflectance: Vec3::new(0.9, 0.5, 0.125),
        };
        let bits = |v: Vec3| v.to_array().map(f32::to_bits);
        let mut s = Sampler::from_seed(3, 7);
        for _ in 0..2000 {
            let wi = warp::square_to_uniform_sphere(s.next_2d());
            let wo = warp::square_to_uniform_sphere(s.next_2d());
            let (f, p) = d.eval_pdf_lanes::<f32>(wi.into(), wo.into());
            assert_eq!(bits(f.into()), bits(d.eval(wi, wo)));
            assert_eq!(p.to_bits(), d.pdf(wi, wo).to_bits());
            let u = s.next_2d();
            let ls = d.sample_lanes::<f32>(wi.into(), 0.0, u.into());
            match d.sample(wi, u) {
                Some(bs) => {
                    assert!(ls.ok);
                    assert_eq!(bits(ls.wo.into()), bits(bs.wo));
                    assert_eq!(ls.pdf.to_bits(), bs.pdf.to_bits());
                    assert_eq!(bits(ls.weight.into()), bits(bs.weight));
                }
                None => assert!(!ls.ok),
            }
        }
    }
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use crate::error::Result;
    use crate::load::bsdfs::BsdfCtx;
    use crate::material::MaterialNode;
    use crate::spectrum::Spectrum;

    /// `diffuse`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        let r = cx.color("reflectance", Spectrum::splat(0.5))?;
        Ok(MaterialNode::Diffuse { reflectance: r })
    }
}
