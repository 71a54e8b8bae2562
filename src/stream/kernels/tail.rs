//! The end of a vertex, split from the 8-wide kernels so that both integrators of the stream
//! renderer run them: a kernel computes a chunk's light samples (shadow ray and contribution)
//! and BSDF samples 8-wide, then hands each lane's results to a [`Tail`]. The `path`
//! integrator's tail ([`PathTail`]) keeps the light sample pending and ends the vertex in
//! `PathState::advance` (throughput update, Russian roulette); the `direct` integrator's tail
//! (`stream::direct`) records both samples as rays to trace, keeping the zero-weight BSDF
//! samples that `advance` would drop (the scalar `direct` traces them). Under the `path`
//! integrator ([`Tail::advances`]) the wrapper-chain, `blendbsdf`, `diffuse` and `plastic`
//! kernels end their chunk's vertices in lanes instead ([`advance`]: `PathState::advance`'s
//! arithmetic in lanes on the batch's path columns, the stores and the roulette's draws lane
//! by lane); the compensated normal map's kernel still goes through [`Tail::bsdf`].
//!
//! A tail also shades lane by lane the paths no kernel takes ([`Tail::scalar`]), so one shading
//! stage (`stream::shade`) serves both integrators.

use crate::bsdf::BsdfArena;
use crate::geometry::Ray;
use crate::integrator::path::PendingLight;
use crate::integrator::PathSettings;
use crate::lane::vec::V3;
use crate::lane::{Lane, LaneI32, ToArray, Wide};
use crate::scene::Scene;
use crate::spectrum::Spectrum;
use crate::stream::batch::{pcol, Batch};
use crate::stream::kernels::light::x8::Cols3;
use crate::stream::BATCH;
use glam::Vec3;

/// A BSDF sample of one lane: the ray leaving the vertex `p`, the sample weight, the relative
/// index of refraction of the crossing, the density and whether it went through a delta lobe.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sampled {
    pub p: Vec3,
    pub ray: Ray,
    pub weight: Spectrum,
    pub eta: f32,
    pub pdf: f32,
    pub delta: bool,
}

/// What becomes of a vertex's samples, lane by lane, in each path's order (its light sample,
/// then its BSDF sample).
pub(crate) trait Tail {
    /// Whether the 8-wide kernels may shade (else every path goes through [`Tail::scalar`]).
    fn kernels(&self) -> bool;
    /// Path `i`'s light sample: its shadow ray and contribution (throughput × f·Le × MIS
    /// weight / density, the weight of `PathState::scatter`).
    fn light(&mut self, b: &mut Batch, i: usize, shadow: Ray, contribution: Spectrum);
    /// Path `i`'s BSDF sample (one that passed `SurfaceBsdf::sample`'s tests).
    fn bsdf(&mut self, b: &mut Batch, i: usize, s: &Sampled);
    /// Shades path `i` (at the surface in its row of `b.surf`) with the 1-lane code.
    fn scalar(&mut self, scene: &Scene, b: &mut Batch, i: usize, arena: &mut BsdfArena);
    /// The settings under which [`Tail::bsdf`] is `PathState::advance` on the batch's path
    /// columns (the `path` integrator), which a kernel may then run for a chunk in lanes
    /// ([`advance`]); `None` where it is something else.
    #[inline(always)]
    fn advances(&self) -> Option<PathSettings> {
        None
    }
}

/// The BSDF samples of a chunk, in lanes, as [`advance`] reads them: per lane whether it
/// sampled, the vertex point, the ray's origin and direction, the sample weight, the relative
/// index of refraction, the density and whether the lobe was a delta.
pub(crate) struct Lanes<'a, L: Lane, const W: usize> {
    pub ok: L::Mask,
    pub p: &'a Cols3<W>,
    pub o: V3<L>,
    pub wo: V3<L>,
    pub weight: V3<L>,
    pub eta: L,
    pub pdf: L,
    pub delta: L::Mask,
}

/// `PathState::advance` of a chunk's BSDF samples (the lanes that are `front` and sampled,
/// `tp` their paths' throughputs) on the batch's path columns: the throughput and η products
/// and the Russian roulette's survival probability in lanes, the same operations in the same
/// order (`f32::max`/`min`'s NaN rules kept); then, lane by lane in path order, the stores and
/// the roulette's draw where the depth reaches `rr_depth`.
#[inline(always)]
pub(crate) fn advance<T: Wide<W>, const W: usize>(
    avx: T,
    cfg: &PathSettings,
    b: &mut Batch,
    ids: &[u32; W],
    front: &[bool; W],
    tp: V3<T::F>,
    s: &Lanes<T::F, W>,
) {
    let mut idx = [0i32; W];
    for k in 0..W {
        idx[k] = ids[k] as i32;
    }
    let idx = avx.load_i32(&idx);
    // self.throughput *= weight; self.eta *= eta;
    let t = V3::new(tp.x * s.weight.x, tp.y * s.weight.y, tp.z * s.weight.z);
    let at = idx.add(idx.splat((pcol::ETA * BATCH) as i32));
    let eta = <T::F as Lane>::gather(b.paths.flat(), at) * s.eta;
    // max_component: x.max(y).max(z), where f32::max ignores a NaN operand (the lane `max`
    // returns its second operand when either is NaN).
    let m = <T::F as Lane>::select(t.y.is_nan(), t.x, t.x.max(t.y));
    let tmax = <T::F as Lane>::select(t.z.is_nan(), m, m.max(t.z));
    let live = tmax.is_finite() & tmax.gt(avx.splat(0.0));
    // (tmax · η · η).min(0.95): the lane `min` gives 0.95 for NaN, as f32::min.
    let q = (tmax * eta * eta).min(avx.splat(0.95));
    let (ok, live, delta) = (s.ok.to_array(), live.to_array(), s.delta.to_array());
    let (tx, ty, tz) = (t.x.to_array(), t.y.to_array(), t.z.to_array());
    let (eta, q, pdf) = (eta.to_array(), q.to_array(), s.pdf.to_array());
    let (o, wo) = (Cols3::store(s.o), Cols3::store(s.wo));
    for (k, &i) in ids.iter().enumerate() {
        if !(front[k] && ok[k]) {
            continue;
        }
        let i = i as usize;
        let paths = &mut b.paths;
        paths.put(pcol::ETA, i, eta[k]);
        paths.set_prev(i, s.p.get(k), pdf[k], delta[k]);
        let depth = paths.depth(i) + 1;
        paths.set_depth(i, depth);
        let (mut x, mut y, mut z) = (tx[k], ty[k], tz[k]);
        let mut survives = live[k];
        if survives && depth as i64 >= cfg.rr_depth as i64 {
            let q = q[k];
            if b.sampler[i].next_1d() >= q {
                survives = false;
            } else {
                // self.throughput /= q
                (x, y, z) = (x / q, y / q, z / q);
            }
        }
        b.paths.put3(pcol::THROUGHPUT, i, Vec3::new(x, y, z));
        if survives {
            b.ray[i] = Ray::new(o.get(k), wo.get(k));
            b.alive[i] = true;
        }
    }
}

/// The `path` integrator's tail: the pending light sample, then `PathState::advance`.
pub(crate) struct PathTail<'a> {
    pub cfg: &'a PathSettings,
}

impl Tail for PathTail<'_> {
    #[inline(always)]
    fn kernels(&self) -> bool {
        true
    }

    #[inline(always)]
    fn advances(&self) -> Option<PathSettings> {
        Some(*self.cfg)
    }

    #[inline(always)]
    fn light(&mut self, b: &mut Batch, i: usize, shadow: Ray, contribution: Spectrum) {
        b.light[i] = Some(PendingLight {
            shadow,
            contribution,
        });
    }

    #[inline(always)]
    fn bsdf(&mut self, b: &mut Batch, i: usize, s: &Sampled) {
        let mut st = b.paths.get(i);
        let next = st.advance(
            self.cfg,
            s.p,
            s.weight,
            s.eta,
            s.pdf,
            s.delta,
            s.ray,
            &mut b.sampler[i],
        );
        b.paths.set_vertex(i, &st);
        if let Some(r) = next {
            b.ray[i] = r;
            b.alive[i] = true;
        }
    }

    #[inline]
    fn scalar(&mut self, scene: &Scene, b: &mut Batch, i: usize, arena: &mut BsdfArena) {
        let si = b.surf.get(i);
        let mut st = b.paths.get(i);
        let next = st.scatter(
            self.cfg,
            scene,
            &si,
            &mut b.sampler[i],
            arena,
            &mut b.light[i],
        );
        b.paths.set(i, &st);
        if let Some(r) = next {
            b.ray[i] = r;
            b.alive[i] = true;
        }
    }
}
