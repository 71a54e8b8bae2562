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

/// Chi-square of sampled directions against the density, weight = value/pdf per sample, and
/// the density's normalisation, for each phase function (grid in cosine × azimuth about an
/// arbitrary incident direction, so the test does not rely on the frame's alignment).
#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::rng::Pcg32;
    use std::f64::consts::TAU;

    const N: usize = 400_000;
    const NT: usize = 24;
    const NP: usize = 48;

    /// A frame about the incident direction: cell (i, j) = (cos bin, azimuth bin) of `w`.
    fn cell(wi: Vec3, w: Vec3) -> usize {
        let f = crate::math::frame::Frame::from_normal(wi);
        let l = f.to_local(w);
        let i = (((l.z as f64 + 1.0) * 0.5 * NT as f64) as usize).min(NT - 1);
        let phi = (l.y as f64).atan2(l.x as f64).rem_euclid(TAU);
        let j = ((phi / TAU * NP as f64) as usize).min(NP - 1);
        i * NP + j
    }

    /// Expected fraction per cell by midpoint integration of the pdf (16 × 16 points per cell).
    fn expected(p: &Phase, wi: Vec3) -> Vec<f64> {
        let f = crate::math::frame::Frame::from_normal(wi);
        let mut e = vec![0.0; NT * NP];
        let k = 16;
        for i in 0..NT {
            for j in 0..NP {
                let mut s = 0.0;
                for a in 0..k {
                    for b in 0..k {
                        let z = -1.0 + 2.0 * (i as f64 + (a as f64 + 0.5) / k as f64) / NT as f64;
                        let phi = TAU * (j as f64 + (b as f64 + 0.5) / k as f64) / NP as f64;
                        let r = (1.0 - z * z).max(0.0).sqrt();
                        let w = f.to_world(Vec3::new(
                            (r * phi.cos()) as f32,
                            (r * phi.sin()) as f32,
                            z as f32,
                        ));
                        s += p.eval_pdf(wi, w).1 as f64;
                    }
                }
                // dω = dz dφ.
                e[i * NP + j] = s / (k * k) as f64 * (2.0 / NT as f64) * (TAU / NP as f64);
            }
        }
        e
    }

    fn check(name: &str, p: &Phase) {
        let wi = Vec3::new(0.3, -0.5, 0.8).normalize();
        let mut rng = Pcg32::new(7, name.len() as u64);
        let mut counts = vec![0usize; NT * NP];
        let mut weight_sum = 0.0;
        for _ in 0..N {
            let u1 = rng.next_f32();
            let u2 = Vec2::new(rng.next_f32(), rng.next_f32());
            let s = p.sample(wi, u1, u2).expect("a sample");
            assert!((s.wo.length() - 1.0).abs() < 1e-4, "{name}: wo not unit");
            let (v, pdf) = p.eval_pdf(wi, s.wo);
            assert!(
                (pdf - s.pdf).abs() <= 1e-3 * pdf.max(1e-3),
                "{name}: sampled pdf {} vs eval_pdf {pdf}",
                s.pdf
            );
            assert!(
                (s.weight - v / pdf).abs() <= 1e-3 * (v / pdf),
                "{name}: weight {} vs value/pdf {}",
                s.weight,
                v / pdf
            );
            weight_sum += s.weight as f64;
            counts[cell(wi, s.wo)] += 1;
        }
        let e = expected(p, wi);
        let total: f64 = e.iter().sum();
        assert!(
            (total - 1.0).abs() < 2e-3,
            "{name}: pdf integrates to {total}"
        );
        assert!(
            (weight_sum / N as f64 - 1.0).abs() < 1e-3,
            "{name}: E[weight] ≠ 1"
        );
        // Pool cells expected below 5 samples (Cochran's rule) into one.
        let (mut chi2, mut dof) = (0.0, 0usize);
        let (mut pool_e, mut pool_o) = (0.0, 0.0);
        for (c, &ec) in e.iter().enumerate() {
            let ec = ec * N as f64;
            let o = counts[c] as f64;
            if ec < 5.0 {
                pool_e += ec;
                pool_o += o;
            } else {
                chi2 += (o - ec) * (o - ec) / ec;
                dof += 1;
            }
        }
        if pool_e > 0.0 {
            chi2 += (pool_o - pool_e) * (pool_o - pool_e) / pool_e.max(1.0);
            dof += 1;
        }
        let dof = (dof - 1) as f64;
        // Wilson–Hilferty: the 1 − 1e-4 quantile of χ²(dof) (z = 3.72).
        let h = 2.0 / (9.0 * dof);
        let limit = dof * (1.0 - h + 3.72 * h.sqrt()).powi(3);
        assert!(
            chi2 < limit,
            "{name}: χ² = {chi2:.1} above {limit:.1} (dof {dof})"
        );
    }

    #[test]
    fn isotropic_samples_its_density() {
        check("isotropic", &Phase::Isotropic);
    }

    #[test]
    fn hg_samples_its_density() {
        for g in [-0.7, -0.2, 0.0, 0.3, 0.8] {
            check(&format!("hg g={g}"), &Phase::Hg(Hg { g }));
        }
    }

    #[test]
    fn blendphase_samples_its_density() {
        let b = Phase::Blend(Box::new(Blend {
            weight: 0.35,
            phases: [Phase::Hg(Hg { g: 0.7 }), Phase::Hg(Hg { g: -0.4 })],
        }));
        check("blend", &b);
        let b = Phase::Blend(Box::new(Blend {
            weight: 0.6,
            phases: [Phase::Isotropic, Phase::Hg(Hg { g: 0.5 })],
        }));
        check("blend iso", &b);
    }

    /// The test sees a wrong sign of g (backward instead of forward scattering).
    #[test]
    fn hg_is_forward_scattering_for_positive_g() {
        let wi = Vec3::Z;
        let h = Hg { g: 0.6 };
        // Propagation direction −wi: forward means wo ≈ −wi.
        assert!(h.eval(wi, -wi) > 10.0 * h.eval(wi, wi));
    }
}
