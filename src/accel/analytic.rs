//! Ray tests of the analytic primitives, written once over [`Lane`] (issue 16 item 3).
//!
//! The same source runs at width 1 (`f32`) and width 8 (`F32x8`), with the lanes holding either
//! 8 primitives against one ray or 8 rays against one primitive (tier A, `brute.rs`). Each test
//! repeats, operation for operation, the Embree user-geometry callback of its shape in
//! `embree.rs` (glam's operation order: `dot = x·x' + y·y' + z·z'`, an affine point
//! `((X·x + Y·y) + Z·z) + W`; Rust's `f32::min`/`max` as x86 lowers them, [`min_num`]), so tier A
//! reports the bits the Embree tier reports. A hit is the nearest root in the open interval
//! (tnear, tfar), as the callbacks accept it.

use crate::lane::vec::V3;
use crate::lane::Lane;

/// The columns of an affine map (x, y, z axes and the translation), in lanes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Affine<L> {
    pub x: V3<L>,
    pub y: V3<L>,
    pub z: V3<L>,
    pub w: V3<L>,
}

impl<L: Lane> Affine<L> {
    /// `M·p` for a point, in glam's `Mat4::transform_point3` order.
    #[inline(always)]
    fn point(&self, p: V3<L>) -> V3<L> {
        self.x.scale(p.x) + self.y.scale(p.y) + self.z.scale(p.z) + self.w
    }
    /// `M·v` for a vector (`Mat4::transform_vector3`).
    #[inline(always)]
    fn vector(&self, v: V3<L>) -> V3<L> {
        self.x.scale(v.x) + self.y.scale(v.y) + self.z.scale(v.z)
    }
}

/// A ray in lanes: origin, direction and the open interval of accepted parameters.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayL<L> {
    pub o: V3<L>,
    pub d: V3<L>,
    pub tnear: L,
    pub tfar: L,
}

/// Rust's `f32::min` as rustc lowers it on x86-64 (`minnum`: `if a is NaN { b } else if b < a
/// { b } else { a }`), which glam's `Vec3::min` and `min_element` use.
#[inline(always)]
pub(crate) fn min_num<L: Lane>(a: L, b: L) -> L {
    L::select(a.is_nan(), b, b.min(a))
}

/// Rust's `f32::max` likewise (`if a is NaN { b } else if b > a { b } else { a }`).
#[inline(always)]
pub(crate) fn max_num<L: Lane>(a: L, b: L) -> L {
    L::select(a.is_nan(), b, b.max(a))
}

/// The sphere of centre `c` and radius `r`: the nearer root in the interval, with the
/// discriminant from the line's distance to the centre and the small root from the product of
/// the roots (Haines et al., "Precision Improvements for Ray/Sphere Intersection", Ray Tracing
/// Gems, 2019, ch. 7), as `SphereData::hit`. Returns t and the hit mask.
#[inline(always)]
pub(crate) fn sphere<L: Lane>(ray: &RayL<L>, c: V3<L>, r: L) -> (L, L::Mask) {
    sphere_roots(ray, &sphere_disc(ray, c, r))
}

/// The first half of [`sphere`]: the discriminant and what the roots need. Where `real` is
/// false in every lane, [`sphere_roots`] reports no hit in any lane, so a packet may skip it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SphereDisc<L: Lane> {
    f: V3<L>,
    a: L,
    b: L,
    r2: L,
    disc: L,
    /// The line meets the sphere (a real discriminant, a nonzero direction).
    pub real: L::Mask,
}

/// [`sphere`] up to its discriminant.
#[inline(always)]
pub(crate) fn sphere_disc<L: Lane>(ray: &RayL<L>, c: V3<L>, r: L) -> SphereDisc<L> {
    let (o, d) = (ray.o, ray.d);
    let zero = r.splat(0.0);
    let f = o - c;
    let a = d.dot(d);
    let b = f.dot(d);
    let l = f - d.scale(b / a);
    let r2 = r * r;
    let disc = r2 - l.dot(l);
    let real = !(disc.is_nan() | disc.lt(zero) | a.eq(zero));
    SphereDisc {
        f,
        a,
        b,
        r2,
        disc,
        real,
    }
}

/// [`sphere`] from its discriminant: t and the hit mask (false wherever `s.real` is).
#[inline(always)]
pub(crate) fn sphere_roots<L: Lane>(ray: &RayL<L>, s: &SphereDisc<L>) -> (L, L::Mask) {
    let (f, a, b, r2, disc) = (s.f, s.a, s.b, s.r2, s.disc);
    let zero = a.splat(0.0);
    let cc = f.dot(f) - r2;
    let q = -b - (a * disc).sqrt().copysign(b);
    let t0 = q / a;
    let t1 = L::select(q.ne(zero), cc / q, q / a);
    let swap = t0.gt(t1);
    let (lo, hi) = (L::select(swap, t1, t0), L::select(swap, t0, t1));
    let in_lo = lo.gt(ray.tnear) & lo.lt(ray.tfar);
    let in_hi = hi.gt(ray.tnear) & hi.lt(ray.tfar);
    (L::select(in_lo, lo, hi), s.real & (in_lo | in_hi))
}

/// Where a ray crosses the plane z = 0 of an object space: t, whether t lies in the ray's
/// open interval, and the ray in object space (for [`PlaneCross::at`]). Where `within` is false
/// in every lane, [`planar`] reports no hit (square or disk) in any lane, so a packet may stop there.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PlaneCross<L: Lane> {
    pub t: L,
    pub within: L::Mask,
    ol: V3<L>,
    dl: V3<L>,
}

impl<L: Lane> PlaneCross<L> {
    /// The crossing's object-space x and y.
    #[inline(always)]
    pub(crate) fn at(&self) -> (L, L) {
        let l = self.ol + self.dl.scale(self.t);
        (l.x, l.y)
    }
}

/// The crossing of the plane z = 0 of the object space that `to_object` maps the ray into, as
/// `PlanarData::hit` computes it.
#[inline(always)]
pub(crate) fn plane_cross<L: Lane>(ray: &RayL<L>, to_object: &Affine<L>) -> PlaneCross<L> {
    let ol = to_object.point(ray.o);
    let dl = to_object.vector(ray.d);
    let t = -ol.z / dl.z;
    PlaneCross {
        t,
        within: t.gt(ray.tnear) & t.lt(ray.tfar),
        ol,
        dl,
    }
}

/// Whether the crossing (x, y) lies in the unit square [−1,1]².
#[inline(always)]
pub(crate) fn in_square<L: Lane>(x: L, y: L) -> L::Mask {
    let one = x.splat(1.0);
    x.abs().le(one) & y.abs().le(one)
}

/// Whether the crossing (x, y) lies in the unit disk.
#[inline(always)]
pub(crate) fn in_disk<L: Lane>(x: L, y: L) -> L::Mask {
    (x * x + y * y).le(x.splat(1.0))
}

/// The unit square [−1,1]² (`square`) or the unit disk of the plane z = 0 of the object space
/// that `to_object` maps the ray into, as `PlanarData::hit`.
#[inline(always)]
pub(crate) fn planar<L: Lane>(
    ray: &RayL<L>,
    to_object: &Affine<L>,
    square: L::Mask,
) -> (L, L::Mask) {
    let p = plane_cross(ray, to_object);
    let (x, y) = p.at();
    let inside = (square & in_square(x, y)) | (!square & in_disk(x, y));
    (p.t, p.within & inside)
}

/// What the box test found; `entering`, `near`, `far`, `ol` and `dl` let the width-1 caller
/// pick the face and its triangle ([`super::brute`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct BoxHit<L: Lane> {
    pub t: L,
    pub hit: L::Mask,
    /// The hit is where the ray enters the box (else where it leaves).
    pub entering: L::Mask,
    /// Per axis, the slab parameters where the ray enters and leaves.
    pub near: V3<L>,
    pub far: V3<L>,
    /// The ray in object space.
    pub ol: V3<L>,
    pub dl: V3<L>,
}

/// The box [−1,1]³ of the object space `to_object` maps into: the slab test (Kay & Kajiya,
/// "Ray Tracing Complex Scenes", SIGGRAPH 1986), entry if in the interval, else exit, as
/// `BoxData::hit`.
#[inline(always)]
pub(crate) fn cube<L: Lane>(ray: &RayL<L>, to_object: &Affine<L>) -> BoxHit<L> {
    let ol = to_object.point(ray.o);
    let dl = to_object.vector(ray.d);
    let one = ray.tnear.splat(1.0);
    let inv = V3::new(one / dl.x, one / dl.y, one / dl.z);
    let t_lo = (V3::new(-one, -one, -one) - ol) * inv;
    let t_hi = (V3::new(one, one, one) - ol) * inv;
    let near = V3::new(
        min_num(t_lo.x, t_hi.x),
        min_num(t_lo.y, t_hi.y),
        min_num(t_lo.z, t_hi.z),
    );
    let far = V3::new(
        max_num(t_lo.x, t_hi.x),
        max_num(t_lo.y, t_hi.y),
        max_num(t_lo.z, t_hi.z),
    );
    let enter = max_num(near.x, max_num(near.y, near.z));
    let exit = min_num(far.x, min_num(far.y, far.z));
    let in_enter = enter.gt(ray.tnear) & enter.lt(ray.tfar);
    let in_exit = exit.gt(ray.tnear) & exit.lt(ray.tfar);
    BoxHit {
        t: L::select(in_enter, enter, exit),
        hit: !enter.gt(exit) & (in_enter | in_exit),
        entering: in_enter,
        near,
        far,
        ol,
        dl,
    }
}
