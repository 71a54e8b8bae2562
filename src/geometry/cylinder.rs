//! Mitsuba 3's `cylinder` shape (`src/shapes/cylinder.cpp`): the open tube x² + y² = 1,
//! 0 ≤ z ≤ 1 of object space (no caps), placed by `p0`, `p1`, `radius` and `to_world`.
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | `p0`, `p1` | point | (0,0,0), (0,0,1) | centres of the two ends (object space, before `to_world`) |
//! | `radius` | float | 1 | radius (a negative one gives the same tube with u turned by ½, as in Mitsuba) |
//! | `flip_normals` | boolean | false | normals point toward the axis (an area emitter then emits inward) |
//! | `to_world` | transform | identity | applied after p0/p1/radius (any invertible affine map) |
//!
//! The object-to-world map is M = to_world · translate(p0) · frame(p1 − p0) · scale(r, r, |p1 − p0|)
//! where frame(d) has the columns (s, t, d) of Mitsuba's `coordinate_system(d)` (Duff et al.
//! 2017; [`Frame::from_normal`]), which fixes where u = 0 lies around the axis.
//! Parameterisation at the object-space point (cos φ, sin φ, z): uv = (φ/2π, z) with φ ∈ [0, 2π),
//! dp/du = M·2π(−sin φ, cos φ, 0), dp/dv = M·(0,0,1); the normal is the outward radial
//! direction (the normal transform of (cos φ, sin φ, 0)) unless `flip_normals`.
//! `sample_position`: φ = 2π·ξ₂, z = ξ₁, uv = (ξ₂, ξ₁), pdf = 1/(2π r ℓ).
//!
//! What Mitsuba 3.9.1 does with a `to_world` that is not a similarity (`Cylinder::update`,
//! `ray_intersect_preliminary_impl`, `sample_position` in `src/shapes/cylinder.cpp`), and
//! groove with it:
//! - it warns, from the symmetric polar factor S of M (drjit's `transform_decompose`): "shouldn't
//!   contain any shearing" for off-diagonal entries, "non-uniform scaling along the X and Y
//!   axes" when S₀₀ ≠ S₁₁ (double precision here, tolerance 1e-4 relative to the largest scale,
//!   as for the sphere: Mitsuba's 1e-6 absolute in single precision);
//! - rays meet the exact affine image of the unit tube (an elliptic tube when the scale across
//!   the axis is uneven, a slanted one under a shear): the ray is taken to object space by
//!   Mitsuba's inverse of M;
//! - r = |M·(1,0,0)| and ℓ = |M·(0,0,1)|, so the area 2π r ℓ and the sampling density 1/(2π r ℓ),
//!   uniform in (φ, z), are those of a round tube: wrong for an ellipse, kept for parity;
//! - sampled normals are Mitsuba's normal transform (its stored inverse transpose) of
//!   (cos φ, sin φ, 0), hit normals the direction of dp/du × dp/dv turned outward.
//!
//! After a `<rotate>` with a non-unit axis Mitsuba's inverse of `to_world` is not the inverse of
//! its matrix (see `scene/xml/transform.rs`): rays then meet the tube of that quirky object
//! space, while positions are still sampled on M's tube and uv, dp/du, dp/dv come from M applied
//! to the quirky object-space point; the hit point stays the ray's (Mitsuba 3.9.1 moves it by
//! n·(1 − |local xy|), which is rounding there). groove's bounds hold both tubes, so no hit of
//! the traced one is culled (Mitsuba's box holds only M's).
//!
//! Mitsuba also gives a mirrored cylinder sampled normals opposite to its hit normals (it flips
//! the normals when S₀₀ < 0, which cancels the mirror in dp/du × dp/dv only); groove keeps both
//! outward (see the tests).

use crate::error::{Error, Result};
use crate::lane::math as lm;
use crate::math::{Frame, INV_2PI, PI};
use crate::scene::xml::props::Props;
use glam::{DMat4, Mat3, Mat4, Vec2, Vec3};

/// A cylinder in world space.
#[derive(Clone, Debug)]
pub struct Cylinder {
    /// Object (unit tube) to world: M.
    to_world: Mat4,
    /// The true inverse of M (its transpose maps radial directions to hit normals).
    to_object: Mat4,
    /// Mitsuba's inverse of M, which rays and hit points are taken to object space by: in f32
    /// (hit points) and in f64 (ray intersection). The true inverse unless a `<rotate>` had a
    /// non-unit axis.
    hit_to_object: Mat4,
    to_object_d: DMat4,
    /// True when `hit_to_object` is not M's inverse (the quirk above).
    quirk: bool,
    /// Mitsuba's normal matrix of M (the transpose of `hit_to_object`'s linear part), for
    /// sampled normals.
    normal_matrix: Mat3,
    /// r = |M·x| and ℓ = |M·z| (Mitsuba's radius and length).
    radius: f32,
    length: f32,
}

impl Cylinder {
    /// The cylinder from `p0` to `p1` of `radius` under `to_world` (Mitsuba's composition, see the
    /// module docs). Errors: a zero or non-finite radius, coinciding or non-finite end points, or
    /// a degenerate (singular or non-finite) transform.
    pub fn new(p0: Vec3, p1: Vec3, radius: f32, to_world: &Mat4) -> Result<Cylinder> {
        Cylinder::with_inverse(p0, p1, radius, to_world, None)
    }

    /// [`Cylinder::new`] with Mitsuba's inverse of `to_world` when it is not the true one (after
    /// a `<rotate>` with a non-unit axis; see the module docs).
    pub fn with_inverse(
        p0: Vec3,
        p1: Vec3,
        radius: f32,
        to_world: &Mat4,
        inverse: Option<&Mat4>,
    ) -> Result<Cylinder> {
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
        let local =
            Mat4::from_translation(p0) * frame * Mat4::from_scale(Vec3::new(radius, radius, len));
        let m = *to_world * local;
        let (r, l) = (
            m.transform_vector3(Vec3::X).length(),
            m.transform_vector3(Vec3::Z).length(),
        );
        let det = Mat3::from_mat4(m).determinant();
        if !(m.is_finite() && r > 0.0 && l > 0.0 && det.is_finite() && det != 0.0) {
            return Err(err("to_world is degenerate".into()));
        }
        let to_object = m.inverse();
        // Mitsuba composes inverses separately: the steps' own inverses, then `to_world`'s.
        let hit_to_object = match inverse {
            Some(inv) => local.inverse() * *inv,
            None => to_object,
        };
        let hit_d = match inverse {
            Some(inv) => local.as_dmat4().inverse() * inv.as_dmat4(),
            None => m.as_dmat4().inverse(),
        };
        let det_hit = Mat3::from_mat4(hit_to_object).determinant();
        if !(to_object.is_finite() && hit_to_object.is_finite() && det_hit != 0.0) {
            return Err(err("to_world is not invertible".into()));
        }
        Ok(Cylinder {
            to_world: m,
            to_object,
            hit_to_object,
            to_object_d: hit_d,
            quirk: inverse.is_some(),
            normal_matrix: Mat3::from_mat4(hit_to_object).transpose(),
            radius: r,
            length: l,
        })
    }

    /// Mitsuba 3.9.1's warnings for this cylinder's map M (see the module docs): shear, and an
    /// uneven scale across the axis.
    pub fn warnings(&self) -> Vec<&'static str> {
        super::sphere_map::similarity_warnings(
            &self.to_world,
            false,
            "'to_world' transform shouldn't contain non-uniform scaling along the X and Y axes!",
        )
    }

    /// The `cylinder` shape element's own parameters (`p0`, `p1`, `radius`); the loader reads
    /// `to_world` (with Mitsuba's inverse when it differs, see [`Cylinder::with_inverse`]) and
    /// `flip_normals`, which every shape has.
    pub fn from_props(p: &Props<'_>, to_world: &Mat4, inverse: Option<&Mat4>) -> Result<Cylinder> {
        let p0 = p.point("p0", Vec3::ZERO)?;
        let p1 = p.point("p1", Vec3::Z)?;
        let radius = p.float("radius", 1.0)?;
        let c = Cylinder::with_inverse(p0, p1, radius, to_world, inverse)
            .map_err(|e| Error::scene(p.loc(), e.to_string()))?;
        Ok(c)
    }

    /// Surface area 2π r ℓ.
    pub fn area(&self) -> f32 {
        2.0 * PI * self.radius * self.length
    }

    /// Axis-aligned world bounds: the box around the two end circles of M's tube (Mitsuba's
    /// `bbox`), grown to hold the traced tube when that is another (the quirk in the module docs).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let (lo, hi) = tube_box(&self.to_world);
        if self.quirk {
            let (l2, h2) = tube_box(&self.hit_to_object.inverse());
            (lo.min(l2), hi.max(h2))
        } else {
            (lo, hi)
        }
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
    /// point `p` of a hit: reprojected onto the tube, unless the traced tube is not M's (then the
    /// ray's point itself, as Mitsuba).
    pub fn surface(&self, p: Vec3) -> (Vec3, Vec3, Vec2, Vec3, Vec3) {
        let l = self.hit_to_object.transform_point3(p);
        let r = (l.x * l.x + l.y * l.y).sqrt();
        let (x, y) = if r > 0.0 {
            (l.x / r, l.y / r)
        } else {
            (1.0, 0.0)
        };
        // The crate's own atan2 (not `f32::atan2`), which the stream renderer's lanes reproduce
        // bit for bit (`surface_lanes::cylinder`).
        let mut phi = lm::atan2(y, x);
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let l = Vec3::new(x, y, l.z);
        let uv = Vec2::new(phi * INV_2PI, l.z);
        // The direction of dp/du × dp/dv, outward: M⁻ᵀ·(x, y, 0).
        let n = normalised(Mat3::from_mat4(self.to_object).transpose(), l);
        let (dpdu, dpdv) = self.partials(l);
        let p = if self.quirk {
            p
        } else {
            self.to_world.transform_point3(l)
        };
        (p, n, uv, dpdu, dpdv)
    }

    /// What the lane form of [`Self::surface`] needs ([`super::surface_lanes::cylinder`]): M
    /// and Mitsuba's inverse of it as columns (the last the translation), the columns of the
    /// normal map M⁻ᵀ (linear part), dp/dv = M·(0, 0, 1) as [`Self::surface`] computes it, and
    /// whether the hit point stays the ray's (the quirk in the module docs).
    pub(crate) fn lanes(&self) -> CylinderLanes {
        let col = |m: &Mat4, j: usize| m.col(j).truncate();
        let nm = Mat3::from_mat4(self.to_object).transpose();
        CylinderLanes {
            to_world: [0, 1, 2, 3].map(|j| col(&self.to_world, j)),
            to_object: [0, 1, 2, 3].map(|j| col(&self.hit_to_object, j)),
            normal: [nm.x_axis, nm.y_axis, nm.z_axis],
            dpdv: self.partials(Vec3::ZERO).1,
            quirk: self.quirk,
        }
    }

    /// A point by (φ, z): φ = 2π·u.y, z = u.x, uv = (u.y, u.x), as Mitsuba's
    /// `Cylinder::sample_position` (uniform by area for a round tube). Returns the point, the
    /// normal by Mitsuba's normal matrix (outward) and uv.
    pub fn sample_position(&self, u: Vec2) -> (Vec3, Vec3, Vec2) {
        let (s, c) = (2.0 * PI * u.y).sin_cos();
        let l = Vec3::new(c, s, u.x);
        let p = self.to_world.transform_point3(l);
        let n = normalised(self.normal_matrix, l);
        (p, n, Vec2::new(u.y, u.x))
    }

    /// dp/du = M·2π(−y, x, 0) and dp/dv = M·(0, 0, 1) at the object-space point `l`.
    fn partials(&self, l: Vec3) -> (Vec3, Vec3) {
        let dpdu = self
            .to_world
            .transform_vector3(Vec3::new(-l.y, l.x, 0.0) * (2.0 * PI));
        (dpdu, self.to_world.transform_vector3(Vec3::Z))
    }
}

/// A cylinder's constants for the lane form of its hit reconstruction ([`Cylinder::lanes`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct CylinderLanes {
    pub to_world: [Vec3; 4],
    pub to_object: [Vec3; 4],
    pub normal: [Vec3; 3],
    pub dpdv: Vec3,
    pub quirk: bool,
}

/// `n`·(l.x, l.y, 0), normalised (+z if it vanishes).
fn normalised(n: Mat3, l: Vec3) -> Vec3 {
    (n * Vec3::new(l.x, l.y, 0.0))
        .try_normalize()
        .unwrap_or(Vec3::Z)
}

/// The box around the end circles of the unit tube under `m` (per axis, the circle's extent is
/// the length of the row of its two spanning vectors).
fn tube_box(m: &Mat4) -> (Vec3, Vec3) {
    let x1 = m.transform_vector3(Vec3::X);
    let x2 = m.transform_vector3(Vec3::Y);
    let ext = (x1 * x1 + x2 * x2).powf(0.5);
    let p0 = m.transform_point3(Vec3::ZERO);
    let p1 = m.transform_point3(Vec3::Z);
    ((p0 - ext).min(p1 - ext), (p0 + ext).max(p1 + ext))
}
