//! `blendphase`: the mixture (1 − w)·p0 + w·p1 of two phase functions (Mitsuba 3's
//! `BlendPhaseFunction`: component 1 is picked with probability w, and the sample is weighted
//! by the mixture's value over the mixture's density).
//!
//! # XML parameters (Mitsuba 3 names)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `weight` | float | (required) | w, clamped to [0, 1]: 0 gives the first phase function, 1 the second |
//! | (two nested `<phase>`) | phase | (required) | the components, in document order |

use super::{Phase, PhaseSample};
use glam::{Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Blend {
    pub weight: f32,
    pub phases: [Phase; 2],
}

impl Blend {
    #[inline]
    pub fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (f32, f32) {
        let w = self.weight;
        let (v0, p0) = self.phases[0].eval_pdf(wi, wo);
        let (v1, p1) = self.phases[1].eval_pdf(wi, wo);
        ((1.0 - w) * v0 + w * v1, (1.0 - w) * p0 + w * p1)
    }

    #[inline]
    pub fn sample(&self, wi: Vec3, u1: f32, u2: Vec2) -> Option<PhaseSample> {
        let w = self.weight;
        let s = if w > 0.0 && u1 <= w {
            self.phases[1].sample(wi, u1 / w, u2)?
        } else {
            self.phases[0].sample(wi, (u1 - w) / (1.0 - w), u2)?
        };
        let (value, pdf) = self.eval_pdf(wi, s.wo);
        if pdf.is_nan() || pdf <= 0.0 {
            return None;
        }
        Some(PhaseSample {
            wo: s.wo,
            weight: value / pdf,
            pdf,
        })
    }
}
