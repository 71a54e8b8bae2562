//! Lobes and terms shared by `principled` and `principledthin` (Burley 2012, "Physically Based
//! Shading at Disney"; Burley 2015, "Extending the Disney BRDF to a BSDF with Integrated
//! Subsurface Scattering"), in the form Mitsuba 3.9.1 evaluates them: Schlick Fresnel, the
//! roughness-to-α map, the GTR1 clearcoat distribution with its separable GGX masking, the
//! diffuse/retro-reflection/fake-subsurface base and the sheen lobe.

use crate::spectrum::{luminance, Spectrum};
use glam::{Vec2, Vec3};
use std::f32::consts::PI;

/// Schlick's weight (1 − cos θ)⁵, with 1 − cos θ clamped to [0, 1] (Burley 2012, §5.3).
#[inline]
pub fn schlick_weight(cos_i: f32) -> f32 {
    let m = (1.0 - cos_i).clamp(0.0, 1.0);
    let m2 = m * m;
    m2 * m2 * m
}

/// The Schlick weight a reflectance at normal incidence `r0` is blended with:
/// `F = r0 + (1 − r0)·w`. For a ray entering the denser side (η_it > 1) `w` uses the incident
/// cosine, otherwise the refracted one (0 past the critical angle gives `w = 1`), as Mitsuba's
/// `calc_schlick` does.
#[inline]
pub fn schlick_blend_weight(cos_theta_i: f32, eta: f32) -> f32 {
    let outside = cos_theta_i >= 0.0;
    let (eta_it, eta_ti) = if outside {
        (eta, 1.0 / eta)
    } else {
        (1.0 / eta, eta)
    };
    if eta_it > 1.0 {
        schlick_weight(cos_theta_i.abs())
    } else {
        let ct2 = 1.0 - (1.0 - cos_theta_i * cos_theta_i) * eta_ti * eta_ti;
        schlick_weight(crate::math::safe_sqrt(ct2))
    }
}

/// Schlick's approximation with a scalar `r0` (see [`schlick_blend_weight`]).
#[inline]
pub fn schlick(r0: f32, cos_theta_i: f32, eta: f32) -> f32 {
    let w = schlick_blend_weight(cos_theta_i, eta);
    w + (1.0 - w) * r0
}

/// Schlick's approximation per colour channel.
#[inline]
pub fn schlick_rgb(r0: Spectrum, cos_theta_i: f32, eta: f32) -> Spectrum {
    let w = schlick_blend_weight(cos_theta_i, eta);
    Spectrum::splat(w) + (1.0 - w) * r0
}

/// Reflectance at normal incidence of a relative index η: ((η − 1)/(η + 1))².
#[inline]
pub fn schlick_r0(eta: f32) -> f32 {
    let r = (eta - 1.0) / (eta + 1.0);
    r * r
}

/// The base colour normalised by its luminance (the hue of the tints); white if it is black.
#[inline]
pub fn tint_color(base_color: Spectrum) -> Spectrum {
    let lum = luminance(base_color);
    if lum > 0.0 {
        base_color / lum
    } else {
        Spectrum::ONE
    }
}

/// GGX roughnesses (α_x, α_y) from `roughness` and `anisotropic`: α = roughness², stretched by
/// aspect = √(1 − 0.9·anisotropic) (Burley 2012, §B.2), each at least 0.001.
#[inline]
pub fn alphas(anisotropic: f32, roughness: f32) -> (f32, f32) {
    let r2 = roughness * roughness;
    let aspect = (1.0 - 0.9 * anisotropic).sqrt();
    ((r2 / aspect).max(0.001), (r2 * aspect).max(0.001))
}

/// Do the micro- and macro-surface agree: `wi` on the facet's front (the side of `wi`) and `wo`
/// on the same side for a reflection, on the other for a transmission.
#[inline]
pub fn facet_compatible(m: Vec3, wi: Vec3, wo: Vec3, cos_theta_i: f32, reflection: bool) -> bool {
    let m = if cos_theta_i.is_sign_negative() {
        -m
    } else {
        m
    };
    let o = if reflection { wo.dot(m) } else { -wo.dot(m) };
    wi.dot(m) > 0.0 && o > 0.0
}

/// The isotropic GTR1 ("generalised Trowbridge–Reitz", γ = 1) distribution of the clearcoat
/// lobe (Burley 2012, eq. 4 and §B.2), sampled in proportion to D(m) cos θm.
#[derive(Clone, Copy, Debug)]
pub struct Gtr1 {
    pub alpha: f32,
}

impl Gtr1 {
    /// The clearcoat distribution for `clearcoat_gloss` g: α = lerp(0.1, 0.001, g).
    #[inline]
    pub fn clearcoat(gloss: f32) -> Self {
        Gtr1 {
            alpha: 0.1 + (0.001 - 0.1) * gloss,
        }
    }

    /// D(m) = (α² − 1) / (π ln α² (1 + (α² − 1) cos²θm)).
    #[inline]
    pub fn eval(&self, m: Vec3) -> f32 {
        let ct = m.z;
        let a2 = self.alpha * self.alpha;
        let d = (a2 - 1.0) / (PI * a2.ln() * (1.0 + (a2 - 1.0) * ct * ct));
        if d * ct > 1e-20 {
            d
        } else {
            0.0
        }
    }

    /// Density of [`Self::sample`]: D(m) cos θm.
    #[inline]
    pub fn pdf(&self, m: Vec3) -> f32 {
        if m.z < 0.0 {
            0.0
        } else {
            m.z * self.eval(m)
        }
    }

    /// A normal with density D(m) cos θm (inverting the CDF of cos²θm).
    #[inline]
    pub fn sample(&self, u: Vec2) -> Vec3 {
        let (sp, cp) = (2.0 * PI * u.x).sin_cos();
        let a2 = self.alpha * self.alpha;
        let ct2 = (1.0 - a2.powf(1.0 - u.y)) / (1.0 - a2);
        let st = (1.0 - ct2).max(0.0).sqrt();
        let ct = ct2.max(0.0).sqrt();
        Vec3::new(cp * st, sp * st, ct)
    }
}

/// Smith's GGX masking G1(v) of roughness `alpha`, 0 for a facet `wh` seen from behind.
#[inline]
pub fn smith_ggx1(v: Vec3, wh: Vec3, alpha: f32) -> f32 {
    if v.dot(wh) * v.z <= 0.0 {
        return 0.0;
    }
    if v.z == 1.0 {
        return 1.0;
    }
    let c2 = v.z * v.z;
    let t2 = (1.0 - c2) / c2;
    2.0 / (1.0 + (1.0 + alpha * alpha * t2).sqrt())
}

/// The clearcoat's masking-shadowing: separable GGX with α = 0.25 (Burley 2012, §B.2).
#[inline]
pub fn clearcoat_g(wi: Vec3, wo: Vec3, wh: Vec3) -> f32 {
    smith_ggx1(wi, wh, 0.25) * smith_ggx1(wo, wh, 0.25)
}

/// The diffuse base without albedo, 1/π and cosine: Burley's diffuse with retro-reflection
/// (Burley 2015, eq. 4–5), blended by `flatness` toward the Hanrahan–Krueger-like fake
/// subsurface term (Burley 2012, §5.3). `cos_i`, `cos_o` are |cos θ|, `cos_d` = wh·wo.
#[inline]
pub fn diffuse_base(cos_i: f32, cos_o: f32, cos_d: f32, roughness: f32, flatness: f32) -> f32 {
    let fo = schlick_weight(cos_o);
    let fi = schlick_weight(cos_i);
    let f_diff = (1.0 - 0.5 * fi) * (1.0 - 0.5 * fo);
    let rr = 2.0 * roughness * cos_d * cos_d;
    let f_retro = rr * (fo + fi + fo * fi * (rr - 1.0));
    let fss90 = 0.5 * rr;
    let fss = (1.0 + (fss90 - 1.0) * fo) * (1.0 + (fss90 - 1.0) * fi);
    let f_ss = 1.25 * (fss * (1.0 / (cos_o + cos_i) - 0.5) + 0.5);
    let base = f_diff + f_retro;
    base + (f_ss - base) * flatness
}

/// Burley's sheen (2012, §5.3) without its weight and cosine: Schlick weight of the half angle,
/// coloured from white toward the base colour's hue by `sheen_tint`.
#[inline]
pub fn sheen(base_color: Spectrum, sheen_tint: f32, cos_d: f32) -> Spectrum {
    let c = Spectrum::ONE + (tint_color(base_color) - Spectrum::ONE) * sheen_tint;
    c * schlick_weight(cos_d.abs())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gtr1_is_normalised_and_sampled_by_its_pdf() {
        // (α = 0.001 is too peaked for this midpoint rule; the pointwise test covers it.)
        for alpha in [0.02f32, 0.05, 0.1] {
            let d = Gtr1 { alpha };
            // ∫ D(m) cos θm dω = 1 (midpoint rule in cos θ, D is isotropic).
            let n = 200_000;
            let mut s = 0.0f64;
            for i in 0..n {
                let ct = (i as f64 + 0.5) / n as f64;
                s += d.eval(Vec3::new((1.0 - ct * ct).sqrt() as f32, 0.0, ct as f32)) as f64
                    * ct
                    * 2.0
                    * std::f64::consts::PI
                    / n as f64;
            }
            assert!((s - 1.0).abs() < 2e-3, "α {alpha}: {s}");
            // Sampling inverts the CDF of cos θm: u.y = 0.5 gives the median cosine.
            let m = d.sample(Vec2::new(0.3, 0.5));
            let c_med = m.z as f64;
            let mut cdf = 0.0f64;
            for i in 0..n {
                let ct = (i as f64 + 0.5) / n as f64;
                if ct < c_med {
                    cdf += d.pdf(Vec3::new((1.0 - ct * ct).sqrt() as f32, 0.0, ct as f32)) as f64
                        * 2.0
                        * std::f64::consts::PI
                        / n as f64;
                }
            }
            // Half of the mass lies below the median cosine.
            assert!((cdf - 0.5).abs() < 5e-3, "α {alpha}: {cdf}");
        }
    }

    #[test]
    fn schlick_limits() {
        assert!((schlick(0.04, 1.0, 1.5) - 0.04).abs() < 1e-6);
        assert!((schlick(0.04, 0.0, 1.5) - 1.0).abs() < 1e-6);
        // From inside beyond the critical angle the refracted cosine is 0: F = 1.
        assert!((schlick(0.04, -0.3, 1.5) - 1.0).abs() < 1e-6);
        assert!((schlick_r0(1.5) - 0.04).abs() < 1e-7);
        assert_eq!(alphas(0.0, 0.0), (0.001, 0.001));
    }
}
