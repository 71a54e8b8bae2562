//! `homogeneous`: a medium of constant extinction σt and single-scattering albedo α
//! (Mitsuba 3's `HomogeneousMedium`). The albedo may vary in space (a `gridvolume`, looked up at
//! each scattering point as Mitsuba 3.9.1's `get_scattering_coefficients` does): σt stays
//! constant, so free flights and transmittance keep their closed forms. Distances are sampled in one colour channel per path
//! (Pharr et al., PBRT 3rd ed. §15.2.1: exponential free flight; Mitsuba's RGB "hero channel"
//! without spectral MIS), and transmittance along shadow rays is evaluated in closed form,
//! exp(−σt·d), which is the expectation of Mitsuba's track-length estimator.
//!
//! # XML parameters (Mitsuba 3 names and defaults)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `sigma_t` | float, rgb or spectrum | 1 | extinction coefficient, per unit length (before `scale`); an rgb must lie in [0, 1], as Mitsuba 3.9.1 reads it as a reflectance |
//! | `albedo` | float, rgb, spectrum or volume | 0.75 | single-scattering albedo σs/σt: a constant in [0, 1], or a `gridvolume` evaluated per point (its values are not limited to 1, as in Mitsuba) |
//! | `scale` | float | 1 | multiplies `sigma_t` (units of the scene) |
//! | `sample_emitters` | boolean | true | next-event estimation at scattering events |
//! | `has_spectral_extinction` | boolean | true | false: Mitsuba's grey-extinction shortcut (weights ignore the other channels' transmittance) |
//! | (nested `<phase>`) | phase | `isotropic` | the phase function |
//! | (nested `<volume name="sigma_t">`) | `constvolume` | | its constant `value` instead of the property (a grid is an error: σt must be constant) |
//! | (nested `<volume name="albedo">`) | `constvolume` or `gridvolume` | | see [`super::volume`] |

use super::volume::Volume;
use super::Phase;
use crate::spectrum::Spectrum;
use glam::Vec3;

#[derive(Clone, Debug)]
pub struct Homogeneous {
    /// Extinction, `scale` applied.
    pub sigma_t: Spectrum,
    /// Scattering coefficient σs = α·σt of a constant albedo. With an `albedo_volume` it is NaN
    /// in every channel (there is no single value): read σs through [`Homogeneous::sigma_s_at`].
    pub sigma_s: Spectrum,
    /// A spatially varying albedo (a `gridvolume`), looked up at each scattering point; `None`
    /// for a constant albedo (already in `sigma_s`). Boxed: most media have none.
    pub albedo_volume: Option<Box<Volume>>,
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
    /// A medium of extinction `sigma_t` (`scale` applied) and constant albedo `albedo`.
    pub fn new(
        sigma_t: Spectrum,
        albedo: Spectrum,
        phase: Phase,
        sample_emitters: bool,
        spectral_extinction: bool,
    ) -> Homogeneous {
        Homogeneous {
            sigma_t,
            sigma_s: sigma_t * albedo,
            albedo_volume: None,
            phase,
            sample_emitters,
            spectral_extinction,
        }
    }

    /// The same medium with the albedo of `volume`, evaluated per point, instead of a constant.
    pub fn with_albedo_volume(mut self, volume: Volume) -> Homogeneous {
        self.sigma_s = Spectrum::splat(f32::NAN);
        self.albedo_volume = Some(Box::new(volume));
        self
    }

    /// The scattering coefficient σs = σt·α(p) at world point `p` (Mitsuba's
    /// `get_scattering_coefficients`: the albedo volume is evaluated at the interaction point,
    /// with its wrap mode outside its box; the medium itself is unbounded).
    #[inline]
    pub fn sigma_s_at(&self, p: Vec3) -> Spectrum {
        match &self.albedo_volume {
            None => self.sigma_s,
            Some(v) => self.sigma_t * v.eval(p),
        }
    }

    /// The distance at which the ray o + t·d (unit `d`) scatters, sampled with channel
    /// `channel`'s extinction from `u`, when that is closer than `t_max` (the nearest surface, or
    /// infinity). The albedo is looked up at the scattering point only.
    #[inline]
    pub fn sample_free_flight(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        channel: usize,
        u: f32,
    ) -> FreeFlight {
        let s = self.sigma_t[channel];
        let t = if s > 0.0 {
            -(1.0 - u).ln() / s
        } else {
            f32::INFINITY
        };
        if t < t_max {
            let sigma_s = self.sigma_s_at(o + d * t);
            let w = if self.spectral_extinction {
                tr_ratio(t, self.sigma_t, s) * sigma_s / s
            } else {
                sigma_s / self.sigma_t
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

    /// What a shadow ray in this medium is attenuated by over distance `d`, for a path whose
    /// distances are sampled in colour channel `channel`: exp(−σt·d) per channel, or, with
    /// `has_spectral_extinction` off, exp(−σt_c·d) in every channel. The latter is the
    /// expectation of Mitsuba 3.9.1's estimator there (`volpath.cpp`/`volpathmis.cpp`
    /// `sample_emitter`: a collision sampled with channel c kills the shadow ray, a pass keeps
    /// it with weight 1), a grey shortcut that equals the per-channel form only for a grey σt.
    #[inline]
    pub fn shadow_transmittance(&self, d: f32, channel: usize) -> Spectrum {
        if self.spectral_extinction {
            self.transmittance(d)
        } else {
            Spectrum::splat(exp_neg(self.sigma_t[channel], d))
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
    use crate::geometry::volfile::VolGrid;
    use crate::medium::volume::{Filter, Grid, VolumeData, Wrap};
    use crate::medium::Medium;
    use glam::Mat4;

    fn medium(sigma: Spectrum, albedo: Spectrum) -> Homogeneous {
        Homogeneous::new(sigma, albedo, Phase::Isotropic, true, true)
    }

    /// A 4×1×1 nearest-neighbour rgb albedo grid (voxel i: (0.2 + 0.2 i, 0.9 − 0.2 i, 0.5))
    /// stretched over x ∈ [0, 4] (one voxel per unit), y, z ∈ [0, 1], with `wrap`.
    fn albedo_grid(wrap: Wrap) -> Volume {
        let mut data = Vec::new();
        for i in 0..4 {
            data.extend([0.2 + 0.2 * i as f32, 0.9 - 0.2 * i as f32, 0.5]);
        }
        let g = VolGrid {
            size: [4, 1, 1],
            channels: 3,
            bbox: [0.0, 0.0, 0.0, 1.0, 1.0, 1.0],
            data,
        };
        let to_world = Mat4::from_scale(Vec3::new(4.0, 1.0, 1.0));
        Volume::new(
            VolumeData::Grid(Grid::new(g, Filter::Nearest, wrap).unwrap()),
            &to_world,
            to_world.inverse(),
        )
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
                if let FreeFlight::Pass { weight } =
                    m.sample_free_flight(Vec3::ZERO, Vec3::X, d, ch, u)
                {
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
                if let FreeFlight::Scatter { weight, .. } =
                    m.sample_free_flight(Vec3::ZERO, Vec3::X, d, ch, u)
                {
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

    /// The albedo lookup path: σs at a point is σt times the grid's value there (through the
    /// volume's `to_world`, wrapped outside its box), in `sigma_s_at`, in the tracking interface's
    /// `coefficients` and in `sample_interaction`; a constant albedo keeps its σs.
    #[test]
    fn grid_albedo_is_looked_up_at_the_point() {
        let sigma = Vec3::new(0.5, 1.0, 2.0);
        let m = medium(sigma, Vec3::splat(0.3)).with_albedo_volume(albedo_grid(Wrap::Clamp));
        let voxel = |i: usize| Vec3::new(0.2 + 0.2 * i as f32, 0.9 - 0.2 * i as f32, 0.5);
        for (x, i) in [(0.5, 0), (1.5, 1), (2.2, 2), (3.9, 3), (-3.0, 0), (7.0, 3)] {
            let p = Vec3::new(x, 0.5, 0.5);
            assert_eq!(m.sigma_s_at(p), sigma * voxel(i), "x = {x}");
        }
        // y and z outside [0, 1] are clamped too: the homogeneous medium has no box.
        assert_eq!(m.sigma_s_at(Vec3::new(2.5, -4.0, 9.0)), sigma * voxel(2));
        // Repeat: x = 5.5 reads voxel 1.
        let r = medium(sigma, Vec3::splat(0.3)).with_albedo_volume(albedo_grid(Wrap::Repeat));
        assert_eq!(r.sigma_s_at(Vec3::new(5.5, 0.5, 0.5)), sigma * voxel(1));

        let med = Medium::Homogeneous(m);
        let c = med.coefficients(Vec3::new(1.5, 0.5, 0.5));
        assert_eq!(c.sigma_t, sigma);
        assert_eq!(c.sigma_s, sigma * voxel(1));
        assert_eq!(c.sigma_n, Vec3::ZERO);
        // Along +x from x = 0 with u = 1 − e^{−σ·t}: the collision at t = 2.5 reads voxel 2.
        let u = 1.0 - (-2.5f32).exp(); // σ_G = 1
        let (t, c) = med
            .sample_interaction(Vec3::new(0.0, 0.5, 0.5), Vec3::X, 0.0, 10.0, 1, u)
            .unwrap();
        assert!((t - 2.5).abs() < 1e-5, "{t}");
        assert_eq!(c.sigma_s, sigma * voxel(2));
        assert_eq!(med.majorant(), sigma);

        let k = medium(sigma, Vec3::new(0.9, 0.5, 0.2));
        assert_eq!(k.sigma_s_at(Vec3::new(1.0, 2.0, 3.0)), k.sigma_s);
        assert_eq!(k.sigma_s, sigma * Vec3::new(0.9, 0.5, 0.2));
    }

    /// With a grid albedo the free flight's scatter weight integrates, per channel, to
    /// ∫₀ᵈ σs(x(t))·Tr(t) dt (the albedo read where the ray scatters; σt, hence the sampling and
    /// the pass weight, unchanged), whichever channel samples and with or without spectral
    /// extinction. Against the integral summed piecewise over the grid's voxels in closed form.
    #[test]
    fn free_flight_with_grid_albedo_integrates_the_albedo_along_the_ray() {
        let sigma = Vec3::new(0.5, 1.0, 2.0);
        let voxel = |i: usize| Vec3::new(0.2 + 0.2 * i as f32, 0.9 - 0.2 * i as f32, 0.5);
        let d = 3.3;
        // ∫ over voxel i's span [i, i + 1] ∩ [0, d] of σ e^{−σ t} = e^{−σ a} − e^{−σ b}.
        let mut want = Vec3::ZERO;
        for i in 0..4 {
            let (a, b) = (i as f32, (i as f32 + 1.0).min(d));
            let absorbed = Vec3::new(
                (-sigma.x * a).exp() - (-sigma.x * b).exp(),
                (-sigma.y * a).exp() - (-sigma.y * b).exp(),
                (-sigma.z * a).exp() - (-sigma.z * b).exp(),
            );
            want += voxel(i) * absorbed;
        }
        // The same medium with its albedo at the grid's mean, which the test must tell apart.
        let mean_albedo = (voxel(0) + voxel(1) + voxel(2) + voxel(3)) / 4.0;
        let flat = mean_albedo * (Vec3::ONE - medium(sigma, Vec3::ONE).transmittance(d));
        assert!((flat - want).abs().max_element() > 0.02, "{flat} {want}");
        for spectral in [true, false] {
            let mut m =
                medium(sigma, Vec3::splat(0.3)).with_albedo_volume(albedo_grid(Wrap::Clamp));
            m.spectral_extinction = spectral;
            let n = 200_000;
            for ch in 0..3 {
                let (mut sum, mut passed) = (Vec3::ZERO, Vec3::ZERO);
                for i in 0..n {
                    let u = (i as f32 + 0.5) / n as f32;
                    match m.sample_free_flight(Vec3::new(0.0, 0.5, 0.5), Vec3::X, d, ch, u) {
                        FreeFlight::Scatter { weight, .. } => sum += weight,
                        FreeFlight::Pass { weight } => passed += weight,
                    }
                }
                let est = sum / n as f32;
                if spectral {
                    assert!(
                        (est - want).abs().max_element() < 3e-3,
                        "{ch}: {est} vs {want}"
                    );
                    let tr = (passed / n as f32 - m.transmittance(d)).abs().max_element();
                    assert!(tr < 2e-3, "{ch}: pass {tr}");
                } else {
                    // Grey shortcut: the weight is the albedo where the ray scattered; in the
                    // sampling channel the estimate integrates exactly as above.
                    assert!((est[ch] - want[ch]).abs() < 3e-3, "{ch}: {est} vs {want}");
                }
            }
        }
    }
}
