//! `homogeneous`: a medium of constant extinction σt and single-scattering albedo α
//! (Mitsuba 3's `HomogeneousMedium`). Distances are sampled in one colour channel per path
//! (Pharr et al., PBRT 3rd ed. §15.2.1: exponential free flight; Mitsuba's RGB "hero channel"
//! without spectral MIS), and transmittance along shadow rays is evaluated in closed form,
//! exp(−σt·d), which is the expectation of Mitsuba's track-length estimator.
//!
//! # XML parameters (Mitsuba 3 names and defaults)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `sigma_t` | float, rgb or spectrum | 1 | extinction coefficient, per unit length (before `scale`); an rgb must lie in [0, 1], as Mitsuba 3.9.1 reads it as a reflectance |
//! | `albedo` | float, rgb or spectrum | 0.75 | single-scattering albedo σs/σt, in [0, 1] |
//! | `scale` | float | 1 | multiplies `sigma_t` (units of the scene) |
//! | `sample_emitters` | boolean | true | next-event estimation at scattering events |
//! | `has_spectral_extinction` | boolean | true | false: Mitsuba's grey-extinction shortcut (weights ignore the other channels' transmittance) |
//! | (nested `<phase>`) | phase | `isotropic` | the phase function |
//! | (nested `<volume name="sigma_t"/"albedo">`) | `constvolume` | | its constant `value` instead of the property |

use super::Phase;
use crate::spectrum::Spectrum;
use glam::Vec3;

#[derive(Clone, Debug)]
pub struct Homogeneous {
    /// Extinction, `scale` applied.
    pub sigma_t: Spectrum,
    /// Scattering coefficient σs = α·σt.
    pub sigma_s: Spectrum,
    pub phase: Phase,
    pub sample_emitters: bool,
    pub spectral_extinction: bool,
}

/// Outcome of sampling a free-flight distance along a ray segment.
#[derive(Clone, Copy, Debug)]
pub enum FreeFlight {
    /// A real scattering event at distance `t`; the throughput is multiplied by `weight`
    /// (σs·Tr/pdf, pdf in the sampled channel).
    Scatter { t: f32, weight: Spectrum },
    /// The segment's end (a surface, or infinity) was reached; weight Tr/pdf.
    Pass { weight: Spectrum },
}

impl Homogeneous {
    /// The distance at which a ray scatters, sampled with channel `channel`'s extinction from
    /// `u`, when that is closer than `t_max` (the nearest surface, or infinity).
    #[inline]
    pub fn sample_free_flight(&self, t_max: f32, channel: usize, u: f32) -> FreeFlight {
        let s = self.sigma_t[channel];
        let t = if s > 0.0 {
            -(1.0 - u).ln() / s
        } else {
            f32::INFINITY
        };
        if t < t_max {
            let w = if self.spectral_extinction {
                tr_ratio(t, self.sigma_t, s) * self.sigma_s / s
            } else {
                self.sigma_s / self.sigma_t
            };
            FreeFlight::Scatter { t, weight: w }
        } else {
            let w = if self.spectral_extinction {
                tr_ratio(t_max, self.sigma_t, s)
            } else {
                Spectrum::ONE
            };
            FreeFlight::Pass { weight: w }
        }
    }

    /// Transmittance over distance `d`.
    #[inline]
    pub fn transmittance(&self, d: f32) -> Spectrum {
        Vec3::new(
            exp_neg(self.sigma_t.x, d),
            exp_neg(self.sigma_t.y, d),
            exp_neg(self.sigma_t.z, d),
        )
    }
}

/// exp(−σ·d), 1 when σ = 0 (also for d = ∞).
#[inline]
fn exp_neg(sigma: f32, d: f32) -> f32 {
    if sigma == 0.0 {
        1.0
    } else {
        (-sigma * d).exp()
    }
}

/// Tr(t)/Tr_c(t) per channel = exp(−t·(σ − σc)), computed as one exponential so that it does
/// not underflow to 0/0 over long distances; 1 where σ = σc (also for t = ∞). Shared with
/// `volpathmis`.
#[inline]
pub(crate) fn tr_ratio(t: f32, sigma: Spectrum, s_c: f32) -> Spectrum {
    let f = |x: f32| {
        let d = x - s_c;
        if d == 0.0 {
            1.0
        } else {
            (-t * d).exp()
        }
    };
    Vec3::new(f(sigma.x), f(sigma.y), f(sigma.z))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn medium(sigma: Spectrum, albedo: Spectrum) -> Homogeneous {
        Homogeneous {
            sigma_t: sigma,
            sigma_s: sigma * albedo,
            phase: Phase::Isotropic,
            sample_emitters: true,
            spectral_extinction: true,
        }
    }

    /// The free-flight estimator of transmittance to a surface at distance d is unbiased in
    /// every channel, whichever channel samples (E[weight·1{pass}] = exp(−σ d)).
    #[test]
    fn free_flight_pass_is_unbiased_per_channel() {
        let m = medium(Vec3::new(0.5, 1.0, 2.0), Vec3::splat(0.8));
        let d = 0.7;
        let n = 200_000;
        for ch in 0..3 {
            let mut sum = Vec3::ZERO;
            for i in 0..n {
                let u = (i as f32 + 0.5) / n as f32;
                if let FreeFlight::Pass { weight } = m.sample_free_flight(d, ch, u) {
                    sum += weight;
                }
            }
            let est = sum / n as f32;
            let want = m.transmittance(d);
            assert!(
                (est - want).abs().max_element() < 2e-3,
                "{ch}: {est} vs {want}"
            );
        }
    }

    /// Integrating the scatter weight over the segment gives σs·∫Tr = α(1 − Tr(d)) per channel.
    #[test]
    fn free_flight_scatter_weight_integrates_to_albedo_times_absorbed() {
        let m = medium(Vec3::new(0.5, 1.0, 2.0), Vec3::new(0.9, 0.5, 0.2));
        let d = 1.3;
        let n = 200_000;
        for ch in 0..3 {
            let mut sum = Vec3::ZERO;
            for i in 0..n {
                let u = (i as f32 + 0.5) / n as f32;
                if let FreeFlight::Scatter { weight, .. } = m.sample_free_flight(d, ch, u) {
                    sum += weight;
                }
            }
            let est = sum / n as f32;
            let want = Vec3::new(0.9, 0.5, 0.2) * (Vec3::ONE - m.transmittance(d));
            assert!(
                (est - want).abs().max_element() < 3e-3,
                "{ch}: {est} vs {want}"
            );
        }
    }
}
