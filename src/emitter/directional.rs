//! `directional`: light arriving from a single direction from infinitely far away (Mitsuba 3's
//! `directional`), a delta light at infinity. `irradiance` is the power per unit area
//! perpendicular to the direction of travel; the light travels along `direction` (or the local
//! +z of `to_world`). It is not seen by escaping rays, only by next-event estimation, and its
//! shadow rays go to infinity (`dist` = ∞, which the integrators already turn into an unbounded
//! ray).

use super::DirectSample;
use crate::spectrum::Spectrum;
use glam::Vec3;

#[derive(Clone, Debug)]
pub struct DirectionalLight {
    /// Unit direction in which the light travels.
    pub direction: Vec3,
    pub irradiance: Spectrum,
}

impl DirectionalLight {
    pub fn sample_direct(&self, ref_p: Vec3) -> Option<DirectSample> {
        let d = -self.direction;
        Some(DirectSample {
            d,
            dist: f32::INFINITY,
            p: ref_p + d,
            n: None,
            pdf: 1.0,
            value: self.irradiance,
            delta: true,
        })
    }
}
