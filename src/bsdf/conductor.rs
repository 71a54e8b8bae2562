//! `conductor`: a smooth metal, i.e. a perfect mirror weighted by the conductor Fresnel reflectance
//! of the complex index η + ik (per RGB channel) and by `specular_reflectance`. One-sided like
//! Mitsuba 3: light arriving from below the shading frame is not reflected.

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
