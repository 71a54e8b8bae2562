//! The ray/triangle test of tier A (few-triangle scenes, issue 18), written once over [`Lane`]
//! like the analytic kernels (`analytic.rs`): the same source runs one ray × 8 triangles and
//! 8 rays × one triangle, so both forms give the same bits per (ray, triangle).
//!
//! Möller and Trumbore, "Fast, Minimum Storage Ray/Triangle Intersection" (Journal of Graphics
//! Tools 2(1), 1997): Cramer's rule on `o + t·d = p0 + u·(p1 − p0) + v·(p2 − p0)`, written with
//! the triangle's normal `n = (p1 − p0) × (p2 − p0)` precomputed, so that per ray only one cross
//! product remains. With `c = p0 − o` and `r = c × d`, the determinant is `d·n` and
//! `u = (p2 − p0)·r / d·n`, `v = (p0 − p1)·r / d·n`, `t = c·n / d·n`. The edge tests compare the
//! numerators, their sign flipped by the determinant's, with |d·n| (no division before the
//! test: `u + v ≤ 1` is decided as `U + V ≤ |d·n|`), the same for the two triangles sharing an
//! edge whatever their winding. Both faces are hit (Embree's default, no backface culling).
//!
//! The barycentrics are Embree's (`Hit::u` weights p1, `Hit::v` weights p2); t, u and v differ
//! from Embree's in the last bits (Embree divides by a refined reciprocal estimate). A hit is a
//! t in the open interval (tnear, tfar), as tier A's analytic shapes.

use super::analytic::RayL;
use crate::lane::vec::V3;
use crate::lane::Lane;

/// A triangle as tier A keeps it: a corner `p0`, the edges `e1 = p0 − p1` and `e2 = p2 − p0`,
/// and the normal `n = (p1 − p0) × (p2 − p0)`, in lanes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TriL<L> {
    pub p0: V3<L>,
    pub e1: V3<L>,
    pub e2: V3<L>,
    pub n: V3<L>,
}

/// The 12 numbers of a triangle `[p0, e1, e2, n]` (x, y, z each) from its corners, in the
/// order [`TriL`] reads them.
pub(crate) fn tri_data(p0: glam::Vec3, p1: glam::Vec3, p2: glam::Vec3) -> [f32; 12] {
    let (e1, e2, n) = (p0 - p1, p2 - p0, (p1 - p0).cross(p2 - p0));
    let mut out = [0.0; 12];
    for (k, v) in [p0, e1, e2, n].iter().enumerate() {
        out[3 * k..3 * k + 3].copy_from_slice(&v.to_array());
    }
    out
}

/// The plane half of the test: where the ray's line crosses the triangle's plane. A packet
/// whose lanes all cross outside the interval (or behind their nearest hit so far) may stop
/// here: [`tri_edges`] cannot add a nearer hit.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TriPlane<L: Lane> {
    c: V3<L>,
    den: L,
    /// |d·n|.
    pub a: L,
    /// The ray parameter of the crossing, `(c·n)/(d·n)` (the numerator's sign flipped by the
    /// determinant's, over |d·n|).
    pub t: L,
}

/// [`TriPlane`] of `ray` and `tri`.
#[inline(always)]
pub(crate) fn tri_plane<L: Lane>(ray: &RayL<L>, tri: &TriL<L>) -> TriPlane<L> {
    let c = tri.p0 - ray.o;
    let den = tri.n.dot(ray.d);
    let a = den.abs();
    let t = tri.n.dot(c).mulsign(den) / a;
    TriPlane { c, den, a, t }
}

/// The edge half: the numerators u·|d·n| and v·|d·n| (signs flipped by the determinant's) and
/// the hit mask (a nonzero determinant, `U ≥ 0`, `V ≥ 0`, `U + V ≤ |d·n|`, t in the open
/// interval (tnear, tfar)).
#[inline(always)]
pub(crate) fn tri_edges<L: Lane>(ray: &RayL<L>, tri: &TriL<L>, p: &TriPlane<L>) -> (L, L, L::Mask) {
    let r = p.c.cross(ray.d);
    let u = tri.e2.dot(r).mulsign(p.den);
    let v = tri.e1.dot(r).mulsign(p.den);
    let zero = p.a.splat(0.0);
    let inside = p.a.gt(zero) & u.ge(zero) & v.ge(zero) & (u + v).le(p.a);
    (u, v, inside & p.t.gt(ray.tnear) & p.t.lt(ray.tfar))
}

/// Whether the ray meets the box `[lo, hi]` within its interval: the slab test (Kay & Kajiya,
/// "Ray Tracing Complex Scenes", SIGGRAPH 1986) with `inv = 1/d` per component, over
/// [tnear, tfar] closed. Tier A culls a mesh's triangles by their (padded) bounding box with it;
/// the forms run the same operations per (ray, box), so they cull alike.
#[inline(always)]
pub(crate) fn in_bounds<L: Lane>(ray: &RayL<L>, inv: V3<L>, lo: V3<L>, hi: V3<L>) -> L::Mask {
    let t0 = (lo - ray.o) * inv;
    let t1 = (hi - ray.o) * inv;
    let enter = t0.x.min(t1.x).max(t0.y.min(t1.y)).max(t0.z.min(t1.z));
    let exit = t0.x.max(t1.x).min(t0.y.max(t1.y)).min(t0.z.max(t1.z));
    enter.max(ray.tnear).le(exit.min(ray.tfar))
}

/// The whole test: the crossing ([`TriPlane`]: t and |d·n|), the numerators of u and v, and
/// the hit mask.
#[inline(always)]
pub(crate) fn triangle<L: Lane>(ray: &RayL<L>, tri: &TriL<L>) -> (TriPlane<L>, L, L, L::Mask) {
    let p = tri_plane(ray, tri);
    let (u, v, m) = tri_edges(ray, tri, &p);
    (p, u, v, m)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    fn tri(p: [Vec3; 3]) -> TriL<f32> {
        let d = tri_data(p[0], p[1], p[2]);
        let v = |k: usize| V3::new(d[3 * k], d[3 * k + 1], d[3 * k + 2]);
        TriL {
            p0: v(0),
            e1: v(1),
            e2: v(2),
            n: v(3),
        }
    }

    fn ray(o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> RayL<f32> {
        RayL {
            o: o.into(),
            d: d.into(),
            tnear,
            tfar,
        }
    }

    /// t, u, v as the definition says, for both windings and both sides.
    #[test]
    fn reports_t_and_embrees_barycentrics() {
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y];
        for (corners, flip) in [(p, false), ([p[0], p[2], p[1]], true)] {
            let t = tri(corners);
            for (o, d) in [
                (Vec3::new(0.25, 0.5, 1.0), Vec3::NEG_Z),
                (Vec3::new(0.25, 0.5, -2.0), Vec3::Z),
            ] {
                let r = ray(o, d, 0.0, f32::INFINITY);
                let (p, u, v, hit) = triangle(&r, &t);
                assert!(hit);
                assert_eq!(p.t, o.z.abs());
                let (u, v) = (u / p.a, v / p.a);
                // u weights corner 1, v corner 2.
                let want = if flip { (0.5, 0.25) } else { (0.25, 0.5) };
                assert_eq!((u, v), want);
            }
        }
    }

    /// Misses outside the edges, outside the interval (open at both ends), and parallel rays.
    #[test]
    fn rejects_outside_and_the_interval_ends() {
        let t = tri([Vec3::ZERO, Vec3::X, Vec3::Y]);
        let hits = |o: Vec3, d: Vec3, lo: f32, hi: f32| triangle(&ray(o, d, lo, hi), &t).3;
        assert!(!hits(Vec3::new(0.6, 0.6, 1.0), Vec3::NEG_Z, 0.0, 9.0));
        assert!(!hits(Vec3::new(-0.1, 0.5, 1.0), Vec3::NEG_Z, 0.0, 9.0));
        assert!(!hits(Vec3::new(0.5, -0.1, 1.0), Vec3::NEG_Z, 0.0, 9.0));
        assert!(!hits(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 1.0, 9.0));
        assert!(!hits(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 1.0));
        assert!(hits(Vec3::new(0.2, 0.2, 1.0), Vec3::NEG_Z, 0.0, 1.0000001));
        assert!(!hits(Vec3::new(0.2, 0.2, 0.0), Vec3::X, 0.0, 9.0));
        // On an edge and a corner: inside (closed edges).
        assert!(hits(Vec3::new(0.5, 0.5, 1.0), Vec3::NEG_Z, 0.0, 9.0));
        assert!(hits(Vec3::new(0.0, 0.0, 1.0), Vec3::NEG_Z, 0.0, 9.0));
        // A degenerate triangle and NaN corners are never hit.
        let flat = tri([Vec3::ZERO, Vec3::X, Vec3::X * 2.0]);
        assert!(!triangle(&ray(Vec3::new(0.5, 0.0, 1.0), Vec3::NEG_Z, 0.0, 9.0), &flat).3);
        let nan = tri([Vec3::NAN; 3]);
        assert!(!triangle(&ray(Vec3::Z, Vec3::NEG_Z, 0.0, 9.0), &nan).3);
    }
}
