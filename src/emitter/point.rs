//! `point`: an isotropic point light of radiant `intensity` (Mitsuba's `point`).

use super::DirectSample;
use crate::spectrum::Spectrum;
use glam::Vec3;

#[derive(Clone, Debug)]
pub struct PointLight {
    pub position: Vec3,
    pub intensity: Spectrum,
}

impl PointLight {
    pub fn sample_direct(&self, ref_p: Vec3) -> Option<DirectSample> {
        let v = self.position - ref_p;
        let dist2 = v.length_squared();
        if dist2.is_nan() || dist2 <= 0.0 {
            return None;
        }
        let dist = dist2.sqrt();
        Some(DirectSample {
            d: v / dist,
            dist,
            p: self.position,
            n: None,
            pdf: 1.0,
            value: self.intensity / dist2,
            delta: true,
        })
    }
}
