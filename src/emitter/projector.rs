//! `projector`: a pinhole that projects an image into the scene, the reciprocal of a
//! perspective camera (Mitsuba 3's `projector`, `src/emitters/projector.cpp`). A delta light:
//! found only by next-event estimation.
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | `irradiance` | colour or texture | 1 | the image, as irradiance on the virtual image plane at distance 1 from the pinhole; a bitmap's width / height sets the aspect ratio (other textures count as 1 × 1) |
//! | `scale` | float | 1 | factor on `irradiance` |
//! | `fov` | float | — | field of view in degrees along `fov_axis`, in (0, 180) |
//! | `fov_axis` | string | `x` | `x`, `y`, `diagonal`, `smaller` or `larger` (only with `fov`) |
//! | `focal_length` | string | `50mm` | 35 mm-equivalent focal length (the diagonal field of view), instead of `fov` |
//! | `to_world` | transform | identity | projector to world: it looks along local +z, +x is the image's left and +y its top, as the perspective camera |
//!
//! As Mitsuba computes it: a world point p with local position l = `to_world`⁻¹·p (Mitsuba's
//! `Transform::inverse()`, see `scene::xml::transform`) is lit when l.z > 0 and its image
//! coordinates
//!
//! `u = 0.5 − 0.5·l.x / (l.z·tan(fov_x/2))`, `v = 0.5 − 0.5·aspect·l.y / (l.z·tan(fov_x/2))`
//!
//! (Mitsuba's `perspective_projection` with the texture as film) lie in [0, 1]²; the light
//! arriving there (intensity / distance²) is `irradiance(u, v)·π·scale / (l.z²·cos θ)` with
//! cos θ = n·(p − o)/|p − o|, n = `to_world`·(0, 0, 1) unnormalised, o the pinhole. So the
//! irradiance on a plane at local z = 1 facing the projector is π·scale·`irradiance`: the π is
//! Mitsuba's (the inverse of a perspective camera's importance normalisation), kept for parity.

use super::DirectSample;
use crate::math::PI;
use crate::spectrum::luminance;
use crate::texture::Texture;
use glam::{Mat4, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct ProjectorLight {
    /// The pinhole (`to_world`'s translation).
    position: Vec3,
    /// World to projector space (Mitsuba's `to_world.inverse()`).
    to_local: Mat4,
    /// `to_world`·(0, 0, 1), not normalised (Mitsuba's `ds.n`).
    normal: Vec3,
    irradiance: Texture,
    scale: f32,
    /// 1 / tan(fov_x / 2).
    cot_half_x: f32,
    /// Image width / height.
    aspect: f32,
    /// Area of the image rectangle on the plane z = 1: 4·tan²(fov_x/2) / aspect.
    image_area: f32,
}

impl ProjectorLight {
    /// `to_world` and `to_local` (its inverse as Mitsuba computes it); `tan_half_x` =
    /// tan(fov_x / 2) > 0 and `aspect` > 0, validated by the caller.
    pub fn new(
        to_world: Mat4,
        to_local: Mat4,
        irradiance: Texture,
        scale: f32,
        tan_half_x: f32,
        aspect: f32,
    ) -> ProjectorLight {
        ProjectorLight {
            position: to_world.w_axis.truncate(),
            to_local,
            normal: to_world.transform_vector3(Vec3::Z),
            irradiance,
            scale,
            cot_half_x: 1.0 / tan_half_x,
            aspect,
            image_area: 4.0 * tan_half_x * tan_half_x / aspect,
        }
    }

    /// Image coordinates of the projector-space point `l`, if the projector lights it.
    #[inline]
    fn image_uv(&self, l: Vec3) -> Option<Vec2> {
        if l.z.is_nan() || l.z <= 0.0 {
            return None;
        }
        let k = self.cot_half_x / l.z;
        let uv = Vec2::new(0.5 - 0.5 * l.x * k, 0.5 - 0.5 * self.aspect * l.y * k);
        let inside = (0.0..=1.0).contains(&uv.x) && (0.0..=1.0).contains(&uv.y);
        inside.then_some(uv)
    }

    /// The pinhole's world position.
    pub fn position(&self) -> Vec3 {
        self.position
    }

    pub fn sample_direct(&self, ref_p: Vec3) -> Option<DirectSample> {
        let l = self.to_local.transform_point3(ref_p);
        let uv = self.image_uv(l)?;
        let v = self.position - ref_p;
        let dist2 = v.length_squared();
        if !(dist2 > 0.0 && dist2.is_finite()) {
            return None;
        }
        let dist = dist2.sqrt();
        let d = v / dist;
        let cos = -self.normal.dot(d);
        let k = PI * self.scale / (l.z * l.z * cos);
        if !(k.is_finite() && k > 0.0) {
            return None;
        }
        Some(DirectSample {
            d,
            dist,
            p: self.position,
            n: None,
            pdf: 1.0,
            value: self.irradiance.eval(uv) * k,
            delta: true,
        })
    }

    /// Radiant power (luminance): ∫ I dω over the image = π·scale·(mean irradiance)·(image
    /// area at z = 1), since dω = cos³θ dA on that plane (exact for a rigid `to_world`).
    pub fn power(&self) -> f32 {
        PI * self.scale * luminance(self.irradiance.mean()) * self.image_area
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::Spectrum;

    fn light(scale: f32, aspect: f32) -> ProjectorLight {
        // At the origin looking down −y (Mitsuba's look-at: columns left, up, dir).
        let to_world = Mat4::from_cols(
            Vec3::X.extend(0.0),
            Vec3::Z.extend(0.0),
            (-Vec3::Y).extend(0.0),
            Vec3::ZERO.extend(1.0),
        );
        ProjectorLight::new(
            to_world,
            to_world.inverse(),
            Texture::Constant(Spectrum::ONE),
            scale,
            (20f32).to_radians().tan(),
            aspect,
        )
    }

    #[test]
    fn irradiance_on_a_facing_plane_at_unit_distance_is_pi_scale() {
        // A plane at local z = 1 facing the projector: E = I·cos θ / r² = π·scale everywhere
        // in the image (the 1/cos³ of a perspective projection cancels).
        let p = light(2.0, 1.0);
        for x in [-0.3f32, 0.0, 0.2] {
            let point = Vec3::new(x, -1.0, 0.1);
            let s = p.sample_direct(point).expect("inside the image");
            let cos_receiver = s.d.dot(Vec3::Y);
            let e = s.value.x * cos_receiver;
            assert!((e - 2.0 * PI).abs() < 1e-4, "E = {e} at x = {x}");
        }
    }

    #[test]
    fn image_bounds_follow_the_fov_and_aspect() {
        let t = (20f32).to_radians().tan();
        let p = light(1.0, 2.0);
        // Local +x is the image's left (u = 0), local +y its top (v = 0).
        let uv = p.image_uv(Vec3::new(0.999 * t, 0.0, 1.0)).unwrap();
        assert!(uv.x < 1e-3 && (uv.y - 0.5).abs() < 1e-6);
        let uv = p.image_uv(Vec3::new(0.0, 0.999 * t / 2.0, 1.0)).unwrap();
        assert!(uv.y < 1e-3);
        assert!(p.image_uv(Vec3::new(1.01 * t, 0.0, 1.0)).is_none());
        assert!(p.image_uv(Vec3::new(0.0, 1.01 * t / 2.0, 1.0)).is_none());
        assert!(p.image_uv(Vec3::new(0.0, 0.0, -1.0)).is_none());
    }

    #[test]
    fn power_integrates_the_intensity() {
        // Riemann sum of I(ω) dω over the image plane z = 1 (dω = cos³θ dA, I = π/cos³θ).
        let p = light(1.5, 1.25);
        let t = (20f32).to_radians().tan();
        let n = 200;
        let (w, h) = (2.0 * t, 2.0 * t / 1.25);
        let mut sum = 0.0f64;
        for i in 0..n {
            for j in 0..n {
                let x = -t + (i as f32 + 0.5) / n as f32 * w;
                let y = -t / 1.25 + (j as f32 + 0.5) / n as f32 * h;
                let q = Vec3::new(x, -1.0, y);
                let dir = q.normalize();
                let cos = -dir.y;
                let s = p.sample_direct(q).unwrap();
                let intensity = s.value.x * s.dist * s.dist;
                sum += (intensity * cos * cos * cos * (w * h) / (n * n) as f32) as f64;
            }
        }
        assert!((sum as f32 / p.power() - 1.0).abs() < 1e-3);
    }
}
