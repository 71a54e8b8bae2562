//! Integrators: estimate the radiance arriving along a camera ray.

pub mod aov;
pub mod direct;
mod media_nee;
pub mod moment;
pub mod nee;
pub mod path;
pub mod ptracer;
pub mod rays;
pub mod splat;
pub mod volpath;
pub mod volpathmis;

pub use rays::{LoggedRay, RayCounters, RayKind, Rays};

use std::sync::Arc;

use crate::bsdf::BsdfArena;
use crate::geometry::{Ray, SurfaceInteraction};
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

/// An integrator of the scene file. `Moment` and `Aov` wrap others (Mitsuba's nesting) and add
/// output channels ([`IntegratorDesc::aov_names`]) beside the RGB image.
#[derive(Clone, Debug)]
pub enum IntegratorDesc {
    Path(PathSettings),
    Direct(DirectSettings),
    /// Volumetric path tracing ([`volpath`]).
    Volpath(volpath::VolpathSettings),
    /// Volumetric path tracing with spectral MIS ([`volpathmis`]).
    VolpathMis(Arc<volpathmis::VolpathMisSettings>),
    Moment(Arc<moment::MomentSettings>),
    Aov(Arc<aov::AovSettings>),
    /// Light tracing: rendered by its own loop ([`ptracer::render`], which
    /// [`crate::render::render`] calls), not per camera ray; the loader refuses it inside
    /// `moment` and `aov` (as Mitsuba, whose adjoint integrators are not sampling integrators).
    Ptracer(Arc<ptracer::PtracerSettings>),
}

/// Per-thread scratch state of an integrator (no allocation per ray).
#[derive(Default)]
pub struct Scratch {
    pub arena: BsdfArena,
    /// The BSDFs of the surfaces a volumetric shadow ray passes (`volpath`), apart from
    /// `arena`, which holds the shading point's BSDF meanwhile.
    pub shadow_arena: BsdfArena,
    /// Every ray goes through here: counted, and recorded when the render asks.
    pub rays: Rays,
}

impl IntegratorDesc {
    /// Radiance along the camera ray `ray` (the extra channels of a wrapper are discarded:
    /// use [`IntegratorDesc::sample`] to get them).
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
            IntegratorDesc::Volpath(s) => volpath::li(s, scene, ray, sampler, scratch),
            IntegratorDesc::VolpathMis(s) => volpathmis::li(s, scene, ray, sampler, scratch),
            IntegratorDesc::Moment(_) | IntegratorDesc::Aov(_) | IntegratorDesc::Ptracer(_) => {
                self.sample(scene, ray, sampler, scratch, &mut [])
            }
        }
    }

    /// Names of the extra output channels, in Mitsuba 3.9.1's order and spelling
    /// (`SamplingIntegrator::aov_names`): none for `path` and `direct`.
    pub fn aov_names(&self) -> Vec<String> {
        match self {
            IntegratorDesc::Path(_)
            | IntegratorDesc::Direct(_)
            | IntegratorDesc::Volpath(_)
            | IntegratorDesc::VolpathMis(_)
            | IntegratorDesc::Ptracer(_) => Vec::new(),
            IntegratorDesc::Moment(m) => m.aov_names(),
            IntegratorDesc::Aov(a) => a.aov_names(),
        }
    }

    /// Number of extra output channels (the length of [`IntegratorDesc::aov_names`]).
    pub fn aov_count(&self) -> usize {
        match self {
            IntegratorDesc::Path(_)
            | IntegratorDesc::Direct(_)
            | IntegratorDesc::Volpath(_)
            | IntegratorDesc::VolpathMis(_)
            | IntegratorDesc::Ptracer(_) => 0,
            IntegratorDesc::Moment(m) => m.aov_count(),
            IntegratorDesc::Aov(a) => a.aov_count(),
        }
    }

    /// Mitsuba's `SamplingIntegrator::sample`: the radiance along `ray`, with the extra channels
    /// written to `aovs`. When `aovs` is shorter than [`IntegratorDesc::aov_count`] (e.g.
    /// empty) the channels are not written, only the radiance is estimated.
    #[inline]
    pub fn sample(
        &self,
        scene: &Scene,
        ray: Ray,
        sampler: &mut Sampler,
        scratch: &mut Scratch,
        aovs: &mut [f32],
    ) -> Spectrum {
        match self {
            IntegratorDesc::Path(s) => path::li(s, scene, ray, sampler, scratch),
            IntegratorDesc::Direct(s) => direct::li(s, scene, ray, sampler, scratch),
            IntegratorDesc::Volpath(s) => volpath::li(s, scene, ray, sampler, scratch),
            IntegratorDesc::VolpathMis(s) => volpathmis::li(s, scene, ray, sampler, scratch),
            IntegratorDesc::Moment(m) => m.sample(scene, ray, sampler, scratch, aovs),
            IntegratorDesc::Aov(a) => a.sample(scene, ray, sampler, scratch, aovs),
            // No estimate along a camera ray: light tracing splats (see the variant's comment).
            IntegratorDesc::Ptracer(_) => Spectrum::ZERO,
        }
    }

    /// Mitsuba's `valid` mask of this integrator's sample for a camera ray whose first hit is
    /// `hit`: the alpha of the `aov` integrator's inner images. `path`: a visible environment,
    /// or a surface from which the path continues (with `max_depth` 1: a seen emitter); Mitsuba
    /// also leaves it false when every vertex is a `null` pass-through into the void, groove
    /// counts that hit. `direct`: a surface hit. Wrappers: their first inner integrator's.
    pub fn valid(&self, scene: &Scene, hit: Option<&SurfaceInteraction>) -> bool {
        match self {
            IntegratorDesc::Path(s) => {
                let env = !s.hide_emitters && !scene.env_emitters.is_empty();
                match s.max_depth {
                    0 => false,
                    1 => {
                        env || (!s.hide_emitters
                            && hit
                                .is_some_and(|si| scene.shape_emitter[si.shape as usize].is_some()))
                    }
                    _ => env || hit.is_some(),
                }
            }
            IntegratorDesc::Direct(_) => hit.is_some(),
            // Mitsuba's volpath: a visible environment, or any real scattering event (at a
            // surface, or in the sensor's medium: counted here from the first hit).
            IntegratorDesc::Volpath(s) => {
                (!s.hide_emitters && !scene.env_emitters.is_empty())
                    || hit.is_some()
                    || scene.camera_medium.is_some()
            }
            // Mitsuba's volpathmis: the same rule.
            IntegratorDesc::VolpathMis(s) => {
                (!s.hide_emitters && !scene.env_emitters.is_empty())
                    || hit.is_some()
                    || scene.camera_medium.is_some()
            }
            IntegratorDesc::Ptracer(_) => false,
            IntegratorDesc::Moment(m) => m.inner.first().is_some_and(|(_, i)| i.valid(scene, hit)),
            IntegratorDesc::Aov(a) => a.inner.first().is_some_and(|(_, i)| i.valid(scene, hit)),
        }
    }
}

/// Mitsuba's `max_depth` as a bounce limit: −1 (any negative value) means no limit.
#[inline]
pub(crate) fn depth_limit(max_depth: i32) -> u32 {
    u32::try_from(max_depth).unwrap_or(u32::MAX)
}
