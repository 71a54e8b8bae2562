//! The render settings of a scene: `<integrator>` (`path`, `volpath`, `volpathmis`, `direct`, `ptracer`, `moment`, `aov`), `<sensor>`
//! (`perspective`), `<film>` (`hdrfilm`), `<rfilter>` (`box`, `tent`, `gaussian`) and
//! `<sampler>` (`independent`, `stratified`), with Mitsuba 3's parameter names and defaults.

use super::{check, unknown, Builder};
use crate::camera::{Camera, Orthographic, ThinLens};
use crate::error::{Error, Result, SourceLoc};
use crate::film::{FilmDesc, Filter};
use crate::integrator::aov::{AovKind, AovSettings};
use crate::integrator::moment::MomentSettings;
use crate::integrator::ptracer::PtracerSettings;
use crate::integrator::volpath::VolpathSettings;
use crate::integrator::volpathmis::VolpathMisSettings;
use crate::integrator::{DirectSettings, IntegratorDesc, PathSettings};
use crate::sampler::{SamplerDesc, SamplerKind};
use crate::scene::xml::ir::Node;
use crate::scene::xml::props::Props;
use std::sync::Arc;

impl<'d> Builder<'d> {
    pub(super) fn integrator(&mut self, n: &'d Node) -> Result<IntegratorDesc> {
        let p = self.props(n)?;
        let d = match p.plugin_type() {
            "path" => {
                let (max_depth, rr_depth) = depths(&p)?;
                IntegratorDesc::Path(PathSettings {
                    max_depth,
                    rr_depth,
                    hide_emitters: p.bool("hide_emitters", false)?,
                    ..Default::default()
                })
            }
            "volpath" => {
                // Mitsuba 3.9.1's MonteCarloIntegrator: max_depth -1 or >= 0, rr_depth > 0.
                let (max_depth, rr_depth) = depths(&p)?;
                IntegratorDesc::Volpath(VolpathSettings {
                    max_depth,
                    rr_depth,
                    hide_emitters: p.bool("hide_emitters", false)?,
                })
            }
            "volpathmis" => {
                // Mitsuba 3.9.1's MonteCarloIntegrator (as volpath) and volpathmis's own
                // 'use_spectral_mis'.
                let (max_depth, rr_depth) = depths(&p)?;
                IntegratorDesc::VolpathMis(Arc::new(VolpathMisSettings {
                    max_depth,
                    rr_depth,
                    hide_emitters: p.bool("hide_emitters", false)?,
                    spectral_mis: p.bool("use_spectral_mis", true)?,
                    loc: p.loc().clone(),
                }))
            }
            "direct" => {
                // Mitsuba 3: 'shading_samples' sets both counts and excludes the other two.
                check(
                    p.loc(),
                    !(p.has("shading_samples")
                        && (p.has("emitter_samples") || p.has("bsdf_samples"))),
                    "give either 'shading_samples' or 'emitter_samples'/'bsdf_samples', not both",
                )?;
                let shading = p.int("shading_samples", 1)?;
                let em = p.int("emitter_samples", shading)?;
                let bs = p.int("bsdf_samples", shading)?;
                check(
                    p.loc(),
                    em >= 0 && bs >= 0 && em + bs > 0,
                    "sample counts must be >= 0 and not both 0",
                )?;
                check(
                    p.loc(),
                    em <= u32::MAX as i64 && bs <= u32::MAX as i64,
                    "sample counts must be below 2^32",
                )?;
                if em > 1 {
                    // Warned about once the emitters are known (see `instantiate_within`).
                    self.direct_emitter_samples
                        .push((p.loc().clone(), em as u32));
                }
                IntegratorDesc::Direct(DirectSettings {
                    emitter_samples: em as u32,
                    bsdf_samples: bs as u32,
                    hide_emitters: p.bool("hide_emitters", false)?,
                })
            }
            "ptracer" => {
                // Mitsuba 3.9.1's AdjointIntegrator: rr_depth > 0, max_depth -1 or >= 0,
                // samples_per_pass an unsigned count (default: all samples in one pass).
                let max_depth = p.int("max_depth", -1)?;
                check(
                    p.loc(),
                    max_depth >= -1,
                    "max_depth must be set to -1 (infinite) or a value >= 0",
                )?;
                let rr_depth = p.int("rr_depth", 5)?;
                check(
                    p.loc(),
                    rr_depth > 0,
                    "rr_depth must be set to a value greater than zero",
                )?;
                let samples_per_pass = match p.int_opt("samples_per_pass")? {
                    None => None,
                    Some(v) => {
                        check(
                            p.loc(),
                            v >= 1 && v <= u32::MAX as i64,
                            "samples_per_pass must be a positive sample count",
                        )?;
                        Some(v as u32)
                    }
                };
                IntegratorDesc::Ptracer(Arc::new(PtracerSettings {
                    max_depth: max_depth.min(i32::MAX as i64) as i32,
                    rr_depth: rr_depth.min(i32::MAX as i64) as i32,
                    hide_emitters: p.bool("hide_emitters", false)?,
                    samples_per_pass,
                    loc: p.loc().clone(),
                }))
            }
            "moment" => IntegratorDesc::Moment(Arc::new(MomentSettings {
                inner: self.nested_integrators(&p)?,
            })),
            "aov" => {
                let inner = self.nested_integrators(&p)?;
                let spec_loc = p.property_node("aovs").map(|n| n.loc.clone());
                let spec = p.string_opt("aovs")?.ok_or_else(|| {
                    Error::scene(p.loc(), "aov needs a string 'aovs' (\"name:type,...\")")
                })?;
                let loc = spec_loc.as_ref().unwrap_or(p.loc());
                let entries = self.aov_entries(&spec, loc)?;
                if inner.is_empty() && entries.is_empty() {
                    self.warnings
                        .push(format!("{}: aov: no AOVs were specified", p.loc()));
                }
                IntegratorDesc::Aov(Arc::new(AovSettings { inner, entries }))
            }
            t => {
                return Err(unknown(
                    p.loc(),
                    "integrator",
                    t,
                    &[
                        "path",
                        "volpath",
                        "volpathmis",
                        "direct",
                        "ptracer",
                        "moment",
                        "aov",
                    ],
                ))
            }
        };
        p.finish()?;
        Ok(d)
    }

    /// The nested integrators of a `moment` or `aov`, named as Mitsuba names them: the `name`
    /// attribute, else `_arg_<i>` counting the unnamed nested objects from 0.
    fn nested_integrators(&mut self, p: &Props<'d>) -> Result<Vec<(String, IntegratorDesc)>> {
        let mut inner = Vec::new();
        let mut unnamed = 0;
        for c in p.objects() {
            if p.kind(c) != "integrator" {
                return Err(Error::scene(
                    &c.loc,
                    format!(
                        "{}: child objects must be integrators, not <{}>",
                        p.plugin_type(),
                        p.kind(c)
                    ),
                ));
            }
            let name = match c.attr("name") {
                Some(n) => n.to_string(),
                None => {
                    unnamed += 1;
                    format!("_arg_{}", unnamed - 1)
                }
            };
            let target = match c.tag.as_str() {
                "ref" => self.ids.resolve(c, "integrator")?,
                _ => c,
            };
            let desc = self.integrator(target)?;
            if matches!(desc, IntegratorDesc::Ptracer(_)) {
                return Err(Error::scene(
                    &target.loc,
                    format!(
                        "{}: a ptracer cannot be nested (it splats light paths, it does not \
                         estimate a camera ray; Mitsuba refuses it too)",
                        p.plugin_type()
                    ),
                ));
            }
            inner.push((name, desc));
        }
        Ok(inner)
    }

    /// The entries of an `aov` integrator's `aovs` string: comma-separated `name:type` pairs
    /// (Mitsuba tokenises on commas and colons; an empty list is allowed).
    fn aov_entries(&mut self, spec: &str, loc: &SourceLoc) -> Result<Vec<(String, AovKind)>> {
        let mut out = Vec::new();
        for token in spec.split(',').map(str::trim).filter(|t| !t.is_empty()) {
            let item: Vec<&str> = token.split(':').map(str::trim).collect();
            if item.len() != 2 || item[0].is_empty() || item[1].is_empty() {
                return Err(Error::scene(
                    loc,
                    format!("aov: invalid AOV specification '{token}': expected <name>:<type>"),
                ));
            }
            let kind = match AovKind::parse(item[1]) {
                Some(k) => k,
                None => {
                    let msg = if ["albedo", "duv_dx", "duv_dy"].contains(&item[1]) {
                        format!(
                            "aov: Mitsuba's AOV type '{}' is not supported by groove (groove has: {})",
                            item[1],
                            AovKind::NAMES.join(", ")
                        )
                    } else {
                        format!(
                            "aov: invalid AOV type '{}' (types: {})",
                            item[1],
                            AovKind::NAMES.join(", ")
                        )
                    };
                    return Err(Error::scene(loc, msg));
                }
            };
            out.push((item[0].to_string(), kind));
        }
        Ok(out)
    }

    pub(super) fn sensor(&mut self, n: &'d Node) -> Result<(Camera, FilmDesc, SamplerDesc)> {
        let p = self.props(n)?;
        const SENSORS: [&str; 3] = ["perspective", "orthographic", "thinlens"];
        if !SENSORS.contains(&p.plugin_type()) {
            return Err(unknown(p.loc(), "sensor", p.plugin_type(), &SENSORS));
        }
        let mut film: Option<FilmDesc> = None;
        let mut sampler: Option<SamplerDesc> = None;
        for c in p.objects() {
            // A `<ref>` to a top-level `<sampler id>` or `<film id>` (Mitsuba allows both).
            match p.kind(c) {
                "film" => film = Some(self.film(self.ids.resolve(c, "film")?)?),
                "sampler" => sampler = Some(self.sampler(self.ids.resolve(c, "sampler")?)?),
                // Mitsuba 3: a medium nested in (or referenced by) the sensor, whatever its name.
                "medium" => {
                    if self.camera_medium.is_some() {
                        return Err(Error::scene(&c.loc, "a sensor takes only one medium"));
                    }
                    self.camera_medium = Some(self.medium(c)?);
                }
                t => {
                    return Err(Error::scene(
                        &c.loc,
                        format!("<{t}> is not expected inside a <sensor>"),
                    ))
                }
            }
        }
        let film = match film {
            Some(f) => f,
            None => self.film_defaults(p.loc())?,
        };
        let sampler = sampler.unwrap_or(SamplerDesc {
            kind: SamplerKind::Independent,
            sample_count: 4,
            seed: 0,
        });
        // Each of these sensors reads its own parameters (in its file under src/camera/).
        let size = (film.width, film.height);
        let camera = match p.plugin_type() {
            "orthographic" => Some(Camera::Orthographic(Orthographic::from_props(&p, size)?)),
            "thinlens" => Some(Camera::ThinLens(ThinLens::from_props(&p, size)?)),
            _ => None,
        };
        if let Some(camera) = camera {
            p.finish()?;
            return Ok((camera, film, sampler));
        }
        let to_world = p.transform("to_world")?;
        let (fov, axis) = crate::camera::perspective::fov_from_props(&p)?;
        let near = p.float("near_clip", 0.01)?;
        let far = p.float("far_clip", 10000.0)?;
        // Depth of field parameters of the base camera that `perspective` ignores.
        let _ = p.float("focus_distance", 0.0)?;
        let _ = p.float("shutter_open", 0.0)?;
        let _ = p.float("shutter_close", 0.0)?;
        for k in ["principal_point_offset_x", "principal_point_offset_y"] {
            let v = p.float(k, 0.0)?;
            check(
                p.loc(),
                v == 0.0,
                format!("{k} other than 0 is not supported"),
            )?;
        }
        let camera = Camera::perspective(to_world, fov, axis, near, far, (film.width, film.height))
            .map_err(|e| Error::scene(p.loc(), e.to_string()))?;
        p.finish()?;
        Ok((camera, film, sampler))
    }

    fn film_defaults(&self, _loc: &SourceLoc) -> Result<FilmDesc> {
        Ok(FilmDesc {
            width: 768,
            height: 576,
            crop_offset: (0, 0),
            crop_size: (768, 576),
            filter: Filter::Gaussian {
                stddev: 0.5,
                radius: 2.0,
            },
            second_moments: true,
        })
    }

    fn film(&mut self, n: &'d Node) -> Result<FilmDesc> {
        let p = self.props(n)?;
        if p.plugin_type() != "hdrfilm" {
            return Err(unknown(p.loc(), "film", p.plugin_type(), &["hdrfilm"]));
        }
        let w = p.int("width", 768)?;
        let h = p.int("height", 576)?;
        check(
            p.loc(),
            (1..=1 << 16).contains(&w) && (1..=1 << 16).contains(&h),
            "film width and height must be between 1 and 65536",
        )?;
        let (w, h) = (w as u32, h as u32);
        let cx = p.int("crop_offset_x", 0)?;
        let cy = p.int("crop_offset_y", 0)?;
        let cw = p.int("crop_width", w as i64 - cx)?;
        let ch = p.int("crop_height", h as i64 - cy)?;
        check(
            p.loc(),
            cx >= 0 && cy >= 0 && cw >= 1 && ch >= 1 && cx + cw <= w as i64 && cy + ch <= h as i64,
            "the crop window must lie inside the film",
        )?;
        let pf = p.string("pixel_format", "rgb")?;
        if !matches!(pf.as_str(), "rgb" | "rgba") {
            self.warnings.push(format!(
                "{}: pixel_format '{pf}' is written as rgb",
                p.loc()
            ));
        }
        let cf = p.string("component_format", "float16")?;
        check(
            p.loc(),
            matches!(cf.as_str(), "float16" | "float32" | "uint32"),
            format!("component_format '{cf}' is not known"),
        )?;
        let _ = p.string("file_format", "openexr")?;
        let _ = p.bool("banner", true)?;
        // Mitsuba 0.x's `highQualityEdges`: Mitsuba 3.9.1 rejects it as an unreferenced
        // property, even in upgraded 0.x files; groove accepts it there only, with a warning.
        if self.doc.upgraded_from_v0 && p.has("high_quality_edges") {
            let _ = p.bool("high_quality_edges", false)?;
            self.warnings.push(format!(
                "{}: high_quality_edges (Mitsuba 0.x) is ignored; Mitsuba 3 rejects it",
                p.loc()
            ));
        }
        let _ = p.bool("sample_border", false)?;
        let mut filter = Filter::Gaussian {
            stddev: 0.5,
            radius: 2.0,
        };
        for c in p.objects() {
            if c.tag != "rfilter" {
                return Err(Error::scene(
                    &c.loc,
                    format!("<{}> is not expected inside a <film>", c.tag),
                ));
            }
            filter = self.rfilter(c)?;
        }
        let loc = p.loc().clone();
        p.finish()?;
        let desc = FilmDesc {
            width: w,
            height: h,
            crop_offset: (cx as u32, cy as u32),
            crop_size: (cw as u32, ch as u32),
            filter,
            second_moments: true,
        };
        // Refused here, at the <film>, rather than after the rest of the scene has loaded.
        let need = crate::render::film_bytes(&desc, crate::render::DEFAULT_BLOCK);
        self.budget
            .check(need, &format!("film {cw}×{ch}"))
            .map_err(|m| Error::scene(&loc, m))?;
        Ok(desc)
    }

    fn rfilter(&mut self, n: &'d Node) -> Result<Filter> {
        let p = self.props(n)?;
        let f = match p.plugin_type() {
            "box" => Filter::Box,
            "tent" => {
                let r = p.float("radius", 1.0)?;
                check(
                    p.loc(),
                    r > 0.0 && r <= 16.0,
                    "tent radius must be in (0, 16]",
                )?;
                Filter::Tent { radius: r }
            }
            "gaussian" => {
                let s = p.float("stddev", 0.5)?;
                check(
                    p.loc(),
                    s > 0.0 && s <= 4.0,
                    "gaussian stddev must be in (0, 4]",
                )?;
                Filter::Gaussian {
                    stddev: s,
                    radius: 4.0 * s,
                }
            }
            t => return Err(unknown(p.loc(), "rfilter", t, &["box", "tent", "gaussian"])),
        };
        p.finish()?;
        Ok(f)
    }

    fn sampler(&mut self, n: &'d Node) -> Result<SamplerDesc> {
        let p = self.props(n)?;
        let count = p.int("sample_count", 4)?;
        check(
            p.loc(),
            count >= 1 && count <= u32::MAX as i64,
            "sample_count must be >= 1",
        )?;
        let seed = p.int("seed", 0)?;
        let kind = match p.plugin_type() {
            "independent" => SamplerKind::Independent,
            "stratified" => SamplerKind::Stratified {
                jitter: p.bool("jitter", true)?,
            },
            t
            @ ("sobol" | "halton" | "ldsampler" | "multijitter" | "orthogonal" | "hammersley") => {
                self.warnings.push(format!(
                    "{}: sampler '{t}' is not implemented; using 'independent' (same image in expectation)",
                    p.loc()
                ));
                for k in ["scramble", "jitter", "strength", "dimension"] {
                    p.mark_used(k);
                }
                SamplerKind::Independent
            }
            t => {
                return Err(unknown(
                    p.loc(),
                    "sampler",
                    t,
                    &["independent", "stratified"],
                ))
            }
        };
        p.finish()?;
        Ok(SamplerDesc {
            kind,
            sample_count: count as u32,
            seed: seed as u64,
        })
    }
}

/// Mitsuba 3.9.1's MonteCarloIntegrator depths: `max_depth` (−1 = unlimited, else ≥ 0) and
/// `rr_depth` (≥ 1), clamped into i32.
fn depths(p: &Props<'_>) -> Result<(i32, i32)> {
    let max_depth = p.int("max_depth", -1)?;
    check(
        p.loc(),
        max_depth >= -1,
        "max_depth must be -1 (unlimited) or >= 0",
    )?;
    let rr_depth = p.int("rr_depth", 5)?;
    check(p.loc(), rr_depth >= 1, "rr_depth must be >= 1")?;
    Ok((
        max_depth.clamp(-1, i32::MAX as i64) as i32,
        rr_depth.min(i32::MAX as i64) as i32,
    ))
}
