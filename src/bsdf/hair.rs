//! `hair`: Chiang et al.'s near-field fiber model ("A Practical and Controllable Hair and Fur
//! Model for Production Path Tracing", EGSR 2016), as Mitsuba 3.9.1's `src/bsdfs/hair.cpp` has it:
//! lobes p = 0 (R), 1 (TT), 2 (TRT) and the sum of the rest, each a longitudinal term M_p (d'Eon
//! et al. 2011's rough-fiber density, variances from `longitudinal_roughness`, the cuticle
//! scales tilting p = 0, 1, 2 by −2α, α, 4α), an attenuation A_p (Fresnel of the cross-section
//! and the absorption along the chords) and an azimuthal term N_p (a logistic of scale s from
//! `azimuthal_roughness`, trimmed to [−π, π]).
//!
//! Local frame: y is along the fiber (θ is the angle to the normal plane, sin θ = w.y), the
//! normal plane is xz with z the surface normal; φ = atan2(w.z, w.x) and the offset across the
//! fiber is h = sin γ, γ the angle of w's projection to the normal (Mitsuba derives it from the
//! incident direction). The shading tangent x must therefore run *around* the fiber, which holds
//! on `bsplinecurve` (dp/du); Mitsuba warns that other shapes give unexpected results (on its
//! `linearcurve` the tangent is arbitrary).
//!
//! The fiber scatters to the whole sphere (glossy reflection and transmission), with eta 1
//! (the walk inside the fiber enters and leaves at the same point). `eval` is Mitsuba's value
//! Σ_p M_p 2π A_p N_p (it includes the cosine); sampling picks p by the luminance of A_p, then θ
//! and φ as Mitsuba does. One deliberate difference: Mitsuba samples the last lobe (p = 3) with
//! a zero reframed angle, which puts all of its samples on the normal plane (sin θo = 0) while
//! its pdf assumes the M_3 density; groove samples p = 3 from M_3 around the unreframed incident
//! angle, as pbrt-v3 does, so `pdf` is the density of `sample`. The expectation is the same
//! wherever Mitsuba's is right; the p = 3 mass is ~A_2·f (below 1% for the defaults). Second,
//! the Bessel function I₀ of the longitudinal density is evaluated accurately ([`i0`]); Mitsuba's
//! truncated series makes its M_p up to ~0.6% low where cos θi cos θo / v is near 12 (its
//! density then integrates to 0.997–0.999), so groove's values differ from Mitsuba's by that much
//! there and agree to float rounding elsewhere (`tests/bsdf/hair.rs`).
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `eumelanin`, `pheomelanin` | float | 1.3, 0.2 | pigment concentrations: σ_a = e·(0.419, 0.697, 1.37) + p·(0.187, 0.4, 1.05) (d'Eon et al. 2011) |
//! | `sigma_a` | spectrum or texture | — | absorption per unit of fiber radius, instead of the pigments (not both) |
//! | `scale` | float | 1 | factor on `sigma_a` |
//! | `int_ior`, `ext_ior` | float or string | amber (1.55), air (1.000277) | indices inside and outside (must differ) |
//! | `longitudinal_roughness`, `azimuthal_roughness` | float | 0.3, 0.3 | roughness along and around the fiber, in [0, 1] |
//! | `scale_tilt` | float | 2 | angle α of the cuticle scales, degrees |

use super::fresnel::fresnel_dielectric;
use super::{is_positive, BsdfSample, Lobes};
use crate::math::{INV_2PI, PI};
use crate::spectrum::{luminance, Spectrum};
use glam::{Vec2, Vec3};

/// Lobes modelled separately (R, TT, TRT); the rest are summed.
const P_MAX: usize = 3;

/// σ_a of eumelanin and pheomelanin per unit concentration (d'Eon et al. 2011).
pub const EUMELANIN_SIGMA_A: Spectrum = Spectrum::new(0.419, 0.697, 1.37);
pub const PHEOMELANIN_SIGMA_A: Spectrum = Spectrum::new(0.187, 0.4, 1.05);

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hair {
    /// Longitudinal variance v₀ of p = 0 (v₁ = v₀/4, v₂ = v₃ = 4 v₀).
    v0: f32,
    /// Logistic scale of the azimuthal terms.
    s: f32,
    /// sin and cos of 2^k α, k = 0, 1, 2 (α = `scale_tilt`).
    sin_2k_alpha: [f32; 3],
    cos_2k_alpha: [f32; 3],
    /// Relative index inside / outside.
    eta: f32,
    /// Absorption coefficient (per fiber radius) before `scale`; patched per hit when textured.
    pub sigma_a: Spectrum,
    /// Factor on `sigma_a`.
    pub scale: f32,
}

impl Hair {
    /// A fiber of roughnesses in [0, 1], cuticle tilt `scale_tilt_deg`, relative index `eta`
    /// and absorption `scale · sigma_a` (Mitsuba's `update`).
    pub fn new(
        longitudinal_roughness: f32,
        azimuthal_roughness: f32,
        scale_tilt_deg: f32,
        eta: f32,
        sigma_a: Spectrum,
        scale: f32,
    ) -> Hair {
        let mut sin = [scale_tilt_deg.to_radians().sin(), 0.0, 0.0];
        let mut cos = [(1.0 - sin[0] * sin[0]).max(0.0).sqrt(), 0.0, 0.0];
        for i in 1..3 {
            sin[i] = 2.0 * cos[i - 1] * sin[i - 1];
            cos[i] = cos[i - 1] * cos[i - 1] - sin[i - 1] * sin[i - 1];
        }
        let (bl, ba) = (longitudinal_roughness, azimuthal_roughness);
        let s = (PI / 8.0).sqrt() * (0.265 * ba + 1.194 * ba * ba + 5.372 * ba.powi(22));
        let v0 = (0.726 * bl + 0.812 * bl * bl + 3.7 * bl.powi(20)).powi(2);
        Hair {
            v0,
            s,
            sin_2k_alpha: sin,
            cos_2k_alpha: cos,
            eta,
            sigma_a,
            scale,
        }
    }

    /// σ_a of pigment concentrations `eumelanin` and `pheomelanin`.
    pub fn pigment_sigma_a(eumelanin: f32, pheomelanin: f32) -> Spectrum {
        EUMELANIN_SIGMA_A * eumelanin + PHEOMELANIN_SIGMA_A * pheomelanin
    }

    /// The longitudinal variance of lobe p.
    #[inline]
    fn v(&self, p: usize) -> f32 {
        match p {
            0 => self.v0,
            1 => 0.25 * self.v0,
            _ => 4.0 * self.v0,
        }
    }

    /// sin θ and cos θ of the incident direction tilted by the scales for lobe p (p = 3: as is).
    fn reframe(&self, sin_t: f32, cos_t: f32, p: usize) -> (f32, f32) {
        let (s, c) = (&self.sin_2k_alpha, &self.cos_2k_alpha);
        let (si, ci) = match p {
            0 => (sin_t * c[1] - cos_t * s[1], cos_t * c[1] + sin_t * s[1]),
            1 => (sin_t * c[0] + cos_t * s[0], cos_t * c[0] - sin_t * s[0]),
            2 => (sin_t * c[2] + cos_t * s[2], cos_t * c[2] - sin_t * s[2]),
            _ => (sin_t, cos_t),
        };
        (si, ci.abs())
    }

    /// Everything the three queries share about the incident direction `wi`.
    fn incident(&self, wi: Vec3) -> Incident {
        let gamma_i = gamma(wi);
        let h = gamma_i.sin();
        let sin_ti = wi.y;
        let cos_ti = safe_sqrt(1.0 - sin_ti * sin_ti);
        let phi_i = wi.z.atan2(wi.x);
        // Refraction in the longitudinal plane and, with the modified index, in the normal plane.
        let sin_tt = sin_ti / self.eta;
        let cos_tt = safe_sqrt(1.0 - sin_tt * sin_tt);
        let eta_p = safe_sqrt(self.eta * self.eta - sin_ti * sin_ti) / cos_ti;
        let sin_gt = h / eta_p;
        let cos_gt = safe_sqrt(1.0 - sin_gt * sin_gt);
        let gamma_t = sin_gt.clamp(-1.0, 1.0).asin();
        let tr = (-(self.sigma_a * self.scale) * (2.0 * cos_gt / cos_tt)).map(f32::exp);
        // Attenuations: Fresnel of the cross-section angle, then chords through the fiber.
        let f = fresnel_dielectric(cos_ti * safe_sqrt(1.0 - h * h), self.eta).r;
        let mut a = [Spectrum::ZERO; P_MAX + 1];
        a[0] = Spectrum::splat(f);
        a[1] = tr * (1.0 - f) * (1.0 - f);
        for p in 2..P_MAX {
            a[p] = a[p - 1] * tr * f;
        }
        a[P_MAX] = a[P_MAX - 1] * tr * f / (Spectrum::ONE - tr * f);
        let lum = a.map(luminance);
        let total: f32 = lum.iter().sum();
        let a_pdf = lum.map(|l| l / total);
        Incident {
            gamma_i,
            gamma_t,
            sin_ti,
            cos_ti,
            phi_i,
            a,
            a_pdf,
        }
    }

    /// `(eval, pdf)` toward `wo`, sharing every term; non-finite values become 0 (Mitsuba).
    pub fn eval_pdf(&self, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        let inc = self.incident(wi);
        let delta_phi = wo.z.atan2(wo.x) - inc.phi_i;
        let (mut value, mut pdf) = (Spectrum::ZERO, 0.0);
        let (sp, cp) = inc.phi_i.sin_cos();
        for p in 0..P_MAX {
            let (st, ct) = self.reframe(inc.sin_ti, inc.cos_ti, p);
            let wi_p = Vec3::new(ct * cp, st, ct * sp);
            let m = rough_fiber_pdf(wo, wi_p, 1.0 / self.v(p)) * (2.0 * PI);
            let n = self.azimuthal(delta_phi, p, &inc);
            value += inc.a[p] * (m * n);
            pdf += inc.a_pdf[p] * m * n;
        }
        let m = rough_fiber_pdf(wo, wi, 1.0 / self.v(P_MAX));
        value += inc.a[P_MAX] * m;
        pdf += inc.a_pdf[P_MAX] * m;
        let value = if crate::spectrum::is_finite(value) {
            value
        } else {
            Spectrum::ZERO
        };
        (value, if pdf.is_finite() { pdf } else { 0.0 })
    }

    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Spectrum {
        self.eval_pdf(wi, wo).0
    }

    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.eval_pdf(wi, wo).1
    }

    /// Picks the lobe with `u1` (by the luminance of A_p, the rest of `u1` reused for φ), then θ
    /// and φ with `u2` (Mitsuba's `sample`; the p = 3 difference is in the module docs).
    pub fn sample(&self, wi: Vec3, u1: f32, u2: Vec2) -> Option<BsdfSample> {
        let inc = self.incident(wi);
        let mut u0 = u1;
        let mut p = P_MAX;
        for (i, &w) in inc.a_pdf.iter().enumerate().take(P_MAX) {
            if u0 < w {
                p = i;
                break;
            }
            u0 -= w;
        }
        let w = inc.a_pdf[p];
        let u_phi = if w > 0.0 {
            (u0 / w).clamp(0.0, 1.0)
        } else {
            0.0
        };
        let (st, ct) = self.reframe(inc.sin_ti, inc.cos_ti, p);
        // θ: the rough-fiber longitudinal sample around the (reframed) incident angle.
        let v = self.v(p);
        let cos_theta = (1.0 + v * (u2.x + (1.0 - u2.x) * (-2.0 / v).exp()).ln()).clamp(-1.0, 1.0);
        let sin_theta = safe_sqrt(1.0 - cos_theta * cos_theta);
        let cos_phi = (2.0 * PI * u2.y).cos();
        let sin_to = -cos_theta * st + sin_theta * cos_phi * ct;
        let cos_to = safe_sqrt(1.0 - sin_to * sin_to);
        // φ: around the perfect specular chain of lobe p, uniform for the rest.
        let delta_phi = if p < P_MAX {
            perfect_delta_phi(p, inc.gamma_i, inc.gamma_t) + trimmed_logistic_sample(u_phi, self.s)
        } else {
            2.0 * PI * u_phi
        };
        let (sp, cp) = (inc.phi_i + delta_phi).sin_cos();
        let wo = Vec3::new(cos_to * cp, sin_to, cos_to * sp).normalize();
        let (value, pdf) = self.eval_pdf(wi, wo);
        if !is_positive(pdf) {
            return None;
        }
        Some(BsdfSample {
            wo,
            pdf,
            weight: value / pdf,
            eta: 1.0,
            lobe: if wo.z >= 0.0 {
                Lobes::GLOSSY_REFLECTION
            } else {
                Lobes::GLOSSY_TRANSMISSION
            },
        })
    }

    /// N_p: the trimmed logistic of the azimuthal offset from lobe p's perfect direction.
    fn azimuthal(&self, delta_phi: f32, p: usize, inc: &Incident) -> f32 {
        let mut phi = (delta_phi - perfect_delta_phi(p, inc.gamma_i, inc.gamma_t)) % (2.0 * PI);
        // Mitsuba's mapping to [−π, π].
        if phi < PI {
            phi += 2.0 * PI;
        }
        if phi > PI {
            phi -= 2.0 * PI;
        }
        let s = self.s;
        logistic(phi, s) / (logistic_cdf(PI, s) - logistic_cdf(-PI, s))
    }
}

/// What the queries share about the incident direction.
struct Incident {
    gamma_i: f32,
    gamma_t: f32,
    sin_ti: f32,
    cos_ti: f32,
    phi_i: f32,
    /// A_p, and the lobe selection probabilities (luminance of A_p, normalised).
    a: [Spectrum; P_MAX + 1],
    a_pdf: [f32; P_MAX + 1],
}

#[inline]
fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

/// The angle between the normal (z) and w's projection onto the normal plane (xz), signed by x
/// as Mitsuba's `gamma`.
fn gamma(w: Vec3) -> f32 {
    let proj = safe_sqrt(w.x * w.x + w.z * w.z);
    if proj == 0.0 {
        return 0.0;
    }
    let g = (w.z / proj).clamp(-1.0, 1.0).acos();
    if w.x < 0.0 {
        g
    } else {
        -g
    }
}

/// The azimuthal deflection of a perfectly specular lobe p: 2p γt − 2γi + pπ.
#[inline]
fn perfect_delta_phi(p: usize, gamma_i: f32, gamma_t: f32) -> f32 {
    let p = p as f32;
    2.0 * p * gamma_t - 2.0 * gamma_i + p * PI
}

fn logistic(x: f32, s: f32) -> f32 {
    let e = (-x.abs() / s).exp();
    e / (s * (1.0 + e) * (1.0 + e))
}

fn logistic_cdf(x: f32, s: f32) -> f32 {
    1.0 / (1.0 + (-x / s).exp())
}

fn trimmed_logistic_sample(u: f32, s: f32) -> f32 {
    let k = logistic_cdf(PI, s) - logistic_cdf(-PI, s);
    let x = -s * (1.0 / (u * k + logistic_cdf(-PI, s)) - 1.0).ln();
    x.clamp(-PI, PI)
}

/// d'Eon et al. 2011's longitudinal density of `wo` around the cone of `wi` about the fiber
/// (y), with the log-space form for large κ (Mitsuba's `square_to_rough_fiber_pdf`, with an
/// accurate I₀: see [`i0`]).
fn rough_fiber_pdf(wo: Vec3, wi: Vec3, kappa: f32) -> f32 {
    let (sin_i, sin_o) = (wi.y, wo.y);
    let (cos_i, cos_o) = (
        safe_sqrt(1.0 - sin_i * sin_i),
        safe_sqrt(1.0 - sin_o * sin_o),
    );
    let c = cos_i * cos_o * kappa;
    let s = sin_i * sin_o * kappa;
    if kappa > 10.0 {
        // κ / (2 sinh κ) = κ e^−κ to float precision (Mitsuba writes ln κ as 0.6931 + ln(κ/2)).
        (-s + log_i0(c) - kappa + kappa.ln()).exp() * INV_2PI
    } else {
        (-s).exp() * i0(c) * kappa / (2.0 * kappa.sinh()) * INV_2PI
    }
}

/// The modified Bessel function I₀(x) = Σ (x²/4)^k / (k!)², summed until the terms stop
/// mattering (x ≤ 12 here: at most ~40 terms). Mitsuba (like pbrt-v3) stops at 10 terms, which
/// is 0.6% low at x = 12; with its asymptotic form below that made the density integrate to
/// 0.997–0.999 at the default roughness, which the chi-square test of `sample` sees.
fn i0(x: f32) -> f32 {
    let q = x * x * 0.25;
    let (mut sum, mut term) = (1.0f32, 1.0f32);
    for k in 1..64 {
        let kf = k as f32;
        term *= q / (kf * kf);
        sum += term;
        if term < sum * 1e-8 {
            break;
        }
    }
    sum
}

/// ln I₀(x): the series below 12, above it the asymptotic expansion
/// x − ½ ln(2πx) + ln(1 + 1/(8x) + 9/(128x²) + 225/(3072x³)) (Abramowitz & Stegun 9.7.1;
/// Mitsuba keeps half of the 1/(8x) term only).
fn log_i0(x: f32) -> f32 {
    if x > 12.0 {
        let r = 1.0 / x;
        x - 0.5 * (2.0 * PI * x).ln()
            + (1.0 + r * (0.125 + r * (9.0 / 128.0 + r * (225.0 / 3072.0)))).ln()
    } else {
        i0(x).ln()
    }
}

impl Default for Hair {
    /// Mitsuba's defaults: roughness 0.3 / 0.3, tilt 2°, amber in air, pigments 1.3 / 0.2.
    fn default() -> Self {
        Hair::new(
            0.3,
            0.3,
            2.0,
            1.55 / 1.000277,
            Hair::pigment_sigma_a(1.3, 0.2),
            1.0,
        )
    }
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use super::Hair;
    use crate::bsdf::ior::load::ior_param;
    use crate::bsdf::BsdfNode;
    use crate::error::{Error, Result};
    use crate::load::bsdfs::BsdfCtx;
    use crate::load::check;
    use crate::material::{MaterialNode, Slot};
    use crate::spectrum::{Spectrum, SpectrumUse};
    use crate::texture::Texture;

    /// `hair`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        let p = cx.props();
        let loc = p.loc().clone();
        let bl = p.float("longitudinal_roughness", 0.3)?;
        let ba = p.float("azimuthal_roughness", 0.3)?;
        let tilt = p.float("scale_tilt", 2.0)?;
        let ext = ior_param(p, "ext_ior", 1.000277)?;
        let int = ior_param(p, "int_ior", 1.55)?;
        let scale = p.float("scale", 1.0)?;
        let pigments = p.has("eumelanin") || p.has("pheomelanin");
        let eu = p.float("eumelanin", 1.3)?;
        let pheo = p.float("pheomelanin", 0.2)?;
        check(
            &loc,
            (0.0..=1.0).contains(&bl),
            "the longitudinal roughness must be in [0, 1]",
        )?;
        check(
            &loc,
            (0.0..=1.0).contains(&ba),
            "the azimuthal roughness must be in [0, 1]",
        )?;
        check(
            &loc,
            int != ext,
            "the interior and exterior indices of refraction must differ",
        )?;
        check(&loc, tilt.is_finite(), "scale_tilt must be finite")?;
        check(&loc, scale.is_finite(), "scale must be finite")?;
        let sigma_node = p.objects().find(|c| c.attr("name") == Some("sigma_a"));
        let given = sigma_node.is_some() || p.has("sigma_a");
        if given && pigments {
            return Err(Error::scene(
                &loc,
                "give either the pigments (eumelanin, pheomelanin) or sigma_a, not both",
            ));
        }
        let mut slots = Vec::new();
        let sigma_a = if let Some(c) = sigma_node {
            if cx.props().kind(c) != "texture" {
                return Err(Error::scene(
                    &c.loc,
                    format!(
                        "'sigma_a' expects a colour or a <texture>, not a <{}>",
                        c.tag
                    ),
                ));
            }
            let tex = cx.texture(c)?;
            match cx.texture_at(tex) {
                Texture::Constant(v) => *v,
                other => {
                    let mean = other.mean();
                    slots.push((Slot::SigmaA, tex));
                    mean
                }
            }
        } else if given {
            p.color_with("sigma_a", Spectrum::ZERO, SpectrumUse::Unbounded)?
        } else {
            Hair::pigment_sigma_a(eu, pheo)
        };
        let template = BsdfNode::Hair(Hair::new(bl, ba, tilt, int / ext, sigma_a, scale));
        Ok(MaterialNode::Leaf {
            template: Box::new(template),
            slots,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rough_fiber_density_is_normalised_and_continuous_at_kappa_10() {
        // ∫ M dω over the sphere = 1 for a few incident angles and roughnesses.
        for &(sin_i, kappa) in &[(0.0f32, 2.0f32), (0.5, 9.0), (-0.3, 40.0), (0.9, 200.0)] {
            let wi = Vec3::new((1.0 - sin_i * sin_i).sqrt(), sin_i, 0.0);
            let n = 4000;
            let mut sum = 0.0f64;
            for k in 0..n {
                let y = -1.0 + 2.0 * (k as f32 + 0.5) / n as f32;
                let wo = Vec3::new((1.0 - y * y).sqrt(), y, 0.0);
                // dω = dy dφ, the density does not depend on φ.
                sum += rough_fiber_pdf(wo, wi, kappa) as f64 * (2.0 / n as f64) * 2.0 * PI as f64;
            }
            assert!((sum - 1.0).abs() < 2e-3, "sin θi {sin_i}, κ {kappa}: {sum}");
        }
        let wi = Vec3::new(0.8, 0.6, 0.0);
        let wo = Vec3::new(0.6, -0.8, 0.0);
        let (a, b) = (
            rough_fiber_pdf(wo, wi, 10.0),
            rough_fiber_pdf(wo, wi, 10.0001),
        );
        assert!((a - b).abs() < 1e-3 * a, "{a} vs {b}");
    }

    #[test]
    fn lossless_fiber_weights_are_one_and_defaults_absorb() {
        let clear = Hair::new(0.3, 0.3, 2.0, 1.55, Spectrum::ZERO, 1.0);
        let wi = Vec3::new(0.3, 0.4, 0.866).normalize();
        for k in 0..64 {
            let u1 = (k as f32 + 0.5) / 64.0;
            let u2 = Vec2::new(
                ((k * 37) % 64) as f32 / 64.0 + 0.01,
                ((k * 11) % 64) as f32 / 64.0,
            );
            if let Some(s) = clear.sample(wi, u1, u2) {
                assert!(
                    (s.weight - Spectrum::ONE).abs().max_element() < 1e-4,
                    "{}",
                    s.weight
                );
            }
        }
        let brown = Hair::default();
        let s = brown.sample(wi, 0.9, Vec2::new(0.3, 0.6)).unwrap();
        assert!(
            s.weight.max_element() < 1.0 && s.weight.z < s.weight.x,
            "{}",
            s.weight
        );
    }
}
