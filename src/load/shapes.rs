//! `<shape>`s (`obj`, `ply`, `serialized`, `rectangle`, `cube`, `disk`, `sphere`, `cylinder`, `sdfgrid`,
//! `linearcurve`, `bsplinecurve`; `shapegroup` and `instance` are in `shapegroup.rs`), the `area`
//! emitter a shape carries, and the default materials of shapes without a BSDF.

use super::shapegroup::Placed;
use super::{check, unknown, Builder};
use crate::emitter::area::AreaLight;
use crate::emitter::Emitter;
use crate::error::{Error, Result};
use crate::geometry::curves::{self, CurveBasis};
use crate::geometry::sdfgrid::SdfGrid;
use crate::geometry::sphere_map::sphere_warnings;
use crate::geometry::{obj, ply, serialized, Cylinder, Shape, ShapeKind};
use crate::material::{MatId, MaterialNode};
use crate::scene::xml::ir::Node;
use crate::scene::xml::props::Props;
use crate::spectrum::{Spectrum, SpectrumUse};
use crate::texture::Texture;
use glam::{Mat4, Vec3};

impl<'d> Builder<'d> {
    /// The default BSDF of a shape that has none (shared by all such shapes).
    fn default_material(&mut self, emitting: bool) -> MatId {
        let slot = usize::from(emitting);
        if let Some(m) = self.default_materials[slot] {
            return m;
        }
        let grey = if emitting { 0.0 } else { 0.5 };
        let t = self
            .materials
            .add_texture(Texture::Constant(Spectrum::splat(grey)));
        let m = self
            .materials
            .add_node(MaterialNode::Diffuse { reflectance: t });
        self.default_materials[slot] = Some(m);
        m
    }

    /// An error of a file element `p` asked for (`kind` "mesh", "image"...), located at the
    /// element; the file's own position (line, byte offset), if any, stays in the message.
    pub(super) fn file_error(&self, p: &Props<'d>, kind: &str, name: &str, e: Error) -> Error {
        Error::scene(p.loc(), format!("cannot load {kind} '{name}': {e}"))
    }

    /// Reserves what a loaded mesh keeps (its arrays, and the acceleration structure's copy).
    fn reserve_mesh(
        &self,
        p: &Props<'d>,
        name: &str,
        m: &crate::geometry::mesh::TriMesh,
    ) -> Result<()> {
        let per_vertex =
            12 + m.normals.as_ref().map_or(0, |_| 12) + m.uvs.as_ref().map_or(0, |_| 8);
        let bytes = 2 * (m.positions.len() as u64 * per_vertex + m.indices.len() as u64 * 12);
        self.budget
            .reserve(
                bytes,
                &format!(
                    "mesh '{name}' ({} vertices, {} triangles)",
                    m.positions.len(),
                    m.indices.len()
                ),
            )
            .map_err(|m| Error::scene(p.loc(), m))
    }

    /// The geometry of a `<shape>`, in world space (with a PLY file's mesh attributes).
    fn geometry(&mut self, p: &Props<'d>) -> Result<Shape> {
        let xf = p.transform_full("to_world")?;
        let to_world = xf.matrix;
        // Mitsuba's normal matrix and inverse when they differ from the true ones (a non-unit
        // `<rotate>`).
        let normal_matrix = xf.quirk_inverse_transpose.map(|_| xf.normal_matrix());
        let quirk_inverse = xf.quirk_inverse_transpose.map(|_| xf.inverse());
        let curve = match p.plugin_type() {
            "linearcurve" => Some(CurveBasis::Linear),
            "bsplinecurve" => Some(CurveBasis::BSpline),
            _ => None,
        };
        if let Some(basis) = curve {
            // No `flip_normals` here: left unread, `finish` reports it as unknown, as
            // Mitsuba 3.9.1 does.
            return curves::from_props(
                p,
                basis,
                &to_world,
                |name| self.doc.resolve_file(name, p.loc()),
                &self.budget,
            );
        }
        if p.plugin_type() == "sdfgrid" {
            // No `flip_normals` either (Mitsuba 3.9.1 reports it unreferenced).
            let (grid, warnings) = SdfGrid::from_props(
                p,
                &to_world,
                quirk_inverse.as_ref(),
                |name| self.doc.resolve_file(name, p.loc()),
                &self.budget,
            )?;
            for w in warnings {
                self.warnings.push(format!("{}: sdfgrid: {w}", p.loc()));
            }
            return Ok(Shape::sdfgrid(grid));
        }
        let flip = p.bool("flip_normals", false)?;
        Ok(match p.plugin_type() {
            t @ ("obj" | "ply") => {
                let fname = p.string_opt("filename")?.ok_or_else(|| {
                    Error::scene(p.loc(), format!("shape '{t}' needs a 'filename'"))
                })?;
                let file = self.doc.resolve_file(&fname, p.loc())?;
                let face_normals = p.bool("face_normals", false)?;
                let flip_tex = p.bool("flip_tex_coords", t == "obj")?;
                let mesh = if t == "obj" {
                    obj::load_obj_within(&file, &self.budget).map(|mesh| ply::PlyMesh {
                        mesh,
                        attributes: Vec::new(),
                        warnings: Vec::new(),
                    })
                } else {
                    ply::load_ply_attributed_within(&file, &self.budget)
                };
                let ply::PlyMesh {
                    mut mesh,
                    attributes,
                    warnings,
                } = mesh.map_err(|e| self.file_error(p, "mesh", &fname, e))?;
                for w in warnings {
                    self.warnings.push(format!("{}: '{fname}': {w}", p.loc()));
                }
                self.reserve_mesh(p, &fname, &mesh)?;
                let attr_bytes: u64 = attributes.iter().map(|a| a.bytes()).sum();
                if attr_bytes > 0 {
                    self.budget
                        .reserve(attr_bytes, &format!("mesh attributes of '{fname}'"))
                        .map_err(|m| Error::scene(p.loc(), m))?;
                }
                // The OBJ loader applies Mitsuba's v flip; undo it when asked not to flip.
                if (t == "obj") != flip_tex {
                    if let Some(uv) = mesh.uvs.as_mut() {
                        uv.iter_mut().for_each(|t| t.y = 1.0 - t.y);
                    }
                }
                mesh.transform_with_normals(&to_world, normal_matrix.as_ref());
                Shape::from_mesh(mesh, flip, face_normals)
                    .and_then(|s| s.with_attributes(attributes))
                    .map_err(|e| Error::scene(p.loc(), format!("{}: {e}", file.display())))?
            }
            "serialized" => {
                // Mitsuba's zlib-compressed binary meshes; see `geometry::serialized`.
                let fname = p.string_opt("filename")?.ok_or_else(|| {
                    Error::scene(p.loc(), "shape 'serialized' needs a 'filename'")
                })?;
                let file = self.doc.resolve_file(&fname, p.loc())?;
                let face_normals = p.bool("face_normals", false)?;
                let index = p.int("shape_index", 0)?;
                check(p.loc(), index >= 0, "shape_index must be nonnegative")?;
                let index = u32::try_from(index)
                    .map_err(|_| Error::scene(p.loc(), "shape_index is too large"))?;
                let mut mesh =
                    serialized::load_serialized_within(&file, index, !face_normals, &self.budget)
                        .map_err(|e| self.file_error(p, "mesh", &fname, e))?
                        .mesh;
                self.reserve_mesh(p, &fname, &mesh)?;
                mesh.transform_with_normals(&to_world, normal_matrix.as_ref());
                Shape::from_mesh(mesh, flip, face_normals)
                    .map_err(|e| Error::scene(p.loc(), format!("{}: {e}", file.display())))?
            }
            "rectangle" => Shape::rectangle_with_normals(&to_world, normal_matrix.as_ref(), flip),
            "cube" => Shape::cube_with_normals(&to_world, normal_matrix.as_ref(), flip),
            "disk" => Shape::disk_with_inverse(&to_world, quirk_inverse.as_ref(), flip)
                .map_err(|e| Error::scene(p.loc(), e.to_string()))?,
            "sphere" => {
                let c = p.point("center", Vec3::ZERO)?;
                let r = p.float("radius", 1.0)?;
                check(
                    p.loc(),
                    r > 0.0 && r.is_finite(),
                    "sphere radius must be positive",
                )?;
                let full = to_world * Mat4::from_translation(c) * Mat4::from_scale(Vec3::splat(r));
                for w in sphere_warnings(&full) {
                    self.warnings.push(format!(
                        "{}: sphere: {w} (as Mitsuba 3.9.1, it stays a sphere, of radius \
                         |to_world·(1,0,0)|, with the uv map through the transform)",
                        p.loc()
                    ));
                }
                Shape::sphere_with_inverse(c, r, &to_world, quirk_inverse.as_ref(), flip)
                    .map_err(|e| Error::scene(p.loc(), e.to_string()))?
            }
            // Mitsuba's open cylinder; its parameters are read in its own file.
            "cylinder" => {
                let c = Cylinder::from_props(p, &to_world, quirk_inverse.as_ref())?;
                for w in c.warnings() {
                    self.warnings.push(format!(
                        "{}: cylinder: {w} (as Mitsuba 3.9.1, it is traced exactly but sampled \
                         as a round tube of radius |to_world·(1,0,0)|)",
                        p.loc()
                    ));
                }
                Shape::cylinder(c, flip)
            }
            t => {
                return Err(unknown(
                    p.loc(),
                    "shape",
                    t,
                    &[
                        "obj",
                        "ply",
                        "serialized",
                        "rectangle",
                        "cube",
                        "disk",
                        "sphere",
                        "cylinder",
                        "shapegroup",
                        "instance",
                        "linearcurve",
                        "bsplinecurve",
                        "sdfgrid",
                    ],
                ))
            }
        })
    }

    /// A `<shape>` with its BSDF (or a default one) and its area emitter, if any.
    pub(super) fn shape(&mut self, n: &'d Node) -> Result<()> {
        match n.attr("type") {
            Some("shapegroup") => return self.shape_group(n).map(|_| ()),
            Some("instance") => return self.instance(n),
            _ => {}
        }
        let p = self.props(n)?;
        let shape = self.geometry(&p)?;
        let index = self.shapes.len() as u32;
        let mut media = crate::medium::MediumInterface::default();
        for c in p.objects() {
            match p.kind(c) {
                "bsdf" | "emitter" => {}
                "medium" => self.shape_medium(c, &mut media)?,
                "ref" => {
                    let id = c.attr("id").unwrap_or("");
                    return Err(Error::scene(
                        c.attr_loc("id"),
                        format!("reference to unknown id '{id}'"),
                    ));
                }
                t => {
                    return Err(Error::scene(
                        &c.loc,
                        format!("<{t}> is not expected inside a <shape>"),
                    ))
                }
            }
        }
        let material = match p.one_child("bsdf")? {
            Some(c) => Some(self.bsdf(c)?),
            None => None,
        };
        let emitter = match p.one_child("emitter")? {
            Some(c) if matches!(shape.kind, ShapeKind::SdfGrid(_)) => {
                return Err(Error::scene(
                    &c.loc,
                    "an 'sdfgrid' cannot carry an area emitter: Mitsuba 3.9.1 has no position \
                     sampling on it (its documentation: \"It cannot be used as an area emitter\")",
                ));
            }
            Some(c) if matches!(shape.kind, ShapeKind::Curves(_)) => {
                return Err(Error::scene(
                    &c.loc,
                    format!(
                        "a '{}' cannot carry an area emitter: Mitsuba 3.9.1 has no position \
                         sampling on curves",
                        p.plugin_type()
                    ),
                ));
            }
            Some(c) => Some(self.area_emitter(self.ids.resolve(c, "emitter")?, index)?),
            None => None,
        };
        self.check_zero_area(&p, &shape, emitter.is_some())?;
        p.finish()?;
        // Mitsuba 3: a shape without a BSDF gets a 0.5 grey diffuse one, but an emitting shape
        // without a BSDF gets a black one (it does not reflect light).
        let material = match material {
            Some(m) => m,
            None => self.default_material(emitter.is_some()),
        };
        self.check_hit_textures(material, &shape, &n.loc)?;
        self.placed.push(Placed::Shape(index));
        self.shapes.push(shape);
        self.shape_material.push(material);
        self.shape_emitter.push(emitter);
        self.shape_media.push(media);
        Ok(())
    }

    /// Zero-area triangles of a mesh are warned about (once per mesh, with their count): they
    /// are never hit and get no sampling probability, as in Mitsuba 3.9.1, which accepts them
    /// silently. A mesh of zero total area is warned about too (never hit), unless it is an area
    /// light: Mitsuba 3.9.1 (`scalar_rgb`) refuses to build its sampling table ("no
    /// probability mass found"), and so does groove, with the element's location.
    fn check_zero_area(&mut self, p: &Props<'d>, shape: &Shape, emitting: bool) -> Result<()> {
        let zero = shape.zero_area_triangles();
        if zero == 0 {
            return Ok(());
        }
        let n = match &shape.kind {
            crate::geometry::ShapeKind::Mesh(m) => m.indices.len(),
            _ => return Ok(()),
        };
        if shape.area() > 0.0 {
            self.warnings.push(format!(
                "{}: mesh has {zero} zero-area triangle(s) of {n}: they are never hit nor sampled",
                p.loc()
            ));
            return Ok(());
        }
        check(
            p.loc(),
            !emitting,
            format!(
                "this area light's mesh has zero surface area (all {n} triangles are degenerate): \
                 it cannot be sampled (Mitsuba 3.9.1 refuses it too)"
            ),
        )?;
        self.warnings.push(format!(
            "{}: mesh has zero surface area (all {n} triangles are degenerate): it is never hit",
            p.loc()
        ));
        Ok(())
    }

    /// An `area` emitter on shape `shape`; returns its index.
    fn area_emitter(&mut self, n: &'d Node, shape: u32) -> Result<u32> {
        let p = self.props(n)?;
        if p.plugin_type() != "area" {
            return Err(Error::scene(
                p.loc(),
                format!(
                    "only 'area' emitters can be attached to a shape, not '{}'",
                    p.plugin_type()
                ),
            ));
        }
        let radiance = self.emission_param(&p, "radiance")?;
        p.finish()?;
        self.emitters
            .push(Emitter::Area(AreaLight { shape, radiance }));
        Ok((self.emitters.len() - 1) as u32)
    }

    fn emission_param(&mut self, p: &Props<'d>, name: &str) -> Result<Texture> {
        for c in p.objects() {
            if c.attr("name") == Some(name) {
                let id = self.texture(c)?;
                let t = &self.materials.textures[id as usize];
                if matches!(t, Texture::MeshAttribute(_)) {
                    return Err(Error::scene(
                        &c.loc,
                        format!("a 'mesh_attribute' texture as an emitter's '{name}' is not supported by groove"),
                    ));
                }
                return Ok(t.clone());
            }
        }
        // Mitsuba 3.9.1 defaults an area light's radiance to 1 (`get_emissive_texture(.., 1.f)`).
        let c = p.color_with(name, Spectrum::ONE, SpectrumUse::Emission)?;
        check(
            p.loc(),
            c.min_element() >= 0.0,
            format!("'{name}' must not be negative"),
        )?;
        Ok(Texture::Constant(c))
    }
}
