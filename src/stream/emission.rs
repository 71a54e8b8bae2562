//! The emission stage of the stream renderer in lanes: what each active path's ray sees (an
//! escaped ray, the constant environment lights; a hit on an area light, its radiance), weighted
//! by MIS against the light's density, added to the path's radiance 8 paths at a time; and which
//! paths go on to the shading stage.
//!
//! The arithmetic is [`PathState::add_emission`]'s, operation for operation, written once over
//! [`Lane`] (width 1 is checked against the scalar functions below, width 8 by
//! `tests/render/stream.rs`): the power heuristic (Veach 1997, eq. 9.13, β = 2) of the previous
//! vertex's BSDF density against the light's, `Shape::pdf_direction`'s area-measure density
//! `dist² / (|cos| · area)` times the light selection's pmf, and `result += throughput · Le · w`.
//! Sphere lights add the density of their cone sampling from outside (`Shape::pdf_direction`:
//! `uniform_cone_pdf` of the cone the sphere subtends, where the reference point is far enough
//! out); environment maps ([`env_uv`]: the world direction to (u, v), sin θ and the table's
//! patch point with the crate's `lane::math`, as `EnvMapLight::eval` and `pdf_direct`) look
//! their texels and table density up lane by lane and do the rest in lanes. What it does not
//! cover goes lane by lane through [`PathState::add_emission`] itself: hits on area lights
//! with textured radiance.

use crate::emitter::Emitter;
use crate::geometry::shapes::ShapeKind;
use crate::lane::vec::V3;
use crate::lane::Lane;
use crate::scene::Scene;
use crate::spectrum::Spectrum;
use crate::stream::kernels::emitters::env_uv;
use crate::stream::kernels::mis::power_heuristic;
use crate::texture::Texture;
use glam::Vec3;

#[cfg(doc)]
use crate::integrator::path::PathState;

/// What a ray that hits a shape sees of its emission.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Seen {
    /// Nothing: the shape emits nothing (or zero radiance).
    Dark,
    /// An area light of constant `radiance` on a shape of `area`, picked by the light sampler
    /// with probability `pmf`, on a sphere (`Some((center, radius))`) or not: in lanes.
    Area {
        radiance: Vec3,
        area: f32,
        pmf: f32,
        sphere: Option<(Vec3, f32)>,
    },
    /// Anything else: [`PathState::add_emission`], lane by lane.
    Scalar,
}

/// [`Lights::info_seen`] of a shape whose [`Seen`] is `Dark`.
pub(crate) const DARK: u32 = 0;
/// [`Lights::info_seen`] of a shape whose [`Seen`] is `Area`.
pub(crate) const AREA: u32 = 1;
/// [`Lights::info_seen`] of a shape whose [`Seen`] is `Scalar`.
pub(crate) const SCALAR: u32 = 2;

/// The scene's emission as the stage sees it, decided once at load.
#[derive(Clone, Debug)]
pub(crate) struct Lights {
    /// Per shape.
    pub shapes: Vec<Seen>,
    /// What the emission stage's first pass needs of a shape a ray hits, as two columns by
    /// shape (one entry of 0 each when the scene has no shape, so that the first pass may
    /// gather from them 8 hits at a time): its material (the sort key of the paths that
    /// scatter there) and what a ray that hits it sees ([`Seen`]'s variant: [`DARK`],
    /// [`AREA`] or [`SCALAR`]). Most hits see nothing, and for them these are all the stage
    /// reads of the shape.
    pub info_material: Vec<u32>,
    pub info_seen: Vec<u32>,
    /// The environment lights in `Scene::env_emission`'s order when every one is `constant`
    /// or `envmap` (constant ones of zero radiance left out); `None` when one is neither
    /// (escaped rays then go lane by lane).
    pub env: Option<Vec<Env>>,
}

/// An environment light as escaped rays see it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Env {
    /// `constant`: its radiance and light density (`pdf_direct_env · pmf`).
    Constant { radiance: Vec3, pdf: f32 },
    /// `envmap`: emitter `emitter` (an `Emitter::EnvMap`) picked with probability `pmf`, its
    /// world-to-map frame's columns and `EnvMapLight::half_texel`.
    Map {
        emitter: u32,
        pmf: f32,
        to_local: [Vec3; 3],
        half_texel: f32,
    },
}

impl Lights {
    pub(crate) fn new(scene: &Scene) -> Lights {
        let shapes: Vec<Seen> = (0..scene.shapes.len())
            .map(|s| {
                let Some(e) = scene.shape_emitter[s] else {
                    return Seen::Dark;
                };
                match &scene.emitters[e as usize] {
                    Emitter::Area(a) => match a.radiance {
                        Texture::Constant(le) => {
                            // `add_emission` adds nothing when the radiance is zero.
                            if le == Spectrum::ZERO {
                                Seen::Dark
                            } else {
                                let shape = &scene.shapes[a.shape as usize];
                                Seen::Area {
                                    radiance: le,
                                    area: shape.area(),
                                    pmf: scene.light_sampler.pmf(e as usize),
                                    sphere: match shape.kind {
                                        ShapeKind::Sphere { center, radius, .. } => {
                                            Some((center, radius))
                                        }
                                        _ => None,
                                    },
                                }
                            }
                        }
                        _ => Seen::Scalar,
                    },
                    // Only area lights have surface emission (`Emitter::eval_surface`).
                    _ => Seen::Dark,
                }
            })
            .collect();
        let env = scene
            .env_emitters
            .iter()
            .map(|&e| {
                let pmf = scene.light_sampler.pmf(e as usize);
                match &scene.emitters[e as usize] {
                    Emitter::Constant(c) => Some(Env::Constant {
                        radiance: c.radiance,
                        pdf: c.pdf_direct(Vec3::Z) * pmf,
                    }),
                    Emitter::EnvMap(m) => {
                        let (_, to_local) = m.frames();
                        Some(Env::Map {
                            emitter: e,
                            pmf,
                            to_local: [to_local.x_axis, to_local.y_axis, to_local.z_axis],
                            half_texel: m.half_texel(),
                        })
                    }
                    _ => None,
                }
            })
            .collect::<Option<Vec<_>>>()
            .map(|v| {
                v.into_iter()
                    .filter(|e| {
                        !matches!(e, Env::Constant { radiance, .. } if *radiance == Spectrum::ZERO)
                    })
                    .collect()
            });
        let column = |f: &dyn Fn(usize, &Seen) -> u32| -> Vec<u32> {
            match shapes.len() {
                0 => vec![0],
                _ => shapes
                    .iter()
                    .enumerate()
                    .map(|(s, seen)| f(s, seen))
                    .collect(),
            }
        };
        let info_material = column(&|s, _| scene.shape_material[s]);
        let info_seen = column(&|_, seen| match seen {
            Seen::Dark => DARK,
            Seen::Area { .. } => AREA,
            Seen::Scalar => SCALAR,
        });
        Lights {
            shapes,
            info_material,
            info_seen,
            env,
        }
    }
}

/// The previous vertices of `L::WIDTH` paths as the MIS weight sees them (`PathState::prev_mis`'s
/// fields in lanes).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Prev<L: Lane> {
    pub p: V3<L>,
    pub pdf: L,
    pub mis: L::Mask,
    pub zero: L::Mask,
}

/// The MIS weight of emission whose light density is `light_pdf` (`path::emission_weight`).
#[inline(always)]
pub(crate) fn weight<L: Lane>(prev: &Prev<L>, light_pdf: L) -> L {
    let k = |c: f32| light_pdf.splat(c);
    L::select(
        prev.mis,
        power_heuristic(prev.pdf, light_pdf),
        L::select(prev.zero, k(0.0), k(1.0)),
    )
}

/// `Shape::pdf_direction` for a shape that is not a sphere: the density of the point `p`
/// (shading normal `n`) seen from `ref_p` by area sampling of a shape of `area`, in solid angle
/// (0 where not finite).
#[inline(always)]
pub(crate) fn area_pdf<L: Lane>(p: V3<L>, n: V3<L>, ref_p: V3<L>, area: L) -> L {
    let v = p - ref_p;
    let dist2 = v.length_squared();
    let cos = v.div_by(dist2.sqrt()).dot(n).abs();
    let pdf = dist2 / (cos * area);
    L::select(pdf.is_finite(), pdf, pdf.splat(0.0))
}

/// `Shape::pdf_direction` for an area light that may be a sphere (`sphere`, its `center` and
/// `radius`): from a reference point outside the cone threshold (`shapes::sphere_sees_cone`)
/// the density of the cone the sphere subtends, else [`area_pdf`].
#[inline(always)]
pub(crate) fn light_pdf<L: Lane>(
    p: V3<L>,
    n: V3<L>,
    ref_p: V3<L>,
    area: L,
    sphere: (L::Mask, V3<L>, L),
) -> L {
    let k = |c: f32| area.splat(c);
    let (is_sphere, center, radius) = sphere;
    let dist_c = (center - ref_p).length();
    let cone = is_sphere & dist_c.gt(radius * k(1.0 + 1e-3));
    let sin_a = radius / dist_c;
    let cos_a = (k(1.0) - sin_a * sin_a).max(k(0.0)).sqrt();
    L::select(
        cone,
        crate::lane::warp::uniform_cone_pdf(cos_a),
        area_pdf(p, n, ref_p, area),
    )
}

/// An environment map's light density (`EnvMapLight::pdf_direct` · pmf) from the table's
/// density `table` at the patch point, where `ok` (a non-zero local direction and a positive
/// sin θ; elsewhere `pdf_direct` is 0).
#[inline(always)]
pub(crate) fn env_light_pdf<L: Lane>(ok: L::Mask, table: L, sin_theta: L, pmf: L) -> L {
    let (pdf, _) = crate::stream::kernels::emitters::env_pdf(table, sin_theta);
    L::select(ok, pdf, pmf.splat(0.0)) * pmf
}

/// `AreaLight::eval`'s side test: the point emits toward `wi` unless `n · wi ≤ 0` (a NaN
/// product emits, as in the scalar test).
#[inline(always)]
pub(crate) fn front<L: Lane>(n: V3<L>, wi: V3<L>) -> L::Mask {
    let d = n.dot(wi);
    !d.le(d.splat(0.0))
}

/// `result += throughput · le · w`, as glam computes it (component products, then the scale).
#[inline(always)]
pub(crate) fn add<L: Lane>(result: V3<L>, throughput: V3<L>, le: V3<L>, w: L) -> V3<L> {
    result + (throughput * le).scale(w)
}

/// One environment light seen by `L::WIDTH` escaped paths with radiance `result`, throughput
/// `throughput` and previous vertices `prev`: radiance `le` of light density `light_pdf`
/// (`pdf_direct_env · pmf`) added where `on` (the ray escaped and `le` is not zero). Returns
/// the new radiance.
#[inline(always)]
pub(crate) fn seen_env<L: Lane>(
    result: V3<L>,
    throughput: V3<L>,
    prev: &Prev<L>,
    on: L::Mask,
    le: V3<L>,
    light_pdf: L,
) -> V3<L> {
    let w = weight(prev, light_pdf);
    V3::select(on, add(result, throughput, le, w), result)
}

/// An area light's emission seen by `L::WIDTH` paths with radiance `result`, throughput
/// `throughput` and previous vertices `prev`: the light of constant radiance `le`, `area`, pmf
/// `pmf` and `sphere` (as [`light_pdf`]) at the point `p` (shading normal `n`, toward the
/// previous vertex `wi`) where `on_area`. Returns the new radiance.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn seen<L: Lane>(
    result: V3<L>,
    throughput: V3<L>,
    prev: &Prev<L>,
    on_area: L::Mask,
    area: (V3<L>, L, L),
    sphere: (L::Mask, V3<L>, L),
    hit: (V3<L>, V3<L>, V3<L>),
) -> V3<L> {
    let (le, a, pmf) = area;
    let (p, n, wi) = hit;
    let on = on_area & front(n, wi);
    let w = weight(prev, light_pdf(p, n, prev.p, a, sphere) * pmf);
    V3::select(on, add(result, throughput, le, w), result)
}

/// The (u, v) of the escaped rays' directions `d` in an environment map of world-to-map
/// columns `to_local` and half texel `half_texel`, as [`env_uv`]; returns per lane whether the
/// map sees the direction, (u, v), the patch point and whether sin θ passes, for the lookups.
#[inline(always)]
pub(crate) fn env_where<L: Lane>(
    to_local: &[Vec3; 3],
    half_texel: f32,
    d: V3<L>,
) -> crate::stream::kernels::emitters::EnvUv<L> {
    let c = |v: Vec3| V3::splat(d.x, v.x, v.y, v.z);
    env_uv(
        &[c(to_local[0]), c(to_local[1]), c(to_local[2])],
        d.x.splat(half_texel),
        d,
    )
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod x8 {
    use super::*;
    use crate::geometry::Ray;
    use crate::integrator::path::PathState;
    use crate::integrator::{PathSettings, Strategy};
    use crate::lane::{Avx2, F32x8, LaneI32};
    use crate::stream::batch::{cols, Batch};
    use crate::stream::kernels::light::x8::Cols3;
    use glam::Vec2;

    /// What the emission stage did in lanes (`LaneCounters`): paths whose emission went
    /// through the lanes, of which escaped rays under an environment map and hits on sphere
    /// lights.
    #[derive(Clone, Copy, Debug, Default)]
    pub(crate) struct Counts {
        pub lanes: u64,
        pub env_map: u64,
        pub sphere: u64,
    }

    /// The emission stage over `batch.active`: adds what each ray sees to its path, and lists
    /// in `batch.scatter` (ascending) the paths that scatter at their hit (depth + 1 <
    /// max_depth), with their materials in `batch.scatter_material`. Returns what went
    /// through the lanes. Call inside [`Avx2::run`].
    ///
    /// One pass over the active paths reads only what every path needs (its depth, whether it
    /// hit, the hit shape's [`Lights::info_material`] and [`Lights::info_seen`]) and sorts the paths whose ray shows emission into
    /// three lists (`batch.escaped`, `batch.on_lights`, `batch.one_by_one`) without a branch
    /// for the escaped ones; then each list goes 8 paths at a time through its lanes (full
    /// chunks: most paths see nothing, so lanes of mixed chunks would mostly idle), the last
    /// lane by lane. The per-path arrays are cut to the batch's length once, so one bounds test
    /// covers a path's accesses.
    #[inline(always)]
    pub(crate) fn stage(
        avx: Avx2,
        scene: &Scene,
        cfg: &PathSettings,
        lights: &Lights,
        batch: &mut Batch,
    ) -> Counts {
        let limit = crate::integrator::depth_limit(cfg.max_depth);
        // A path scatters at its hit while depth < `last` (Mitsuba: while depth + 1 <
        // max_depth).
        let last = limit.saturating_sub(1);
        let n = batch.len();
        let Batch {
            active,
            state,
            hit,
            hit_flag,
            surf,
            scatter,
            scatter_material,
            escaped,
            on_lights,
            one_by_one,
            ray,
            ..
        } = batch;
        let (state, hit, ray) = (&mut state[..n], &hit[..n], &ray[..n]);
        let rows = &surf.flat().as_chunks::<{ cols::ROW }>().0[..n];
        let lists = [
            &mut *scatter,
            &mut *escaped,
            &mut *on_lights,
            &mut *one_by_one,
        ];
        let paths = Paths {
            state: &*state,
            hit,
            hit_flag: &hit_flag[..n],
            rows,
            flat: &surf.flat()[..n * cols::ROW],
            lights,
        };
        // The first pass in a function of its own (its list lengths stay in registers).
        avx.splat(0.0).outlined(
            #[inline(always)]
            || {
                let mats = &mut *scatter_material;
                if cfg.hide_emitters {
                    classify::<true>(avx, active, paths, mats, last, lists);
                } else {
                    classify::<false>(avx, active, paths, mats, last, lists);
                }
            },
        );
        let mut counts = Counts::default();
        match lights.env.as_deref() {
            // No environment light: escaped rays see nothing.
            Some([]) => {}
            Some(env) => {
                for ids in escaped.chunks(8) {
                    seen_envs(avx, scene, cfg, env, ids, state, ray);
                }
                counts.lanes += escaped.len() as u64;
                if env.iter().any(|e| matches!(e, Env::Map { .. })) {
                    counts.env_map += escaped.len() as u64;
                }
            }
            // An environment light the lanes do not cover.
            None => {
                for &i in escaped.iter() {
                    let i = i as usize;
                    state[i].add_emission(cfg, scene, &ray[i], None);
                }
            }
        }
        for ids in on_lights.chunks(8) {
            counts.sphere += seen_areas(avx, cfg, lights, rows, ids, state);
        }
        counts.lanes += on_lights.len() as u64;
        for &i in one_by_one.iter() {
            let i = i as usize;
            let si = surf.get(i);
            state[i].add_emission(cfg, scene, &ray[i], Some(&si));
        }
        counts
    }

    /// What [`classify`] reads of the batch's paths (each slice cut to the batch's length).
    struct Paths<'a> {
        state: &'a [PathState],
        hit: &'a [crate::accel::HitRow],
        /// `Batch::hit_flag`.
        hit_flag: &'a [u32],
        rows: &'a [[f32; cols::ROW]],
        /// `rows` as one slice of floats (for the shape indices' gather).
        flat: &'a [f32],
        lights: &'a Lights,
    }

    /// The emission stage's first pass over the active paths `active` (see [`stage`]): appends
    /// each to `lists`: `[scatter, escaped, on_lights, one_by_one]` (each cleared first), the
    /// hits that scatter (depth < `last`) with their material (to `materials`, in the order of
    /// `scatter`), the
    /// escaped rays that show emission, and the hits that show an area light's ([`AREA`]) or
    /// other ([`SCALAR`]) emission. `HIDE`: `hide_emitters` (a path shows emission only after
    /// its first vertex). Call inside an AVX2 region.
    ///
    /// 8 paths at a time in lanes: their hit flags (`Batch::hit_flag`) and depths
    /// ([`Avx2::gather_depth`]) by two gathers, the hit shapes' indices from their surface rows
    /// and the shapes' materials and [`Seen`] variants from [`Lights::info_material`] and
    /// [`Lights::info_seen`] by three more; the scattering hits and the escaped rays appended
    /// to their lists by one compress each ([`Avx2::compress_store`], the ids in the order
    /// walked, so the lists are those of the path-by-path loop), the scattering hits'
    /// materials by a third with the same mask; the rare hits on emitters appended lane by
    /// lane. Nothing is written per path: the `alive` flags are stamps of the bounce
    /// (`Batch::next_round`), and the sort writes the scattering paths' materials. The last
    /// `active.len() % 8` paths go through the path-by-path loop ([`classify_one`]).
    /// (The path-by-path loop for every path cost 28 instructions a path on metal_plastic;
    /// with `alive` and `material` stored per lane, the lanes cost ~45 instructions a chunk
    /// more.)
    #[inline(always)]
    fn classify<const HIDE: bool>(
        avx: Avx2,
        active: &[u32],
        paths: Paths,
        materials: &mut crate::stream::batch::Ids,
        last: u32,
        lists: [&mut crate::stream::batch::Ids; 4],
    ) {
        use crate::lane::{I32x8, LaneMask};
        use crate::stream::BATCH;
        let n = paths.state.len();
        let (state, flag, flat) = (paths.state, &paths.hit_flag[..n], paths.flat);
        // The tables as slices held in locals, and the lists' buffers taken once: the loop
        // keeps their pointers and lengths (and the gathers' clamps and checks) out of the
        // chunk's code. Reached through `paths` and the lists in the loop, they were reloaded
        // and checked again for every chunk (the stores into the lists may alias them, as far
        // as the compiler knows).
        let (info_material, info_seen): (&[u32], &[u32]) =
            (&paths.lights.info_material, &paths.lights.info_seen);
        let [scatter, escaped, on_lights, one_by_one] = lists;
        on_lights.clear();
        one_by_one.clear();
        let (sb, eb, mb) = (scatter.buf_mut(), escaped.buf_mut(), materials.buf_mut());
        let (mut ns, mut ne) = (0usize, 0usize);
        let chunks = active.chunks_exact(8);
        let rest = chunks.remainder();
        // A row's shape index is float `32·i + SHAPE` of `flat`.
        const { assert!(cols::ROW == 32) };
        for ids in chunks {
            let ids: &[u32; 8] = ids.try_into().expect("8 ids");
            let idv = avx.load_u32(ids);
            let zero = idv.splat(0);
            let hit = !I32x8::gather_u32(flag, idv).eq(zero);
            let depth = avx.gather_depth(state, idv);
            let at = idv.shl::<5>().add(idv.splat(cols::SHAPE as i32));
            // Misses' rows are stale: their shape is taken as 0 (their material is dropped
            // by the compress).
            let shape = I32x8::select(hit, F32x8::gather_slice(flat, at).to_bits(), zero);
            let mat = I32x8::gather_u32(info_material, shape);
            let seen = I32x8::gather_u32(info_seen, shape);
            // depth < last and depth >= show_from, as unsigned numbers.
            let lastv = idv.splat(last as i32);
            let below = !depth.min_u32(lastv).eq(lastv);
            let show = if HIDE { !depth.eq(zero) } else { zero.eq(zero) };
            // Each list's length is at most the paths walked before this chunk, so at most
            // `BATCH − 8`: `% BATCH` changes nothing, but it lets the compiler see that the 8
            // slots fit the buffer of `BATCH + 8` (`Ids`), with no bounds test per store.
            let (ws, we) = (ns % BATCH, ne % BATCH);
            avx.compress_store(mat, hit & below, &mut mb[..], ws);
            ns = avx.compress_store(idv, hit & below, &mut sb[..], ws);
            ne = avx.compress_store(idv, !hit & show, &mut eb[..], we);
            // Rare (hits on emitters): through the lists' own appends, in lane order.
            let lit = hit & show & !seen.eq(idv.splat(DARK as i32));
            if lit.any() {
                let (bits, seen) = (lit.bits(), seen.to_array());
                for k in 0..8 {
                    if bits >> k & 1 == 1 {
                        if seen[k] == AREA as i32 {
                            on_lights.push(ids[k]);
                        } else {
                            one_by_one.push(ids[k]);
                        }
                    }
                }
            }
        }
        let rest = (rest, paths, materials, last);
        classify_one::<HIDE>(rest, [scatter, escaped, on_lights, one_by_one], (ns, ne));
    }

    /// [`classify`] path by path, for the paths `walk.0` (the rest after its chunks of 8), the
    /// scattering hits (and their materials, to `walk.2`) and escaped rays appended at lengths
    /// `lens` of the first two lists (the last two are appended to as they stand). Each list's
    /// length stays in a register and
    /// an id is written at `buf[len % BATCH]` (no bounds test: a list never holds more ids
    /// than the paths walked before it, fewer than [`crate::stream::BATCH`]) with the length
    /// advanced by the kept flag, as [`crate::stream::batch::Ids::put`].
    #[allow(clippy::type_complexity)]
    #[inline(always)]
    fn classify_one<const HIDE: bool>(
        walk: (&[u32], Paths, &mut crate::stream::batch::Ids, u32),
        lists: [&mut crate::stream::batch::Ids; 4],
        lens: (usize, usize),
    ) {
        use crate::stream::BATCH;
        let (active, paths, materials, last) = walk;
        let n = paths.state.len();
        let (state, hit, rows) = (paths.state, &paths.hit[..n], &paths.rows[..n]);
        let (info_material, info_seen) = (&paths.lights.info_material, &paths.lights.info_seen);
        // A path shows what its ray sees from this depth on.
        let show_from = HIDE as u32;
        let [scatter, escaped, on_lights, one_by_one] = lists;
        let (sb, eb, mb) = (scatter.buf_mut(), escaped.buf_mut(), materials.buf_mut());
        let (mut ns, mut ne) = lens;
        for &i in active {
            let i = i as usize;
            let depth = state[i].depth;
            let show = depth >= show_from;
            if hit[i].is_hit() {
                let shape = rows[i][cols::SHAPE].to_bits() as usize;
                mb[ns % BATCH] = info_material[shape];
                sb[ns % BATCH] = i as u32;
                ns += (depth < last) as usize;
                // Rare (hits on emitters): through the lists' own appends.
                let seen = info_seen[shape];
                if show && seen != DARK {
                    if seen == AREA {
                        on_lights.push(i as u32);
                    } else {
                        one_by_one.push(i as u32);
                    }
                }
            } else {
                eb[ne % BATCH] = i as u32;
                ne += show as usize;
            }
        }
        scatter.set_len(ns);
        materials.set_len(ns);
        escaped.set_len(ne);
    }

    /// The radiance, throughput and previous vertices of the paths `ids` (1 to 8) in lanes
    /// (the lanes past `ids.len()` repeat the last path; nothing of them is written back).
    /// Each lane's state is looked up once. Each path's first 8 floats
    /// (`PathState::row8`: throughput, η, the previous vertex and its density) are one
    /// 32-byte load, transposed with the chunk's others ([`F32x8::transpose8`]); its radiance
    /// (and depth, unused) one 16-byte load (`PathState::result_row`, [`Avx2::fields4`]). The MIS flags
    /// of `PathState::prev_mis` from the 8 previous-vertex kinds at once: `mis` (or `zero`)
    /// where the vertex has a density and the strategy is MIS (light sampling only). Where it
    /// has none `prev_mis` gives the point and density 0, the rows their stored values: the
    /// weight ([`weight`]) reads them only where `mis`, so the radiance is the same bits.
    #[inline(always)]
    pub(super) fn paths(
        avx: Avx2,
        cfg: &PathSettings,
        ids: &[u32],
        state: &[PathState],
    ) -> (V3<F32x8>, V3<F32x8>, Prev<F32x8>) {
        let last = ids.len() - 1;
        let at = |k: usize| &state[ids[k.min(last)] as usize];
        // Each lane's state looked up once (its clamp and bounds test), then read three times;
        // a full chunk's 8 ids checked at once (`Avx2::entries_at`: ~3 instructions a lane
        // less than the clamp, the id's bounds test and the state's).
        let full = <&[u32; 8]>::try_from(ids).ok();
        let st = match full.and_then(|ids| avx.entries_at(state, ids)) {
            Some(st) => st,
            None => [at(0), at(1), at(2), at(3), at(4), at(5), at(6), at(7)],
        };
        // Written out, not `array::from_fn` (a closure compiled out of line would lose the
        // lanes' target features).
        let r8 = [
            st[0].row8(),
            st[1].row8(),
            st[2].row8(),
            st[3].row8(),
            st[4].row8(),
            st[5].row8(),
            st[6].row8(),
            st[7].row8(),
        ];
        let f = F32x8::transpose8([
            avx.load(&r8[0]),
            avx.load(&r8[1]),
            avx.load(&r8[2]),
            avx.load(&r8[3]),
            avx.load(&r8[4]),
            avx.load(&r8[5]),
            avx.load(&r8[6]),
            avx.load(&r8[7]),
        ]);
        let r4 = [
            st[0].result_row(),
            st[1].result_row(),
            st[2].result_row(),
            st[3].result_row(),
            st[4].result_row(),
            st[5].result_row(),
            st[6].result_row(),
            st[7].result_row(),
        ];
        let r = avx.fields4(&r4);
        let kind = [
            st[0].prev_kind_i32(),
            st[1].prev_kind_i32(),
            st[2].prev_kind_i32(),
            st[3].prev_kind_i32(),
            st[4].prev_kind_i32(),
            st[5].prev_kind_i32(),
            st[6].prev_kind_i32(),
            st[7].prev_kind_i32(),
        ];
        let kind = avx.load_i32(&kind);
        let smooth = kind.eq(kind.splat(0));
        let prev = Prev {
            p: V3::new(f[4], f[5], f[6]),
            pdf: f[7],
            mis: smooth & avx.mask_splat(cfg.strategy == Strategy::Mis),
            zero: smooth & avx.mask_splat(cfg.strategy == Strategy::LightOnly),
        };
        (V3::new(r[0], r[1], r[2]), V3::new(f[0], f[1], f[2]), prev)
    }

    /// The new radiance `out` of the paths `ids` (1 to 8) into their states, by columns: per
    /// path three floats from the stored lanes. (As rows, `Avx2::rows4` and one row per path,
    /// it was 0.84 M instructions on metal_plastic against 0.57 M: LLVM split each row's store
    /// and reloaded the depth; `docs/bench/README.md`, twenty-fifth session, h4.)
    #[inline(always)]
    pub(super) fn write(avx: Avx2, ids: &[u32], out: V3<F32x8>, state: &mut [PathState]) {
        let (x, y, z) = (out.x.to_array(), out.y.to_array(), out.z.to_array());
        // A full chunk's 8 ids checked at once (`Avx2::for_each_at_mut`), not one a store.
        if let Ok(ids) = <&[u32; 8]>::try_from(ids) {
            avx.for_each_at_mut(
                state,
                ids,
                #[inline(always)]
                |k, s| s.result = Vec3::new(x[k], y[k], z[k]),
            );
            return;
        }
        for (k, &i) in ids.iter().enumerate() {
            state[i as usize].result = Vec3::new(x[k], y[k], z[k]);
        }
    }

    /// The directions of the rays of the paths `ids` (1 to 8) in lanes (the lanes past
    /// `ids.len()` repeat the last path's): per ray one 16-byte row (`d`, then `tmin`, unused)
    /// transposed by [`Avx2::fields4`], not three column writes per lane. Only an environment
    /// map reads them (a constant environment light sees every escaped ray alike).
    #[inline(always)]
    fn directions(avx: Avx2, ids: &[u32], ray: &[Ray]) -> V3<F32x8> {
        let last = ids.len() - 1;
        let row = |k: usize| {
            let r = &ray[ids[k.min(last)] as usize];
            [r.d.x, r.d.y, r.d.z, r.tmin]
        };
        let f = avx.fields4(&[
            row(0),
            row(1),
            row(2),
            row(3),
            row(4),
            row(5),
            row(6),
            row(7),
        ]);
        V3::new(f[0], f[1], f[2])
    }

    /// Every environment light `env` (in `Scene::env_emission`'s order) seen by the escaped
    /// rays of the paths `ids` (at most 8), added to their radiance.
    #[inline(always)]
    fn seen_envs(
        avx: Avx2,
        scene: &Scene,
        cfg: &PathSettings,
        env: &[Env],
        ids: &[u32],
        state: &mut [PathState],
        ray: &[Ray],
    ) {
        let (mut out, throughput, prev) = paths(avx, cfg, ids, state);
        let used = avx.mask_bits(0xff >> (8 - ids.len()));
        for e in env {
            out = match *e {
                Env::Constant { radiance: c, pdf } => seen_env(
                    out,
                    throughput,
                    &prev,
                    used,
                    V3::splat(prev.pdf, c.x, c.y, c.z),
                    avx.splat(pdf),
                ),
                Env::Map {
                    emitter,
                    pmf,
                    to_local,
                    half_texel,
                } => {
                    let Emitter::EnvMap(m) = &scene.emitters[emitter as usize] else {
                        unreachable!("Env::Map is an envmap")
                    };
                    let q = env_where(&to_local, half_texel, directions(avx, ids, ray));
                    let (seen, sin_ok) = (q.seen.to_array(), q.sin_ok.to_array());
                    let (u, v) = (q.uv.x.to_array(), q.uv.y.to_array());
                    let px = q.patch.x.to_array();
                    let mut map_le: Cols3 = Cols3::default();
                    let mut table = [0.0f32; 8];
                    for k in 0..ids.len() {
                        if seen[k] {
                            map_le.set(k, m.lookup(Vec2::new(u[k], v[k])));
                            if sin_ok[k] {
                                table[k] = m.patch_pdf(Vec2::new(px[k], v[k]));
                            }
                        }
                    }
                    let map_le = map_le.load(avx);
                    let z = avx.splat(0.0);
                    let on = used & q.seen & !(map_le.x.eq(z) & map_le.y.eq(z) & map_le.z.eq(z));
                    let lpdf = env_light_pdf(
                        q.seen & q.sin_ok,
                        avx.load(&table),
                        q.sin_theta,
                        avx.splat(pmf),
                    );
                    seen_env(out, throughput, &prev, on, map_le, lpdf)
                }
            };
        }
        write(avx, ids, out, state);
    }

    /// The area lights seen by the paths `ids` (at most 8; each a hit on a shape whose
    /// [`Seen`] is `Area`, its row in `rows`), added to their radiance. Returns how many hit a
    /// sphere light.
    #[inline(always)]
    fn seen_areas(
        avx: Avx2,
        cfg: &PathSettings,
        lights: &Lights,
        rows: &[[f32; cols::ROW]],
        ids: &[u32],
        state: &mut [PathState],
    ) -> u64 {
        let (out, throughput, prev) = paths(avx, cfg, ids, state);
        let mut le: Cols3 = Cols3::default();
        let mut a = [0.0f32; 8];
        let mut pmf = [0.0f32; 8];
        let mut is_sphere = [false; 8];
        let mut center: Cols3 = Cols3::default();
        let mut radius = [0.0f32; 8];
        let mut p: Cols3 = Cols3::default();
        let mut n: Cols3 = Cols3::default();
        let mut wi: Cols3 = Cols3::default();
        let mut spheres = 0;
        for (k, &i) in ids.iter().enumerate() {
            let row = &rows[i as usize];
            let Seen::Area {
                radiance,
                area: sa,
                pmf: q,
                sphere,
            } = lights.shapes[row[cols::SHAPE].to_bits() as usize]
            else {
                unreachable!("path {i} hit an area light")
            };
            le.set(k, radiance);
            (a[k], pmf[k]) = (sa, q);
            if let Some((c, r)) = sphere {
                is_sphere[k] = true;
                center.set(k, c);
                radius[k] = r;
                spheres += 1;
            }
            let v3 = |c: usize| Vec3::new(row[c], row[c + 1], row[c + 2]);
            p.set(k, v3(cols::P));
            n.set(k, v3(cols::N));
            wi.set(k, v3(cols::WI));
        }
        let out = seen(
            out,
            throughput,
            &prev,
            avx.mask_bits(0xff >> (8 - ids.len())),
            (le.load(avx), avx.load(&a), avx.load(&pmf)),
            (avx.mask(&is_sphere), center.load(avx), avx.load(&radius)),
            (p.load(avx), n.load(avx), wi.load(avx)),
        );
        write(avx, ids, out, state);
        spheres
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;
    use crate::integrator::path::PrevMis;
    use crate::math::mis::power_heuristic as scalar_ph;
    use crate::math::Pcg32;
    use glam::{Mat4, Vec2};

    fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    fn same3(a: V3<f32>, b: Vec3) -> bool {
        same(a.x, b.x) && same(a.y, b.y) && same(a.z, b.z)
    }

    /// The scalar MIS weight of `path::emission_weight` from a `PrevMis`.
    fn scalar_weight(pm: &PrevMis, light_pdf: f32) -> f32 {
        if pm.mis {
            scalar_ph(pm.pdf, light_pdf)
        } else if pm.zero {
            0.0
        } else {
            1.0
        }
    }

    /// Width 1 (and width 8 in lane 5) of the area-light pieces equals the scalar code bit for
    /// bit: `AreaLight::eval`'s side test and `Shape::pdf_direction` on random rectangles and
    /// triangle-free shapes seen from random points (grazing, behind and at the point included),
    /// the weight and `result += throughput · le · w` under every MIS case.
    #[test]
    fn lane_emission_equals_the_scalar_code() {
        use crate::emitter::area::AreaLight;
        use crate::geometry::SurfaceInteraction;
        use crate::math::Frame;
        let mut r = Pcg32::new(17, 3);
        let mut f = |a: f32, b: f32| a + (b - a) * r.next_f32();
        let mut checked = [0usize; 2];
        for i in 0..6000 {
            let axis = Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(0.1, 1.0)).normalize();
            let (scale, turn) = (Vec3::new(f(0.1, 3.0), f(0.1, 3.0), 1.0), f(-3.0, 3.0));
            let at = Vec3::new(f(-2.0, 2.0), f(-2.0, 2.0), f(-2.0, 2.0));
            let m = Mat4::from_translation(at)
                * Mat4::from_quat(glam::Quat::from_axis_angle(axis, turn))
                * Mat4::from_scale(scale);
            // Every fourth a sphere (its cone density from outside, the area density from
            // inside or near it), the rest rectangles.
            let ball = (i % 4 == 3).then(|| (at, f(0.05, 1.5)));
            let shape = match ball {
                Some((c, rad)) => Shape::sphere(c, rad, &Mat4::IDENTITY, i % 3 == 0).unwrap(),
                None => Shape::rectangle_with_normals(&m, None, i % 3 == 0),
            };
            let le = Vec3::new(f(0.0, 9.0), f(0.0, 9.0), f(0.0, 9.0));
            let light = AreaLight {
                shape: 0,
                radiance: Texture::Constant(le),
            };
            let n = Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)).normalize();
            let p = match ball {
                Some((c, rad)) => c + n * rad,
                None => m.transform_point3(Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), 0.0)),
            };
            let refp = match (i % 7, ball) {
                (0, _) => p,
                (1, _) => p + n * 1e-30,
                // At the cone threshold of a sphere, inside it and just outside.
                (2, Some((c, rad))) => c + n * (rad * (1.0 + 1e-3)),
                (3, Some((c, rad))) => c + n * (rad * f(0.0, 1.0)),
                (4, Some((c, rad))) => c + n * (rad * f(1.0, 1.01)),
                _ => Vec3::new(f(-4.0, 4.0), f(-4.0, 4.0), f(-4.0, 4.0)),
            };
            let wi = match i % 11 {
                0 => Vec3::new(n.y, -n.x, 0.0),
                _ => (refp - p).normalize_or(Vec3::Z),
            };
            let si = SurfaceInteraction {
                p,
                t: 1.0,
                ng: n,
                sh: Frame::from_normal(n),
                uv: Vec2::new(f(0.0, 1.0), f(0.0, 1.0)),
                dpdu: Vec3::X,
                dpdv: Vec3::Y,
                shape: 0,
                prim: 0,
                wi,
            };
            let shapes = [shape];
            let pm = PrevMis {
                p: refp,
                pdf: [0.0, f(0.0, 5.0), f32::INFINITY, 1e30][i % 4],
                mis: i % 5 != 0,
                zero: i % 5 == 0 && i % 2 == 0,
            };
            let pmf = f(0.1, 1.0);
            let t = Vec3::new(f(0.0, 2.0), f(0.0, 2.0), f(0.0, 2.0));
            let r0 = Vec3::new(f(0.0, 2.0), f(0.0, 2.0), f(0.0, 2.0));
            // The scalar code (`add_emission`'s area branch).
            let sle = light.eval(&si);
            let mut expect = r0;
            if sle != Spectrum::ZERO {
                let w = scalar_weight(&pm, light.pdf_direct(&shapes, refp, &si) * pmf);
                expect += t * sle * w;
            }
            let prev = Prev {
                p: pm.p.into(),
                pdf: pm.pdf,
                mis: pm.mis,
                zero: pm.zero,
            };
            let area = shapes[0].area();
            let (c, rad) = ball.unwrap_or((Vec3::ZERO, 0.0));
            let got = seen::<f32>(
                r0.into(),
                t.into(),
                &prev,
                true,
                (le.into(), area, pmf),
                (ball.is_some(), c.into(), rad),
                (p.into(), si.sh.n.into(), wi.into()),
            );
            assert!(same3(got, expect), "{i}: {got:?} vs {expect}");
            #[cfg(target_arch = "x86_64")]
            if let Some(avx) = crate::lane::Avx2::detect() {
                let v = |v: Vec3| V3::splat(avx.splat(0.0), v.x, v.y, v.z);
                let m = |b: bool| avx.mask(&[b; 8]);
                let got = avx.run(|| {
                    let prev = Prev {
                        p: v(pm.p),
                        pdf: avx.splat(pm.pdf),
                        mis: m(pm.mis),
                        zero: m(pm.zero),
                    };
                    seen(
                        v(r0),
                        v(t),
                        &prev,
                        m(true),
                        (v(le), avx.splat(area), avx.splat(pmf)),
                        (m(ball.is_some()), v(c), avx.splat(rad)),
                        (v(p), v(si.sh.n), v(wi)),
                    )
                });
                let g = V3::new(got.x.lane(5), got.y.lane(5), got.z.lane(5));
                assert!(same3(g, expect), "{i} at width 8");
            }
            // A constant environment light seen by an escaped ray.
            let lpdf = crate::math::warp::uniform_sphere_pdf() * pmf;
            let expect = r0 + t * le * scalar_weight(&pm, lpdf);
            let got = seen_env::<f32>(r0.into(), t.into(), &prev, true, le.into(), lpdf);
            assert!(same3(got, expect), "{i} (environment)");
            checked[ball.is_some() as usize] += (sle != Spectrum::ZERO) as usize;
        }
        assert!(checked[0] > 1000 && checked[1] > 300, "{checked:?}");
    }

    /// Width 1 (and width 8 in lane 3) of an environment map seen by escaped rays equals
    /// `add_emission`'s environment branch bit for bit: `EnvMapLight::eval` (through
    /// [`env_where`] and the texel lookup) and `pdf_direct` · pmf (through [`env_light_pdf`]),
    /// on a random map under random rotations, for random directions, the poles, the seam
    /// (u = 0), unnormalised and zero directions, under every MIS case.
    #[test]
    fn lane_envmap_emission_equals_the_scalar_code() {
        use crate::emitter::envmap::EnvMapLight;
        use glam::Mat3;
        let mut r = Pcg32::new(23, 5);
        let mut f = |a: f32, b: f32| a + (b - a) * r.next_f32();
        let (w, h) = (11, 6);
        let px: Vec<[f32; 3]> = (0..w * h)
            .map(|i| {
                let x = (i * 7919 % 101) as f32 / 50.0;
                // Some all-zero texels: rays that see nothing add nothing.
                if i % 7 == 0 {
                    [0.0; 3]
                } else {
                    [x, 0.5 * x, if i % 5 == 0 { 0.0 } else { 1.0 }]
                }
            })
            .collect();
        let mut seen_some = 0;
        for i in 0..4000 {
            let rot = glam::Quat::from_euler(
                glam::EulerRot::XYZ,
                f(-3.0, 3.0),
                f(-3.0, 3.0),
                f(-3.0, 3.0),
            );
            let to_world = if i % 9 == 0 {
                Mat3::IDENTITY
            } else {
                Mat3::from_quat(rot)
            };
            let em = EnvMapLight::new(w, h, &px, f(0.5, 2.0), to_world).unwrap();
            let d = match i % 13 {
                0 => Vec3::ZERO,
                1 => to_world * Vec3::Y,
                2 => to_world * -Vec3::Y,
                3 => to_world * -Vec3::Z,
                4 => Vec3::new(f(-9.0, 9.0), f(-9.0, 9.0), f(-9.0, 9.0)),
                _ => Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)).normalize_or(Vec3::X),
            };
            let pm = PrevMis {
                p: Vec3::ZERO,
                pdf: [0.0, f(0.0, 5.0), f32::INFINITY, 1e30][i % 4],
                mis: i % 5 != 0,
                zero: i % 5 == 0 && i % 2 == 0,
            };
            let pmf = f(0.1, 1.0);
            let t = Vec3::new(f(0.0, 2.0), f(0.0, 2.0), f(0.0, 2.0));
            let r0 = Vec3::new(f(0.0, 2.0), f(0.0, 2.0), f(0.0, 2.0));
            // The scalar code (`add_emission`'s environment branch).
            let sle = em.eval(d);
            let mut expect = r0;
            if sle != Spectrum::ZERO {
                expect += t * sle * scalar_weight(&pm, em.pdf_direct(d) * pmf);
                seen_some += 1;
            }
            let (_, tl) = em.frames();
            let cols = [tl.x_axis, tl.y_axis, tl.z_axis];
            // The lanes' steps, at width 1.
            let q = env_where::<f32>(&cols, em.half_texel(), d.into());
            let le = if q.seen {
                em.lookup(q.uv.into())
            } else {
                Vec3::ZERO
            };
            let table = if q.seen && q.sin_ok {
                em.patch_pdf(q.patch.into())
            } else {
                0.0
            };
            let on = q.seen && le != Spectrum::ZERO;
            let lpdf = env_light_pdf(q.seen & q.sin_ok, table, q.sin_theta, pmf);
            let prev = Prev {
                p: pm.p.into(),
                pdf: pm.pdf,
                mis: pm.mis,
                zero: pm.zero,
            };
            let got = seen_env::<f32>(r0.into(), t.into(), &prev, on, le.into(), lpdf);
            assert!(same3(got, expect), "{i}: {got:?} vs {expect} ({d})");
            #[cfg(target_arch = "x86_64")]
            if let Some(avx) = crate::lane::Avx2::detect() {
                let v = |v: Vec3| V3::splat(avx.splat(0.0), v.x, v.y, v.z);
                let m = |b: bool| avx.mask(&[b; 8]);
                let (g, ok) = avx.run(|| {
                    let q8 = env_where(&cols, em.half_texel(), v(d));
                    let prev = Prev {
                        p: v(pm.p),
                        pdf: avx.splat(pm.pdf),
                        mis: m(pm.mis),
                        zero: m(pm.zero),
                    };
                    let lpdf = env_light_pdf(
                        q8.seen & q8.sin_ok,
                        avx.splat(table),
                        q8.sin_theta,
                        avx.splat(pmf),
                    );
                    let same_uv = same(q8.uv.x.lane(3), q.uv.x)
                        && same(q8.uv.y.lane(3), q.uv.y)
                        && same(q8.patch.x.lane(3), q.patch.x)
                        && q8.seen.to_array()[3] == q.seen
                        && q8.sin_ok.to_array()[3] == q.sin_ok;
                    (seen_env(v(r0), v(t), &prev, m(on), v(le), lpdf), same_uv)
                });
                assert!(ok, "{i}: (u, v) at width 8");
                let g = V3::new(g.x.lane(3), g.y.lane(3), g.z.lane(3));
                assert!(same3(g, expect), "{i} at width 8");
            }
        }
        assert!(seen_some > 2500, "{seen_some}");
    }

    /// The emission stage's rows ([`x8::paths`], [`x8::write`]) read each path's radiance,
    /// throughput and `PathState::prev_mis` bit for bit (the previous vertex's point and
    /// density where it has a density; the flags under every strategy, after the camera, a
    /// delta and a smooth vertex), and write back each listed path's radiance and nothing
    /// else: chunks of 1 to 8 paths out of order, random and edge values (±0, ±∞, NaN).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn the_rows_read_and_write_each_path() {
        use crate::integrator::path::PathState;
        use crate::integrator::{PathSettings, Strategy};
        use crate::lane::Avx2;
        let Some(avx) = Avx2::detect() else {
            return;
        };
        let mut r = Pcg32::new(9, 21);
        let mut v = move || {
            let u = r.next_u32();
            match u % 8 {
                0 => [0.0, -0.0, f32::INFINITY, f32::NAN, 1e-40][(u >> 8) as usize % 5],
                _ => f32::from_bits(u & 0x3fff_ffff) - 1.0,
            }
        };
        for round in 0..3000 {
            let strategy = [Strategy::Mis, Strategy::LightOnly, Strategy::BsdfOnly][round % 3];
            let cfg = PathSettings {
                strategy,
                ..PathSettings::default()
            };
            let mut state: Vec<PathState> = (0..12)
                .map(|j| {
                    let mut s = PathState::new();
                    let row: [f32; 8] = core::array::from_fn(|_| v());
                    // None (the camera), then a smooth and a delta vertex.
                    if j % 3 != 0 {
                        s.set_advanced_row(&row, j % 3 == 2);
                    }
                    s.result = Vec3::new(v(), v(), v());
                    s.depth = (v().to_bits() >> (round % 32)) % 1000;
                    s
                })
                .collect();
            let n = 1 + round % 8;
            let start = (round / 8) % 12;
            let ids: Vec<u32> = (0..n).map(|k| ((start + 5 * k) % 12) as u32).collect();
            let before = state.clone();
            let new: [[f32; 8]; 3] = core::array::from_fn(|_| core::array::from_fn(|_| v()));
            let got = avx.run(|| {
                let (res, t, prev) = x8::paths(avx, &cfg, &ids, &state);
                let out = V3::new(avx.load(&new[0]), avx.load(&new[1]), avx.load(&new[2]));
                x8::write(avx, &ids, out, &mut state);
                let a =
                    |x: V3<crate::lane::F32x8>| [x.x.to_array(), x.y.to_array(), x.z.to_array()];
                (
                    a(res),
                    a(t),
                    a(prev.p),
                    prev.pdf.to_array(),
                    prev.mis.to_array(),
                    prev.zero.to_array(),
                )
            });
            let (res, t, pp, pdf, mis, zero) = got;
            let b = |x: f32| x.to_bits();
            for (k, &i) in ids.iter().enumerate() {
                let (st, i) = (&before[i as usize], i as usize);
                let pm = st.prev_mis(&cfg);
                let at = |c: &[[f32; 8]; 3]| [b(c[0][k]), b(c[1][k]), b(c[2][k])];
                assert_eq!(at(&res), st.result.to_array().map(b), "{round} lane {k}");
                assert_eq!(at(&t), st.throughput.to_array().map(b), "{round} lane {k}");
                assert_eq!((mis[k], zero[k]), (pm.mis, pm.zero), "{round} lane {k}");
                if i % 3 == 1 {
                    assert_eq!(at(&pp), pm.p.to_array().map(b), "{round} lane {k}");
                    assert_eq!(b(pdf[k]), b(pm.pdf), "{round} lane {k}");
                }
                // The radiance written, the rest of the state as it was.
                let mut want = *st;
                want.result = Vec3::new(new[0][k], new[1][k], new[2][k]);
                assert_eq!(
                    format!("{:?}", state[i]),
                    format!("{want:?}"),
                    "{round} {i}"
                );
            }
            for i in 0..12 {
                if !ids.contains(&(i as u32)) {
                    let (a, w) = (&state[i], &before[i]);
                    assert_eq!(format!("{a:?}"), format!("{w:?}"), "{round} untouched {i}");
                }
            }
        }
    }
}
