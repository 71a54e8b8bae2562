//! Integrators: estimate the radiance arriving along a camera ray.

pub mod direct;
pub mod path;

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

/// Ray counts of one thread, summed by the renderer.
#[derive(Clone, Copy, Debug, Default)]
pub struct RayCounters {
    pub camera: u64,
    pub bounce: u64,
    pub shadow: u64,
    /// Random walks sampled by microfacet normal maps, and their vertices (not rays).
    pub walks: u64,
    pub walk_vertices: u64,
}

impl RayCounters {
    /// Rays traced (camera + bounce + shadow).
    pub fn total(&self) -> u64 {
        self.camera + self.bounce + self.shadow
    }
    pub fn add(&mut self, o: &RayCounters) {
        self.camera += o.camera;
        self.bounce += o.bounce;
        self.shadow += o.shadow;
        self.walks += o.walks;
        self.walk_vertices += o.walk_vertices;
    }
    /// Mean vertices per sampled microfacet walk (0 without walks).
    pub fn mean_walk_length(&self) -> f64 {
        if self.walks == 0 {
            0.0
        } else {
            self.walk_vertices as f64 / self.walks as f64
        }
    }
}

/// Per-thread scratch state of an integrator (no allocation per ray).
#[derive(Default)]
pub struct Scratch {
    pub arena: BsdfArena,
    pub counters: RayCounters,
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
