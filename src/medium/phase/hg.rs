//! `hg`: the Henyey–Greenstein phase function (Henyey & Greenstein 1941, "Diffuse radiation in
//! the galaxy"), p(μ) = (1 − g²) / (4π (1 + g² − 2gμ)^{3/2}) for the cosine μ between the
//! sampled direction and the direction of propagation; g > 0 scatters forward. Sampled by
//! inverting its CDF in μ (PBRT 3rd ed. §15.2.3).
//!
//! # XML parameters (Mitsuba 3 names and defaults)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `g` | float | 0.8 | mean cosine of scattering, in (−1, 1) |

use super::PhaseSample;
use crate::math::frame::Frame;
use glam::{Vec2, Vec3};
use std::f32::consts::{FRAC_1_PI, TAU};

#[derive(Clone, Copy, Debug)]
pub struct Hg {
    pub g: f32,
}

impl Hg {
    /// p as a function of μ = cos(angle between `wo` and the propagation direction −`wi`).
    #[inline]
    fn eval_mu(&self, mu: f32) -> f32 {
        let g = self.g;
        let t = 1.0 + g * g - 2.0 * g * mu;
        0.25 * FRAC_1_PI * (1.0 - g * g) / (t * t.max(0.0).sqrt())
    }

    #[inline]
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.eval_mu(-wi.dot(wo))
    }

    #[inline]
    pub fn sample(&self, wi: Vec3, u: Vec2) -> PhaseSample {
        let g = self.g;
        let mu = if g.abs() < 1e-3 {
            1.0 - 2.0 * u.x
        } else {
            let s = (1.0 - g * g) / (1.0 - g + 2.0 * g * u.x);
            ((1.0 + g * g - s * s) / (2.0 * g)).clamp(-1.0, 1.0)
        };
        let sin = (1.0 - mu * mu).max(0.0).sqrt();
        let (sp, cp) = (TAU * u.y).sin_cos();
        let frame = Frame::from_normal(-wi);
        let wo = frame
            .to_world(Vec3::new(sin * cp, sin * sp, mu))
            .normalize();
        PhaseSample {
            wo,
            weight: 1.0,
            pdf: self.eval_mu(mu),
        }
    }
}
