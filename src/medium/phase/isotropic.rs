//! `isotropic`: scatters equally in every direction, 1/(4π) per steradian.
//!
//! # XML parameters
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | (none) | | | `isotropic` takes no parameters |

use super::PhaseSample;
use crate::math::warp::{square_to_uniform_sphere, uniform_sphere_pdf};
use glam::Vec2;

/// The constant value 1/(4π).
#[inline]
pub fn eval() -> f32 {
    uniform_sphere_pdf()
}

/// A uniformly distributed direction (weight 1).
#[inline]
pub fn sample(u: Vec2) -> PhaseSample {
    PhaseSample {
        wo: square_to_uniform_sphere(u),
        weight: 1.0,
        pdf: uniform_sphere_pdf(),
    }
}
