//! `spot`: a point light that shines into a cone around the local +z axis of `to_world`
//! (Mitsuba 3's `spot`, `src/emitters/spot.cpp`). Full `intensity` within `beam_width` of the
//! axis, then a falloff that is linear in the angle down to zero at `cutoff_angle`. (Checked
//! against Mitsuba 3.9.1 with `sample_direction`: cutoff 20°, beam 15° gives 1 at 15°, 0.8 at 16°,
//! 0.5 at 17.5°, 0.2 at 19°, 0 at 20°: not a smooth step.)
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | `intensity` | colour | 1 | radiant intensity on the axis (a plain colour: Mitsuba refuses a spatially varying one) |
//! | `texture` | texture | none | a spatially varying texture (e.g. a bitmap) projected over the cone, multiplying `intensity` |
//! | `cutoff_angle` | float | 20 | half-angle of the cone in degrees, in (0, 180] |
//! | `beam_width` | float | ¾ `cutoff_angle` | half-angle of the full-intensity core, in [0, `cutoff_angle`] |
//! | `to_world` | transform | identity | light to world: the light sits at its origin and shines along local +z |
//!
//! Every direction is judged in the light's frame, as Mitsuba does: the direction d from the
//! light toward a point is taken to local space by Mitsuba's `to_world.inverse()` (see
//! `scene::xml::transform`), the falloff reads the cosine of its normalised local z, and the
//! texture is looked up at `uv = 0.5 + 0.5·(l.x, l.y) / (l.z·tan cutoff)` (Mitsuba's
//! `direction_to_uv`: the disc of the cone's cross-section inscribed in the unit uv square,
//! local +x toward u = 1, +y toward v = 1).

use super::DirectSample;
use crate::lane::math as lm;
use crate::spectrum::{luminance, Spectrum};
use crate::texture::Texture;
use glam::{Mat3, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct SpotLight {
    pub position: Vec3,
    /// World to light directions (the linear part of Mitsuba's `to_world.inverse()`).
    pub(crate) to_local: Mat3,
    pub intensity: Spectrum,
    /// The projected texture, if any.
    pub(crate) texture: Option<Texture>,
    /// Angles in radians, 0 ≤ beam_width ≤ cutoff ≤ π.
    pub cutoff: f32,
    pub beam_width: f32,
    pub(crate) cos_cutoff: f32,
    pub(crate) cos_beam: f32,
    /// tan(cutoff): the texture's uv scale.
    pub(crate) uv_factor: f32,
}

impl SpotLight {
    /// `to_local` is the linear part of the inverse of `to_world` (as Mitsuba computes it);
    /// angles in radians, validated by the caller.
    pub fn new(
        position: Vec3,
        to_local: Mat3,
        intensity: Spectrum,
        texture: Option<Texture>,
        cutoff: f32,
        beam_width: f32,
    ) -> SpotLight {
        SpotLight {
            position,
            to_local,
            intensity,
            texture,
            cutoff,
            beam_width,
            cos_cutoff: cutoff.cos(),
            cos_beam: beam_width.cos(),
            uv_factor: cutoff.tan(),
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
        let theta = lm::acos(c.clamp(-1.0, 1.0));
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
        let local = self.to_local * -d;
        let fall = self.falloff(local.normalize_or_zero().z);
        if fall <= 0.0 {
            return None;
        }
        let mut value = self.intensity * (fall / dist2);
        if let Some(t) = &self.texture {
            let k = 0.5 / (local.z * self.uv_factor);
            value *= t.eval(Vec2::new(0.5 + local.x * k, 0.5 + local.y * k));
        }
        Some(DirectSample {
            d,
            dist,
            p: self.position,
            n: None,
            pdf: 1.0,
            value,
            delta: true,
        })
    }

    /// A direction for a light path leaving the spot and its solid-angle density (light
    /// tracing): uniform in the cone when the light's transform is rigid (the local cone is then
    /// the world cone), else uniform on the sphere (directions outside the cone carry nothing).
    pub fn sample_emission_direction(&self, u: Vec2) -> (Vec3, f32) {
        let rigid = (self.to_local * self.to_local.transpose() - Mat3::IDENTITY)
            .to_cols_array()
            .iter()
            .all(|v| v.abs() < 1e-4);
        if rigid && self.cos_cutoff > -1.0 {
            let local = crate::math::warp::square_to_uniform_cone(u, self.cos_cutoff);
            // The inverse of a rotation is its transpose.
            let d = (self.to_local.transpose() * local).normalize();
            (d, crate::math::warp::uniform_cone_pdf(self.cos_cutoff))
        } else {
            (
                crate::math::warp::square_to_uniform_sphere(u),
                crate::math::warp::uniform_sphere_pdf(),
            )
        }
    }

    /// Radiant power estimate (luminance) for light selection: intensity × the texture's mean
    /// × the falloff integrated over the sphere.
    pub fn power(&self) -> f32 {
        let tex = self.texture.as_ref().map_or(1.0, |t| luminance(t.mean()));
        luminance(self.intensity) * tex * self.solid_angle()
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
