//! The stream renderer's kernel for the compensated microfacet normal map (issues 17 and 18):
//! a material whose root is a microfacet `normalmap` with `evaluation = compensated` and a
//! remainder table (what `--normal-mapping compensated` makes of a scene's normal maps) over a
//! leaf BSDF, or (since the thirty-ninth session) one with the random walk or a closed form
//! and no table (`walk-same`, `walk-mirror`, `explicit`, `explicit4` among them: no map of
//! these is a compensated point, so steps 3 and 4 below evaluate and sample each lane's BSDF
//! lane by lane, the scalar model with each path's stream, while the build, the light sample
//! and the rays run in lanes), 8 paths at a time (a run's last 2–7 paths as one padded chunk,
//! as the other kernels take them: `vertex::x8::Chunks`), in the steps of the wrapper-chain
//! driver ([`super::vertex`]):
//! 1. the surface interactions gathered into SoA columns;
//! 2. the BSDFs built at the hits, into one arena for the 8 points: where the chunk's nested
//!    leaf is constant ([`shared_nested`]), [`build_shared`] (the leaf pushed once; the
//!    perturbed normals, candidate facets, facet frames and table cells 8-wide; then over the
//!    mirror sawtooth with a `roughconductor` or `roughplastic` leaf ([`lane_points`]) no map
//!    for a hit that is not flat: its numbers stay in the build's columns, which become the
//!    chunk's (`compensated::lanes::Chunk::of_facets`); each other point's map written from
//!    them), else lane by lane `Scene::bsdf_root` (the scalar code); for the random walk over
//!    a shared reflecting rough leaf ([`mapless_bits`], forty-second session) no map for a lane
//!    that is not flat and is seen from above: its view of the columns
//!    (`bsdf::mnm::map_view::ColMap`, [`views_of`]) stands for the map in steps 3 and 4;
//!    then the side test (as bits for the points built without maps, else lane by lane), the
//!    light selection and light point through the shared gather
//!    ([`super::light::x8::Gather`]: area lights 8-wide);
//!    then the chunk's compensated points and their state at ωi, once for steps 3 and 4
//!    (`compensated::lanes::Chunk`: the table lookups at ωi 8-wide, over the mirror sawtooth
//!    the entries in lanes; a built map that is no such point gets its ωi cache instead,
//!    `compensated::lanes::with_incident_alone_x8`);
//! 3. the BSDF value and density toward each light point: where the chunk's nested leaf has no
//!    textured parameter ([`shared_nested`]), the 8 points together through
//!    `bsdf::mnm::compensated::lanes` (the first orders' nested pairs of all points in full
//!    8-wide calls, the remainder's table lookups with their coordinates 8-wide), else lane by
//!    lane (the scalar model; for the random walk over a shared `roughconductor` or
//!    `roughplastic` leaf the MIS density's nested pairs of all lanes first in 8-wide calls,
//!    `bsdf::mnm::walk_pdf_lanes`, which each lane's walk then takes); then 8-wide: the power
//!    heuristic, the contribution and the shadow ray ([`super::diffuse::light_out`]);
//! 4. the BSDF samples (the same split: over the mirror sawtooth the points' draws 8-wide,
//!    masked PCG32 steps on their streams, else lane by lane; their first orders and
//!    remainders together; the lanes whose sample is the reflection walk over a shared rough
//!    leaf in one masked 8-lane walk, `compensated::lanes::sample_walks_x8`, and those whose
//!    sample is the two-sided walk over a shared rough dielectric in another, since the
//!    fortieth session), then lane by lane the next ray; each lane's light and BSDF samples
//!    go to the integrator's [`super::tail::Tail`] (`PathState::advance` for `path`, rays to
//!    trace for `direct`).
//!
//! Over the mirror sawtooth the first orders of steps 3 and 4 run in lanes too
//! (`compensated::lanes`' `first`), from the chunk's columns built once for both steps (there
//! from the build's columns as they are: no per-point map, issue 18, seventeenth session).
//! Every number is the scalar model's bit for bit
//! (`compensated::lanes`' tests), so the image is the scalar renderer's (`docs/mnm.md`, "Issues
//! 17/18: the compensated model in lanes (tenth session)" and "... the compensated build and
//! sampler in lanes (eleventh session)").

use crate::bsdf::mnm::compensated::lanes::Cols;
#[cfg(target_arch = "x86_64")]
use crate::bsdf::mnm::compensated::lanes::WalkGroups;
use crate::bsdf::mnm::facets::Microgeometry;
use crate::bsdf::mnm::map_view::ColMap;
use crate::bsdf::mnm::{Evaluation, Tangent};
use crate::bsdf::{BsdfArena, BsdfNode};
use crate::lane::vec::V3;
use crate::lane::{Lane, ToArray};
use crate::material::{MatId, MaterialNode, Materials, MnmCols, MnmSettings};
use crate::scene::Scene;
use crate::texture::Texture;
use glam::Vec3;

/// Whether material `m` is shaded by this kernel: a microfacet `normalmap` with `evaluation =
/// compensated` and its table, or with the random walk or a closed form and no table, directly
/// over a leaf BSDF (`diffuse` or a leaf with constant or textured parameters). Not `auto`
/// (per point the compensated model, the walk or their blend).
pub(crate) fn qualifies(materials: &Materials, m: MatId) -> bool {
    let nodes = materials.nodes();
    match &nodes[m as usize] {
        MaterialNode::MicrofacetNormalMap {
            nested, settings, ..
        } => {
            let model = match settings.evaluation {
                // The compensated model: its points in lanes (`compensated::lanes`).
                Evaluation::Compensated => settings.ms_table.is_some(),
                // The closed forms and the random walk, without a table (so no map is a
                // compensated point): the kernel's build, light and ray steps in lanes, the
                // BSDF's eval and sample lane by lane (the scalar model, each path's stream).
                Evaluation::Explicit | Evaluation::ExplicitComplete | Evaluation::RandomWalk => {
                    settings.ms_table.is_none()
                }
                // Per point the compensated model or the walk: not through this kernel.
                Evaluation::Auto => false,
            };
            model
                && matches!(
                    nodes[*nested as usize],
                    MaterialNode::Leaf { .. } | MaterialNode::Diffuse { .. }
                )
        }
        _ => false,
    }
}

/// Whether every hit of material `m` (one that [`qualifies`]) builds its nested BSDF with the
/// same parameters bit for bit: a leaf without textured parameters (its template copied as
/// is). Then the compensated model's first order may evaluate the nested BSDF of 8 hits in
/// shared 8-wide calls (`bsdf::mnm::compensated::lanes`).
pub(crate) fn shared_nested(materials: &Materials, m: MatId) -> bool {
    let nodes = materials.nodes();
    match &nodes[m as usize] {
        MaterialNode::MicrofacetNormalMap { nested, .. } => {
            matches!(&nodes[*nested as usize], MaterialNode::Leaf { slots, .. } if slots.is_empty())
        }
        _ => false,
    }
}

/// What [`build_shared`] built for a chunk.
pub(crate) struct Built {
    /// Each lane's BSDF root: its map, or for a point built without one (bit k of `points`)
    /// the nested leaf (the map's lobes; its queries go through the chunk, only its side test
    /// and frames through the root).
    pub roots: [u32; 8],
    /// The hits' ωi in the shading frame (as `Materials::build_at` computes it), where the
    /// points are built with their maps (else `+z`: nothing reads them).
    pub wi: [Vec3; 8],
    /// The nested leaf's node, shared by the chunk's maps and points.
    pub child: u32,
    /// Bit k: lane k is a point over the mirror sawtooth built without its map
    /// ([`lane_points`]).
    pub points: u8,
}

/// The arithmetic of the maps of material `m` (a microfacet `normalmap`) at 8 hits, from the
/// normal map texture's values `rgb` there (looked up by the caller, [`normal_texture`]):
/// `MnmSettings::lanes_at` (perturbed normals, microsurfaces, facet frames, θp cells) at the
/// width of `L`, stored by lane. Returned straight into the caller's slot (the ~2 KB columns
/// are not moved again: [`build_shared`] and `Chunk::of_facets` read them in place).
#[inline(always)]
pub(crate) fn build_lanes<L>(scene: &Scene, m: MatId, rgb: V3<L>) -> Option<MnmCols<8>>
where
    L: Lane + ToArray<f32, 8>,
    L::I32: ToArray<i32, 8>,
{
    match &scene.materials.nodes()[m as usize] {
        MaterialNode::MicrofacetNormalMap { settings, .. } => {
            Some(settings.lanes_at(rgb).cols::<8>())
        }
        _ => None,
    }
}

/// Builds the BSDFs of the 8 hits of material `m` (one that [`qualifies`] and
/// [`shared_nested`]) into `arena`: the leaf once for the chunk (a constant template: every
/// hit's copy would be the same bit for bit); then, from the maps' arithmetic for the 8 lanes
/// together (`lanes`, [`build_lanes`]), where the material's points are built without their
/// maps (`points`, [`lane_points`]) every hit whose ωp is not flat is such a point (its
/// numbers stay in `lanes`, for `Chunk::of_facets`), and each other hit's map is written
/// (`MnmSettings::map_lane_into`: `map_into`'s map bit for bit), as `Materials::build_at`
/// builds it but without the incident-direction cache (which
/// `compensated::lanes::with_incident_alone_x8` adds where the scalar model answers). `wi`: the
/// hits' ωi in the shading frame by component (`SurfaceBsdf::new`'s `frame.to_local(wi)`,
/// computed 8-wide by the caller: `diffuse::incident`). `cols`: the caller's token, for the
/// points' tests 8-wide ([`point_bits`]). `mapless` (bit k: lane k, [`mapless_bits`]): the
/// walking lanes built without a map (their root is the nested leaf; their views of `lanes`,
/// [`views_of`], stand for their maps in steps 3 and 4).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn build_shared(
    cols: Cols,
    scene: &Scene,
    m: MatId,
    wi: &[[f32; 8]; 3],
    lanes: &MnmCols<8>,
    points: bool,
    mapless: u8,
    arena: &mut BsdfArena,
) -> Option<Built> {
    let materials = &scene.materials;
    let (settings, nested, template) = map_leaf(materials, m)?;
    let child = arena.push_with_lobes(materials.lobes(nested), *template);
    // The points: not flat (`MicrofacetNormalMap::is_flat`, the map's `degenerate`), both
    // facets kept (the map's `mirror_wall`), with a table cell (`two_facets_with_cell` of each
    // lane, as bits).
    let pts = match (points, lanes.cells()) {
        (true, Some(_)) => point_bits(cols, lanes),
        _ => 0,
    };
    let mut b = Built {
        roots: [child; 8],
        wi: [Vec3::Z; 8],
        child,
        points: pts,
    };
    // Each other lane's map, in lane order. The ωi rows only where the maps answer their own
    // queries (`with_incident_alone_x8` reads them; no point is built without its map).
    let mut rest = !pts & !mapless;
    while rest != 0 {
        let k = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        b.roots[k] = arena.push_microfacet_normal_map_with(child, |m| {
            settings.map_lane_into(m, child, lanes, k);
        });
    }
    if !points {
        for (k, w) in b.wi.iter_mut().enumerate() {
            *w = Vec3::new(wi[0][k], wi[1][k], wi[2][k]);
        }
    }
    Some(b)
}

/// The lanes of material `m` (one that [`qualifies`] and [`shared_nested`]) that the kernel
/// builds without their maps (issue 18, forty-second session), as bits: where the material
/// walks by reflection (`Evaluation::RandomWalk`, no table) over a `roughconductor` or
/// `roughplastic` leaf that does not transmit (no Lambert form: not diffuse), every lane
/// that is not flat (`MicrofacetNormalMap::is_flat` of the columns' ωp, as [`point_bits`]
/// tests it) and whose ωi (`wi_z`, the shading frame's, `SurfaceBsdf`'s bits) is above the
/// surface. Every query of such a lane reaches the masked walks, which read its view of the
/// columns ([`views_of`]) instead of a map: the light sample's (`WalkEvals::push_view`,
/// `walk_x8`; ωo below the surface is the scalar query's (0, 0), no draw) and the BSDF
/// sample's (`sample_walks_x8`, the reflection walk: `mnm::walk_alone` of its map holds). A
/// flat lane, a lane seen from below and every lane of another material keep their maps.
#[inline(always)]
pub(crate) fn mapless_bits(
    cols: Cols,
    materials: &Materials,
    m: MatId,
    lanes: &MnmCols<8>,
    wi_z: &[f32; 8],
) -> u8 {
    let walks = map_leaf(materials, m).is_some_and(|(settings, nested, template)| {
        settings.evaluation == Evaluation::RandomWalk
            && settings.ms_table.is_none()
            && rough_reflector(materials, nested, template)
    });
    if !walks {
        return 0;
    }
    cols.run(
        #[inline(always)]
        |cols| {
            let flat = flat_bits(cols, lanes);
            let mut above = 0u8;
            for (k, z) in wi_z.iter().enumerate() {
                above |= u8::from(*z > 0.0) << k;
            }
            above & !flat
        },
    )
}

/// The views of the lanes `bits` of `lanes` (material `m`'s build columns, [`mapless_bits`])
/// that stand for their maps: `ColMap::of_lane` with the material's settings, the numbers of
/// `MnmSettings::map_lane_into`'s map (`map_view`).
#[inline(always)]
pub(crate) fn views_of<'c>(
    materials: &Materials,
    m: MatId,
    lanes: &'c MnmCols<8>,
    bits: u8,
) -> [Option<ColMap<'c>>; 8] {
    let mut v = [None; 8];
    let MaterialNode::MicrofacetNormalMap { settings, .. } = &materials.nodes()[m as usize] else {
        return v;
    };
    let mut rest = bits;
    while rest != 0 {
        let k = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        v[k] = Some(ColMap::of_lane(
            lanes.facets(),
            k,
            lanes.wp(k),
            settings.geometry,
            settings.tangent,
            settings.max_order,
        ));
    }
    v
}

/// The lanes of `lanes` that are not flat and keep their first two candidate facets, as bits
/// (bit k: lane k): `MnmCols::two_facets_with_cell` of each lane of columns with cells,
/// without a branch per lane.
///
/// The flatness test (`MicrofacetNormalMap::is_flat`: |x| and |y| of ωp below
/// [`FLAT`](crate::bsdf::mnm::FLAT)) and the facets' as one compare per column, 8-wide
/// where `cols` is (lane by lane otherwise: the same bits).
#[inline(always)]
pub(crate) fn point_bits(cols: Cols, lanes: &MnmCols<8>) -> u8 {
    cols.run(
        #[inline(always)]
        |cols| lanes.facets().keeps_bits8(cols, 2) & !flat_bits(cols, lanes),
    )
}

/// The lanes of `lanes` whose ωp is flat (`MicrofacetNormalMap::is_flat`: |x| and |y| below
/// [`FLAT`](crate::bsdf::mnm::FLAT)), as bits, one compare per column ([`point_bits`] and
/// [`mapless_bits`]; call inside [`Cols::run`]).
#[inline(always)]
fn flat_bits(cols: Cols, lanes: &MnmCols<8>) -> u8 {
    use crate::bsdf::mnm::FLAT;
    let wp = lanes.wp_cols();
    cols.abs_lt_bits(&wp[0], FLAT) & cols.abs_lt_bits(&wp[1], FLAT)
}

/// Material `m`'s leaf under its microfacet normal map: the map's settings, the nested
/// node and its template (`None`: not a map directly over a `Leaf`). The kernel's gates on
/// the leaf ([`build_shared`], [`mapless_bits`], [`lane_points`]) read it here.
#[inline(always)]
fn map_leaf(materials: &Materials, m: MatId) -> Option<(&MnmSettings, u32, &BsdfNode)> {
    let nodes = materials.nodes();
    let MaterialNode::MicrofacetNormalMap {
        nested, settings, ..
    } = &nodes[m as usize]
    else {
        return None;
    };
    let MaterialNode::Leaf { template, .. } = &nodes[*nested as usize] else {
        return None;
    };
    Some((settings, *nested, &**template))
}

/// Whether leaf `template` (node `nested` of `materials`) reflects only and has a lane form
/// without a Lambert closed form: `roughconductor` or `roughplastic` that does not transmit
/// (the leaf over which the walk's lanes go without maps, [`mapless_bits`], and the
/// compensated points without maps, [`lane_points`]).
#[inline(always)]
fn rough_reflector(materials: &Materials, nested: u32, template: &BsdfNode) -> bool {
    matches!(
        template,
        BsdfNode::RoughConductor(_) | BsdfNode::RoughPlastic(_)
    ) && !materials.lobes(nested).has_transmission()
}

/// Whether the points of material `m` (one that [`qualifies`] and [`shared_nested`]) are built
/// without their maps where they can be (`compensated::lanes::Chunk::of_facets`, issue 18):
/// the compensated model over the mirror sawtooth, a nested leaf with a lane form that
/// neither transmits nor has a Lambert closed form (`roughconductor`, `roughplastic`), so that
/// every hit that is not flat is the compensated model alone (`mnm::compensated_alone`) over
/// the mirror sawtooth.
pub(crate) fn lane_points(materials: &Materials, m: MatId) -> bool {
    map_leaf(materials, m).is_some_and(|(settings, nested, template)| {
        settings.evaluation == Evaluation::Compensated
            && settings.geometry == Microgeometry::Sawtooth
            && settings.tangent == Tangent::Mirror
            && rough_reflector(materials, nested, template)
    })
}

/// The evaluation of material `m` (one that [`qualifies`]: a microfacet `normalmap`; `None`
/// for another node), the one gate the kernel asks of a chunk's material:
/// - `Evaluation::Compensated` (with its table): only then can a map be a compensated point
///   (`mnm::compensated_alone` needs the map's table reference, which only this evaluation
///   sets) or want an ωi cache (`set_incident` caches for the table only); for the random walk
///   and the closed forms the kernel skips the compensated machinery (the points' search, the
///   chunk's state at ωi, its empty light query, the maps' ωi caches), which would find
///   nothing;
/// - `Evaluation::RandomWalk` (`walk-same`, `walk-mirror`): step 3 takes the walk's
///   light-sample queries over a shared nested leaf with a lane form through
///   `bsdf::mnm::walk_pdf_lanes` (their MIS density's nested pairs 8-wide before the walks),
///   and step 4 walks its lanes' samples masked (the reflection walk, `mnm::walk_alone`, needs
///   a walking evaluation and no table; a closed form's two-sided walk over a transmitting
///   leaf stays lane by lane, as before).
pub(crate) fn evaluation(materials: &Materials, m: MatId) -> Option<Evaluation> {
    match &materials.nodes()[m as usize] {
        MaterialNode::MicrofacetNormalMap { settings, .. } => Some(settings.evaluation),
        _ => None,
    }
}

/// Which of the masked walk groups (`compensated::lanes::sample_walks_x8`) the lanes of
/// material `m` (one that [`qualifies`] and walks) may take: every lane's map is built over a
/// nested node of the material's `nested` (the shared leaf, or its own copy by
/// `Materials::build_at`), whose lobes are the material table's (`Materials::lobes`, pushed
/// with the node), so a lane transmits exactly where the material's nested node does: the
/// two-sided walk's lanes and the reflection walk's never share a chunk, and the kernel asks
/// for the one group that can apply instead of scanning the lanes for both.
#[cfg(target_arch = "x86_64")]
pub(crate) fn walk_groups(materials: &Materials, m: MatId) -> WalkGroups {
    let nested = match &materials.nodes()[m as usize] {
        MaterialNode::MicrofacetNormalMap { nested, .. } => *nested,
        _ => m,
    };
    WalkGroups::of_lobes(materials.lobes(nested))
}

/// The remainder table of material `m` (a microfacet `normalmap` with one).
pub(crate) fn ms_table(
    scene: &Scene,
    m: MatId,
) -> Option<&'static crate::bsdf::mnm::ms_table::MsTable> {
    match &scene.materials.nodes()[m as usize] {
        MaterialNode::MicrofacetNormalMap { settings, .. } => settings.ms_table,
        _ => None,
    }
}

/// The normal map texture of material `m` (a microfacet `normalmap`).
pub(crate) fn normal_texture(scene: &Scene, m: MatId) -> Option<&Texture> {
    match &scene.materials.nodes()[m as usize] {
        MaterialNode::MicrofacetNormalMap { normalmap, .. } => {
            Some(&scene.materials.textures[*normalmap as usize])
        }
        _ => None,
    }
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod x8 {
    use crate::bsdf::mnm::compensated::lanes::{
        eval_pdf_x8_into, sample_walks_x8, sample_x8_cols, two_sided_evals_x8,
        with_incident_alone_x8, BuiltFacets, Chunk, Cols, Point, TwoSidedEvals, WalkSamples,
    };
    use crate::bsdf::mnm::walk_pdf_lanes::{WalkEvals, WalkEvalsBuf};
    use crate::bsdf::mnm::Evaluation;
    use crate::bsdf::{BsdfArena, BsdfContext, Lobes, SurfaceBsdf};
    use crate::geometry::{Ray, SurfaceInteraction};
    use crate::integrator::{PathSettings, Strategy};
    use crate::lane::vec::V3;
    use crate::lane::{Avx2, F32x8, Lane};
    use crate::scene::Scene;
    use crate::stream::batch::Batch;
    use crate::stream::kernels::diffuse::light_out;
    use crate::stream::kernels::diffuse::reflectance;
    use crate::stream::kernels::draws::{x8::draw, Draws};
    use crate::stream::kernels::light::x8::{Cols3, Gather};
    use crate::stream::kernels::light::LaneLight;
    use crate::stream::kernels::ray::offset_origin;
    use crate::stream::kernels::tail::{Sampled, Tail};
    use crate::texture::Texture;
    use glam::Vec3;

    /// The fewest lanes of a chunk that walk together ([`sample_walks_x8`]); fewer walk lane by
    /// lane.
    const WALK_MIN: u32 = 1;

    /// The normal map texture's values at the hits of the 8 paths `ids` (material `m`), as
    /// `Materials::build_at` looks it up (`Texture::eval` at the hit's uv, or its mesh data):
    /// a bitmap at the 8 uvs at once (gathered from the batch's rows,
    /// `surface::x8::uv`; `BitmapTexture::eval_x8`, bit for bit `eval`), another texture lane
    /// by lane.
    #[inline(always)]
    fn normal_rgb(
        avx: Avx2,
        scene: &Scene,
        m: crate::material::MatId,
        b: &Batch,
        ids: &[u32; 8],
    ) -> V3<F32x8> {
        let zero = avx.splat(0.0);
        let Some(tex) = super::normal_texture(scene, m) else {
            return V3::new(zero, zero, zero);
        };
        if let Texture::Bitmap(bt) = tex {
            bt.eval_x8(
                avx,
                crate::stream::kernels::surface::x8::uv(avx, &b.surf, ids),
            )
        } else {
            let mut rgb = Cols3::default();
            for (k, &i) in ids.iter().enumerate() {
                rgb.set(k, reflectance(scene, tex, &b.surf.get(i as usize)));
            }
            rgb.load(avx)
        }
    }

    /// Shades the paths `ids` (all at a surface of material `m0`, one that
    /// [`super::qualifies`]: the chunk is part of a run of the sorted paths) as
    /// `PathState::scatter` would, one after the other; hands each lane's light sample, then
    /// its BSDF sample, to `tail` (the integrator's end of the vertex). `arena` holds the 8
    /// points' BSDF trees (cleared here); `walk_evals` the random walk's light-sample arrays
    /// (`WalkEvals`, reset per chunk), kept by the caller across a run's chunks. The first `live` lanes are the chunk's paths; a
    /// padded chunk's other lanes (`vertex::x8::padded`: the last path's id again) are marked
    /// behind their surface, as `vertex::x8::live_only` does for the other kernels: they build
    /// their BSDFs (in the chunk's arena) but neither scatter, draw a number nor hand a sample
    /// to the tail, and the sampler's stores leave the lowest lane's state where an id repeats
    /// (`Avx2::store_u64_at`). Call inside [`Avx2::run`].
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn shade(
        avx: Avx2,
        scene: &Scene,
        cfg: &PathSettings,
        b: &mut Batch,
        m0: crate::material::MatId,
        ids: &[u32; 8],
        live: usize,
        lights: &[Option<LaneLight>],
        gather: &mut Gather,
        walk_evals: &mut WalkEvalsBuf,
        arena: &mut BsdfArena,
        tail: &mut impl Tail,
    ) {
        let ctx = BsdfContext::default();
        // The chunk's compensated points share their nested BSDF (one material, a constant
        // leaf: every chunk of a run): their first orders are evaluated together.
        let shared = super::shared_nested(&scene.materials, m0);
        // The compensated model's points, their state at ωi and the maps' ωi caches exist
        // only for its own evaluation (the walk and the closed forms have none: skipped).
        // The random walk's lanes (steps 3 and 4 take them in lanes, where their leaf allows).
        // One look at the material's evaluation for both gates.
        let evaluation = super::evaluation(&scene.materials, m0);
        let comp = evaluation == Some(Evaluation::Compensated);
        let walking = evaluation == Some(Evaluation::RandomWalk);
        // 1. The surfaces, loaded 8-wide from the batch's rows (the light stage's columns).
        let surf = crate::stream::kernels::surface::x8::load(avx, &b.surf, ids);

        // 2. The BSDFs: where the nested leaf is shared, the maps built here and their ωi
        //    caches 8-wide (`super::build_shared`, `with_incident_x8`), else by
        //    `Scene::bsdf_root`; then the side test and the light points, lane by lane in each
        //    path's order.
        arena.clear();
        // A lane's surface interaction is read from the batch's row only where the scalar
        // code needs it (a BSDF built by `Scene::bsdf_root`, a map or the nested leaf queried
        // through its `SurfaceBsdf`): the chunk's points read the 8-wide columns (`surf`,
        // the same rows).
        let si_at = |b: &Batch, k: usize| -> SurfaceInteraction { b.surf.get(ids[k] as usize) };
        let p = Cols3::store(surf.p);
        let lane_points = shared && super::lane_points(&scene.materials, m0);
        let lanes = match shared {
            true => super::build_lanes(scene, m0, normal_rgb(avx, scene, m0, b, ids)),
            false => None,
        };
        // The hits' ωi in the shading frame and `SurfaceBsdf::new`'s side test, 8-wide.
        let (wi_local, front) = crate::stream::kernels::diffuse::incident(&surf);
        // (A padded chunk's lanes from `live` on: behind their surface.)
        let live_bits = if live >= 8 {
            u8::MAX
        } else {
            (1u8 << live) - 1
        };
        let (wi_local, front) = (Cols3::store(wi_local), front.bits() as u8 & live_bits);
        // The walking lanes built without maps, and their views of the build's columns.
        let mapless = match &lanes {
            Some(l) if walking => {
                super::mapless_bits(Cols::of(avx), &scene.materials, m0, l, &wi_local.0[2])
            }
            _ => 0,
        };
        let views = match &lanes {
            Some(l) if mapless != 0 => super::views_of(&scene.materials, m0, l, mapless),
            _ => [None; 8],
        };
        let built = match &lanes {
            Some(l) => super::build_shared(
                Cols::of(avx),
                scene,
                m0,
                &wi_local.0,
                l,
                lane_points,
                mapless,
                arena,
            ),
            None => None,
        };
        let (roots, wi, points) = match &built {
            Some(bt) => (bt.roots, bt.wi, bt.points),
            None => ([u32::MAX; 8], [Vec3::Z; 8], 0),
        };
        // The other lanes' BSDFs (the scalar code), then where the maps answer their own
        // queries (no points built without maps) the built maps that are no chunk points (the
        // scalar model answers their queries) get their ωi caches: the arena is complete.
        let mut all = roots;
        if built.is_none() {
            for (k, r) in all.iter_mut().enumerate() {
                *r = scene.bsdf_root(&si_at(b, k), arena);
            }
        }
        if shared && !lane_points && comp {
            with_incident_alone_x8(arena, &roots, &wi);
        }
        let arena: &BsdfArena = arena;
        // The side test, then the light points, in each path's order; each lane's
        // `SurfaceBsdf` kept for steps 3 and 4, but a point built without its map (bit k of
        // `points`), whose queries all go through the chunk: its side test is `front`
        // (`SurfaceBsdf::new`'s, 8-wide) and its lobes the nested leaf's (its root), so those
        // lanes are settled as bits, together; the other lanes build their `SurfaceBsdf` one by
        // one. Bit k of `alive`: lane k scatters (it has a `SurfaceBsdf` or is such a point);
        // of `nee`: it takes a light sample (smooth lobes, a strategy with light samples).
        let mut sb: [Option<SurfaceBsdf>; 8] = [None; 8];
        let light_samples = cfg.strategy != Strategy::BsdfOnly;
        let mut alive = points & front;
        let mut nee = match &built {
            Some(bt) if light_samples && arena.bsdf(bt.child).lobes().is_smooth() => alive,
            _ => 0,
        };
        let mut rest = !points & live_bits;
        while rest != 0 {
            let k = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let si = si_at(b, k);
            let Some(bsdf) = SurfaceBsdf::new(arena.bsdf(all[k]), si.sh, si.ng, si.wi) else {
                continue; // as `PathState::scatter`: the path ends
            };
            sb[k] = Some(bsdf);
            alive |= 1 << k;
            nee |= u8::from(light_samples && bsdf.lobes().is_smooth()) << k;
        }
        // The scattering paths' throughputs; the light sample's points (the others 0).
        let mut tp = Cols3::default();
        for (k, &i) in ids.iter().enumerate() {
            let i = i as usize;
            if alive & (1 << k) != 0 {
                tp.set(k, b.state[i].throughput);
            }
        }
        let light_only = cfg.strategy == Strategy::LightOnly;
        gather.reset();
        let zero = avx.splat(0.0);
        let p8 = Cols3::store(V3::select(
            avx.mask_bits(u32::from(nee)),
            surf.p,
            V3::new(zero, zero, zero),
        ));
        // The light selection and light point numbers of the lanes that take a light sample,
        // 8-wide from their streams (`draws::x8::draw`: each stream's scalar order; every
        // lane's numbers come before its BSDF sample's, as in `PathState::scatter`).
        if nee != 0 {
            let light = Draws {
                light: true,
                u1: false,
                u2: false,
            };
            let on = crate::lane::bits::bools8(u32::from(nee));
            let n = draw(avx, &mut b.sampler, ids, &on, light);
            gather.add_x8(
                avx,
                scene,
                lights,
                light_only,
                u32::from(nee),
                &n.u_sel,
                &n.u,
                &p8,
            );
        }

        // The compensated model's points (where the nested leaf is shared) and their state
        // at ωi, once for steps 3 and 4 ([`Chunk`], 8-wide; built in place: a struct literal,
        // then its state at ωi): where the material's points are built without their maps
        // (`super::lane_points`), from the build's lanes (the other lanes' maps are flat:
        // the nested BSDF answers), else from the maps.
        // (Each chunk a struct literal straight into `chunk`, then filled in place.)
        let mut pts = [None; 8];
        if !lane_points && comp {
            for (k, bsdf) in sb.iter().enumerate() {
                match bsdf {
                    Some(bsdf) if shared => {
                        let (local, wi) = bsdf.local();
                        pts[k] = Point::of(local, wi);
                    }
                    _ => {}
                }
            }
        }
        let mut chunk = match (&lanes, lane_points) {
            (Some(l), true) => Chunk::of_facets(Cols::of(avx), l.facets()),
            // No point (the walk, a closed form): the empty chunk, from constants. (Not built
            // at all, as an `Option`, it cost the compensated mode a copy of its chunk
            // through a temporary: +14 a sample there for −15 on the walk modes.)
            _ if !comp => Chunk::of(Cols::of(avx), [None; 8]),
            _ => Chunk::of(Cols::of(avx), pts),
        };
        if let (Some(l), Some(bt), true) = (&lanes, &built, lane_points) {
            let on = alive & bt.points;
            if let (Some(cells), Some(table)) = (l.cells(), super::ms_table(scene, m0)) {
                chunk.set_lanes(arena.bsdf(bt.child), table, cells, on, &wi_local.0);
            }
        }
        if comp {
            chunk.prepare();
        }
        // Bit k: lane k is one of the chunk's points.
        let chunk_lanes = chunk.lanes();

        // The build's facet columns, where the maps were written from them (the lanes not
        // built as points without a map): the walks of steps 3 and 4 read them 8-wide instead
        // of each lane's map.
        let facets = match (&lanes, &built) {
            (Some(l), Some(bt)) => Some(BuiltFacets {
                facets: l.facets(),
                lanes: !bt.points,
                views: Some(&views),
            }),
            _ => None,
        };

        // 3. Next-event estimation: the light directions in the shading frame with
        //    `SurfaceBsdf::local_wo`'s side test 8-wide (the lanes' frames and true normals are
        //    their `SurfaceBsdf`'s, from the same rows; `Frame::to_local` is the lane form at
        //    width 1), the BSDF toward them lane by lane where a point was not one of the
        //    chunk's (as `nee::prepare_light`), the chunk's points together into the columns,
        //    the rest 8-wide.
        if nee != 0 {
            let lp = gather.finish(avx, scene, surf.p, &mut b.light_lanes);
            let zero = avx.splat(0.0);
            let local = surf.frame.to_local(lp.d);
            let side = (lp.d.dot(surf.ng) * local.z).gt(zero) & lp.some;
            let lwo = Cols3::store(local);
            let (mut f, mut pdf) = (Cols3::default(), [0.0f32; 8]);
            // Bits: the lanes toward their light point; those of the chunk's points (evaluated
            // together below, their directions in the columns as they are); the lanes whose
            // value is consistent (every one of the chunk's, the others where they have a
            // `SurfaceBsdf`, evaluated lane by lane).
            let toward = nee & side.bits() as u8;
            let lit = toward & chunk_lanes;
            let mut consistent = lit;
            let mut rest = toward & !lit;
            // The random walk's queries over the shared leaf: their MIS density's nested pairs
            // (the terms) of all lanes in 8-wide calls first (`WalkEvals`: the scalar
            // `walk_eval_pdf`'s numbers; it draws nothing), then their walks.
            let mut walks = match &built {
                Some(bt) if rest != 0 && walking => {
                    WalkEvals::new(arena.bsdf(bt.child), bt.child, walk_evals)
                }
                _ => None,
            };
            if let Some(w) = &mut walks {
                let mut r = rest;
                while r != 0 {
                    let k = r.trailing_zeros() as usize;
                    r &= r - 1;
                    if let Some(s) = &sb[k] {
                        let (local, wi) = s.local();
                        match &views[k] {
                            // A lane without a map: its view stands for it.
                            Some(v) => w.push_view(k, v, wi, lwo.get(k)),
                            None => w.push(k, local, wi, lwo.get(k)),
                        };
                    }
                }
                w.evaluate();
                // Their walks as one masked 8-lane walk (each lane on its own stream).
                w.walk_x8(avx, &mut b.sampler, ids, facets);
            }
            // The two-sided walk's queries over a shared rough dielectric (`mnm::eval_pdf`'s
            // transmitting branch: `walk::eval_t` and `mnm::pdf`) as one masked 8-lane walk,
            // each lane on its own stream (`two_sided_evals_x8`: the scalar query's bits).
            let two_sided = match &built {
                Some(bt)
                    if rest != 0 && walking && arena.bsdf(bt.child).lobes().has_transmission() =>
                {
                    let mut q = [None; 8];
                    let mut r = rest;
                    while r != 0 {
                        let k = r.trailing_zeros() as usize;
                        r &= r - 1;
                        if let Some(s) = &sb[k] {
                            let (local, wi) = s.local();
                            q[k] = Some((local, wi, lwo.get(k)));
                        }
                    }
                    two_sided_evals_x8(avx, &ctx, &q, &mut b.sampler, ids)
                }
                _ => TwoSidedEvals::none(),
            };
            while rest != 0 {
                let k = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                let i = ids[k];
                let Some(s) = &sb[k] else { continue };
                consistent |= 1 << k;
                let (local, wi) = s.local();
                let (fk, pk) = match &mut walks {
                    Some(w) if w.walked(k) => w.value(k),
                    Some(w) if w.has(k) => w.eval_pdf(k, &ctx, &mut b.sampler.at(i as usize)),
                    // A lane without a map not pushed: ωo below its surface, the scalar
                    // query's (0, 0) without a draw (`mnm::eval_pdf`).
                    _ if mapless & (1 << k) != 0 => (Vec3::ZERO, 0.0),
                    _ if two_sided.has(k) => two_sided.value(k),
                    _ => local.eval_pdf(&ctx, wi, lwo.get(k), &mut b.sampler.at(i as usize)),
                };
                f.set(k, fk);
                pdf[k] = pk;
            }
            if comp {
                eval_pdf_x8_into(&ctx, &chunk, lit, &lwo.0, &mut f.0, &mut pdf);
            }
            let lo = light_out(
                &surf,
                tp.load(avx),
                &lp,
                f.load(avx),
                avx.load(&pdf),
                avx.mask_bits(u32::from(consistent)),
            );
            let (ok, c) = (lo.ok.to_array(), Cols3::store(lo.contribution));
            // The shadow rays as whole rows (`RayRows::segment_rows`).
            let shadow =
                crate::stream::kernels::ray::RayRows::segment_rows(avx, lo.o, lo.d, lo.tmax);
            for (k, &i) in ids.iter().enumerate() {
                if nee & (1 << k) != 0 && ok[k] {
                    tail.light(b, i as usize, shadow[k], c.get(k));
                }
            }
        }

        // 4. The BSDF samples (the compensated model's points together, their first orders'
        //    nested evaluations 8-wide, in columns; the others lane by lane), then 8-wide the
        //    chunk points' world directions with `SurfaceBsdf::world_sample`'s side test and
        //    every sample's ray origin (`SurfaceInteraction::spawn_ray`'s `offset_origin`, the
        //    lane form: the same bits), then lane by lane the next rays to the tail (for
        //    `path`, `PathState::scatter`'s end).
        let sampled = sample_x8_cols(&ctx, &chunk, &mut b.sampler, ids);
        let local = Cols3(sampled.wo).load(avx);
        let world = surf.frame.to_world(local);
        let side = (world.dot(surf.ng) * local.z).gt(avx.splat(0.0));
        // Bit k: lane k has a sample (the chunk's points, every one alive: kept and on the
        // side of their ωo).
        let mut keep = sampled.ok & side.bits() as u8;
        let mut wo = Cols3::store(world);
        let (mut pdf, mut w, mut eta) = (sampled.pdf, Cols3(sampled.w), [1.0f32; 8]);
        let mut delta = [sampled.lobe.intersects(Lobes::DELTA); 8];
        // The lanes whose sample is the reflection walk over a shared rough leaf walk
        // together, masked 8-wide, and so do those whose sample is the two-sided walk over a
        // shared rough dielectric (`sample_walks_x8`: each lane's scalar sample bit for bit);
        // the others lane by lane. Only a material that evaluates by the walk has such lanes
        // (`mnm::walk_alone` and `walk_two_sided` ask for a walking evaluation and no table;
        // the compensated materials here have their table): the others skip the walks' lane
        // scan (~25 instructions a sample on the compensated mode). Of the two groups only
        // the one the material's nested leaf allows is looked for (`super::walk_groups`: a
        // reflecting leaf's lanes never walk two-sided, a transmitting leaf's never by
        // reflection), which skips the other group's scan of the lanes.
        // (The walks write their samples here: returned, they were copied out.)
        let mut walks = WalkSamples::none();
        if walking {
            let mut pts_local = [None; 8];
            for (k, s) in sb.iter().enumerate() {
                if chunk_lanes & (1 << k) == 0 {
                    pts_local[k] = s.as_ref().map(|s| s.local());
                }
            }
            let groups = super::walk_groups(&scene.materials, m0);
            sample_walks_x8(
                avx,
                &ctx,
                &pts_local,
                &mut b.sampler,
                ids,
                WALK_MIN,
                groups,
                facets,
                walk_evals,
                &mut walks,
            );
        }
        let mut rest = walks.lanes;
        while rest != 0 {
            let k = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let (Some(s), Some(bs)) = (&sb[k], walks.out[k]) else {
                continue;
            };
            if let Some(bs) = s.world_sample(bs) {
                wo.set(k, bs.wo);
                (pdf[k], eta[k], delta[k]) = (bs.pdf, bs.eta, bs.lobe.intersects(Lobes::DELTA));
                w.set(k, bs.weight);
                keep |= 1 << k;
            }
        }
        let mut rest = !chunk_lanes & !walks.lanes;
        while rest != 0 {
            let k = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let i = ids[k];
            let Some(s) = &sb[k] else { continue };
            if let Some(bs) = s.sample(&ctx, &mut b.sampler.at(i as usize)) {
                wo.set(k, bs.wo);
                (pdf[k], eta[k], delta[k]) = (bs.pdf, bs.eta, bs.lobe.intersects(Lobes::DELTA));
                w.set(k, bs.weight);
                keep |= 1 << k;
            }
        }
        let origin = Cols3::store(offset_origin(surf.p, surf.ng, wo.load(avx)));
        let mut rest = keep;
        while rest != 0 {
            let k = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            let i = ids[k];
            // `PathState::advance_sampled`'s arguments, for the tail.
            let s = Sampled {
                p: p.get(k),
                ray: Ray::new(origin.get(k), wo.get(k)),
                weight: w.get(k),
                eta: eta[k],
                pdf: pdf[k],
                delta: delta[k],
            };
            tail.bsdf(b, i as usize, &s);
        }
    }
}
