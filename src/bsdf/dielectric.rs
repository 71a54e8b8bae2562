//! `dielectric`: a smooth interface between two dielectrics (glass, water): delta reflection and
//! delta refraction, chosen in proportion to the Fresnel reflectance, so the sample weight is 1
//! (times `specular_reflectance` / `specular_transmittance`). Works from both sides; a ray from
//! inside sees the inverted relative index and can be totally internally reflected.
//!
//! Radiance crossing into a denser medium is compressed into a smaller solid angle: in
//! [`TransportMode::Radiance`] the refracted weight is scaled by (η_i/η_t)² (Veach 1997, §5.2);
//! importance is not scaled.
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
use super::{BsdfSample, Lobes, TransportMode};
use crate::spectrum::Spectrum;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// Relative index `int_ior / ext_ior` (default bk7 / air = 1.5046 / 1.000277).
    pub eta: f32,
    /// Multiplier of the reflected part (default 1; not physical, for artistic control).
    pub specular_reflectance: Spectrum,
    /// Multiplier of the transmitted part (default 1).
    pub specular_transmittance: Spectrum,
}

/// Mitsuba's default interior (bk7) and exterior (air) indices.
pub const DEFAULT_INT_IOR: f32 = 1.5046;
pub const DEFAULT_EXT_IOR: f32 = 1.000277;

impl Dielectric {
    /// From Mitsuba's parameters `int_ior`, `ext_ior`, `specular_reflectance`, `specular_transmittance`.
    pub fn new(
        int_ior: f32,
        ext_ior: f32,
        specular_reflectance: Spectrum,
        specular_transmittance: Spectrum,
    ) -> Self {
        Dielectric {
            eta: int_ior / ext_ior,
            specular_reflectance,
            specular_transmittance,
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

    pub fn sample(&self, mode: TransportMode, wi: Vec3, u: f32) -> Option<BsdfSample> {
        let f = fresnel_dielectric(wi.z, self.eta);
        if u <= f.r {
            Some(BsdfSample {
                wo: reflect_z(wi),
                pdf: 0.0,
                weight: self.specular_reflectance,
                eta: 1.0,
                lobe: Lobes::DELTA_REFLECTION,
            })
        } else {
            // Refraction about the normal: tangential part scales by η_i/η_t.
            let wo = Vec3::new(-f.eta_ti * wi.x, -f.eta_ti * wi.y, f.cos_theta_t);
            let scale = match mode {
                TransportMode::Radiance => f.eta_ti * f.eta_ti,
                TransportMode::Importance => 1.0,
            };
            Some(BsdfSample {
                wo,
                pdf: 0.0,
                weight: self.specular_transmittance * scale,
                eta: f.eta_it,
                lobe: Lobes::DELTA_TRANSMISSION,
            })
        }
    }
}

impl Default for Dielectric {
    fn default() -> Self {
        Dielectric::new(
            DEFAULT_INT_IOR,
            DEFAULT_EXT_IOR,
            Spectrum::ONE,
            Spectrum::ONE,
        )
    }
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use super::Dielectric;
    use crate::bsdf::dielectric::{DEFAULT_EXT_IOR, DEFAULT_INT_IOR};
    use crate::bsdf::ior::load::ior_param;
    use crate::bsdf::BsdfNode;
    use crate::error::Result;
    use crate::load::bsdfs::BsdfCtx;
    use crate::material::{MaterialNode, Slot, TexId};
    use crate::spectrum::Spectrum;

    /// What every dielectric interface (`dielectric`, `thindielectric`, `roughdielectric`) reads:
    /// the two indices and the two (possibly textured) colours with their texture slots.
    pub(crate) struct Interface {
        pub int_ior: f32,
        pub ext_ior: f32,
        pub r: Spectrum,
        pub tr: Spectrum,
        pub slots: Vec<(Slot, TexId)>,
    }

    pub(crate) fn interface(cx: &mut BsdfCtx<'_, '_>) -> Result<Interface> {
        let int_ior = ior_param(cx.props(), "int_ior", DEFAULT_INT_IOR)?;
        let ext_ior = ior_param(cx.props(), "ext_ior", DEFAULT_EXT_IOR)?;
        let (r, mut slots) =
            cx.leaf_color("specular_reflectance", Slot::SpecularReflectance, 1.0)?;
        let (tr, s2) = cx.leaf_color("specular_transmittance", Slot::SpecularTransmittance, 1.0)?;
        slots.extend(s2);
        Ok(Interface {
            int_ior,
            ext_ior,
            r,
            tr,
            slots,
        })
    }

    /// `dielectric`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        let Interface {
            int_ior,
            ext_ior,
            r,
            tr,
            slots,
        } = interface(cx)?;
        let template = BsdfNode::Dielectric(Dielectric::new(int_ior, ext_ior, r, tr));
        Ok(MaterialNode::Leaf {
            template: Box::new(template),
            slots,
        })
    }
}
