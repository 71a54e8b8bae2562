//! Sampling warps from the unit square to common domains, each with its density.
//! (Shirley & Chiu 1997 concentric disk; Malley's method for the cosine hemisphere.)

use super::{safe_sqrt, INV_4PI, INV_PI, PI};
use glam::{Vec2, Vec3};

/// Concentric map of the unit square to the unit disk (Shirley & Chiu 1997).
#[inline]
pub fn square_to_disk_concentric(u: Vec2) -> Vec2 {
    let a = 2.0 * u.x - 1.0;
    let b = 2.0 * u.y - 1.0;
    if a == 0.0 && b == 0.0 {
        return Vec2::ZERO;
    }
    let (r, phi) = if a * a > b * b {
        (a, (PI / 4.0) * (b / a))
    } else {
        (b, PI / 2.0 - (PI / 4.0) * (a / b))
    };
    let (s, c) = phi.sin_cos();
    Vec2::new(r * c, r * s)
}

/// Cosine-weighted hemisphere around +z (Malley's method).
#[inline]
pub fn square_to_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = square_to_disk_concentric(u);
    let z = safe_sqrt(1.0 - d.length_squared());
    Vec3::new(d.x, d.y, z)
}

#[inline]
pub fn cosine_hemisphere_pdf(v: Vec3) -> f32 {
    INV_PI * v.z.max(0.0)
}

/// Uniform direction on the unit sphere.
#[inline]
pub fn square_to_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.y;
    let r = safe_sqrt(1.0 - z * z);
    let (s, c) = (2.0 * PI * u.x).sin_cos();
    Vec3::new(r * c, r * s, z)
}

#[inline]
pub fn uniform_sphere_pdf() -> f32 {
    INV_4PI
}

/// Uniform direction in the cone around +z with `cos θ ≥ cos_max`.
#[inline]
pub fn square_to_uniform_cone(u: Vec2, cos_max: f32) -> Vec3 {
    let cos_t = (1.0 - u.y) + u.y * cos_max;
    let sin_t = safe_sqrt(1.0 - cos_t * cos_t);
    let (s, c) = (2.0 * PI * u.x).sin_cos();
    Vec3::new(c * sin_t, s * sin_t, cos_t)
}

#[inline]
pub fn uniform_cone_pdf(cos_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_max))
}

/// Uniform barycentrics on a triangle: returns (b1, b2); b0 = 1 − b1 − b2.
#[inline]
pub fn square_to_uniform_triangle(u: Vec2) -> Vec2 {
    let t = safe_sqrt(1.0 - u.x);
    Vec2::new(1.0 - t, u.y * t)
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
