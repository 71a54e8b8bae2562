//! `thindielectric`: a thin slab of dielectric (a window pane) seen as a single surface. Light is
//! either reflected or passes straight through (no offset, no bending); the interreflections
//! inside the slab are summed in closed form: with R the single-interface Fresnel reflectance,
//! R_total = R + T²R/(1 − R²) = 2R/(1 + R) and T_total = 1 − R_total. Both sides behave the same.
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `int_ior` | float or string | 1.5046 (`bk7`) | interior index of refraction, a number or a name ([`super::named_ior`]) |
//! | `ext_ior` | float or string | 1.000277 (`air`) | exterior index of refraction |
//! | `specular_reflectance` | spectrum or texture | 1 | multiplier of the reflection |
//! | `specular_transmittance` | spectrum or texture | 1 | multiplier of the transmission |

use super::fresnel::{fresnel_dielectric, reflect_z};
use super::{BsdfSample, Lobes};
use crate::spectrum::Spectrum;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinDielectric {
    /// Relative index `int_ior / ext_ior` (default bk7 / air).
    pub eta: f32,
    pub specular_reflectance: Spectrum,
    pub specular_transmittance: Spectrum,
}

impl ThinDielectric {
    /// From Mitsuba's parameters `int_ior`, `ext_ior`, `specular_reflectance`, `specular_transmittance`.
    pub fn new(
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Spectrum,
        specular_transmittance: Spectrum,
    ) -> Self {
        ThinDielectric {
            eta: int_ior / ext_ior,
            specular_reflectance,
            specular_transmittance,
        }
    }

    /// Total reflectance of the slab at incidence cosine `cos_theta`.
    #[inline]
    pub fn reflectance(&self, cos_theta: f32) -> f32 {
        let r = fresnel_dielectric(cos_theta.abs(), self.eta).r;
        if r < 1.0 {
            2.0 * r / (1.0 + r)
        } else {
            r
        }
    }

    #[inline]
    pub fn eval(&self, _wi: Vec3, _wo: Vec3) -> Spectrum {
        Spectrum::ZERO
    }

    #[inline]
    pub fn pdf(&self, _wi: Vec3, _wo: Vec3) -> f32 {
        0.0
    }

    pub fn sample(&self, wi: Vec3, u: f32) -> Option<BsdfSample> {
        let r = self.reflectance(wi.z);
        if u <= r {
            Some(BsdfSample {
                wo: reflect_z(wi),
                pdf: 0.0,
                weight: self.specular_reflectance,
                eta: 1.0,
                lobe: Lobes::DELTA_REFLECTION,
            })
        } else {
            Some(BsdfSample {
                wo: -wi,
                pdf: 0.0,
                weight: self.specular_transmittance,
                eta: 1.0,
                lobe: Lobes::DELTA_TRANSMISSION,
            })
        }
    }
}

impl Default for ThinDielectric {
    fn default() -> Self {
        ThinDielectric::new(
            super::dielectric::DEFAULT_INT_IOR,
            super::dielectric::DEFAULT_EXT_IOR,
            Spectrum::ONE,
            Spectrum::ONE,
        )
    }
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use super::ThinDielectric;
    use crate::bsdf::dielectric::load::{interface, Interface};
    use crate::bsdf::BsdfNode;
    use crate::error::Result;
    use crate::load::bsdfs::BsdfCtx;
    use crate::material::MaterialNode;

    /// `thindielectric`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        let Interface {
            int_ior,
            ext_ior,
            r,
            tr,
            slots,
        } = interface(cx)?;
        let template = BsdfNode::ThinDielectric(ThinDielectric::new(int_ior, ext_ior, r, tr));
        Ok(MaterialNode::Leaf {
            template: Box::new(template),
            slots,
        })
    }
}
