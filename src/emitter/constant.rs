//! `constant`: a uniform environment of `radiance` from every direction (Mitsuba's `constant`),
//! sampled uniformly over the sphere.

use super::DirectSample;
use crate::math::warp;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct ConstantLight {
    pub radiance: Spectrum,
}

impl ConstantLight {
    pub fn sample_direct(&self, u: Vec2) -> Option<DirectSample> {
        let d = warp::square_to_uniform_sphere(u);
        Some(DirectSample {
            d,
            dist: f32::INFINITY,
            p: d,
            n: None,
            pdf: warp::uniform_sphere_pdf(),
            value: self.radiance,
            delta: false,
        })
    }

    pub fn pdf_direct(&self, _d: Vec3) -> f32 {
        warp::uniform_sphere_pdf()
    }

    pub fn eval(&self, _d: Vec3) -> Spectrum {
        self.radiance
    }
}
