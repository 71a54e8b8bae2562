//! Chooses which emitter next-event estimation samples: proportionally to each emitter's power
//! (so a dim environment beside a bright small light does not waste samples).

use super::Emitter;
use crate::geometry::Shape;
use crate::math::Distribution1D;

#[derive(Clone, Debug, Default)]
pub struct LightSampler {
    dist: Option<Distribution1D>,
}

impl LightSampler {
    pub fn new(emitters: &[Emitter], shapes: &[Shape], scene_radius: f32) -> LightSampler {
        if emitters.is_empty() {
            return LightSampler { dist: None };
        }
        let mut w: Vec<f32> = emitters
            .iter()
            .map(|e| e.power(shapes, scene_radius))
            .collect();
        // A light with zero or unknown power still gets a small share if all are zero.
        if !w.iter().any(|&x| x > 0.0 && x.is_finite()) {
            w.iter_mut().for_each(|x| *x = 1.0);
        }
        w.iter_mut().for_each(|x| {
            if !x.is_finite() {
                *x = 0.0
            }
        });
        LightSampler {
            dist: Distribution1D::new(&w),
        }
    }

    /// Pick an emitter: (index, selection probability, reusable `u`).
    #[inline]
    pub fn sample(&self, u: f32) -> Option<(usize, f32, f32)> {
        self.dist.as_ref().map(|d| d.sample(u))
    }

    /// Probability of picking emitter `i`.
    #[inline]
    pub fn pmf(&self, i: usize) -> f32 {
        self.dist.as_ref().map_or(0.0, |d| d.pmf(i))
    }
}
