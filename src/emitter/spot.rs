//! `spot`: a point light that shines into a cone around the local +z axis of `to_world`
//! (Mitsuba 3's `spot`). Full `intensity` within `beam_width` of the axis, then a falloff that is
//! linear in the angle down to zero at `cutoff_angle`. (Checked against Mitsuba 3.9.1 with
//! `sample_direction`: cutoff 20°, beam 15° gives 1 at 15°, 0.8 at 16°, 0.5 at 17.5°, 0.2 at 19°,
//! 0 at 20°: not a smooth step.)

use super::DirectSample;
use crate::spectrum::Spectrum;
use glam::{Mat3, Vec3};

#[derive(Clone, Debug)]
pub struct SpotLight {
    pub position: Vec3,
    /// Unit beam axis (the local +z of `to_world`).
    pub axis: Vec3,
    pub intensity: Spectrum,
    /// Angles in radians, 0 ≤ beam_width ≤ cutoff ≤ π.
    pub cutoff: f32,
    pub beam_width: f32,
    cos_cutoff: f32,
    cos_beam: f32,
}

impl SpotLight {
    /// `to_world` is the light's frame (rotation part, may carry a uniform scale; its columns are
    /// normalised); angles in radians, validated by the caller.
    pub fn new(
        position: Vec3,
        to_world: Mat3,
        intensity: Spectrum,
        cutoff: f32,
        beam_width: f32,
    ) -> SpotLight {
        // Only the beam axis matters for an untextured spot.
        SpotLight {
            position,
            axis: to_world.z_axis.normalize(),
            intensity,
            cutoff,
            beam_width,
            cos_cutoff: cutoff.cos(),
            cos_beam: beam_width.cos(),
        }
    }

    /// Fraction of `intensity` emitted along a direction at angle θ from the axis (`c` = cos θ).
    pub fn falloff(&self, c: f32) -> f32 {
        if c <= self.cos_cutoff {
            return 0.0;
        }
        if c >= self.cos_beam {
            return 1.0;
        }
        let theta = c.clamp(-1.0, 1.0).acos();
        ((self.cutoff - theta) / (self.cutoff - self.beam_width)).clamp(0.0, 1.0)
    }

    pub fn sample_direct(&self, ref_p: Vec3) -> Option<DirectSample> {
        let v = self.position - ref_p;
        let dist2 = v.length_squared();
        if dist2.is_nan() || dist2 <= 0.0 {
            return None;
        }
        let dist = dist2.sqrt();
        let d = v / dist;
        let fall = self.falloff(self.axis.dot(-d));
        if fall <= 0.0 {
            return None;
        }
        Some(DirectSample {
            d,
            dist,
            p: self.position,
            n: None,
            pdf: 1.0,
            value: self.intensity * (fall / dist2),
            delta: true,
        })
    }

    /// Radiant power (luminance weights applied by the caller): intensity × the falloff
    /// integrated over the sphere, ∫ falloff dω = 2π ∫ falloff(θ) sin θ dθ.
    pub fn solid_angle(&self) -> f32 {
        // Full beam: 2π(1 − cos beam). Transition: integrate the linear ramp numerically.
        let mut s = 2.0 * crate::math::PI * (1.0 - self.cos_beam);
        let n = 64;
        let w = self.cutoff - self.beam_width;
        if w > 0.0 {
            let h = w / n as f32;
            let mut acc = 0.0;
            for i in 0..n {
                let th = self.beam_width + (i as f32 + 0.5) * h;
                acc += (self.cutoff - th) / w * th.sin() * h;
            }
            s += 2.0 * crate::math::PI * acc;
        }
        s
    }
}
