//! The 8-wide driver of the [`super::conductor`] kernels: one path vertex for 8 paths, in the
//! steps of the `diffuse` kernel (`super::diffuse`, whose module doc describes them):
//! 1. load the surfaces 8-wide from the batch's columns ([`super::surface`]) and run
//!    `SurfaceBsdf::new`'s side test in lanes ([`super::diffuse::incident`]);
//! 2. the random numbers in each path's order, 8-wide from the gathered PCG32 states
//!    ([`super::draws`]): the light selection `u_sel` and light point `u` (when the material
//!    takes light samples), the BSDF's `u1` (plastic leaves) and `u2` (all but the smooth
//!    conductor); lane by lane: the normal maps' texture lookups, the light points through the
//!    shared gather ([`super::light::x8::Gather`]: area lights of a constant radiance on
//!    triangle meshes, rectangles and spheres 8-wide, every other emitter lane by lane);
//! 3. 8-wide: the BSDF value and density toward the light point, the power heuristic, the
//!    contribution and shadow ray ([`light`]); the BSDF sample and next ray;
//! 4. scatter back lane by lane: the pending light sample, then `PathState::advance` (the
//!    throughput update and Russian roulette of the scalar code).

use super::conductor::{self, Down, Leaf, Material, Normal, Params, Wrap, MAX_WRAPS};
use super::diffuse::{light_direction, light_out_from, reflectance, LightOut, LightPoint, Surface};
use super::ray::{AtPoint, Offsets, Origin};
use crate::bsdf::bumpmap;
use crate::geometry::SurfaceInteraction;
use crate::lane::vec::V3;
use crate::lane::Lane;
use crate::material::{unit_weight, TexId};
use crate::scene::Scene;
use crate::texture::Texture;
use glam::Vec3;

/// Next-event estimation at the material's BSDF: `nee::prepare_light` after its call to
/// `sample_emitter` (`SurfaceBsdf::eval_pdf`'s side test, the BSDF toward the light point, the
/// zero test), and the MIS-weighted contribution and shadow ray of `PathState::scatter`, in
/// the operations of `diffuse::light`. `dn` is the incident direction's way down the wrappers
/// (`conductor::down`, shared with [`sample`]); `p` holds the leaf's parameters per lane;
/// `offs` the surface point's two ray origins (shared with [`sample`]); `MASK`: as in
/// [`conductor::eval_pdf`].
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn light<L: Lane, const MASK: bool>(
    s: &Surface<L>,
    offs: &Offsets<L>,
    dn: &Down<L>,
    mat: &Material,
    p: &Params<L>,
    throughput: V3<L>,
    lp: &LightPoint<L>,
) -> LightOut<L> {
    let (wo, consistent) = light_direction(s, lp);
    let (f, bsdf_pdf) = conductor::eval_pdf_from::<L, MASK>(mat, p, dn, wo);
    light_out_from(s, offs, throughput, lp, f, bsdf_pdf, consistent)
}

/// The BSDF sample of [`sample`]: where it succeeded (`SurfaceBsdf::sample`'s side test
/// included), the world direction, density, weight, whether through a delta lobe, and the next
/// ray's origin.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SampleOut<L: Lane> {
    pub ok: L::Mask,
    pub wo: V3<L>,
    pub pdf: L,
    pub weight: V3<L>,
    pub delta: L::Mask,
    /// The relative index of the crossing (1 but where a dielectric refracted).
    pub eta: L,
    pub o: V3<L>,
}

/// The material's BSDF sample (`Bsdf::sample`), `SurfaceBsdf::sample`'s side test and
/// `SurfaceInteraction::spawn_ray`; `wi` is the shading frame's incident direction and `dn`
/// its way down the wrappers (`conductor::down`); `offs` the point's ray origins where the
/// light sample computed them (else the origin is offset here). `MASK` as in
/// [`conductor::eval_pdf`].
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub(crate) fn sample<L: Lane, const MASK: bool>(
    s: &Surface<L>,
    offs: Option<&Offsets<L>>,
    wi: V3<L>,
    dn: &Down<L>,
    mat: &Material,
    p: &Params<L>,
    u1: L,
    u2: crate::lane::vec::V2<L>,
) -> SampleOut<L> {
    let (bs, delta, eta) = conductor::sample_from::<L, MASK>(mat, p, dn, u1, u2);
    match offs {
        Some(offs) => SampleOut::at_with(s, offs, wi, &bs, delta, eta),
        None => SampleOut::at(s, wi, &bs, delta, eta),
    }
}

impl<L: Lane> SampleOut<L> {
    /// A local BSDF sample `bs` (with its delta lanes and η) at surface `s` seen from local
    /// `wi`: `SurfaceBsdf::sample`'s side test and `SurfaceInteraction::spawn_ray` (shared by
    /// [`sample`] and the blend kernel's `sample_out`).
    #[inline(always)]
    pub(crate) fn at(
        s: &Surface<L>,
        wi: V3<L>,
        bs: &crate::bsdf::lanes::LaneBsdfSample<L>,
        delta: L::Mask,
        eta: L,
    ) -> SampleOut<L> {
        let at = AtPoint { p: s.p, n: s.ng };
        Self::at_with(s, &at, wi, bs, delta, eta)
    }

    /// [`SampleOut::at`] with the origin from `origin` (the point's shared [`Offsets`] or
    /// one offset per ray: the same value).
    #[inline(always)]
    pub(crate) fn at_with<O: Origin<L>>(
        s: &Surface<L>,
        origin: &O,
        wi: V3<L>,
        bs: &crate::bsdf::lanes::LaneBsdfSample<L>,
        delta: L::Mask,
        eta: L,
    ) -> SampleOut<L> {
        let wo_world = s.frame.to_world(bs.wo);
        let consistent = (wo_world.dot(s.ng) * bs.wo.z).gt(wi.z.splat(0.0));
        SampleOut {
            ok: bs.ok & consistent,
            wo: wo_world,
            pdf: bs.pdf,
            weight: bs.weight,
            delta,
            eta,
            o: origin.toward(wo_world),
        }
    }
}

/// The perturbed-frame wrappers' normal sources of `mat`, per wrapper (`None` for `twosided`).
fn normal_sources(mat: &Material) -> [Option<Normal>; MAX_WRAPS] {
    let mut t = [None; MAX_WRAPS];
    for (j, w) in mat.wraps().iter().enumerate() {
        if let Wrap::NormalMap { normal, .. } = *w {
            t[j] = Some(normal);
        }
    }
    t
}

/// The perturbed-frame wrappers' normal sources of a material, split once per run of it
/// (`vertex::x8::shade_run`): normal maps of bitmaps (looked up 8-wide at the rows' uvs) and
/// the others (looked up lane by lane), per wrapper.
pub(crate) struct Maps<'a> {
    pub bitmap: [Option<&'a crate::texture::BitmapTexture>; MAX_WRAPS],
    pub lane: [Option<Normal>; MAX_WRAPS],
    /// Some wrapper's normal is looked up lane by lane.
    pub any_lane: bool,
}

impl<'a> Maps<'a> {
    pub(crate) fn new(scene: &'a Scene, mat: &Material) -> Maps<'a> {
        let mut m = Maps {
            bitmap: [None; MAX_WRAPS],
            lane: normal_sources(mat),
            any_lane: false,
        };
        for (j, n) in m.lane.iter_mut().enumerate() {
            let Some(Normal::Map(t)) = *n else { continue };
            if let Some(bm) = scene.materials.textures[t as usize].as_bitmap() {
                (m.bitmap[j], *n) = (Some(bm), None);
            }
        }
        m.any_lane = m.lane.iter().any(Option::is_some);
        m
    }
}

/// The normal (shading-frame coordinates) of a perturbed-frame wrapper at `si`, as
/// `Materials::build_at` computes it: 2·rgb − 1 of a normal map, or the bump-mapped normal of
/// `scale` times the height's uv gradient (`bsdf::bumpmap::perturbed_normal`). Bump maps take
/// the driver's `FULL` instance (`Material::full`): without it the interaction's unused fields
/// need not be rebuilt (+69 instructions per sample on metal_plastic when they were).
#[inline(always)]
fn wrapper_normal<const FULL: bool>(
    scene: &Scene,
    normal: Normal,
    si: &SurfaceInteraction,
) -> Vec3 {
    let tex = |t: TexId| &scene.materials.textures[t as usize];
    match normal {
        Normal::Map(t) => 2.0 * reflectance(scene, tex(t), si) - Vec3::ONE,
        Normal::Bump { height, scale } if FULL => {
            bumpmap::perturbed_normal(si, scale * tex(height).eval_1_grad(si.uv))
        }
        Normal::Bump { .. } => unreachable!("a bump map takes the driver's full instance"),
    }
}

/// A scalar texture's value at `si` (`eval_1`, a `mask`'s opacity), at the lookup
/// `Scene::bsdf_root` picks.
#[inline(always)]
pub(crate) fn scalar_at(scene: &Scene, tex: &Texture, si: &SurfaceInteraction) -> f32 {
    let shape = si.shape as usize;
    if scene.shape_reads_mesh[shape] {
        tex.eval_1(crate::texture::TexPoint::on_shape(si, &scene.shapes[shape]))
    } else {
        tex.eval_1(si.uv)
    }
}

/// The parameters of a textured leaf at `si` ([`Params`]' values): its template patched as
/// `Materials::build_at` patches a leaf, at the lookup `Scene::bsdf_root` picks.
pub(crate) fn leaf_values(
    scene: &Scene,
    mat: &Material,
    si: &SurfaceInteraction,
) -> (Vec3, Vec3, f32, f32) {
    let mut node = mat.leaf.node(Vec3::ZERO);
    let (m, shape) = (&scene.materials, si.shape as usize);
    if scene.shape_reads_mesh[shape] {
        let at = crate::texture::TexPoint::on_shape(si, &scene.shapes[shape]);
        m.patch_leaf(&mut node, mat.slots(), at);
    } else {
        m.patch_leaf(&mut node, mat.slots(), si.uv);
    }
    Leaf::of(&node).unwrap_or(mat.leaf).values()
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod x8 {
    use super::*;
    use crate::geometry::Ray;
    use crate::integrator::path::advance_lanes;
    use crate::integrator::{PathSettings, Strategy};
    use crate::lane::vec::V2;
    use crate::lane::{LaneI32, ToArray, Wide};
    use crate::stream::batch::Batch;
    use crate::stream::kernels::draws::{x8::draw, Draws};
    use crate::stream::kernels::light::x8::{Cols3, Gather};
    use crate::stream::kernels::light::LaneLight;
    use crate::stream::kernels::ray::RayRows;
    use crate::stream::kernels::surface;
    use crate::stream::kernels::tail::{Sampled, Tail};

    /// Shades the paths `sorted[run]` (all at a surface of material `mat`) with [`shade`], `W`
    /// at a time, then the last `run.len() % W` as one padded chunk ([`padded`]) when there
    /// are at least `pad_min` of them; returns where it stopped (the rest is left to the
    /// 1-lane code). The instance for `mat` is picked once here: whether the leaf's parameters
    /// differ per lane (`Material::per_lane`; else its constant [`Params`] are built once,
    /// from the template) and whether the chain needs the full instance (`Material::full`:
    /// textured leaf parameters, a `mask`, a `bumpmap`). `gather` is the caller's, made once
    /// per shading stage rather than per run (its light selection is the scene's: building it
    /// and its [`Gather`] per run cost ~10 instructions per sample on metal_plastic). Call
    /// inside [`crate::lane::Avx2::run`].
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn shade_run<T: RayRows<W>, const W: usize>(
        avx: T,
        scene: &Scene,
        cfg: &PathSettings,
        b: &mut Batch,
        run: std::ops::Range<usize>,
        pad_min: usize,
        mat: &Material,
        lights: &[Option<LaneLight>],
        gather: &mut Gather<W>,
        tail: &mut impl Tail,
    ) -> usize {
        let base = mat.params(avx.splat(0.0));
        let maps = Maps::new(scene, mat);
        macro_rules! run {
            ($per_lane:literal, $full:literal) => {{
                let mut chunks = Chunks::<W>::new(run, pad_min);
                while let Some((ids, live)) = chunks.next(&b.sorted) {
                    shade::<T, W, $per_lane, $full>(
                        avx, scene, cfg, b, &ids, live, mat, &base, &maps, lights, gather, tail,
                    );
                }
                chunks.at()
            }};
        }
        match (mat.per_lane(), mat.full()) {
            (false, false) => run!(false, false),
            (false, true) => run!(false, true),
            (true, false) => run!(true, false),
            (true, true) => run!(true, true),
        }
    }

    /// Shades the 8 paths `ids` (all at a surface of material `mat`) as `PathState::scatter`
    /// would, one after the other; sets their pending light samples, and their next rays and
    /// `alive` flags where they go on. Only the first `live` lanes are paths (a padded chunk,
    /// [`padded`]: the others repeat the last path's id and are treated as behind their
    /// surface, [`live_only`]: they draw, write and hand over nothing). `base` is `mat`'s
    /// constant [`Params`] (used as they are unless `PER_LANE`, `mat.per_lane()`); `FULL` is
    /// `mat.full()` (without it the chain has no textured leaf parameters, `mask` or
    /// `bumpmap`). Call inside [`crate::lane::Avx2::run`].
    #[inline(always)]
    // `!(u < o)`: `bsdf::mask::sample`'s test, negated as written there (u and o are never NaN).
    #[allow(clippy::too_many_arguments, clippy::neg_cmp_op_on_partial_ord)]
    pub(crate) fn shade<T: RayRows<W>, const W: usize, const PER_LANE: bool, const FULL: bool>(
        avx: T,
        scene: &Scene,
        cfg: &PathSettings,
        b: &mut Batch,
        ids: &[u32; W],
        live: usize,
        mat: &Material,
        base: &Params<T::F>,
        maps: &Maps,
        lights: &[Option<LaneLight>],
        gather: &mut Gather<W>,
        tail: &mut impl Tail,
    ) {
        debug_assert_eq!((PER_LANE, FULL), (mat.per_lane(), mat.full()));
        // 1. The surfaces, loaded 8-wide from the batch's columns; the side test.
        let surface::x8::Prologue {
            surf,
            p,
            wi,
            front,
            bits: front_bits,
        } = prologue(avx, &b.surf, ids, live);

        // 2. Random numbers, 8-wide from the gathered PCG32 states where the streams are plain
        // (`kernels::draws`); normal maps and light points lane by lane in each path's order.
        // Under a `mask` the BSDF's numbers depend on its choice: drawn lane by lane below.
        let nee = cfg.strategy != Strategy::BsdfOnly && mat.smooth;
        let mask_tex = mat
            .mask()
            .filter(|_| FULL)
            .map(|t| &scene.materials.textures[t as usize]);
        let draws = Draws {
            light: nee,
            u1: mat.draws_u1() && mask_tex.is_none(),
            u2: mat.draws_u2() && mask_tex.is_none(),
        };
        let mut num = draw(avx, &mut b.sampler, ids, &front, draws);
        let (mut opacity, mut through) = ([1.0f32; W], [false; W]);
        let mut normals = [Cols3::<W>::default(); MAX_WRAPS];
        // The leaf's parameters, looked up per lane as `Materials::build_at` does: a `diffuse`
        // leaf's reflectance, a textured leaf's slots.
        let rho_tex = mat
            .reflectance()
            .filter(|_| PER_LANE)
            .map(|t| &scene.materials.textures[t as usize]);
        let slots = FULL && mat.n_slots > 0;
        let (mut c0, mut c1) = <(Cols3<W>, Cols3<W>)>::default();
        let (mut au, mut av) = ([0.0f32; W], [0.0f32; W]);
        let mut tp = Cols3::<W>::default();
        let light_only = cfg.strategy == Strategy::LightOnly;
        gather.reset();
        // Normal maps of bitmaps: 8-wide lookups at the rows' uvs (a bitmap reads the uv
        // alone, whatever lookup `Scene::bsdf_root` picks); the other sources lane by lane.
        let (sources, mut normals_x8) = (&maps.lane, [None; MAX_WRAPS]);
        for (j, bm) in maps.bitmap.iter().enumerate() {
            let Some(bm) = bm else { continue };
            let rgb = bm.eval_x8(avx, surface::x8::uv(avx, &b.surf, ids));
            let (two, one) = (rgb.x.splat(2.0), rgb.x.splat(1.0));
            normals_x8[j] = Some(V3::new(
                two * rgb.x - one,
                two * rgb.y - one,
                two * rgb.z - one,
            ));
        }
        let textured = PER_LANE || FULL || maps.any_lane;
        // With lookups lane by lane: the throughputs read here, per lane. Without (so no
        // `mask` either, which takes `FULL`): the throughputs gathered in every lane below (a
        // lane behind its surface keeps its throughput too; its results are dropped). The
        // pending light samples are cleared or set by `scatter`.
        if textured {
            for (k, &i) in ids.iter().enumerate() {
                let i = i as usize;
                if !front[k] {
                    continue;
                }
                // The interaction, rebuilt from its row once, for the texture lookups.
                let si = &b.surf.get(i);
                for (j, n) in sources.iter().enumerate() {
                    if let Some(n) = n {
                        normals[j].set(k, wrapper_normal::<FULL>(scene, *n, si));
                    }
                }
                if let Some(t) = rho_tex {
                    c0.set(k, reflectance(scene, t, si));
                }
                if slots {
                    let v = leaf_values(scene, mat, si);
                    c0.set(k, v.0);
                    c1.set(k, v.1);
                    (au[k], av[k]) = (v.2, v.3);
                }
                tp.set(k, b.state[i].throughput);
                if let Some(t) = mask_tex {
                    // bsdf::mask::sample: the choice (drawn where 0 < opacity < 1), then the nested
                    // BSDF's numbers where it is chosen.
                    let o = unit_weight(scalar_at(scene, t, si));
                    let s = &mut b.sampler.at(i);
                    through[k] = if o <= 0.0 {
                        true
                    } else if o >= 1.0 {
                        false
                    } else {
                        !(s.next_1d() < o)
                    };
                    if !through[k] {
                        if mat.draws_u1() {
                            num.u1[k] = s.next_1d();
                        }
                        if mat.draws_u2() {
                            let u = s.next_2d();
                            (num.u2[0][k], num.u2[1][k]) = (u.x, u.y);
                        }
                    }
                    opacity[k] = o;
                }
            }
        }

        // 3. The kernel.
        let mut normals8 = normals.map(|c| c.load(avx));
        for (n8, x8) in normals8.iter_mut().zip(normals_x8) {
            if let Some(x8) = x8 {
                *n8 = x8;
            }
        }
        let mut params = if PER_LANE {
            Params {
                c0: c0.load(avx),
                c1: c1.load(avx),
                alpha_u: avx.load(&au),
                alpha_v: avx.load(&av),
                ..*base
            }
        } else {
            *base
        };
        if mask_tex.is_some() {
            params.opacity = avx.load(&opacity);
            params.through = avx.mask(&through);
        }
        // A block, not a closure: a closure would be compiled outside `Avx2::run`'s target
        // features and call every 8-wide operation out of line.
        // (Without lookups, one gather per component: 8 paths' 24 scalar copies through the
        // stack cost ~49 instructions a chunk on metal_plastic.)
        let tp8 = if textured {
            tp.load(avx)
        } else {
            avx.throughputs(&b.state, ids)
        };
        // The incident direction's way down the wrappers, once for the light sample and the
        // BSDF sample.
        let dn = conductor::down::<_, FULL>(mat, &normals8, wi);
        // The point's two ray origins, shared by the light sample's rays and the BSDF sample's
        // (without a light sample the one origin is offset alone).
        // (A plain `if`, not `bool::then`'s closure: see the block note above.)
        let offs = if nee {
            Some(Offsets::new(surf.p, surf.ng))
        } else {
            None
        };
        let lo = if let Some(offs) = &offs {
            let (u_sel, u) = (&num.u_sel, &num.u);
            gather.add_x8(avx, scene, lights, light_only, front_bits, u_sel, u, &p);
            let lp = gather.finish(avx, scene, surf.p, &mut b.light_lanes);
            let lo = light::<_, FULL>(&surf, offs, &dn, mat, &params, tp8, &lp);
            Some(LightCols::store(&lo))
        } else {
            None
        };
        let so = sample::<_, FULL>(
            &surf,
            offs.as_ref(),
            wi,
            &dn,
            mat,
            &params,
            avx.load(&num.u1),
            V2::new(avx.load(&num.u2[0]), avx.load(&num.u2[1])),
        );

        // 4. Scatter back.
        scatter(avx, b, ids, &front, &p, tp8, lo.as_ref(), &so, tail);
    }

    /// The fewest paths left at the end of a material's run (fewer than a chunk) that the
    /// kernels shade as one padded chunk rather than lane by lane in the 1-lane code. On
    /// metal_plastic a path through the 1-lane code cost ~2,060 instructions (`PathState::scatter`,
    /// inclusive), a chunk of 8 in the wrapper-chain driver ~4,340, of which ~140 per lane
    /// that does work: one path is cheaper alone, two and more in a padded chunk.
    pub(crate) const PAD_MIN: usize = 2;

    /// The ids of a padded chunk: the last `rest.len()` (1 to `W` − 1) paths of a run, then
    /// the last of them again in the lanes beyond. A repeated id, not an arbitrary path: the
    /// kernels' steps that run in every lane whatever [`live_only`] says (the surface loads,
    /// the throughput gathers) then touch only paths of the chunk; [`scatter`] writes each
    /// path's pending light sample last from its own lane.
    #[inline(always)]
    pub(crate) fn padded<const W: usize>(rest: &[u32]) -> [u32; W] {
        let last = *rest.last().expect("a padded chunk has a path");
        let mut ids = [last; W];
        ids[..rest.len()].copy_from_slice(rest);
        ids
    }

    /// Marks the lanes from `live` on as behind their surface (`front` false), so that a
    /// padded chunk's extra lanes draw no numbers (`draws::x8::draw` draws where `front`),
    /// gather no light point, and hand no sample to the tail; their computed values are
    /// dropped, as those of a lane that fails the side test.
    #[inline(always)]
    pub(crate) fn live_only<const W: usize>(front: &mut [bool; W], live: usize) {
        // Only a padded chunk has lanes to clear (a full chunk's pass cost ~50 instructions).
        if live < W {
            for f in &mut front[live..] {
                *f = false;
            }
        }
    }

    /// [`surface::x8::prologue`] of a chunk whose first `live` lanes are paths (the others
    /// marked behind their surface: [`live_only`]).
    #[inline(always)]
    pub(crate) fn prologue<T: Wide<W>, const W: usize>(
        avx: T,
        s: &crate::stream::batch::Surfaces,
        ids: &[u32; W],
        live: usize,
    ) -> surface::x8::Prologue<T::F, W> {
        let mut pr = surface::x8::prologue(avx, s, ids);
        live_only(&mut pr.front, live);
        pr.bits &= crate::stream::kernels::light::x8::lane_bits(live.min(W));
        pr
    }

    /// The chunks the kernels shade of a run of one material in `Batch::sorted`: `W` paths
    /// at a time, then the last `run.len() % W` as one padded chunk ([`padded`]) when there
    /// are at least `pad_min` of them (`usize::MAX`: never); the rest is left to the 1-lane
    /// code, from [`Chunks::at`] on.
    pub(crate) struct Chunks<const W: usize> {
        next: usize,
        end: usize,
        pad_min: usize,
    }

    impl<const W: usize> Chunks<W> {
        #[inline(always)]
        pub(crate) fn new(run: std::ops::Range<usize>, pad_min: usize) -> Self {
            Chunks {
                next: run.start,
                end: run.end,
                pad_min,
            }
        }

        /// Whether a chunk is left (without taking it).
        #[inline(always)]
        pub(crate) fn any(&self) -> bool {
            let rest = self.end - self.next;
            rest >= W || (rest > 0 && rest >= self.pad_min)
        }

        /// The next chunk's ids and how many of its lanes are paths, read from `sorted`.
        #[inline(always)]
        pub(crate) fn next(&mut self, sorted: &[u32]) -> Option<([u32; W], usize)> {
            let rest = self.end - self.next;
            if rest >= W {
                let ids = sorted[self.next..self.next + W].try_into().expect("W ids");
                self.next += W;
                Some((ids, W))
            } else if rest > 0 && rest >= self.pad_min {
                let ids = padded::<W>(&sorted[self.next..self.end]);
                self.next = self.end;
                Some((ids, rest))
            } else {
                None
            }
        }

        /// Where the chunks taken so far end.
        #[inline(always)]
        pub(crate) fn at(&self) -> usize {
            self.next
        }
    }

    /// A chunk's light samples as the scatter reads them: per lane whether a shadow ray is
    /// pending, its origin, direction, length and contribution.
    pub(crate) struct LightCols<const W: usize> {
        ok: [bool; W],
        o: Cols3<W>,
        d: Cols3<W>,
        tmax: [f32; W],
        c: Cols3<W>,
    }

    impl<const W: usize> LightCols<W> {
        /// Each lane's shadow ray, `Ray::segment(o, d, tmax)`, as whole rows
        /// ([`RayRows::segment_rows`]: the columns reloaded and transposed once per chunk, one
        /// 32-byte copy per pending sample instead of seven scalar loads and eight stores).
        #[inline(always)]
        pub(crate) fn shadow_rows<T: RayRows<W>>(&self, avx: T) -> [Ray; W] {
            avx.segment_rows(self.o.load(avx), self.d.load(avx), avx.load(&self.tmax))
        }

        #[inline(always)]
        pub(crate) fn store<L: Lane + ToArray<f32, W>>(lo: &LightOut<L>) -> Self
        where
            L::Mask: ToArray<bool, W>,
        {
            LightCols {
                ok: lo.ok.to_array(),
                o: Cols3::store(lo.o),
                d: Cols3::store(lo.d),
                tmax: lo.tmax.to_array(),
                c: Cols3::store(lo.contribution),
            }
        }
    }

    /// Step 4 of a chunk (the wrapper-chain driver's and [`crate::stream::kernels::blend`]'s):
    /// each front-facing lane's pending shadow ray, then its BSDF sample, to the integrator's
    /// tail, in path order (`throughput`: the paths' throughputs, read by the `path` tail; a
    /// lane behind its surface may hold any value there). The lanes whose light sample passed
    /// append it to the batch's pending samples (`Batch::push_light`; a padded chunk's
    /// repeated lanes are behind their surface, so each path appends at most one). Under the
    /// `path` integrator's tail ([`Tail::path`], whose
    /// [`Tail::light`] only stores the sample) the light samples are stored here and the
    /// vertices end in lanes ([`advance`]); the order does not matter there (each lane writes
    /// its own path's fields).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn scatter<T: RayRows<W>, const W: usize>(
        avx: T,
        b: &mut Batch,
        ids: &[u32; W],
        front: &[bool; W],
        p: &Cols3<W>,
        throughput: V3<T::F>,
        lo: Option<&LightCols<W>>,
        so: &SampleOut<T::F>,
        tail: &mut impl Tail,
    ) {
        // The passing samples (in front of their surface, their light sample passed) appended
        // to the batch's pending ones (`Batch::push_light` per lane, without a test per lane:
        // `RayRows::push_pending` writes W rows at the end, the passing lanes' first; the
        // buffers hold `LIGHT_SLACK` ≥ W entries past the batch's paths). Nothing to clear:
        // the list starts empty at each shading stage.
        if let Some(cfg) = tail.path().copied() {
            if let Some(l) = lo {
                const { assert!(W <= crate::stream::batch::LIGHT_SLACK) };
                let pass = T::bits(avx.mask(front) & avx.mask(&l.ok));
                let n = b.pending_lights;
                let rays = (&mut b.shadow_rays[n..n + W]).try_into().expect("W rays");
                let adds = (&mut b.shadow_adds[n..n + W]).try_into().expect("W adds");
                let (o, d) = (l.o.load(avx), l.d.load(avx));
                let tmax = avx.load(&l.tmax);
                b.pending_lights = n + avx.push_pending(pass, o, d, tmax, ids, &l.c, rays, adds);
            }
            advance(avx, &cfg, b, ids, front, p, throughput, so);
            return;
        }
        let (s_ok, s_wo, s_pdf, s_w, s_delta, s_eta, s_o) = (
            so.ok.to_array(),
            Cols3::store(so.wo),
            so.pdf.to_array(),
            Cols3::store(so.weight),
            so.delta.to_array(),
            so.eta.to_array(),
            Cols3::store(so.o),
        );
        // A `match`, not `Option::map` (a closure could be compiled without the lanes' target
        // features).
        #[allow(clippy::manual_map)]
        let shadow = match lo {
            Some(l) => Some(l.shadow_rows(avx)),
            None => None,
        };
        for (k, &i) in ids.iter().enumerate() {
            let i = i as usize;
            if !front[k] {
                continue;
            }
            if let (Some(l), Some(shadow)) = (lo, &shadow) {
                if l.ok[k] {
                    tail.light(b, i, shadow[k], l.c.get(k));
                }
            }
            if s_ok[k] {
                let s = Sampled {
                    p: p.get(k),
                    ray: Ray::new(s_o.get(k), s_wo.get(k)),
                    weight: s_w.get(k),
                    eta: s_eta[k],
                    pdf: s_pdf[k],
                    delta: s_delta[k],
                };
                tail.bsdf(b, i, &s);
            }
        }
    }

    /// `PathState::advance` (the `path` integrator's [`Tail::bsdf`]) for the lanes of a chunk
    /// whose BSDF sample passed (`front` and `so.ok`; `p`: their points; `throughput`: the
    /// paths' throughputs, as gathered by the kernel for its light samples): the index
    /// products and depths gathered ([`RayRows::eta_depth`]), the throughput update, the test,
    /// the survival probability and where the roulette plays (depth + 1 ≥ rr_depth on a live
    /// lane) in lanes (`path::advance_lanes`); then the roulette draw of each lane where it
    /// plays (the one `next_1d` of `advance`, from the path's own stream), the winners'
    /// division in lanes, and per lane that ends its vertex (walked by its bit) the state row
    /// written, with the next ray and `alive` of the paths that go on. Bit for bit `advance`
    /// per lane (the test `the_lane_advance_equals_advance`). (Lane by lane from the depth
    /// test on, with the index products read per lane, it cost ~390 instructions a chunk on
    /// metal_plastic.)
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn advance<T: RayRows<W>, const W: usize>(
        avx: T,
        cfg: &PathSettings,
        b: &mut Batch,
        ids: &[u32; W],
        front: &[bool; W],
        p: &Cols3<W>,
        throughput: V3<T::F>,
        so: &SampleOut<T::F>,
    ) {
        // The rows as slices held apart (their lengths and pointers stay in registers).
        let (state, sampler) = (&mut b.state[..], &mut b.sampler);
        let (ray, alive, round) = (&mut b.ray[..], &mut b.alive[..], b.round);
        // The index products and depths gathered (two gathers with AVX2).
        let (eta, depth) = avx.eta_depth(state, ids);
        let a = advance_lanes(throughput, eta, so.weight, so.eta);
        // The lanes whose vertex ends here: in front of their surface, their sample passed.
        let go = avx.mask(front) & so.ok;
        // Roulette from rr_depth on, as `advance` tests it after its `depth += 1` (the depth
        // as an unsigned number, `depth as i64 >= rr_depth as i64`): unsigned ≥ as a signed
        // compare of both sides with their top bit flipped.
        let rr_depth = cfg.rr_depth;
        let plays = if rr_depth <= 0 {
            go & a.live
        } else {
            let top = depth.splat(i32::MIN);
            let d1 = depth.add(depth.splat(1)).xor(top);
            go & a.live & !depth.splat(rr_depth).xor(top).gt(d1)
        };
        // The roulette draw where it plays (the one `next_1d` of `advance`, from the path's
        // own stream; lanes hold distinct paths, so their order does not matter): the path
        // ends at u ≥ q, else its throughput is divided by q (in lanes below).
        let q = a.q.to_array();
        let (mut lost, mut won, mut draw) = (0u32, 0u32, T::bits(plays));
        while draw != 0 {
            let k = draw.trailing_zeros() as usize;
            draw &= draw - 1;
            if sampler.next_1d(ids[k] as usize) >= q[k] {
                lost |= 1 << k;
            } else {
                won |= 1 << k;
            }
        }
        let t = V3::select(avx.mask_bits(won), a.throughput.div_by(a.q), a.throughput);
        let on = T::bits(go & a.live) & !lost;
        // Each lane's state row (`PathState::set_advanced_row`: the throughput and index
        // products, the vertex and its density), transposed once per chunk.
        let pl = p.load(avx);
        let rows = avx.rows8([t.x, t.y, t.z, a.eta, pl.x, pl.y, pl.z, so.pdf]);
        // The next rays as whole rows (`Ray::new`'s fields, transposed once per chunk).
        let rays = avx.ray_rows(so.o, so.wo, f32::INFINITY);
        let delta = so.delta.to_array();
        let mut ends = T::bits(go);
        while ends != 0 {
            let k = ends.trailing_zeros() as usize;
            ends &= ends - 1;
            let i = ids[k] as usize;
            state[i].set_advanced_row(&rows[k], delta[k]);
            if on >> k & 1 == 1 {
                ray[i] = rays[k];
                // `Batch::set_alive`.
                alive[i] = round;
            }
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::x8::advance;
    use super::SampleOut;
    use crate::geometry::Ray;
    use crate::integrator::PathSettings;
    use crate::lane::Avx2;
    use crate::math::rng::Pcg32;
    use crate::sampler::Sampler;
    use crate::stream::batch::Batch;
    use crate::stream::kernels::light::x8::Cols3;
    use crate::stream::kernels::tail::{PathTail, Sampled, Tail};
    use glam::{Vec2, Vec3};

    /// Values that reach `advance`'s operations: zeros of both signs, subnormals, huge values
    /// (whose products overflow), infinities, NaN, and ordinary ones.
    const EDGES: [f32; 16] = [
        0.0,
        -0.0,
        1e-40,
        -1e-40,
        f32::MIN_POSITIVE,
        1e30,
        3e38,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        0.5,
        1.0,
        2.0,
        0.95,
        1e-3,
        -0.25,
    ];

    /// An edge value half of the time, else a uniform number in [0, 2).
    fn value(r: &mut Pcg32) -> f32 {
        if r.next_u32() & 1 == 0 {
            EDGES[(r.next_u32() % EDGES.len() as u32) as usize]
        } else {
            2.0 * r.next_f32()
        }
    }

    /// The lane form of the vertex's end ([`advance`]) leaves every path's state, stream, next
    /// ray and `alive` flag bit for bit where `PathState::advance` (the `path` tail's
    /// `Tail::bsdf`) leaves them lane by lane, over random and edge throughputs, weights and
    /// indices, depths below, at and past `rr_depth`, and lanes that are behind their surface or
    /// whose sample failed (untouched on both sides).
    #[test]
    fn the_lane_advance_equals_advance() {
        let Some(avx) = Avx2::detect() else {
            return;
        };
        let mut r = Pcg32::new(7, 11);
        let (mut roulette, mut survived, mut nan_kept) = (0, 0, 0);
        for round in 0..3000u32 {
            let cfg = PathSettings {
                rr_depth: [5, 0, 3, -1, 100, 1, i32::MAX, i32::MIN][round as usize % 8],
                ..PathSettings::default()
            };
            // The same 12 paths in two batches; the chunk takes 8 of them, out of order.
            let ids = [3u32, 0, 11, 5, 6, 9, 1, 7];
            let mut batches = [Batch::new(12, 1), Batch::new(12, 1)];
            let states: Vec<(Vec3, f32, u32)> = (0..12)
                .map(|_| {
                    let t = Vec3::new(value(&mut r), value(&mut r), value(&mut r));
                    // Depths around rr_depth, and near the top of the signed and unsigned
                    // ranges (the lanes compare them as unsigned numbers).
                    let depth = match r.next_u32() % 16 {
                        0 => i32::MAX as u32,
                        1 => i32::MAX as u32 - 1,
                        2 => u32::MAX - 1,
                        d => d % 8,
                    };
                    (t, value(&mut r), depth)
                })
                .collect();
            for b in &mut batches {
                b.next_round();
                for (j, &(t, eta, depth)) in states.iter().enumerate() {
                    let ray = Ray::new(Vec3::splat(j as f32), Vec3::Z);
                    b.push(Vec2::ZERO, Sampler::from_seed(round as u64, j as u64), ray);
                    let st = &mut b.state[j];
                    (st.throughput, st.eta, st.depth) = (t, eta, depth);
                }
            }
            let front: [bool; 8] = core::array::from_fn(|_| r.next_u32() & 7 != 0);
            let ok: [bool; 8] = core::array::from_fn(|_| r.next_u32() & 7 != 0);
            let delta: [bool; 8] = core::array::from_fn(|_| r.next_u32() & 1 == 0);
            let mut col = || {
                Cols3::<8>(core::array::from_fn(|_| {
                    core::array::from_fn(|_| value(&mut r))
                }))
            };
            let (p, o, wo, w) = (col(), col(), col(), col());
            let eta_s: [f32; 8] = core::array::from_fn(|_| value(&mut r));
            let pdf: [f32; 8] = core::array::from_fn(|_| value(&mut r));
            let [lanes, scalar] = &mut batches;
            avx.run(|| {
                let so = SampleOut {
                    ok: avx.mask(&ok),
                    wo: wo.load(avx),
                    pdf: avx.load(&pdf),
                    weight: w.load(avx),
                    delta: avx.mask(&delta),
                    eta: avx.load(&eta_s),
                    o: o.load(avx),
                };
                let mut tp = Cols3::<8>::default();
                for (k, &i) in ids.iter().enumerate() {
                    tp.set(k, lanes.state[i as usize].throughput);
                }
                let tp = tp.load(avx);
                advance(avx, &cfg, lanes, &ids, &front, &p, tp, &so);
            });
            let mut tail = PathTail { cfg: &cfg };
            for (k, &i) in ids.iter().enumerate() {
                if !(front[k] && ok[k]) {
                    continue;
                }
                let i = i as usize;
                let before = scalar.state[i];
                let s = Sampled {
                    p: p.get(k),
                    ray: Ray::new(o.get(k), wo.get(k)),
                    weight: w.get(k),
                    eta: eta_s[k],
                    pdf: pdf[k],
                    delta: delta[k],
                };
                tail.bsdf(scalar, i, &s);
                let after = &scalar.state[i];
                let tmax = crate::spectrum::max_component(before.throughput * s.weight);
                if tmax.is_finite() && tmax > 0.0 && after.depth as i64 >= cfg.rr_depth as i64 {
                    roulette += 1;
                    survived += scalar.is_alive(i) as u32;
                }
                nan_kept +=
                    (scalar.is_alive(i) && !crate::spectrum::is_finite(after.throughput)) as u32;
            }
            for i in 0..12 {
                assert_eq!(
                    lanes.sampler.next_1d(i).to_bits(),
                    scalar.sampler.at(i).next_1d().to_bits(),
                    "round {round} path {i}"
                );
                assert_eq!(
                    format!("{:?}", lanes.state[i]),
                    format!("{:?}", scalar.state[i]),
                    "round {round} path {i}"
                );
                assert_eq!(
                    format!("{:?}", lanes.ray[i]),
                    format!("{:?}", scalar.ray[i]),
                    "round {round} path {i}"
                );
                assert_eq!(lanes.alive[i], scalar.alive[i], "round {round} path {i}");
            }
        }
        // The cases the lanes must get right were all reached.
        assert!(roulette > 1000 && survived > 100 && roulette - survived > 100);
        assert!(
            nan_kept > 10,
            "a NaN component next to a positive maximum goes on"
        );
    }
}
