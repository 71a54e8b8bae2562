//! Maths: glam re-exports, orthonormal frames, sampling warps, MIS weights and the random generator.

pub mod distrib;
pub mod frame;
pub mod mis;
pub mod rng;
pub mod warp;

pub use distrib::{Distribution1D, Distribution2D};
pub use frame::Frame;
pub use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
pub use rng::Pcg32;

pub const PI: f32 = std::f32::consts::PI;
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
pub const INV_2PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;
pub const INV_4PI: f32 = 0.25 * std::f32::consts::FRAC_1_PI;

/// Reflect `w` (pointing away from the surface) about the normal `n`.
#[inline]
pub fn reflect(w: Vec3, n: Vec3) -> Vec3 {
    2.0 * w.dot(n) * n - w
}

/// `x.floor()` without a libm call (the x86-64 baseline has no `roundss`, so `f32::floor` is a
/// function call in the hot texture and film paths). Exact for every float: a magnitude of 2²³
/// or more is already an integer; NaN stays NaN.
#[inline]
pub fn floor(x: f32) -> f32 {
    if x.is_nan() || x.abs() >= 8_388_608.0 {
        return x;
    }
    let t = x as i32 as f32;
    if t > x {
        t - 1.0
    } else {
        t
    }
}

/// sqrt clamped at zero (guards tiny negative arguments from rounding).
#[inline]
pub fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

/// A point transform by an affine 4×4 matrix.
#[inline]
pub fn transform_point(m: &Mat4, p: Vec3) -> Vec3 {
    m.transform_point3(p)
}

/// A direction transform by an affine 4×4 matrix (no translation, no normalisation).
#[inline]
pub fn transform_vector(m: &Mat4, v: Vec3) -> Vec3 {
    m.transform_vector3(v)
}

/// A normal transform: by the inverse transpose, normalised.
#[inline]
pub fn transform_normal(inv: &Mat4, n: Vec3) -> Vec3 {
    inv.transpose().transform_vector3(n).normalize()
}

#[cfg(test)]
mod tests {
    #[test]
    fn floor_matches_std() {
        let mut r = super::Pcg32::new(7, 3);
        let specials = [
            0.0f32,
            -0.0,
            0.5,
            -0.5,
            1.0,
            -1.0,
            -1e-30,
            8_388_607.5,
            -8_388_607.5,
            8_388_608.0,
            1e20,
            -1e20,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        for x in specials {
            assert_eq!(super::floor(x), x.floor(), "{x}");
        }
        assert!(super::floor(f32::NAN).is_nan());
        for _ in 0..100_000 {
            let x = (r.next_f32() - 0.5) * 2e4;
            assert_eq!(super::floor(x), x.floor(), "{x}");
        }
    }
}
