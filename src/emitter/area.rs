//! `area`: a shape that emits radiance from its front side (Mitsuba's `area` emitter). Sampled by
//! the shape's own direction sampling (area measure for meshes, visible cone for spheres).

use super::DirectSample;
use crate::geometry::{Shape, SurfaceInteraction};
use crate::spectrum::Spectrum;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct AreaLight {
    /// Index of the emitting shape.
    pub shape: u32,
    pub radiance: Texture,
}

impl AreaLight {
    pub fn sample_direct(&self, shapes: &[Shape], ref_p: Vec3, u: Vec2) -> Option<DirectSample> {
        let ds = shapes[self.shape as usize].sample_direction(ref_p, u)?;
        // Emits only from the front: the light point must face the reference point.
        if ds.n.dot(-ds.d) <= 0.0 || !(ds.pdf.is_finite() && ds.pdf > 0.0) {
            return None;
        }
        Some(DirectSample {
            d: ds.d,
            dist: ds.dist,
            p: ds.p,
            n: Some(ds.n),
            pdf: ds.pdf,
            value: self.radiance.eval(ds.uv),
            delta: false,
        })
    }

    pub fn pdf_direct(&self, shapes: &[Shape], ref_p: Vec3, si: &SurfaceInteraction) -> f32 {
        if si.sh.n.dot(si.wi) <= 0.0 {
            return 0.0;
        }
        shapes[self.shape as usize].pdf_direction(ref_p, si)
    }

    pub fn eval(&self, si: &SurfaceInteraction) -> Spectrum {
        if si.sh.n.dot(si.wi) <= 0.0 {
            return Spectrum::ZERO;
        }
        self.radiance.eval(si.uv)
    }
}
