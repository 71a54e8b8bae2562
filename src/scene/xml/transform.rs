//! `<transform>`: the operations (`translate`, `scale`, `rotate`, `matrix`, `lookat`) composed as
//! Mitsuba 3 composes them, each left-multiplied (`transform = op * transform`).
//!
//! Mitsuba 3.9.1 keeps a transform as its matrix *and* an inverse transpose, composed
//! separately, and `<rotate>` quirks both:
//! - the matrix is Rodrigues' formula with the axis as written, `cos θ·I + sin θ·[a]× +
//!   (1 − cos θ)·a·aᵀ` (drjit's `rotate`, `include/drjit/transform.h`), not normalised: a
//!   non-unit axis also scales (by `cos θ + (1 − cos θ)·|a|²` along it);
//! - its "inverse transpose" is set to that same matrix (`Transform::rotate` in
//!   `include/mitsuba/core/transform.h`: `Transform(matrix, matrix)`), right only for a true
//!   rotation. Mesh vertex normals follow the stored inverse transpose (`PackedMesh`), and
//!   `Transform::inverse()` is its transpose (the spot and projector lights use it).
//!
//! groove matches the matrix everywhere, and the stored inverse transpose (or its transpose,
//! Mitsuba's inverse) wherever Mitsuba 3.9.1 uses it: meshes (`obj`, `ply`, `serialized`,
//! `cube`) and the `rectangle` (a mesh in 3.9.1) transform their vertex normals by it (the
//! rectangle's geometric normal stays the true one); the `disk` is intersected in the object
//! space of that inverse (which moves the disk that rays meet off the one that is sampled) and
//! takes its normal from it; a non-similar `sphere` evaluates its uv map through it; an
//! `instance` maps normals by it and takes rays to group space by its transpose; `spot` and
//! `projector` take directions to their frame by it; a `cylinder` is traced in the object space
//! of that inverse and samples normals by the stored inverse transpose. It warns at every
//! `<rotate>` whose axis is not unit length ([`non_unit_rotations`]). A transform whose
//! rotations all have unit axes carries no separate inverse transpose: the true one is used, bit
//! for bit as before.

use super::ir::Node;
use super::props::{parse_f32, parse_list, vec3_attr, xyz_of};
use crate::error::{Error, Result};
use glam::{DMat3, DVec3, Mat3, Mat4, Vec3, Vec4};

/// A `<transform>` as Mitsuba holds it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Transform {
    pub matrix: Mat4,
    /// Mitsuba's separately composed inverse transpose, present only when a `<rotate>` had a
    /// non-unit axis (it then differs from the true inverse transpose of `matrix`).
    pub quirk_inverse_transpose: Option<Mat4>,
}

impl Transform {
    pub const IDENTITY: Transform = Transform {
        matrix: Mat4::IDENTITY,
        quirk_inverse_transpose: None,
    };

    /// The matrix normals are transformed by (before normalisation), as in Mitsuba.
    pub fn normal_matrix(&self) -> Mat3 {
        match self.quirk_inverse_transpose {
            Some(it) => Mat3::from_mat4(it),
            None => Mat3::from_mat4(self.matrix.inverse().transpose()),
        }
    }

    /// Mitsuba's `Transform::inverse()`: the transpose of the stored inverse transpose (the
    /// true inverse unless a `<rotate>` had a non-unit axis).
    pub fn inverse(&self) -> Mat4 {
        match self.quirk_inverse_transpose {
            Some(it) => it.transpose(),
            None => self.matrix.inverse(),
        }
    }
}

/// The matrix of a `<transform>`.
pub fn transform_of(t: &Node) -> Result<Mat4> {
    transform_full(t).map(|t| t.matrix)
}

/// A `<transform>` with Mitsuba's inverse transpose (see the module comment).
pub fn transform_full(t: &Node) -> Result<Transform> {
    let mut m = Mat4::IDENTITY;
    // Mitsuba's inverse transpose, composed alongside while any rotation is quirky.
    let mut it = Mat4::IDENTITY;
    let mut quirk = false;
    for op in &t.children {
        let (step, step_it) = match op.tag.as_str() {
            "translate" => (Mat4::from_translation(xyz_of(op, 0.0)?), None),
            "scale" => (Mat4::from_scale(xyz_of(op, 1.0)?), None),
            "rotate" => {
                let axis = xyz_of(op, 0.0)?;
                let Some(angle) = op.attr("angle") else {
                    return Err(Error::scene(&op.loc, "<rotate> needs an 'angle' (degrees)"));
                };
                let angle = parse_f32(angle, op.attr_loc("angle"))?;
                if axis.length_squared() == 0.0 {
                    return Err(Error::scene(&op.loc, "<rotate> needs a non-zero axis"));
                }
                if axis.length_squared() == 1.0 {
                    (Mat4::from_axis_angle(axis, angle.to_radians()), None)
                } else {
                    let r = Mat4::from_mat3(rotate_raw(axis, angle));
                    quirk = true;
                    (r, Some(r))
                }
            }
            "matrix" => (matrix_op(op)?, None),
            "lookat" => (look_at(op)?, None),
            other => {
                return Err(Error::scene(
                    &op.loc,
                    format!("<{other}> is not a transform operation"),
                ))
            }
        };
        m = step * m;
        it = step_it.unwrap_or_else(|| step.inverse().transpose()) * it;
    }
    if !m.is_finite() {
        return Err(Error::scene(&t.loc, "transform is not finite"));
    }
    // A singular step (a zero scale) has no inverse; Mitsuba's normals would be NaN there, and
    // groove keeps the true (equally undefined) inverse transpose rather than store NaN.
    let quirk_inverse_transpose = (quirk && it.is_finite()).then_some(it);
    Ok(Transform {
        matrix: m,
        quirk_inverse_transpose,
    })
}

/// Mitsuba's `<rotate>` matrix: Rodrigues' formula with `axis` as given (not normalised), angle
/// in degrees; computed in double precision as Mitsuba's parser does.
pub fn rotate_raw(axis: Vec3, angle_deg: f32) -> Mat3 {
    let a = axis.as_dvec3();
    let (s, c) = (angle_deg as f64).to_radians().sin_cos();
    let cross = DMat3::from_cols(
        DVec3::new(0.0, a.z, -a.y),
        DVec3::new(-a.z, 0.0, a.x),
        DVec3::new(a.y, -a.x, 0.0),
    );
    let outer = DMat3::from_cols(a * a.x, a * a.y, a * a.z);
    (DMat3::from_diagonal(DVec3::splat(c)) + cross * s + outer * (1.0 - c)).as_mat3()
}

/// A warning for every `<rotate>` under `root` whose axis is not unit length (relative error
/// above 1e-4): Mitsuba does not normalise it (see the module comment).
pub fn non_unit_rotations(root: &Node, out: &mut Vec<String>) {
    if root.tag == "rotate" {
        if let Ok(a) = xyz_of(root, 0.0) {
            let len = a.length();
            if len > 0.0 && (len - 1.0).abs() > 1e-4 {
                out.push(format!(
                    "{}: <rotate> axis ({}, {}, {}) has length {len}, not 1: as in Mitsuba 3.9.1 \
                     it is used unnormalised, so the transform also scales along the axis, and \
                     normals (and a disk's, a cylinder's or an instance's object space) follow \
                     that matrix instead of its inverse transpose (groove matches Mitsuba); \
                     normalise the axis for a pure rotation",
                    root.loc, a.x, a.y, a.z
                ));
            }
        }
    }
    for c in &root.children {
        non_unit_rotations(c, out);
    }
}

/// `<matrix>`: 16 (or 9) values, row-major.
fn matrix_op(op: &Node) -> Result<Mat4> {
    let loc = op.attr_loc("value");
    let text = op.attr("value").unwrap_or_default();
    let n = parse_list(text, loc)?;
    match n.len() {
        // Row-major in the file; glam is column-major.
        16 => Ok(Mat4::from_cols_slice(&n).transpose()),
        9 => {
            let r = |i: usize| Vec4::new(n[3 * i], n[3 * i + 1], n[3 * i + 2], 0.0);
            Ok(Mat4::from_cols(r(0), r(1), r(2), Vec4::W).transpose())
        }
        k => Err(Error::scene(
            loc,
            format!("<matrix> needs 16 (or 9) values, got {k}"),
        )),
    }
}

/// Mitsuba 3's look-at (camera to world): columns `left = normalize(up × dir)`,
/// `new_up = dir × left`, `dir = normalize(target − origin)`, `origin`. A missing or zero `up`
/// is replaced by a vector perpendicular to `dir` (Mitsuba's `coordinate_system`); a degenerate
/// result (e.g. `up` parallel to the view direction) is an error.
fn look_at(op: &Node) -> Result<Mat4> {
    let origin = vec3_attr(op, "origin")?;
    let target = vec3_attr(op, "target")?;
    let mut up = if op.attr("up").is_some() {
        vec3_attr(op, "up")?
    } else {
        Vec3::ZERO
    };
    let dir = (target - origin).normalize();
    if !dir.is_finite() {
        return Err(Error::scene(
            &op.loc,
            "invalid lookat transformation: origin and target coincide",
        ));
    }
    if up.length_squared() == 0.0 {
        up = coordinate_system_s(dir);
    }
    let left = up.cross(dir).normalize();
    let new_up = dir.cross(left);
    let m = Mat4::from_cols(
        left.extend(0.0),
        new_up.extend(0.0),
        dir.extend(0.0),
        origin.extend(1.0),
    );
    if !m.is_finite() {
        return Err(Error::scene(
            &op.loc,
            "invalid lookat transformation: 'up' is parallel to the viewing direction",
        ));
    }
    Ok(m)
}

/// First tangent of the orthonormal basis around `n` (Duff et al. 2017), as Mitsuba's
/// `coordinate_system`.
fn coordinate_system_s(n: Vec3) -> Vec3 {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x)
}
