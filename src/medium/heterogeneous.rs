//! `heterogeneous`: a medium whose extinction σt and albedo α come from volumes (Mitsuba 3's
//! `HeterogeneousMedium`), tracked against one global majorant σ̄ = `scale` · max(σt volume)
//! (Mitsuba 3.9.1 builds no majorant grid). The medium exists only inside the world bounding
//! box of its σt volume (Mitsuba's `intersect_aabb`), even when the shape that holds it is larger.
//!
//! - Distance sampling is delta tracking (Woodcock et al. 1965; Novák et al., "Monte Carlo
//!   methods for volumetric light transport simulation", 2018, §5.1): tentative collisions at
//!   exponential steps of rate σ̄; at each, a real collision with probability mean(σt)/σ̄, else
//!   a null one. With `has_spectral_extinction` (the default) the weights are Mitsuba's:
//!   σs/mean(σt) at a real collision and σn/mean(σn) at a null one (σn = σ̄ − σt), which keep
//!   every RGB channel unbiased; without it, σs/σt and 1.
//! - Transmittance along shadow rays is ratio tracking (Novák et al. 2014, "Residual ratio
//!   tracking", eq. 5 with a constant control): the product of σn/σ̄ over the tentative
//!   collisions, as Mitsuba's `volpath` computes it.
//!
//! # XML parameters (Mitsuba 3 names and defaults)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `sigma_t` | float, rgb, spectrum or volume | 1 | extinction per unit length (before `scale`); a float or rgb becomes a `constvolume` on the unit cube [0, 1]³, as in Mitsuba |
//! | `albedo` | float, rgb, spectrum or volume | 0.75 | single-scattering albedo (grid values are not limited to 1, as in Mitsuba) |
//! | `scale` | float | 1 | multiplies `sigma_t` |
//! | `sample_emitters` | boolean | true | next-event estimation at scattering events |
//! | `has_spectral_extinction` | boolean | true | false: Mitsuba's grey shortcut (weights σs/σt and 1) |
//! | (nested `<phase>`) | phase | `isotropic` | the phase function |
//! | (nested `<volume>`) | `constvolume` or `gridvolume` | | see [`super::volume`] |

use super::homogeneous::FreeFlight;
use super::volume::Volume;
use super::{Coefficients, Phase};
use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use glam::Vec3;

#[derive(Clone, Debug)]
pub struct Heterogeneous {
    /// Extinction before `scale`.
    pub sigma_t: Volume,
    pub albedo: Volume,
    pub scale: f32,
    /// σ̄ = `scale` · max(σt), the same in every channel (Mitsuba's `m_max_density`).
    pub majorant: f32,
    pub phase: Phase,
    pub sample_emitters: bool,
    pub spectral_extinction: bool,
}

/// mean of the three channels.
#[inline]
fn mean(s: Spectrum) -> f32 {
    (s.x + s.y + s.z) * (1.0 / 3.0)
}

impl Heterogeneous {
    /// A medium of extinction `sigma_t` (times `scale`) and `albedo`.
    pub fn new(
        sigma_t: Volume,
        albedo: Volume,
        scale: f32,
        phase: Phase,
        sample_emitters: bool,
        spectral_extinction: bool,
    ) -> Heterogeneous {
        let majorant = scale * sigma_t.max();
        Heterogeneous {
            sigma_t,
            albedo,
            scale,
            majorant,
            phase,
            sample_emitters,
            spectral_extinction,
        }
    }

    /// σt, σs and σn at world point `p` (Mitsuba's `get_scattering_coefficients`).
    #[inline]
    pub fn coefficients(&self, p: Vec3) -> Coefficients {
        let sigma_t = self.sigma_t.eval(p) * self.scale;
        Coefficients {
            sigma_t,
            sigma_s: sigma_t * self.albedo.eval(p),
            sigma_n: Spectrum::splat(self.majorant) - sigma_t,
        }
    }

    /// The part [t0, t1] of the ray o + t·d, t ∈ [0, t_max], where the medium exists.
    #[inline]
    pub fn clip(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32)> {
        if self.majorant <= 0.0 {
            return None;
        }
        self.sigma_t.clip(o, d, t_max)
    }

    /// The next tentative collision after `t` (exponential step of rate σ̄ from `u`), or `None`
    /// at or beyond `t1`.
    #[inline]
    fn step(&self, t: f32, t1: f32, u: f32) -> Option<f32> {
        let t = t - (1.0 - u).ln() / self.majorant;
        (t < t1).then_some(t)
    }

    /// Delta tracking along o + t·d up to `t_max` (a surface, or ∞). `d` has unit length.
    #[inline]
    pub fn sample_free_flight(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        sampler: &mut Sampler,
    ) -> FreeFlight {
        self.delta_track(o, d, t_max, sampler).0
    }

    /// Delta tracking as [`Self::sample_free_flight`], also returning the product of the
    /// probabilities of the null collisions it chose, Π mean(σn)/σ̄ (1 without any). Next-event
    /// estimation by ratio tracking passes the same null collisions with probability 1, so this
    /// is the ratio of the two techniques' densities along the segment (Miller, Georgiev and
    /// Jarosz 2019: ratio tracking is null scattering whose null probability is 1), which
    /// `volpathmis` needs to weigh a path that reaches an emitter against next-event estimation.
    pub fn delta_track(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        sampler: &mut Sampler,
    ) -> (FreeFlight, f32) {
        let mut weight = Spectrum::ONE;
        let mut p_nulls = 1.0f32;
        let Some((mut t, t1)) = self.clip(o, d, t_max) else {
            return (FreeFlight::Pass { weight }, p_nulls);
        };
        let inv_majorant = 1.0 / self.majorant;
        loop {
            match self.step(t, t1, sampler.next_1d()) {
                None => return (FreeFlight::Pass { weight }, p_nulls),
                Some(tn) => t = tn,
            }
            let c = self.coefficients(o + d * t);
            let u = sampler.next_1d();
            // Mitsuba: null with probability mean(σn)/σ̄, the same for every hero channel since
            // the majorant is grey.
            let p_null = mean(c.sigma_n) * inv_majorant;
            if self.spectral_extinction {
                // The weights divide by the chosen event's probability density mean(σ)·(1/σ̄)…
                // times the 1/σ̄ of the step's pdf.
                if u < p_null {
                    weight *= c.sigma_n / mean(c.sigma_n);
                    p_nulls *= p_null;
                } else {
                    let m = mean(c.sigma_t);
                    if m <= 0.0 {
                        p_nulls *= p_null;
                        continue;
                    }
                    weight *= c.sigma_s / m;
                    return (FreeFlight::Scatter { t, weight }, p_nulls);
                }
            } else if u >= p_null {
                weight *= Vec3::select(
                    c.sigma_t.cmpgt(Vec3::ZERO),
                    c.sigma_s / c.sigma_t,
                    Vec3::ZERO,
                );
                return (FreeFlight::Scatter { t, weight }, p_nulls);
            } else {
                p_nulls *= p_null;
            }
        }
    }

    /// Ratio-tracking estimate of the transmittance along o + t·d, t ∈ [0, t_max].
    #[inline]
    pub fn transmittance(&self, o: Vec3, d: Vec3, t_max: f32, sampler: &mut Sampler) -> Spectrum {
        self.ratio_track(o, d, t_max, sampler).0
    }

    /// Ratio tracking as [`Self::transmittance`], also returning Π mean(σn)/σ̄ over its
    /// tentative collisions: the probability that delta tracking would have made the same
    /// collisions all null, i.e. the ratio of the path-tracing density of this segment to the
    /// ratio-tracking one (see [`Self::delta_track`]). Stops early (product 0) once the
    /// transmittance is 0.
    pub fn ratio_track(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        sampler: &mut Sampler,
    ) -> (Spectrum, f32) {
        let mut tr = Spectrum::ONE;
        let mut p_nulls = 1.0f32;
        let Some((mut t, t1)) = self.clip(o, d, t_max) else {
            return (tr, p_nulls);
        };
        let inv_majorant = 1.0 / self.majorant;
        while let Some(tn) = self.step(t, t1, sampler.next_1d()) {
            t = tn;
            let sigma_n = self.coefficients(o + d * t).sigma_n;
            tr *= sigma_n * inv_majorant;
            p_nulls *= mean(sigma_n) * inv_majorant;
            if tr == Spectrum::ZERO {
                break;
            }
        }
        (tr, p_nulls)
    }

    /// One tentative collision from `t_from` (Mitsuba's `Medium::sample_interaction` on a ray
    /// restarted there): its distance and coefficients, or `None` past `t_max` / the medium.
    pub fn sample_interaction(
        &self,
        o: Vec3,
        d: Vec3,
        t_from: f32,
        t_max: f32,
        u: f32,
    ) -> Option<(f32, Coefficients)> {
        let p0 = o + d * t_from;
        let (t0, t1) = self.clip(p0, d, t_max - t_from)?;
        let t = self.step(t0, t1, u)?;
        Some((t_from + t, self.coefficients(p0 + d * t)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::volfile::VolGrid;
    use crate::medium::volume::{Filter, Grid, VolumeData, Wrap};
    use glam::Mat4;

    /// A 4×1×1 grid along x (values `v`, channels of 1 or 3), nearest lookups, on [0, 4]×[0,1]².
    fn medium(v: Vec<f32>, channels: u32, albedo: Spectrum, spectral: bool) -> Heterogeneous {
        let g = Grid::new(
            VolGrid {
                size: [4, 1, 1],
                channels,
                bbox: [0.0; 6],
                data: v,
            },
            Filter::Nearest,
            Wrap::Clamp,
        )
        .unwrap();
        let to_world = Mat4::from_scale(Vec3::new(4.0, 1.0, 1.0));
        let sigma_t = Volume::new(VolumeData::Grid(g), &to_world, to_world.inverse());
        Heterogeneous::new(
            sigma_t,
            Volume::constant(albedo),
            1.0,
            Phase::Isotropic,
            true,
            spectral,
        )
    }

    /// Exact transmittance along x from 0 to `d` through piecewise-constant cells of width 1.
    fn exact(cells: &[Spectrum], d: f32) -> Spectrum {
        let mut tau = Spectrum::ZERO;
        for (i, s) in cells.iter().enumerate() {
            let len = (d - i as f32).clamp(0.0, 1.0);
            tau += *s * len;
        }
        Vec3::new((-tau.x).exp(), (-tau.y).exp(), (-tau.z).exp())
    }

    const N: usize = 200_000;

    /// Mean and standard error per channel of `f` over N paths of one fixed stream.
    fn estimate(mut f: impl FnMut(&mut Sampler) -> Spectrum) -> (Spectrum, Spectrum) {
        let mut s = Sampler::from_seed(7, 11);
        let (mut sum, mut sq) = (Spectrum::ZERO, Spectrum::ZERO);
        for _ in 0..N {
            let x = f(&mut s);
            sum += x;
            sq += x * x;
        }
        let mean = sum / N as f32;
        let var = (sq / N as f32 - mean * mean).max(Spectrum::ZERO);
        (mean, (var / N as f32).powf(0.5))
    }

    fn assert_close(est: (Spectrum, Spectrum), want: Spectrum, what: &str) {
        let (m, se) = est;
        for c in 0..3 {
            // 4.5 standard errors (plus float slack): a false alarm about once in 10⁵ runs.
            let tol = 4.5 * se[c] + 1e-4;
            assert!(
                (m[c] - want[c]).abs() <= tol,
                "{what}, channel {c}: {} vs exact {} (tolerance {tol})",
                m[c],
                want[c]
            );
        }
    }

    fn rgb_cells() -> (Vec<f32>, Vec<Spectrum>) {
        let cells = vec![
            Vec3::new(0.2, 1.0, 0.0),
            Vec3::new(2.0, 0.5, 0.3),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.5, 3.0, 0.7),
        ];
        let data = cells.iter().flat_map(|c| c.to_array()).collect();
        (data, cells)
    }

    /// Ratio tracking's mean equals the exact transmittance through the known cells, per channel.
    #[test]
    fn ratio_tracking_is_unbiased() {
        let (data, cells) = rgb_cells();
        let m = medium(data, 3, Spectrum::splat(0.5), true);
        for d in [0.7f32, 2.5, 3.9] {
            let est = estimate(|s| m.transmittance(Vec3::new(0.0, 0.5, 0.5), Vec3::X, d, s));
            assert_close(est, exact(&cells, d), &format!("ratio tracking to {d}"));
        }
        // Outside the grid's box the medium does not exist: transmittance 1 without sampling.
        let mut s = Sampler::from_seed(1, 1);
        let tr = m.transmittance(Vec3::new(0.0, 2.0, 0.5), Vec3::X, 10.0, &mut s);
        assert_eq!(tr, Spectrum::ONE);
    }

    /// Delta tracking: the mean pass weight is the transmittance to a surface at d, and the mean
    /// scatter weight is ∫ Tr·σs over [0, d] — per channel, for chromatic σt (Mitsuba's weights) and
    /// a grey one without spectral extinction.
    #[test]
    fn delta_tracking_is_unbiased() {
        let (data, cells) = rgb_cells();
        let albedo = Vec3::new(0.9, 0.5, 0.2);
        let o = Vec3::new(0.0, 0.5, 0.5);
        let d = 3.5;
        // ∫0^d Tr(t)·σs(t) dt = α·(1 − Tr(d)) when α is constant.
        let scattered = albedo * (Spectrum::ONE - exact(&cells, d));
        let m = medium(data, 3, albedo, true);
        let pass = estimate(|s| match m.sample_free_flight(o, Vec3::X, d, s) {
            FreeFlight::Pass { weight } => weight,
            FreeFlight::Scatter { .. } => Spectrum::ZERO,
        });
        assert_close(pass, exact(&cells, d), "delta tracking, pass");
        let scatter = estimate(|s| match m.sample_free_flight(o, Vec3::X, d, s) {
            FreeFlight::Scatter { weight, t } => {
                assert!((0.0..d).contains(&t));
                weight
            }
            FreeFlight::Pass { .. } => Spectrum::ZERO,
        });
        assert_close(scatter, scattered, "delta tracking, scatter");

        let grey = vec![0.2, 2.0, 0.0, 1.5];
        let cells: Vec<Spectrum> = grey.iter().map(|&v| Spectrum::splat(v)).collect();
        let m = medium(grey, 1, albedo, false);
        let pass = estimate(|s| match m.sample_free_flight(o, Vec3::X, d, s) {
            FreeFlight::Pass { weight } => weight,
            FreeFlight::Scatter { .. } => Spectrum::ZERO,
        });
        assert_close(pass, exact(&cells, d), "grey delta tracking, pass");
    }

    /// The density ratios of delta and ratio tracking make a balance-heuristic pair: a pass of
    /// delta tracking weighted by P_dt / (P_dt + P_rt) = p / (p + 1) (p = its product of null
    /// probabilities) plus a ratio-tracking estimate weighted by 1 / (1 + ρ) estimate the
    /// transmittance, per channel (what `volpathmis` relies on for emitters behind heterogeneous
    /// media). Leaving ρ out on the ratio-tracking side (weight ½, i.e. weights that no longer
    /// sum to one per path) is detected.
    #[test]
    fn delta_and_ratio_tracking_densities_combine_by_mis() {
        let (data, cells) = rgb_cells();
        let m = medium(data, 3, Spectrum::splat(0.6), true);
        let o = Vec3::new(0.0, 0.5, 0.5);
        let d = 3.5;
        let want = exact(&cells, d);
        let mis = |s: &mut Sampler, use_rho: bool| {
            let uni = match m.delta_track(o, Vec3::X, d, s) {
                (FreeFlight::Pass { weight }, p) => weight * (p / (p + 1.0)),
                (FreeFlight::Scatter { .. }, _) => Spectrum::ZERO,
            };
            let (tr, rho) = m.ratio_track(o, Vec3::X, d, s);
            uni + tr / (1.0 + if use_rho { rho } else { 1.0 })
        };
        assert_close(
            estimate(|s| mis(s, true)),
            want,
            "MIS of delta and ratio tracking",
        );
        let (est, se) = estimate(|s| mis(s, false));
        let z = ((est - want).abs() / (se + Spectrum::splat(1e-6))).max_element();
        assert!(
            z > 10.0,
            "a one-sided weight was not told apart: {z:.1} standard errors"
        );
    }

    /// Sensitivity of the two tests above: a medium of twice the density is told apart.
    #[test]
    fn the_unbiasedness_checks_see_a_wrong_density() {
        let (data, cells) = rgb_cells();
        let doubled: Vec<f32> = data.iter().map(|v| 2.0 * v).collect();
        let m = medium(doubled, 3, Spectrum::splat(0.5), true);
        let (est, se) = estimate(|s| m.transmittance(Vec3::new(0.0, 0.5, 0.5), Vec3::X, 2.5, s));
        let want = exact(&cells, 2.5);
        assert!(((est - want).abs() / (se + Spectrum::splat(1e-6))).max_element() > 10.0);
    }
}
