//! The top-level `<emitter>`s: `point`, `constant`, `spot`, `projector`, `directional`,
//! `envmap` (and `area` emitters declared with an id for shapes to `<ref>`). The parameter
//! tables are in each light's own file under `src/emitter/`.

use super::{check, unknown, Builder};
use crate::budget::{bytes_of, Budget};
use crate::emitter::constant::ConstantLight;
use crate::emitter::directional::DirectionalLight;
use crate::emitter::envmap::EnvMapLight;
use crate::emitter::point::PointLight;
use crate::emitter::projector::ProjectorLight;
use crate::emitter::spot::SpotLight;
use crate::emitter::Emitter;
use crate::error::{Error, Result};
use crate::scene::xml::ir::{Document, Node};
use crate::scene::xml::props::Props;
use crate::spectrum::{Spectrum, SpectrumUse};
use crate::texture::float_image;
use crate::texture::Texture;
use glam::{Mat3, Vec3};
use std::path::Path;

impl<'d> Builder<'d> {
    pub(super) fn top_level_emitter(&mut self, n: &'d Node) -> Result<()> {
        let p = self.props(n)?;
        let e = match p.plugin_type() {
            "area" => {
                // Declared for reference by shapes; validated when referenced.
                if n.attr("id").is_none() {
                    return Err(Error::scene(p.loc(), "an 'area' emitter must be attached to a shape (nest it in a <shape> or give it an id and <ref> it)"));
                }
                p.mark_used("radiance");
                return Ok(());
            }
            "point" => {
                let intensity = p.color_with("intensity", Spectrum::ONE, SpectrumUse::Emission)?;
                let m = p.transform("to_world")?;
                let pos = if p.has("position") {
                    p.point("position", Vec3::ZERO)?
                } else {
                    m.transform_point3(Vec3::ZERO)
                };
                Emitter::Point(PointLight {
                    position: pos,
                    intensity,
                })
            }
            "constant" => {
                let r = p.color_with("radiance", Spectrum::ONE, SpectrumUse::Emission)?;
                Emitter::Constant(ConstantLight { radiance: r })
            }
            "spot" => self.spot_emitter(&p)?,
            "projector" => self.projector_emitter(&p)?,
            "directional" => directional_emitter(&p)?,
            "envmap" => envmap_emitter(self.doc, &p, &self.budget)?,
            t => {
                return Err(unknown(
                    p.loc(),
                    "emitter",
                    t,
                    &[
                        "area",
                        "point",
                        "constant",
                        "spot",
                        "projector",
                        "directional",
                        "envmap",
                    ],
                ))
            }
        };
        p.finish()?;
        self.emitters.push(e);
        Ok(())
    }
}

/// Rejects nested objects (textures) in an emitter that only takes plain values.
fn no_nested_objects(p: &Props<'_>, what: &str) -> Result<()> {
    if let Some(c) = p.objects().next() {
        return Err(Error::scene(
            &c.loc,
            format!(
                "emitter '{what}' takes no nested <{}> (name '{}'): textured {what} lights are not supported; give plain values",
                c.tag,
                c.attr("name").unwrap_or_default()
            ),
        ));
    }
    Ok(())
}

/// A non-negative emitted colour.
fn emission_color(p: &Props<'_>, name: &str) -> Result<Spectrum> {
    let c = p.color_with(name, Spectrum::ONE, SpectrumUse::Emission)?;
    check(
        p.loc(),
        crate::spectrum::is_finite(c) && c.min_element() >= 0.0,
        format!("'{name}' must be finite and not negative"),
    )?;
    Ok(c)
}

impl<'d> Builder<'d> {
    /// Mitsuba 3 `spot`: `intensity`, `texture`, `cutoff_angle` (20°), `beam_width` (¾ cutoff),
    /// `to_world` (see `emitter::spot`).
    fn spot_emitter(&mut self, p: &Props<'d>) -> Result<Emitter> {
        let texture = self.spot_texture(p)?;
        let intensity = emission_color(p, "intensity")?;
        let cutoff = p.float("cutoff_angle", 20.0)?;
        let beam = p.float("beam_width", cutoff * 0.75)?;
        check(
            p.loc(),
            cutoff.is_finite() && cutoff > 0.0 && cutoff <= 180.0,
            format!("'cutoff_angle' must be in (0, 180] degrees (it is {cutoff})"),
        )?;
        check(
            p.loc(),
            beam.is_finite() && (0.0..=cutoff).contains(&beam),
            format!("'beam_width' must be in [0, cutoff_angle = {cutoff}] degrees (it is {beam})"),
        )?;
        let xf = p.transform_full("to_world")?;
        let m = xf.matrix;
        let to_local = Mat3::from_mat4(xf.inverse());
        check(
            p.loc(),
            m.transform_vector3(Vec3::Z).length() > 1e-12 && to_local.is_finite(),
            "the spot light's 'to_world' is degenerate (not invertible)",
        )?;
        Ok(Emitter::Spot(SpotLight::new(
            m.transform_point3(Vec3::ZERO),
            to_local,
            intensity,
            texture,
            cutoff.to_radians(),
            beam.to_radians(),
        )))
    }

    /// The spot's `texture`, which Mitsuba requires to be spatially varying; any other nested
    /// object (a textured `intensity`) is an error, as in Mitsuba.
    fn spot_texture(&mut self, p: &Props<'d>) -> Result<Option<Texture>> {
        let mut texture = None;
        for c in p.objects() {
            let name = c.attr("name").unwrap_or_default();
            if name == "texture" && p.kind(c) == "texture" {
                let id = self.texture(c)?;
                texture = Some(self.materials.textures[id as usize].clone());
                continue;
            }
            let what = if name == "intensity" {
                "'intensity' cannot be spatially varying (Mitsuba refuses it too); give a colour, \
                 and a texture as 'texture'"
                    .to_string()
            } else {
                format!("takes no nested <{}> named '{name}'", c.tag)
            };
            return Err(Error::scene(&c.loc, format!("emitter 'spot': {what}")));
        }
        if texture.is_none() && p.has("texture") {
            // A plain value: Mitsuba's "The parameter 'texture' must be spatially varying".
            p.mark_used("texture");
            return Err(Error::scene(
                p.loc(),
                "emitter 'spot': 'texture' must be spatially varying (e.g. a bitmap); for a \
                 uniform colour use 'intensity'",
            ));
        }
        Ok(texture)
    }

    /// Mitsuba 3 `projector`: `irradiance`, `scale`, `fov`/`fov_axis` or `focal_length`,
    /// `to_world` (see `emitter::projector`).
    fn projector_emitter(&mut self, p: &Props<'d>) -> Result<Emitter> {
        let irradiance = self.projector_irradiance(p)?;
        let scale = p.float("scale", 1.0)?;
        check(
            p.loc(),
            scale.is_finite() && scale >= 0.0,
            format!("'scale' must be finite and not negative (it is {scale})"),
        )?;
        // Mitsuba: the image's aspect ratio is the texture's (1 x 1 unless a bitmap).
        let (w, h) = irradiance.resolution().unwrap_or((1, 1));
        let aspect = w as f64 / h as f64;
        let (fov, axis) = crate::camera::perspective::fov_from_props(p)?;
        check(
            p.loc(),
            fov.is_finite() && fov > 0.0 && fov < 180.0,
            format!("'fov' must be in (0, 180) degrees (it is {fov})"),
        )?;
        let tan_half_x = crate::camera::perspective::tan_half_x_fov(fov, axis, aspect);
        let x_fov = 2.0 * tan_half_x.atan().to_degrees();
        check(
            p.loc(),
            x_fov > 0.0 && x_fov < 180.0,
            format!("the horizontal field of view must be in (0, 180) degrees (it is {x_fov})"),
        )?;
        let xf = p.transform_full("to_world")?;
        let to_local = xf.inverse();
        check(
            p.loc(),
            to_local.is_finite() && xf.matrix.determinant() != 0.0,
            "the projector's 'to_world' is not invertible",
        )?;
        Ok(Emitter::Projector(ProjectorLight::new(
            xf.matrix,
            to_local,
            irradiance,
            scale,
            tan_half_x as f32,
            aspect as f32,
        )))
    }

    /// The projector's `irradiance`: a texture, or a colour (default 1), not negative.
    fn projector_irradiance(&mut self, p: &Props<'d>) -> Result<Texture> {
        let mut texture = None;
        for c in p.objects() {
            let name = c.attr("name").unwrap_or_default();
            if name != "irradiance" || p.kind(c) != "texture" || texture.is_some() {
                return Err(Error::scene(
                    &c.loc,
                    format!(
                        "emitter 'projector' takes no nested <{}> named '{name}' here",
                        c.tag
                    ),
                ));
            }
            let id = self.texture(c)?;
            texture = Some(self.materials.textures[id as usize].clone());
        }
        match texture {
            Some(t) => Ok(t),
            None => Ok(Texture::Constant(emission_color(p, "irradiance")?)),
        }
    }
}

/// Mitsuba 3 `directional`: `irradiance`, and `direction` or `to_world` (light travels along +z).
fn directional_emitter(p: &Props<'_>) -> Result<Emitter> {
    no_nested_objects(p, "directional")?;
    let irradiance = emission_color(p, "irradiance")?;
    let dir = p.point_opt("direction")?;
    let m = p.transform_opt("to_world")?;
    let d = match (dir, m) {
        (Some(_), Some(_)) => {
            return Err(Error::scene(
                p.loc(),
                "give the directional light either 'direction' or 'to_world', not both",
            ))
        }
        (Some(d), None) => d,
        (None, Some(m)) => m.transform_vector3(Vec3::Z),
        (None, None) => Vec3::Z,
    };
    check(
        p.loc(),
        d.is_finite() && d.length() > 1e-12,
        format!("the directional light's direction must be a non-zero vector (it is {d})"),
    )?;
    Ok(Emitter::Directional(DirectionalLight {
        direction: d.normalize(),
        irradiance,
    }))
}

/// Mitsuba 3 `envmap`: `filename` (a lat-long OpenEXR, Radiance RGBE or PFM image, recognised by
/// content as Mitsuba does), `scale`, `to_world` (a rotation).
fn envmap_emitter(doc: &Document, p: &Props<'_>, budget: &Budget) -> Result<Emitter> {
    no_nested_objects(p, "envmap")?;
    let name = p
        .string_opt("filename")?
        .ok_or_else(|| Error::scene(p.loc(), "emitter 'envmap' needs a 'filename'"))?;
    let scale = p.float("scale", 1.0)?;
    let m = p.transform("to_world")?;
    let file = doc.resolve_file(&name, p.loc())?;
    let img = envmap_image(&file, budget)
        .map_err(|e| Error::scene(p.loc(), format!("cannot read envmap '{name}': {e}")))?;
    // The rotation part, which may carry a uniform scale (removed); anything else is rejected.
    let r = Mat3::from_mat4(m);
    let s = r.determinant().abs().cbrt();
    let rot = r * (1.0 / s);
    let ortho =
        s.is_finite() && s > 0.0 && (rot.transpose() * rot).abs_diff_eq(Mat3::IDENTITY, 1e-4);
    check(
        p.loc(),
        ortho,
        "envmap 'to_world' must be a rotation (no shear or non-uniform scale)",
    )?;
    let light = EnvMapLight::new(
        img.width as usize,
        img.height as usize,
        &img.data,
        scale,
        rot,
    )
    .map_err(|e| Error::scene(p.loc(), format!("envmap '{name}': {e}")))?;
    Ok(Emitter::EnvMap(light))
}

/// The pixels of an environment map file (RGB, top row first; grey images in all three
/// channels). The light keeps a copy of the pixels and its sampling distribution (~20 bytes a
/// pixel besides the decoded image), checked against `budget` from the header before decoding.
fn envmap_image(file: &Path, budget: &Budget) -> Result<crate::film::Image> {
    const KEEP: u64 = 20;
    let mut magic = Vec::with_capacity(4);
    {
        use std::io::Read;
        let (f, _) = crate::inputs::open_regular(file)?;
        f.take(4)
            .read_to_end(&mut magic)
            .map_err(|e| Error::io(file, e))?;
    }
    if magic == [0x76, 0x2f, 0x31, 0x01] {
        return crate::output::read_exr_within(file, budget, KEEP).map(|(img, _)| img);
    }
    let bytes = crate::inputs::read_regular(file, budget)?;
    let Some(header) = float_image::header(&bytes) else {
        return Err(Error::file(
            file,
            "unsupported image format (environment maps are read from OpenEXR, Radiance RGBE (.hdr) and PFM files)",
        ));
    };
    let h = header.map_err(|m| Error::file(file, m))?;
    let (w, ht) = (h.width as u64, h.height as u64);
    let what = format!("envmap image {w}×{ht} ({})", file.display());
    let decoded = h.decoded_bytes();
    budget
        .check(decoded.saturating_add(bytes_of(&[w, ht, 12 + KEEP])), &what)
        .and_then(|_| budget.reserve(bytes_of(&[w, ht, 12 + KEEP]), &what))
        .map_err(|m| Error::file(file, m))?;
    let img = float_image::decode(&bytes, &h).map_err(|m| Error::file(file, m))?;
    Ok(crate::film::Image {
        width: img.width,
        height: img.height,
        data: (0..img.pixel_count()).map(|i| img.rgb(i)).collect(),
    })
}
