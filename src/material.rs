//! Materials: the scene's `<bsdf>` trees with textured parameters. At a hit a material evaluates
//! its textures and writes plain-valued [`BsdfNode`]s into the per-thread arena.

use crate::bsdf::mnm::facets::{store3, Candidates, FacetCols, MaxTilt, Microgeometry};
use crate::bsdf::mnm::ms_table::{CellCols, ThetaCells};
use crate::bsdf::mnm::{Evaluation, MicrofacetNormalMap, Tangent, TransmissionWalk};
use crate::bsdf::{
    bumpmap, Blend, BsdfArena, BsdfNode, Diffuse, Lobes, Mask, NormalMap, Principled,
    PrincipledThin,
};
use crate::geometry::SurfaceInteraction;
use crate::lane::vec::V3;
use crate::lane::{Lane, ToArray};
use crate::texture::{Lookup, Texture};
use glam::Vec3;

/// Index of a texture in [`Materials::textures`].
pub type TexId = u32;
/// Index of a material node in [`Materials::nodes`].
pub type MatId = u32;

/// Which field of a leaf BSDF a texture drives: a colour, or a scalar (roughness) read with
/// [`Texture::eval_1`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    Reflectance,
    SpecularReflectance,
    SpecularTransmittance,
    DiffuseReflectance,
    /// Isotropic microfacet roughness (sets both `alpha_u` and `alpha_v`).
    Alpha,
    AlphaU,
    AlphaV,
    /// `principled` / `principledthin` parameters (all scalar except `BaseColor`).
    BaseColor,
    Roughness,
    Anisotropic,
    Metallic,
    SpecTrans,
    SpecTint,
    Sheen,
    SheenTint,
    Flatness,
    Clearcoat,
    ClearcoatGloss,
    DiffTrans,
    Eta,
    /// `hair`'s absorption coefficient (a colour, not clamped).
    SigmaA,
}

impl Slot {
    /// A scalar field (evaluated with `eval_1`, Mitsuba's rule for float textures).
    pub fn is_scalar(self) -> bool {
        !matches!(
            self,
            Slot::Reflectance
                | Slot::SpecularReflectance
                | Slot::SpecularTransmittance
                | Slot::DiffuseReflectance
                | Slot::BaseColor
                | Slot::SigmaA
        )
    }
}

/// Settings of a `microfacet_normalmap` (see `bsdf::mnm`).
#[derive(Clone, Copy, Debug)]
pub struct MnmSettings {
    pub geometry: Microgeometry,
    pub tangent: Tangent,
    pub evaluation: Evaluation,
    pub max_order: u32,
    /// Largest tilt of the perturbed normal (radians, with its cosine and sine).
    pub max_theta: MaxTilt,
    /// Over a transmitting nested BSDF: two-sided (§9.3) or early-exit (§9.4) walk.
    pub transmission_walk: TransmissionWalk,
    /// Over a diffuse nested BSDF, the random walk's exact closed forms (`bsdf::mnm::lambert`).
    pub lambert_closed_form: bool,
    /// `evaluation = compensated`: the nested BSDF's remainder table (`bsdf::mnm::ms_table`).
    pub ms_table: Option<&'static crate::bsdf::mnm::ms_table::MsTable>,
}

impl MnmSettings {
    /// The map at one hit, over the arena node `nested`, with the perturbed normal `rgb` of the
    /// normal map texture (2·rgb − 1, clamped to `max_theta`), before its ωi cache
    /// ([`MicrofacetNormalMap::with_incident`]; the stream kernel adds 8 at once).
    #[inline(always)]
    pub fn map_at(&self, nested: u32, rgb: Vec3) -> MicrofacetNormalMap {
        let wp = self.max_theta.clamp(2.0 * rgb - Vec3::ONE);
        MicrofacetNormalMap::new(
            nested,
            wp,
            self.geometry,
            self.tangent,
            self.evaluation,
            self.max_order,
        )
        .with_transmission_walk(self.transmission_walk)
        .with_lambert_closed_form(self.lambert_closed_form)
        .with_ms_table(self.ms_table)
    }

    /// [`Self::map_at`] written in place into `slot` (every field: the arena's in-place
    /// build, [`crate::bsdf::BsdfArena::push_microfacet_normal_map_with`]); the same map bit
    /// for bit.
    #[inline(always)]
    pub fn map_into(&self, slot: &mut MicrofacetNormalMap, nested: u32, rgb: Vec3) {
        let wp = self.max_theta.clamp(2.0 * rgb - Vec3::ONE);
        *slot = MicrofacetNormalMap::new(
            nested,
            wp,
            self.geometry,
            self.tangent,
            self.evaluation,
            self.max_order,
        );
        self.options_into(slot);
        slot.set_ms_table(self.ms_table);
    }

    /// The settings both map builds copy as they are: the transmission walk and the Lambert
    /// closed form.
    #[inline(always)]
    fn options_into(&self, slot: &mut MicrofacetNormalMap) {
        slot.transmission_walk = self.transmission_walk;
        slot.set_lambert_closed_form(self.lambert_closed_form);
    }

    /// The arithmetic of [`Self::map_into`] at several hits at once (lanes), from their normal
    /// map values `rgb`: the clamped perturbed normals, the microsurfaces' candidate facets and
    /// frames, and (compensated, with a table) the θp cells; [`Self::map_lane_into`] then
    /// writes each hit's map.
    #[inline(always)]
    pub fn lanes_at<L: Lane>(&self, rgb: V3<L>) -> MnmLanes<L> {
        let like = rgb.z;
        let (two, one) = (like.splat(2.0), like.splat(1.0));
        let n = V3::new(two * rgb.x - one, two * rgb.y - one, two * rgb.z - one);
        let wp = self.max_theta.clamp_lanes(n);
        let eps = like.splat(1e-6);
        let flat = wp.x.abs().lt(eps) & wp.y.abs().lt(eps);
        let z = V3::splat(like, 0.0, 0.0, 1.0);
        let facets = Candidates::new(
            self.geometry,
            V3::select(flat, z, wp),
            MicrofacetNormalMap::framed(self.geometry, self.tangent),
        );
        let cells = match self.ms_table {
            Some(t) if self.evaluation == Evaluation::Compensated => Some(t.cells(wp)),
            _ => None,
        };
        MnmLanes { wp, facets, cells }
    }

    /// [`Self::map_into`] for lane `i` of `lanes` ([`Self::lanes_at`], stored:
    /// [`MnmLanes::cols`]): the same map bit for bit as `map_into` with that lane's `rgb`.
    #[inline(always)]
    pub fn map_lane_into<const W: usize>(
        &self,
        slot: &mut MicrofacetNormalMap,
        nested: u32,
        lanes: &MnmCols<W>,
        i: usize,
    ) {
        let wp = lanes.wp(i);
        *slot = MicrofacetNormalMap::of_lane(
            nested,
            wp,
            &lanes.facets,
            i,
            self.geometry,
            self.tangent,
            self.evaluation,
            self.max_order,
        );
        self.options_into(slot);
        match &lanes.cells {
            Some(c) => slot.set_ms_table_in(self.ms_table, c.get(i)),
            None => slot.set_ms_table(self.ms_table),
        }
    }
}

/// What [`MnmSettings::lanes_at`] computes for several hits at once.
#[derive(Clone, Copy, Debug)]
pub struct MnmLanes<L: Lane> {
    /// The clamped perturbed normals.
    wp: V3<L>,
    /// Their microsurfaces' candidate facets (+z's where ωp is flat).
    facets: Candidates<L>,
    /// Their θp cells in the compensated model's table.
    cells: Option<ThetaCells<L>>,
}

impl<L: Lane> MnmLanes<L> {
    /// The lanes stored as arrays of `W` (the lane width), what
    /// [`MnmSettings::map_lane_into`] reads (plain numbers: the per-hit writes, which the
    /// compiler may keep out of the kernel's SIMD function, need no SIMD instruction).
    #[inline(always)]
    pub fn cols<const W: usize>(&self) -> MnmCols<W>
    where
        L: ToArray<f32, W>,
        L::I32: ToArray<i32, W>,
    {
        // A `match`, not `Option::map`: a closure may be compiled out of the kernel's SIMD
        // function (its stores become calls).
        #[allow(clippy::manual_map)]
        let cells = match &self.cells {
            Some(c) => Some(c.cols()),
            None => None,
        };
        MnmCols {
            wp: store3(self.wp),
            facets: self.facets.cols(),
            cells,
        }
    }
}

/// [`MnmLanes`] stored per lane (`[component][lane]`).
#[derive(Clone, Copy, Debug)]
pub struct MnmCols<const W: usize> {
    wp: [[f32; W]; 3],
    facets: FacetCols<W>,
    cells: Option<CellCols<W>>,
}

impl<const W: usize> MnmCols<W> {
    /// Lane `i`'s clamped perturbed normal.
    #[inline(always)]
    pub fn wp(&self, i: usize) -> Vec3 {
        Vec3::new(self.wp[0][i], self.wp[1][i], self.wp[2][i])
    }

    /// The clamped perturbed normals by component (`[component][lane]`): the flatness test
    /// of 8 lanes in one compare (`stream::kernels::mnm::point_bits`).
    #[inline(always)]
    pub fn wp_cols(&self) -> &[[f32; W]; 3] {
        &self.wp
    }

    /// The microsurfaces' candidate facets and frames, by lane.
    #[inline(always)]
    pub fn facets(&self) -> &FacetCols<W> {
        &self.facets
    }

    /// Whether lane `i`'s map ([`MnmSettings::map_lane_into`]) is not flat
    /// (`MicrofacetNormalMap::is_flat`), keeps its first two candidate facets and has a θp cell:
    /// over the mirror sawtooth of a compensated material with a table, a map with its mirror
    /// wall and its table reference (the stream kernel builds such points without the map,
    /// `compensated::lanes::Chunk::of_facets`).
    #[inline(always)]
    pub fn two_facets_with_cell(&self, i: usize) -> bool {
        !MicrofacetNormalMap::is_flat(self.wp(i)) && self.facets.keeps(2, i) && self.cells.is_some()
    }

    /// The θp cells in the compensated model's table, by lane (compensated, with a table).
    #[inline(always)]
    pub fn cells(&self) -> Option<&CellCols<W>> {
        self.cells.as_ref()
    }
}

#[derive(Clone, Debug)]
pub enum MaterialNode {
    Diffuse {
        reflectance: TexId,
    },
    /// A leaf BSDF whose parameters were fixed at load time except for textured colours:
    /// `template` is copied per hit and its `slots` overwritten with the texture values.
    Leaf {
        template: Box<BsdfNode>,
        slots: Vec<(Slot, TexId)>,
    },
    TwoSided {
        front: MatId,
        back: MatId,
    },
    /// Microfacet-based normal mapping of `nested` by the normal map `normalmap`
    /// (decoded as n = 2·rgb − 1 in the shading frame).
    MicrofacetNormalMap {
        nested: MatId,
        normalmap: TexId,
        settings: MnmSettings,
    },
    /// Classic normal mapping (Mitsuba 3's `normalmap`) of `nested` by `normalmap`.
    NormalMap {
        nested: MatId,
        normalmap: TexId,
        flip_invalid_normals: bool,
        use_shadowing_function: bool,
    },
    /// `blendbsdf`: `(1 − w)·bsdf0 + w·bsdf1`, w = `weight` (scalar texture, clamped to [0, 1]).
    Blend {
        weight: TexId,
        bsdf0: MatId,
        bsdf1: MatId,
    },
    /// `null`: straight pass-through.
    Null,
    /// `mask`: `nested` with probability `opacity` (scalar texture, clamped to [0, 1]), else
    /// pass-through.
    Mask {
        opacity: TexId,
        nested: MatId,
    },
    /// `bumpmap`: `nested` in the frame perturbed by the gradient of the height texture `height`
    /// (times `scale`); the same perturbed-BSDF flags as `NormalMap`.
    BumpMap {
        nested: MatId,
        height: TexId,
        scale: f32,
        flip_invalid_normals: bool,
        use_shadowing_function: bool,
    },
    /// `principled` or `principledthin` (one variant, boxed: `build` stays as small as it was).
    Principled(Box<PrincipledMaterial>),
}

/// A `principled` or `principledthin` material: `template` is copied per hit (into the arena's
/// side storage) with its `slots` overwritten by the texture values.
#[derive(Clone, Debug)]
pub enum PrincipledMaterial {
    Full {
        template: Principled,
        slots: Vec<(Slot, TexId)>,
    },
    Thin {
        template: PrincipledThin,
        /// It has the glossy transmission lobe (`spec_trans` given and not the constant 0).
        transmits: bool,
        slots: Vec<(Slot, TexId)>,
    },
}

/// All materials and textures of a scene.
#[derive(Clone, Debug, Default)]
pub struct Materials {
    nodes: Vec<MaterialNode>,
    pub textures: Vec<Texture>,
    /// The lobes each node can produce, fixed by the tree's structure and templates (the
    /// loader's checks ask for them; at a hit the arena has its own, by the same rule).
    lobes: Vec<Lobes>,
}

/// A `blendbsdf` weight's or a `mask` opacity's texture value as the BSDF takes it: clamped to
/// [0, 1], NaN read as 0.
#[inline]
pub(crate) fn unit_weight(w: f32) -> f32 {
    if w.is_nan() {
        0.0
    } else {
        w.clamp(0.0, 1.0)
    }
}

/// Write a texture value into the field `slot` of a leaf node.
fn patch(node: &mut BsdfNode, slot: Slot, v: Vec3) {
    match (node, slot) {
        (BsdfNode::Diffuse(d), Slot::Reflectance) => d.reflectance = v,
        (BsdfNode::Conductor(b), Slot::SpecularReflectance) => b.specular_reflectance = v,
        (BsdfNode::RoughConductor(b), Slot::SpecularReflectance) => b.specular_reflectance = v,
        (BsdfNode::Dielectric(b), Slot::SpecularReflectance) => b.specular_reflectance = v,
        (BsdfNode::Dielectric(b), Slot::SpecularTransmittance) => b.specular_transmittance = v,
        (BsdfNode::ThinDielectric(b), Slot::SpecularReflectance) => b.specular_reflectance = v,
        (BsdfNode::ThinDielectric(b), Slot::SpecularTransmittance) => b.specular_transmittance = v,
        (BsdfNode::RoughDielectric(b), Slot::SpecularReflectance) => b.specular_reflectance = v,
        (BsdfNode::RoughDielectric(b), Slot::SpecularTransmittance) => b.specular_transmittance = v,
        (BsdfNode::Plastic(b), Slot::SpecularReflectance) => b.specular_reflectance = v,
        (BsdfNode::Plastic(b), Slot::DiffuseReflectance) => b.diffuse_reflectance = v,
        (BsdfNode::RoughPlastic(b), Slot::SpecularReflectance) => b.specular_reflectance = v,
        (BsdfNode::RoughPlastic(b), Slot::DiffuseReflectance) => b.diffuse_reflectance = v,
        (BsdfNode::Hair(b), Slot::SigmaA) => b.sigma_a = v,
        // The instantiation only creates valid (node, slot) pairs.
        _ => {}
    }
}

/// Write a scalar texture value (a roughness) into the field `slot` of a leaf node; the
/// distribution clamps it to its minimum, as Mitsuba's does per hit.
fn patch_scalar(node: &mut BsdfNode, slot: Slot, a: f32) {
    let dist = match node {
        BsdfNode::RoughConductor(b) => &mut b.distribution,
        BsdfNode::RoughDielectric(b) => &mut b.distribution,
        // The instantiation only creates valid (node, slot) pairs.
        _ => return,
    };
    let (au, av) = match slot {
        Slot::Alpha => (a, a),
        Slot::AlphaU => (a, dist.alpha_v),
        Slot::AlphaV => (dist.alpha_u, a),
        _ => return,
    };
    *dist =
        crate::bsdf::MicrofacetDistribution::anisotropic(dist.kind, au, av, dist.sample_visible);
}

/// A node of the kind `n` builds, with `n`'s children as its children: what
/// [`BsdfNode::lobes`] needs to know (parameters do not change lobes).
fn skeleton(n: &MaterialNode) -> BsdfNode {
    match n {
        MaterialNode::Diffuse { .. } => BsdfNode::Diffuse(Diffuse {
            reflectance: Vec3::ZERO,
        }),
        MaterialNode::Leaf { template, .. } => **template,
        MaterialNode::TwoSided { front, back } => BsdfNode::TwoSided {
            front: *front,
            back: *back,
        },
        MaterialNode::MicrofacetNormalMap { nested, .. } => BsdfNode::MicrofacetNormalMap {
            map: 0,
            nested: *nested,
        },
        MaterialNode::NormalMap { nested, .. } | MaterialNode::BumpMap { nested, .. } => {
            BsdfNode::NormalMap(NormalMap::new(*nested, Vec3::Z, false, false))
        }
        MaterialNode::Blend { bsdf0, bsdf1, .. } => BsdfNode::Blend(Blend {
            bsdf0: *bsdf0,
            bsdf1: *bsdf1,
            weight: 0.0,
        }),
        MaterialNode::Null => BsdfNode::Null,
        MaterialNode::Principled(m) => match &**m {
            PrincipledMaterial::Full { template, .. } => BsdfNode::Principled {
                index: 0,
                lobes: Principled::lobes(template.has_spec_trans),
            },
            PrincipledMaterial::Thin { transmits, .. } => BsdfNode::PrincipledThin {
                index: 0,
                lobes: PrincipledThin::lobes(*transmits),
            },
        },
        MaterialNode::Mask { nested, .. } => BsdfNode::Mask(Mask {
            nested: *nested,
            opacity: 1.0,
        }),
    }
}

impl Materials {
    /// Number of material nodes (every [`MatId`] is below it).
    pub fn node_count(&self) -> usize {
        self.nodes.len()
    }

    pub fn add_texture(&mut self, t: Texture) -> TexId {
        self.textures.push(t);
        (self.textures.len() - 1) as TexId
    }

    /// Adds a node whose children (if any) were added before it.
    pub fn add_node(&mut self, n: MaterialNode) -> MatId {
        let lobes = skeleton(&n).lobes(|c| self.lobes[c as usize]);
        self.lobes.push(lobes);
        self.nodes.push(n);
        (self.nodes.len() - 1) as MatId
    }

    /// The nodes (a material's children come before it).
    pub fn nodes(&self) -> &[MaterialNode] {
        &self.nodes
    }

    /// Calls `f(texture, scalar)` for every texture material `id` evaluates at a hit (its own
    /// and its children's), `scalar` when it is read as a scalar (`eval_1`: roughness, weights,
    /// opacity, heights) rather than as a colour. Each material node is visited once (a node
    /// shared by several parents is one use), so the walk is linear in the nodes.
    pub fn texture_uses(&self, id: MatId, f: &mut impl FnMut(TexId, bool)) {
        let mut seen = vec![false; self.nodes.len()];
        let mut stack = vec![id];
        while let Some(id) = stack.pop() {
            let Some(s) = seen.get_mut(id as usize) else {
                continue;
            };
            if std::mem::replace(s, true) {
                continue;
            }
            let slot_uses = |slots: &[(Slot, TexId)], f: &mut dyn FnMut(TexId, bool)| {
                for &(slot, t) in slots {
                    f(t, slot.is_scalar());
                }
            };
            match &self.nodes[id as usize] {
                MaterialNode::Diffuse { reflectance } => f(*reflectance, false),
                MaterialNode::Leaf { slots, .. } => slot_uses(slots, f),
                MaterialNode::TwoSided { front, back } => stack.extend([*front, *back]),
                MaterialNode::MicrofacetNormalMap {
                    nested, normalmap, ..
                }
                | MaterialNode::NormalMap {
                    nested, normalmap, ..
                } => {
                    f(*normalmap, false);
                    stack.push(*nested);
                }
                MaterialNode::Blend {
                    weight,
                    bsdf0,
                    bsdf1,
                } => {
                    f(*weight, true);
                    stack.extend([*bsdf0, *bsdf1]);
                }
                MaterialNode::Null => {}
                MaterialNode::Mask { opacity, nested } => {
                    f(*opacity, true);
                    stack.push(*nested);
                }
                MaterialNode::BumpMap { nested, height, .. } => {
                    f(*height, true);
                    stack.push(*nested);
                }
                MaterialNode::Principled(m) => match &**m {
                    PrincipledMaterial::Full { slots, .. }
                    | PrincipledMaterial::Thin { slots, .. } => slot_uses(slots, f),
                },
            }
        }
    }

    /// The lobes material `id` can produce: [`crate::bsdf::Bsdf::lobes`] of any BSDF it builds.
    #[inline]
    pub fn lobes(&self, id: MatId) -> Lobes {
        self.lobes[id as usize]
    }

    /// Evaluate the textures of `slots` at `si` and hand each value to `patch` (colour slots as
    /// the colour, scalar slots as `eval_1`).
    fn patch_slots(
        &self,
        slots: &[(Slot, TexId)],
        at: impl Lookup,
        mut patch: impl FnMut(Slot, Vec3, f32),
    ) {
        for &(slot, tex) in slots {
            let t = &self.textures[tex as usize];
            if slot.is_scalar() {
                patch(slot, Vec3::ZERO, t.eval_1(at));
            } else {
                patch(slot, t.eval(at), 0.0);
            }
        }
    }

    /// [`Self::build`] of a principled material: its parameters go to the arena's side
    /// storage. Out of line so that `build` stays as small as it was for the other models.
    #[inline(never)]
    fn build_principled(
        &self,
        m: &PrincipledMaterial,
        at: impl Lookup,
        arena: &mut BsdfArena,
    ) -> u32 {
        match m {
            PrincipledMaterial::Full { template, slots } => {
                let mut b = *template;
                self.patch_slots(slots, at, |slot, v, s| b.patch(slot, v, s));
                arena.push_principled(b)
            }
            PrincipledMaterial::Thin {
                template,
                transmits,
                slots,
            } => {
                let mut b = *template;
                self.patch_slots(slots, at, |slot, v, s| b.patch(slot, v, s));
                arena.push_principled_thin(b, *transmits)
            }
        }
    }

    /// Overwrite the fields `slots` of the leaf `node` with their textures' values at `at`
    /// (colour slots with `eval`, scalar ones with `eval_1`), as a hit builds a
    /// `MaterialNode::Leaf` (the stream renderer's kernels patch their own copies per lane).
    #[inline]
    pub(crate) fn patch_leaf(&self, node: &mut BsdfNode, slots: &[(Slot, TexId)], at: impl Lookup) {
        for &(slot, tex) in slots {
            let t = &self.textures[tex as usize];
            if slot.is_scalar() {
                patch_scalar(node, slot, t.eval_1(at));
            } else {
                patch(node, slot, t.eval(at));
            }
        }
    }

    /// Build the BSDF of material `id` at `si` into `arena`, its textures looked up by `si.uv`
    /// (no mesh attributes); returns the root node index.
    pub fn build(&self, id: MatId, si: &SurfaceInteraction, arena: &mut BsdfArena) -> u32 {
        self.build_at(id, si, si.uv, arena)
    }

    /// [`Self::build`] with the textures looked up at `at` (the uv of `si`, and the hit mesh's
    /// data for `mesh_attribute`).
    pub fn build_at(
        &self,
        id: MatId,
        si: &SurfaceInteraction,
        at: impl Lookup,
        arena: &mut BsdfArena,
    ) -> u32 {
        let lobes = self.lobes[id as usize];
        match &self.nodes[id as usize] {
            MaterialNode::Diffuse { reflectance } => {
                let r = self.textures[*reflectance as usize].eval(at);
                arena.push_with_lobes(lobes, BsdfNode::Diffuse(Diffuse { reflectance: r }))
            }
            MaterialNode::Leaf { template, slots } => {
                // Copied once, into the arena, and patched there.
                let id = arena.push_with_lobes(lobes, **template);
                // A constant leaf (most of them) skips the call: `patch_leaf` is out of line.
                if !slots.is_empty() {
                    self.patch_leaf(arena.node_mut(id), slots, at);
                }
                id
            }
            MaterialNode::TwoSided { front, back } => {
                let f = self.build_at(*front, si, at, arena);
                let b = if front == back {
                    f
                } else {
                    self.build_at(*back, si, at, arena)
                };
                arena.push_with_lobes(lobes, BsdfNode::TwoSided { front: f, back: b })
            }
            MaterialNode::MicrofacetNormalMap {
                nested,
                normalmap,
                settings,
            } => {
                let child = self.build_at(*nested, si, at, arena);
                let rgb = self.textures[*normalmap as usize].eval(at);
                let wi = si.sh.to_local(si.wi);
                arena.push_microfacet_normal_map_with(child, |m| {
                    settings.map_into(m, child, rgb);
                    m.set_incident(wi);
                })
            }
            MaterialNode::NormalMap {
                nested,
                normalmap,
                flip_invalid_normals,
                use_shadowing_function,
            } => {
                let child = self.build_at(*nested, si, at, arena);
                let rgb = self.textures[*normalmap as usize].eval(at);
                arena.push_with_lobes(
                    lobes,
                    BsdfNode::NormalMap(NormalMap::new(
                        child,
                        2.0 * rgb - Vec3::ONE,
                        *flip_invalid_normals,
                        *use_shadowing_function,
                    )),
                )
            }
            MaterialNode::Blend {
                weight,
                bsdf0,
                bsdf1,
            } => {
                let a = self.build_at(*bsdf0, si, at, arena);
                let b = self.build_at(*bsdf1, si, at, arena);
                let w = self.textures[*weight as usize].eval_1(at);
                arena.push_with_lobes(
                    lobes,
                    BsdfNode::Blend(Blend {
                        bsdf0: a,
                        bsdf1: b,
                        weight: unit_weight(w),
                    }),
                )
            }
            MaterialNode::Null => arena.push_with_lobes(lobes, BsdfNode::Null),
            MaterialNode::Principled(m) => self.build_principled(m, at, arena),
            MaterialNode::Mask { opacity, nested } => {
                let child = self.build_at(*nested, si, at, arena);
                let o = self.textures[*opacity as usize].eval_1(at);
                arena.push_with_lobes(
                    lobes,
                    BsdfNode::Mask(Mask {
                        nested: child,
                        opacity: unit_weight(o),
                    }),
                )
            }
            MaterialNode::BumpMap {
                nested,
                height,
                scale,
                flip_invalid_normals,
                use_shadowing_function,
            } => {
                let child = self.build_at(*nested, si, at, arena);
                let grad = *scale * self.textures[*height as usize].eval_1_grad(si.uv);
                arena.push_with_lobes(
                    lobes,
                    BsdfNode::NormalMap(NormalMap::new(
                        child,
                        bumpmap::perturbed_normal(si, grad),
                        *flip_invalid_normals,
                        *use_shadowing_function,
                    )),
                )
            }
        }
    }
}
