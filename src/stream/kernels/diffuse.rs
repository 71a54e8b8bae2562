//! The 8-wide `diffuse` kernel with next-event estimation: what
//! [`PathState::scatter`](crate::integrator::path::PathState::scatter) does at a `diffuse` vertex
//! (Lambertian f = ρ/π, one-sided; `bsdf::diffuse`), for 8 paths at a time.
//!
//! Per chunk of 8 paths of one `diffuse` material:
//! 1. load the surfaces 8-wide from the batch's columns ([`super::surface`]);
//! 2. [`incident`], 8-wide: the incident direction in the shading frame and the strict-normal
//!    side test of `SurfaceBsdf::new` (a path that fails it ends here, drawing nothing);
//! 3. each path's random numbers in the scalar renderer's order (light selection `u_sel`, light
//!    point `u`, BSDF sample `u2`): 8-wide from the 8 paths' gathered PCG32 states
//!    ([`super::draws`]: a path whose stream is not plain PCG32, a `stratified` path at its
//!    first vertex, draws lane by lane from its `Sampler`); a constant reflectance splat and
//!    the throughputs gathered (another reflectance texture looked up lane by lane, each
//!    throughput read beside it); then lane by lane: the light selection,
//!    and the light point of every emitter through its own scalar `sample_direct`, except area
//!    lights of a constant radiance on triangle meshes, rectangles and spheres (seen from
//!    outside): their triangle is picked here (`Shape::pick_triangle`) and the point sampled
//!    8-wide ([`super::light`]);
//! 4. [`light`] and [`sample`], 8-wide: BSDF value and density toward the light point, power
//!    heuristic, contribution, shadow ray; cosine-hemisphere sample, its side test, next ray;
//! 5. scatter back (`vertex::x8::scatter`): the pending light samples lane by lane, then the
//!    throughput update and Russian roulette of `PathState::advance` in lanes under the `path`
//!    integrator (`vertex::x8::advance`; the roulette draw, where it plays, from the path's
//!    `Sampler`, whose state the 8-wide draws left where the scalar draws would have); under
//!    another integrator's tail, each lane's samples in path order.
//!
//! Each 8-wide step is the scalar code's operations in its order (see `kernels` for the rule).

use crate::geometry::SurfaceInteraction;
use crate::lane::frame::Frame;
use crate::lane::vec::{V2, V3};
use crate::lane::{warp, Lane};
use crate::math::INV_PI;
use crate::scene::Scene;
use crate::spectrum::Spectrum;
use crate::texture::Texture;

use super::mis::power_heuristic;
use super::ray::{offset_origin, AtPoint, Origin};

/// A surface point per lane.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Surface<L: Lane> {
    pub p: V3<L>,
    /// True (geometric) normal.
    pub ng: V3<L>,
    /// Shading frame.
    pub frame: Frame<L>,
    /// Direction toward the previous vertex, world space.
    pub wi_world: V3<L>,
}

/// The incident direction in the shading frame, and where `SurfaceBsdf::new`'s side test passes
/// (`wi_world · ng` and the local `wi.z` agree in sign).
#[inline(always)]
pub(crate) fn incident<L: Lane>(s: &Surface<L>) -> (V3<L>, L::Mask) {
    let wi = s.frame.to_local(s.wi_world);
    let bad = (s.wi_world.dot(s.ng) * wi.z).le(wi.z.splat(0.0));
    (wi, !bad)
}

/// A light point per lane, as `nee::sample_emitter` returned it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LightPoint<L: Lane> {
    /// A light point was sampled.
    pub some: L::Mask,
    /// Unit direction toward it.
    pub d: V3<L>,
    pub p: V3<L>,
    /// Its surface normal, where `has_n`.
    pub n: V3<L>,
    pub has_n: L::Mask,
    /// At a finite distance (else an environment: the shadow ray is unbounded).
    pub finite: L::Mask,
    /// Emitter density × selection probability.
    pub pdf: L,
    /// Radiance arriving along `-d`.
    pub value: V3<L>,
    /// MIS weight 1 (a delta light, or the light-only strategy).
    pub weight_one: L::Mask,
}

/// The light sample of [`light`]: where it is pending, its shadow ray and contribution.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LightOut<L: Lane> {
    pub ok: L::Mask,
    pub o: V3<L>,
    pub d: V3<L>,
    pub tmax: L,
    pub contribution: V3<L>,
}

/// `Diffuse::eval` and `Diffuse::pdf` (`f·cos θo`, cosine-hemisphere density).
#[inline(always)]
fn eval_pdf<L: Lane>(refl: V3<L>, wi: V3<L>, wo: V3<L>) -> (V3<L>, L) {
    let zero = wi.z.splat(0.0);
    let back = wi.z.le(zero) | wo.z.le(zero);
    let f = refl.scale(wi.z.splat(INV_PI) * wo.z);
    let pdf = warp::cosine_hemisphere_pdf(wo);
    (
        V3::select(back, V3::new(zero, zero, zero), f),
        L::select(back, zero, pdf),
    )
}

/// Next-event estimation from the sampled light points: `nee::prepare_light` after its call to
/// `sample_emitter`, and the MIS-weighted contribution of `PathState::scatter`.
#[inline(always)]
pub(crate) fn light<L: Lane>(
    s: &Surface<L>,
    wi: V3<L>,
    refl: V3<L>,
    throughput: V3<L>,
    lp: &LightPoint<L>,
) -> LightOut<L> {
    // SurfaceBsdf::eval_pdf: the light direction in the shading frame and its side test.
    let (wo, consistent) = light_direction(s, lp);
    let (f, bsdf_pdf) = eval_pdf(refl, wi, wo);
    light_out(s, throughput, lp, f, bsdf_pdf, consistent)
}

/// `SurfaceBsdf::eval_pdf`'s first step toward a light point: the direction in the shading frame
/// and its strict side test (shared by every kernel's next-event estimation).
#[inline(always)]
pub(crate) fn light_direction<L: Lane>(s: &Surface<L>, lp: &LightPoint<L>) -> (V3<L>, L::Mask) {
    let k = |c: f32| lp.pdf.splat(c);
    let wo = s.frame.to_local(lp.d);
    let consistent = (lp.d.dot(s.ng) * wo.z).gt(k(0.0));
    (wo, consistent)
}

/// The rest of next-event estimation once the BSDF's value `f` (`f · |cos θo|`) and density
/// toward the light point are known: the zero test, the MIS-weighted contribution of
/// `PathState::scatter` and the shadow ray (shared by every kernel).
#[inline(always)]
pub(crate) fn light_out<L: Lane>(
    s: &Surface<L>,
    throughput: V3<L>,
    lp: &LightPoint<L>,
    f: V3<L>,
    bsdf_pdf: L,
    consistent: L::Mask,
) -> LightOut<L> {
    let at = AtPoint { p: s.p, n: s.ng };
    light_out_from(s, &at, throughput, lp, f, bsdf_pdf, consistent)
}

/// [`light_out`] with the ray origins of `s`'s point from `origin` (`s.p` and `s.ng` offset
/// per ray, or picked from the point's offsets made once: the same values).
#[inline(always)]
pub(crate) fn light_out_from<L: Lane, O: Origin<L>>(
    s: &Surface<L>,
    origin: &O,
    throughput: V3<L>,
    lp: &LightPoint<L>,
    f: V3<L>,
    bsdf_pdf: L,
    consistent: L::Mask,
) -> LightOut<L> {
    let k = |c: f32| lp.pdf.splat(c);
    let nonzero = !(f.x.eq(k(0.0)) & f.y.eq(k(0.0)) & f.z.eq(k(0.0)));
    let ok = lp.some & consistent & nonzero;
    let f_value = f * lp.value;
    let w = L::select(lp.weight_one, k(1.0), power_heuristic(lp.pdf, bsdf_pdf));
    let contribution = throughput * f_value.scale(w / lp.pdf);
    // SurfaceInteraction::spawn_ray_to (a light point at a finite distance) or spawn_ray.
    let d0 = lp.p - s.p;
    let o_to = origin.toward(d0);
    let t_end = V3::select(lp.has_n, offset_origin(lp.p, lp.n, -d0), lp.p);
    let d = t_end - o_to;
    let dist = d.length();
    let o_inf = origin.toward(lp.d);
    LightOut {
        ok,
        o: V3::select(lp.finite, o_to, o_inf),
        d: V3::select(lp.finite, d.div_by(dist), lp.d),
        tmax: L::select(lp.finite, dist * k(1.0 - 1e-4), k(f32::INFINITY)),
        contribution,
    }
}

/// The BSDF sample of [`sample`]: where it succeeded, the world direction, its density and the
/// next ray's origin (its weight is the reflectance, its η 1, its lobe diffuse).
#[derive(Clone, Copy, Debug)]
pub(crate) struct SampleOut<L: Lane> {
    pub ok: L::Mask,
    pub wo: V3<L>,
    pub pdf: L,
    pub o: V3<L>,
}

/// `Diffuse::sample` from `u`, the finiteness checks of `Bsdf::sample`, the side test of
/// `SurfaceBsdf::sample` and `SurfaceInteraction::spawn_ray`.
#[inline(always)]
pub(crate) fn sample<L: Lane>(s: &Surface<L>, wi: V3<L>, refl: V3<L>, u: V2<L>) -> SampleOut<L> {
    let k = |c: f32| wi.z.splat(c);
    let wo = warp::square_to_cosine_hemisphere(u);
    let pdf = warp::cosine_hemisphere_pdf(wo);
    let finite = wo.x.is_finite()
        & wo.y.is_finite()
        & wo.z.is_finite()
        & pdf.ge(k(0.0))
        & refl.x.is_finite()
        & refl.y.is_finite()
        & refl.z.is_finite();
    let ok = !wi.z.le(k(0.0)) & !pdf.le(k(0.0)) & finite;
    let wo_world = s.frame.to_world(wo);
    let consistent = (wo_world.dot(s.ng) * wo.z).gt(k(0.0));
    SampleOut {
        ok: ok & consistent,
        wo: wo_world,
        pdf,
        o: offset_origin(s.p, s.ng, wo_world),
    }
}

/// The reflectance of a `diffuse` whose `reflectance` is `tex`, at `si`: as
/// `Materials::build_at` evaluates it (`Scene::bsdf_at` picks the lookup).
#[inline(always)]
pub(crate) fn reflectance(scene: &Scene, tex: &Texture, si: &SurfaceInteraction) -> Spectrum {
    let shape = si.shape as usize;
    if scene.shape_reads_mesh[shape] {
        tex.eval(crate::texture::TexPoint::on_shape(si, &scene.shapes[shape]))
    } else {
        tex.eval(si.uv)
    }
}

/// The 8-wide driver: gathers, the kernel at width 8 and the scatter back.
#[cfg(target_arch = "x86_64")]
pub(crate) mod x8 {
    use super::*;
    use crate::integrator::{PathSettings, Strategy};
    use crate::stream::batch::Batch;
    use crate::stream::kernels::draws::{x8::draw, Draws};
    use crate::stream::kernels::light::x8::{Cols3, Gather};
    use crate::stream::kernels::light::LaneLight;
    use crate::stream::kernels::ray::RayRows;
    use crate::stream::kernels::surface;
    use crate::stream::kernels::tail::Tail;
    use crate::stream::kernels::vertex::x8::{prologue, scatter, LightCols};
    use crate::stream::kernels::vertex::SampleOut;

    /// What a material needs for the kernel: its reflectance texture and whether it takes a
    /// light sample (`Lobes::is_smooth`, as `PathState::scatter` asks).
    #[derive(Clone, Copy)]
    pub(crate) struct Material<'a> {
        pub reflectance: &'a Texture,
        pub smooth: bool,
        /// Per emitter, how the kernel samples it in lanes (`LaneLight::table`).
        pub lights: &'a [Option<LaneLight>],
    }

    /// Shades the 8 paths `ids` (all at a surface of material `mat`, each with its interaction in
    /// `b.surf`) as `PathState::scatter` would, one after the other; sets their pending light
    /// samples, and their next rays and `alive` flags where they go on. Only the first `live`
    /// lanes are paths (a padded chunk: `vertex::x8::padded`, `vertex::x8::live_only`). Call
    /// inside [`crate::lane::Wide::run`].
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn shade<T: RayRows<W>, const W: usize>(
        avx: T,
        scene: &Scene,
        cfg: &PathSettings,
        b: &mut Batch,
        ids: &[u32; W],
        live: usize,
        mat: Material<'_>,
        gather: &mut Gather<W>,
        tail: &mut impl Tail,
    ) {
        // 1. The surfaces, loaded 8-wide from the batch's rows; 2. the side test.
        let surface::x8::Prologue {
            surf,
            p,
            wi,
            front,
            bits: front_bits,
        } = prologue(avx, &b.surf, ids, live);

        // 3a. Each path's random numbers in the scalar renderer's order (`u_sel` and `u` when it
        // takes a light sample, then `u2`), 8-wide from the gathered PCG32 states where the
        // streams are plain (`kernels::draws`). A path that failed the side test draws nothing
        // (its lane is computed and dropped).
        let nee = cfg.strategy != Strategy::BsdfOnly && mat.smooth;
        let draws = Draws {
            light: nee,
            u1: false,
            u2: true,
        };
        let num = draw(avx, &mut b.sampler, ids, &front, draws);

        // 3b. The reflectances and throughputs, then the light points lane by lane in each
        // path's order (completed 8-wide by the shared gather of `kernels::light`). A constant
        // reflectance (`Texture::Constant`: its lookup reads nothing of the point) is splat and
        // the throughputs gathered, in every lane (a lane behind its surface takes them too; its
        // results are dropped, as in `vertex::x8::shade`); another texture is looked up lane by
        // lane on the interaction rebuilt from its row, each throughput read beside it.
        // (A `match`, not a closure: see `vertex::x8::scatter`.)
        let light_only = cfg.strategy == Strategy::LightOnly;
        gather.reset();
        let (refl8, tp8) = match mat.reflectance {
            Texture::Constant(c) => (
                V3::new(avx.splat(c.x), avx.splat(c.y), avx.splat(c.z)),
                avx.throughputs(&b.state, ids),
            ),
            _ => {
                let (mut refl, mut tp) = <(Cols3<W>, Cols3<W>)>::default();
                for (k, &i) in ids.iter().enumerate() {
                    let i = i as usize;
                    if !front[k] {
                        continue;
                    }
                    let si = b.surf.get(i);
                    refl.set(k, reflectance(scene, mat.reflectance, &si));
                    tp.set(k, b.state[i].throughput);
                }
                (refl.load(avx), tp.load(avx))
            }
        };
        if nee {
            let (u_sel, u) = (&num.u_sel, &num.u);
            gather.add_x8(avx, scene, mat.lights, light_only, front_bits, u_sel, u, &p);
        }

        // 4. The kernel.
        let lp = gather.finish(avx, scene, surf.p, &mut b.light_lanes);
        let lo = light(&surf, wi, refl8, tp8, &lp);
        let u2 = V2::new(avx.load(&num.u2[0]), avx.load(&num.u2[1]));
        let so = sample(&surf, wi, refl8, u2);

        // 5. Scatter back through the wrapper-chain driver's step 4 (`vertex::x8::scatter`):
        // under the `path` tail the light samples are stored and the vertices end in lanes
        // (`vertex::x8::advance`, bit for bit `PathState::advance`); under another tail each
        // lane's light sample, then its BSDF sample (weight ρ, η 1, not delta), in path order.
        let lo = LightCols::store(&lo);
        let so = SampleOut {
            ok: so.ok,
            wo: so.wo,
            pdf: so.pdf,
            weight: refl8,
            delta: avx.mask(&[false; W]),
            eta: avx.splat(1.0),
            o: so.o,
        };
        scatter(avx, b, ids, &front, &p, tp8, nee.then_some(&lo), &so, tail);
    }
}
