//! `<texture>`s (`bitmap`, `checkerboard`, `rawconstant`, `mesh_attribute`) and the colour
//! parameters that may be a constant or a texture; the checks of the textures whose use depends
//! on the shape they are evaluated on.

use super::{unknown, Builder};
use crate::error::{Error, Result, SourceLoc};
use crate::material::{MatId, TexId};
use crate::scene::xml::ir::Node;
use crate::scene::xml::props::Props;
use crate::spectrum::Spectrum;
use crate::texture::Texture;
use glam::{Mat3, Mat4, Vec3};

impl<'d> Builder<'d> {
    /// A colour parameter that may be a constant or a texture (child `<texture name>` or
    /// `<ref name id>` to a texture).
    pub(super) fn color_param(
        &mut self,
        p: &Props<'d>,
        name: &str,
        default: Spectrum,
    ) -> Result<TexId> {
        for c in p.objects() {
            if c.attr("name") == Some(name) {
                if p.kind(c) == "texture" {
                    return self.texture(c);
                }
                return Err(Error::scene(
                    &c.loc,
                    format!(
                        "'{name}' expects a colour or a <texture>, not a <{}>",
                        c.tag
                    ),
                ));
            }
        }
        let c = p.color(name, default)?;
        Ok(self.materials.add_texture(Texture::Constant(c)))
    }

    /// Builds `<texture>` `n` (or the one a `<ref>` names) once; a texture with an id is shared
    /// by every reference to it.
    pub(super) fn texture(&mut self, n: &'d Node) -> Result<TexId> {
        let n = self.ids.resolve(n, "texture")?;
        if let Some(id) = n.attr("id") {
            if let Some(&t) = self.tex_cache.get(id) {
                return Ok(t);
            }
        }
        let p = self.props(n)?;
        let mut vector_only = false;
        let tex = match p.plugin_type() {
            "checkerboard" => {
                let c0 = p.color("color0", Spectrum::splat(0.4))?;
                let c1 = p.color("color1", Spectrum::splat(0.2))?;
                let m = p.transform("to_uv")?;
                Texture::Checkerboard {
                    color0: c0,
                    color1: c1,
                    to_uv: mat4_to_uv(&m),
                }
            }
            "bitmap" => self.bitmap_texture(&p)?,
            "rawconstant" => {
                let r = crate::texture::rawconstant::load::build(&p)?;
                if r.vector {
                    vector_only = true;
                }
                Texture::Constant(r.value)
            }
            "mesh_attribute" => {
                Texture::MeshAttribute(crate::texture::mesh_attribute::load::build(&p)?)
            }
            t => {
                return Err(unknown(
                    p.loc(),
                    "texture",
                    t,
                    &["bitmap", "checkerboard", "mesh_attribute", "rawconstant"],
                ))
            }
        };
        p.finish()?;
        let id = self.materials.add_texture(tex);
        if vector_only
            || matches!(
                self.materials.textures[id as usize],
                Texture::MeshAttribute(_)
            )
        {
            self.hit_checked.insert(id, (n, vector_only));
        }
        if let Some(i) = n.attr("id") {
            self.tex_cache.insert(i, id);
        }
        Ok(id)
    }

    /// Mitsuba 3's `bitmap`: `filename`, `raw`, `filter_type`, `wrap_mode`, `to_uv`, `format`
    /// (`accel` is accepted and has no effect on the CPU). Any problem with the image is an
    /// error at the `<texture>` naming the file.
    fn bitmap_texture(&mut self, p: &Props<'d>) -> Result<Texture> {
        use crate::texture::{BitmapOptions, BitmapTexture, FilterType, StorageFormat, WrapMode};
        let fname = p
            .string_opt("filename")?
            .ok_or_else(|| Error::scene(p.loc(), "texture 'bitmap' needs a 'filename'"))?;
        let file = self.doc.resolve_file(&fname, p.loc())?;
        let choice = |name: &str, default: &str, allowed: &str| -> Result<String> {
            let v = p.string(name, default)?;
            if allowed.split(", ").any(|a| a == v) {
                Ok(v)
            } else {
                Err(Error::scene(
                    p.loc(),
                    format!(
                        "invalid {name} '{v}' for texture 'bitmap' (must be one of: {allowed})"
                    ),
                ))
            }
        };
        let filter = choice("filter_type", "bilinear", "bilinear, nearest")?;
        let wrap = choice("wrap_mode", "repeat", "repeat, mirror, clamp")?;
        let format = choice("format", "auto", "auto, variant, fp16")?;
        let opts = BitmapOptions {
            raw: p.bool("raw", false)?,
            filter: FilterType::parse(&filter).unwrap_or_default(),
            wrap: WrapMode::parse(&wrap).unwrap_or_default(),
            to_uv: mat4_to_uv(&p.transform("to_uv")?),
            format: StorageFormat::parse(&format).unwrap_or_default(),
        };
        let _ = p.bool("accel", true)?;
        let bmp = BitmapTexture::load_within(&file, &opts, &self.budget)
            .map_err(|e| self.file_error(p, "bitmap texture", &fname, e))?;
        for w in bmp.warnings() {
            self.warnings.push(format!("{}: {w}", p.loc()));
        }
        Ok(Texture::from(bmp))
    }
}

/// The 2-D affine part of a `to_uv` transform.
fn mat4_to_uv(m: &Mat4) -> Mat3 {
    Mat3::from_cols(
        Vec3::new(m.x_axis.x, m.x_axis.y, 0.0),
        Vec3::new(m.y_axis.x, m.y_axis.y, 0.0),
        Vec3::new(m.w_axis.x, m.w_axis.y, 1.0),
    )
}

impl<'d> Builder<'d> {
    /// Checks what Mitsuba 3.9.1 only finds when it renders shape `shape` with material
    /// `material`: every `mesh_attribute` texture the material evaluates names an attribute of
    /// the shape with a usable size (1 or 3 values as a colour, 1 as a scalar), and no 3-D
    /// `rawconstant` is read as a scalar. Errors are at the texture, naming the shape; the
    /// messages are Mitsuba's.
    pub(super) fn check_hit_textures(
        &self,
        material: MatId,
        shape: &crate::geometry::Shape,
        shape_loc: &SourceLoc,
    ) -> Result<()> {
        if self.hit_checked.is_empty() {
            return Ok(());
        }
        let mut uses: Vec<(TexId, bool)> = Vec::new();
        self.materials
            .texture_uses(material, &mut |t, scalar| uses.push((t, scalar)));
        for (t, scalar) in uses {
            let Some(&(node, vector_only)) = self.hit_checked.get(&t) else {
                continue;
            };
            if vector_only {
                if scalar {
                    return Err(Error::scene(
                        &node.loc,
                        crate::texture::rawconstant::NO_SCALAR,
                    ));
                }
                continue;
            }
            let Texture::MeshAttribute(m) = &self.materials.textures[t as usize] else {
                continue;
            };
            let at_shape = |msg: String| {
                Error::scene(&node.loc, format!("{msg} (on the shape at {shape_loc})"))
            };
            let Some(a) = crate::geometry::attributes::find(shape.attributes(), &m.name) else {
                let have: Vec<&str> = shape.attributes().iter().map(|a| a.name.as_str()).collect();
                let have = if have.is_empty() {
                    "which has no attributes".to_string()
                } else {
                    format!("which has {}", have.join(", "))
                };
                return Err(Error::scene(
                    &node.loc,
                    format!(
                        "Invalid attribute requested {}. (on the shape at {shape_loc}, {have})",
                        m.name
                    ),
                ));
            };
            let ok = if scalar {
                a.dim == 1
            } else {
                a.dim == 1 || a.dim == 3
            };
            if !ok {
                let f = if scalar {
                    "eval_attribute_1"
                } else {
                    "eval_attribute"
                };
                return Err(at_shape(format!(
                    "{f}(): Attribute \"{}\" requested but had size {}.",
                    m.name, a.dim
                )));
            }
        }
        Ok(())
    }
}
