//! `moment` (Mitsuba 3.9.1 `src/integrators/moment.cpp`): wraps one or more integrators. The
//! image is the first inner integrator's estimate; the extra channels are, for every inner
//! integrator `NAME` in order, its own channels (`NAME.<its channel>`) and the CIE XYZ of its
//! sample (`NAME.X`, `NAME.Y`, `NAME.Z`, from linear sRGB by Mitsuba's `srgb_to_xyz`), followed
//! by the same list again as second moments (`m2_` prefix: the per-sample squares, so that the
//! developed channel is the pixel mean of the square). Unnamed inner integrators are called
//! `_arg_0`, `_arg_1`, … as in Mitsuba.

use super::{IntegratorDesc, Scratch};
use crate::geometry::Ray;
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::Spectrum;

/// The inner integrators with their names.
#[derive(Clone, Debug)]
pub struct MomentSettings {
    pub inner: Vec<(String, IntegratorDesc)>,
}

/// Mitsuba's `srgb_to_xyz` (linear Rec. 709 → XYZ, D65), rows X, Y, Z.
pub const SRGB_TO_XYZ: [[f32; 3]; 3] = [
    [0.412453, 0.357580, 0.180423],
    [0.212671, 0.715160, 0.072169],
    [0.019334, 0.119193, 0.950227],
];

/// Linear sRGB to XYZ with Mitsuba's matrix.
#[inline]
pub fn srgb_to_xyz(c: Spectrum) -> [f32; 3] {
    let v = c.to_array();
    SRGB_TO_XYZ.map(|r| r[0] * v[0] + r[1] * v[1] + r[2] * v[2])
}

impl MomentSettings {
    /// First moments: per inner integrator its channels, then X, Y, Z.
    fn first_count(&self) -> usize {
        self.inner.iter().map(|(_, i)| i.aov_count() + 3).sum()
    }

    pub fn aov_count(&self) -> usize {
        2 * self.first_count()
    }

    pub fn aov_names(&self) -> Vec<String> {
        let mut names = Vec::with_capacity(self.aov_count());
        for (name, inner) in &self.inner {
            names.extend(inner.aov_names().iter().map(|a| format!("{name}.{a}")));
            names.extend(["X", "Y", "Z"].map(|c| format!("{name}.{c}")));
        }
        let m2: Vec<String> = names.iter().map(|n| format!("m2_{n}")).collect();
        names.extend(m2);
        names
    }

    /// The first inner integrator's radiance; the channels go to `aovs` when it is long enough.
    pub fn sample(
        &self,
        scene: &Scene,
        ray: Ray,
        sampler: &mut Sampler,
        scratch: &mut Scratch,
        aovs: &mut [f32],
    ) -> Spectrum {
        let half = self.first_count();
        let write = aovs.len() >= 2 * half;
        let mut result = Spectrum::ZERO;
        let mut off = 0;
        for (i, (_, inner)) in self.inner.iter().enumerate() {
            let n = inner.aov_count();
            let l = if write {
                inner.sample(scene, ray, sampler, scratch, &mut aovs[off..off + n])
            } else {
                inner.sample(scene, ray, sampler, scratch, &mut [])
            };
            if write {
                aovs[off + n..off + n + 3].copy_from_slice(&srgb_to_xyz(l));
                for k in off..off + n + 3 {
                    aovs[half + k] = aovs[k] * aovs[k];
                }
            }
            off += n + 3;
            if i == 0 {
                result = l;
            }
        }
        result
    }
}
