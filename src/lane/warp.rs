//! The sampling warps of `math::warp`, per lane, with the polynomial `sincos` of [`super::math`]
//! in place of libm (so width 1 differs from `math::warp` by a few ulps where a sine is taken,
//! and is bit-identical where none is: the triangle and the densities).
//! Shirley & Chiu 1997 concentric disk; Malley's method for the cosine hemisphere.

use super::math::sincos;
use super::vec::{V2, V3};
use super::Lane;
use crate::math::{INV_4PI, INV_PI, PI};

/// `max(x, 0).sqrt()` (x86 max: NaN gives 0).
#[inline(always)]
pub fn safe_sqrt<L: Lane>(x: L) -> L {
    x.max(x.splat(0.0)).sqrt()
}

/// Concentric map of the unit square to the unit disk (Shirley & Chiu 1997).
#[inline(always)]
pub fn square_to_disk_concentric<L: Lane>(u: V2<L>) -> V2<L> {
    let k = |c: f32| u.x.splat(c);
    let a = k(2.0) * u.x - k(1.0);
    let b = k(2.0) * u.y - k(1.0);
    let first = (a * a).gt(b * b);
    let r = L::select(first, a, b);
    // One division: q = b/a or a/b (the same quotient each branch would take).
    let q = L::select(first, b, a) / r;
    let phi = L::select(first, k(PI / 4.0) * q, k(PI / 2.0) - k(PI / 4.0) * q);
    let (s, c) = sincos(phi);
    let zero = a.eq(k(0.0)) & b.eq(k(0.0));
    V2::new(
        L::select(zero, k(0.0), r * c),
        L::select(zero, k(0.0), r * s),
    )
}

/// Cosine-weighted hemisphere around +z (Malley's method).
#[inline(always)]
pub fn square_to_cosine_hemisphere<L: Lane>(u: V2<L>) -> V3<L> {
    let d = square_to_disk_concentric(u);
    let z = safe_sqrt(u.x.splat(1.0) - d.length_squared());
    V3::new(d.x, d.y, z)
}

/// Density of [`square_to_cosine_hemisphere`].
#[inline(always)]
pub fn cosine_hemisphere_pdf<L: Lane>(v: V3<L>) -> L {
    v.z.splat(INV_PI) * v.z.max(v.z.splat(0.0))
}

/// Uniform direction on the unit sphere.
#[inline(always)]
pub fn square_to_uniform_sphere<L: Lane>(u: V2<L>) -> V3<L> {
    let k = |c: f32| u.x.splat(c);
    let z = k(1.0) - k(2.0) * u.y;
    let r = safe_sqrt(k(1.0) - z * z);
    let (s, c) = sincos(k(2.0 * PI) * u.x);
    V3::new(r * c, r * s, z)
}

/// Density of [`square_to_uniform_sphere`].
#[inline(always)]
pub fn uniform_sphere_pdf<L: Lane>(like: L) -> L {
    like.splat(INV_4PI)
}

/// Uniform direction in the cone around +z with `cos θ ≥ cos_max`.
#[inline(always)]
pub fn square_to_uniform_cone<L: Lane>(u: V2<L>, cos_max: L) -> V3<L> {
    let k = |c: f32| u.x.splat(c);
    let cos_t = (k(1.0) - u.y) + u.y * cos_max;
    let sin_t = safe_sqrt(k(1.0) - cos_t * cos_t);
    let (s, c) = sincos(k(2.0 * PI) * u.x);
    V3::new(c * sin_t, s * sin_t, cos_t)
}

/// Density of [`square_to_uniform_cone`].
#[inline(always)]
pub fn uniform_cone_pdf<L: Lane>(cos_max: L) -> L {
    let k = |c: f32| cos_max.splat(c);
    k(1.0) / (k(2.0 * PI) * (k(1.0) - cos_max))
}

/// Uniform barycentrics on a triangle: (b1, b2); b0 = 1 − b1 − b2.
#[inline(always)]
pub fn square_to_uniform_triangle<L: Lane>(u: V2<L>) -> V2<L> {
    let one = u.x.splat(1.0);
    let t = safe_sqrt(one - u.x);
    V2::new(one - t, u.y * t)
}
