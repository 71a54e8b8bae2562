//! `<bsdf>`: the plugin name picks the constructor, which lives in that BSDF's own file beside
//! its table of parameters (`bsdf::diffuse::load`, ...); this file holds the dispatch, the
//! `--normal-mapping` conversions and [`BsdfCtx`], the narrow view of the loader a constructor
//! works through.

use super::options::{MnmMode, NormalMapping};
use super::{unknown, Builder, MAX_NESTING};
use crate::bsdf::mnm::facets::Microgeometry;
use crate::bsdf::mnm::Evaluation;
use crate::bsdf::{
    blend, bumpmap, conductor, dielectric, diffuse, hair, mask, mnm, normalmap, null, plastic,
    principled, principledthin, roughconductor, roughdielectric, roughplastic, thindielectric,
    twosided, Lobes,
};
use crate::error::{Error, Result};
use crate::material::{MatId, MaterialNode, Slot, TexId};
use crate::scene::xml::ir::Node;
use crate::scene::xml::props::Props;
use crate::spectrum::Spectrum;
use crate::texture::Texture;

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
    "hair",
];

/// The model `--normal-mapping microfacet` gives a `normalmap`: the defaults of
/// `microfacet_normalmap` (its wall: `mnm::load::DEFAULT_WALK_TANGENT`).
const MICROFACET_DEFAULT: MnmMode = MnmMode {
    geometry: Microgeometry::Sawtooth,
    tangent: mnm::load::DEFAULT_WALK_TANGENT,
    evaluation: Evaluation::RandomWalk,
};

impl<'d> Builder<'d> {
    /// Builds `<bsdf>` `n` (or the one a `<ref>` names) once; a BSDF with an id is shared by
    /// every reference to it.
    ///
    /// A BSDF that refers (directly or through others) to itself is an error at the `<ref>`
    /// that closes the cycle ("circular reference", as Mitsuba 3 says), and so is nesting
    /// deeper than [`MAX_NESTING`]: both are found before the stack can overflow.
    pub(super) fn bsdf(&mut self, r: &'d Node) -> Result<MatId> {
        let n = self.ids.resolve(r, "bsdf")?;
        if let Some(id) = n.attr("id") {
            if let Some(&m) = self.bsdf_cache.get(id) {
                return Ok(m);
            }
        }
        if self.building.iter().any(|b| std::ptr::eq(*b, n)) {
            let chain: Vec<String> = self
                .building
                .iter()
                .skip_while(|b| !std::ptr::eq(**b, n))
                .map(|b| match b.attr("id") {
                    Some(id) => format!("'{id}'"),
                    None => b.describe(),
                })
                .collect();
            return Err(Error::scene(
                r.attr_loc("id"),
                format!(
                    "circular reference: bsdf {} refers to itself ({} -> {})",
                    chain[0],
                    chain.join(" -> "),
                    chain[0]
                ),
            ));
        }
        if self.building.len() >= MAX_NESTING {
            return Err(Error::scene(
                &r.loc,
                format!("BSDFs nest more than {MAX_NESTING} deep (through children and <ref>s)"),
            ));
        }
        self.building.push(n);
        let built = self.construct_bsdf(n);
        self.building.pop();
        let node = built?;
        let id = self.materials.add_node(node);
        if let Some(i) = n.attr("id") {
            self.bsdf_cache.insert(i, id);
        }
        Ok(id)
    }

    /// Runs the constructor of `<bsdf>` `n` and checks that it used every property.
    fn construct_bsdf(&mut self, n: &'d Node) -> Result<MaterialNode> {
        let mut cx = BsdfCtx {
            p: self.props(n)?,
            b: self,
        };
        let node = cx.construct()?;
        cx.p.finish()?;
        Ok(node)
    }
}

/// What a BSDF's constructor sees of the loader: its element's properties, the textures and
/// nested BSDFs it refers to (built on demand, shared when they have an id), and a few facts
/// about the document. Nothing else of the loader's state is reachable through it.
pub(crate) struct BsdfCtx<'b, 'd> {
    p: Props<'d>,
    b: &'b mut Builder<'d>,
}

impl<'d> BsdfCtx<'_, 'd> {
    /// Runs the constructor of the element's plugin type, applying `--normal-mapping`.
    fn construct(&mut self) -> Result<MaterialNode> {
        let nm = self.b.normal_mapping;
        match self.p.plugin_type() {
            "diffuse" => diffuse::load::build(self),
            "conductor" => conductor::load::build(self),
            "roughconductor" => roughconductor::load::build(self),
            "hair" => hair::load::build(self),
            "dielectric" => dielectric::load::build(self),
            "thindielectric" => thindielectric::load::build(self),
            "roughdielectric" => roughdielectric::load::build(self),
            "plastic" => plastic::load::build(self),
            "roughplastic" => roughplastic::load::build(self),
            "twosided" => twosided::load::build(self),
            "microfacet_normalmap" => match nm {
                // Classic side of `--normal-mapping`: the plain model over the same texture and
                // nested BSDF (the microfacet parameters are still checked).
                NormalMapping::Classic => Ok(match mnm::load::build(self, None)? {
                    MaterialNode::MicrofacetNormalMap {
                        nested, normalmap, ..
                    } => MaterialNode::NormalMap {
                        nested,
                        normalmap,
                        flip_invalid_normals: false,
                        use_shadowing_function: false,
                    },
                    other => other,
                }),
                // `--normal-mapping explicit|walk-mirror|...` replaces the written choices.
                NormalMapping::Forced(f) => mnm::load::build(self, Some(f)),
                _ => mnm::load::build(self, None),
            },
            "blendbsdf" => blend::load::build(self),
            "null" => null::load::build(self),
            "mask" => mask::load::build(self),
            "bumpmap" => bumpmap::load::build(self),
            t @ ("principled" | "principledthin") => {
                let BsdfCtx { p, b } = self;
                // A parameter's nested (or referenced) texture, if any.
                let mut texture = |name: &str| -> Result<Option<TexId>> {
                    let Some(c) = p.objects().find(|c| c.attr("name") == Some(name)) else {
                        return Ok(None);
                    };
                    if p.kind(c) != "texture" {
                        return Err(Error::scene(
                            &c.loc,
                            format!("'{name}' expects a value or a <texture>, not a <{}>", c.tag),
                        ));
                    }
                    b.texture(c).map(Some)
                };
                if t == "principled" {
                    principled::material(p, &mut texture)
                } else {
                    principledthin::material(p, &mut texture)
                }
            }
            "normalmap" => match nm {
                NormalMapping::Microfacet => mnm::load::from_normalmap(self, MICROFACET_DEFAULT),
                NormalMapping::Forced(f) => mnm::load::from_normalmap(self, f),
                mode => normalmap::load::build(self, mode == NormalMapping::Classic),
            },
            t if PLANNED_BSDFS.contains(&t) => Err(Error::scene(
                self.p.loc(),
                format!("bsdf '{t}' is not supported yet"),
            )),
            t => Err(unknown(self.p.loc(), "bsdf", t, SUPPORTED_BSDFS)),
        }
    }

    /// The element's properties (read them with their Mitsuba 3 defaults).
    pub(crate) fn props(&self) -> &Props<'d> {
        &self.p
    }

    /// The document was older than 2.0 (upgraded): some defaults follow Mitsuba 0.6.
    pub(crate) fn upgraded_from_v0(&self) -> bool {
        self.b.doc.upgraded_from_v0
    }

    /// The nested BSDF `c` (a `<bsdf>` or a `<ref>` to one), built.
    pub(crate) fn bsdf(&mut self, c: &'d Node) -> Result<MatId> {
        self.b.bsdf(c)
    }

    /// The nested texture `c` (a `<texture>` or a `<ref>` to one), built.
    pub(crate) fn texture(&mut self, c: &'d Node) -> Result<TexId> {
        self.b.texture(c)
    }

    /// A texture built before.
    pub(crate) fn texture_at(&self, id: TexId) -> &Texture {
        &self.b.materials.textures[id as usize]
    }

    /// A new constant texture.
    pub(crate) fn constant(&mut self, c: Spectrum) -> TexId {
        self.b.materials.add_texture(Texture::Constant(c))
    }

    /// The lobes a material built before can produce.
    pub(crate) fn lobes(&self, id: MatId) -> Lobes {
        self.b.materials.lobes(id)
    }

    /// The materials and textures built so far (a constructor that precomputes from its nested
    /// BSDF: `microfacet_normalmap`'s compensated tables).
    pub(crate) fn materials(&self) -> &crate::material::Materials {
        &self.b.materials
    }

    /// A warning for the load's report.
    pub(crate) fn warn(&mut self, w: String) {
        self.b.warnings.push(w);
    }

    /// A colour parameter that may be a constant (`default` when absent) or a texture.
    pub(crate) fn color(&mut self, name: &str, default: Spectrum) -> Result<TexId> {
        self.b.color_param(&self.p, name, default)
    }

    /// A colour of a leaf BSDF: constant (returned, no slot) or textured (returned as the
    /// texture's mean for load-time decisions, plus the slot to fill per hit).
    pub(crate) fn leaf_color(
        &mut self,
        name: &str,
        slot: Slot,
        default: f32,
    ) -> Result<(Spectrum, Vec<(Slot, TexId)>)> {
        let tex = self.color(name, Spectrum::splat(default))?;
        match self.texture_at(tex) {
            Texture::Constant(c) => Ok((*c, Vec::new())),
            // Mitsuba's plastics weigh their sampling by the textures' means, which a
            // `mesh_attribute` does not have (its `mean()` throws "not implemented").
            Texture::MeshAttribute(_)
                if matches!(self.p.plugin_type(), "plastic" | "roughplastic") =>
            {
                Err(Error::scene(
                    self.p.loc(),
                    format!(
                        "'{name}' of bsdf '{}' cannot be a 'mesh_attribute' texture: the BSDF needs the texture's mean, which a mesh attribute does not have (Mitsuba 3 fails the same way)",
                        self.p.plugin_type()
                    ),
                ))
            }
            other => Ok((other.mean(), vec![(slot, tex)])),
        }
    }
}
