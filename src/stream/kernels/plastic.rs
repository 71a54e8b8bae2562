//! The 8-wide `plastic` / `roughplastic` kernel with next-event estimation: what
//! [`PathState::scatter`](crate::integrator::path::PathState::scatter) does at a vertex of either
//! coated model (`bsdf::plastic`, `bsdf::roughplastic`), for 8 paths at a time, through the
//! models' lane forms (`eval_pdf_with`, `sample_with`: the scalar BSDF is their `f32`
//! instantiation, so the bits are the scalar renderer's).
//!
//! A material runs here when it is a leaf `plastic` or `roughplastic` (under `twosided` or a
//! classic normal map, with constant parameters, it runs in [`super::conductor`]'s wrapper
//! chain; under `blendbsdf` or with textured reflectances under a wrapper, lane by lane). Textured `diffuse_reflectance` / `specular_reflectance` are
//! **gathered**: each lane's texture is evaluated lane by lane as `Materials::build_at` patches
//! the slot, and the lane form takes the reflectances per lane (the lobe-sampling weight stays
//! the material's, from the textures' means, as in the scalar code).
//!
//! Per chunk of 8 paths, the steps of the `diffuse` kernel ([`super::diffuse`]):
//! 1. load the surfaces 8-wide from the batch's columns ([`super::surface`]); [`super::diffuse::incident`]
//!    and its side test, 8-wide;
//! 2. lane by lane: the reflectance textures; each path's numbers in the scalar order (light
//!    selection `u_sel`, light point `u`, lobe choice `u1`, BSDF sample `u2`), 8-wide from the
//!    gathered PCG32 states ([`super::draws`]); lane by lane: the light point (through the
//!    shared gather `super::light::x8::Gather`: area lights of a
//!    constant radiance on triangle meshes, rectangles and spheres 8-wide, every other emitter by
//!    its own scalar `sample_direct`);
//! 3. [`light`] and [`sample`], 8-wide: the coating's value and density toward the light point,
//!    power heuristic, contribution, shadow ray; the coating's sample (the lobe chosen by `u1`
//!    as a select), `Bsdf::sample`'s finiteness test, the side test, the next ray;
//! 4. scatter back: under the `path` integrator, the pending light samples lane by lane, then
//!    `PathState::advance` (throughput, Russian roulette; `plastic`'s specular lobe is a delta
//!    lobe there) in lanes (`vertex::x8::scatter`); under another integrator's tail, the light
//!    samples then the BSDF samples lane by lane.

use crate::bsdf::lanes::LaneBsdfSample;
use crate::bsdf::{BsdfNode, Plastic, RoughPlastic};
use crate::lane::vec::{V2, V3};
use crate::lane::Lane;
use crate::material::{MaterialNode, Slot, TexId};
use crate::scene::Scene;

use super::diffuse::{light_direction, light_out, LightOut, LightPoint, Surface};
use super::ray::offset_origin;

/// The coating model of a run, its parameters uniform over the lanes (the reflectances come
/// per lane, see [`Coating::eval_pdf`]).
#[derive(Clone, Copy, Debug)]
pub(crate) enum Coating {
    Smooth(Plastic),
    Rough(RoughPlastic),
}

impl Coating {
    /// `f · cos θo` and the density toward `wo`, with per-lane diffuse (`rho`) and specular
    /// (`spec`) reflectances.
    #[inline(always)]
    pub(crate) fn eval_pdf<L: Lane>(
        &self,
        rho: V3<L>,
        spec: V3<L>,
        wi: V3<L>,
        wo: V3<L>,
    ) -> (V3<L>, L) {
        match self {
            Coating::Smooth(b) => b.eval_pdf_with(rho, wi, wo),
            Coating::Rough(b) => b.eval_pdf_with(rho, spec, wi, wo),
        }
    }

    /// The model's sample, and the lanes that took a delta lobe (`plastic`'s specular
    /// reflection; none for `roughplastic`).
    #[inline(always)]
    pub(crate) fn sample<L: Lane>(
        &self,
        rho: V3<L>,
        spec: V3<L>,
        wi: V3<L>,
        u1: L,
        u2: V2<L>,
    ) -> (LaneBsdfSample<L>, L::Mask) {
        match self {
            Coating::Smooth(b) => b.sample_with(rho, spec, wi, u1, u2),
            Coating::Rough(b) => {
                let (s, _) = b.sample_with(rho, spec, wi, u1, u2);
                let k = wi.z.splat(0.0);
                (s, k.ne(k))
            }
        }
    }
}

/// What a material needs for the kernel: its coating, the textures of its reflectances (where
/// textured) and whether it takes a light sample (`Lobes::is_smooth`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Material {
    pub coating: Coating,
    pub diffuse: Option<TexId>,
    pub specular: Option<TexId>,
    pub smooth: bool,
}

/// The kernel's view of material `m`: a leaf `plastic` or `roughplastic` whose only textured
/// parameters are its reflectances; `None` for anything else.
pub(crate) fn material(scene: &Scene, m: u32) -> Option<Material> {
    let MaterialNode::Leaf { template, slots } = &scene.materials.nodes()[m as usize] else {
        return None;
    };
    let coating = match **template {
        BsdfNode::Plastic(b) => Coating::Smooth(b),
        BsdfNode::RoughPlastic(b) => Coating::Rough(b),
        _ => return None,
    };
    let (mut diffuse, mut specular) = (None, None);
    for &(slot, tex) in slots {
        match slot {
            Slot::DiffuseReflectance => diffuse = Some(tex),
            Slot::SpecularReflectance => specular = Some(tex),
            _ => return None,
        }
    }
    Some(Material {
        coating,
        diffuse,
        specular,
        smooth: scene.materials.lobes(m).is_smooth(),
    })
}

/// Next-event estimation from the sampled light points: `nee::prepare_light` after its call to
/// `sample_emitter` (through `SurfaceBsdf::eval_pdf`), and the MIS-weighted contribution of
/// `PathState::scatter`. As `diffuse::light` with the coating's value and density.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn light<L: Lane>(
    c: &Coating,
    s: &Surface<L>,
    wi: V3<L>,
    rho: V3<L>,
    spec: V3<L>,
    throughput: V3<L>,
    lp: &LightPoint<L>,
) -> LightOut<L> {
    // SurfaceBsdf::eval_pdf: the light direction in the shading frame and its side test.
    let (wo, consistent) = light_direction(s, lp);
    let (f, bsdf_pdf) = c.eval_pdf(rho, spec, wi, wo);
    light_out(s, throughput, lp, f, bsdf_pdf, consistent)
}

/// The BSDF sample of [`sample`]: where it succeeded (and passed the side test), the world
/// direction, density, weight, whether through a delta lobe, and the next ray's origin.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SampleOut<L: Lane> {
    pub ok: L::Mask,
    pub wo: V3<L>,
    pub pdf: L,
    pub weight: V3<L>,
    pub delta: L::Mask,
    pub o: V3<L>,
}

/// The coating's sample from `u1`, `u2`; the finiteness checks of `Bsdf::sample`, the side test
/// of `SurfaceBsdf::sample` and `SurfaceInteraction::spawn_ray`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample<L: Lane>(
    c: &Coating,
    s: &Surface<L>,
    wi: V3<L>,
    rho: V3<L>,
    spec: V3<L>,
    u1: L,
    u2: V2<L>,
) -> SampleOut<L> {
    let k = |c: f32| wi.z.splat(c);
    let (bs, delta) = c.sample(rho, spec, wi, u1, u2);
    let finite = bs.wo.x.is_finite()
        & bs.wo.y.is_finite()
        & bs.wo.z.is_finite()
        & bs.pdf.ge(k(0.0))
        & bs.weight.x.is_finite()
        & bs.weight.y.is_finite()
        & bs.weight.z.is_finite();
    let wo_world = s.frame.to_world(bs.wo);
    let consistent = (wo_world.dot(s.ng) * bs.wo.z).gt(k(0.0));
    SampleOut {
        ok: bs.ok & finite & consistent,
        wo: wo_world,
        pdf: bs.pdf,
        weight: bs.weight,
        delta,
        o: offset_origin(s.p, s.ng, wo_world),
    }
}

/// The 8-wide driver: gathers, the kernel at width 8 and the scatter back.
#[cfg(target_arch = "x86_64")]
pub(crate) mod x8 {
    use super::*;
    use crate::geometry::Ray;
    use crate::integrator::{PathSettings, Strategy};
    use crate::lane::ToArray;
    use crate::spectrum::Spectrum;
    use crate::stream::batch::Batch;
    use crate::stream::kernels::diffuse::reflectance;
    use crate::stream::kernels::draws::{x8::draw, Draws};
    use crate::stream::kernels::light::x8::{Cols3, Gather};
    use crate::stream::kernels::light::LaneLight;
    use crate::stream::kernels::ray::RayRows;
    use crate::stream::kernels::surface;
    use crate::stream::kernels::tail::{Sampled, Tail};
    use crate::stream::kernels::vertex;
    use crate::stream::kernels::vertex::x8::{prologue, scatter, Chunks, LightCols};

    /// Shades the paths of the run `batch.sorted[run]` (all of material `mat`) `W` at a time,
    /// then the last `run.len() % W` as one padded chunk (`vertex::x8::padded`) when there are
    /// at least `pad_min` of them; returns how many it shaded. Enters [`crate::lane::Wide::run`] itself.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn shade_run<T: RayRows<W>, const W: usize>(
        avx: T,
        scene: &Scene,
        cfg: &PathSettings,
        b: &mut Batch,
        run: std::ops::Range<usize>,
        pad_min: usize,
        mat: Material,
        lights: &[Option<LaneLight>],
        tail: &mut impl Tail,
    ) -> usize {
        let mut chunks = Chunks::<W>::new(run.clone(), pad_min);
        if !chunks.any() {
            return 0;
        }
        avx.run(
            #[inline(always)]
            || {
                let mut gather = Gather::<W>::new();
                while let Some((ids, live)) = chunks.next(&b.sorted) {
                    shade(
                        avx,
                        scene,
                        cfg,
                        b,
                        &ids,
                        live,
                        &mat,
                        lights,
                        &mut gather,
                        tail,
                    );
                }
            },
        );
        chunks.at() - run.start
    }

    /// Shades the 8 paths `ids` (each at a surface of material `mat`, with its interaction in
    /// `b.surf`) as `PathState::scatter` would, one after the other; sets their pending light
    /// samples, and their next rays and `alive` flags where they go on. Only the first `live`
    /// lanes are paths (a padded chunk: `vertex::x8::padded`, `vertex::x8::live_only`). Call
    /// inside [`crate::lane::Avx2::run`].
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn shade<T: RayRows<W>, const W: usize>(
        avx: T,
        scene: &Scene,
        cfg: &PathSettings,
        b: &mut Batch,
        ids: &[u32; W],
        live: usize,
        mat: &Material,
        lights: &[Option<LaneLight>],
        gather: &mut Gather<W>,
        tail: &mut impl Tail,
    ) {
        // 1. The surfaces, loaded 8-wide from the batch's columns; the side test.
        let surface::x8::Prologue {
            surf,
            p,
            wi,
            front,
            bits: front_bits,
        } = prologue(avx, &b.surf, ids, live);

        // 2. Textures, light points and BSDF numbers, lane by lane in each path's order.
        let (rho0, spec0) = match &mat.coating {
            Coating::Smooth(c) => (c.diffuse_reflectance, c.specular_reflectance),
            Coating::Rough(c) => (c.diffuse_reflectance, c.specular_reflectance),
        };
        let (mut rho, mut spec, mut tp) = <(Cols3<W>, Cols3<W>, Cols3<W>)>::default();
        for (k, &i) in ids.iter().enumerate() {
            if !front[k] {
                continue;
            }
            let si = b.surf.get(i as usize);
            let tex = |t: Option<TexId>, c: Spectrum| match t {
                Some(t) => reflectance(scene, &scene.materials.textures[t as usize], &si),
                None => c,
            };
            rho.set(k, tex(mat.diffuse, rho0));
            spec.set(k, tex(mat.specular, spec0));
            tp.set(k, b.state[i as usize].throughput);
        }
        // Each path's numbers (`u_sel`, `u` with a light sample, `u1`, `u2`), 8-wide from the
        // gathered PCG32 states where the streams are plain (`kernels::draws`), then the light
        // points through the shared gather of `kernels::light` (area lights on meshes,
        // rectangles and spheres 8-wide).
        let nee = cfg.strategy != Strategy::BsdfOnly && mat.smooth;
        let draws = Draws {
            light: nee,
            u1: true,
            u2: true,
        };
        let num = draw(avx, &mut b.sampler, ids, &front, draws);
        let lp = if nee {
            let light_only = cfg.strategy == Strategy::LightOnly;
            gather.reset();
            let (u_sel, u) = (&num.u_sel, &num.u);
            gather.add_x8(avx, scene, lights, light_only, front_bits, u_sel, u, &p);
            Some(gather.finish(avx, scene, surf.p, &mut b.light_lanes))
        } else {
            None
        };

        // 3. The kernel.
        let (rho8, spec8, tp8) = (rho.load(avx), spec.load(avx), tp.load(avx));
        // A `match`, not `Option::map`: the closure would be compiled out of line without the
        // lanes' target features, and every intrinsic in `light` would become a call.
        let lo = match lp {
            Some(lp) => Some(light(&mat.coating, &surf, wi, rho8, spec8, tp8, &lp)),
            None => None,
        };
        let u2 = V2::new(avx.load(&num.u2[0]), avx.load(&num.u2[1]));
        let so = sample(&mat.coating, &surf, wi, rho8, spec8, avx.load(&num.u1), u2);

        // 4. Scatter back. Under the `path` tail, through the wrapper-chain driver's step 4
        // (`vertex::x8::scatter`): the light samples stored, then the vertices' ends in lanes
        // (`vertex::x8::advance`, bit for bit `PathState::advance`; η 1).
        if tail.path().is_some() {
            // A `match`, not `Option::map` (as for `lo` above: a closure would run outside the
            // lanes' target features).
            #[allow(clippy::manual_map)]
            let lc = match lo {
                Some(lo) => Some(LightCols::store(&lo)),
                None => None,
            };
            let so = vertex::SampleOut {
                ok: so.ok,
                wo: so.wo,
                pdf: so.pdf,
                weight: so.weight,
                delta: so.delta,
                eta: avx.splat(1.0),
                o: so.o,
            };
            scatter(avx, b, ids, &front, &p, tp8, lc.as_ref(), &so, tail);
            return;
        }
        if let Some(lo) = lo {
            let (ok, c) = (lo.ok.to_array(), Cols3::store(lo.contribution));
            // The shadow rays as whole rows (`RayRows::segment_rows`).
            let shadow = avx.segment_rows(lo.o, lo.d, lo.tmax);
            for (k, &i) in ids.iter().enumerate() {
                if front[k] && ok[k] {
                    tail.light(b, i as usize, shadow[k], c.get(k));
                }
            }
        }
        let (ok, wo, pdf) = (so.ok.to_array(), Cols3::store(so.wo), so.pdf.to_array());
        let (weight, delta, o) = (
            Cols3::store(so.weight),
            so.delta.to_array(),
            Cols3::store(so.o),
        );
        for (k, &i) in ids.iter().enumerate() {
            let i = i as usize;
            if !(front[k] && ok[k]) {
                continue;
            }
            let s = Sampled {
                p: p.get(k),
                ray: Ray::new(o.get(k), wo.get(k)),
                weight: weight.get(k),
                eta: 1.0,
                pdf: pdf[k],
                delta: delta[k],
            };
            tail.bsdf(b, i, &s);
        }
    }
}
