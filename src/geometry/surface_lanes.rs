//! Lane forms of [`super::Shape::interaction`] for the shapes the stream renderer meets most:
//! triangles of meshes, spheres (similarity `to_world`), rectangles, disks and cylinders, written once over
//! [`Lane`] so 8 hits are reconstructed at once (`stream::kernels::surface`, issue 18).
//!
//! Bit identity: each form performs the scalar code's glam operations in the same order
//! (glam's `Vec3` is one correctly rounded operation per component; `try_normalize` is
//! `v · (1/|v|)` when that reciprocal is finite and positive; `Mat4::transform_point3` is
//! `((c0·x + c1·y) + c2·z) + c3`), branches become selects, and the frames are
//! [`crate::lane::frame::Frame`]'s, of which `math::Frame` is the width-1 instantiation. The unit
//! tests below compare every field with `Shape::interaction`'s bits on thousands of random hits
//! per kind, flipped normals included. What a shape needs per lane (vertices, the sphere's frame,
//! the rectangle's matrices) the caller gathers; the forms are pure arithmetic.

use crate::lane::frame::Frame;
use crate::lane::math as lm;
use crate::lane::vec::{V2, V3};
use crate::lane::Lane;
use crate::math::{INV_2PI, PI};

/// The fields of a surface interaction in lanes (the shape and primitive indices are the
/// caller's).
#[derive(Clone, Copy, Debug)]
pub struct SurfLanes<L> {
    pub p: V3<L>,
    pub ng: V3<L>,
    pub frame: Frame<L>,
    pub uv: V2<L>,
    pub dpdu: V3<L>,
    pub dpdv: V3<L>,
}

/// glam's `try_normalize`: `v · (1/|v|)` and whether `1/|v|` is finite and positive.
#[inline(always)]
fn try_normalize<L: Lane>(v: V3<L>) -> (V3<L>, L::Mask) {
    let len = v.length();
    let rcp = len.splat(1.0) / len;
    let ok = rcp.is_finite() & rcp.gt(len.splat(0.0));
    (v.scale(rcp), ok)
}

/// `try_normalize(v).unwrap_or(fallback)`.
#[inline(always)]
fn normalize_or<L: Lane>(v: V3<L>, fallback: V3<L>) -> V3<L> {
    let (n, ok) = try_normalize(v);
    V3::select(ok, n, fallback)
}

/// `a·x + b·y + c·z` per component, left to right (the barycentric interpolations).
#[inline(always)]
fn lerp3<L: Lane>(a: V3<L>, b: V3<L>, c: V3<L>, w: [L; 3]) -> V3<L> {
    a.scale(w[0]) + b.scale(w[1]) + c.scale(w[2])
}

/// The ray's point `o + d·t` (`Ray::at`).
#[inline(always)]
pub fn ray_at<L: Lane>(o: V3<L>, d: V3<L>, t: L) -> V3<L> {
    o + d.scale(t)
}

/// `c0·v.x + c1·v.y + c2·v.z` per component, left to right (glam's `Mat4::transform_vector3`;
/// `transform_point3` adds the translation column after it).
#[inline(always)]
fn linear<L: Lane>(c: &[V3<L>; 3], v: V3<L>) -> V3<L> {
    c[0].scale(v.x) + c[1].scale(v.y) + c[2].scale(v.z)
}

/// `Mat4::transform_point3` of the affine map with columns `c` (the last the translation).
#[inline(always)]
fn affine<L: Lane>(c: &[V3<L>; 4], v: V3<L>) -> V3<L> {
    linear(&[c[0], c[1], c[2]], v) + c[3]
}

/// The planar shapes' projection: `x` in the object space of `to_object` (columns), with z = 0.
#[inline(always)]
fn to_plane<L: Lane>(to_object: &[V3<L>; 4], x: V3<L>) -> V3<L> {
    let l = affine(to_object, x);
    V3::new(l.x, l.y, x.x.splat(0.0))
}

/// One triangle hit per lane: the triangle's vertices, their normals and uvs (any values in
/// lanes whose mesh lacks them, masked by `has_n` / `has_uv`), Embree's barycentrics `b1`,
/// `b2`, and the `flip_normals` sign (±1).
#[derive(Clone, Copy, Debug)]
pub struct Triangle<L: Lane> {
    pub p: [V3<L>; 3],
    pub n: [V3<L>; 3],
    pub uv: [V2<L>; 3],
    pub has_n: L::Mask,
    pub has_uv: L::Mask,
    pub b1: L,
    pub b2: L,
    pub sign: L,
}

/// `analytic_interaction` of `shapes.rs`: the shading frame around the true normal `ng`,
/// tangent to `dpdu`.
#[inline(always)]
fn analytic<L: Lane>(p: V3<L>, ng: V3<L>, uv: V2<L>, dpdu: V3<L>, dpdv: V3<L>) -> SurfLanes<L> {
    SurfLanes {
        p,
        ng,
        frame: Frame::from_normal_tangent(ng, dpdu),
        uv,
        dpdu,
        dpdv,
    }
}

/// The mesh branch of `Shape::interaction`.
#[inline(always)]
pub fn triangle<L: Lane>(x: &Triangle<L>) -> SurfLanes<L> {
    triangle_with::<L, true>(x)
}

/// [`triangle`] for lanes none of whose meshes has uvs (`x.has_uv` false in every lane, known
/// beforehand: one mesh's chunk): uv = (b1, b2) and the frame around the face normal, the
/// values [`triangle`]'s selects take there, without computing the uv terms they discard.
#[inline(always)]
pub fn triangle_no_uv<L: Lane>(x: &Triangle<L>) -> SurfLanes<L> {
    triangle_with::<L, false>(x)
}

/// [`triangle`], with the uv terms when `UV` (else as if no lane had uvs): the triangle's
/// own terms ([`triangle_consts`]), then the hit's ([`triangle_at`]).
#[inline(always)]
fn triangle_with<L: Lane, const UV: bool>(x: &Triangle<L>) -> SurfLanes<L> {
    let c = triangle_consts::<L, UV>(&x.p, &x.uv, x.has_uv);
    triangle_at::<L, UV>(x, &c)
}

/// What a triangle hit's interaction takes from the triangle alone, whatever the hit's
/// barycentrics: the true normal before the `flip_normals` sign, dp/du and dp/dv. A mesh of a
/// few triangles keeps them per triangle (`stream::kernels::surface::SmallTris`, computed at
/// load by [`triangle_consts`] at width 1: the same bits as in lanes).
#[derive(Clone, Copy, Debug)]
pub struct TriangleConsts<L> {
    pub ng: V3<L>,
    pub dpdu: V3<L>,
    pub dpdv: V3<L>,
}

/// The triangle's terms of [`triangle`] (`UV`) or [`triangle_no_uv`] (not `UV`; `uv` and
/// `has_uv` unread): the face normal of the corners `p`, normalised (+z where that fails), and
/// dp/du, dp/dv from the corners' uvs where their determinant is non-zero, else the frame
/// around the face normal.
#[inline(always)]
pub fn triangle_consts<L: Lane, const UV: bool>(
    p: &[V3<L>; 3],
    uv: &[V2<L>; 3],
    has_uv: L::Mask,
) -> TriangleConsts<L> {
    let [p0, p1, p2] = *p;
    let k = |c: f32| p0.x.splat(c);
    let (dp0, dp1) = (p1 - p0, p2 - p0);
    let ng = normalize_or(dp0.cross(dp1), V3::splat(p0.x, 0.0, 0.0, 1.0));
    let f = Frame::from_normal(ng);
    let (dpdu, dpdv) = if UV {
        let [t0, t1, t2] = *uv;
        let (d0, d1) = (
            V2::new(t1.x - t0.x, t1.y - t0.y),
            V2::new(t2.x - t0.x, t2.y - t0.y),
        );
        let det = d0.x * d1.y - d0.y * d1.x;
        let derivs = has_uv & det.ne(k(0.0));
        let inv = k(1.0) / det;
        let dpdu = V3::select(derivs, (dp0.scale(d1.y) - dp1.scale(d0.y)).scale(inv), f.s);
        let dpdv = V3::select(derivs, (dp1.scale(d0.x) - dp0.scale(d1.x)).scale(inv), f.t);
        (dpdu, dpdv)
    } else {
        (f.s, f.t)
    };
    TriangleConsts { ng, dpdu, dpdv }
}

/// [`triangle`] (`UV`) or [`triangle_no_uv`] of the hits `x` on triangles whose own terms are
/// `c` ([`triangle_consts`] of `x`'s corners; `x.p` is read for the point, `x.uv` for the uv
/// where `UV`): the point and uv interpolated, the shading normal from the vertex normals
/// (the face normal where `x.has_n` is not set or they sum to zero), the signs applied.
#[inline(always)]
pub fn triangle_at<L: Lane, const UV: bool>(
    x: &Triangle<L>,
    c: &TriangleConsts<L>,
) -> SurfLanes<L> {
    let (b1, b2) = (x.b1, x.b2);
    let b0 = b1.splat(1.0) - b1 - b2;
    let w = [b0, b1, b2];
    let [p0, p1, p2] = x.p;
    let p = lerp3(p0, p1, p2, w);
    // uvs interpolated; else uv = (b1, b2).
    let uv = if UV {
        let [t0, t1, t2] = x.uv;
        let uv = V2::new(
            t0.x * b0 + t1.x * b1 + t2.x * b2,
            t0.y * b0 + t1.y * b1 + t2.y * b2,
        );
        V2::select(x.has_uv, uv, V2::new(b1, b2))
    } else {
        V2::new(b1, b2)
    };
    let [n0, n1, n2] = x.n;
    let (ns, ns_ok) = try_normalize(lerp3(n0, n1, n2, w));
    let ns = V3::select(x.has_n & ns_ok, ns, c.ng);
    SurfLanes {
        p,
        ng: c.ng.scale(x.sign),
        frame: Frame::from_normal_tangent(ns.scale(x.sign), c.dpdu),
        uv,
        dpdu: c.dpdu,
        dpdv: c.dpdv,
    }
}

/// A sphere of centre `c` and radius `r` whose uv map is oriented by the rotation with columns
/// `frame` (a similarity `to_world`: `ShapeKind::Sphere` without a `map`), hit at `x` (the
/// ray's point); `sign` is the `flip_normals` sign (±1).
#[inline(always)]
pub fn sphere<L: Lane>(c: V3<L>, r: L, frame: [V3<L>; 3], sign: L, x: V3<L>) -> SurfLanes<L> {
    let k = |v: f32| r.splat(v);
    let n = normalize_or(x - c, V3::splat(r, 0.0, 0.0, 1.0));
    // Reprojected onto the sphere, as Mitsuba.
    let p = c + n.scale(r);
    // `sphere_uv`: the normal in the local frame (the transpose of `frame` applied to it).
    let l = V3::new(frame[0].dot(n), frame[1].dot(n), frame[2].dot(n));
    let lz = L::select(l.z.lt(k(-1.0)), k(-1.0), l.z);
    let lz = L::select(lz.gt(k(1.0)), k(1.0), lz);
    let theta = lm::acos(lz);
    let phi = lm::atan2(l.y, l.x);
    let phi = L::select(phi.lt(k(0.0)), phi + k(2.0 * PI), phi);
    let rd = (l.x * l.x + l.y * l.y).sqrt();
    let dpdu = V3::new(-l.y, l.x, k(0.0)).scale(k(2.0 * PI) * r);
    let dpdv = V3::select(
        rd.gt(k(0.0)),
        V3::new(l.z * l.x / rd, l.z * l.y / rd, -rd),
        V3::splat(r, 1.0, 0.0, 0.0),
    )
    .scale(k(PI) * r);
    let (dpdu, dpdv) = (linear(&frame, dpdu), linear(&frame, dpdv));
    let uv = V2::new(phi * k(INV_2PI), theta * k(1.0 / PI));
    analytic(p, n.scale(sign), uv, dpdu, dpdv)
}

/// A rectangle hit at `x` (the ray's point): `to_object` and `to_world` as columns (the last
/// the translation), and the shape's constants: the signed true normal `ng`, the signed shading
/// normal `n` (`ng` unless Mitsuba's differs), dp/du and dp/dv.
#[derive(Clone, Copy, Debug)]
pub struct Rectangle<L> {
    pub to_object: [V3<L>; 4],
    pub to_world: [V3<L>; 4],
    pub ng: V3<L>,
    pub n: V3<L>,
    pub dpdu: V3<L>,
    pub dpdv: V3<L>,
}

/// The rectangle branch of `Shape::interaction`.
#[inline(always)]
pub fn rectangle<L: Lane>(m: &Rectangle<L>, x: V3<L>) -> SurfLanes<L> {
    let k = |v: f32| x.x.splat(v);
    let l = to_plane(&m.to_object, x);
    SurfLanes {
        p: affine(&m.to_world, l),
        ng: m.ng,
        frame: Frame::from_normal_tangent(m.n, m.dpdu),
        uv: V2::new(k(0.5) * l.x + k(0.5), k(0.5) * l.y + k(0.5)),
        dpdu: m.dpdu,
        dpdv: m.dpdv,
    }
}

/// A disk hit at `x` (the ray's point): `to_object` and `hit_to_world` as columns (the last
/// the translation; the disk is traced in the first's object space and its point mapped back by
/// the second), `to_world`'s linear columns (the uv partials) and the signed normal `ng`.
#[derive(Clone, Copy, Debug)]
pub struct Disk<L> {
    pub to_object: [V3<L>; 4],
    pub hit_to_world: [V3<L>; 4],
    pub to_world: [V3<L>; 3],
    pub ng: V3<L>,
}

/// The disk branch of `Shape::interaction` (with `disk_uv`).
#[inline(always)]
pub fn disk<L: Lane>(m: &Disk<L>, x: V3<L>) -> SurfLanes<L> {
    let k = |v: f32| x.x.splat(v);
    let l = to_plane(&m.to_object, x);
    let p = affine(&m.hit_to_world, l);
    // `disk_uv`: polar coordinates, the partials through `to_world`.
    let r = (l.x * l.x + l.y * l.y).sqrt();
    let phi = lm::atan2(l.y, l.x);
    let phi = L::select(phi.lt(k(0.0)), phi + k(2.0 * PI), phi);
    let positive = r.gt(k(0.0));
    let cp = L::select(positive, l.x / r, k(1.0));
    let sp = L::select(positive, l.y / r, k(0.0));
    let dpdu = linear(&m.to_world, V3::new(cp, sp, k(0.0)));
    let dpdv = linear(&m.to_world, V3::new(-sp, cp, k(0.0))).scale(k(2.0 * PI) * r);
    analytic(p, m.ng, V2::new(r, phi * k(INV_2PI)), dpdu, dpdv)
}

/// An instance's transform in lanes: `to_world` as columns (the last the translation) and the
/// normal matrix's columns (`Instance`'s inverse transpose).
#[derive(Clone, Copy, Debug)]
pub struct InstanceLanes<L> {
    pub to_world: [V3<L>; 4],
    pub normal: [V3<L>; 3],
}

/// `Instance::interaction`: a member's interaction `s` (computed in group space) mapped to
/// world space; uv stays.
#[inline(always)]
pub fn instance<L: Lane>(m: &InstanceLanes<L>, s: &SurfLanes<L>) -> SurfLanes<L> {
    let w = [m.to_world[0], m.to_world[1], m.to_world[2]];
    let dpdu = linear(&w, s.dpdu);
    let ng = normalize_or(linear(&m.normal, s.ng), s.ng);
    let n = normalize_or(linear(&m.normal, s.frame.n), s.frame.n);
    SurfLanes {
        p: affine(&m.to_world, s.p),
        ng,
        frame: Frame::from_normal_tangent(n, dpdu),
        uv: s.uv,
        dpdu,
        dpdv: linear(&w, s.dpdv),
    }
}

/// A cylinder hit at `x` (the ray's point): M (`to_world`) and Mitsuba's inverse of it
/// (`to_object`) as columns (the last the translation), the normal map's columns, the constant
/// dp/dv, the `flip_normals` sign (±1), and where the hit point stays the ray's (`quirk`).
#[derive(Clone, Copy, Debug)]
pub struct CylinderLanes<L: Lane> {
    pub to_world: [V3<L>; 4],
    pub to_object: [V3<L>; 4],
    pub normal: [V3<L>; 3],
    pub dpdv: V3<L>,
    pub sign: L,
    pub quirk: L::Mask,
}

/// The cylinder branch of `Shape::interaction` (`Cylinder::surface`): the point in object
/// space, its angle φ around the axis (the crate's `atan2`), the outward normal by the normal
/// map, dp/du, and the point reprojected onto the tube unless `quirk`.
#[inline(always)]
pub fn cylinder<L: Lane>(m: &CylinderLanes<L>, x: V3<L>) -> SurfLanes<L> {
    let k = |v: f32| x.x.splat(v);
    let l = affine(&m.to_object, x);
    let r = (l.x * l.x + l.y * l.y).sqrt();
    let positive = r.gt(k(0.0));
    let cx = L::select(positive, l.x / r, k(1.0));
    let cy = L::select(positive, l.y / r, k(0.0));
    let phi = lm::atan2(cy, cx);
    let phi = L::select(phi.lt(k(0.0)), phi + k(2.0 * PI), phi);
    let uv = V2::new(phi * k(INV_2PI), l.z);
    let n = normalize_or(
        linear(&m.normal, V3::new(cx, cy, k(0.0))),
        V3::splat(x.x, 0.0, 0.0, 1.0),
    );
    let w = [m.to_world[0], m.to_world[1], m.to_world[2]];
    let two_pi = k(2.0 * PI);
    let dpdu = linear(&w, V3::new(-cy * two_pi, cx * two_pi, k(0.0) * two_pi));
    let p = V3::select(m.quirk, x, affine(&m.to_world, V3::new(cx, cy, l.z)));
    analytic(p, n.scale(m.sign), uv, dpdu, m.dpdv)
}

#[cfg(test)]
mod tests {
    //! Every lane form against `Shape::interaction`, field by field and bit for bit, at width 1
    //! and (with AVX2) width 8, on thousands of random hits per kind: meshes with and without
    //! vertex normals and uvs (degenerate uvs, zero normals and collinear triangles included),
    //! spheres under rotations and uniform scales, rectangles (with Mitsuba's quirky shading
    //! normal too), disks, cylinders (with Mitsuba's quirky inverse too), each with and without
    //! `flip_normals`.
    use super::*;
    use crate::geometry::{Hit, Ray, Shape, ShapeKind, SurfaceInteraction, TriMesh};
    use glam::{Mat3, Mat4, Vec2, Vec3};

    /// xorshift64*: a fixed-seed stream of floats in [0, 1).
    struct Rng(u64);
    impl Rng {
        fn f(&mut self) -> f32 {
            self.0 ^= self.0 >> 12;
            self.0 ^= self.0 << 25;
            self.0 ^= self.0 >> 27;
            ((self.0.wrapping_mul(0x2545_f491_4f6c_dd1d) >> 40) as f32) / (1u64 << 24) as f32
        }
        fn s(&mut self) -> f32 {
            2.0 * self.f() - 1.0
        }
        fn v3(&mut self) -> Vec3 {
            Vec3::new(self.s(), self.s(), self.s())
        }
        fn dir(&mut self) -> Vec3 {
            loop {
                let v = self.v3();
                if let Some(d) = v.try_normalize() {
                    return d;
                }
            }
        }
    }

    /// The interaction's fields as bits, in a fixed order (p, ng, s, t, n, uv, dpdu, dpdv).
    fn bits(si: &SurfaceInteraction) -> Vec<u32> {
        let v = [si.p, si.ng, si.sh.s, si.sh.t, si.sh.n, si.dpdu, si.dpdv];
        let mut b: Vec<u32> = v
            .iter()
            .flat_map(|v| v.to_array())
            .map(f32::to_bits)
            .collect();
        b.extend([si.uv.x.to_bits(), si.uv.y.to_bits()]);
        b
    }

    /// Lane `k` of `s`, in [`bits`]' order.
    fn lane_bits<L: Lane>(s: &SurfLanes<L>, k: usize) -> Vec<u32> {
        let v = [s.p, s.ng, s.frame.s, s.frame.t, s.frame.n, s.dpdu, s.dpdv];
        let mut b: Vec<u32> = v
            .iter()
            .flat_map(|v| [v.x.lane(k), v.y.lane(k), v.z.lane(k)])
            .map(f32::to_bits)
            .collect();
        b.extend([s.uv.x.lane(k).to_bits(), s.uv.y.lane(k).to_bits()]);
        b
    }

    fn v3(v: Vec3) -> V3<f32> {
        v.into()
    }

    /// A random mesh of 12 vertices and 20 triangles; `normals`/`uvs` as asked, with a zero
    /// normal, repeated uvs (a zero uv determinant) and a collinear triangle among them.
    fn mesh(r: &mut Rng, normals: bool, uvs: bool) -> TriMesh {
        let mut positions: Vec<Vec3> = (0..12).map(|_| r.v3() * 3.0).collect();
        positions[11] = (positions[0] + positions[1]) * 0.5;
        let mut indices: Vec<[u32; 3]> = (0..19)
            .map(|_| {
                let a = (r.f() * 11.0) as u32;
                [
                    a,
                    (a + 1 + (r.f() * 5.0) as u32) % 11,
                    (a + 6 + (r.f() * 4.0) as u32) % 11,
                ]
            })
            .collect();
        indices.push([0, 1, 11]);
        let normals = normals.then(|| {
            let mut n: Vec<Vec3> = (0..12).map(|_| r.dir()).collect();
            n[3] = Vec3::ZERO;
            n
        });
        let uvs = uvs.then(|| {
            let mut t: Vec<Vec2> = (0..12).map(|_| Vec2::new(r.f(), r.f())).collect();
            t[5] = t[4];
            t[6] = t[4];
            t
        });
        TriMesh {
            positions,
            normals,
            uvs,
            indices,
        }
    }

    /// A hit on `shape` at `x` (analytic shapes) or barycentrics (`u`, `v`) of triangle `prim`,
    /// by a random ray ending there.
    fn hit(r: &mut Rng, x: Vec3, prim: u32, u: f32, v: f32) -> (Ray, Hit) {
        let d = r.dir();
        let t = 0.5 + 4.0 * r.f();
        let ray = Ray::new(x - d * t, d);
        let h = Hit {
            geom: 0,
            prim,
            t,
            u,
            v,
            inst: crate::geometry::NO_INSTANCE,
        };
        (ray, h)
    }

    /// The triangle form's inputs for `hit` on `shape` (a mesh), at width 1.
    fn triangle_input(shape: &Shape, h: &Hit) -> Triangle<f32> {
        let ShapeKind::Mesh(m) = &shape.kind else {
            panic!("a mesh")
        };
        let tri = m.indices[h.prim as usize];
        let nr = |j: usize| {
            m.normals
                .as_ref()
                .map_or(Vec3::ZERO, |n| n[tri[j] as usize])
        };
        let uv = |j: usize| m.uvs.as_ref().map_or(Vec2::ZERO, |t| t[tri[j] as usize]);
        Triangle {
            p: tri.map(|i| v3(m.positions[i as usize])),
            n: [0, 1, 2].map(|j| v3(nr(j))),
            uv: [0, 1, 2].map(|j| uv(j).into()),
            has_n: m.normals.is_some(),
            has_uv: m.uvs.is_some(),
            b1: h.u,
            b2: h.v,
            sign: if shape.flip_normals { -1.0 } else { 1.0 },
        }
    }

    /// Random (shape, ray, hit, width-1 form) cases of one kind.
    type Case = (Shape, Ray, Hit);

    fn triangle_cases(r: &mut Rng, n: usize) -> Vec<Case> {
        let mut out = Vec::new();
        for k in 0..n {
            let (normals, uvs, flip) = (k % 2 == 0, k / 2 % 2 == 0, k / 4 % 2 == 0);
            let face = k / 8 % 3 == 0;
            let m = mesh(r, normals, uvs);
            let shape = Shape::from_mesh(m, flip, face && !normals).expect("a valid mesh");
            let prim = (r.f() * 20.0) as u32;
            // Barycentrics inside, on the edges and at the corners.
            let (mut u, mut v) = (r.f(), r.f());
            if u + v > 1.0 {
                (u, v) = (1.0 - u, 1.0 - v);
            }
            match k % 7 {
                0 => u = 0.0,
                1 => (u, v) = (1.0, 0.0),
                2 => v = 1.0 - u,
                _ => {}
            }
            let (ray, h) = hit(r, Vec3::ZERO, prim.min(19), u, v);
            out.push((shape, ray, h));
        }
        out
    }

    fn sphere_cases(r: &mut Rng, n: usize) -> Vec<Case> {
        (0..n)
            .map(|k| {
                let rot = Mat4::from_quat(glam::Quat::from_axis_angle(r.dir(), 6.0 * r.f()));
                let to_world = Mat4::from_translation(r.v3())
                    * rot
                    * Mat4::from_scale(Vec3::splat(0.5 + r.f()));
                let shape =
                    Shape::sphere(r.v3(), 0.2 + r.f(), &to_world, k % 2 == 0).expect("a sphere");
                let Some((c, rad, ..)) = shape.sphere_lanes() else {
                    panic!("a similarity sphere")
                };
                // Near the surface, at the poles too.
                let d = if k % 13 == 0 {
                    to_world.transform_vector3(Vec3::Z).normalize()
                } else {
                    r.dir()
                };
                let x = c + d * rad * (1.0 + 1e-4 * r.s());
                let (ray, h) = hit(r, x, 0, 0.0, 0.0);
                (shape, ray, h)
            })
            .collect()
    }

    fn rectangle_cases(r: &mut Rng, n: usize) -> Vec<Case> {
        (0..n)
            .map(|k| {
                let rot = Mat4::from_quat(glam::Quat::from_axis_angle(r.dir(), 6.0 * r.f()));
                let scale = Vec3::new(0.5 + r.f(), 0.5 + r.f(), 0.5 + r.f());
                let to_world = Mat4::from_translation(r.v3()) * rot * Mat4::from_scale(scale);
                let flip = k % 2 == 0;
                let shape = if k % 3 == 0 {
                    let nm = Mat3::from_quat(glam::Quat::from_axis_angle(r.dir(), r.f()));
                    Shape::rectangle_with_normals(&to_world, Some(&nm), flip)
                } else {
                    Shape::rectangle(&to_world, flip)
                };
                let l = Vec3::new(r.s(), r.s(), 1e-4 * r.s());
                let (ray, h) = hit(r, to_world.transform_point3(l), 0, 0.0, 0.0);
                (shape, ray, h)
            })
            .collect()
    }

    fn disk_cases(r: &mut Rng, n: usize) -> Vec<Case> {
        (0..n)
            .map(|k| {
                let rot = Mat4::from_quat(glam::Quat::from_axis_angle(r.dir(), 6.0 * r.f()));
                let scale = Vec3::new(0.5 + r.f(), 0.5 + r.f(), 0.5 + r.f());
                let to_world = Mat4::from_translation(r.v3()) * rot * Mat4::from_scale(scale);
                let shape = Shape::disk(&to_world, k % 2 == 0).expect("a disk");
                // Inside the unit disk, its centre (r = 0) too.
                let l = if k % 11 == 0 {
                    Vec3::new(0.0, 0.0, 1e-4 * r.s())
                } else {
                    Vec3::new(0.7 * r.s(), 0.7 * r.s(), 1e-4 * r.s())
                };
                let (ray, h) = hit(r, to_world.transform_point3(l), 0, 0.0, 0.0);
                (shape, ray, h)
            })
            .collect()
    }

    /// Cylinders under random affine maps (uneven scales and shears too), with and without
    /// `flip_normals` and Mitsuba's quirky inverse (the hit point stays the ray's); hits all
    /// around the tube, on the seam (φ = 0, π), off the surface and on the axis (r = 0).
    fn cylinder_cases(r: &mut Rng, n: usize) -> Vec<Case> {
        use crate::geometry::cylinder::Cylinder;
        (0..n)
            .map(|k| {
                let rot = Mat4::from_quat(glam::Quat::from_axis_angle(r.dir(), 6.0 * r.f()));
                let scale = if k % 3 == 0 {
                    Vec3::splat(0.5 + r.f())
                } else {
                    Vec3::new(0.5 + r.f(), 0.5 + r.f(), 0.5 + r.f())
                };
                let to_world = Mat4::from_translation(r.v3()) * rot * Mat4::from_scale(scale);
                let (p0, p1) = (r.v3(), r.v3() + Vec3::splat(2.0));
                let radius = if k % 7 == 0 {
                    -0.3 - r.f()
                } else {
                    0.3 + r.f()
                };
                let quirk = (k % 4 == 1)
                    .then(|| (to_world * Mat4::from_scale(Vec3::splat(1.01))).inverse());
                let c = Cylinder::with_inverse(p0, p1, radius, &to_world, quirk.as_ref())
                    .expect("a cylinder");
                let w = c.lanes().to_world;
                let m = Mat4::from_cols(
                    w[0].extend(0.0),
                    w[1].extend(0.0),
                    w[2].extend(0.0),
                    w[3].extend(1.0),
                );
                let phi = match k % 9 {
                    0 => 0.0,
                    1 => crate::math::PI,
                    _ => 6.3 * r.f(),
                };
                let rad = match k % 13 {
                    0 => 0.0,
                    _ => 1.0 + 1e-3 * r.s(),
                };
                let l = Vec3::new(rad * phi.cos(), rad * phi.sin(), r.f());
                let shape = Shape::cylinder(c, k % 2 == 0);
                let (ray, h) = hit(r, m.transform_point3(l), 0, 0.0, 0.0);
                (shape, ray, h)
            })
            .collect()
    }

    fn cylinder_input(shape: &Shape) -> CylinderLanes<f32> {
        let ShapeKind::Cylinder(c) = &shape.kind else {
            panic!("a cylinder")
        };
        let m = c.lanes();
        CylinderLanes {
            to_world: m.to_world.map(v3),
            to_object: m.to_object.map(v3),
            normal: m.normal.map(v3),
            dpdv: v3(m.dpdv),
            sign: if shape.flip_normals { -1.0 } else { 1.0 },
            quirk: m.quirk,
        }
    }

    fn disk_input(shape: &Shape) -> Disk<f32> {
        let (o, hw, w, ng) = shape.disk_lanes().expect("a disk");
        Disk {
            to_object: [0, 1, 2, 3].map(|j| v3(o.col(j).truncate())),
            hit_to_world: [0, 1, 2, 3].map(|j| v3(hw.col(j).truncate())),
            to_world: [0, 1, 2].map(|j| v3(w.col(j).truncate())),
            ng: v3(ng),
        }
    }

    fn sphere_input(shape: &Shape) -> (V3<f32>, f32, [V3<f32>; 3], f32) {
        let (c, rad, f, sign) = shape.sphere_lanes().expect("a similarity sphere");
        let cols = [f.x_axis, f.y_axis, f.z_axis].map(|a| v3(a.truncate()));
        (v3(c), rad, cols, sign)
    }

    fn rectangle_input(shape: &Shape) -> Rectangle<f32> {
        let (o, w, [ng, n, dpdu, dpdv]) = shape.rectangle_lanes().expect("a rectangle");
        Rectangle {
            to_object: [0, 1, 2, 3].map(|j| v3(o.col(j).truncate())),
            to_world: [0, 1, 2, 3].map(|j| v3(w.col(j).truncate())),
            ng: v3(ng),
            n: v3(n),
            dpdu: v3(dpdu),
            dpdv: v3(dpdv),
        }
    }

    /// The width-1 form of a case.
    fn form1(c: &Case) -> SurfLanes<f32> {
        let (shape, ray, h) = c;
        let x = ray_at(v3(ray.o), v3(ray.d), h.t);
        match &shape.kind {
            ShapeKind::Mesh(_) => triangle(&triangle_input(shape, h)),
            ShapeKind::Sphere { .. } => {
                let (c, rad, f, sign) = sphere_input(shape);
                sphere(c, rad, f, sign, x)
            }
            ShapeKind::Rectangle { .. } => rectangle(&rectangle_input(shape), x),
            ShapeKind::Disk { .. } => disk(&disk_input(shape), x),
            ShapeKind::Cylinder(_) => cylinder(&cylinder_input(shape), x),
            _ => unreachable!(),
        }
    }

    fn all_cases() -> Vec<(&'static str, Vec<Case>)> {
        let mut r = Rng(0x9e37_79b9_7f4a_7c15);
        vec![
            ("triangle", triangle_cases(&mut r, 4000)),
            ("sphere", sphere_cases(&mut r, 4000)),
            ("rectangle", rectangle_cases(&mut r, 4000)),
            ("disk", disk_cases(&mut r, 4000)),
            ("cylinder", cylinder_cases(&mut r, 4000)),
        ]
    }

    /// Checks every kind and names each that differs (a mismatch in one kind does not hide
    /// another's).
    fn assert_no_mismatch(width: usize, failed: Vec<String>) {
        assert!(failed.is_empty(), "width {width}: {}", failed.join("; "));
    }

    /// [`triangle_no_uv`] equals `Shape::interaction` on every triangle case without uvs (and
    /// there are such cases).
    #[test]
    fn the_no_uv_triangle_form_equals_shape_interaction() {
        let mut r = Rng(0x2545_f491_4f6c_dd1d);
        let (mut n, mut bad) = (0, 0);
        for (shape, ray, h) in triangle_cases(&mut r, 4000) {
            let ShapeKind::Mesh(m) = &shape.kind else {
                unreachable!()
            };
            if m.uvs.is_some() {
                continue;
            }
            n += 1;
            let s = triangle_no_uv(&triangle_input(&shape, &h));
            bad += usize::from(lane_bits(&s, 0) != bits(&shape.interaction(0, &ray, &h)));
        }
        assert!(n > 100, "only {n} triangle cases without uvs");
        assert_eq!(bad, 0, "{bad} of {n} hits differ");
    }

    #[test]
    fn width_1_forms_equal_shape_interaction() {
        let mut failed = Vec::new();
        for (kind, cases) in all_cases() {
            let bad = cases
                .iter()
                .filter(|c| lane_bits(&form1(c), 0) != bits(&c.0.interaction(0, &c.1, &c.2)))
                .count();
            if bad > 0 {
                failed.push(format!("{kind}: {bad} of {} hits differ", cases.len()));
            }
        }
        assert_no_mismatch(1, failed);
    }

    #[cfg(target_arch = "x86_64")]
    fn pack3(avx: crate::lane::Avx2, v: [V3<f32>; 8]) -> V3<crate::lane::F32x8> {
        V3::new(
            avx.load(&v.map(|v| v.x)),
            avx.load(&v.map(|v| v.y)),
            avx.load(&v.map(|v| v.z)),
        )
    }

    #[cfg(target_arch = "x86_64")]
    fn pack2(avx: crate::lane::Avx2, v: [V2<f32>; 8]) -> V2<crate::lane::F32x8> {
        V2::new(avx.load(&v.map(|v| v.x)), avx.load(&v.map(|v| v.y)))
    }

    /// Eight width-1 triangle inputs as one width-8 input.
    #[cfg(target_arch = "x86_64")]
    fn pack_triangles(
        avx: crate::lane::Avx2,
        t: &[Triangle<f32>; 8],
    ) -> Triangle<crate::lane::F32x8> {
        let p3 =
            |f: &dyn Fn(&Triangle<f32>) -> V3<f32>| pack3(avx, std::array::from_fn(|k| f(&t[k])));
        let p2 =
            |f: &dyn Fn(&Triangle<f32>) -> V2<f32>| pack2(avx, std::array::from_fn(|k| f(&t[k])));
        Triangle {
            p: [p3(&|t| t.p[0]), p3(&|t| t.p[1]), p3(&|t| t.p[2])],
            n: [p3(&|t| t.n[0]), p3(&|t| t.n[1]), p3(&|t| t.n[2])],
            uv: [p2(&|t| t.uv[0]), p2(&|t| t.uv[1]), p2(&|t| t.uv[2])],
            has_n: avx.mask(&t.map(|t| t.has_n)),
            has_uv: avx.mask(&t.map(|t| t.has_uv)),
            b1: avx.load(&t.map(|t| t.b1)),
            b2: avx.load(&t.map(|t| t.b2)),
            sign: avx.load(&t.map(|t| t.sign)),
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn width_8_forms_equal_shape_interaction() {
        use crate::lane::Avx2;
        let Some(avx) = Avx2::detect() else {
            eprintln!("no AVX2: width 8 not tested");
            return;
        };
        let mut failed = Vec::new();
        for (kind, cases) in all_cases() {
            let mut bad = 0;
            for chunk in cases.chunks_exact(8) {
                let x = pack3(
                    avx,
                    std::array::from_fn(|k| {
                        let (_, ray, h) = &chunk[k];
                        ray_at(v3(ray.o), v3(ray.d), h.t)
                    }),
                );
                let s = match kind {
                    "triangle" => {
                        let t: [Triangle<f32>; 8] =
                            std::array::from_fn(|k| triangle_input(&chunk[k].0, &chunk[k].2));
                        let x8 = pack_triangles(avx, &t);
                        avx.run(|| triangle(&x8))
                    }
                    "sphere" => {
                        let t: [_; 8] = std::array::from_fn(|k| sphere_input(&chunk[k].0));
                        let f = [0, 1, 2].map(|j| pack3(avx, t.map(|t| t.2[j])));
                        let c = pack3(avx, t.map(|t| t.0));
                        let (rad, sign) = (avx.load(&t.map(|t| t.1)), avx.load(&t.map(|t| t.3)));
                        avx.run(|| sphere(c, rad, f, sign, x))
                    }
                    "disk" => {
                        let t: [_; 8] = std::array::from_fn(|k| disk_input(&chunk[k].0));
                        let m = Disk {
                            to_object: [0, 1, 2, 3].map(|j| pack3(avx, t.map(|t| t.to_object[j]))),
                            hit_to_world: [0, 1, 2, 3]
                                .map(|j| pack3(avx, t.map(|t| t.hit_to_world[j]))),
                            to_world: [0, 1, 2].map(|j| pack3(avx, t.map(|t| t.to_world[j]))),
                            ng: pack3(avx, t.map(|t| t.ng)),
                        };
                        avx.run(|| disk(&m, x))
                    }
                    "cylinder" => {
                        let t: [_; 8] = std::array::from_fn(|k| cylinder_input(&chunk[k].0));
                        let m = CylinderLanes {
                            to_world: [0, 1, 2, 3].map(|j| pack3(avx, t.map(|t| t.to_world[j]))),
                            to_object: [0, 1, 2, 3].map(|j| pack3(avx, t.map(|t| t.to_object[j]))),
                            normal: [0, 1, 2].map(|j| pack3(avx, t.map(|t| t.normal[j]))),
                            dpdv: pack3(avx, t.map(|t| t.dpdv)),
                            sign: avx.load(&t.map(|t| t.sign)),
                            quirk: avx.mask(&t.map(|t| t.quirk)),
                        };
                        avx.run(|| cylinder(&m, x))
                    }
                    _ => {
                        let t: [_; 8] = std::array::from_fn(|k| rectangle_input(&chunk[k].0));
                        let m = Rectangle {
                            to_object: [0, 1, 2, 3].map(|j| pack3(avx, t.map(|t| t.to_object[j]))),
                            to_world: [0, 1, 2, 3].map(|j| pack3(avx, t.map(|t| t.to_world[j]))),
                            ng: pack3(avx, t.map(|t| t.ng)),
                            n: pack3(avx, t.map(|t| t.n)),
                            dpdu: pack3(avx, t.map(|t| t.dpdu)),
                            dpdv: pack3(avx, t.map(|t| t.dpdv)),
                        };
                        avx.run(|| rectangle(&m, x))
                    }
                };
                for (k, c) in chunk.iter().enumerate() {
                    if lane_bits(&s, k) != bits(&c.0.interaction(0, &c.1, &c.2)) {
                        bad += 1;
                    }
                }
            }
            if bad > 0 {
                failed.push(format!("{kind}: {bad} of {} hits differ", cases.len()));
            }
        }
        assert_no_mismatch(8, failed);
    }

    /// Instanced mesh hits: a random mesh member under a random affine `to_world` (non-uniform
    /// scales and mirrors included), the member's triangle form then [`instance`], against
    /// `Instance::interaction` of the member's interaction along the object ray.
    fn instance_cases(n: usize) -> Vec<(Shape, crate::geometry::Instance, Ray, Hit)> {
        let mut r = Rng(0x2545_f491_4f6c_dd1d);
        let tri = triangle_cases(&mut r, n);
        tri.into_iter()
            .enumerate()
            .map(|(k, (shape, ray, h))| {
                let rot = Mat4::from_quat(glam::Quat::from_axis_angle(r.dir(), 6.0 * r.f()));
                let mut scale = Vec3::new(0.3 + r.f(), 0.3 + r.f(), 0.3 + r.f());
                if k % 5 == 0 {
                    scale.x = -scale.x;
                }
                let to_world = Mat4::from_translation(r.v3()) * rot * Mat4::from_scale(scale);
                let inst = crate::geometry::Instance::new(0, &to_world).expect("an instance");
                (shape, inst, ray, h)
            })
            .collect()
    }

    fn instance_input(inst: &crate::geometry::Instance) -> InstanceLanes<f32> {
        let (w, nm) = inst.lanes();
        InstanceLanes {
            to_world: [0, 1, 2, 3].map(|j| v3(w.col(j).truncate())),
            normal: [0, 1, 2].map(|j| v3(nm.col(j))),
        }
    }

    fn instance_reference(c: &(Shape, crate::geometry::Instance, Ray, Hit)) -> Vec<u32> {
        let (shape, inst, ray, h) = c;
        bits(&inst.interaction(shape.interaction(0, &inst.object_ray(ray), h), ray))
    }

    #[test]
    fn width_1_instance_form_equals_instance_interaction() {
        let cases = instance_cases(4000);
        let bad = cases
            .iter()
            .filter(|c| {
                let s = triangle(&triangle_input(&c.0, &c.3));
                lane_bits(&instance(&instance_input(&c.1), &s), 0) != instance_reference(c)
            })
            .count();
        assert_eq!(bad, 0, "{bad} of {} instanced hits differ", cases.len());
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn width_8_instance_form_equals_instance_interaction() {
        use crate::lane::Avx2;
        let Some(avx) = Avx2::detect() else {
            eprintln!("no AVX2: width 8 not tested");
            return;
        };
        let cases = instance_cases(4000);
        let mut bad = 0;
        for chunk in cases.chunks_exact(8) {
            let t: [Triangle<f32>; 8] =
                std::array::from_fn(|k| triangle_input(&chunk[k].0, &chunk[k].3));
            let x8 = pack_triangles(avx, &t);
            let m: [InstanceLanes<f32>; 8] = std::array::from_fn(|k| instance_input(&chunk[k].1));
            let m8 = InstanceLanes {
                to_world: [0, 1, 2, 3].map(|j| pack3(avx, m.map(|m| m.to_world[j]))),
                normal: [0, 1, 2].map(|j| pack3(avx, m.map(|m| m.normal[j]))),
            };
            let s = avx.run(|| instance(&m8, &triangle(&x8)));
            for (k, c) in chunk.iter().enumerate() {
                if lane_bits(&s, k) != instance_reference(c) {
                    bad += 1;
                }
            }
        }
        assert_eq!(bad, 0, "{bad} of {} instanced hits differ", cases.len());
    }
}
