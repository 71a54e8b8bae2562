//! The stream renderer's kernel for the compensated microfacet normal map (issues 17 and 18):
//! a material whose root is a microfacet `normalmap` with `evaluation = compensated` and a
//! remainder table (what `--normal-mapping compensated` makes of a scene's normal maps) over a
//! leaf BSDF, 8 paths at a time, in the steps of the wrapper-chain driver ([`super::vertex`]):
//! 1. the surface interactions gathered into SoA columns;
//! 2. the BSDFs built at the hits, into one arena for the 8 points: where the chunk's nested
//!    leaf is constant ([`shared_nested`]), [`build_shared`] (the leaf pushed once; the
//!    perturbed normals, candidate facets, facet frames and table cells 8-wide, then each
//!    point's map written from them), else lane by lane `Scene::bsdf_root` (the scalar code);
//!    then lane by lane, in each path's order, the side test, the light selection and light
//!    point through the shared gather ([`super::light::x8::Gather`]: area lights 8-wide);
//!    then the chunk's compensated points and their state at ωi, once for steps 3 and 4
//!    (`compensated::lanes::Chunk`: the table lookups at ωi 8-wide, over the mirror sawtooth
//!    the entries in lanes; a built map that is no such point gets its ωi cache instead,
//!    `compensated::lanes::with_incident_alone_x8`);
//! 3. the BSDF value and density toward each light point: where the chunk's nested leaf has no
//!    textured parameter ([`shared_nested`]), the 8 points together through
//!    `bsdf::mnm::compensated::lanes` (the first orders' nested pairs of all points in full
//!    8-wide calls, the remainder's table lookups with their coordinates 8-wide), else lane by
//!    lane (the scalar model); then 8-wide: the power heuristic, the contribution and the
//!    shadow ray ([`super::diffuse::light_out`]);
//! 4. the BSDF samples (the same split: the points' draws lane by lane, their first orders and
//!    remainders together), then lane by lane the next ray; each lane's light and BSDF samples
//!    go to the integrator's [`super::tail::Tail`] (`PathState::advance` for `path`, rays to
//!    trace for `direct`).
//!
//! Over the mirror sawtooth the first orders of steps 3 and 4 run in lanes too
//! (`compensated::lanes`' `first`), from the chunk's columns built once for both steps. The
//! per-hit build's per-point write (facet compaction, the map itself) and the draws still run
//! per lane through the scalar code; every number
//! is the scalar model's bit for bit
//! (`compensated::lanes`' tests), so the image is the scalar renderer's (`docs/mnm.md`, "Issues
//! 17/18: the compensated model in lanes (tenth session)" and "... the compensated build and
//! sampler in lanes (eleventh session)").

use crate::bsdf::mnm::Evaluation;
use crate::bsdf::BsdfArena;
use crate::geometry::SurfaceInteraction;
use crate::lane::vec::V3;
use crate::lane::{Lane, ToArray};
use crate::material::{MatId, MaterialNode, Materials};
use crate::scene::Scene;
use crate::texture::Texture;
use glam::Vec3;

/// Whether material `m` is shaded by this kernel: a microfacet `normalmap` with `evaluation =
/// compensated` and its table, directly over a leaf BSDF (`diffuse` or a leaf with constant
/// or textured parameters).
pub(crate) fn qualifies(materials: &Materials, m: MatId) -> bool {
    let nodes = materials.nodes();
    match &nodes[m as usize] {
        MaterialNode::MicrofacetNormalMap {
            nested, settings, ..
        } => {
            settings.evaluation == Evaluation::Compensated
                && settings.ms_table.is_some()
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

/// Pushes the microfacet normal maps of the 8 hits `si` of material `m` (one that
/// [`qualifies`] and [`shared_nested`]) into `arena`, as `Materials::build_at` builds them but
/// without the incident-direction cache, which `compensated::lanes::with_incident_x8` then adds
/// for the 8 points at once; the leaf is pushed once for the chunk (a constant template: every
/// hit's copy would be the same bit for bit). `rgb`: the normal map texture's values at the
/// hits (looked up by the caller, [`normal_texture`]); the maps' arithmetic (perturbed
/// normals, microsurfaces, facet frames, θp cells) runs for the 8 lanes together
/// (`MnmSettings::lanes_at`, at the width of `L`), then each hit's map is written
/// (`MnmSettings::map_lane_into`: `map_into`'s map bit for bit). Returns the roots
/// (`u32::MAX` for a lane whose hit is not given) and the ωi the cache is for (shading frame,
/// as `Materials::build_at` computes it). Inlined into the kernel (inside `Avx2::run`, where
/// the 8-wide operations are single instructions).
#[inline(always)]
pub(crate) fn build_shared<L>(
    scene: &Scene,
    m: MatId,
    si: &[Option<SurfaceInteraction>; 8],
    rgb: V3<L>,
    arena: &mut BsdfArena,
) -> ([u32; 8], [Vec3; 8])
where
    L: Lane + ToArray<f32, 8>,
    L::I32: ToArray<i32, 8>,
{
    let materials = &scene.materials;
    let nodes = materials.nodes();
    let (mut roots, mut wi) = ([u32::MAX; 8], [Vec3::Z; 8]);
    let MaterialNode::MicrofacetNormalMap {
        nested, settings, ..
    } = &nodes[m as usize]
    else {
        return (roots, wi);
    };
    let MaterialNode::Leaf { template, .. } = &nodes[*nested as usize] else {
        return (roots, wi);
    };
    let child = arena.push_with_lobes(materials.lobes(*nested), **template);
    let lanes = settings.lanes_at(rgb).cols::<8>();
    for (k, si) in si.iter().enumerate() {
        let Some(si) = si else { continue };
        roots[k] = arena.push_microfacet_normal_map_with(child, |m| {
            settings.map_lane_into(m, child, &lanes, k);
        });
        wi[k] = si.sh.to_local(si.wi);
    }
    (roots, wi)
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
        eval_pdf_x8, sample_x8, with_incident_alone_x8, Chunk, Point,
    };
    use crate::bsdf::{BsdfArena, BsdfContext, Lobes, SurfaceBsdf};
    use crate::geometry::{Ray, SurfaceInteraction};
    use crate::integrator::{PathSettings, Strategy};
    use crate::lane::vec::{V2, V3};
    use crate::lane::{Avx2, F32x8};
    use crate::scene::Scene;
    use crate::stream::batch::Batch;
    use crate::stream::kernels::diffuse::light_out;
    use crate::stream::kernels::diffuse::reflectance;
    use crate::stream::kernels::light::x8::{Cols3, Gather};
    use crate::stream::kernels::light::LaneLight;
    use crate::stream::kernels::tail::{Sampled, Tail};
    use crate::texture::Texture;
    use glam::Vec3;

    /// The normal map texture's values at the 8 hits `si` of material `m`, as
    /// `Materials::build_at` looks it up (`Texture::eval` at the hit's uv, or its mesh data):
    /// a bitmap at the 8 uvs at once (`BitmapTexture::eval_x8`, bit for bit `eval`), another
    /// texture lane by lane. Lanes without a hit hold any value (they are not built).
    #[inline(always)]
    fn normal_rgb(
        avx: Avx2,
        scene: &Scene,
        m: crate::material::MatId,
        si: &[Option<SurfaceInteraction>; 8],
    ) -> V3<F32x8> {
        let zero = avx.splat(0.0);
        let Some(tex) = super::normal_texture(scene, m) else {
            return V3::new(zero, zero, zero);
        };
        if let Texture::Bitmap(bt) = tex {
            let (mut u, mut v) = ([0.0f32; 8], [0.0f32; 8]);
            for (k, si) in si.iter().enumerate() {
                if let Some(si) = si {
                    (u[k], v[k]) = (si.uv.x, si.uv.y);
                }
            }
            bt.eval_x8(avx, V2::new(avx.load(&u), avx.load(&v)))
        } else {
            let mut rgb = Cols3::default();
            for (k, si) in si.iter().enumerate() {
                if let Some(si) = si {
                    rgb.set(k, reflectance(scene, tex, si));
                }
            }
            rgb.load(avx)
        }
    }

    /// The BSDF built at `si` in step 2 (root `root` of `arena`), whose side test passed.
    #[inline(always)]
    fn bsdf<'a>(arena: &'a BsdfArena, root: u32, si: &SurfaceInteraction) -> SurfaceBsdf<'a> {
        SurfaceBsdf::new(arena.bsdf(root), si.sh, si.ng, si.wi)
            .expect("the side test passed in step 2")
    }

    /// Shades the 8 paths `ids` (all at a surface of a material that [`super::qualifies`]) as
    /// `PathState::scatter` would, one after the other; hands each lane's light sample, then
    /// its BSDF sample, to `tail` (the integrator's end of the vertex). `arena` holds the 8
    /// points' BSDF trees (cleared here). Call inside [`Avx2::run`].
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn shade(
        avx: Avx2,
        scene: &Scene,
        cfg: &PathSettings,
        b: &mut Batch,
        ids: &[u32; 8],
        lights: &[Option<LaneLight>],
        gather: &mut Gather,
        arena: &mut BsdfArena,
        tail: &mut impl Tail,
    ) {
        let si_of = |b: &Batch, i: u32| -> SurfaceInteraction { b.surf.get(i as usize) };
        let ctx = BsdfContext::default();
        // The chunk's compensated points share their nested BSDF (one material, a constant
        // leaf): their first orders are evaluated together.
        let m0 = b.material[ids[0] as usize];
        let shared = super::shared_nested(&scene.materials, m0)
            && ids.iter().all(|&i| b.material[i as usize] == m0);
        // 1. The surfaces, loaded 8-wide from the batch's rows (the light stage's columns).
        let surf = crate::stream::kernels::surface::x8::load(avx, &b.surf, ids);

        // 2. The BSDFs: where the nested leaf is shared, the maps built here and their ωi
        //    caches 8-wide (`super::build_shared`, `with_incident_x8`), else by
        //    `Scene::bsdf_root`; then the side test and the light points, lane by lane in each
        //    path's order.
        arena.clear();
        let mut built = [u32::MAX; 8];
        let mut wi = [Vec3::Z; 8];
        if shared {
            let sis = ids.map(|i| Some(si_of(b, i)));
            let rgb = normal_rgb(avx, scene, m0, &sis);
            (built, wi) = super::build_shared(scene, m0, &sis, rgb, arena);
        }
        let mut root = [u32::MAX; 8];
        let mut nee = [false; 8];
        let mut tp = Cols3::default();
        let light_only = cfg.strategy == Strategy::LightOnly;
        gather.reset();
        let (mut u_sel8, mut u8, mut p8) = ([0.0f32; 8], [[0.0f32; 8]; 2], Cols3::default());
        for (k, &i) in ids.iter().enumerate() {
            let i = i as usize;
            b.light[i] = None;
            let si = si_of(b, i as u32);
            let r = match built[k] {
                u32::MAX => scene.bsdf_root(&si, arena),
                r => r,
            };
            let Some(bsdf) = SurfaceBsdf::new(arena.bsdf(r), si.sh, si.ng, si.wi) else {
                continue; // no light scatters toward wi: the path ends (`PathState::scatter`)
            };
            root[k] = r;
            tp.set(k, b.state[i].throughput);
            if cfg.strategy != Strategy::BsdfOnly && bsdf.lobes().is_smooth() {
                nee[k] = true;
                let sampler = &mut b.sampler[i];
                u_sel8[k] = sampler.next_1d();
                let u = sampler.next_2d();
                (u8[0][k], u8[1][k]) = (u.x, u.y);
                p8.set(k, si.p);
            }
        }
        if nee.contains(&true) {
            gather.add_x8(avx, scene, lights, light_only, &nee, &u_sel8, &u8, &p8);
        }

        // The compensated model's points (where the nested leaf is shared) and their state
        // at ωi, once for steps 3 and 4 ([`Chunk`], 8-wide). The built maps that are no such
        // points (the scalar model answers their queries) get their ωi caches.
        if shared {
            with_incident_alone_x8(arena, &built, &wi);
        }
        let mut pts = [None; 8];
        for (k, &i) in ids.iter().enumerate() {
            if shared && root[k] != u32::MAX {
                let (local, wi) = bsdf(arena, root[k], &si_of(b, i)).local();
                pts[k] = Point::of(local, wi);
            }
        }
        // Built in place (a struct literal, then its state at ωi).
        let mut chunk = Chunk::of(pts);
        chunk.prepare();

        // 3. Next-event estimation: the BSDF toward the light points lane by lane (where a
        //    point was sampled, as `nee::prepare_light`), the rest 8-wide.
        if nee.contains(&true) {
            let lp = gather.finish(avx, scene, surf.p, &mut b.light_lanes);
            let (some, d) = (lp.some.to_array(), Cols3::store(lp.d));
            let (mut f, mut pdf, mut consistent) = (Cols3::default(), [0.0f32; 8], [false; 8]);
            let (mut lit, mut wo) = (0u8, [Vec3::ZERO; 8]);
            for (k, &i) in ids.iter().enumerate() {
                if !(nee[k] && some[k]) {
                    continue;
                }
                let i = i as usize;
                let si = si_of(b, i as u32);
                let s = bsdf(arena, root[k], &si);
                let Some(wo_k) = s.local_wo(d.get(k)) else {
                    continue; // `SurfaceBsdf::eval_pdf`'s side test
                };
                consistent[k] = true;
                if pts[k].is_some() {
                    lit |= 1 << k;
                    wo[k] = wo_k; // evaluated below with the other points
                } else {
                    let (local, wi) = s.local();
                    let (fk, pk) = local.eval_pdf(&ctx, wi, wo_k, &mut b.sampler[i]);
                    f.set(k, fk);
                    pdf[k] = pk;
                }
            }
            for (k, (fk, pk)) in eval_pdf_x8(&ctx, &chunk, lit, &wo).into_iter().enumerate() {
                if lit & (1 << k) != 0 {
                    f.set(k, fk);
                    pdf[k] = pk;
                }
            }
            let lo = light_out(
                &surf,
                tp.load(avx),
                &lp,
                f.load(avx),
                avx.load(&pdf),
                avx.mask(&consistent),
            );
            let (ok, o, dd, tmax, c) = (
                lo.ok.to_array(),
                Cols3::store(lo.o),
                Cols3::store(lo.d),
                lo.tmax.to_array(),
                Cols3::store(lo.contribution),
            );
            for (k, &i) in ids.iter().enumerate() {
                if nee[k] && ok[k] {
                    let shadow = Ray::segment(o.get(k), dd.get(k), tmax[k]);
                    tail.light(b, i as usize, shadow, c.get(k));
                }
            }
        }

        // 4. The BSDF samples (the compensated model's points together, their first orders'
        //    nested evaluations 8-wide; the others lane by lane) and the next rays, lane by
        //    lane, to the tail (for `path`, `PathState::scatter`'s end).
        let sampled = sample_x8(&ctx, &chunk, &mut b.sampler, ids);
        for (k, &i) in ids.iter().enumerate() {
            if root[k] == u32::MAX {
                continue;
            }
            let i = i as usize;
            let si = si_of(b, i as u32);
            let s = bsdf(arena, root[k], &si);
            let bs = match (pts[k], sampled[k]) {
                (Some(_), Some(bs)) => s.world_sample(bs),
                (Some(_), None) => None,
                (None, _) => s.sample(&ctx, &mut b.sampler[i]),
            };
            let Some(bs) = bs else {
                continue;
            };
            // `PathState::advance_sampled`'s arguments, for the tail.
            let s = Sampled {
                p: si.p,
                ray: si.spawn_ray(bs.wo),
                weight: bs.weight,
                eta: bs.eta,
                pdf: bs.pdf,
                delta: bs.lobe.intersects(Lobes::DELTA),
            };
            tail.bsdf(b, i, &s);
        }
    }
}
