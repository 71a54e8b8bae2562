//! `conductor`: a smooth metal, i.e. a perfect mirror weighted by the conductor Fresnel reflectance
//! of the complex index η + ik (per RGB channel) and by `specular_reflectance`. One-sided like
//! Mitsuba 3: light arriving from below the shading frame is not reflected.
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `material` | string | `none` | a named conductor's (η, k) ([`super::named_conductor`]: none, Au, Ag, Cu, Al, Cr, ...) |
//! | `eta`, `k` | spectrum | 0, 1 | the complex index η + ik, instead of `material` |
//! | `specular_reflectance` | spectrum or texture | 1 | multiplier of the reflectance |

use super::fresnel::{fresnel_conductor, reflect_z};
use super::{BsdfSample, Lobes};
use crate::spectrum::Spectrum;
use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conductor {
    /// Real part of the relative index (default: material "none", η = 0).
    pub eta: Spectrum,
    /// Imaginary part (default: material "none", k = 1).
    pub k: Spectrum,
    /// Multiplier of the reflectance (default 1).
    pub specular_reflectance: Spectrum,
}

impl Default for Conductor {
    /// Mitsuba's default: material "none", a perfect mirror.
    fn default() -> Self {
        Conductor {
            eta: Spectrum::ZERO,
            k: Spectrum::ONE,
            specular_reflectance: Spectrum::ONE,
        }
    }
}

impl Conductor {
    /// A delta lobe: `eval` is 0 for any given pair of directions.
    #[inline]
    pub fn eval(&self, _wi: Vec3, _wo: Vec3) -> Spectrum {
        Spectrum::ZERO
    }

    #[inline]
    pub fn pdf(&self, _wi: Vec3, _wo: Vec3) -> f32 {
        0.0
    }

    #[inline]
    pub fn sample(&self, wi: Vec3) -> Option<BsdfSample> {
        if wi.z <= 0.0 {
            return None;
        }
        Some(BsdfSample {
            wo: reflect_z(wi),
            pdf: 0.0,
            weight: self.specular_reflectance * fresnel_conductor(wi.z, self.eta, self.k),
            eta: 1.0,
            lobe: Lobes::DELTA_REFLECTION,
        })
    }
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use super::Conductor;
    use crate::bsdf::ior::load::conductor_ior;
    use crate::bsdf::BsdfNode;
    use crate::error::Result;
    use crate::load::bsdfs::BsdfCtx;
    use crate::material::{MaterialNode, Slot};

    /// `conductor`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        let (eta, k) = conductor_ior(cx.props())?;
        let (spec, slots) =
            cx.leaf_color("specular_reflectance", Slot::SpecularReflectance, 1.0)?;
        let template = BsdfNode::Conductor(Conductor {
            eta,
            k,
            specular_reflectance: spec,
        });
        Ok(MaterialNode::Leaf {
            template: Box::new(template),
            slots,
        })
    }
}
