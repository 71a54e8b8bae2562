//! The scene's shapes: triangle meshes (OBJ, PLY and Mitsuba's `cube` mesh, which Embree
//! intersects as an exact box) and the exact `rectangle`, `disk` and sphere; their surface
//! interactions and the area / solid-angle sampling used by area emitters. The `cylinder` and the
//! `sdfgrid` have their own files (`cylinder.rs`, `sdfgrid.rs`). Conventions follow
//! Mitsuba 3's shape plugins (`src/shapes/*.cpp`, `src/render/mesh.cpp` in
//! mitsuba-renderer/mitsuba3).

use super::attributes::Attribute;
use super::curves::Curves;
use super::cylinder::Cylinder;
use super::interaction::SurfaceInteraction;
use super::mesh::TriMesh;
use super::sdfgrid::SdfGrid;
use super::sphere_map::SphereMap;
use super::Hit;
use super::Ray;
use crate::error::{Error, Result};
use crate::lane::math as lm;
use crate::math::{warp, Frame, INV_2PI, PI};
use glam::{Mat3, Mat4, Vec2, Vec3};

/// What a shape is made of.
#[derive(Clone, Debug)]
pub enum ShapeKind {
    /// A triangle mesh in world space.
    Mesh(TriMesh),
    /// An exact sphere; `frame` is the rotation part of `to_world`, which orients the uv map.
    /// `map` is set when `to_world` is not a similarity (Mitsuba's sphere is then still this
    /// sphere, but its uv map goes through the transform: [`SphereMap`]; `frame` is unused).
    Sphere {
        center: Vec3,
        radius: f32,
        frame: Mat4,
        map: Option<SphereMap>,
    },
    /// Mitsuba's exact `disk`: the unit disk of the XY plane mapped by `to_world` (intersected by
    /// an Embree user geometry). Rays meet the image of that disk under `hit_to_world`, which is
    /// `to_world` itself except after a `<rotate>` with a non-unit axis: Mitsuba intersects the
    /// disk in the object space of its quirky inverse, so the disk it traces is another one than
    /// the disk it samples (see `scene/xml/transform.rs`).
    Disk { to_world: Mat4, hit_to_world: Mat4 },
    /// Mitsuba's exact `rectangle`: [−1,1]² of the XY plane mapped by `to_world` (an Embree user
    /// geometry like the disk: a scene of rectangles and spheres then needs a single Embree
    /// acceleration structure instead of one for triangles and one for user geometry, which
    /// halved Embree's instructions per ray on the benchmark scenes).
    Rectangle { to_world: Mat4 },
    /// Mitsuba's exact open `cylinder` (its own file: [`Cylinder`]), an Embree user geometry.
    Cylinder(Cylinder),
    /// Mitsuba's `linearcurve` / `bsplinecurve` (their own files: [`Curves`]), Embree's round
    /// curves. Never an emitter: it has no area and is never sampled.
    Curves(Curves),
    /// Mitsuba's `sdfgrid` (its own file: [`SdfGrid`]), an Embree user geometry of one primitive
    /// per occupied voxel (shared with the accelerator, hence the `Arc`). Never an emitter.
    SdfGrid(std::sync::Arc<SdfGrid>),
}

/// Mitsuba's `cube` (`cube.cpp`): the 4 corners of each face of [−1,1]³, in order around the
/// face (corner 0 → 1 and corner 0 → 3 are its two edges); their mean is the outward normal.
#[rustfmt::skip]
pub(crate) const CUBE_FACES: [[[f32; 3]; 4]; 6] = [
    [[1.0, -1.0, -1.0], [1.0, -1.0, 1.0], [-1.0, -1.0, 1.0], [-1.0, -1.0, -1.0]],
    [[1.0, 1.0, -1.0], [-1.0, 1.0, -1.0], [-1.0, 1.0, 1.0], [1.0, 1.0, 1.0]],
    [[1.0, -1.0, -1.0], [1.0, 1.0, -1.0], [1.0, 1.0, 1.0], [1.0, -1.0, 1.0]],
    [[1.0, -1.0, 1.0], [1.0, 1.0, 1.0], [-1.0, 1.0, 1.0], [-1.0, -1.0, 1.0]],
    [[-1.0, -1.0, 1.0], [-1.0, 1.0, 1.0], [-1.0, 1.0, -1.0], [-1.0, -1.0, -1.0]],
    [[1.0, 1.0, -1.0], [1.0, -1.0, -1.0], [-1.0, -1.0, -1.0], [-1.0, 1.0, -1.0]],
];

/// A shape ready for rendering: geometry plus the tables its sampling needs.
#[derive(Clone, Debug)]
pub struct Shape {
    pub kind: ShapeKind,
    /// Negates the geometric and shading normals (Mitsuba's `flip_normals`).
    pub flip_normals: bool,
    /// The mesh is shaded with its geometric normals (vertex normals were dropped).
    pub face_normals: bool,
    area: f32,
    /// Normalised cumulative triangle areas (meshes; empty for spheres).
    cdf: Vec<f32>,
    /// Inverse of the disk's or rectangle's `to_world` (identity for other shapes); for a disk,
    /// the inverse of `hit_to_world` (Mitsuba's quirky one after a non-unit `<rotate>`).
    to_object: Mat4,
    /// A rectangle's unit shading normal (before `flip_normals`) when Mitsuba's differs from the
    /// geometric one: after a non-unit `<rotate>`, Mitsuba 3.9.1's rectangle (a two-triangle
    /// mesh) takes its vertex normals through the quirky normal matrix.
    shading_normal: Option<Vec3>,
    /// Mitsuba 3.9.1's number of this shape in `scene.shapes()`, from 1: what the `aov`
    /// integrator's `shape_index` reports (0 for members of shape groups, whose hits report
    /// their instance's number; set by the loader).
    pub scene_index: u32,
    /// Mitsuba's `cube` under this invertible `to_world`: Embree intersects the exact box (one
    /// user-geometry primitive reporting the triangle and barycentrics the mesh would), so a
    /// scene of cubes, rectangles and spheres keeps a single acceleration structure.
    pub box_to_world: Option<Mat4>,
    /// A mesh's `vertex_…` / `face_…` attributes (from a PLY file), for `mesh_attribute`.
    attributes: Vec<Attribute>,
}

/// A point sampled uniformly on a shape's surface.
#[derive(Clone, Copy, Debug)]
pub struct PositionSample {
    pub p: Vec3,
    /// Unit normal at `p` on the emitting side (after `flip_normals`); the interpolated vertex
    /// normal when the mesh has one, as Mitsuba's `Mesh::sample_position`.
    pub n: Vec3,
    /// Unit geometric (face) normal at `p` (the winding's, after `flip_normals`): the normal of
    /// the area element itself, whose |cosine| converts area density to solid angle and weighs
    /// emitted flux (`L·|cos θ_g| dA dω`). Equals `n` except on meshes with vertex normals.
    pub ng: Vec3,
    pub uv: Vec2,
    /// Area density (1 / area).
    pub pdf: f32,
}

/// A point on a shape sampled as seen from a reference point.
#[derive(Clone, Copy, Debug)]
pub struct DirectionSample {
    pub p: Vec3,
    pub n: Vec3,
    pub uv: Vec2,
    /// Unit direction from the reference point to `p`.
    pub d: Vec3,
    pub dist: f32,
    /// Solid-angle density at the reference point.
    pub pdf: f32,
}

impl Shape {
    fn new_mesh(mesh: TriMesh, flip_normals: bool, face_normals: bool) -> Result<Shape> {
        mesh.validate().map_err(|m| Error::file("mesh", m))?;
        let mut acc = 0.0f64;
        let mut cdf: Vec<f32> = (0..mesh.indices.len())
            .map(|i| {
                acc += mesh.triangle_area(i) as f64;
                acc as f32
            })
            .collect();
        let area = acc as f32;
        if !area.is_finite() {
            return Err(Error::file(
                "mesh",
                format!("mesh has an invalid surface area ({area})"),
            ));
        }
        if area > 0.0 {
            for c in &mut cdf {
                *c /= area;
            }
            // From the last triangle with area on, the CDF is 1: trailing zero-area triangles
            // (which cannot be sampled, as in Mitsuba's area pmf) are never chosen.
            let last = (0..mesh.indices.len())
                .rev()
                .find(|&i| mesh.triangle_area(i) > 0.0)
                .unwrap_or(0);
            cdf[last..].iter_mut().for_each(|c| *c = 1.0);
        } else {
            // Zero total area: never hit, never sampled (the loader warns, and refuses it as an
            // area light as Mitsuba does).
            cdf.clear();
        }
        Ok(Shape {
            kind: ShapeKind::Mesh(mesh),
            flip_normals,
            face_normals,
            area,
            cdf,
            to_object: Mat4::IDENTITY,
            box_to_world: None,
            attributes: Vec::new(),
            shading_normal: None,
            scene_index: 0,
        })
    }

    /// The shape with mesh attributes `attributes` (each one's length checked against the
    /// mesh's vertex or triangle count). Only meshes carry attributes.
    pub fn with_attributes(mut self, attributes: Vec<Attribute>) -> Result<Shape> {
        use super::attributes::Per;
        let ShapeKind::Mesh(m) = &self.kind else {
            return Err(Error::file("mesh", "only meshes carry attributes"));
        };
        for a in &attributes {
            let n = match a.per {
                Per::Vertex => m.positions.len(),
                Per::Face => m.indices.len(),
            };
            if a.dim == 0 || a.data.len() != n * a.dim {
                return Err(Error::file(
                    "mesh",
                    format!("attribute {} does not fit the mesh", a.name),
                ));
            }
        }
        self.attributes = attributes;
        Ok(self)
    }

    /// The mesh's attributes (none for other shapes).
    #[inline]
    pub fn attributes(&self) -> &[Attribute] {
        &self.attributes
    }

    /// A shape from a loaded (and already transformed) mesh. `face_normals` drops the vertex
    /// normals; a mesh without normals otherwise gets Mitsuba's smooth angle-weighted normals.
    pub fn from_mesh(mut mesh: TriMesh, flip_normals: bool, face_normals: bool) -> Result<Shape> {
        mesh.validate().map_err(|m| Error::file("mesh", m))?;
        if face_normals {
            mesh.normals = None;
        } else if mesh.normals.is_none() {
            mesh.compute_vertex_normals();
        }
        Shape::new_mesh(mesh, flip_normals, face_normals)
    }

    /// Mitsuba's `rectangle`: [−1,1]² in the XY plane, normal +Z (by the normal transform, as
    /// Mitsuba), uv = ((x+1)/2, (y+1)/2), dp/du = to_world·(2,0,0), dp/dv = to_world·(0,2,0).
    /// Exact: an Embree user geometry. A degenerate (zero-area) transform gives a never-hit shape.
    pub fn rectangle(to_world: &Mat4, flip_normals: bool) -> Shape {
        Shape::rectangle_with_normals(to_world, None, flip_normals)
    }

    /// [`Shape::rectangle`] whose shading normal follows `normal_matrix` (Mitsuba's, after a
    /// `<rotate>` with a non-unit axis) rather than the inverse transpose of `to_world`; the
    /// geometric normal stays the true one (Mitsuba 3.9.1's rectangle is a mesh: its face
    /// normal comes from the mapped vertices, its vertex normals from the normal matrix).
    pub fn rectangle_with_normals(
        to_world: &Mat4,
        normal_matrix: Option<&Mat3>,
        flip_normals: bool,
    ) -> Shape {
        let kind = ShapeKind::Rectangle {
            to_world: *to_world,
        };
        let Some(mut shape) = Shape::planar(kind, to_world, 4.0, flip_normals) else {
            return degenerate();
        };
        shape.shading_normal = normal_matrix.and_then(|nm| (*nm * Vec3::Z).try_normalize());
        shape
    }

    /// A disk or rectangle: `unit_area` is its area in object space (π or 4), scaled by the area
    /// factor of `to_world` on the XY plane; `None` if `to_world` is degenerate (zero area).
    fn planar(
        kind: ShapeKind,
        to_world: &Mat4,
        unit_area: f32,
        flip_normals: bool,
    ) -> Option<Shape> {
        let ax = to_world.transform_vector3(Vec3::X);
        let ay = to_world.transform_vector3(Vec3::Y);
        let area = unit_area * ax.cross(ay).length();
        let det = Mat3::from_mat4(*to_world).determinant();
        if !(area.is_finite() && area > 0.0 && det.is_finite() && det != 0.0) {
            return None;
        }
        Some(Shape {
            kind,
            flip_normals,
            face_normals: true,
            area,
            cdf: Vec::new(),
            to_object: to_world.inverse(),
            box_to_world: None,
            attributes: Vec::new(),
            shading_normal: None,
            scene_index: 0,
        })
    }

    /// Mitsuba's `cube`: [−1,1]³ as 12 triangles with 24 vertices (4 per face, so each face has
    /// its own flat normal and a full \[0,1\]² uv square), winding and uv layout as Mitsuba's
    /// `cube.cpp` ([`CUBE_FACES`]). The mesh serves shading and sampling; when `to_world` is
    /// invertible, Embree intersects the exact box instead (see [`Shape::box_to_world`]).
    pub fn cube(to_world: &Mat4, flip_normals: bool) -> Shape {
        Shape::cube_with_normals(to_world, None, flip_normals)
    }

    /// [`Shape::cube`] whose face normals follow `normal_matrix` rather than the inverse
    /// transpose of `to_world` (Mitsuba's, after a `<rotate>` with a non-unit axis; see
    /// [`TriMesh::transform_with_normals`]).
    pub fn cube_with_normals(
        to_world: &Mat4,
        normal_matrix: Option<&Mat3>,
        flip_normals: bool,
    ) -> Shape {
        // Corner k of a face gets uv (0,1), (1,1), (1,0), (0,0); the face is split into the
        // triangles (0,1,2) and (3,0,2).
        let corner_uv = [
            Vec2::new(0.0, 1.0),
            Vec2::new(1.0, 1.0),
            Vec2::new(1.0, 0.0),
            Vec2::ZERO,
        ];
        let mut mesh = TriMesh::default();
        let (mut ns, mut uvs) = (Vec::new(), Vec::new());
        for (f, corners) in CUBE_FACES.iter().enumerate() {
            let corners = corners.map(Vec3::from_array);
            let n = corners.iter().sum::<Vec3>() * 0.25;
            for (k, c) in corners.iter().enumerate() {
                mesh.positions.push(*c);
                ns.push(n);
                uvs.push(corner_uv[k]);
            }
            let b = 4 * f as u32;
            mesh.indices.push([b, b + 1, b + 2]);
            mesh.indices.push([b + 3, b, b + 2]);
        }
        mesh.normals = Some(ns);
        mesh.uvs = Some(uvs);
        mesh.transform_with_normals(to_world, normal_matrix);
        let Ok(mut shape) = Shape::new_mesh(mesh, flip_normals, false) else {
            return degenerate();
        };
        let det = Mat3::from_mat4(*to_world).determinant();
        if det.is_finite() && det != 0.0 {
            shape.box_to_world = Some(*to_world);
        }
        shape
    }

    /// Mitsuba's `disk`: the unit disk in the XY plane, normal +Z (by the normal transform, as
    /// Mitsuba), uv = (r, φ/2π). Exact: an Embree user geometry with analytic intersection.
    pub fn disk(to_world: &Mat4, flip_normals: bool) -> Result<Shape> {
        Shape::disk_with_inverse(to_world, None, flip_normals)
    }

    /// [`Shape::disk`] intersected in the object space of `inverse` (Mitsuba's
    /// `Transform::inverse()` after a `<rotate>` with a non-unit axis, which is not the inverse
    /// of `to_world`): rays then meet the image of the unit disk under `inverse⁻¹`, whose plane
    /// has the normal Mitsuba reports (the normal transform of +Z), while positions are still
    /// sampled on `to_world`'s disk with the area of that one, as in Mitsuba 3.9.1.
    pub fn disk_with_inverse(
        to_world: &Mat4,
        inverse: Option<&Mat4>,
        flip_normals: bool,
    ) -> Result<Shape> {
        let degenerate = || Error::file("disk", "to_world is degenerate (zero area)");
        let hit_to_world = match inverse {
            Some(inv) => {
                let h = inv.inverse();
                if !(h.is_finite() && Mat3::from_mat4(h).determinant() != 0.0) {
                    return Err(degenerate());
                }
                h
            }
            None => *to_world,
        };
        let kind = ShapeKind::Disk {
            to_world: *to_world,
            hit_to_world,
        };
        let mut shape = Shape::planar(kind, to_world, PI, flip_normals).ok_or_else(degenerate)?;
        if let Some(inv) = inverse {
            shape.to_object = *inv;
        }
        Ok(shape)
    }

    /// Mitsuba's `sphere`: `center`/`radius` in object space, then `to_world`; a translation, a
    /// rotation (orients the uv map) and a uniform scale keep it a sphere. Any other `to_world`
    /// (non-uniform scale, shear) gives what Mitsuba 3.9.1 renders, with its warnings
    /// ([`super::sphere_map::sphere_warnings`], for the loader to report): the sphere of centre
    /// `M·0` and radius `|M·x|` with the uv map through `M` ([`SphereMap`]). A mirroring
    /// `to_world` flips the normals, as in Mitsuba. Intersected exactly by Embree.
    pub fn sphere(center: Vec3, radius: f32, to_world: &Mat4, flip_normals: bool) -> Result<Shape> {
        Shape::sphere_with_inverse(center, radius, to_world, None, flip_normals)
    }

    /// [`Shape::sphere`] whose uv map, when `to_world` is not a similarity, uses `inverse` for
    /// the object space (Mitsuba's `Transform::inverse()` after a `<rotate>` with a non-unit
    /// axis) instead of the inverse of `to_world`.
    pub fn sphere_with_inverse(
        center: Vec3,
        radius: f32,
        to_world: &Mat4,
        inverse: Option<&Mat4>,
        flip_normals: bool,
    ) -> Result<Shape> {
        let m = *to_world * Mat4::from_translation(center) * Mat4::from_scale(Vec3::splat(radius));
        let c = m.transform_point3(Vec3::ZERO);
        let axes = [Vec3::X, Vec3::Y, Vec3::Z].map(|a| m.transform_vector3(a));
        let r = axes[0].length();
        let tol = 1e-4 * r;
        let uniform = axes.iter().all(|a| (a.length() - r).abs() <= tol)
            && axes[0].dot(axes[1]).abs() <= tol * r
            && axes[0].dot(axes[2]).abs() <= tol * r
            && axes[1].dot(axes[2]).abs() <= tol * r;
        if !(r.is_finite() && r > 0.0 && c.is_finite()) {
            return Err(Error::file(
                "sphere",
                format!("invalid radius {r} or center {c}"),
            ));
        }
        let det = Mat3::from_mat4(m).determinant();
        if !(det.is_finite() && det != 0.0) {
            return Err(Error::file("sphere", "to_world is degenerate (singular)"));
        }
        let (frame, map) = if uniform {
            let f = Mat3::from_cols(axes[0] / r, axes[1] / r, axes[2] / r);
            (Mat4::from_mat3(f), None)
        } else {
            // Mitsuba's inverse of `m`: the centre and radius steps, then `to_world`'s.
            let inv_tw = inverse.copied().unwrap_or_else(|| to_world.inverse());
            let to_object = Mat4::from_scale(Vec3::splat(1.0 / radius))
                * Mat4::from_translation(-center)
                * inv_tw;
            if !to_object.is_finite() {
                return Err(Error::file("sphere", "to_world is not invertible"));
            }
            let map = SphereMap {
                to_world: m,
                to_object,
            };
            (Mat4::IDENTITY, Some(map))
        };
        Ok(Shape {
            kind: ShapeKind::Sphere {
                center: c,
                radius: r,
                frame,
                map,
            },
            // Mitsuba flips a mirrored sphere's normals (the first entry of the symmetric polar
            // factor is negative exactly when the determinant is).
            flip_normals: flip_normals != (det < 0.0),
            face_normals: true,
            area: 4.0 * PI * r * r,
            cdf: Vec::new(),
            to_object: Mat4::IDENTITY,
            box_to_world: None,
            attributes: Vec::new(),
            shading_normal: None,
            scene_index: 0,
        })
    }

    /// Mitsuba's `cylinder` (see [`Cylinder`]): exact, area-sampled by (φ, z).
    pub fn cylinder(cylinder: Cylinder, flip_normals: bool) -> Shape {
        Shape {
            area: cylinder.area(),
            kind: ShapeKind::Cylinder(cylinder),
            flip_normals,
            face_normals: true,
            cdf: Vec::new(),
            to_object: Mat4::IDENTITY,
            box_to_world: None,
            attributes: Vec::new(),
            shading_normal: None,
            scene_index: 0,
        }
    }

    /// The number of zero-area triangles of a mesh (0 for other shapes): they are never hit
    /// and never sampled.
    pub fn zero_area_triangles(&self) -> usize {
        match &self.kind {
            ShapeKind::Mesh(m) => (0..m.indices.len())
                .filter(|&i| {
                    let a = m.triangle_area(i);
                    a.is_nan() || a <= 0.0
                })
                .count(),
            _ => 0,
        }
    }

    /// Mitsuba's `linearcurve` / `bsplinecurve` (see [`Curves`]): traced only, no area (the
    /// loader refuses an emitter on it, as Mitsuba has no sampling for curves).
    pub fn curves(curves: Curves) -> Shape {
        Shape {
            kind: ShapeKind::Curves(curves),
            flip_normals: false,
            face_normals: true,
            area: 0.0,
            cdf: Vec::new(),
            to_object: Mat4::IDENTITY,
            box_to_world: None,
            attributes: Vec::new(),
            shading_normal: None,
            scene_index: 0,
        }
    }

    /// Mitsuba's `sdfgrid` (see [`SdfGrid`]): traced only, no area (the loader refuses an
    /// emitter on it).
    pub fn sdfgrid(grid: SdfGrid) -> Shape {
        Shape {
            kind: ShapeKind::SdfGrid(std::sync::Arc::new(grid)),
            flip_normals: false,
            face_normals: true,
            area: 0.0,
            cdf: Vec::new(),
            to_object: Mat4::IDENTITY,
            box_to_world: None,
            attributes: Vec::new(),
            shading_normal: None,
            scene_index: 0,
        }
    }

    /// Surface area.
    pub fn area(&self) -> f32 {
        self.area
    }

    /// Axis-aligned bounds (min, max).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        match &self.kind {
            ShapeKind::Mesh(m) => m.positions.iter().fold(
                (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
                |(lo, hi), p| (lo.min(*p), hi.max(*p)),
            ),
            ShapeKind::Sphere { center, radius, .. } => (*center - *radius, *center + *radius),
            // `to_world`'s disk, as Mitsuba's bounding box (the scene's bounding sphere).
            ShapeKind::Disk { to_world, .. } => {
                let c = to_world.transform_point3(Vec3::ZERO);
                let ax = to_world.transform_vector3(Vec3::X);
                let ay = to_world.transform_vector3(Vec3::Y);
                let ext = Vec3::new(ax.x.hypot(ay.x), ax.y.hypot(ay.y), ax.z.hypot(ay.z));
                (c - ext, c + ext)
            }
            ShapeKind::Rectangle { to_world } => {
                let c = to_world.transform_point3(Vec3::ZERO);
                let ext = to_world.transform_vector3(Vec3::X).abs()
                    + to_world.transform_vector3(Vec3::Y).abs();
                (c - ext, c + ext)
            }
            ShapeKind::Cylinder(c) => c.bounds(),
            ShapeKind::Curves(c) => c.bounds(),
            ShapeKind::SdfGrid(g) => g.bounds(),
        }
    }

    /// The surface interaction of `hit` (which must be a hit on this shape by `ray`).
    pub fn interaction(&self, shape_index: u32, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        let sign = if self.flip_normals { -1.0 } else { 1.0 };
        match &self.kind {
            ShapeKind::Mesh(m) => {
                let tri = m.indices[hit.prim as usize];
                let [p0, p1, p2] = tri.map(|i| m.positions[i as usize]);
                let (b1, b2) = (hit.u, hit.v);
                let b0 = 1.0 - b1 - b2;
                let p = p0 * b0 + p1 * b1 + p2 * b2;
                let (dp0, dp1) = (p1 - p0, p2 - p0);
                let ng = dp0.cross(dp1).try_normalize().unwrap_or(Vec3::Z);
                // Mitsuba's defaults without usable uvs: uv = (b1, b2) and an arbitrary
                // tangent frame around the face normal (built only when needed).
                let mut uv = Vec2::new(b1, b2);
                let mut derivs = None;
                if let Some(uvs) = &m.uvs {
                    let [t0, t1, t2] = tri.map(|i| uvs[i as usize]);
                    uv = t0 * b0 + t1 * b1 + t2 * b2;
                    let (d0, d1) = (t1 - t0, t2 - t0);
                    let det = d0.x * d1.y - d0.y * d1.x;
                    if det != 0.0 {
                        let inv = 1.0 / det;
                        derivs = Some((
                            (dp0 * d1.y - dp1 * d0.y) * inv,
                            (dp1 * d0.x - dp0 * d1.x) * inv,
                        ));
                    }
                }
                let (dpdu, dpdv) = derivs.unwrap_or_else(|| {
                    let f = Frame::from_normal(ng);
                    (f.s, f.t)
                });
                let mut ns = ng;
                if let Some(nrm) = &m.normals {
                    let [n0, n1, n2] = tri.map(|i| nrm[i as usize]);
                    if let Some(n) = (n0 * b0 + n1 * b1 + n2 * b2).try_normalize() {
                        ns = n;
                    }
                }
                SurfaceInteraction {
                    p,
                    t: hit.t,
                    ng: ng * sign,
                    sh: Frame::from_normal_tangent(ns * sign, dpdu),
                    uv,
                    dpdu,
                    dpdv,
                    shape: shape_index,
                    prim: hit.prim,
                    wi: -ray.d,
                }
            }
            ShapeKind::Disk {
                to_world,
                hit_to_world,
            } => {
                // Project the hit onto the traced disk's plane in object space, then back.
                let mut l = self.to_object.transform_point3(ray.at(hit.t));
                l.z = 0.0;
                let p = hit_to_world.transform_point3(l);
                let (uv, dpdu, dpdv) = disk_uv(to_world, l);
                let ng = self.plane_normal() * sign;
                analytic_interaction(p, ng, (uv, dpdu, dpdv), shape_index, ray, hit)
            }
            ShapeKind::Rectangle { to_world } => {
                let mut l = self.to_object.transform_point3(ray.at(hit.t));
                l.z = 0.0;
                let p = to_world.transform_point3(l);
                let ng = self.plane_normal() * sign;
                let (uv, dpdu, dpdv) = rectangle_uv(to_world, l);
                let mut si = analytic_interaction(p, ng, (uv, dpdu, dpdv), shape_index, ray, hit);
                if let Some(n) = self.shading_normal {
                    si.sh = Frame::from_normal_tangent(n * sign, dpdu);
                }
                si
            }
            ShapeKind::Sphere {
                center,
                radius,
                frame,
                map,
            } => {
                let n = (ray.at(hit.t) - *center).try_normalize().unwrap_or(Vec3::Z);
                // Reproject onto the sphere (as Mitsuba) for an accurate surface point.
                let p = *center + n * *radius;
                let (uv, dpdu, dpdv) = sphere_param(frame, map.as_ref(), *center, *radius, n);
                let ng = n * sign;
                analytic_interaction(p, ng, (uv, dpdu, dpdv), shape_index, ray, hit)
            }
            ShapeKind::Cylinder(c) => {
                let (p, n, uv, dpdu, dpdv) = c.surface(ray.at(hit.t));
                analytic_interaction(p, n * sign, (uv, dpdu, dpdv), shape_index, ray, hit)
            }
            ShapeKind::Curves(c) => {
                // The ray point itself, as Mitsuba (no reprojection onto the tube).
                let p = ray.at(hit.t);
                let s = c.surface(hit.prim, hit.u, p);
                analytic_interaction(p, s.n, (s.uv, s.dpdu, s.dpdv), shape_index, ray, hit)
            }
            ShapeKind::SdfGrid(g) => {
                // The ray point itself, no uv and no partials, as Mitsuba.
                let p = ray.at(hit.t);
                let (ng, ns) = g.normals(p);
                let mut si = analytic_interaction(
                    p,
                    ng,
                    (Vec2::ZERO, Vec3::ZERO, Vec3::ZERO),
                    shape_index,
                    ray,
                    hit,
                );
                si.sh = Frame::from_normal(ns);
                si
            }
        }
    }

    /// A point uniformly distributed by area (meshes: triangle chosen by `u.y` through the area
    /// CDF and `u.y` reused, as Mitsuba's `Mesh::sample_position`).
    pub fn sample_position(&self, u: Vec2) -> PositionSample {
        let sign = if self.flip_normals { -1.0 } else { 1.0 };
        let pdf = 1.0 / self.area;
        match &self.kind {
            // An empty mesh, curves and SDF grids (never emitters): nothing to sample.
            ShapeKind::Curves(_) | ShapeKind::SdfGrid(_) => PositionSample {
                p: Vec3::ZERO,
                n: Vec3::Z,
                ng: Vec3::Z,
                uv: Vec2::ZERO,
                pdf: 0.0,
            },
            ShapeKind::Mesh(_) if self.cdf.is_empty() => PositionSample {
                p: Vec3::ZERO,
                n: Vec3::Z,
                ng: Vec3::Z,
                uv: Vec2::ZERO,
                pdf: 0.0,
            },
            ShapeKind::Mesh(m) => {
                let (i, u) = self.pick_triangle(u);
                let b = warp::square_to_uniform_triangle(u);
                let tri = m.indices[i];
                let [p0, p1, p2] = tri.map(|k| m.positions[k as usize]);
                let b0 = 1.0 - b.x - b.y;
                let p = p0 + (p1 - p0) * b.x + (p2 - p0) * b.y;
                let ng = (p1 - p0).cross(p2 - p0).try_normalize().unwrap_or(Vec3::Z);
                let n = m
                    .normals
                    .as_ref()
                    .and_then(|ns| {
                        let [n0, n1, n2] = tri.map(|k| ns[k as usize]);
                        (n0 * b0 + n1 * b.x + n2 * b.y).try_normalize()
                    })
                    .unwrap_or(ng);
                let uv = match &m.uvs {
                    Some(uvs) => {
                        let [t0, t1, t2] = tri.map(|k| uvs[k as usize]);
                        t0 * b0 + t1 * b.x + t2 * b.y
                    }
                    None => b,
                };
                PositionSample {
                    p,
                    n: n * sign,
                    ng: ng * sign,
                    uv,
                    pdf,
                }
            }
            ShapeKind::Disk { to_world, .. } => {
                // Concentric mapping, as Mitsuba's `Disk::sample_position` (on `to_world`'s
                // disk, with the normal of the traced one).
                let d = warp::square_to_disk_concentric(u);
                let l = Vec3::new(d.x, d.y, 0.0);
                PositionSample {
                    p: to_world.transform_point3(l),
                    n: self.plane_normal() * sign,
                    ng: self.plane_normal() * sign,
                    uv: disk_uv(to_world, l).0,
                    pdf,
                }
            }
            ShapeKind::Rectangle { to_world } => {
                // As Mitsuba's `Rectangle::sample_position`: uv = u.
                let l = Vec3::new(2.0 * u.x - 1.0, 2.0 * u.y - 1.0, 0.0);
                PositionSample {
                    p: to_world.transform_point3(l),
                    n: self.rectangle_normal() * sign,
                    ng: self.rectangle_normal() * sign,
                    uv: u,
                    pdf,
                }
            }
            // On the sphere also when `to_world` is not a similarity: Mitsuba's sampling by solid
            // angle (the only use here) samples its sphere, not the ellipsoid its
            // `sample_position` would map the unit sphere to.
            ShapeKind::Sphere {
                center,
                radius,
                frame,
                map,
            } => {
                let n = warp::square_to_uniform_sphere(u);
                PositionSample {
                    p: *center + n * *radius,
                    n: n * sign,
                    ng: n * sign,
                    uv: sphere_param(frame, map.as_ref(), *center, *radius, n).0,
                    pdf,
                }
            }
            ShapeKind::Cylinder(c) => {
                let (p, n, uv) = c.sample_position(u);
                PositionSample {
                    p,
                    n: n * sign,
                    ng: n * sign,
                    uv,
                    pdf,
                }
            }
        }
    }

    /// The triangle of a non-empty mesh that `sample_position` samples from `u` (by area, with
    /// `u.y`), and `u` with `u.y` rescaled to that triangle's share of [0, 1) (so it samples the
    /// triangle uniformly). Shared with the stream renderer's 8-wide light sampling.
    #[inline]
    pub(crate) fn pick_triangle(&self, u: Vec2) -> (usize, Vec2) {
        let i = self
            .cdf
            .partition_point(|&c| c <= u.y)
            .min(self.cdf.len() - 1);
        let lo = if i == 0 { 0.0 } else { self.cdf[i - 1] };
        let w = self.cdf[i] - lo;
        let uy = if w > 0.0 {
            ((u.y - lo) / w).clamp(0.0, 1.0 - f32::EPSILON * 0.5)
        } else {
            0.5
        };
        (i, Vec2::new(u.x, uy))
    }

    /// A mesh's normalised cumulative triangle areas, which [`Self::pick_triangle`] searches
    /// (empty for other shapes and meshes of zero area).
    #[inline]
    pub(crate) fn triangle_cdf(&self) -> &[f32] {
        &self.cdf
    }

    /// Whether [`Self::sample_position`] samples this shape as a triangle mesh (a mesh with
    /// a positive area).
    #[inline]
    pub(crate) fn samples_triangles(&self) -> bool {
        matches!(self.kind, ShapeKind::Mesh(_)) && !self.cdf.is_empty()
    }

    /// Samples a point on the shape as seen from `ref_p`, with its solid-angle density. Spheres
    /// seen from outside sample the cone of directions toward the sphere uniformly (Mitsuba 3's
    /// `Sphere::sample_direction`); everything else samples by area and converts.
    pub fn sample_direction(&self, ref_p: Vec3, u: Vec2) -> Option<DirectionSample> {
        if let ShapeKind::Sphere {
            center,
            radius,
            frame,
            map,
        } = &self.kind
        {
            let dc = *center - ref_p;
            let dist_c = dc.length();
            if sphere_sees_cone(dist_c, *radius) {
                let sin_a = *radius / dist_c;
                let cos_a = (1.0 - sin_a * sin_a).max(0.0).sqrt();
                let axis = dc / dist_c;
                let d = Frame::from_normal(axis).to_world(warp::square_to_uniform_cone(u, cos_a));
                // Nearest intersection of the ray with the sphere; a direction grazing the
                // silhouette (rounding) is clamped to the tangent point.
                let b = d.dot(dc);
                let disc = (*radius * *radius - (dist_c * dist_c - b * b)).max(0.0);
                let t = b - disc.sqrt();
                let n0 = (ref_p + d * t - *center).try_normalize()?;
                let p = *center + n0 * *radius;
                let v = p - ref_p;
                let dist = v.length();
                let pdf = warp::uniform_cone_pdf(cos_a);
                if !(dist > 0.0 && pdf.is_finite()) {
                    return None;
                }
                let sign = if self.flip_normals { -1.0 } else { 1.0 };
                return Some(DirectionSample {
                    p,
                    n: n0 * sign,
                    uv: sphere_param(frame, map.as_ref(), *center, *radius, n0).0,
                    d: v / dist,
                    dist,
                    pdf,
                });
            }
        }
        let ps = self.sample_position(u);
        if ps.pdf == 0.0 {
            return None;
        }
        let v = ps.p - ref_p;
        let dist2 = v.length_squared();
        let dist = dist2.sqrt();
        if dist.is_nan() || dist <= 0.0 {
            return None;
        }
        let d = v / dist;
        let cos = d.dot(ps.n).abs();
        let pdf = ps.pdf * dist2 / cos;
        if !(cos > 0.0 && pdf.is_finite()) {
            return None;
        }
        Some(DirectionSample {
            p: ps.p,
            n: ps.n,
            uv: ps.uv,
            d,
            dist,
            pdf,
        })
    }

    /// The solid-angle density with which [`Shape::sample_direction`] from `ref_p` produces the
    /// point `si` of this shape (for MIS). Uses `si.sh.n`, the same normal sampling reports.
    pub fn pdf_direction(&self, ref_p: Vec3, si: &SurfaceInteraction) -> f32 {
        if let ShapeKind::Sphere { center, radius, .. } = &self.kind {
            let dist_c = (*center - ref_p).length();
            if sphere_sees_cone(dist_c, *radius) {
                let sin_a = *radius / dist_c;
                let cos_a = (1.0 - sin_a * sin_a).max(0.0).sqrt();
                return warp::uniform_cone_pdf(cos_a);
            }
        }
        let v = si.p - ref_p;
        let dist2 = v.length_squared();
        let cos = (v / dist2.sqrt()).dot(si.sh.n).abs();
        let pdf = dist2 / (cos * self.area);
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }

    /// The unit normal of a rectangle's sampled points before `flip_normals` (its shading normal
    /// where Mitsuba's differs from the geometric one). Shared with the stream renderer's 8-wide
    /// light sampling.
    #[inline]
    pub(crate) fn rectangle_normal(&self) -> Vec3 {
        self.shading_normal.unwrap_or_else(|| self.plane_normal())
    }

    /// What the lane form of a rectangle's interaction needs ([`super::surface_lanes::rectangle`]):
    /// `to_object`, `to_world`, and the constants the scalar [`Self::interaction`] computes
    /// per hit (signed true and shading normals, dp/du, dp/dv), computed here by the same code;
    /// `None` for other shapes.
    pub(crate) fn rectangle_lanes(&self) -> Option<(Mat4, Mat4, [Vec3; 4])> {
        let ShapeKind::Rectangle { to_world } = &self.kind else {
            return None;
        };
        let sign = if self.flip_normals { -1.0 } else { 1.0 };
        let ng = self.plane_normal() * sign;
        let n = self.shading_normal.map_or(ng, |n| n * sign);
        let (_, dpdu, dpdv) = rectangle_uv(to_world, Vec3::ZERO);
        Some((self.to_object, *to_world, [ng, n, dpdu, dpdv]))
    }

    /// What the lane form of a sphere's interaction needs ([`super::surface_lanes::sphere`]):
    /// centre, radius, the rotation orienting its uv map and the `flip_normals` sign; `None`
    /// for other shapes and for spheres whose `to_world` is not a similarity (their uv map goes
    /// through [`SphereMap`]).
    pub(crate) fn sphere_lanes(&self) -> Option<(Vec3, f32, Mat4, f32)> {
        let ShapeKind::Sphere {
            center,
            radius,
            frame,
            map: None,
        } = &self.kind
        else {
            return None;
        };
        let sign = if self.flip_normals { -1.0 } else { 1.0 };
        Some((*center, *radius, *frame, sign))
    }

    /// What the lane form of a disk's interaction needs ([`super::surface_lanes::disk`]):
    /// `to_object`, `hit_to_world`, `to_world` and the signed normal; `None` for other shapes.
    pub(crate) fn disk_lanes(&self) -> Option<(Mat4, Mat4, Mat4, Vec3)> {
        let ShapeKind::Disk {
            to_world,
            hit_to_world,
        } = &self.kind
        else {
            return None;
        };
        let sign = if self.flip_normals { -1.0 } else { 1.0 };
        let ng = self.plane_normal() * sign;
        Some((self.to_object, *hit_to_world, *to_world, ng))
    }

    /// The disk's unit normal before `flip_normals`: +Z by the normal transform.
    /// The unit normal of a disk or rectangle: the normal transform of +Z, as Mitsuba.
    fn plane_normal(&self) -> Vec3 {
        self.to_object
            .transpose()
            .transform_vector3(Vec3::Z)
            .try_normalize()
            .unwrap_or(Vec3::Z)
    }
}

/// An empty, never-hit shape for a degenerate (zero-area) rectangle or cube transform.
fn degenerate() -> Shape {
    Shape {
        kind: ShapeKind::Mesh(TriMesh::default()),
        flip_normals: false,
        face_normals: true,
        area: 0.0,
        cdf: Vec::new(),
        to_object: Mat4::IDENTITY,
        box_to_world: None,
        attributes: Vec::new(),
        shading_normal: None,
        scene_index: 0,
    }
}

/// Mitsuba 3's disk parameterisation at the object-space point `l`: uv = (r, φ/2π), dp/du
/// radial, dp/dv tangential (scaled by 2πr, the true derivative), both mapped to world space.
/// Mitsuba's rectangle parameterisation at the object-space point `l`.
fn rectangle_uv(to_world: &Mat4, l: Vec3) -> (Vec2, Vec3, Vec3) {
    (
        Vec2::new(0.5 * l.x + 0.5, 0.5 * l.y + 0.5),
        to_world.transform_vector3(Vec3::new(2.0, 0.0, 0.0)),
        to_world.transform_vector3(Vec3::new(0.0, 2.0, 0.0)),
    )
}

fn disk_uv(to_world: &Mat4, l: Vec3) -> (Vec2, Vec3, Vec3) {
    let r = Vec2::new(l.x, l.y).length();
    let mut phi = lm::atan2(l.y, l.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let (cp, sp) = if r > 0.0 {
        (l.x / r, l.y / r)
    } else {
        (1.0, 0.0)
    };
    let dpdu = to_world.transform_vector3(Vec3::new(cp, sp, 0.0));
    let dpdv = to_world.transform_vector3(Vec3::new(-sp, cp, 0.0)) * (2.0 * PI * r);
    (Vec2::new(r, phi * INV_2PI), dpdu, dpdv)
}

/// The sphere's uv and partials at the outward unit normal `n`: through `map` when `to_world`
/// is not a similarity, else by the rotation `frame` ([`sphere_uv`]).
#[inline]
fn sphere_param(
    frame: &Mat4,
    map: Option<&SphereMap>,
    center: Vec3,
    radius: f32,
    n: Vec3,
) -> (Vec2, Vec3, Vec3) {
    match map {
        Some(m) => m.param(center + n * radius),
        None => sphere_uv(frame, radius, n),
    }
}

/// Mitsuba 3's sphere parameterisation for the outward unit normal `n` (world space):
/// in the local frame, uv = (φ/2π, θ/π) with θ measured from +z and φ = atan2(y, x) ∈ [0, 2π);
/// dp/du = 2π·r·(−y, x, 0), dp/dv = π·r·(z cos φ, z sin φ, −sin θ), mapped back to world.
fn sphere_uv(frame: &Mat4, radius: f32, n: Vec3) -> (Vec2, Vec3, Vec3) {
    let l = frame.transpose().transform_vector3(n);
    let theta = lm::acos(l.z.clamp(-1.0, 1.0));
    let mut phi = lm::atan2(l.y, l.x);
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    let rd = (l.x * l.x + l.y * l.y).sqrt();
    let dpdu = Vec3::new(-l.y, l.x, 0.0) * (2.0 * PI * radius);
    let dpdv = if rd > 0.0 {
        Vec3::new(l.z * l.x / rd, l.z * l.y / rd, -rd)
    } else {
        Vec3::X
    } * (PI * radius);
    (
        Vec2::new(phi * INV_2PI, theta * (1.0 / PI)),
        frame.transform_vector3(dpdu),
        frame.transform_vector3(dpdv),
    )
}

/// Whether a reference point at distance `dist_c` from a sphere's centre samples the sphere by its
/// visible cone. Points on the surface itself (within rounding: hit points are reprojected onto
/// the sphere, so half of them land an ulp outside) must use area sampling: from the surface the
/// "cone" degenerates to a hemisphere whose nearest intersections collapse onto the point itself,
/// which lost ~10% of the light inside an emitting sphere. A point on the outside of a convex
/// sphere cannot see the sphere's own surface, so area sampling is correct there too.
#[inline]
pub(crate) fn sphere_sees_cone(dist_c: f32, radius: f32) -> bool {
    dist_c > radius * (1.0 + 1e-3)
}

/// The interaction of an analytic shape (sphere, disk), whose shading normal is its true normal.
#[inline]
fn analytic_interaction(
    p: Vec3,
    ng: Vec3,
    (uv, dpdu, dpdv): (Vec2, Vec3, Vec3),
    shape: u32,
    ray: &Ray,
    hit: &Hit,
) -> SurfaceInteraction {
    SurfaceInteraction {
        p,
        t: hit.t,
        ng,
        sh: Frame::from_normal_tangent(ng, dpdu),
        uv,
        dpdu,
        dpdv,
        shape,
        prim: hit.prim,
        wi: -ray.d,
    }
}
