//! Turns the parsed XML document into a [`Scene`]: one constructor per plugin type, references
//! resolved by id, every property checked (an unreferenced property is an error, as in Mitsuba 3).

use super::xml::parse::{load_file, Document, Node};
use super::xml::props::Props;
use super::Scene;
use crate::accel::Accel;
use crate::bsdf::conductor::Conductor;
use crate::bsdf::dielectric::{DEFAULT_EXT_IOR, DEFAULT_INT_IOR};
use crate::bsdf::mnm::facets::Microgeometry;
use crate::bsdf::mnm::{Evaluation, Tangent, TransmissionWalk};
use crate::bsdf::plastic::DEFAULT_PLASTIC_INT_IOR;
use crate::bsdf::{
    named_conductor, named_ior, BsdfNode, Dielectric, Lobes, MicrofacetDistribution,
    MicrofacetType, Plastic, RoughConductor, RoughDielectric, RoughPlastic, ThinDielectric,
};
use crate::camera::{Camera, FovAxis};
use crate::emitter::area::AreaLight;
use crate::emitter::constant::ConstantLight;
use crate::emitter::directional::DirectionalLight;
use crate::emitter::envmap::EnvMapLight;
use crate::emitter::point::PointLight;
use crate::emitter::spot::SpotLight;
use crate::emitter::{Emitter, LightSampler};
use crate::error::{Error, Result, SourceLoc};
use crate::film::{FilmDesc, Filter};
use crate::geometry::{obj, ply, serialized, Shape};
use crate::integrator::{DirectSettings, IntegratorDesc, PathSettings};
use crate::material::{MatId, MaterialNode, Materials, MnmSettings, Slot, TexId};
use crate::sampler::{SamplerDesc, SamplerKind};
use crate::spectrum::{Spectrum, SpectrumUse};
use crate::texture::Texture;
use glam::{Mat3, Mat4, Vec3};
use std::collections::HashMap;
use std::path::Path;

pub use super::xml::parse::{LoadOptions, MnmMode, NormalMapping};

/// A loaded scene and the warnings its loading produced (lenient fallbacks, old tags).
pub struct Loaded {
    pub scene: Scene,
    pub warnings: Vec<String>,
}

/// Parse, upgrade and instantiate a scene file.
pub fn load_scene(path: &Path, opts: &LoadOptions) -> Result<Loaded> {
    let doc = load_file(path, opts)?;
    instantiate_with(&doc, path, opts.normal_mapping)
}

/// BSDF types groove knows but has not implemented yet: a clear error, not a silent fallback.
const PLANNED_BSDFS: &[&str] = &[];

const SUPPORTED_BSDFS: &[&str] = &[
    "diffuse",
    "conductor",
    "roughconductor",
    "dielectric",
    "thindielectric",
    "roughdielectric",
    "plastic",
    "roughplastic",
    "twosided",
    "microfacet_normalmap",
    "normalmap",
    "blendbsdf",
    "null",
    "mask",
    "bumpmap",
    "principled",
    "principledthin",
];

struct Builder<'d> {
    doc: &'d Document,
    /// `--normal-mapping`: which model the scene's normal maps become.
    normal_mapping: NormalMapping,
    /// Every node with an `id`, for `<ref>`.
    ids: HashMap<&'d str, &'d Node>,
    bsdf_cache: HashMap<&'d str, MatId>,
    tex_cache: HashMap<&'d str, TexId>,
    materials: Materials,
    /// The default diffuse BSDFs: [for plain shapes (0.5 grey), for emitting shapes (black)].
    default_materials: [Option<MatId>; 2],
    shapes: Vec<Shape>,
    shape_material: Vec<MatId>,
    shape_emitter: Vec<Option<u32>>,
    emitters: Vec<Emitter>,
    warnings: Vec<String>,
}

/// Instantiate a parsed document. `path` names the scene in the result.
pub fn instantiate(doc: &Document, path: &Path) -> Result<Loaded> {
    instantiate_with(doc, path, NormalMapping::AsWritten)
}

/// [`instantiate`] with every normal map converted to the model `normal_mapping` (decision 6).
pub fn instantiate_with(
    doc: &Document,
    path: &Path,
    normal_mapping: NormalMapping,
) -> Result<Loaded> {
    let mut b = Builder {
        doc,
        normal_mapping,
        ids: HashMap::new(),
        bsdf_cache: HashMap::new(),
        tex_cache: HashMap::new(),
        materials: Materials::default(),
        default_materials: [None, None],
        shapes: Vec::new(),
        shape_material: Vec::new(),
        shape_emitter: Vec::new(),
        emitters: Vec::new(),
        warnings: doc.warnings.clone(),
    };
    collect_ids(&doc.root, &mut b.ids);

    let mut integrator: Option<IntegratorDesc> = None;
    let mut sensor: Option<(Camera, FilmDesc, SamplerDesc)> = None;
    for child in &doc.root.children {
        match child.tag.as_str() {
            "integrator" => {
                if integrator.is_some() {
                    return Err(Error::scene(
                        &child.loc,
                        "a scene takes only one <integrator>",
                    ));
                }
                integrator = Some(b.integrator(child)?);
            }
            "sensor" => {
                if sensor.is_some() {
                    return Err(Error::scene(
                        &child.loc,
                        "groove renders one <sensor> per scene; this is a second one",
                    ));
                }
                sensor = Some(b.sensor(child)?);
            }
            "shape" => b.shape(child)?,
            "bsdf" => {
                b.bsdf(child)?;
            }
            "texture" => {
                b.texture(child)?;
            }
            "emitter" => b.top_level_emitter(child)?,
            "rfilter" | "film" | "sampler" => {
                return Err(Error::scene(
                    &child.loc,
                    format!("<{}> belongs inside <sensor> (or <film>)", child.tag),
                ))
            }
            other => {
                return Err(Error::scene(
                    &child.loc,
                    format!("<{other}> is not supported at the top level of a scene"),
                ))
            }
        }
    }

    let integrator = integrator.unwrap_or(IntegratorDesc::Path(PathSettings::default()));
    let (camera, film, sampler) = match sensor {
        Some(s) => s,
        None => {
            return Err(Error::scene(
                &doc.root.loc,
                "the scene has no <sensor>: add a perspective sensor to render it",
            ))
        }
    };
    if b.shapes.is_empty() && b.emitters.is_empty() {
        b.warnings.push(format!(
            "{}: the scene is empty (no shapes, no emitters)",
            doc.root.loc
        ));
    }

    let accel = Accel::build(&b.shapes)?;
    let bsphere = Scene::bounding_sphere(&b.shapes);
    let env_emitters = b
        .emitters
        .iter()
        .enumerate()
        .filter(|(_, e)| e.is_environment())
        .map(|(i, _)| i as u32)
        .collect();
    let light_sampler = LightSampler::new(&b.emitters, &b.shapes, bsphere.1);
    Ok(Loaded {
        scene: Scene {
            shapes: b.shapes,
            shape_material: b.shape_material,
            shape_emitter: b.shape_emitter,
            accel,
            materials: b.materials,
            emitters: b.emitters,
            env_emitters,
            light_sampler,
            camera,
            film,
            sampler,
            integrator,
            bsphere,
            source: path.to_path_buf(),
        },
        warnings: b.warnings,
    })
}

fn collect_ids<'d>(n: &'d Node, ids: &mut HashMap<&'d str, &'d Node>) {
    for c in &n.children {
        if c.tag != "ref" {
            if let Some(id) = c.attr("id") {
                ids.insert(id, c);
            }
        }
        collect_ids(c, ids);
    }
}

fn unknown(loc: &SourceLoc, kind: &str, ty: &str, known: &[&str]) -> Error {
    Error::scene(
        loc,
        format!(
            "unknown {kind} plugin '{ty}' (groove supports: {})",
            known.join(", ")
        ),
    )
}

/// Check a value read from the scene is finite and in range.
fn check(loc: &SourceLoc, ok: bool, msg: impl Into<String>) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Error::scene(loc, msg))
    }
}

impl<'d> Builder<'d> {
    /// Follow a `<ref id>` to its target node (or return the node itself).
    fn deref(&self, n: &'d Node, expect: &str) -> Result<&'d Node> {
        if n.tag != "ref" {
            return Ok(n);
        }
        let id = n
            .attr("id")
            .ok_or_else(|| Error::scene(&n.loc, "<ref> needs an id"))?;
        let target = self.ids.get(id).ok_or_else(|| {
            Error::scene(
                &n.attr_loc("id").clone(),
                format!("reference to unknown id '{id}'"),
            )
        })?;
        if target.tag != expect {
            return Err(Error::scene(
                &n.loc,
                format!(
                    "id '{id}' is a <{}>, but a <{expect}> is expected here",
                    target.tag
                ),
            ));
        }
        Ok(target)
    }

    /// The tag of an object child, looking through a `<ref>` to its target ("ref" if unknown).
    fn object_tag<'n>(&self, c: &'n Node) -> &'n str
    where
        'd: 'n,
    {
        if c.tag == "ref" {
            self.ref_target_tag(c).unwrap_or("ref")
        } else {
            c.tag.as_str()
        }
    }

    fn ref_target_tag(&self, n: &Node) -> Option<&'d str> {
        if n.tag == "ref" {
            n.attr("id")
                .and_then(|id| self.ids.get(id))
                .map(|t| t.tag.as_str())
        } else {
            None
        }
    }

    // ------------------------------------------------------------------ integrator
    fn integrator(&mut self, n: &'d Node) -> Result<IntegratorDesc> {
        let p = Props::new(n)?;
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

    // ------------------------------------------------------------------ sensor, film, sampler
    fn sensor(&mut self, n: &'d Node) -> Result<(Camera, FilmDesc, SamplerDesc)> {
        let p = Props::new(n)?;
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
        let p = Props::new(n)?;
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
        p.finish()?;
        Ok(FilmDesc {
            width: w,
            height: h,
            crop_offset: (cx as u32, cy as u32),
            crop_size: (cw as u32, ch as u32),
            filter,
        })
    }

    fn rfilter(&mut self, n: &'d Node) -> Result<Filter> {
        let p = Props::new(n)?;
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
        let p = Props::new(n)?;
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

    // ------------------------------------------------------------------ textures and BSDFs
    /// A colour parameter that may be a constant or a texture (child `<texture name>` or
    /// `<ref name id>` to a texture).
    fn color_param(&mut self, p: &Props<'d>, name: &str, default: Spectrum) -> Result<TexId> {
        for c in p.objects() {
            if c.attr("name") == Some(name) {
                let is_tex = c.tag == "texture" || self.ref_target_tag(c) == Some("texture");
                if is_tex {
                    let t = self.deref(c, "texture")?;
                    return self.texture(t);
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

    fn texture(&mut self, n: &'d Node) -> Result<TexId> {
        if let Some(id) = n.attr("id") {
            if let Some(&t) = self.tex_cache.get(id) {
                return Ok(t);
            }
        }
        let p = Props::new(n)?;
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
            t => return Err(unknown(p.loc(), "texture", t, &["bitmap", "checkerboard"])),
        };
        p.finish()?;
        let id = self.materials.add_texture(tex);
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
        let bmp = BitmapTexture::load(&file, &opts)
            .map_err(|e| Error::scene(p.loc(), format!("cannot load bitmap texture: {e}")))?;
        for w in bmp.warnings() {
            self.warnings.push(format!("{}: {w}", p.loc()));
        }
        Ok(Texture::from(bmp))
    }

    fn bsdf(&mut self, n: &'d Node) -> Result<MatId> {
        let n = self.deref(n, "bsdf")?;
        if let Some(id) = n.attr("id") {
            if let Some(&m) = self.bsdf_cache.get(id) {
                return Ok(m);
            }
        }
        let p = Props::new(n)?;
        let node = match p.plugin_type() {
            "diffuse" => {
                let r = self.color_param(&p, "reflectance", Spectrum::splat(0.5))?;
                MaterialNode::Diffuse { reflectance: r }
            }
            t @ ("conductor" | "roughconductor") => {
                let (eta, k) = self.conductor_ior(&p)?;
                let (spec, slots) =
                    self.leaf_color(&p, "specular_reflectance", Slot::SpecularReflectance, 1.0)?;
                let mut slots = slots;
                let template = if t == "conductor" {
                    BsdfNode::Conductor(Conductor {
                        eta,
                        k,
                        specular_reflectance: spec,
                    })
                } else {
                    let (distribution, alpha_slots) = self.distribution(&p, true, true)?;
                    slots.extend(alpha_slots);
                    BsdfNode::RoughConductor(RoughConductor {
                        distribution,
                        eta,
                        k,
                        specular_reflectance: spec,
                    })
                };
                MaterialNode::Leaf {
                    template: Box::new(template),
                    slots,
                }
            }
            t @ ("dielectric" | "thindielectric" | "roughdielectric") => {
                let int_ior = ior_param(&p, "int_ior", DEFAULT_INT_IOR)?;
                let ext_ior = ior_param(&p, "ext_ior", DEFAULT_EXT_IOR)?;
                let (r, mut slots) =
                    self.leaf_color(&p, "specular_reflectance", Slot::SpecularReflectance, 1.0)?;
                let (tr, s2) = self.leaf_color(
                    &p,
                    "specular_transmittance",
                    Slot::SpecularTransmittance,
                    1.0,
                )?;
                slots.extend(s2);
                let template = match t {
                    "dielectric" => BsdfNode::Dielectric(Dielectric::new(int_ior, ext_ior, r, tr)),
                    "thindielectric" => {
                        BsdfNode::ThinDielectric(ThinDielectric::new(int_ior, ext_ior, r, tr))
                    }
                    _ => {
                        let (distribution, alpha_slots) = self.distribution(&p, true, true)?;
                        slots.extend(alpha_slots);
                        BsdfNode::RoughDielectric(RoughDielectric::new(
                            distribution,
                            int_ior,
                            ext_ior,
                            r,
                            tr,
                        ))
                    }
                };
                MaterialNode::Leaf {
                    template: Box::new(template),
                    slots,
                }
            }
            t @ ("plastic" | "roughplastic") => {
                let int_ior = ior_param(&p, "int_ior", DEFAULT_PLASTIC_INT_IOR)?;
                let ext_ior = ior_param(&p, "ext_ior", DEFAULT_EXT_IOR)?;
                // Sampling weights come from the textures' means, as Mitsuba does.
                let (d, mut slots) =
                    self.leaf_color(&p, "diffuse_reflectance", Slot::DiffuseReflectance, 0.5)?;
                let (sr, s2) =
                    self.leaf_color(&p, "specular_reflectance", Slot::SpecularReflectance, 1.0)?;
                slots.extend(s2);
                let nonlinear = p.bool("nonlinear", false)?;
                let template = if t == "plastic" {
                    BsdfNode::Plastic(Plastic::new(d, sr, int_ior, ext_ior, nonlinear))
                } else {
                    // Mitsuba 3's roughplastic takes a plain float `alpha` (no texture).
                    let (dist, _) = self.distribution(&p, false, false)?;
                    BsdfNode::RoughPlastic(RoughPlastic::new(
                        dist.kind,
                        dist.alpha_u,
                        dist.sample_visible,
                        d,
                        sr,
                        int_ior,
                        ext_ior,
                        nonlinear,
                    ))
                };
                MaterialNode::Leaf {
                    template: Box::new(template),
                    slots,
                }
            }
            "twosided" => {
                let children: Vec<&'d Node> = p.objects().collect();
                let mut bsdfs = Vec::new();
                for c in &children {
                    let is_bsdf = c.tag == "bsdf" || self.ref_target_tag(c) == Some("bsdf");
                    if !is_bsdf {
                        return Err(Error::scene(
                            &c.loc,
                            format!("twosided expects nested <bsdf>s, not <{}>", c.tag),
                        ));
                    }
                    bsdfs.push(self.bsdf(c)?);
                }
                match bsdfs.as_slice() {
                    [f] => MaterialNode::TwoSided {
                        front: *f,
                        back: *f,
                    },
                    [f, b] => MaterialNode::TwoSided {
                        front: *f,
                        back: *b,
                    },
                    _ => {
                        return Err(Error::scene(
                            p.loc(),
                            format!(
                                "twosided takes one or two nested BSDFs, found {}",
                                bsdfs.len()
                            ),
                        ))
                    }
                }
            }
            "microfacet_normalmap" => match self.normal_mapping {
                // Classic side of `--normal-mapping`: the plain model over the same texture and
                // nested BSDF (the microfacet parameters are still checked).
                NormalMapping::Classic => match self.microfacet_normalmap(&p)? {
                    MaterialNode::MicrofacetNormalMap {
                        nested, normalmap, ..
                    } => MaterialNode::NormalMap {
                        nested,
                        normalmap,
                        flip_invalid_normals: false,
                        use_shadowing_function: false,
                    },
                    other => other,
                },
                _ => self.microfacet_normalmap(&p)?,
            },
            "blendbsdf" => self.blendbsdf(&p)?,
            "null" => {
                if let Some(c) = p.objects().next() {
                    return Err(Error::scene(
                        &c.loc,
                        format!(
                            "<{}> is not expected inside a null BSDF (it takes no parameters)",
                            c.tag
                        ),
                    ));
                }
                MaterialNode::Null
            }
            "mask" => self.mask(&p)?,
            "bumpmap" => self.bumpmap(&p)?,
            t @ ("principled" | "principledthin") => {
                // A parameter's nested (or referenced) texture, if any.
                let mut texture = |name: &str| -> Result<Option<TexId>> {
                    let Some(c) = p.objects().find(|c| c.attr("name") == Some(name)) else {
                        return Ok(None);
                    };
                    if c.tag != "texture" && self.ref_target_tag(c) != Some("texture") {
                        return Err(Error::scene(
                            &c.loc,
                            format!("'{name}' expects a value or a <texture>, not a <{}>", c.tag),
                        ));
                    }
                    let tex = self.deref(c, "texture")?;
                    self.texture(tex).map(Some)
                };
                if t == "principled" {
                    crate::bsdf::principled::material(&p, &mut texture)?
                } else {
                    crate::bsdf::principledthin::material(&p, &mut texture)?
                }
            }
            "normalmap" => match self.normal_mapping {
                NormalMapping::Microfacet | NormalMapping::Forced(_) => {
                    self.normalmap_as_microfacet(&p)?
                }
                mode => self.classic_normalmap(&p, mode == NormalMapping::Classic)?,
            },
            t if PLANNED_BSDFS.contains(&t) => {
                return Err(Error::scene(
                    p.loc(),
                    format!("bsdf '{t}' is not supported yet"),
                ))
            }
            t => return Err(unknown(p.loc(), "bsdf", t, SUPPORTED_BSDFS)),
        };
        p.finish()?;
        let id = self.materials.add_node(node);
        if let Some(i) = n.attr("id") {
            self.bsdf_cache.insert(i, id);
        }
        Ok(id)
    }

    /// A colour of a leaf BSDF: constant (returned, no slot) or textured (returned as the
    /// texture's mean for load-time decisions, plus the slot to fill per hit).
    fn leaf_color(
        &mut self,
        p: &Props<'d>,
        name: &str,
        slot: Slot,
        default: f32,
    ) -> Result<(Spectrum, Vec<(Slot, TexId)>)> {
        let tex = self.color_param(p, name, Spectrum::splat(default))?;
        let t = &self.materials.textures[tex as usize];
        match t {
            Texture::Constant(c) => Ok((*c, Vec::new())),
            other => Ok((other.mean(), vec![(slot, tex)])),
        }
    }

    /// `material` (a named conductor) or explicit `eta` and `k`.
    fn conductor_ior(&mut self, p: &Props<'d>) -> Result<(Spectrum, Spectrum)> {
        if p.has("eta") || p.has("k") {
            if p.has("material") {
                return Err(Error::scene(
                    p.loc(),
                    "give either 'material' or 'eta'/'k', not both",
                ));
            }
            let eta = p.color_with("eta", Spectrum::ZERO, SpectrumUse::Unbounded)?;
            let k = p.color_with("k", Spectrum::ONE, SpectrumUse::Unbounded)?;
            return Ok((eta, k));
        }
        let name = p.string("material", "none")?;
        named_conductor(&name).ok_or_else(|| {
            Error::scene(
                p.loc(),
                format!("unknown conductor material '{name}' (e.g. none, Au, Ag, Cu, Al, Cr)"),
            )
        })
    }

    /// `distribution`, `alpha` or `alpha_u`/`alpha_v`, `sample_visible` (Mitsuba's defaults:
    /// beckmann, 0.1, true). `anisotropic` = false for models that are isotropic only;
    /// `textured` = the roughness may be a texture (Mitsuba 3: roughconductor and
    /// roughdielectric, not roughplastic), returned as scalar slots to fill per hit (the
    /// distribution then holds the texture's mean, for load-time decisions only).
    fn distribution(
        &mut self,
        p: &Props<'d>,
        anisotropic: bool,
        textured: bool,
    ) -> Result<(MicrofacetDistribution, Vec<(Slot, TexId)>)> {
        let name = p.string("distribution", "beckmann")?;
        let kind = MicrofacetType::from_name(&name).ok_or_else(|| {
            Error::scene(
                p.loc(),
                format!("distribution '{name}' must be 'beckmann' or 'ggx'"),
            )
        })?;
        let visible = p.bool("sample_visible", true)?;
        let mut slots = Vec::new();
        let mut textures = [None; 3];
        for (i, k) in ["alpha", "alpha_u", "alpha_v"].into_iter().enumerate() {
            if let Some(c) = p.objects().find(|c| c.attr("name") == Some(k)) {
                let is_tex = c.tag == "texture" || self.ref_target_tag(c) == Some("texture");
                if !textured || !is_tex {
                    return Err(Error::scene(
                        &c.loc,
                        if textured {
                            format!("'{k}' expects a number or a <texture>, not a <{}>", c.tag)
                        } else {
                            format!("'{k}' of bsdf '{}' must be a number (Mitsuba 3 takes no texture here)", p.plugin_type())
                        },
                    ));
                }
                let t = self.deref(c, "texture")?;
                textures[i] = Some(self.texture(t)?);
            }
        }
        let given = |i: usize, k: &str| textures[i].is_some() || p.has(k);
        // A scalar parameter: a texture (its mean now, a slot per hit) or a checked number.
        let mut alpha = |i: usize, k: &str, slot: Slot| -> Result<f32> {
            if let Some(t) = textures[i] {
                slots.push((slot, t));
                let tex = &self.materials.textures[t as usize];
                return Ok(crate::spectrum::luminance(tex.mean()));
            }
            let a = p.float(k, 0.1)?;
            check(p.loc(), a.is_finite() && a >= 0.0, "alpha must be >= 0")?;
            Ok(a)
        };
        if anisotropic && (given(1, "alpha_u") || given(2, "alpha_v")) {
            if given(0, "alpha") {
                return Err(Error::scene(
                    p.loc(),
                    "give either 'alpha' or 'alpha_u'/'alpha_v', not both",
                ));
            }
            let au = alpha(1, "alpha_u", Slot::AlphaU)?;
            let av = alpha(2, "alpha_v", Slot::AlphaV)?;
            let d = MicrofacetDistribution::anisotropic(kind, au, av, visible);
            return Ok((d, slots));
        }
        let a = alpha(0, "alpha", Slot::Alpha)?;
        Ok((MicrofacetDistribution::new(kind, a, visible), slots))
    }

    /// The nested BSDF (with its node, for error locations) and the `normalmap` texture of a
    /// `normalmap` or `microfacet_normalmap` (`kind`).
    fn normalmap_parts(&mut self, p: &Props<'d>, kind: &str) -> Result<(MatId, &'d Node, TexId)> {
        let mut nested = None;
        let mut normalmap = None;
        for c in p.objects() {
            let tag = self.object_tag(c);
            match tag {
                "bsdf" => {
                    if nested.is_some() {
                        return Err(Error::scene(&c.loc, format!("{kind} takes exactly one nested BSDF")));
                    }
                    nested = Some((self.bsdf(c)?, c));
                }
                "texture" if c.attr("name") == Some("normalmap") => {
                    let t = self.deref(c, "texture")?;
                    normalmap = Some(self.texture(t)?);
                }
                t => return Err(Error::scene(&c.loc, format!("<{t}> is not expected inside a {kind} (a nested <bsdf> and a <texture name=\"normalmap\">)"))),
            }
        }
        let (nested, nested_node) =
            nested.ok_or_else(|| Error::scene(p.loc(), format!("{kind} needs a nested <bsdf>")))?;
        let normalmap = match normalmap {
            Some(t) => t,
            None if p.has("normalmap") => {
                self.color_param(p, "normalmap", Spectrum::new(0.5, 0.5, 1.0))?
            }
            None => {
                return Err(Error::scene(
                    p.loc(),
                    format!("{kind} needs a <texture name=\"normalmap\">"),
                ))
            }
        };
        Ok((nested, nested_node, normalmap))
    }

    /// Mitsuba 3's `blendbsdf`: `weight` (float or texture, required) and exactly two nested
    /// BSDFs, the first weighted 1 − w, the second w.
    fn blendbsdf(&mut self, p: &Props<'d>) -> Result<MaterialNode> {
        let mut bsdfs = Vec::new();
        let mut weight = None;
        for c in p.objects() {
            let tag = if c.tag == "ref" {
                self.ref_target_tag(c).unwrap_or("ref")
            } else {
                c.tag.as_str()
            };
            match tag {
                "bsdf" => bsdfs.push(self.bsdf(c)?),
                "texture" if c.attr("name") == Some("weight") => {
                    let t = self.deref(c, "texture")?;
                    weight = Some(self.texture(t)?);
                }
                t => return Err(Error::scene(&c.loc, format!("<{t}> is not expected inside a blendbsdf (two nested <bsdf>s and a float or <texture name=\"weight\">)"))),
            }
        }
        let [bsdf0, bsdf1] = bsdfs[..] else {
            return Err(Error::scene(
                p.loc(),
                format!(
                    "blendbsdf takes exactly two nested BSDFs, found {}",
                    bsdfs.len()
                ),
            ));
        };
        let weight = match weight {
            Some(t) => t,
            None if !p.has("weight") => {
                return Err(Error::scene(
                    p.loc(),
                    "blendbsdf needs a 'weight' (a float or a <texture name=\"weight\">)",
                ))
            }
            None => {
                let w = p.float("weight", 0.5)?;
                check(
                    p.loc(),
                    (0.0..=1.0).contains(&w),
                    "blendbsdf weight must be in [0, 1]",
                )?;
                self.materials
                    .add_texture(Texture::Constant(Spectrum::splat(w)))
            }
        };
        Ok(MaterialNode::Blend {
            weight,
            bsdf0,
            bsdf1,
        })
    }

    /// Mitsuba 3's `mask`: `opacity` (float, colour or texture, read as a scalar; default 0.5)
    /// and exactly one nested BSDF.
    fn mask(&mut self, p: &Props<'d>) -> Result<MaterialNode> {
        let mut nested = None;
        for c in p.objects() {
            match self.object_tag(c) {
                "bsdf" => {
                    if nested.is_some() {
                        return Err(Error::scene(&c.loc, "mask takes exactly one nested BSDF"));
                    }
                    nested = Some(self.bsdf(c)?);
                }
                "texture" if c.attr("name") == Some("opacity") => {}
                t => return Err(Error::scene(&c.loc, format!("<{t}> is not expected inside a mask (a nested <bsdf> and a float or <texture name=\"opacity\">)"))),
            }
        }
        let nested = nested.ok_or_else(|| Error::scene(p.loc(), "mask needs a nested <bsdf>"))?;
        let opacity = self.color_param(p, "opacity", Spectrum::splat(0.5))?;
        if let Texture::Constant(c) = &self.materials.textures[opacity as usize] {
            let o = crate::spectrum::luminance(*c);
            check(
                p.loc(),
                (0.0..=1.0).contains(&o),
                "mask opacity must be in [0, 1]",
            )?;
        }
        Ok(MaterialNode::Mask { opacity, nested })
    }

    /// Mitsuba 3.9.1's `bumpmap`: one nested height `<texture>` (any name; a `bitmap`, the only
    /// texture with a gradient in Mitsuba), one nested BSDF, `scale` (default 1) and the
    /// perturbed-BSDF flags of `normalmap` (same defaults).
    fn bumpmap(&mut self, p: &Props<'d>) -> Result<MaterialNode> {
        let mut nested = None;
        let mut height = None;
        for c in p.objects() {
            match self.object_tag(c) {
                "bsdf" => {
                    if nested.is_some() {
                        return Err(Error::scene(&c.loc, "bumpmap takes exactly one nested BSDF"));
                    }
                    nested = Some(self.bsdf(c)?);
                }
                "texture" => {
                    if height.is_some() {
                        return Err(Error::scene(&c.loc, "bumpmap takes exactly one nested height <texture>"));
                    }
                    let t = self.deref(c, "texture")?;
                    let id = self.texture(t)?;
                    if !matches!(self.materials.textures[id as usize], Texture::Bitmap(_)) {
                        return Err(Error::scene(&c.loc, "a bumpmap's height texture must be a 'bitmap' (Mitsuba 3 has no gradient for other textures)"));
                    }
                    height = Some(id);
                }
                t => return Err(Error::scene(&c.loc, format!("<{t}> is not expected inside a bumpmap (a nested <bsdf> and a height <texture>)"))),
            }
        }
        let nested =
            nested.ok_or_else(|| Error::scene(p.loc(), "bumpmap needs a nested <bsdf>"))?;
        let height = height
            .ok_or_else(|| Error::scene(p.loc(), "bumpmap needs a nested height <texture>"))?;
        let scale = p.float("scale", 1.0)?;
        check(p.loc(), scale.is_finite(), "bumpmap scale must be finite")?;
        let default = !self.doc.upgraded_from_v0;
        Ok(MaterialNode::BumpMap {
            nested,
            height,
            scale,
            flip_invalid_normals: p.bool("flip_invalid_normals", default)?,
            use_shadowing_function: p.bool("use_shadowing_function", default)?,
        })
    }

    /// Mitsuba 3.9.1's `normalmap` (`bsdf::normalmap`): `flip_invalid_normals` and
    /// `use_shadowing_function` default to true, to false in documents upgraded from 0.6
    /// (Mitsuba 0.6 had neither). `plain` (the classic side of `--normal-mapping`) forces both
    /// false.
    fn classic_normalmap(&mut self, p: &Props<'d>, plain: bool) -> Result<MaterialNode> {
        let (nested, _, normalmap) = self.normalmap_parts(p, "normalmap")?;
        let default = !self.doc.upgraded_from_v0;
        let flip = p.bool("flip_invalid_normals", default)?;
        let shadow = p.bool("use_shadowing_function", default)?;
        Ok(MaterialNode::NormalMap {
            nested,
            normalmap,
            flip_invalid_normals: flip && !plain,
            use_shadowing_function: shadow && !plain,
        })
    }

    /// A `normalmap` converted to a `microfacet_normalmap` with the decisions page's defaults
    /// (`--normal-mapping microfacet`); its own flags are read (and checked) but have no effect.
    fn normalmap_as_microfacet(&mut self, p: &Props<'d>) -> Result<MaterialNode> {
        let (nested, nested_node, normalmap) = self.normalmap_parts(p, "normalmap")?;
        let _ = p.bool("flip_invalid_normals", true)?;
        let _ = p.bool("use_shadowing_function", true)?;
        let mode = match self.normal_mapping {
            NormalMapping::Forced(f) => f,
            _ => MnmMode {
                geometry: Microgeometry::Sawtooth,
                tangent: Tangent::Mirror,
                evaluation: Evaluation::RandomWalk,
            },
        };
        self.check_mnm_nested(nested, nested_node, p.loc(), mode.evaluation)?;
        Ok(MaterialNode::MicrofacetNormalMap {
            nested,
            normalmap,
            settings: MnmSettings {
                geometry: mode.geometry,
                tangent: mode.tangent,
                evaluation: mode.evaluation,
                max_order: 256,
                max_theta: 85f32.to_radians(),
                transmission_walk: TransmissionWalk::TwoSided,
            },
        })
    }

    /// What a `microfacet_normalmap` (written, or converted by `--normal-mapping microfacet`)
    /// accepts as nested BSDF: a non-delta lobe; over a transmitting BSDF only the random walk.
    fn check_mnm_nested(
        &self,
        nested: MatId,
        nested_node: &Node,
        loc: &SourceLoc,
        evaluation: Evaluation,
    ) -> Result<()> {
        let flags = self.materials.lobes(nested);
        if flags.intersects(Lobes::TRANSMISSION) && evaluation == Evaluation::Explicit {
            return Err(Error::scene(loc, "microfacet_normalmap over a transmitting BSDF needs evaluation = random_walk (the closed forms are reflection only)"));
        }
        if !flags.is_smooth() {
            return Err(Error::scene(&nested_node.loc, "microfacet_normalmap needs a nested BSDF with a non-delta lobe (e.g. diffuse, roughconductor, roughplastic): with only delta lobes its evaluation is zero almost everywhere"));
        }
        Ok(())
    }

    /// `microfacet_normalmap`: a nested BSDF and a `normalmap` texture, with the parameters of
    /// the decisions page of `mnm.md`.
    fn microfacet_normalmap(&mut self, p: &Props<'d>) -> Result<MaterialNode> {
        let (nested, nested_node, normalmap) = self.normalmap_parts(p, "microfacet_normalmap")?;
        let geometry = match p.string("microgeometry", "sawtooth")?.as_str() {
            "sawtooth" => Microgeometry::Sawtooth,
            "vgroove" => Microgeometry::VGroove,
            "ugroove" => {
                let s = p.float("groove_fill", 0.5)?;
                check(
                    p.loc(),
                    s > 0.0 && s <= 1.0,
                    "groove_fill must be in (0, 1]",
                )?;
                Microgeometry::UGroove { fill: s }
            }
            other => {
                return Err(Error::scene(
                    p.loc(),
                    format!("microgeometry '{other}' must be sawtooth, vgroove or ugroove"),
                ))
            }
        };
        if !matches!(geometry, Microgeometry::UGroove { .. }) && p.has("groove_fill") {
            return Err(Error::scene(
                p.loc(),
                "groove_fill belongs to microgeometry 'ugroove'",
            ));
        }
        let tangent = if p.has("tangent") {
            if geometry != Microgeometry::Sawtooth {
                return Err(Error::scene(
                    p.loc(),
                    "'tangent' belongs to the sawtooth microgeometry only",
                ));
            }
            match p.string("tangent", "mirror")?.as_str() {
                "mirror" => Tangent::Mirror,
                "same" => Tangent::Same,
                other => {
                    return Err(Error::scene(
                        p.loc(),
                        format!("tangent '{other}' must be 'mirror' or 'same'"),
                    ))
                }
            }
        } else if geometry == Microgeometry::Sawtooth {
            Tangent::Mirror
        } else {
            Tangent::Same
        };
        let evaluation = match p.string("evaluation", "random_walk")?.as_str() {
            "random_walk" => Evaluation::RandomWalk,
            "explicit" => Evaluation::Explicit,
            other => {
                return Err(Error::scene(
                    p.loc(),
                    format!("evaluation '{other}' must be 'random_walk' or 'explicit'"),
                ))
            }
        };
        // `--normal-mapping explicit|walk-mirror|...` replaces the written choices.
        let (geometry, tangent, evaluation) = match self.normal_mapping {
            NormalMapping::Forced(f) => (f.geometry, f.tangent, f.evaluation),
            _ => (geometry, tangent, evaluation),
        };
        if geometry != Microgeometry::Sawtooth && evaluation == Evaluation::Explicit {
            return Err(Error::scene(
                p.loc(),
                "microgeometries other than 'sawtooth' need evaluation = random_walk",
            ));
        }
        let max_order = p.int("max_order", 256)?;
        check(
            p.loc(),
            (1..=1 << 20).contains(&max_order),
            "max_order must be >= 1",
        )?;
        let max_theta = p.float("max_theta", 85.0)?;
        check(
            p.loc(),
            max_theta > 0.0 && max_theta < 90.0,
            "max_theta must be in (0, 90) degrees",
        )?;
        let walk = p.string("transmission_walk", "two_sided")?;
        let transmission_walk = match walk.as_str() {
            "two_sided" => TransmissionWalk::TwoSided,
            "exit_on_refraction" => TransmissionWalk::ExitOnRefraction,
            _ => {
                return Err(Error::scene(
                    p.loc(),
                    "transmission_walk must be 'two_sided' or 'exit_on_refraction'",
                ))
            }
        };
        self.check_mnm_nested(nested, nested_node, p.loc(), evaluation)?;
        Ok(MaterialNode::MicrofacetNormalMap {
            nested,
            normalmap,
            settings: MnmSettings {
                geometry,
                tangent,
                evaluation,
                max_order: max_order as u32,
                max_theta: max_theta.to_radians(),
                transmission_walk,
            },
        })
    }

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

    // ------------------------------------------------------------------ shapes
    fn shape(&mut self, n: &'d Node) -> Result<()> {
        let p = Props::new(n)?;
        let to_world = p.transform("to_world")?;
        let flip = p.bool("flip_normals", false)?;
        let shape = match p.plugin_type() {
            t @ ("obj" | "ply") => {
                let fname = p.string_opt("filename")?.ok_or_else(|| {
                    Error::scene(p.loc(), format!("shape '{t}' needs a 'filename'"))
                })?;
                let file = self.doc.resolve_file(&fname, p.loc())?;
                let face_normals = p.bool("face_normals", false)?;
                let flip_tex = p.bool("flip_tex_coords", t == "obj")?;
                let mut mesh = if t == "obj" {
                    obj::load_obj(&file)?
                } else {
                    ply::load_ply(&file)?
                };
                // The OBJ loader applies Mitsuba's v flip; undo it when asked not to flip.
                if (t == "obj") != flip_tex {
                    if let Some(uv) = mesh.uvs.as_mut() {
                        uv.iter_mut().for_each(|t| t.y = 1.0 - t.y);
                    }
                }
                mesh.transform(&to_world);
                Shape::from_mesh(mesh, flip, face_normals)
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
                let mut mesh = serialized::load_serialized(&file, index, !face_normals)
                    .map_err(|e| Error::scene(p.loc(), e.to_string()))?
                    .mesh;
                mesh.transform(&to_world);
                Shape::from_mesh(mesh, flip, face_normals)
                    .map_err(|e| Error::scene(p.loc(), format!("{}: {e}", file.display())))?
            }
            "rectangle" => Shape::rectangle(&to_world, flip),
            "cube" => Shape::cube(&to_world, flip),
            "disk" => {
                Shape::disk(&to_world, flip).map_err(|e| Error::scene(p.loc(), e.to_string()))?
            }
            "sphere" => {
                let c = p.point("center", Vec3::ZERO)?;
                let r = p.float("radius", 1.0)?;
                check(
                    p.loc(),
                    r > 0.0 && r.is_finite(),
                    "sphere radius must be positive",
                )?;
                Shape::sphere(c, r, &to_world, flip)
                    .map_err(|e| Error::scene(p.loc(), e.to_string()))?
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
                    ],
                ))
            }
        };
        let index = self.shapes.len() as u32;
        let mut material = None;
        let mut emitter = None;
        for c in p.objects() {
            let tag = self.object_tag(c);
            match tag {
                "bsdf" => {
                    if material.is_some() {
                        return Err(Error::scene(&c.loc, "a shape takes only one BSDF"));
                    }
                    material = Some(self.bsdf(c)?);
                }
                "emitter" => {
                    if emitter.is_some() {
                        return Err(Error::scene(&c.loc, "a shape takes only one emitter"));
                    }
                    let en = self.deref(c, "emitter")?;
                    emitter = Some(self.area_emitter(en, index)?);
                }
                "ref" => {
                    let id = c.attr("id").unwrap_or("");
                    return Err(Error::scene(
                        &c.attr_loc("id").clone(),
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
        p.finish()?;
        // Mitsuba 3: a shape without a BSDF gets a 0.5 grey diffuse one, but an emitting shape
        // without a BSDF gets a black one (it does not reflect light).
        let material = match material {
            Some(m) => m,
            None => self.default_material(emitter.is_some()),
        };
        self.shapes.push(shape);
        self.shape_material.push(material);
        self.shape_emitter.push(emitter);
        Ok(())
    }

    // ------------------------------------------------------------------ emitters
    fn area_emitter(&mut self, n: &'d Node, shape: u32) -> Result<u32> {
        let p = Props::new(n)?;
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
                let t = self.deref(c, "texture")?;
                let id = self.texture(t)?;
                return Ok(self.materials.textures[id as usize].clone());
            }
        }
        if !p.has(name) {
            return Err(Error::scene(
                p.loc(),
                format!("the emitter needs a '{name}'"),
            ));
        }
        let c = p.color_with(name, Spectrum::ONE, SpectrumUse::Emission)?;
        check(
            p.loc(),
            c.min_element() >= 0.0,
            format!("'{name}' must not be negative"),
        )?;
        Ok(Texture::Constant(c))
    }

    fn top_level_emitter(&mut self, n: &'d Node) -> Result<()> {
        let p = Props::new(n)?;
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
            "spot" => spot_emitter(&p)?,
            "directional" => directional_emitter(&p)?,
            "envmap" => envmap_emitter(self.doc, &p)?,
            t => {
                return Err(unknown(
                    p.loc(),
                    "emitter",
                    t,
                    &["area", "point", "constant", "spot", "directional", "envmap"],
                ))
            }
        };
        p.finish()?;
        self.emitters.push(e);
        Ok(())
    }
}

// ---------------------------------------------------------------------- emitters at infinity, spot
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

/// Mitsuba 3 `spot`: `intensity`, `cutoff_angle` (20°), `beam_width` (¾ cutoff), `to_world`.
fn spot_emitter(p: &Props<'_>) -> Result<Emitter> {
    no_nested_objects(p, "spot")?;
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
    let m = p.transform("to_world")?;
    let axis = m.transform_vector3(Vec3::Z);
    check(
        p.loc(),
        axis.is_finite() && axis.length() > 1e-12,
        "the spot light's 'to_world' is degenerate (maps +z to zero)",
    )?;
    Ok(Emitter::Spot(SpotLight::new(
        m.transform_point3(Vec3::ZERO),
        Mat3::from_mat4(m),
        intensity,
        cutoff.to_radians(),
        beam.to_radians(),
    )))
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

/// Mitsuba 3 `envmap`: `filename` (a lat-long OpenEXR), `scale`, `to_world` (a rotation).
fn envmap_emitter(doc: &Document, p: &Props<'_>) -> Result<Emitter> {
    no_nested_objects(p, "envmap")?;
    let name = p
        .string_opt("filename")?
        .ok_or_else(|| Error::scene(p.loc(), "emitter 'envmap' needs a 'filename'"))?;
    let scale = p.float("scale", 1.0)?;
    let m = p.transform("to_world")?;
    let file = doc.resolve_file(&name, p.loc())?;
    let is_exr = file
        .extension()
        .and_then(|e| e.to_str())
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    check(
        p.loc(),
        is_exr,
        format!("envmap '{name}': only OpenEXR (.exr) environment maps are supported"),
    )?;
    let (img, _) = crate::output::read_exr(&file)
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

/// The 2-D affine part of a `to_uv` transform.
fn mat4_to_uv(m: &Mat4) -> Mat3 {
    Mat3::from_cols(
        Vec3::new(m.x_axis.x, m.x_axis.y, 0.0),
        Vec3::new(m.y_axis.x, m.y_axis.y, 0.0),
        Vec3::new(m.w_axis.x, m.w_axis.y, 1.0),
    )
}

/// An index of refraction given as a number or by name (`bk7`, `water`, `air`, ...).
fn ior_param(p: &Props, name: &str, default: f32) -> Result<f32> {
    let v = match p.property_node(name) {
        None => default,
        Some(node) if node.tag == "string" => {
            let s = node.attr("value").unwrap_or("");
            named_ior(s).ok_or_else(|| {
                Error::scene(
                    &node.loc,
                    format!("unknown index of refraction '{s}' (e.g. bk7, water, air, vacuum)"),
                )
            })?
        }
        Some(_) => p.float(name, default)?,
    };
    check(
        p.loc(),
        v.is_finite() && v > 0.0,
        format!("{name} must be positive"),
    )?;
    Ok(v)
}
