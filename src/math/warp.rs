//! Sampling warps from the unit square to common domains, each with its density.
//! (Shirley & Chiu 1997 concentric disk; Malley's method for the cosine hemisphere.)
//!
//! The scalar renderer's width of the lane kernels (issue 16, item 4): each function is
//! `lane::warp` at width 1, so the 1-lane and 8-lane renderers share one source.

use crate::lane::vec::{V2, V3};
use crate::lane::warp as lw;
use glam::{Vec2, Vec3};

/// Concentric map of the unit square to the unit disk (Shirley & Chiu 1997).
#[inline]
pub fn square_to_disk_concentric(u: Vec2) -> Vec2 {
    lw::square_to_disk_concentric(V2::from(u)).into()
}

/// Cosine-weighted hemisphere around +z (Malley's method).
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    lw::square_to_cosine_hemisphere(V2::from(u)).into()
}

/// Density of [`square_to_cosine_hemisphere`].
#[inline]
pub fn cosine_hemisphere_pdf(v: Vec3) -> f32 {
    lw::cosine_hemisphere_pdf(V3::from(v))
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    lw::square_to_uniform_sphere(V2::from(u)).into()
}

/// Density of [`square_to_uniform_sphere`].
#[inline]
pub fn uniform_sphere_pdf() -> f32 {
    lw::uniform_sphere_pdf(0.0f32)
}

/// Uniform direction in the cone around +z with `cos θ ≥ cos_max`.
#[inline]
pub fn square_to_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    lw::square_to_uniform_cone(V2::from(u), cos_max).into()
}

/// Density of [`square_to_uniform_cone`].
#[inline]
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    lw::uniform_cone_pdf(cos_max)
}

/// Uniform barycentrics on a triangle: (b1, b2); b0 = 1 − b1 − b2.
#[inline]
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    lw::square_to_uniform_triangle(V2::from(u)).into()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Pcg32;

    /// Monte Carlo check: E[g(X)/pdf(X)] over the warp equals ∫ g over the domain.
    #[test]
    fn cosine_hemisphere_integrates_cosine_to_pi() {
        let mut r = Pcg32::new(3, 0);
        let n = 100_000;
        let mut s = 0.0f64;
        for _ in 0..n {
            let v = square_to_cosine_hemisphere(Vec2::new(r.next_f32(), r.next_f32()));
            assert!((v.length() - 1.0).abs() < 1e-5 && v.z >= 0.0);
            // ∫ cos² dω over the hemisphere = 2π/3
            s += (v.z * v.z / cosine_hemisphere_pdf(v)) as f64;
        }
        let est = s / n as f64;
        assert!(
            (est - 2.0 * std::f64::consts::PI / 3.0).abs() < 0.02,
            "{est}"
        );
    }

    #[test]
    fn cone_samples_stay_in_cone() {
        let mut r = Pcg32::new(5, 0);
        for _ in 0..1000 {
            let v = square_to_uniform_cone(Vec2::new(r.next_f32(), r.next_f32()), 0.9);
            assert!(v.z >= 0.9 - 1e-6);
        }
    }

    #[test]
    fn triangle_barycentrics_are_valid() {
        let mut r = Pcg32::new(9, 0);
        for _ in 0..1000 {
            let b = square_to_uniform_triangle(Vec2::new(r.next_f32(), r.next_f32()));
            assert!(b.x >= 0.0 && b.y >= 0.0 && b.x + b.y <= 1.0 + 1e-6);
        }
    }
}
