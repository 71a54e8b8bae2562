//! Indexed triangle meshes: the common currency of the OBJ/PLY loaders and of Mitsuba's `cube`.

use crate::lane::Row8;
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

/// A mesh's vertices as interleaved rows ([`TriMesh::vertex_rows`]): row `i` holds vertex
/// `i`'s position (fields 0–2), shading normal (3–5) and uv (6–7).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VertexRows {
    pub rows: Vec<Row8>,
    /// The mesh has vertex normals (else fields 3–5 are zero).
    pub has_normals: bool,
    /// The mesh has uvs (else fields 6–7 are zero).
    pub has_uvs: bool,
}

impl VertexRows {
    /// Vertex `i`'s position.
    #[inline(always)]
    pub fn p(&self, i: u32) -> Vec3 {
        let r = &self.rows[i as usize].0;
        Vec3::new(r[0], r[1], r[2])
    }
    /// Vertex `i`'s normal (zero without normals).
    #[inline(always)]
    pub fn n(&self, i: u32) -> Vec3 {
        let r = &self.rows[i as usize].0;
        Vec3::new(r[3], r[4], r[5])
    }
    /// Vertex `i`'s uv (zero without uvs).
    #[inline(always)]
    pub fn uv(&self, i: u32) -> Vec2 {
        let r = &self.rows[i as usize].0;
        Vec2::new(r[6], r[7])
    }
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

    /// One interleaved row per vertex for the render's surface lookups: position, normal, uv
    /// (`px py pz nx ny nz u v`, [`Row8`]), so that a hit's three vertices are three half
    /// cache lines instead of up to nine lines in three arrays. A mesh without normals or
    /// uvs holds zeros there (what the lane forms are given for absent attributes). Built once
    /// per shape ([`super::Shape`]); the mesh must be valid ([`TriMesh::validate`]: one normal
    /// and uv per vertex).
    pub fn vertex_rows(&self) -> VertexRows {
        let n = |i: usize| self.normals.as_ref().map_or(Vec3::ZERO, |ns| ns[i]);
        let t = |i: usize| self.uvs.as_ref().map_or(Vec2::ZERO, |ts| ts[i]);
        let rows = self
            .positions
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let (n, t) = (n(i), t(i));
                Row8([p.x, p.y, p.z, n.x, n.y, n.z, t.x, t.y])
            })
            .collect();
        VertexRows {
            rows,
            has_normals: self.normals.is_some(),
            has_uvs: self.uvs.is_some(),
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

    /// Values a vertex can hold in the rows' tests: edge cases (±0, subnormals, the largest
    /// finite, ±∞, NaN with a payload) and random bit patterns.
    fn edge_or_random(k: usize, r: &mut crate::math::Pcg32) -> f32 {
        const EDGES: [f32; 9] = [
            0.0,
            -0.0,
            f32::MIN_POSITIVE,
            1e-40,
            -1e-45,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1.5,
        ];
        match k % 3 {
            0 => EDGES[(k / 3) % EDGES.len()],
            1 => f32::from_bits(0x7fc0_1234 | (k as u32 & 1) << 31),
            _ => f32::from_bits(r.next_u32()),
        }
    }

    /// A mesh of `n` vertices with every kind of value, with or without normals and uvs.
    fn odd_mesh(n: usize, normals: bool, uvs: bool) -> TriMesh {
        let mut r = crate::math::Pcg32::new(7, n as u64);
        let mut k = 0;
        let mut f = || {
            k += 1;
            edge_or_random(k, &mut r)
        };
        let mut v3 = || Vec3::new(f(), f(), f());
        let positions: Vec<Vec3> = (0..n).map(|_| v3()).collect();
        let ns: Vec<Vec3> = (0..n).map(|_| v3()).collect();
        let ts: Vec<Vec2> = (0..n).map(|_| Vec2::new(f(), f())).collect();
        TriMesh {
            positions,
            normals: normals.then_some(ns),
            uvs: uvs.then_some(ts),
            indices: vec![[0, 1, 2]],
        }
    }

    #[test]
    fn vertex_rows_hold_the_arrays_bit_for_bit() {
        for (normals, uvs) in [(true, true), (true, false), (false, true), (false, false)] {
            let m = odd_mesh(300, normals, uvs);
            let rows = m.vertex_rows();
            assert_eq!((rows.has_normals, rows.has_uvs), (normals, uvs));
            assert_eq!(rows.rows.len(), m.positions.len());
            for (i, row) in rows.rows.iter().enumerate() {
                let n = m.normals.as_ref().map_or(Vec3::ZERO, |ns| ns[i]);
                let t = m.uvs.as_ref().map_or(Vec2::ZERO, |ts| ts[i]);
                let p = m.positions[i];
                let want = [p.x, p.y, p.z, n.x, n.y, n.z, t.x, t.y].map(f32::to_bits);
                assert_eq!(row.0.map(f32::to_bits), want, "vertex {i}");
                let k = i as u32;
                assert_eq!(
                    rows.p(k).to_array().map(f32::to_bits),
                    [0, 1, 2].map(|c| want[c])
                );
                assert_eq!(
                    rows.n(k).to_array().map(f32::to_bits),
                    [3, 4, 5].map(|c| want[c])
                );
                assert_eq!(
                    rows.uv(k).to_array().map(f32::to_bits),
                    [6, 7].map(|c| want[c])
                );
            }
        }
    }

    /// A shape's rows are its mesh's vertices; the shape's mesh keeps positions and indices.
    #[test]
    fn a_mesh_shape_reads_its_vertices_from_the_rows() {
        let mut m = quad();
        m.uvs = Some(vec![Vec2::ZERO, Vec2::X, Vec2::ONE, Vec2::new(-0.0, 1e-40)]);
        m.normals = Some(vec![Vec3::Z, Vec3::Z, -Vec3::Z, Vec3::new(0.0, 0.6, 0.8)]);
        let want = m.vertex_rows();
        let s = crate::geometry::Shape::from_mesh(m.clone(), false, false).unwrap();
        assert_eq!(s.vertex_rows().rows.len(), 4);
        for (a, b) in s.vertex_rows().rows.iter().zip(&want.rows) {
            assert_eq!(a.0.map(f32::to_bits), b.0.map(f32::to_bits));
        }
        assert!(s.vertex_rows().has_normals && s.vertex_rows().has_uvs);
        let crate::geometry::ShapeKind::Mesh(sm) = &s.kind else {
            panic!("a mesh")
        };
        assert_eq!((&sm.positions, &sm.indices), (&m.positions, &m.indices));
        assert!(sm.normals.is_none() && sm.uvs.is_none());
        // Face normals: no normals in the rows; no uvs: zeros there.
        m.uvs = None;
        let s = crate::geometry::Shape::from_mesh(m, false, true).unwrap();
        let rows = s.vertex_rows();
        assert!(!rows.has_normals && !rows.has_uvs);
        assert!(rows.rows.iter().all(|r| r.0[3..] == [0.0; 5]));
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
