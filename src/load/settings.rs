//! The render settings of a scene: `<integrator>` (`path`, `direct`), `<sensor>`
//! (`perspective`), `<film>` (`hdrfilm`), `<rfilter>` (`box`, `tent`, `gaussian`) and
//! `<sampler>` (`independent`, `stratified`), with Mitsuba 3's parameter names and defaults.

use super::{check, unknown, Builder};
use crate::camera::{Camera, FovAxis};
use crate::error::{Error, Result, SourceLoc};
use crate::film::{FilmDesc, Filter};
use crate::integrator::{DirectSettings, IntegratorDesc, PathSettings};
use crate::sampler::{SamplerDesc, SamplerKind};
use crate::scene::xml::ir::Node;

impl<'d> Builder<'d> {
    pub(super) fn integrator(&mut self, n: &'d Node) -> Result<IntegratorDesc> {
        let p = self.props(n)?;
        let d = match p.plugin_type() {
            "path" => {
                let max_depth = p.int("max_depth", -1)?;
                check(
                    p.loc(),
                    max_depth >= -1,
                    "max_depth must be -1 (unlimited) or >= 0",
                )?;
                let rr_depth = p.int("rr_depth", 5)?;
                check(p.loc(), rr_depth >= 1, "rr_depth must be >= 1")?;
                IntegratorDesc::Path(PathSettings {
                    max_depth: max_depth.clamp(-1, i32::MAX as i64) as i32,
                    rr_depth: rr_depth.min(i32::MAX as i64) as i32,
                    hide_emitters: p.bool("hide_emitters", false)?,
                    ..Default::default()
                })
            }
            "direct" => {
                let shading = p.int("shading_samples", 1)?;
                let em = p.int("emitter_samples", shading)?;
                let bs = p.int("bsdf_samples", shading)?;
                check(
                    p.loc(),
                    em >= 0 && bs >= 0 && em + bs > 0,
                    "sample counts must be >= 0 and not both 0",
                )?;
                IntegratorDesc::Direct(DirectSettings {
                    emitter_samples: em as u32,
                    bsdf_samples: bs as u32,
                    hide_emitters: p.bool("hide_emitters", false)?,
                })
            }
            "moment" | "aov" | "stokes" | "depth" => {
                return Err(Error::scene(
                    p.loc(),
                    format!(
                        "integrator '{}' is not supported: groove renders with 'path' or 'direct'",
                        p.plugin_type()
                    ),
                ))
            }
            t => return Err(unknown(p.loc(), "integrator", t, &["path", "direct"])),
        };
        p.finish()?;
        Ok(d)
    }

    pub(super) fn sensor(&mut self, n: &'d Node) -> Result<(Camera, FilmDesc, SamplerDesc)> {
        let p = self.props(n)?;
        if p.plugin_type() != "perspective" {
            return Err(unknown(
                p.loc(),
                "sensor",
                p.plugin_type(),
                &["perspective"],
            ));
        }
        let mut film: Option<FilmDesc> = None;
        let mut sampler: Option<SamplerDesc> = None;
        for c in p.objects() {
            match c.tag.as_str() {
                "film" => film = Some(self.film(c)?),
                "sampler" => sampler = Some(self.sampler(c)?),
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
        let to_world = p.transform("to_world")?;
        let (fov, axis) = match (p.float_opt("fov")?, p.string_opt("focal_length")?) {
            (Some(_), Some(_)) => {
                return Err(Error::scene(
                    p.loc(),
                    "give either fov or focal_length, not both",
                ))
            }
            (Some(f), None) => {
                let axis_s = p.string("fov_axis", "x")?;
                let axis = FovAxis::parse(&axis_s).ok_or_else(|| {
                    Error::scene(
                        p.loc(),
                        format!(
                            "fov_axis '{axis_s}' must be one of x, y, diagonal, smaller, larger"
                        ),
                    )
                })?;
                (f, axis)
            }
            (None, fl) => {
                // Mitsuba: a 35 mm-equivalent focal length (default 50mm) sets the diagonal fov.
                let s = fl.unwrap_or_else(|| "50mm".to_string());
                let mm: f32 = s
                    .trim()
                    .trim_end_matches("mm")
                    .trim()
                    .parse()
                    .map_err(|_| {
                        Error::scene(p.loc(), format!("focal_length '{s}' must look like '50mm'"))
                    })?;
                check(
                    p.loc(),
                    mm > 0.0 && mm.is_finite(),
                    "focal_length must be positive",
                )?;
                let diag = (36.0f32 * 36.0 + 24.0 * 24.0).sqrt();
                (
                    2.0 * (diag / (2.0 * mm)).atan().to_degrees(),
                    FovAxis::Diagonal,
                )
            }
        };
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
        let _ = p.bool("high_quality_edges", false)?;
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
