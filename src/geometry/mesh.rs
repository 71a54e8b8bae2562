//! Indexed triangle meshes: the common currency of the OBJ/PLY loaders and of Mitsuba's `cube`.

use glam::{Mat3, Mat4, Vec2, Vec3};

/// An indexed triangle mesh in world space (after [`TriMesh::transform`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TriMesh {
    pub positions: Vec<Vec3>,
    /// Per-vertex shading normals (unit), when the file had them or they were computed.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates.
    pub uvs: Option<Vec<Vec2>>,
    /// Triangles as vertex indices; the winding defines the geometric normal `(p1−p0)×(p2−p0)`.
    pub indices: Vec<[u32; 3]>,
}

impl TriMesh {
    /// Applies an affine transform: positions by `to_world`, normals by its inverse transpose
    /// (renormalised), so normals stay perpendicular under non-uniform scale.
    pub fn transform(&mut self, to_world: &Mat4) {
        self.transform_with_normals(to_world, None);
    }

    /// [`TriMesh::transform`] whose vertex normals follow `normal_matrix` instead of the
    /// inverse transpose of `to_world` (Mitsuba's stored inverse transpose after a `<rotate>`
    /// with a non-unit axis, see `scene::xml::transform`).
    pub fn transform_with_normals(&mut self, to_world: &Mat4, normal_matrix: Option<&Mat3>) {
        for p in &mut self.positions {
            *p = to_world.transform_point3(*p);
        }
        if let Some(ns) = &mut self.normals {
            match normal_matrix {
                Some(nm) => {
                    for n in ns {
                        *n = (*nm * *n).normalize_or_zero();
                    }
                }
                None => {
                    let inv_t = to_world.inverse().transpose();
                    for n in ns {
                        *n = inv_t.transform_vector3(*n).normalize_or_zero();
                    }
                }
            }
        }
    }

    /// Checks the invariants the renderer relies on: every index in range, finite positions,
    /// normals and uvs, and one normal / uv per vertex. Returns a human-readable reason.
    pub fn validate(&self) -> Result<(), String> {
        let nv = self.positions.len();
        if self.indices.is_empty() {
            return Err("mesh has no triangles".into());
        }
        if let Some((i, p)) = self
            .positions
            .iter()
            .enumerate()
            .find(|(_, p)| !p.is_finite())
        {
            return Err(format!("vertex {i} has a non-finite position {p}"));
        }
        if let Some(ns) = &self.normals {
            if ns.len() != nv {
                return Err(format!("{} normals for {nv} vertices", ns.len()));
            }
            if let Some(i) = ns.iter().position(|n| !n.is_finite()) {
                return Err(format!("vertex {i} has a non-finite normal"));
            }
        }
        if let Some(uvs) = &self.uvs {
            if uvs.len() != nv {
                return Err(format!("{} uvs for {nv} vertices", uvs.len()));
            }
            if let Some(i) = uvs.iter().position(|t| !t.is_finite()) {
                return Err(format!("vertex {i} has a non-finite uv"));
            }
        }
        for (f, tri) in self.indices.iter().enumerate() {
            if let Some(&i) = tri.iter().find(|&&i| i as usize >= nv) {
                return Err(format!(
                    "triangle {f} uses vertex index {i}, but there are only {nv} vertices"
                ));
            }
        }
        Ok(())
    }

    /// Smooth vertex normals as Mitsuba 3 computes them for meshes without normals
    /// (`Mesh::recompute_vertex_normals`): each face's unit normal, weighted by the face's
    /// interior angle at the vertex (Thürmer & Wüthrich 1998, "Computing Vertex Normals from
    /// Polygonal Facets"). Degenerate faces contribute nothing; a vertex with no valid face
    /// gets +Z rather than NaN. Indices must be valid (call [`TriMesh::validate`] first).
    pub fn compute_vertex_normals(&mut self) {
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for tri in &self.indices {
            let v = tri.map(|i| self.positions[i as usize]);
            let n = (v[1] - v[0]).cross(v[2] - v[0]);
            let len2 = n.length_squared();
            if !(len2.is_finite() && len2 > 0.0) {
                continue;
            }
            let n = n / len2.sqrt();
            for k in 0..3 {
                let d0 = (v[(k + 1) % 3] - v[k]).normalize_or_zero();
                let d1 = (v[(k + 2) % 3] - v[k]).normalize_or_zero();
                let angle = d0.dot(d1).clamp(-1.0, 1.0).acos();
                acc[tri[k] as usize] += n * angle;
            }
        }
        for n in &mut acc {
            *n = n.try_normalize().unwrap_or(Vec3::Z);
        }
        self.normals = Some(acc);
    }

    /// Reverses every triangle's winding (swaps its last two vertices), which negates the
    /// geometric normal, and negates the vertex normals. Shapes implement `flip_normals` without
    /// this (they negate at the hit, which keeps Embree's barycentrics as Mitsuba's); it is here
    /// for tools that want a physically flipped mesh.
    pub fn flip(&mut self) {
        for t in &mut self.indices {
            t.swap(1, 2);
        }
        if let Some(ns) = &mut self.normals {
            for n in ns {
                *n = -*n;
            }
        }
    }

    /// The area of triangle `i`.
    #[inline]
    pub fn triangle_area(&self, i: usize) -> f32 {
        let [a, b, c] = self.indices[i].map(|k| self.positions[k as usize]);
        0.5 * (b - a).cross(c - a).length()
    }

    /// Total surface area.
    pub fn area(&self) -> f32 {
        (0..self.indices.len())
            .map(|i| self.triangle_area(i) as f64)
            .sum::<f64>() as f32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad() -> TriMesh {
        TriMesh {
            positions: vec![
                Vec3::new(0.0, 0.0, 0.0),
                Vec3::new(1.0, 0.0, 0.0),
                Vec3::new(1.0, 1.0, 0.0),
                Vec3::new(0.0, 1.0, 0.0),
            ],
            normals: None,
            uvs: None,
            indices: vec![[0, 1, 2], [0, 2, 3]],
        }
    }

    #[test]
    fn area_and_normals_of_a_flat_quad() {
        let mut m = quad();
        assert!((m.area() - 1.0).abs() < 1e-6);
        m.compute_vertex_normals();
        for n in m.normals.as_ref().unwrap() {
            assert!((*n - Vec3::Z).length() < 1e-6);
        }
    }

    #[test]
    fn angle_weighting_is_independent_of_tessellation() {
        // A vertex at the corner of a 90° fold: one face on each side, but one side split
        // into two triangles. Angle weighting gives the bisector regardless of the split.
        let mut m = TriMesh {
            positions: vec![
                Vec3::ZERO,
                Vec3::X,
                Vec3::Y,
                Vec3::Z,
                Vec3::new(0.0, 1.0, 1.0),
            ],
            normals: None,
            uvs: None,
            // face in the XY plane (normal +Z) and the YZ plane split in two (normal +X)
            indices: vec![[0, 1, 2], [0, 2, 4], [0, 4, 3]],
        };
        m.compute_vertex_normals();
        let n0 = m.normals.as_ref().unwrap()[0];
        let expect = Vec3::new(1.0, 0.0, 1.0).normalize();
        assert!((n0 - expect).length() < 1e-5, "{n0}");
    }

    #[test]
    fn validate_catches_bad_data() {
        let mut m = quad();
        assert!(m.validate().is_ok());
        m.indices.push([0, 1, 7]);
        assert!(m.validate().unwrap_err().contains("index 7"));
        let mut m = quad();
        m.positions[1].x = f32::NAN;
        assert!(m.validate().is_err());
        let mut m = quad();
        m.uvs = Some(vec![Vec2::ZERO]);
        assert!(m.validate().is_err());
    }

    #[test]
    fn transform_keeps_normals_perpendicular() {
        let mut m = TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: None,
            uvs: None,
            indices: vec![[0, 1, 2]],
        };
        m.positions = vec![Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Z];
        m.compute_vertex_normals();
        let s = Mat4::from_scale(Vec3::new(3.0, 1.0, 0.5));
        m.transform(&s);
        let e0 = m.positions[1] - m.positions[0];
        let e1 = m.positions[2] - m.positions[0];
        let n = m.normals.as_ref().unwrap()[0];
        assert!(n.dot(e0).abs() < 1e-5 && n.dot(e1).abs() < 1e-5);
        assert!((n.length() - 1.0).abs() < 1e-5);
    }
}
