//! `<medium>` (`homogeneous`, `heterogeneous`), `<volume>` (`constvolume`, `gridvolume`) and `<phase>` (`isotropic`, `hg`, `blendphase`) elements, and the
//! media a shape or the sensor names (`<ref name="interior"/"exterior">`, nested media). The
//! parameter tables are in each plugin's file under `src/medium/`.

use super::{check, unknown, Builder};
use crate::error::{Error, Result};
use crate::geometry::volfile::read_vol;
use crate::medium::homogeneous::Homogeneous;
use crate::medium::phase::{Blend, Hg, Phase};
use crate::medium::volume::{Filter, Grid, Volume, VolumeData, Wrap};
use crate::medium::Heterogeneous;
use crate::medium::{Medium, MediumId};
use crate::scene::xml::ir::Node;
use crate::scene::xml::props::Props;
use crate::spectrum::{Spectrum, SpectrumUse};
use glam::{Mat4, Vec3};

/// A medium element's nested parts, before they are read by the medium's type.
struct MediumParts<'d> {
    phase: Option<Phase>,
    sigma_t: Option<&'d Node>,
    albedo: Option<&'d Node>,
}

impl<'d> Builder<'d> {
    /// The medium of element `n` (a `<medium>` or a `<ref>` to one), built once per element.
    pub(super) fn medium(&mut self, n: &'d Node) -> Result<MediumId> {
        let n = self.ids.resolve(n, "medium")?;
        let key = n as *const Node;
        if let Some(&id) = self.medium_cache.get(&key) {
            return Ok(id);
        }
        let p = self.props(n)?;
        let m = match p.plugin_type() {
            "homogeneous" => Medium::Homogeneous(self.homogeneous(&p)?),
            "heterogeneous" => Medium::Heterogeneous(Box::new(self.heterogeneous(&p)?)),
            t => {
                return Err(unknown(
                    p.loc(),
                    "medium",
                    t,
                    &["homogeneous", "heterogeneous"],
                ))
            }
        };
        p.finish()?;
        let id = self.media.len() as MediumId;
        self.media.push(m);
        self.medium_cache.insert(key, id);
        Ok(id)
    }

    /// A medium's nested phase function and `sigma_t` / `albedo` volume elements.
    fn medium_parts(&mut self, p: &Props<'d>, kind: &str) -> Result<MediumParts<'d>> {
        // Mitsuba 3.9.1's media have no emission: its media read no 'radiance'.
        if p.has("radiance") {
            return Err(Error::scene(
                p.loc(),
                format!(
                    "emissive media are not supported: Mitsuba 3.9.1's '{kind}' medium and its \
                     volpath integrators have no volume emission"
                ),
            ));
        }
        let mut parts = MediumParts {
            phase: None,
            sigma_t: None,
            albedo: None,
        };
        for c in p.objects() {
            match p.kind(c) {
                "phase" => {
                    if parts.phase.is_some() {
                        return Err(Error::scene(
                            &c.loc,
                            "only a single phase function can be specified per medium",
                        ));
                    }
                    parts.phase = Some(self.phase(self.ids.resolve(c, "phase")?)?);
                }
                "volume" => {
                    let name = c.attr("name").unwrap_or("");
                    let v = self.ids.resolve(c, "volume")?;
                    let slot = match name {
                        "sigma_t" => &mut parts.sigma_t,
                        "albedo" => &mut parts.albedo,
                        _ => {
                            return Err(Error::scene(
                                &c.loc,
                                format!(
                                    "a {kind} medium takes volumes named 'sigma_t' or \
                                     'albedo', not '{name}'"
                                ),
                            ))
                        }
                    };
                    if slot.is_some() {
                        return Err(Error::scene(&c.loc, format!("'{name}' is given twice")));
                    }
                    *slot = Some(v);
                }
                t => {
                    return Err(Error::scene(
                        &c.loc,
                        format!("<{t}> is not expected inside a {kind} <medium>"),
                    ))
                }
            }
        }
        Ok(parts)
    }

    fn homogeneous(&mut self, p: &Props<'d>) -> Result<Homogeneous> {
        let parts = self.medium_parts(p, "homogeneous")?;
        let phase = parts.phase;
        let sigma_t = match parts.sigma_t {
            Some(n) => Some(self.const_volume(n, "sigma_t")?),
            None => None,
        };
        // A nested albedo volume: a `constvolume` is a constant as before; a `gridvolume` is
        // looked up per point (Mitsuba 3.9.1's homogeneous medium takes `albedo` as a volume).
        let (albedo, albedo_volume) = match parts.albedo {
            Some(n) => {
                let v = self.volume(n, "albedo")?;
                match v.data {
                    VolumeData::Const(c) => (Some(c), None),
                    VolumeData::Grid(_) => (None, Some(v)),
                }
            }
            None => (None, None),
        };
        let sigma_t = match sigma_t {
            Some(v) => v,
            // Mitsuba 3.9.1 reads an `<rgb>` sigma_t as a reflectance: components in [0, 1] (larger
            // extinctions go through 'scale').
            None => p.color_with("sigma_t", Spectrum::ONE, SpectrumUse::Reflectance)?,
        };
        let albedo = match albedo {
            Some(v) => v,
            // Not read: the grid replaces it (an `albedo` property beside the volume is a
            // duplicate, refused by the parser).
            None if albedo_volume.is_some() => Spectrum::ZERO,
            None => p.color_with("albedo", Spectrum::splat(0.75), SpectrumUse::Reflectance)?,
        };
        let scale = read_scale(p)?;
        check_sigma_t(p, sigma_t)?;
        // A constant albedo lies in [0, 1]; a grid's values are not limited (as in Mitsuba, and
        // as for `heterogeneous`).
        check_albedo(p, albedo)?;
        let sigma_t = sigma_t * scale;
        check(
            p.loc(),
            sigma_t.is_finite(),
            "'sigma_t' times 'scale' overflows",
        )?;
        let m = Homogeneous::new(
            sigma_t,
            albedo,
            phase.unwrap_or(Phase::Isotropic),
            p.bool("sample_emitters", true)?,
            p.bool("has_spectral_extinction", true)?,
        );
        Ok(match albedo_volume {
            Some(v) => m.with_albedo_volume(v),
            None => m,
        })
    }

    fn heterogeneous(&mut self, p: &Props<'d>) -> Result<Heterogeneous> {
        let parts = self.medium_parts(p, "heterogeneous")?;
        // A float / rgb / spectrum parameter is a `constvolume` on the unit cube (Mitsuba's
        // `Properties::get_volume`); its rgb is read as a reflectance, as for `homogeneous`.
        let sigma_t = match parts.sigma_t {
            Some(n) => self.volume(n, "sigma_t")?,
            None => Volume::constant(p.color_with(
                "sigma_t",
                Spectrum::ONE,
                SpectrumUse::Reflectance,
            )?),
        };
        let albedo = match parts.albedo {
            Some(n) => self.volume(n, "albedo")?,
            None => Volume::constant(p.color_with(
                "albedo",
                Spectrum::splat(0.75),
                SpectrumUse::Reflectance,
            )?),
        };
        if let VolumeData::Const(v) = sigma_t.data {
            check_sigma_t(p, v)?;
        }
        if let VolumeData::Const(v) = albedo.data {
            check_albedo(p, v)?;
        }
        let scale = read_scale(p)?;
        check(
            p.loc(),
            (scale * sigma_t.max()).is_finite(),
            "'sigma_t' times 'scale' overflows",
        )?;
        Ok(Heterogeneous::new(
            sigma_t,
            albedo,
            scale,
            parts.phase.unwrap_or(Phase::Isotropic),
            p.bool("sample_emitters", true)?,
            p.bool("has_spectral_extinction", true)?,
        ))
    }

    /// A `<volume>` (`constvolume` or `gridvolume`) for a heterogeneous medium's `name`, or a
    /// homogeneous medium's `albedo`.
    fn volume(&mut self, n: &'d Node, name: &str) -> Result<Volume> {
        let p = self.props(n)?;
        let xf = p.transform_full_opt("to_world")?;
        let (to_world, mut to_local) = match &xf {
            Some(t) => (t.matrix, t.inverse()),
            None => (Mat4::IDENTITY, Mat4::IDENTITY),
        };
        let data = match p.plugin_type() {
            "constvolume" => {
                if let Some(c) = p.objects().next() {
                    return Err(Error::scene(
                        &c.loc,
                        "groove's 'constvolume' takes a float or rgb 'value', not a nested object",
                    ));
                }
                VolumeData::Const(p.color_with("value", Spectrum::ONE, SpectrumUse::Reflectance)?)
            }
            "gridvolume" => {
                if let Some(c) = p.objects().next() {
                    return Err(Error::scene(
                        &c.loc,
                        format!("<{}> is not expected inside a gridvolume", c.tag),
                    ));
                }
                let filter = p.string("filter_type", "trilinear")?;
                let filter = Filter::parse(&filter).ok_or_else(|| {
                    Error::scene(
                        p.loc(),
                        format!(
                            "invalid filter type \"{filter}\", must be one of: \"nearest\" or \
                             \"trilinear\""
                        ),
                    )
                })?;
                let wrap = p.string("wrap_mode", "clamp")?;
                let wrap = Wrap::parse(&wrap).ok_or_else(|| {
                    Error::scene(
                        p.loc(),
                        format!(
                            "invalid wrap mode \"{wrap}\", must be one of: \"repeat\", \
                             \"mirror\", or \"clamp\""
                        ),
                    )
                })?;
                // No effect in an RGB renderer on the CPU (spectral upsampling, CUDA textures).
                p.bool("raw", false)?;
                p.bool("accel", true)?;
                let fname = p.string_opt("filename")?.ok_or_else(|| {
                    Error::scene(
                        p.loc(),
                        "gridvolume needs a 'filename' (Mitsuba's 'grid' and 'data' objects \
                         cannot be given in XML)",
                    )
                })?;
                let file = self.doc.resolve_file(&fname, p.loc())?;
                let err = |e: String| Error::scene(p.loc(), format!("gridvolume '{fname}': {e}"));
                let vol = read_vol(&file, &self.budget).map_err(err)?;
                let bbox = vol.bbox;
                let mut grid = Grid::new(vol, filter, wrap).map_err(err)?;
                if let Some(m) = p.float_opt("max_value")? {
                    check(
                        p.loc(),
                        m.is_finite() && m >= grid.max(),
                        format!(
                            "'max_value' {m} is below the grid's largest value {}: the majorant \
                             would not bound the extinction",
                            grid.max()
                        ),
                    )?;
                    grid.set_max(m);
                }
                if p.bool("use_grid_bbox", false)? {
                    // Mitsuba's `VolumeGrid::bbox_transform`: the file's box to the unit cube.
                    let lo = Vec3::new(bbox[0], bbox[1], bbox[2]);
                    let ext = Vec3::new(bbox[3], bbox[4], bbox[5]) - lo;
                    check(
                        p.loc(),
                        ext.min_element() > 0.0 && ext.is_finite() && lo.is_finite(),
                        format!(
                            "use_grid_bbox: the file's bounding box {lo} .. {} is empty or \
                             not finite",
                            lo + ext
                        ),
                    )?;
                    let to_box = Mat4::from_scale(ext.recip()) * Mat4::from_translation(-lo);
                    to_local = to_box * to_local;
                }
                VolumeData::Grid(grid)
            }
            t => {
                return Err(unknown(
                    p.loc(),
                    "volume",
                    t,
                    &["constvolume", "gridvolume"],
                ))
            }
        };
        check(
            p.loc(),
            to_world.is_finite() && to_local.is_finite(),
            format!("the '{name}' volume's to_world is degenerate"),
        )?;
        p.finish()?;
        // The world box of the (possibly file-boxed) unit cube.
        let to_world = to_local.inverse();
        Ok(Volume::new(data, &to_world, to_local))
    }

    /// A `constvolume` given for a homogeneous medium's `name` parameter (`sigma_t`): its
    /// constant value. A grid is refused: the closed-form free flight needs a constant σt
    /// (Mitsuba 3.9.1 would sample distances with the grid's value at the world origin).
    fn const_volume(&mut self, n: &'d Node, name: &str) -> Result<Spectrum> {
        let p = self.props(n)?;
        if p.plugin_type() != "constvolume" {
            return Err(Error::scene(
                p.loc(),
                format!(
                    "a homogeneous medium's '{name}' must be a constant (float, rgb or \
                     'constvolume'), not a '{}' volume (a varying extinction needs \
                     <medium type=\"heterogeneous\">)",
                    p.plugin_type()
                ),
            ));
        }
        if let Some(c) = p.objects().next() {
            return Err(Error::scene(
                &c.loc,
                "groove's 'constvolume' takes a float or rgb 'value', not a nested object",
            ));
        }
        let v = p.color_with("value", Spectrum::ONE, SpectrumUse::Reflectance)?;
        let _ = p.transform_opt("to_world")?;
        p.finish()?;
        Ok(v)
    }

    /// A `<phase>` (or a `<ref>` to one).
    fn phase(&mut self, n: &'d Node) -> Result<Phase> {
        let p = self.props(n)?;
        let phase = match p.plugin_type() {
            "isotropic" => {
                no_objects(&p)?;
                Phase::Isotropic
            }
            "hg" => {
                no_objects(&p)?;
                let g = p.float("g", 0.8)?;
                check(
                    p.loc(),
                    g > -1.0 && g < 1.0,
                    "the asymmetry parameter 'g' must lie in the interval (-1, 1)",
                )?;
                Phase::Hg(Hg { g })
            }
            "blendphase" => {
                let mut nested = Vec::new();
                for c in p.objects() {
                    if p.kind(c) != "phase" {
                        return Err(Error::scene(
                            &c.loc,
                            format!("<{}> is not expected inside a blendphase", p.kind(c)),
                        ));
                    }
                    if nested.len() == 2 {
                        return Err(Error::scene(
                            &c.loc,
                            "blendphase: cannot specify more than two child phase functions",
                        ));
                    }
                    nested.push(self.phase(self.ids.resolve(c, "phase")?)?);
                }
                let weight = p
                    .float_opt("weight")?
                    .ok_or_else(|| Error::scene(p.loc(), "blendphase needs a float 'weight'"))?;
                let Ok([a, b]) = <[Phase; 2]>::try_from(nested) else {
                    return Err(Error::scene(
                        p.loc(),
                        "blendphase: two child phase functions must be specified",
                    ));
                };
                Phase::Blend(Box::new(Blend {
                    weight: weight.clamp(0.0, 1.0),
                    phases: [a, b],
                }))
            }
            t => {
                return Err(unknown(
                    p.loc(),
                    "phase",
                    t,
                    &["isotropic", "hg", "blendphase"],
                ))
            }
        };
        p.finish()?;
        Ok(phase)
    }
}

fn no_objects(p: &Props<'_>) -> Result<()> {
    match p.objects().next() {
        Some(c) => Err(Error::scene(
            &c.loc,
            format!(
                "<{}> is not expected inside a '{}' phase function",
                c.tag,
                p.plugin_type()
            ),
        )),
        None => Ok(()),
    }
}

impl<'d> Builder<'d> {
    /// A `<medium name="interior"/"exterior">` (or a `<ref>` with that name) inside a shape.
    pub(super) fn shape_medium(
        &mut self,
        c: &'d Node,
        media: &mut crate::medium::MediumInterface,
    ) -> Result<()> {
        let slot = match c.attr("name") {
            Some("interior") => &mut media.interior,
            Some("exterior") => &mut media.exterior,
            other => {
                return Err(Error::scene(
                    &c.loc,
                    format!(
                        "a shape's medium must be named 'interior' or 'exterior', not '{}'",
                        other.unwrap_or("")
                    ),
                ))
            }
        };
        if slot.is_some() {
            return Err(Error::scene(
                &c.loc,
                format!(
                    "a shape takes only one {} medium",
                    c.attr("name").unwrap_or("")
                ),
            ));
        }
        *slot = Some(self.medium(c)?);
        Ok(())
    }
}

/// A medium's `scale`: finite and >= 0 (both medium kinds).
fn read_scale(p: &Props<'_>) -> Result<f32> {
    let scale = p.float("scale", 1.0)?;
    check(
        p.loc(),
        scale >= 0.0 && scale.is_finite(),
        "'scale' must be finite and >= 0",
    )?;
    Ok(scale)
}

/// A constant `sigma_t` (before `scale`): finite and >= 0.
fn check_sigma_t(p: &Props<'_>, v: Spectrum) -> Result<()> {
    check(
        p.loc(),
        v.min_element() >= 0.0 && v.is_finite(),
        "'sigma_t' must be finite and >= 0",
    )
}

/// A constant `albedo`: in [0, 1] (a grid's values are not limited, as in Mitsuba).
fn check_albedo(p: &Props<'_>, v: Spectrum) -> Result<()> {
    check(
        p.loc(),
        v.min_element() >= 0.0 && v.max_element() <= 1.0,
        "'albedo' must lie in [0, 1]",
    )
}
