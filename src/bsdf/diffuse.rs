//! `diffuse`: the Lambertian reflector, f = ρ/π (Mitsuba's `diffuse`, one-sided: light arriving
//! from below the shading frame is not reflected).
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `reflectance` | spectrum or texture | 0.5 | albedo ρ |

use super::{BsdfSample, Lobes};
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
