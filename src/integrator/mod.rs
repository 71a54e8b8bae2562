//! Integrators: estimate the radiance arriving along a camera ray.

pub mod direct;
pub mod nee;
pub mod path;
pub mod rays;

pub use rays::{LoggedRay, RayCounters, RayKind, Rays};

use crate::bsdf::BsdfArena;
use crate::geometry::Ray;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::Spectrum;

/// Which strategies estimate direct light. `Mis` is the renderer's behaviour; the others exist
/// to test that MIS is unbiased (all three must agree in expectation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Strategy {
    Mis,
    LightOnly,
    BsdfOnly,
}

/// Mitsuba's `path` integrator settings.
#[derive(Clone, Copy, Debug)]
pub struct PathSettings {
    /// Longest path, in vertices, counting the camera ray's hit as 1 (−1: unlimited).
    /// 1 = only directly visible emitters, 2 = direct illumination.
    pub max_depth: i32,
    /// Depth from which Russian roulette starts.
    pub rr_depth: i32,
    pub hide_emitters: bool,
    pub strategy: Strategy,
}

impl Default for PathSettings {
    fn default() -> Self {
        PathSettings {
            max_depth: -1,
            rr_depth: 5,
            hide_emitters: false,
            strategy: Strategy::Mis,
        }
    }
}

/// Mitsuba's `direct` integrator settings.
#[derive(Clone, Copy, Debug)]
pub struct DirectSettings {
    pub emitter_samples: u32,
    pub bsdf_samples: u32,
    pub hide_emitters: bool,
}

#[derive(Clone, Copy, Debug)]
pub enum IntegratorDesc {
    Path(PathSettings),
    Direct(DirectSettings),
}

/// Per-thread scratch state of an integrator (no allocation per ray).
#[derive(Default)]
pub struct Scratch {
    pub arena: BsdfArena,
    /// Every ray goes through here: counted, and recorded when the render asks.
    pub rays: Rays,
}

impl IntegratorDesc {
    /// Radiance along the camera ray `ray`.
    #[inline]
    pub fn li(
        &self,
        scene: &Scene,
        ray: Ray,
        sampler: &mut Sampler,
        scratch: &mut Scratch,
    ) -> Spectrum {
        match self {
            IntegratorDesc::Path(s) => path::li(s, scene, ray, sampler, scratch),
            IntegratorDesc::Direct(s) => direct::li(s, scene, ray, sampler, scratch),
        }
    }
}
