//! Light sources. Each emitter can be sampled from a reference point (next-event estimation),
//! report the density of that strategy for a given light point (MIS), and give its emitted
//! radiance when a path hits it.

pub mod area;
pub mod constant;
pub mod directional;
pub mod emission;
pub mod envmap;
pub mod light_sampler;
pub mod point;
pub mod projector;
pub mod spot;

pub use light_sampler::LightSampler;

use crate::geometry::{Shape, SurfaceInteraction};
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

/// A light point chosen by next-event estimation.
#[derive(Clone, Copy, Debug)]
pub struct DirectSample {
    /// Unit direction from the reference point toward the light.
    pub d: Vec3,
    /// Distance to the light point (`f32::INFINITY` for environment lights).
    pub dist: f32,
    /// The light point and its surface normal (`None` for points and environment lights).
    pub p: Vec3,
    pub n: Option<Vec3>,
    /// Solid-angle density of `d` (for delta lights: 1, and `delta` is set).
    pub pdf: f32,
    /// Incident radiance from the light along `-d` (for a point light: intensity / dist²).
    pub value: Spectrum,
    pub delta: bool,
}

#[derive(Clone, Debug)]
pub enum Emitter {
    Area(area::AreaLight),
    Point(point::PointLight),
    Constant(constant::ConstantLight),
    Spot(spot::SpotLight),
    Directional(directional::DirectionalLight),
    EnvMap(envmap::EnvMapLight),
    Projector(projector::ProjectorLight),
}

impl Emitter {
    /// Sample a light point as seen from `ref_p`.
    pub fn sample_direct(&self, shapes: &[Shape], ref_p: Vec3, u: Vec2) -> Option<DirectSample> {
        match self {
            Emitter::Area(a) => a.sample_direct(shapes, ref_p, u),
            Emitter::Point(p) => p.sample_direct(ref_p),
            Emitter::Constant(c) => c.sample_direct(u),
            Emitter::Spot(s) => s.sample_direct(ref_p),
            Emitter::Directional(d) => d.sample_direct(ref_p),
            Emitter::EnvMap(m) => m.sample_direct(ref_p, u),
            Emitter::Projector(p) => p.sample_direct(ref_p),
        }
    }

    /// Density (solid angle at `ref_p`) with which `sample_direct` picks the surface point `si`.
    pub fn pdf_direct_surface(
        &self,
        shapes: &[Shape],
        ref_p: Vec3,
        si: &SurfaceInteraction,
    ) -> f32 {
        match self {
            Emitter::Area(a) => a.pdf_direct(shapes, ref_p, si),
            _ => 0.0,
        }
    }

    /// Density with which `sample_direct` picks the direction `d` of an environment light.
    pub fn pdf_direct_env(&self, d: Vec3) -> f32 {
        match self {
            Emitter::Constant(c) => c.pdf_direct(d),
            Emitter::EnvMap(m) => m.pdf_direct(d),
            _ => 0.0,
        }
    }

    /// Radiance leaving a hit point of an area light toward `si.wi`.
    pub fn eval_surface(&self, si: &SurfaceInteraction) -> Spectrum {
        match self {
            Emitter::Area(a) => a.eval(si),
            _ => Spectrum::ZERO,
        }
    }

    /// Radiance arriving from an environment light along a ray that escapes in direction `d`.
    pub fn eval_env(&self, d: Vec3) -> Spectrum {
        match self {
            Emitter::Constant(c) => c.eval(d),
            Emitter::EnvMap(m) => m.eval(d),
            _ => Spectrum::ZERO,
        }
    }

    /// True for lights that are points or a single direction (found only by next-event
    /// estimation, never by a ray).
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Emitter::Point(_) | Emitter::Spot(_) | Emitter::Directional(_) | Emitter::Projector(_)
        )
    }

    /// True for lights at infinity seen by rays that escape the scene (not the directional
    /// light: a delta light, found only by next-event estimation).
    pub fn is_environment(&self) -> bool {
        matches!(self, Emitter::Constant(_) | Emitter::EnvMap(_))
    }

    /// Total emitted power estimate (luminance), for light selection. `scene_radius` sizes
    /// environment lights.
    pub fn power(&self, shapes: &[Shape], scene_radius: f32) -> f32 {
        let lum = crate::spectrum::luminance;
        let pi = crate::math::PI;
        match self {
            Emitter::Area(a) => pi * shapes[a.shape as usize].area() * lum(a.radiance.mean()),
            Emitter::Point(p) => 4.0 * pi * lum(p.intensity),
            Emitter::Constant(c) => pi * scene_radius * scene_radius * 4.0 * pi * lum(c.radiance),
            // Intensity × the solid angle of the cone (with its falloff and texture).
            Emitter::Spot(s) => s.power(),
            Emitter::Projector(p) => p.power(),
            // Irradiance × the cross-section of the scene's bounding sphere.
            Emitter::Directional(d) => pi * scene_radius * scene_radius * lum(d.irradiance),
            // Mean radiance × 4π × the cross-section of the bounding sphere.
            Emitter::EnvMap(m) => pi * scene_radius * scene_radius * 4.0 * pi * m.mean_luminance(),
        }
        .max(0.0)
    }
}
