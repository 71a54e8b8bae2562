//! The loader: turns a parsed scene file ([`crate::scene::xml`]) into a [`Scene`], one builder
//! per plugin kind, every property checked (an unreferenced property is an error, as in
//! Mitsuba 3) and `<ref>`s resolved by id.
//!
//! - this file: the entry points ([`load_scene`], [`instantiate`]), the `Builder` that
//!   collects what the builders make, and the top level of a scene;
//! - `settings`: `<integrator>`, `<sensor>`, `<film>`, `<rfilter>`, `<sampler>`;
//! - `textures`: `<texture>` and colour-or-texture parameters;
//! - `bsdfs`: `<bsdf>`, dispatched to the constructor that lives in each BSDF's own file
//!   beside its table of parameters (and the `--normal-mapping` conversions);
//! - `shapes`: `<shape>`, its area emitter and the default materials;
//! - `shapegroup`: `shapegroup` and `instance`;
//! - `emitters`: the top-level `<emitter>`s;
//! - `media`: `<medium>` and `<phase>` (the media of shapes and of the sensor);
//! - [`options`]: what a load is asked for besides the file (`-D`, `--normal-mapping`).

pub(crate) mod bsdfs;
mod emitters;
mod media;
mod mitsuba_plugins;
pub mod options;
mod settings;
mod shapegroup;
mod shapes;
mod textures;

use crate::accel::Accel;
use crate::budget::Budget;
use crate::camera::Camera;
use crate::emitter::{Emitter, LightSampler};
use crate::error::{Error, Result, SourceLoc};
use crate::film::FilmDesc;
use crate::geometry::{Instance, Shape};
use crate::integrator::{IntegratorDesc, PathSettings};
use crate::material::{MatId, Materials, TexId};
use crate::render::RenderSettings;
use crate::sampler::SamplerDesc;
use crate::scene::xml::ir::{Document, Ids, Node};
use crate::scene::xml::parse::load_file_within;
use crate::scene::xml::props::Props;
use crate::scene::Scene;
use options::{LoadOptions, NormalMapping};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// A loaded scene, how its file asks for it to be rendered, and the warnings its loading
/// produced (lenient fallbacks, old tags).
pub struct Loaded {
    pub scene: Scene,
    pub settings: RenderSettings,
    pub warnings: Vec<String>,
    /// Every file the load read: the scene, its includes, meshes and images (an output must
    /// not overwrite any of them).
    pub inputs: Vec<PathBuf>,
}

/// How deep BSDFs may nest (through children or `<ref>`s). Each level costs the loader a few
/// kilobytes of stack (measured: see `tests/scene/hostile.rs`), so 64 levels stay far below
/// the 2 MB of a worker thread's stack, and no real material nests more than a handful deep.
pub const MAX_NESTING: usize = 64;

/// Parse, upgrade and instantiate a scene file.
pub fn load_scene(path: &Path, opts: &LoadOptions) -> Result<Loaded> {
    let doc = load_file_within(path, &opts.defines, &opts.budget)?;
    instantiate_within(&doc, path, opts.normal_mapping, &opts.budget)
}

/// Instantiate a parsed document. `path` names the scene in the result.
pub fn instantiate(doc: &Document, path: &Path) -> Result<Loaded> {
    instantiate_with(doc, path, NormalMapping::AsWritten)
}

/// What the builders of one document collect.
struct Builder<'d> {
    doc: &'d Document,
    /// `--normal-mapping`: which model the scene's normal maps become.
    normal_mapping: NormalMapping,
    /// Every element with an `id`, for `<ref>`.
    ids: &'d Ids<'d>,
    bsdf_cache: HashMap<&'d str, MatId>,
    tex_cache: HashMap<&'d str, TexId>,
    /// Textures checked against each shape they are evaluated on
    /// ([`Builder::check_hit_textures`]): `mesh_attribute`s, and 3-D `rawconstant`s (`true`).
    hit_checked: HashMap<TexId, (&'d Node, bool)>,
    materials: Materials,
    /// The default diffuse BSDFs: [for plain shapes (0.5 grey), for emitting shapes (black)].
    default_materials: [Option<MatId>; 2],
    shapes: Vec<Shape>,
    shape_material: Vec<MatId>,
    shape_emitter: Vec<Option<u32>>,
    /// The media on both sides of each shape.
    shape_media: Vec<crate::medium::MediumInterface>,
    /// The media built so far, and the element each came from (a medium is built once).
    media: Vec<crate::medium::Medium>,
    medium_cache: HashMap<*const Node, crate::medium::MediumId>,
    /// The sensor's medium.
    camera_medium: Option<crate::medium::MediumId>,
    /// The shape groups: the range of `shapes` each one's members occupy.
    groups: Vec<std::ops::Range<u32>>,
    /// Index in `groups` of each group element built so far.
    group_index: HashMap<*const Node, u32>,
    instances: Vec<Instance>,
    /// Every shape and instance in the order they were built (group members included; the
    /// numbering of `aov`'s `shape_index` leaves them out): [`Builder::number_shapes`].
    placed: Vec<shapegroup::Placed>,
    emitters: Vec<Emitter>,
    warnings: Vec<String>,
    /// The memory budget images and meshes are checked against.
    budget: Budget,
    /// The BSDFs being built, outermost first: a `<ref>` to one of them is a cycle, and the
    /// length is the nesting depth ([`MAX_NESTING`]).
    building: Vec<&'d Node>,
    /// Every `direct` integrator with `emitter_samples` > 1 (its element, the count): Mitsuba
    /// weights its delta-light samples by 1, not 1/count (warned when the scene has one).
    direct_emitter_samples: Vec<(SourceLoc, u32)>,
}

/// [`instantiate`] with every normal map converted to the model `normal_mapping` (decision 6).
pub fn instantiate_with(
    doc: &Document,
    path: &Path,
    normal_mapping: NormalMapping,
) -> Result<Loaded> {
    instantiate_within(doc, path, normal_mapping, &Budget::default())
}

/// [`instantiate_with`] whose images and meshes are checked against `budget`.
pub fn instantiate_within(
    doc: &Document,
    path: &Path,
    normal_mapping: NormalMapping,
    budget: &Budget,
) -> Result<Loaded> {
    let ids = Ids::new(&doc.root);
    let mut b = Builder {
        doc,
        normal_mapping,
        ids: &ids,
        bsdf_cache: HashMap::new(),
        tex_cache: HashMap::new(),
        hit_checked: HashMap::new(),
        materials: Materials::default(),
        default_materials: [None, None],
        shapes: Vec::new(),
        shape_material: Vec::new(),
        shape_emitter: Vec::new(),
        shape_media: Vec::new(),
        media: Vec::new(),
        medium_cache: HashMap::new(),
        camera_medium: None,
        groups: Vec::new(),
        group_index: HashMap::new(),
        instances: Vec::new(),
        placed: Vec::new(),
        emitters: Vec::new(),
        warnings: doc.warnings.clone(),
        budget: budget.clone(),
        building: Vec::new(),
        direct_emitter_samples: Vec::new(),
    };
    let (integrator, sensor) = b.top_level()?;
    let integrator = integrator.unwrap_or(IntegratorDesc::Path(PathSettings::default()));
    let Some((camera, film, sampler)) = sensor else {
        return Err(Error::scene(
            &doc.root.loc,
            "the scene has no <sensor>: add a perspective sensor to render it",
        ));
    };
    if b.shapes.is_empty() && b.emitters.is_empty() {
        b.warnings.push(format!(
            "{}: the scene is empty (no shapes, no emitters)",
            doc.root.loc
        ));
    }

    if b.emitters.iter().any(Emitter::is_delta) {
        for (loc, n) in &b.direct_emitter_samples {
            b.warnings.push(format!(
                "{loc}: direct: with emitter_samples = {n}, each sample that picks a delta light \
                 (point, spot, projector, directional) counts fully, as in Mitsuba 3.9.1, so \
                 those lights contribute {n} times their light; groove matches Mitsuba"
            ));
        }
    }
    b.number_shapes();
    let accel = Accel::build_instanced(&b.shapes, &b.groups, &b.instances)?;
    let bsphere = Scene::bounding_sphere_instanced(&b.shapes, &b.groups, &b.instances);
    let env_emitters = b
        .emitters
        .iter()
        .enumerate()
        .filter(|(_, e)| e.is_environment())
        .map(|(i, _)| i as u32)
        .collect();
    let light_sampler = LightSampler::new(&b.emitters, &b.shapes, bsphere.1);
    // Per material once (a scene may have many shapes on few materials).
    let mut reads_mesh: Vec<Option<bool>> = vec![None; b.materials.node_count()];
    let shape_reads_mesh = b
        .shape_material
        .iter()
        .map(|&m| {
            *reads_mesh[m as usize].get_or_insert_with(|| {
                let mut reads = false;
                b.materials.texture_uses(m, &mut |t, _| {
                    reads |= matches!(
                        b.materials.textures[t as usize],
                        crate::texture::Texture::MeshAttribute(_)
                    );
                });
                reads
            })
        })
        .collect();
    Ok(Loaded {
        scene: Scene {
            shapes: b.shapes,
            instances: b.instances,
            shape_material: b.shape_material,
            shape_reads_mesh,
            shape_emitter: b.shape_emitter,
            shape_media: b.shape_media,
            media: b.media,
            camera_medium: b.camera_medium,
            accel,
            materials: b.materials,
            emitters: b.emitters,
            env_emitters,
            light_sampler,
            camera,
            bsphere,
            source: path.to_path_buf(),
        },
        settings: RenderSettings {
            integrator,
            film,
            sampler,
        },
        warnings: b.warnings,
        inputs: doc
            .files
            .iter()
            .chain(doc.read.borrow().iter())
            .cloned()
            .collect(),
    })
}

/// The integrator and the sensor (camera, film, sampler) of a scene, if given.
type TopLevel = (
    Option<IntegratorDesc>,
    Option<(Camera, FilmDesc, SamplerDesc)>,
);

impl<'d> Builder<'d> {
    /// The properties of element `n`, seeing through `<ref>`s.
    fn props(&self, n: &'d Node) -> Result<Props<'d>> {
        Props::with_ids(n, self.ids)
    }

    /// Builds every child of `<scene>`: the objects go into the builder, the integrator and
    /// sensor are returned.
    fn top_level(&mut self) -> Result<TopLevel> {
        let mut integrator = None;
        let mut sensor = None;
        for child in &self.doc.root.children {
            match child.tag.as_str() {
                "integrator" => {
                    if integrator.is_some() {
                        return Err(Error::scene(
                            &child.loc,
                            "a scene takes only one <integrator>",
                        ));
                    }
                    integrator = Some(self.integrator(child)?);
                }
                "sensor" => {
                    if sensor.is_some() {
                        return Err(Error::scene(
                            &child.loc,
                            "groove renders one <sensor> per scene; this is a second one",
                        ));
                    }
                    sensor = Some(self.sensor(child)?);
                }
                "shape" => self.shape(child)?,
                "bsdf" => {
                    self.bsdf(child)?;
                }
                "texture" => {
                    self.texture(child)?;
                }
                "emitter" => self.top_level_emitter(child)?,
                "medium" => {
                    self.medium(child)?;
                }
                // Built where a `<ref>` names them.
                "phase" | "volume" if child.attr("id").is_some() => {}
                // Mitsuba builds a top-level object with an id when a `<ref>` uses it: the
                // sensor does, for its sampler and film.
                "film" | "sampler" if child.attr("id").is_some() => {}
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
        Ok((integrator, sensor))
    }
}

/// A plugin type groove does not build, with the ones it supports for `kind`: a polarisation
/// plugin says it needs Mitsuba's polarised variant, another Mitsuba 3.9.1 plugin says that
/// groove lacks it (naming its Mitsuba kind), any other name is an unknown plugin.
pub(crate) fn unknown(loc: &SourceLoc, kind: &str, ty: &str, known: &[&str]) -> Error {
    let supported = known.join(", ");
    let msg = if mitsuba_plugins::is_polarised(ty) {
        format!(
            "{kind} plugin '{ty}' needs a polarised variant (Mitsuba's *_polarized); \
             groove renders RGB"
        )
    } else if let Some(mkind) = mitsuba_plugins::mitsuba_kind(ty) {
        format!(
            "Mitsuba plugin '{ty}' ({mkind}) is not supported by groove (groove's {kind} plugins: {supported})"
        )
    } else {
        format!("unknown {kind} plugin '{ty}' (groove supports: {supported})")
    };
    Error::scene(loc, msg)
}

/// Checks that a value read from the scene is finite and in range: `msg` at `loc` when not.
pub(crate) fn check(loc: &SourceLoc, ok: bool, msg: impl Into<String>) -> Result<()> {
    if ok {
        Ok(())
    } else {
        Err(Error::scene(loc, msg))
    }
}
