//! `path`: unidirectional path tracing with next-event estimation and BSDF sampling combined by
//! the power heuristic (Veach 1997, ch. 9), Russian roulette, and Mitsuba 3's depth semantics.
//! The side tests that keep shading normals honest live in [`crate::bsdf::SurfaceBsdf`].
//!
//! The per-vertex work is split into steps that both renderers call, so a path's arithmetic is
//! one source: [`li`] (the scalar renderer) runs them depth first for one path, the stream
//! renderer ([`crate::stream`]) runs each step over a batch of paths before the next. The steps
//! are [`PathState::add_emission`] (what the ray sees), [`PathState::scatter`] (next-event
//! estimation up to its shadow ray, BSDF sampling, Russian roulette) and
//! [`PathState::add_light`] (the light sample, once its shadow ray found nothing in the way).

use super::nee::prepare_light;
use super::{PathSettings, RayKind, Scratch, Strategy};
use crate::bsdf::{BsdfArena, BsdfContext, Lobes, SurfaceSample};
use crate::geometry::{Ray, SurfaceInteraction};
use crate::lane::vec::V3;
use crate::lane::Lane;
use crate::math::mis::power_heuristic;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::{max_component, Spectrum};
use glam::Vec3;

/// What the previous vertex knew about the direction it sampled (for MIS on emitter hits).
#[derive(Clone, Copy, Debug)]
struct PrevVertex {
    p: Vec3,
    bsdf_pdf: f32,
    delta: bool,
}

/// What the previous vertex was ([`PathState`]'s flattened `Option<PrevVertex>`): none (the
/// path is on its camera ray), a vertex sampled through a delta lobe, or one with a density.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
enum PrevKind {
    // Smooth 0 and Delta 1, so that `set_prev` stores the `delta` flag's byte as it is.
    Smooth,
    Delta,
    None,
}

/// One path between two vertices: everything the estimator carries from one bounce to the next.
///
/// `repr(C)`, its first eight floats in the order of [`PathState::set_advanced_row`]'s row
/// (throughput, η, the previous vertex's point and BSDF density): what the end of a vertex
/// writes, contiguous, so the stream renderer's kernels store it as one 32-byte copy per path
/// rather than eight scalar stores.
#[derive(Clone, Copy, Debug)]
#[repr(C)]
pub struct PathState {
    pub throughput: Spectrum,
    /// Product of the relative indices of refraction crossed (for Russian roulette).
    pub eta: f32,
    /// The previous vertex's point and BSDF density (meaningful where `prev_kind` is not
    /// `None`; see [`PathState::prev`]).
    prev_p: Vec3,
    prev_pdf: f32,
    /// Radiance gathered so far.
    pub result: Spectrum,
    /// Vertices scattered from so far (0 while the camera ray is traced).
    pub depth: u32,
    prev_kind: PrevKind,
}

/// The previous vertex as the MIS weight of emission sees it ([`PathState::prev_mis`]): the
/// weight is `power_heuristic(pdf, light_pdf)` when `mis`, 0 when `zero`, else 1 (camera rays,
/// delta lobes, BSDF sampling only); `p` is the reference point of the light's density.
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
pub(crate) struct PrevMis {
    pub p: Vec3,
    pub pdf: f32,
    pub mis: bool,
    pub zero: bool,
}

/// A light sample whose shadow ray is still to be traced: `contribution` joins the path's
/// radiance when nothing blocks `shadow` ([`PathState::add_light`]).
#[derive(Clone, Copy, Debug)]
pub struct PendingLight {
    pub shadow: Ray,
    /// Throughput × MIS-weighted light sample, computed at the vertex that sampled it.
    pub contribution: Spectrum,
}

impl Default for PathState {
    fn default() -> Self {
        PathState::new()
    }
}

impl PathState {
    /// A path leaving the camera ([`PathState::new`] as a constant, for blocks of states).
    pub const NEW: PathState = PathState {
        result: Spectrum::ZERO,
        throughput: Spectrum::ONE,
        eta: 1.0,
        depth: 0,
        prev_p: Vec3::ZERO,
        prev_pdf: 0.0,
        prev_kind: PrevKind::None,
    };

    /// A path leaving the camera.
    pub fn new() -> PathState {
        PathState::NEW
    }

    /// The previous vertex, if any (the fields' `Option` form).
    #[inline(always)]
    fn prev(&self) -> Option<PrevVertex> {
        match self.prev_kind {
            PrevKind::None => None,
            kind => Some(PrevVertex {
                p: self.prev_p,
                bsdf_pdf: self.prev_pdf,
                delta: kind == PrevKind::Delta,
            }),
        }
    }

    /// Sets the previous vertex: point `p`, BSDF density `pdf`, through a delta lobe when
    /// `delta`.
    #[inline(always)]
    fn set_prev(&mut self, p: Vec3, pdf: f32, delta: bool) {
        self.prev_p = p;
        self.prev_pdf = pdf;
        self.prev_kind = if delta {
            PrevKind::Delta
        } else {
            PrevKind::Smooth
        };
    }

    /// The counter the ray of the current depth goes to.
    #[inline]
    pub fn ray_kind(&self) -> RayKind {
        if self.depth == 0 {
            RayKind::Camera
        } else {
            RayKind::Bounce
        }
    }

    /// Emission seen along `ray` (which hit `hit`, or escaped): environment light for an
    /// escaped ray, area light for a hit on an emitter, MIS-weighted against the BSDF sample
    /// that chose the ray. Returns whether the path scatters at `hit` (a hit, and
    /// depth + 1 < max_depth as in Mitsuba).
    #[inline]
    pub fn add_emission(
        &mut self,
        cfg: &PathSettings,
        scene: &Scene,
        ray: &Ray,
        hit: Option<&SurfaceInteraction>,
    ) -> bool {
        let show = self.depth > 0 || !cfg.hide_emitters;
        let prev = self.prev();
        let Some(si) = hit else {
            if show {
                for (e, em, le) in scene.env_emission(ray.d) {
                    let w = emission_weight(cfg, prev, || {
                        em.pdf_direct_env(ray.d) * scene.light_sampler.pmf(e)
                    });
                    self.result += self.throughput * le * w;
                }
            }
            return false;
        };
        if show {
            if let Some(e) = scene.shape_emitter[si.shape as usize] {
                let em = &scene.emitters[e as usize];
                let le = em.eval_surface(si);
                if le != Spectrum::ZERO {
                    let w = emission_weight(cfg, prev, || {
                        let p = prev.map_or(si.p, |v| v.p);
                        em.pdf_direct_surface(&scene.shapes, p, si)
                            * scene.light_sampler.pmf(e as usize)
                    });
                    self.result += self.throughput * le * w;
                }
            }
        }
        // Mitsuba: continue only while depth + 1 < max_depth.
        self.depth.saturating_add(1) < super::depth_limit(cfg.max_depth)
    }

    /// Scattering at `si`: builds the BSDF in `arena`, samples a light (the shadow ray is
    /// returned in `light`, not traced), samples the BSDF and plays Russian roulette. Returns
    /// the next ray, or `None` when the path ends here. `light` is set to `None` when no light
    /// sample is pending.
    #[inline]
    pub fn scatter(
        &mut self,
        cfg: &PathSettings,
        scene: &Scene,
        si: &SurfaceInteraction,
        sampler: &mut Sampler,
        arena: &mut BsdfArena,
        light: &mut Option<PendingLight>,
    ) -> Option<Ray> {
        *light = None;
        let ctx = BsdfContext::default();
        let bsdf = scene.bsdf_at(si, arena)?;

        // Next-event estimation.
        if cfg.strategy != Strategy::BsdfOnly && bsdf.lobes().is_smooth() {
            if let Some((ls, shadow)) = prepare_light(scene, si, &bsdf, &ctx, sampler) {
                let w = if ls.delta || cfg.strategy == Strategy::LightOnly {
                    1.0
                } else {
                    power_heuristic(ls.light_pdf, ls.bsdf_pdf)
                };
                *light = Some(PendingLight {
                    shadow,
                    contribution: self.throughput * (ls.f_value * (w / ls.light_pdf)),
                });
            }
        }

        // BSDF sampling.
        let bs = bsdf.sample(&ctx, sampler)?;
        self.advance_sampled(cfg, si, &bs, sampler)
    }

    /// [`Self::advance`] after the BSDF sample `bs` at `si` (the end of [`Self::scatter`];
    /// shared with the stream renderer's compensated-normal-map kernel, which samples lane by
    /// lane).
    #[inline(always)]
    pub(crate) fn advance_sampled(
        &mut self,
        cfg: &PathSettings,
        si: &SurfaceInteraction,
        bs: &SurfaceSample,
        sampler: &mut Sampler,
    ) -> Option<Ray> {
        let ray = si.spawn_ray(bs.wo);
        self.advance(
            cfg,
            si.p,
            bs.weight,
            bs.eta,
            bs.pdf,
            bs.lobe.intersects(Lobes::DELTA),
            ray,
            || sampler.next_1d(),
        )
    }

    /// The end of [`Self::scatter`], once the BSDF sampled `ray` (leaving the vertex `p` with
    /// sample weight `weight`, relative index of refraction `eta`, density `pdf`, through a
    /// delta lobe when `delta`): the throughput update, then Russian roulette (Mitsuba 3:
    /// survival min(max(throughput)·η², 0.95) from rr_depth on), which may draw one number
    /// (`roulette`: the path's next `next_1d`, from a row or the stream renderer's columns).
    /// Returns the ray, or `None` when the path ends. Shared with the stream renderer's 8-wide
    /// kernels (`crate::stream::kernels`), which call it lane by lane after their BSDF sample.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(crate) fn advance(
        &mut self,
        cfg: &PathSettings,
        p: Vec3,
        weight: Spectrum,
        eta: f32,
        pdf: f32,
        delta: bool,
        ray: Ray,
        roulette: impl FnOnce() -> f32,
    ) -> Option<Ray> {
        self.throughput *= weight;
        self.eta *= eta;
        self.set_prev(p, pdf, delta);
        self.depth += 1;

        let tmax = max_component(self.throughput);
        if !(tmax.is_finite() && tmax > 0.0) {
            return None;
        }
        if self.depth as i64 >= cfg.rr_depth as i64 {
            let q = (tmax * self.eta * self.eta).min(0.95);
            if roulette() >= q {
                return None;
            }
            self.throughput /= q;
        }
        Some(ray)
    }

    /// The state [`Self::advance`] leaves before its roulette, from `row` = [throughput x,
    /// y, z, η, p x, y, z, pdf] (the throughput and index products, the previous vertex `p`
    /// sampled with density `pdf`), through a delta lobe when `delta`, one vertex deeper. The
    /// row is this struct's first eight floats (`repr(C)`), so its eight stores are one copy.
    /// The stream renderer's lane form of `advance` ([`advance_lanes`],
    /// `crate::stream::kernels::vertex`) writes each lane's row with it (the roulette's
    /// division, where the path won it, after).
    #[inline(always)]
    pub(crate) fn set_advanced_row(&mut self, row: &[f32; 8], delta: bool) {
        self.throughput = Vec3::new(row[0], row[1], row[2]);
        self.eta = row[3];
        self.set_prev(Vec3::new(row[4], row[5], row[6]), row[7], delta);
        // `advance`'s `depth += 1` as release code runs it (depth never nears u32::MAX: it is
        // bounded by the path's vertices).
        self.depth = self.depth.wrapping_add(1);
    }

    /// This struct's first eight floats as one row: [throughput x, y, z, η, previous vertex
    /// x, y, z, its BSDF density] (the row [`Self::set_advanced_row`] writes; the point and
    /// density are meaningful where [`Self::prev_kind_i32`] is 0). Contiguous (`repr(C)`), so the
    /// stream renderer's emission stage reads it as one 32-byte load per path and transposes
    /// 8 paths' rows into lanes (`crate::stream::emission`).
    #[inline(always)]
    pub(crate) fn row8(&self) -> [f32; 8] {
        let (t, p) = (self.throughput, self.prev_p);
        [t.x, t.y, t.z, self.eta, p.x, p.y, p.z, self.prev_pdf]
    }

    /// The radiance and depth as one row of 4: [result x, y, z, depth's bits] (floats 8–11 of
    /// the `repr(C)` struct, one 16-byte load).
    #[inline(always)]
    pub(crate) fn result_row(&self) -> [f32; 4] {
        let r = self.result;
        [r.x, r.y, r.z, f32::from_bits(self.depth)]
    }

    /// Whether the previous vertex has a density (a vertex not sampled through a delta lobe,
    /// and not the camera), as an `i32` lane value: 0 where it has (`PrevKind::Smooth`'s byte),
    /// else 1 or 2. The emission stage compares 8 of them at once for `Self::prev_mis`'s
    /// flags.
    #[inline(always)]
    pub(crate) fn prev_kind_i32(&self) -> i32 {
        self.prev_kind as i32
    }

    /// What the MIS weight of emission seen by this path's ray needs of its previous vertex
    /// ([`emission_weight`] unrolled for the stream renderer's emission stage in lanes,
    /// `crate::stream::emission`): that vertex's point and BSDF density, and whether the weight
    /// is the power heuristic against the light's density (`mis`), 0 (`zero`), or else 1.
    /// The reference of the emission stage's lane form (which reads the fields as rows:
    /// [`Self::row8`], [`Self::prev_kind_i32`]) in its tests.
    #[cfg(test)]
    pub(crate) fn prev_mis(&self, cfg: &PathSettings) -> PrevMis {
        match self.prev() {
            Some(v) if !v.delta => PrevMis {
                p: v.p,
                pdf: v.bsdf_pdf,
                mis: cfg.strategy == Strategy::Mis,
                zero: cfg.strategy == Strategy::LightOnly,
            },
            _ => PrevMis {
                p: Vec3::ZERO,
                pdf: 0.0,
                mis: false,
                zero: false,
            },
        }
    }

    /// Adds a light sample whose shadow ray reached the light.
    #[inline]
    pub fn add_light(&mut self, light: &PendingLight) {
        self.add_unblocked(light.contribution);
    }

    /// [`Self::add_light`] of a sample kept as its contribution alone (the stream renderer's
    /// pending samples keep the shadow ray beside it, not in a `PendingLight`).
    #[inline(always)]
    pub fn add_unblocked(&mut self, contribution: Spectrum) {
        self.result += contribution;
    }
}

/// [`PathState::advance`]'s arithmetic for a lane per path, before its one random draw: the
/// throughput and index products, whether the path passes the throughput test (`live`) and
/// its roulette survival probability `q` (meaningful where `live`; roulette plays where also
/// depth + 1 ≥ rr_depth, decided by the caller, which draws there and compares `u ≥ q` to end
/// the path, as `advance` does).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Advanced<L: Lane> {
    pub throughput: V3<L>,
    pub eta: L,
    pub live: L::Mask,
    pub q: L,
}

/// `f32::max` in lanes (IEEE maxNum: a NaN operand gives the other one), from the x86 maximum
/// `b.max(a)` (`if b > a { b } else { a }`: a NaN `b` gives `a`) and a select for a NaN `a`.
/// Equal operands of different signs (±0) may come out with either sign; [`advance_lanes`]
/// reads the result only through `> 0`, where both zeros fail.
#[inline(always)]
fn max_num<L: Lane>(a: L, b: L) -> L {
    L::select(a.is_nan(), b, b.max(a))
}

/// [`PathState::advance`] up to its roulette draw, in lanes: from each path's throughput
/// `throughput` and index product `eta`, and its BSDF sample's weight `weight` and relative
/// index `eta_s`. Bit for bit `advance`'s operations in its order: the component-wise product,
/// `max_component` (`x.max(y).max(z)` with `f32::max`'s NaN rule: [`max_num`]), the finite and
/// positive test, `(tmax · η) · η` and `f32::min(…, 0.95)` (a NaN product gives 0.95: the x86
/// minimum `p.min(0.95)` returns its second operand then, as `f32::min` does; the two agree on
/// every other input, the product being never −0 where `tmax > 0`).
#[inline(always)]
pub(crate) fn advance_lanes<L: Lane>(
    throughput: V3<L>,
    eta: L,
    weight: V3<L>,
    eta_s: L,
) -> Advanced<L> {
    let t = throughput * weight;
    let eta = eta * eta_s;
    let tmax = max_num(max_num(t.x, t.y), t.z);
    let live = tmax.is_finite() & tmax.gt(tmax.splat(0.0));
    let q = (tmax * eta * eta).min(tmax.splat(0.95));
    Advanced {
        throughput: t,
        eta,
        live,
        q,
    }
}

/// Radiance along `ray`, one path depth first (the scalar renderer).
pub fn li(
    cfg: &PathSettings,
    scene: &Scene,
    mut ray: Ray,
    sampler: &mut Sampler,
    scratch: &mut Scratch,
) -> Spectrum {
    let mut st = PathState::new();
    if cfg.max_depth == 0 {
        return st.result;
    }
    let mut light = None;
    loop {
        let hit = scratch.rays.intersect(scene, &ray, st.ray_kind());
        if !st.add_emission(cfg, scene, &ray, hit.as_ref()) {
            break;
        }
        let Some(si) = hit else { break };
        let next = st.scatter(cfg, scene, &si, sampler, &mut scratch.arena, &mut light);
        if let Some(l) = &light {
            if !scratch.rays.occluded(scene, &l.shadow) {
                st.add_light(l);
            }
        }
        match next {
            Some(r) => ray = r,
            None => break,
        }
    }
    st.result
}

/// MIS weight of emission found by a BSDF-sampled ray (1 for camera rays and delta bounces).
#[inline]
fn emission_weight(
    cfg: &PathSettings,
    prev: Option<PrevVertex>,
    light_pdf: impl FnOnce() -> f32,
) -> f32 {
    match prev {
        None => 1.0,
        Some(v) if v.delta => 1.0,
        Some(v) => match cfg.strategy {
            Strategy::Mis => power_heuristic(v.bsdf_pdf, light_pdf()),
            Strategy::BsdfOnly => 1.0,
            Strategy::LightOnly => 0.0,
        },
    }
}
