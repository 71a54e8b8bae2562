//! Mitsuba 3's `cylinder` shape (`src/shapes/cylinder.cpp`): the open tube x² + y² = 1,
//! 0 ≤ z ≤ 1 of object space (no caps), placed by `p0`, `p1`, `radius` and `to_world`.
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | `p0`, `p1` | point | (0,0,0), (0,0,1) | centres of the two ends (object space, before `to_world`) |
//! | `radius` | float | 1 | radius (a negative one gives the same tube with u turned by ½, as in Mitsuba) |
//! | `flip_normals` | boolean | false | normals point toward the axis (an area emitter then emits inward) |
//! | `to_world` | transform | identity | applied after p0/p1/radius: rotation, translation, uniform scale |
//!
//! The object-to-world map is M = to_world · translate(p0) · frame(p1 − p0) · scale(r, r, |p1 − p0|)
//! where frame(d) has the columns (s, t, d) of Mitsuba's `coordinate_system(d)` (Duff et al.
//! 2017; [`Frame::from_normal`]), which fixes where u = 0 lies around the axis.
//! Parameterisation at the object-space point (cos φ, sin φ, z): uv = (φ/2π, z) with φ ∈ [0, 2π),
//! dp/du = M·2π(−sin φ, cos φ, 0), dp/dv = M·(0,0,1); the normal is the outward radial
//! direction (the normal transform of (cos φ, sin φ, 0)) unless `flip_normals`.
//! `sample_position` is uniform by area: φ = 2π·ξ₂, z = ξ₁, uv = (ξ₂, ξ₁), pdf = 1/(2π r ℓ).
//!
//! Mitsuba only warns about a shear or non-uniform scale across the axis and then samples an
//! ellipse as if it were a circle (a wrong pdf); groove rejects such a transform, as it does for
//! the sphere. Mitsuba also gives a mirrored cylinder sampled normals opposite to its hit normals;
//! groove keeps both outward (see the tests).

use crate::error::{Error, Result};
use crate::math::{Frame, INV_2PI, PI};
use crate::scene::xml::props::Props;
use glam::{DMat4, Mat3, Mat4, Vec2, Vec3};

/// A cylinder in world space.
#[derive(Clone, Debug)]
pub struct Cylinder {
    /// Object (unit tube) to world.
    to_world: Mat4,
    /// Its inverse, in f32 (hit points to object space) and in f64 (ray intersection).
    to_object: Mat4,
    to_object_d: DMat4,
    /// World-space radius and length.
    radius: f32,
    length: f32,
}

/// Relative tolerance of the uniform-scale and orthogonality checks (float rounding of a
/// rotation already exceeds Mitsuba's 1e-6 on the decomposed scale).
const SHAPE_TOL: f32 = 1e-4;

impl Cylinder {
    /// The cylinder from `p0` to `p1` of `radius` under `to_world` (Mitsuba's composition, see the
    /// module docs). Errors: a zero or non-finite radius, coinciding or non-finite end points, a
    /// degenerate transform, or one with a shear or a non-uniform scale across the axis.
    pub fn new(p0: Vec3, p1: Vec3, radius: f32, to_world: &Mat4) -> Result<Cylinder> {
        let err = |m: String| Error::file("cylinder", m);
        if !(radius.is_finite() && radius != 0.0) {
            return Err(err(format!(
                "radius must be finite and non-zero, got {radius}"
            )));
        }
        let axis = p1 - p0;
        let len = axis.length();
        if !(p0.is_finite() && p1.is_finite() && len.is_finite() && len > 0.0) {
            return Err(err(format!(
                "p0 {p0} and p1 {p1} must be finite and distinct"
            )));
        }
        let f = Frame::from_normal(axis / len);
        let frame = Mat4::from_mat3(Mat3::from_cols(f.s, f.t, f.n));
        let m = *to_world
            * Mat4::from_translation(p0)
            * frame
            * Mat4::from_scale(Vec3::new(radius, radius, len));
        let [a, b, c] = [Vec3::X, Vec3::Y, Vec3::Z].map(|v| m.transform_vector3(v));
        let (r, l) = (a.length(), c.length());
        let det = Mat3::from_mat4(m).determinant();
        if !(m.is_finite() && r > 0.0 && l > 0.0 && det.is_finite() && det != 0.0) {
            return Err(err("to_world is degenerate".into()));
        }
        let round = (b.length() - r).abs() <= SHAPE_TOL * r
            && a.dot(b).abs() <= SHAPE_TOL * r * r
            && a.dot(c).abs() <= SHAPE_TOL * r * l
            && b.dot(c).abs() <= SHAPE_TOL * r * l;
        if !round {
            return Err(err(
                "to_world has a shear or a non-uniform scale across the cylinder's axis; \
                 groove's cylinder allows only rotation, translation and uniform scale \
                 (Mitsuba warns and samples such a cylinder with a wrong density)"
                    .into(),
            ));
        }
        let to_object = m.inverse();
        Ok(Cylinder {
            to_world: m,
            to_object,
            to_object_d: m.as_dmat4().inverse(),
            radius: r,
            length: l,
        })
    }

    /// The `cylinder` shape element's own parameters (`p0`, `p1`, `radius`); the loader reads
    /// `to_world` and `flip_normals`, which every shape has, and passes them in.
    pub fn from_props(p: &Props<'_>, to_world: &Mat4, flip_normals: bool) -> Result<super::Shape> {
        let p0 = p.point("p0", Vec3::ZERO)?;
        let p1 = p.point("p1", Vec3::Z)?;
        let radius = p.float("radius", 1.0)?;
        let c = Cylinder::new(p0, p1, radius, to_world)
            .map_err(|e| Error::scene(p.loc(), e.to_string()))?;
        Ok(super::Shape::cylinder(c, flip_normals))
    }

    /// Surface area 2π r ℓ.
    pub fn area(&self) -> f32 {
        2.0 * PI * self.radius * self.length
    }

    /// Axis-aligned world bounds: the box around the two end circles (Mitsuba's `bbox`).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let x1 = self.to_world.transform_vector3(Vec3::X);
        let x2 = self.to_world.transform_vector3(Vec3::Y);
        let ext = (x1 * x1 + x2 * x2).powf(0.5);
        let p0 = self.to_world.transform_point3(Vec3::ZERO);
        let p1 = self.to_world.transform_point3(Vec3::Z);
        ((p0 - ext).min(p1 - ext), (p0 + ext).max(p1 + ext))
    }

    /// The nearest hit of the ray o + t·d with t in the open interval (tnear, tfar): the roots of
    /// the infinite tube in object space (f64, like Mitsuba's scalar variants; the small root from
    /// the product of the roots), kept where 0 ≤ z ≤ 1.
    pub fn hit(&self, o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> Option<f32> {
        let o = self.to_object_d.transform_point3(o.as_dvec3());
        let d = self.to_object_d.transform_vector3(d.as_dvec3());
        let a = d.x * d.x + d.y * d.y;
        let b = 2.0 * (d.x * o.x + d.y * o.y);
        let c = o.x * o.x + o.y * o.y - 1.0;
        let disc = b * b - 4.0 * a * c;
        if !(a > 0.0 && disc >= 0.0) {
            return None;
        }
        let q = -0.5 * (b + disc.sqrt().copysign(b));
        let t0 = q / a;
        let t1 = if q != 0.0 { c / q } else { t0 };
        let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
        [t0, t1].into_iter().find_map(|t| {
            let z = o.z + d.z * t;
            let tf = t as f32;
            (tf > tnear && tf < tfar && (0.0..=1.0).contains(&z)).then_some(tf)
        })
    }

    /// The surface point, outward unit normal, uv, dp/du and dp/dv at (or nearest to) the world
    /// point `p`, which is reprojected onto the tube.
    pub fn surface(&self, p: Vec3) -> (Vec3, Vec3, Vec2, Vec3, Vec3) {
        let l = self.to_object.transform_point3(p);
        let r = (l.x * l.x + l.y * l.y).sqrt();
        let (x, y) = if r > 0.0 {
            (l.x / r, l.y / r)
        } else {
            (1.0, 0.0)
        };
        let mut phi = y.atan2(x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let (uv, p) = (Vec2::new(phi * INV_2PI, l.z), Vec3::new(x, y, l.z));
        self.at(p, uv)
    }

    /// A point uniformly distributed by area: φ = 2π·u.y, z = u.x, uv = (u.y, u.x), as Mitsuba's
    /// `Cylinder::sample_position`. Returns the point, outward normal and uv.
    pub fn sample_position(&self, u: Vec2) -> (Vec3, Vec3, Vec2) {
        let (s, c) = (2.0 * PI * u.y).sin_cos();
        let (p, n, uv, _, _) = self.at(Vec3::new(c, s, u.x), Vec2::new(u.y, u.x));
        (p, n, uv)
    }

    /// Everything at the object-space surface point `l` = (cos φ, sin φ, z) with uv `uv`.
    fn at(&self, l: Vec3, uv: Vec2) -> (Vec3, Vec3, Vec2, Vec3, Vec3) {
        let p = self.to_world.transform_point3(l);
        let n = self
            .to_object
            .transpose()
            .transform_vector3(Vec3::new(l.x, l.y, 0.0))
            .try_normalize()
            .unwrap_or(Vec3::Z);
        let dpdu = self
            .to_world
            .transform_vector3(Vec3::new(-l.y, l.x, 0.0) * (2.0 * PI));
        let dpdv = self.to_world.transform_vector3(Vec3::Z);
        (p, n, uv, dpdu, dpdv)
    }
}
