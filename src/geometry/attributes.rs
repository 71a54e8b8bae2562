//! Mesh attributes: extra per-vertex or per-face values a mesh file carries (Mitsuba 3's
//! `Mesh::add_attribute`, `src/render/mesh.cpp`), read by the `mesh_attribute` texture.
//!
//! An attribute is named `vertex_<x>` or `face_<x>` and holds `dim` f32 values per vertex or per
//! triangle. A vertex attribute is interpolated with the hit's barycentric coordinates, a face
//! attribute is constant over its triangle (Mitsuba's `interpolate_attribute`).

use super::TriMesh;
use glam::Vec3;

/// Whether an attribute has a value per vertex or per face.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Per {
    Vertex,
    Face,
}

/// One named attribute of a mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Attribute {
    /// The full name, `vertex_…` or `face_…` (Mitsuba's).
    pub name: String,
    pub per: Per,
    /// Values per vertex or face (1, 3, or 4 for a colour with alpha).
    pub dim: usize,
    /// `dim` values per vertex / face (per triangle: a polygon's value repeated for each of the
    /// triangles it was split into).
    pub data: Vec<f32>,
}

impl Attribute {
    /// Element `i`'s value as RGB: a one-value attribute in all three channels, else its first
    /// three values.
    #[inline]
    fn value(&self, i: usize) -> Vec3 {
        let d = &self.data[i * self.dim..];
        if self.dim == 1 {
            Vec3::splat(d[0])
        } else {
            Vec3::new(d[0], d[1], d[2])
        }
    }

    /// Bytes of the values (for the memory budget).
    pub fn bytes(&self) -> u64 {
        4 * self.data.len() as u64
    }

    /// The value at point `p` (world space) of triangle `prim` of `mesh`, the mesh the attribute
    /// belongs to: a face value, or the vertex values interpolated with `p`'s barycentric
    /// coordinates. Out-of-range indices (impossible for a validated mesh) give 0.
    pub fn eval(&self, mesh: &TriMesh, prim: u32, p: Vec3) -> Vec3 {
        let Some(tri) = mesh.indices.get(prim as usize) else {
            return Vec3::ZERO;
        };
        let count = self.data.len() / self.dim.max(1);
        match self.per {
            Per::Face => {
                if (prim as usize) < count {
                    self.value(prim as usize)
                } else {
                    Vec3::ZERO
                }
            }
            Per::Vertex => {
                if tri.iter().any(|&i| i as usize >= count) {
                    return Vec3::ZERO;
                }
                let [w, u, v] = barycentric(mesh, *tri, p);
                // Mitsuba: fmadd(v0, b0, fmadd(v1, b1, v2 · b2)).
                self.value(tri[0] as usize) * w
                    + (self.value(tri[1] as usize) * u + self.value(tri[2] as usize) * v)
            }
        }
    }
}

/// The barycentric coordinates (w, u, v) of `p` in triangle `tri`, recomputed from the position
/// as Mitsuba's `Mesh::barycentric_coordinates` does (least squares in the triangle's plane).
/// A degenerate triangle gives its first vertex.
fn barycentric(mesh: &TriMesh, tri: [u32; 3], p: Vec3) -> [f32; 3] {
    let [p0, p1, p2] = tri.map(|i| mesh.positions[i as usize]);
    let (rel, du, dv) = (p - p0, p1 - p0, p2 - p0);
    let (b1, b2) = (du.dot(rel), dv.dot(rel));
    let (a11, a12, a22) = (du.dot(du), du.dot(dv), dv.dot(dv));
    let inv_det = 1.0 / (a11 * a22 - a12 * a12);
    let u = (a22 * b1 - a12 * b2) * inv_det;
    let v = (a11 * b2 - a12 * b1) * inv_det;
    if !(u.is_finite() && v.is_finite()) {
        return [1.0, 0.0, 0.0];
    }
    [1.0 - u - v, u, v]
}

/// The attribute called `name` among `attrs`.
#[inline]
pub fn find<'a>(attrs: &'a [Attribute], name: &str) -> Option<&'a Attribute> {
    attrs.iter().find(|a| a.name == name)
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec2;

    #[test]
    fn vertex_values_interpolate_and_face_values_do_not() {
        let mesh = TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.0)],
            normals: None,
            uvs: None::<Vec<Vec2>>,
            indices: vec![[0, 1, 2], [1, 3, 2]],
        };
        let vc = Attribute {
            name: "vertex_color".into(),
            per: Per::Vertex,
            dim: 3,
            data: vec![1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0],
        };
        let got = vc.eval(&mesh, 0, Vec3::new(0.25, 0.5, 0.0));
        assert!(got.abs_diff_eq(Vec3::new(0.25, 0.25, 0.5), 1e-6), "{got}");
        let fw = Attribute {
            name: "face_w".into(),
            per: Per::Face,
            dim: 1,
            data: vec![0.5, 2.0],
        };
        assert_eq!(
            fw.eval(&mesh, 1, Vec3::new(0.9, 0.9, 0.0)),
            Vec3::splat(2.0)
        );
        assert_eq!(fw.eval(&mesh, 7, Vec3::ZERO), Vec3::ZERO);
        assert_eq!(find(&[vc.clone(), fw], "vertex_color"), Some(&vc));
    }
}
