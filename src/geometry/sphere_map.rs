//! Mitsuba 3.9.1's `sphere` under a `to_world` that is not a similarity (a non-uniform scale, a
//! shear, or a `<rotate>` with a non-unit axis): Mitsuba warns and keeps the shape a true sphere
//! (`src/shapes/sphere.cpp`, `Sphere::update`), with
//! - centre `M·0` and radius `|M·(1, 0, 0)|`, where `M = to_world · translate(center) ·
//!   scale(radius)`: the ray is intersected with that sphere, and its normal is the sphere's;
//! - the uv parameterisation and dp/du, dp/dv evaluated through the transform itself: the hit
//!   point is taken to object space by Mitsuba's inverse of `M` (`to_object`, which after a
//!   non-unit `<rotate>` is the transpose of its quirky inverse transpose, see
//!   `scene/xml/transform.rs`), there `uv = (φ/2π, θ/π)` of that (generally not unit) vector, θ
//!   by drjit's `unit_angle_z` (`2·asin(|v − ±z|/2)`, which is NaN when that argument exceeds 1),
//!   and the partials of the unit sphere mapped back by `M`;
//! - the normals flipped when `M` mirrors (the symmetric factor of its polar decomposition has a
//!   negative first entry exactly when the determinant is negative); this holds for every sphere.
//!
//! The warnings are Mitsuba's, from the symmetric polar factor `S` of `M`'s linear part (Higham's
//! scaled Newton iteration, as drjit's `polar_decomp`; computed here in double precision, with a
//! tolerance relative to the scale where Mitsuba uses 1e-6 absolute in single precision).

use glam::{DMat3, Mat3, Mat4, Vec2, Vec3};
use std::f32::consts::PI;

/// A non-similar sphere's map: `M` (object to world) and Mitsuba's inverse of it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereMap {
    pub to_world: Mat4,
    pub to_object: Mat4,
}

impl SphereMap {
    /// uv, dp/du and dp/dv at the world point `p` on the sphere, as Mitsuba's
    /// `Sphere::compute_surface_interaction` (see the module comment).
    pub fn param(&self, p: Vec3) -> (Vec2, Vec3, Vec3) {
        let l = self.to_object.transform_point3(p);
        let theta = unit_angle_z(l);
        let mut phi = l.y.atan2(l.x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let rd = (l.x * l.x + l.y * l.y).sqrt();
        let dpdv = if rd == 0.0 {
            Vec3::X
        } else {
            Vec3::new(l.z * (l.x / rd), l.z * (l.y / rd), -rd)
        };
        let dpdu = Vec3::new(-l.y, l.x, 0.0);
        (
            Vec2::new(phi * (0.5 / PI), theta * (1.0 / PI)),
            self.to_world.transform_vector3(dpdu) * (2.0 * PI),
            self.to_world.transform_vector3(dpdv) * PI,
        )
    }
}

/// drjit's `unit_angle_z`: the angle between `v` (meant to be unit) and +z, by
/// `2·asin(|v − z|/2)` (or π minus that about −z), kept exactly for non-unit `v`.
fn unit_angle_z(v: Vec3) -> f32 {
    if v.z >= 0.0 {
        2.0 * (0.5 * Vec3::new(v.x, v.y, v.z - 1.0).length()).asin()
    } else {
        PI - 2.0 * (0.5 * Vec3::new(v.x, v.y, v.z + 1.0).length()).asin()
    }
}

/// The symmetric factor `S` of the polar decomposition `A = Q·S` of `m`'s linear part (`Q` a
/// rotation: when `A` mirrors, `Q` and `S` are both negated, as drjit's `transform_decompose`).
/// Newton's iteration `Q ← (γQ + Q⁻ᵀ/γ)/2`, γ = (‖Q⁻ᵀ‖/‖Q‖)^½ (Higham 1986), 25 steps as Mitsuba.
pub(crate) fn polar_symmetric(m: &Mat4) -> DMat3 {
    let a = Mat3::from_mat4(*m).as_dmat3();
    let mut q = a;
    for _ in 0..25 {
        let qi = q.inverse().transpose();
        let frob = |x: &DMat3| x.to_cols_array().iter().map(|v| v * v).sum::<f64>();
        let gamma = (frob(&qi) / frob(&q)).sqrt().sqrt();
        if !gamma.is_finite() {
            break;
        }
        q = q * (0.5 * gamma) + qi * (0.5 / gamma);
    }
    let s = q.transpose() * a;
    if q.determinant() < 0.0 {
        -s
    } else {
        s
    }
}

/// Mitsuba 3.9.1's warnings for a sphere whose full map `m` (`to_world` with centre and radius)
/// is not a similarity: shear when `S` has off-diagonal entries, non-uniform scaling when its
/// diagonal entries differ (relative tolerance 1e-4 of the largest).
pub fn sphere_warnings(m: &Mat4) -> Vec<&'static str> {
    similarity_warnings(
        m,
        true,
        "'to_world' transform shouldn't contain non-uniform scaling!",
    )
}

/// Mitsuba 3.9.1's shear and uneven-scale warnings for a map `m` that should be a similarity,
/// from its symmetric polar factor `S`: shear when `S` has off-diagonal entries, `uneven` when
/// its x and y (and with `with_z`, z) diagonal entries differ (relative tolerance 1e-4 of the
/// largest). Spheres check all three axes, cylinders only the two across their axis.
pub(crate) fn similarity_warnings(
    m: &Mat4,
    with_z: bool,
    uneven: &'static str,
) -> Vec<&'static str> {
    let s = polar_symmetric(m);
    let c = s.to_cols_array_2d();
    let scale = (0..3).map(|i| c[i][i].abs()).fold(0.0, f64::max);
    let tol = 1e-4 * scale;
    let mut out = Vec::new();
    let off = [(0, 1), (0, 2), (1, 0), (1, 2), (2, 0), (2, 1)];
    if off.iter().any(|&(i, j)| c[i][j].abs() > tol) {
        out.push("'to_world' transform shouldn't contain any shearing!");
    }
    if (c[0][0] - c[1][1]).abs() > tol || (with_z && (c[0][0] - c[2][2]).abs() > tol) {
        out.push(uneven);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn similarities_do_not_warn_and_others_do() {
        let rot = Mat4::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
        let sim = Mat4::from_translation(Vec3::ONE) * rot * Mat4::from_scale(Vec3::splat(3.0));
        assert!(sphere_warnings(&sim).is_empty());
        let mirror = Mat4::from_scale(Vec3::new(-2.0, 2.0, 2.0));
        assert!(sphere_warnings(&mirror).is_empty());
        // Scale then rotate: S is the diagonal scale (no shear).
        let scaled = rot * Mat4::from_scale(Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(
            sphere_warnings(&scaled),
            ["'to_world' transform shouldn't contain non-uniform scaling!"]
        );
        // Rotate then scale: S = Rᵀ·D·R has off-diagonal entries.
        let sheared = Mat4::from_scale(Vec3::new(1.0, 2.0, 1.0)) * Mat4::from_rotation_z(0.7);
        assert_eq!(sphere_warnings(&sheared).len(), 2);
    }

    #[test]
    fn polar_factor_recovers_the_scale_and_the_mirror() {
        let rot = Mat4::from_rotation_y(0.4);
        let s = polar_symmetric(&(rot * Mat4::from_scale(Vec3::new(1.0, 2.0, 3.0))));
        let d = s.to_cols_array_2d();
        for (i, want) in [1.0, 2.0, 3.0].iter().enumerate() {
            assert!((d[i][i] - want).abs() < 1e-6, "{s:?}");
        }
        let m = polar_symmetric(&Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0)));
        assert!(m.x_axis.x < 0.0);
    }

    #[test]
    fn the_parameterisation_of_a_unit_sphere_is_the_usual_one() {
        let map = SphereMap {
            to_world: Mat4::IDENTITY,
            to_object: Mat4::IDENTITY,
        };
        let n = Vec3::new(0.3, -0.5, 0.6).normalize();
        let (uv, dpdu, _) = map.param(n);
        let phi = n.y.atan2(n.x) + 2.0 * PI;
        assert!((uv.x - phi / (2.0 * PI)).abs() < 1e-6);
        assert!((uv.y - n.z.acos() / PI).abs() < 1e-6);
        assert!(dpdu.dot(n).abs() < 1e-6);
    }
}
