//! Mitsuba 3's `mesh_attribute` texture: the value of a mesh attribute (per-vertex values
//! interpolated with the hit's barycentric coordinates, or per-face values) times `scale`
//! (`src/textures/mesh_attribute.cpp`, `Mesh::eval_attribute` in `src/render/mesh.cpp`).
//!
//! # XML parameters
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `name` | string | required | the attribute, `vertex_<x>` or `face_<x>` (e.g. `vertex_color` from a PLY file's `r g b` / `red green blue` vertex properties) |
//! | `scale` | float | 1 | factor applied to the attribute's value |
//!
//! The attribute belongs to the shape that is hit, so one texture serves every mesh its BSDF is
//! on. A one-value attribute evaluates to grey; a three-value one to RGB (its values as stored:
//! no colour conversion). The loader checks, for every shape the texture's BSDF is attached to,
//! what Mitsuba 3.9.1 only finds when it renders: the attribute exists (else Mitsuba's "Invalid
//! attribute requested …"), has 1 or 3 values (colour uses) or 1 value (scalar uses such as a
//! roughness). The texture has no mean (Mitsuba's `mean()` is not implemented either), so BSDFs
//! that need one at load time (`plastic`, `roughplastic`) reject it, as Mitsuba does; nor can it
//! drive an area light's radiance in groove.

use crate::geometry::attributes::{find, Attribute};
use crate::geometry::TriMesh;
use glam::Vec3;

/// A `mesh_attribute` texture.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshAttributeTexture {
    /// `vertex_…` or `face_…`.
    pub name: String,
    pub scale: f32,
}

/// The mesh data a `mesh_attribute` lookup needs: the hit shape's attributes, its triangles and
/// the hit (triangle `prim`, world-space point `p`).
#[derive(Clone, Copy, Debug)]
pub struct MeshPoint<'a> {
    pub attributes: &'a [Attribute],
    pub mesh: &'a TriMesh,
    pub prim: u32,
    pub p: Vec3,
}

impl MeshAttributeTexture {
    /// The value at `at`: 0 where no mesh (or no such attribute) is at hand, as Mitsuba's
    /// vectorised variants return (the loader makes sure a rendered hit always has it).
    #[inline]
    pub fn eval(&self, at: Option<&MeshPoint<'_>>) -> Vec3 {
        let Some(m) = at else {
            return Vec3::ZERO;
        };
        match find(m.attributes, &self.name) {
            Some(a) => a.eval(m.mesh, m.prim, m.p) * self.scale,
            None => Vec3::ZERO,
        }
    }
}

pub(crate) mod load {
    use super::MeshAttributeTexture;
    use crate::error::{Error, Result};
    use crate::scene::xml::props::Props;

    /// `mesh_attribute`.
    pub(crate) fn build(p: &Props<'_>) -> Result<MeshAttributeTexture> {
        let name = p.string_opt("name")?.ok_or_else(|| {
            Error::scene(
                p.loc(),
                "texture 'mesh_attribute' needs a 'name' (vertex_<x> or face_<x>)",
            )
        })?;
        // Mitsuba's test is that the name contains "vertex_" or "face_" (anywhere).
        if !(name.contains("vertex_") || name.contains("face_")) {
            return Err(Error::scene(
                p.loc(),
                format!("Invalid mesh attribute name: must be start with either \"vertex_\" or \"face_\" but was \"{name}\"."),
            ));
        }
        let scale = p.float("scale", 1.0)?;
        if !scale.is_finite() {
            return Err(Error::scene(
                p.loc(),
                "'scale' of texture 'mesh_attribute' must be finite",
            ));
        }
        Ok(MeshAttributeTexture { name, scale })
    }
}
