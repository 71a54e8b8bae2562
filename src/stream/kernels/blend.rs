//! The 8-wide `blendbsdf` kernel: what
//! [`PathState::scatter`](crate::integrator::path::PathState::scatter) does at a vertex whose
//! material is a `blendbsdf` (bare or under `twosided` with one BSDF for both sides) of two
//! children that the wrapper-chain driver has lane forms for ([`super::conductor`]: a `diffuse`,
//! `roughconductor`, `conductor`, `plastic`, `roughplastic` or dielectric leaf, its parameters
//! constant or textured, bare or under `twosided`), for 8 paths at a time.
//!
//! The blend is the scalar model `bsdf::blend` in lanes, with the weight `w` looked up per lane
//! (`unit_weight` of the `weight` texture at the lookup `Scene::bsdf_root` picks, as
//! `Materials::build_at` does):
//! - eval and pdf ([`eval_pdf`]): both children's lane forms (each where some lane weighs it),
//!   combined per lane in the scalar order, `v = 0 + (1 − w)·f₀` where `w < 1`, then `v + w·f₁`
//!   where `w > 0` (the children's eval and pdf equal `(eval, pdf)` called apart,
//!   `Bsdf::eval_pdf`'s rule);
//! - sample ([`sample`]): the choice of the child is drawn by the driver lane by lane, and only
//!   in the lanes where `0 < w < 1` (a lane with w ∈ {0, 1} draws nothing, as the scalar
//!   `blend::sample`), then the chosen child's own numbers (`u1`, `u2`, each where that child
//!   draws it); each child chosen by some lane samples from those numbers and each lane keeps
//!   its chosen child's sample; where it is smooth (not through a delta lobe) and `0 < w < 1` the
//!   full mixture's eval and pdf replace its weight (`eval / pdf`) and density, and the lane
//!   fails where that pdf is not positive. `Bsdf::sample`'s guard runs at every node.
//!
//! The children need no random numbers to evaluate (no random-walk model has a lane form), so
//! `eval`'s sampler argument draws nothing. The per-vertex sequence (surface load, random
//! numbers, light points, scatter back) is [`super::vertex`]'s, here with the blend's weight and
//! each child's parameters gathered per lane; the paths show in `LaneCounters::blend_lanes`.

use super::conductor::{self, Material as Chain, Params, Wrap, MAX_WRAPS};
use super::diffuse::{light_direction, light_out, LightOut, LightPoint, Surface};
use super::vertex::SampleOut;
use crate::bsdf::lanes::LaneBsdfSample;
use crate::lane::vec::{V2, V3};
use crate::lane::{Lane, LaneMask};
use crate::material::{MatId, MaterialNode, Materials, TexId};

/// A `blendbsdf` material the kernel shades.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Material {
    /// Under `twosided` (one BSDF for both sides).
    pub twosided: bool,
    /// The weight's texture (w, the second child's weight, clamped per lane by `unit_weight`).
    pub weight: TexId,
    /// The children (weights 1 − w and w), as wrapper chains of `twosided` only.
    pub children: [Chain; 2],
    /// It takes light samples (`Lobes::is_smooth` of the blend).
    pub smooth: bool,
}

impl Material {
    /// The kernel material of material `m`, if it is a blend that qualifies (module doc).
    pub(crate) fn of(materials: &Materials, m: MatId) -> Option<Material> {
        let nodes = materials.nodes();
        let (twosided, id) = match nodes[m as usize] {
            MaterialNode::TwoSided { front, back } if front == back => (true, front),
            _ => (false, m),
        };
        let MaterialNode::Blend {
            weight,
            bsdf0,
            bsdf1,
        } = nodes[id as usize]
        else {
            return None;
        };
        let child = |c: MatId| {
            Chain::of(materials, c).filter(|ch| ch.wraps().iter().all(|w| *w == Wrap::TwoSided))
        };
        Some(Material {
            twosided,
            weight,
            children: [child(bsdf0)?, child(bsdf1)?],
            smooth: materials.lobes(m).is_smooth(),
        })
    }
}

/// `twosided`'s mirror through the surface.
#[inline(always)]
fn flip<L: Lane>(w: V3<L>) -> V3<L> {
    V3::new(w.x, w.y, -w.z)
}

/// The children's normals: none (their chains hold no perturbed-frame wrapper).
#[inline(always)]
fn no_normals<L: Lane>(like: L) -> [V3<L>; MAX_WRAPS] {
    [V3::splat(like, 0.0, 0.0, 1.0); MAX_WRAPS]
}

/// One child's `conductor::eval_pdf` in a function of its own ([`Lane::outlined`]): the blend
/// kernel would inline it four times (two children, in the light query and in the mixed
/// sample), and LLVM's SROA took minutes over the one function that made.
#[inline(always)]
fn child_eval_pdf<L: Lane>(ch: &Chain, p: &Params<L>, wi: V3<L>, wo: V3<L>) -> (V3<L>, L) {
    wi.z.outlined(
        #[inline(always)]
        || conductor::eval_pdf::<L, false>(ch, &no_normals(wi.z), p, wi, wo),
    )
}

/// One child's `conductor::sample` in a function of its own (as [`child_eval_pdf`]).
#[inline(always)]
fn child_sample<L: Lane>(
    ch: &Chain,
    p: &Params<L>,
    wi: V3<L>,
    u1: L,
    u2: V2<L>,
) -> (LaneBsdfSample<L>, L::Mask, L) {
    wi.z.outlined(
        #[inline(always)]
        || conductor::sample::<L, false>(ch, &no_normals(wi.z), p, wi, u1, u2),
    )
}

/// `blend::eval` and `blend::pdf` below the outer `twosided`: per lane `0 + (1 − w)·x₀` where
/// `w < 1`, then `+ w·x₁` where `w > 0`.
#[inline(always)]
fn mix<L: Lane>(mat: &Material, p: &[Params<L>; 2], w: L, wi: V3<L>, wo: V3<L>) -> (V3<L>, L) {
    let k = |c: f32| wi.z.splat(c);
    let (zero, one) = (k(0.0), k(1.0));
    let (has0, has1) = (w.lt(one), w.gt(zero));
    let z3 = V3::splat(zero, 0.0, 0.0, 0.0);
    // A child no lane weighs is not evaluated (its lanes are not read below).
    let (f0, p0) = if has0.any() {
        child_eval_pdf(&mat.children[0], &p[0], wi, wo)
    } else {
        (z3, zero)
    };
    let (f1, p1) = if has1.any() {
        child_eval_pdf(&mat.children[1], &p[1], wi, wo)
    } else {
        (z3, zero)
    };
    let a = one - w;
    let f = V3::select(has0, z3 + f0.scale(a), z3);
    let f = V3::select(has1, f + f1.scale(w), f);
    let pdf = L::select(has0, zero + a * p0, zero);
    let pdf = L::select(has1, pdf + w * p1, pdf);
    (f, pdf)
}

/// `f · |cos θo|` and the density of the blend (with its outer `twosided`) for local `wi`, `wo`;
/// `p` the children's parameters, `w` the weight per lane.
#[inline(always)]
pub(crate) fn eval_pdf<L: Lane>(
    mat: &Material,
    p: &[Params<L>; 2],
    w: L,
    wi: V3<L>,
    wo: V3<L>,
) -> (V3<L>, L) {
    let (mut wi, mut wo) = (wi, wo);
    if mat.twosided {
        let back = !wi.z.ge(wi.z.splat(0.0));
        wi = V3::select(back, flip(wi), wi);
        wo = V3::select(back, flip(wo), wo);
    }
    mix(mat, p, w, wi, wo)
}

/// The blend's BSDF sample from local `wi`: `pick1` the lanes that chose the second child, `u1`
/// and `u2` each lane's numbers for its chosen child (see the module doc). Returns the sample,
/// the lanes through a delta lobe and each lane's η, as [`conductor::sample`].
#[inline(always)]
pub(crate) fn sample<L: Lane>(
    mat: &Material,
    p: &[Params<L>; 2],
    w: L,
    pick1: L::Mask,
    wi: V3<L>,
    u1: L,
    u2: V2<L>,
) -> (LaneBsdfSample<L>, L::Mask, L) {
    let k = |c: f32| wi.z.splat(c);
    let mut wi = wi;
    let back = !wi.z.ge(k(0.0));
    if mat.twosided {
        wi = V3::select(back, flip(wi), wi);
    }
    // Each child samples where some lane chose it (the other lanes of its sample are dropped).
    let skip = || {
        let none = k(0.0).ne(k(0.0));
        let z3 = V3::splat(k(0.0), 0.0, 0.0, 0.0);
        let s = LaneBsdfSample {
            ok: none,
            wo: z3,
            pdf: k(0.0),
            weight: z3,
        };
        (s, none, k(1.0))
    };
    let (s0, d0, e0) = if (!pick1).any() {
        child_sample(&mat.children[0], &p[0], wi, u1, u2)
    } else {
        skip()
    };
    let (s1, d1, e1) = if pick1.any() {
        child_sample(&mat.children[1], &p[1], wi, u1, u2)
    } else {
        skip()
    };
    let sel = |a: L, b: L| L::select(pick1, b, a);
    let mut s = LaneBsdfSample {
        ok: (pick1 & s1.ok) | (!pick1 & s0.ok),
        wo: V3::select(pick1, s1.wo, s0.wo),
        pdf: sel(s0.pdf, s1.pdf),
        weight: V3::select(pick1, s1.weight, s0.weight),
    };
    let delta = (pick1 & d1) | (!pick1 & d0);
    let eta = sel(e0, e1);
    // A smooth sample of a true mixture: the full mixture's eval and pdf.
    let mixed = !delta & w.gt(k(0.0)) & w.lt(k(1.0));
    if mixed.any() {
        let (f, pdf) = mix(mat, p, w, wi, s.wo);
        s.ok = s.ok & (!mixed | pdf.gt(k(0.0)));
        s.weight = V3::select(mixed, f.div_by(pdf), s.weight);
        s.pdf = L::select(mixed, pdf, s.pdf);
    }
    s.ok = s.ok & conductor::valid(&s);
    if mat.twosided {
        s.wo = V3::select(back, flip(s.wo), s.wo);
        s.ok = s.ok & conductor::valid(&s);
    }
    (s, delta, eta)
}

/// Next-event estimation at the blend (as [`super::vertex::light`] at a chain).
#[inline(always)]
pub(crate) fn light<L: Lane>(
    s: &Surface<L>,
    wi: V3<L>,
    mat: &Material,
    p: &[Params<L>; 2],
    w: L,
    throughput: V3<L>,
    lp: &LightPoint<L>,
) -> LightOut<L> {
    let (wo, consistent) = light_direction(s, lp);
    let (f, bsdf_pdf) = eval_pdf(mat, p, w, wi, wo);
    light_out(s, throughput, lp, f, bsdf_pdf, consistent)
}

/// The blend's BSDF sample, `SurfaceBsdf::sample`'s side test and
/// `SurfaceInteraction::spawn_ray` (as [`super::vertex::sample`] for a chain).
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample_out<L: Lane>(
    s: &Surface<L>,
    wi: V3<L>,
    mat: &Material,
    p: &[Params<L>; 2],
    w: L,
    pick1: L::Mask,
    u1: L,
    u2: V2<L>,
) -> SampleOut<L> {
    let (bs, delta, eta) = sample(mat, p, w, pick1, wi, u1, u2);
    SampleOut::at(s, wi, &bs, delta, eta)
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod x8 {
    use super::*;
    use crate::integrator::{PathSettings, Strategy};
    use crate::lane::{Avx2, F32x8};
    use crate::material::unit_weight;
    use crate::scene::Scene;
    use crate::stream::batch::Batch;
    use crate::stream::kernels::diffuse::reflectance;
    use crate::stream::kernels::draws::{x8::draw, Draws};
    use crate::stream::kernels::light::x8::{Cols3, Gather};
    use crate::stream::kernels::light::LaneLight;
    use crate::stream::kernels::surface;
    use crate::stream::kernels::tail::Tail;
    use crate::stream::kernels::vertex::x8::{scatter, LightCols};
    use crate::stream::kernels::vertex::{leaf_values, scalar_at};

    /// The chunk width: the lanes of [`F32x8`].
    const W: usize = <F32x8 as Lane>::WIDTH;

    /// Shades the paths `sorted[chunks]` (runs of [`W`], all at a surface of the blend `mat`)
    /// with [`shade`]. Call inside [`Avx2::run`].
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn shade_run(
        avx: Avx2,
        scene: &Scene,
        cfg: &PathSettings,
        b: &mut Batch,
        chunks: impl Iterator<Item = usize>,
        mat: &Material,
        lights: &[Option<LaneLight>],
        tail: &mut impl Tail,
    ) {
        let mut gather = Gather::new();
        let like = avx.splat(0.0);
        let base = mat.children.map(|c| c.params(like));
        for c in chunks {
            let ids: [u32; W] = b.sorted[c..c + W].try_into().expect("a chunk of ids");
            shade(
                avx,
                scene,
                cfg,
                b,
                &ids,
                mat,
                &base,
                lights,
                &mut gather,
                tail,
            );
        }
    }

    /// Shades the paths `ids` (all at a surface of the blend `mat`) as `PathState::scatter`
    /// would, one after the other (the steps of [`crate::stream::kernels::vertex`]); `base` are
    /// the children's constant [`Params`]. Call inside [`Avx2::run`].
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn shade(
        avx: Avx2,
        scene: &Scene,
        cfg: &PathSettings,
        b: &mut Batch,
        ids: &[u32; W],
        mat: &Material,
        base: &[Params<F32x8>; 2],
        lights: &[Option<LaneLight>],
        gather: &mut Gather,
        tail: &mut impl Tail,
    ) {
        // 1. The surfaces, their points, the incident direction and the side test.
        let surface::x8::Prologue {
            surf,
            p,
            wi,
            front,
            bits: front_bits,
        } = surface::x8::prologue(avx, &b.surf, ids);

        // 2. The light sample's numbers 8-wide; per lane the weight, the children's
        // parameters, the light point and the BSDF's numbers (the choice where 0 < w < 1, then
        // the chosen child's), in each path's order.
        let nee = cfg.strategy != Strategy::BsdfOnly && mat.smooth;
        let draws = Draws {
            light: nee,
            u1: false,
            u2: false,
        };
        let num = draw(avx, &mut b.sampler, ids, &front, draws);
        let weight_tex = &scene.materials.textures[mat.weight as usize];
        let (mut w, mut pick1) = ([0.0f32; W], [false; W]);
        let (mut u1, mut u2) = ([0.0f32; W], [[0.0f32; W]; 2]);
        let mut c0 = [Cols3::default(); 2];
        let mut c1 = [Cols3::default(); 2];
        let mut au = [[0.0f32; W]; 2];
        let mut av = [[0.0f32; W]; 2];
        let mut tp = Cols3::default();
        let light_only = cfg.strategy == Strategy::LightOnly;
        gather.reset();
        for (k, &i) in ids.iter().enumerate() {
            let i = i as usize;
            if !front[k] {
                continue;
            }
            let si = b.surf.get(i);
            w[k] = unit_weight(scalar_at(scene, weight_tex, &si));
            for (c, ch) in mat.children.iter().enumerate() {
                if let Some(t) = ch.reflectance() {
                    c0[c].set(
                        k,
                        reflectance(scene, &scene.materials.textures[t as usize], &si),
                    );
                }
                if ch.n_slots > 0 {
                    let v = leaf_values(scene, ch, &si);
                    c0[c].set(k, v.0);
                    c1[c].set(k, v.1);
                    (au[c][k], av[c][k]) = (v.2, v.3);
                }
            }
            tp.set(k, b.state[i].throughput);
            // bsdf::blend::sample: the choice, then the chosen child's numbers.
            let s = &mut b.sampler.at(i);
            pick1[k] = crate::bsdf::blend::picks_second(w[k], s);
            let ch = &mat.children[usize::from(pick1[k])];
            if ch.draws_u1() {
                u1[k] = s.next_1d();
            }
            if ch.draws_u2() {
                let u = s.next_2d();
                (u2[0][k], u2[1][k]) = (u.x, u.y);
            }
        }

        // 3. The kernel.
        let mut params = *base;
        for (c, ch) in mat.children.iter().enumerate() {
            if ch.per_lane() {
                params[c] = Params {
                    c0: c0[c].load(avx),
                    c1: c1[c].load(avx),
                    alpha_u: avx.load(&au[c]),
                    alpha_v: avx.load(&av[c]),
                    ..base[c]
                };
            }
        }
        let w8 = avx.load(&w);
        let lo = if nee {
            let (u_sel, u) = (&num.u_sel, &num.u);
            gather.add_x8(avx, scene, lights, light_only, front_bits, u_sel, u, &p);
            let lp = gather.finish(avx, scene, surf.p, &mut b.light_lanes);
            let lo = light(&surf, wi, mat, &params, w8, tp.load(avx), &lp);
            Some(LightCols::store(&lo))
        } else {
            None
        };
        let so = sample_out(
            &surf,
            wi,
            mat,
            &params,
            w8,
            avx.mask(&pick1),
            avx.load(&u1),
            V2::new(avx.load(&u2[0]), avx.load(&u2[1])),
        );

        // 4. Scatter back.
        scatter(
            avx,
            b,
            ids,
            &front,
            &p,
            tp.load(avx),
            lo.as_ref(),
            &so,
            tail,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::lanes::testing::*;
    use crate::bsdf::{BsdfArena, BsdfContext, BsdfNode, Lobes};
    use crate::math::Pcg32;
    use crate::sampler::Sampler;
    use crate::stream::kernels::conductor::tests::{
        case_values, leaves, material, params1, rho_of,
    };
    use crate::stream::kernels::conductor::Leaf;
    use glam::{Vec2, Vec3};

    /// A blend weight for a test case: 0, 1 or between (as `unit_weight` leaves it).
    fn weight_of(wi: Vec3, wo: Vec3) -> f32 {
        let q = (wi.x + wo.y).abs();
        if q < 0.2 {
            0.0
        } else if q > 0.8 {
            1.0
        } else {
            q
        }
    }

    /// The blend `mat` of the leaves `leaf`, with weight `w` (a `diffuse` leaf's reflectance
    /// `rho`) as a scalar BSDF tree; returns its root.
    fn tree(arena: &mut BsdfArena, mat: &Material, leaf: [Leaf; 2], rho: Vec3, w: f32) -> u32 {
        arena.clear();
        let mut ids = [0; 2];
        for (c, ch) in mat.children.iter().enumerate() {
            let mut id = arena.push(leaf[c].node(rho));
            for _ in ch.wraps() {
                id = arena.push(BsdfNode::TwoSided {
                    front: id,
                    back: id,
                });
            }
            ids[c] = id;
        }
        let mut id = arena.push(BsdfNode::Blend(crate::bsdf::Blend {
            bsdf0: ids[0],
            bsdf1: ids[1],
            weight: w,
        }));
        if mat.twosided {
            id = arena.push(BsdfNode::TwoSided {
                front: id,
                back: id,
            });
        }
        id
    }

    /// At width 1 the kernel's blend gives the scalar tree's `eval_pdf` and `sample` bit for
    /// bit (from the numbers the driver draws: the choice where 0 < w < 1, then the chosen
    /// child's), for every pair of leaves, with and without `twosided` around the blend and
    /// around a child; at width 8 width 1's, lane by lane.
    #[test]
    fn kernel_blend_equals_the_scalar_tree() {
        let mut r = Pcg32::new(33, 4);
        let cases: Vec<(Vec3, Vec3)> = (0..96)
            .map(|_| (direction(&mut r), direction(&mut r)))
            .collect();
        let mut arena = BsdfArena::new();
        let ctx = BsdfContext::default();
        let (mut nonzero, mut sampled, mut mixed) = (0, 0, 0);
        let ts: &[Wrap] = &[Wrap::TwoSided];
        for twosided in [false, true] {
            for (w0, w1) in [(&[][..], &[][..]), (ts, &[][..]), (&[][..], ts)] {
                for l0 in leaves() {
                    for l1 in leaves() {
                        let mat = Material {
                            twosided,
                            weight: 0,
                            children: [material(w0, l0), material(w1, l1)],
                            smooth: true,
                        };
                        let mut ones = Vec::with_capacity(cases.len());
                        for (c, &(wi, wo)) in cases.iter().enumerate() {
                            let (rho, w) = (rho_of(wi, wo), weight_of(wi, wo));
                            let root = tree(&mut arena, &mat, [l0, l1], rho, w);
                            let bsdf = arena.bsdf(root);
                            let mut sampler = Sampler::from_seed(c as u64, 9);
                            let (f0, p0) = bsdf.eval_pdf(&ctx, wi, wo, &mut sampler);
                            let p = [params1(case_values(&l0, rho), 1.0, false), {
                                params1(case_values(&l1, rho), 1.0, false)
                            }];
                            let (f1, q1) = eval_pdf(&mat, &p, w, V3::from(wi), V3::from(wo));
                            assert!(same3(f0, f1.into()) && same(p0, q1), "{mat:?} {wi} {wo}");
                            nonzero += (f0 != Vec3::ZERO) as u32;
                            // The driver's draws: the choice, then the chosen child's numbers.
                            let mut draws = sampler.clone();
                            let pick1 = if w <= 0.0 {
                                false
                            } else if w >= 1.0 {
                                true
                            } else {
                                draws.next_1d() < w
                            };
                            let ch = &mat.children[usize::from(pick1)];
                            let u1 = if ch.draws_u1() { draws.next_1d() } else { 0.0 };
                            let u2 = if ch.draws_u2() {
                                draws.next_2d()
                            } else {
                                Vec2::ZERO
                            };
                            let s0 = bsdf.sample(&ctx, wi, &mut sampler);
                            assert_eq!(sampler.next_1d(), draws.next_1d(), "the draws' order");
                            let (s1, d1, e1) =
                                sample(&mat, &p, w, pick1, V3::from(wi), u1, V2::from(u2));
                            assert_eq!(s0.is_some(), s1.ok, "{mat:?} {wi} {w}");
                            if let Some(s0) = s0 {
                                sampled += 1;
                                mixed += (w > 0.0 && w < 1.0) as u32;
                                assert_eq!(s0.lobe.intersects(Lobes::DELTA), d1, "{mat:?}");
                                assert!(same(s0.eta, e1), "{mat:?} {wi}");
                                assert!(same3(s0.wo, s1.wo.into()) && same(s0.pdf, s1.pdf));
                                assert!(same3(s0.weight, s1.weight.into()), "{mat:?} {wi}");
                            }
                            ones.push((p, w, pick1, u1, u2));
                        }
                        #[cfg(target_arch = "x86_64")]
                        if let Some(avx) = crate::lane::Avx2::detect() {
                            width8(avx, &mat, &cases, &ones);
                        }
                    }
                }
            }
        }
        // Not vacuous: many pairs carry light, many samples succeed, many of a true mixture.
        assert!(
            nonzero > 20_000 && sampled > 40_000 && mixed > 15_000,
            "{nonzero} {sampled} {mixed}"
        );
    }

    /// Per case: the children's parameters, the weight, the choice and the numbers.
    type Case = ([Params<f32>; 2], f32, bool, f32, Vec2);

    /// The blend 8-wide on the cases 8 at a time equals width 1 lane by lane.
    #[cfg(target_arch = "x86_64")]
    fn width8(avx: crate::lane::Avx2, mat: &Material, cases: &[(Vec3, Vec3)], ones: &[Case]) {
        for (c, o) in cases.chunks_exact(8).zip(ones.chunks_exact(8)) {
            let wi: [Vec3; 8] = std::array::from_fn(|k| c[k].0);
            let wo: [Vec3; 8] = std::array::from_fn(|k| c[k].1);
            let col = |f: &dyn Fn(&Params<f32>) -> V3<f32>, j: usize| -> [Vec3; 8] {
                std::array::from_fn(|k| f(&o[k].0[j]).into())
            };
            let sc = |f: &dyn Fn(&Params<f32>) -> f32, j: usize| -> [f32; 8] {
                std::array::from_fn(|k| f(&o[k].0[j]))
            };
            let w: [f32; 8] = std::array::from_fn(|k| o[k].1);
            let pick: [bool; 8] = std::array::from_fn(|k| o[k].2);
            let u1: [f32; 8] = std::array::from_fn(|k| o[k].3);
            let u2: [Vec2; 8] = std::array::from_fn(|k| o[k].4);
            let (f, p, (s, d, e)) = avx.run(|| {
                let p8 = [0, 1].map(|j| Params {
                    c0: load3(avx, &col(&|p| p.c0, j)),
                    c1: load3(avx, &col(&|p| p.c1, j)),
                    alpha_u: avx.load(&sc(&|p| p.alpha_u, j)),
                    alpha_v: avx.load(&sc(&|p| p.alpha_v, j)),
                    ..mat.children[j].params(avx.splat(0.0))
                });
                let (wi8, wo8, w8) = (load3(avx, &wi), load3(avx, &wo), avx.load(&w));
                let (f, p) = eval_pdf(mat, &p8, w8, wi8, wo8);
                let pick = avx.mask(&pick);
                let u = (avx.load(&u1), load2(avx, &u2));
                (f, p, sample(mat, &p8, w8, pick, wi8, u.0, u.1))
            });
            let (ok, d) = (s.ok.to_array(), d.to_array());
            for k in 0..8 {
                let (wi1, wo1) = (V3::from(wi[k]), V3::from(wo[k]));
                let (p1, w1, pick1, u1, u2) = o[k];
                let (f1, q1) = eval_pdf(mat, &p1, w1, wi1, wo1);
                assert!(same3(lane3(f, k), f1.into()) && same(p.lane(k), q1));
                let (s1, d1, e1) = sample(mat, &p1, w1, pick1, wi1, u1, V2::from(u2));
                assert_eq!((ok[k], d[k]), (s1.ok, d1), "{mat:?}");
                assert!(same(e.lane(k), e1));
                assert!(same3(lane3(s.wo, k), s1.wo.into()));
                assert!(same(s.pdf.lane(k), s1.pdf));
                assert!(same3(lane3(s.weight, k), s1.weight.into()));
            }
        }
    }
}
