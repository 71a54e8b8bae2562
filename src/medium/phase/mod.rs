//! Phase functions (Mitsuba 3's `<phase>` plugins): the angular distribution of light scattered
//! in a medium. Directions follow Mitsuba's convention: `wi` points back toward where the light
//! goes (−ray direction), `wo` where it comes from or is sampled to; all three here are
//! reciprocal, and their value equals their sampling density (weight 1, or the blend's ratio).

pub mod blendphase;
pub mod hg;
pub mod isotropic;

pub use blendphase::Blend;
pub use hg::Hg;

use glam::{Vec2, Vec3};

/// A sampled direction.
#[derive(Clone, Copy, Debug)]
pub struct PhaseSample {
    pub wo: Vec3,
    /// value / pdf.
    pub weight: f32,
    /// Solid-angle density of `wo`.
    pub pdf: f32,
}

#[derive(Clone, Debug)]
pub enum Phase {
    Isotropic,
    Hg(Hg),
    Blend(Box<Blend>),
}

impl Phase {
    /// Value (per steradian) for the pair of unit directions, and the density with which
    /// [`Phase::sample`] picks `wo` (value, pdf).
    #[inline]
    pub fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (f32, f32) {
        match self {
            Phase::Isotropic => {
                let p = isotropic::eval();
                (p, p)
            }
            Phase::Hg(h) => {
                let p = h.eval(wi, wo);
                (p, p)
            }
            Phase::Blend(b) => b.eval_pdf(wi, wo),
        }
    }

    /// Samples `wo` from two uniform numbers (`u1` picks a blend's component, `u2` the
    /// direction); `None` when the sample carries nothing.
    #[inline]
    pub fn sample(&self, wi: Vec3, u1: f32, u2: Vec2) -> Option<PhaseSample> {
        match self {
            Phase::Isotropic => Some(isotropic::sample(u2)),
            Phase::Hg(h) => Some(h.sample(wi, u2)),
            Phase::Blend(b) => b.sample(wi, u1, u2),
        }
    }
}
