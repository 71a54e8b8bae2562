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
    /// The ray parameter of the crossing, `(c·n)/(d·n)`.
    pub t: L,
}

/// [`TriPlane`] of `ray` and `tri`.
///
/// t is `(c·n)/(d·n)` as one division. It was the numerator's sign flipped by the
/// determinant's over |d·n|, which is the same number: IEEE 754 gives a quotient the
/// exclusive or of its operands' signs and the rounded quotient of their magnitudes (the
/// rounding to nearest is symmetric), zeros and infinities included; only a NaN's sign bit may
/// differ, and a NaN t is never a hit. Two operations less per (ray, triangle) before the
/// packets' cull (the sign mask and the flip); |d·n| is left for the edge half. The test
/// `tn_over_den_is_the_sign_flipped_quotient` checks the equality.
#[inline(always)]
pub(crate) fn tri_plane<L: Lane>(ray: &RayL<L>, tri: &TriL<L>) -> TriPlane<L> {
    let c = tri.p0 - ray.o;
    let den = tri.n.dot(ray.d);
    let a = den.abs();
    let t = tri.n.dot(c) / den;
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

/// The per-ray half of the slab test ([`in_bounds`]): `1/d` per component and, per axis,
/// whether it is negative (its sign bit: −0 gives −∞), which names the box side the ray
/// enters by.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Slab<L: Lane> {
    inv: V3<L>,
    neg: [L::Mask; 3],
}

/// [`Slab`] of `ray` (once per ray or packet, for all of its box tests).
#[inline(always)]
pub(crate) fn slab<L: Lane>(ray: &RayL<L>) -> Slab<L> {
    let one = ray.tnear.splat(1.0);
    let inv = V3::new(one / ray.d.x, one / ray.d.y, one / ray.d.z);
    Slab {
        inv,
        neg: [inv.x.sign_bit(), inv.y.sign_bit(), inv.z.sign_bit()],
    }
}

/// Whether the ray meets the closed box `[lo, hi]` within its interval [tnear, tfar]: the slab
/// test (Kay & Kajiya, "Ray Tracing Complex Scenes", SIGGRAPH 1986). Tier A culls a mesh's
/// triangles by their (padded) bounding box with it; the forms run the same operations per
/// (ray, box), so they cull alike.
///
/// Each axis's entry and exit are taken by the sign of `1/d` (Williams et al., "An Efficient
/// and Robust Ray–Box Intersection Algorithm", JGT 10(1), 2005), not by `min`/`max` of the two
/// planes' parameters: a ray parallel to an axis (`d` = ±0, or subnormal, so `1/d` = ±∞) whose
/// origin lies exactly on one of that axis's planes gets 0·∞ = NaN for that plane, and the other
/// plane's parameter is then the right infinite bound (−∞ entry, +∞ exit: the ray stays inside
/// the slab). The NaN lands in the entry or the exit and is dropped there: x86 `max`/`min`
/// return the second operand when the first is NaN, so each axis is folded in as the first
/// operand onto tnear and tfar. (With `min`/`max` per axis the NaN could instead become +∞
/// entry or −∞ exit and reject the box.) Without NaN both forms give the same answer: the
/// products are monotone in the plane, so the sign picks what `min`/`max` would. A NaN tnear or
/// tfar (a packet's empty lane) still rejects.
#[inline(always)]
pub(crate) fn in_bounds<L: Lane>(ray: &RayL<L>, s: &Slab<L>, lo: V3<L>, hi: V3<L>) -> L::Mask {
    in_bounds_until(ray, s, lo, hi, ray.tfar)
}

/// [`in_bounds`] over [tnear, `tfar`] instead of the ray's own interval: the nearest-hit
/// packets pass the nearest t found so far, so a mesh whose box lies wholly behind every
/// lane's hit is skipped (its crossings would all be culled by the plane half anyway).
#[inline(always)]
pub(crate) fn in_bounds_until<L: Lane>(
    ray: &RayL<L>,
    s: &Slab<L>,
    lo: V3<L>,
    hi: V3<L>,
    tfar: L,
) -> L::Mask {
    let t0 = (lo - ray.o) * s.inv;
    let t1 = (hi - ray.o) * s.inv;
    let near = |k: usize, a: L, b: L| L::select(s.neg[k], b, a);
    let (nx, ny, nz) = (
        near(0, t0.x, t1.x),
        near(1, t0.y, t1.y),
        near(2, t0.z, t1.z),
    );
    let (fx, fy, fz) = (
        near(0, t1.x, t0.x),
        near(1, t1.y, t0.y),
        near(2, t1.z, t0.z),
    );
    let enter = nx.max(ny.max(nz.max(ray.tnear)));
    let exit = fx.min(fy.min(fz.min(tfar)));
    enter.le(exit)
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

    /// `tn / den` (what [`tri_plane`] computes) is `tn.mulsign(den) / |den|` (what it computed
    /// before) bit for bit wherever that is not NaN, and NaN where it is, at width 1 and 8: over
    /// every pair of special values (±0, subnormals, ±`f32::MAX`, ±∞, NaN) and random bit
    /// patterns.
    #[test]
    fn tn_over_den_is_the_sign_flipped_quotient() {
        let special = [
            0.0f32,
            -0.0,
            1e-45,
            -1e-45,
            1.1e-38,
            -3e-39,
            1.0,
            -1.0,
            3.0,
            -7.0,
            f32::MAX,
            -f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -f32::NAN,
        ];
        let check = |tn: f32, den: f32| {
            let (new, old) = (tn / den, tn.mulsign(den) / den.abs());
            if old.is_nan() {
                assert!(new.is_nan(), "{tn} / {den}");
            } else {
                assert_eq!(new.to_bits(), old.to_bits(), "{tn} / {den}");
            }
            (new, old)
        };
        for &tn in &special {
            for &den in &special {
                check(tn, den);
            }
        }
        let mut rng = crate::math::rng::Pcg32::new(26, 1);
        for _ in 0..1_000_000 {
            let (tn, den) = (
                f32::from_bits(rng.next_u32()),
                f32::from_bits(rng.next_u32()),
            );
            check(tn, den);
            check(tn, den * 1e-30);
        }
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = crate::lane::Avx2::detect() {
            for k in 0..special.len() {
                let tn: [f32; 8] = std::array::from_fn(|i| special[(k + i) % special.len()]);
                let den: [f32; 8] = std::array::from_fn(|i| special[(3 * k + i) % special.len()]);
                let got = avx.run(|| (avx.load(&tn) / avx.load(&den)).to_array());
                for i in 0..8 {
                    let (new, _) = check(tn[i], den[i]);
                    assert!(got[i].to_bits() == new.to_bits() || new.is_nan() && got[i].is_nan());
                }
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

    /// The slab test as it was before issue 18's NaN fix: `min`/`max` of the two planes'
    /// parameters per axis (x86 semantics through [`Lane`]), then onto tnear and tfar.
    fn in_bounds_min_max(ray: &RayL<f32>, lo: Vec3, hi: Vec3) -> (bool, bool) {
        let (lo, hi): (V3<f32>, V3<f32>) = (lo.into(), hi.into());
        let inv = V3::new(1.0 / ray.d.x, 1.0 / ray.d.y, 1.0 / ray.d.z);
        let t0 = (lo - ray.o) * inv;
        let t1 = (hi - ray.o) * inv;
        let nan = [t0.x, t0.y, t0.z, t1.x, t1.y, t1.z]
            .iter()
            .any(|t| t.is_nan());
        let enter = Lane::max(
            Lane::max(Lane::min(t0.x, t1.x), Lane::min(t0.y, t1.y)),
            Lane::min(t0.z, t1.z),
        );
        let exit = Lane::min(
            Lane::min(Lane::max(t0.x, t1.x), Lane::max(t0.y, t1.y)),
            Lane::max(t0.z, t1.z),
        );
        (
            Lane::max(enter, ray.tnear) <= Lane::min(exit, ray.tfar),
            nan,
        )
    }

    fn boxed(r: &RayL<f32>, lo: Vec3, hi: Vec3) -> bool {
        in_bounds(r, &slab(r), lo.into(), hi.into())
    }

    /// A ray parallel to an axis (d = +0 or −0 there) whose origin lies exactly on one of the
    /// box's planes of that axis stays on the closed box's boundary: inside. The `min`/`max`
    /// form got 0·∞ = NaN there and rejected the box whenever the origin lay on the low plane
    /// (+0: entry +∞; −0: exit −∞), 12 of these 24 rays; the sign form keeps all, at width 1
    /// and 8. A hair outside the plane is outside in both.
    #[test]
    fn the_slab_test_keeps_rays_on_a_box_plane() {
        let (lo, hi) = (Vec3::new(-1.0, -2.0, -3.0), Vec3::new(2.0, 1.0, 0.5));
        let mut old_rejected = 0;
        for axis in 0..3 {
            for side in [lo[axis], hi[axis]] {
                for zero in [0.0f32, -0.0] {
                    for (k, sign) in [(1usize, 1.0f32), (2, -1.0)] {
                        // Start outside on another axis and travel into the box along it.
                        let other = (axis + k) % 3;
                        let mut o = Vec3::splat(0.25);
                        o[axis] = side;
                        o[other] = if sign > 0.0 {
                            lo[other] - 4.0
                        } else {
                            hi[other] + 4.0
                        };
                        // Along the third axis (inside its slab) a slow drift.
                        let mut d = Vec3::splat(0.01);
                        d[axis] = zero;
                        d[other] = sign;
                        let r = ray(o, d, 0.0, f32::INFINITY);
                        assert!(boxed(&r, lo, hi), "on plane {axis} at {side}: {o} {d}");
                        let (old, nan) = in_bounds_min_max(&r, lo, hi);
                        assert!(nan);
                        old_rejected += usize::from(!old);
                        // Just outside the plane: never inside.
                        let mut out = o;
                        out[axis] = if side == lo[axis] {
                            side.next_down()
                        } else {
                            side.next_up()
                        };
                        let r = ray(out, d, 0.0, f32::INFINITY);
                        assert!(!boxed(&r, lo, hi), "outside plane {axis}: {out} {d}");
                        assert!(!in_bounds_min_max(&r, lo, hi).0);
                        #[cfg(target_arch = "x86_64")]
                        wide_agrees(&ray(o, d, 0.0, f32::INFINITY), lo, hi);
                        #[cfg(target_arch = "x86_64")]
                        wide_agrees(&r, lo, hi);
                    }
                }
            }
        }
        // What the fix changes: the old form dropped the box for most of these rays.
        assert_eq!(old_rejected, 12);
    }

    /// The 8-wide form of [`in_bounds`] gives the width-1 answer for `r` in every lane (one
    /// ray × 8 boxes and 8 rays × one box are the same operations per lane).
    #[cfg(target_arch = "x86_64")]
    fn wide_agrees(r: &RayL<f32>, lo: Vec3, hi: Vec3) {
        let Some(avx) = crate::lane::Avx2::detect() else {
            return;
        };
        let want = boxed(r, lo, hi);
        let s = |x: f32| avx.splat(x);
        let v = |p: V3<f32>| V3::new(s(p.x), s(p.y), s(p.z));
        let wide = RayL {
            o: v(r.o),
            d: v(r.d),
            tnear: s(r.tnear),
            tfar: s(r.tfar),
        };
        let got = avx.run(|| in_bounds(&wide, &slab(&wide), v(lo.into()), v(hi.into())));
        assert_eq!(got.bits(), if want { 0xff } else { 0 }, "{r:?}");
    }

    /// Wherever no 0·∞ arises, the sign form answers as the `min`/`max` form (so no hit of a
    /// renderer's ray changed with the fix), over random rays and boxes with ±0, subnormal,
    /// huge and infinite components and infinite or NaN intervals. Where one arises (the origin
    /// on a plane of an axis with 1/d = ±∞), it answers as if that axis's slab were the whole
    /// line: the ray does not leave the plane, which the closed slab holds.
    #[test]
    fn the_slab_test_equals_min_max_without_nan() {
        let mut rng = crate::math::rng::Pcg32::new(7, 18);
        let specials = [
            0.0f32,
            -0.0,
            1e-40,
            -1e-40,
            f32::MIN_POSITIVE,
            1e30,
            -1e30,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        let pick = |rng: &mut crate::math::rng::Pcg32, scale: f32| {
            let u = rng.next_f32();
            if u < 0.3 {
                specials[(rng.next_u32() % specials.len() as u32) as usize]
            } else if u < 0.4 {
                // A small integer: often exactly on a plane of the box.
                (rng.next_u32() % 5) as f32 - 2.0
            } else {
                scale * (2.0 * rng.next_f32() - 1.0)
            }
        };
        let (mut same, mut with_nan) = (0, 0);
        for k in 0..200_000 {
            let mut v = || {
                Vec3::new(
                    pick(&mut rng, 4.0),
                    pick(&mut rng, 4.0),
                    pick(&mut rng, 4.0),
                )
            };
            let (a, b, o, d) = (v(), v(), v(), v());
            if !(o.is_finite() && d.is_finite() && a.is_finite() && b.is_finite()) {
                continue;
            }
            let (lo, hi) = (a.min(b), a.max(b));
            let tnear = [0.0, 1e-4, f32::NAN][k % 3];
            let tfar = [f32::INFINITY, 3.0, f32::MAX, f32::NAN][k % 4];
            let r = ray(o, d, tnear, tfar);
            let got = boxed(&r, lo, hi);
            #[cfg(target_arch = "x86_64")]
            if k % 16 == 0 {
                wide_agrees(&r, lo, hi);
            }
            let (old, nan) = in_bounds_min_max(&r, lo, hi);
            if !nan {
                assert_eq!(got, old, "{r:?} {lo} {hi}");
                same += 1;
            } else {
                with_nan += 1;
                let mut flat = r;
                let (mut flo, mut fhi) = (lo, hi);
                for a in 0..3 {
                    if (1.0 / d[a]).is_infinite() && (o[a] == lo[a] || o[a] == hi[a]) {
                        // That axis's slab made the whole line: entry −∞, exit +∞.
                        (flo[a], fhi[a]) = (f32::MIN, f32::MAX);
                        let mut fo = Vec3::from(flat.o);
                        fo[a] = 0.0;
                        flat.o = fo.into();
                    }
                }
                if !(tnear.is_nan() || tfar.is_nan()) {
                    let want = in_bounds_min_max(&flat, flo, fhi);
                    if !want.1 {
                        assert_eq!(got, want.0, "{r:?} {lo} {hi}");
                    }
                } else {
                    assert!(!got);
                }
            }
        }
        assert!(same > 50_000 && with_nan > 1_000, "{same} {with_nan}");
    }
}
