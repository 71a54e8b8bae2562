//! The end of a vertex, split from the 8-wide kernels so that both integrators of the stream
//! renderer run them: a kernel computes a chunk's light samples (shadow ray and contribution)
//! and BSDF samples 8-wide, then hands each lane's results to a [`Tail`]. The `path`
//! integrator's tail ([`PathTail`]) keeps the light sample pending and ends the vertex in
//! `PathState::advance` (throughput update, Russian roulette); the `direct` integrator's tail
//! (`stream::direct`) records both samples as rays to trace, keeping the zero-weight BSDF
//! samples that `advance` would drop (the scalar `direct` traces them).
//!
//! A tail also shades lane by lane the paths no kernel takes ([`Tail::scalar`]), so one shading
//! stage (`stream::shade`) serves both integrators.

use crate::bsdf::BsdfArena;
use crate::geometry::Ray;
use crate::integrator::PathSettings;
use crate::scene::Scene;
use crate::spectrum::Spectrum;
use crate::stream::batch::Batch;
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
    /// The `path` integrator's settings when this tail is its [`PathTail`] (whose
    /// [`Tail::light`] only stores the sample and whose [`Tail::bsdf`] is `PathState::advance`):
    /// then a kernel may end a chunk's vertices in lanes (`kernels::vertex::x8::scatter`).
    fn path(&self) -> Option<&PathSettings> {
        None
    }
    /// Path `i`'s light sample: its shadow ray and contribution (throughput × f·Le × MIS
    /// weight / density, the weight of `PathState::scatter`).
    fn light(&mut self, b: &mut Batch, i: usize, shadow: Ray, contribution: Spectrum);
    /// Path `i`'s BSDF sample (one that passed `SurfaceBsdf::sample`'s tests).
    fn bsdf(&mut self, b: &mut Batch, i: usize, s: &Sampled);
    /// Shades path `i` (at the surface in its row of `b.surf`) with the 1-lane code.
    fn scalar(&mut self, scene: &Scene, b: &mut Batch, i: usize, arena: &mut BsdfArena);
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
    fn path(&self) -> Option<&PathSettings> {
        Some(self.cfg)
    }

    #[inline(always)]
    fn light(&mut self, b: &mut Batch, i: usize, shadow: Ray, contribution: Spectrum) {
        b.push_light(i as u32, shadow, contribution);
    }

    #[inline(always)]
    fn bsdf(&mut self, b: &mut Batch, i: usize, s: &Sampled) {
        let next = b.state[i].advance(
            self.cfg,
            s.p,
            s.weight,
            s.eta,
            s.pdf,
            s.delta,
            s.ray,
            || b.sampler.next_1d(i),
        );
        if let Some(r) = next {
            b.ray[i] = r;
            b.set_alive(i);
        }
    }

    #[inline]
    fn scalar(&mut self, scene: &Scene, b: &mut Batch, i: usize, arena: &mut BsdfArena) {
        let si = b.surf.get(i);
        let mut light = None;
        let next = b.state[i].scatter(
            self.cfg,
            scene,
            &si,
            &mut b.sampler.at(i),
            arena,
            &mut light,
        );
        if let Some(l) = light {
            b.push_light(i as u32, l.shadow, l.contribution);
        }
        if let Some(r) = next {
            b.ray[i] = r;
            b.set_alive(i);
        }
    }
}
