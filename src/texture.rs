//! Textures: spatially varying colours looked up by uv. A material evaluates its textures at a hit
//! and hands plain values to the BSDFs (which never see uvs).

use crate::spectrum::Spectrum;
use glam::{Mat3, Vec2};

#[derive(Clone, Debug)]
pub enum Texture {
    Constant(Spectrum),
    /// Mitsuba's `checkerboard`: `color0` where ⌊u·2⌋ + ⌊v·2⌋ is even (after `to_uv`), else `color1`.
    Checkerboard {
        color0: Spectrum,
        color1: Spectrum,
        to_uv: Mat3,
    },
}

impl Texture {
    #[inline]
    pub fn eval(&self, uv: Vec2) -> Spectrum {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checkerboard {
                color0,
                color1,
                to_uv,
            } => {
                let p = to_uv.transform_point2(uv);
                // Mitsuba 3 checkerboard: the four quarters of the unit square, repeated.
                let fx = p.x - p.x.floor();
                let fy = p.y - p.y.floor();
                if (fx > 0.5) == (fy > 0.5) {
                    *color0
                } else {
                    *color1
                }
            }
        }
    }

    /// Mean value over the unit uv square (light power estimates).
    pub fn mean(&self) -> Spectrum {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checkerboard { color0, color1, .. } => 0.5 * (*color0 + *color1),
        }
    }
}
