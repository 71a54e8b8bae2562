//! Area lights on triangle meshes sampled in lanes: `Shape::sample_position`'s point on the
//! triangle that `Shape::pick_triangle` chose (lane by lane: a search of the area CDF), its
//! conversion to solid angle (`Shape::sample_direction`) and `AreaLight::sample_direct`'s
//! front-side test, the same operations in the same order (uniform triangle sampling: Shirley &
//! Chiu / Osada et al. 2002's square-root map, `lane::warp`). Other emitters, and area lights
//! whose radiance is textured, are sampled lane by lane by the scalar code.

use crate::lane::vec::{V2, V3};
use crate::lane::{warp, Lane};

/// One triangle per lane: its corners, optional per-vertex normals, the mesh's
/// `1 / area`, the sign of `flip_normals` and the rescaled sample `u`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Triangle<L: Lane> {
    pub p: [V3<L>; 3],
    /// Vertex normals, where `has_normals`.
    pub n: [V3<L>; 3],
    pub has_normals: L::Mask,
    pub inv_area: L,
    /// −1 where the shape flips its normals, else 1.
    pub sign: L,
    pub u: V2<L>,
}

/// A light point sampled from `ref_p` (see `emitter::DirectSample`); `ok` where
/// `sample_direction` and the area light accept it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TrianglePoint<L: Lane> {
    pub ok: L::Mask,
    pub d: V3<L>,
    pub dist: L,
    pub p: V3<L>,
    pub n: V3<L>,
    pub pdf: L,
}

/// glam's `try_normalize(v).unwrap_or(fallback)`: `v · (1/|v|)` where that reciprocal is finite
/// and positive.
#[inline(always)]
fn normalize_or<L: Lane>(v: V3<L>, fallback: V3<L>) -> V3<L> {
    let rcp = v.x.splat(1.0) / v.length();
    let ok = rcp.is_finite() & rcp.gt(v.x.splat(0.0));
    V3::select(ok, v.scale(rcp), fallback)
}

/// A point on each lane's triangle seen from `ref_p`.
#[inline(always)]
pub(crate) fn sample_triangle<L: Lane>(t: &Triangle<L>, ref_p: V3<L>) -> TrianglePoint<L> {
    let k = |c: f32| ref_p.x.splat(c);
    // Shape::sample_position.
    let b = warp::square_to_uniform_triangle(t.u);
    let b0 = k(1.0) - b.x - b.y;
    let [p0, p1, p2] = t.p;
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let p = (p0 + e1.scale(b.x)) + e2.scale(b.y);
    let ng = normalize_or(e1.cross(e2), V3::new(k(0.0), k(0.0), k(1.0)));
    let [n0, n1, n2] = t.n;
    let ns = normalize_or((n0.scale(b0) + n1.scale(b.x)) + n2.scale(b.y), ng);
    let n = V3::select(t.has_normals, ns, ng).scale(t.sign);
    let pdf_area = t.inv_area;
    // Shape::sample_direction (by area, converted to solid angle).
    let v = p - ref_p;
    let dist2 = v.length_squared();
    let dist = dist2.sqrt();
    let ok = !pdf_area.eq(k(0.0)) & !(dist.is_nan() | dist.le(k(0.0)));
    let d = v.div_by(dist);
    let cos = d.dot(n).abs();
    let pdf = pdf_area * dist2 / cos;
    let ok = ok & cos.gt(k(0.0)) & pdf.is_finite();
    // AreaLight::sample_direct: the light point faces the reference point.
    let ok = ok & !n.dot(-d).le(k(0.0)) & pdf.is_finite() & pdf.gt(k(0.0));
    TrianglePoint {
        ok,
        d,
        dist,
        p,
        n,
        pdf,
    }
}
