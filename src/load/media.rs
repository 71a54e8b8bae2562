//! `<medium>` (`homogeneous`) and `<phase>` (`isotropic`, `hg`, `blendphase`) elements, and the
//! media a shape or the sensor names (`<ref name="interior"/"exterior">`, nested media). The
//! parameter tables are in each plugin's file under `src/medium/`.

use super::{check, unknown, Builder};
use crate::error::{Error, Result};
use crate::medium::homogeneous::Homogeneous;
use crate::medium::phase::{Blend, Hg, Phase};
use crate::medium::{Medium, MediumId};
use crate::scene::xml::ir::Node;
use crate::scene::xml::props::Props;
use crate::spectrum::{Spectrum, SpectrumUse};

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
            t => return Err(unknown(p.loc(), "medium", t, &["homogeneous"])),
        };
        p.finish()?;
        let id = self.media.len() as MediumId;
        self.media.push(m);
        self.medium_cache.insert(key, id);
        Ok(id)
    }

    fn homogeneous(&mut self, p: &Props<'d>) -> Result<Homogeneous> {
        // Mitsuba 3.9.1's media have no emission: its `homogeneous` reads no 'radiance'.
        if p.has("radiance") {
            return Err(Error::scene(
                p.loc(),
                "emissive media are not supported: Mitsuba 3.9.1's 'homogeneous' medium and its \
                 volpath integrators have no volume emission",
            ));
        }
        let mut phase = None;
        let mut sigma_t = None;
        let mut albedo = None;
        for c in p.objects() {
            match p.kind(c) {
                "phase" => {
                    if phase.is_some() {
                        return Err(Error::scene(
                            &c.loc,
                            "only a single phase function can be specified per medium",
                        ));
                    }
                    phase = Some(self.phase(self.ids.resolve(c, "phase")?)?);
                }
                "volume" => {
                    let name = c.attr("name").unwrap_or("");
                    let v = self.const_volume(self.ids.resolve(c, "volume")?, name)?;
                    match name {
                        "sigma_t" => sigma_t = Some(v),
                        "albedo" => albedo = Some(v),
                        _ => {
                            return Err(Error::scene(
                                &c.loc,
                                format!(
                                    "a homogeneous medium takes volumes named 'sigma_t' or \
                                     'albedo', not '{name}'"
                                ),
                            ))
                        }
                    }
                }
                t => {
                    return Err(Error::scene(
                        &c.loc,
                        format!("<{t}> is not expected inside a homogeneous <medium>"),
                    ))
                }
            }
        }
        let sigma_t = match sigma_t {
            Some(v) => v,
            // Mitsuba 3.9.1 reads an `<rgb>` sigma_t as a reflectance: components in [0, 1] (larger
            // extinctions go through 'scale').
            None => p.color_with("sigma_t", Spectrum::ONE, SpectrumUse::Reflectance)?,
        };
        let albedo = match albedo {
            Some(v) => v,
            None => p.color_with("albedo", Spectrum::splat(0.75), SpectrumUse::Reflectance)?,
        };
        let scale = p.float("scale", 1.0)?;
        check(
            p.loc(),
            scale >= 0.0 && scale.is_finite(),
            "'scale' must be finite and >= 0",
        )?;
        check(
            p.loc(),
            sigma_t.min_element() >= 0.0 && sigma_t.is_finite(),
            "'sigma_t' must be finite and >= 0",
        )?;
        check(
            p.loc(),
            albedo.min_element() >= 0.0 && albedo.max_element() <= 1.0,
            "'albedo' must lie in [0, 1]",
        )?;
        let sigma_t = sigma_t * scale;
        check(
            p.loc(),
            sigma_t.is_finite(),
            "'sigma_t' times 'scale' overflows",
        )?;
        Ok(Homogeneous {
            sigma_t,
            sigma_s: sigma_t * albedo,
            phase: phase.unwrap_or(Phase::Isotropic),
            sample_emitters: p.bool("sample_emitters", true)?,
            spectral_extinction: p.bool("has_spectral_extinction", true)?,
        })
    }

    /// A `constvolume` given for a homogeneous medium's `name` parameter: its constant value.
    fn const_volume(&mut self, n: &'d Node, name: &str) -> Result<Spectrum> {
        let p = self.props(n)?;
        if p.plugin_type() != "constvolume" {
            return Err(Error::scene(
                p.loc(),
                format!(
                    "a homogeneous medium's '{name}' must be a constant (float, rgb or \
                     'constvolume'), not a '{}' volume",
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
