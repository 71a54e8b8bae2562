//! Fresnel equations for unpolarised light: dielectric interfaces (with the refracted cosine and
//! total internal reflection) and conductors with a complex index of refraction η + ik, plus the
//! hemispherical ("diffuse") Fresnel reflectance fits used by `plastic`.
//!
//! Conventions follow Mitsuba 3: `eta` is the *relative* index (inside / outside, i.e. the index
//! below the local surface over the index above it); a negative `cos_theta_i` means the incident
//! direction arrives from inside, in which case the relative index is inverted.

use crate::spectrum::Spectrum;
use glam::Vec3;

/// Result of [`fresnel_dielectric`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DielectricFresnel {
    /// Unpolarised reflectance (1 under total internal reflection).
    pub r: f32,
    /// Cosine of the refracted direction, with the sign of the side it leaves on (opposite to
    /// `cos_theta_i`); 0 under total internal reflection.
    pub cos_theta_t: f32,
    /// Relative index seen by the refracted ray: η_t / η_i.
    pub eta_it: f32,
    /// Its reciprocal η_i / η_t (the factor that scales the tangential component).
    pub eta_ti: f32,
}

/// Fresnel reflectance of a smooth dielectric interface (average of the s and p amplitudes squared,
/// Hecht, "Optics", ch. 4). `eta` is the relative index inside/outside.
#[inline]
pub fn fresnel_dielectric(cos_theta_i: f32, eta: f32) -> DielectricFresnel {
    let f = crate::lane::fresnel::dielectric(cos_theta_i, eta);
    DielectricFresnel {
        r: f.r,
        cos_theta_t: f.cos_theta_t,
        eta_it: f.eta_it,
        eta_ti: f.eta_ti,
    }
}

/// Fresnel reflectance of a conductor with complex relative index `eta + i k` for one channel
/// (exact unpolarised formula, e.g. K. D. Möller, "Optics", 1988; PBR 3rd ed. §8.2.1).
/// `eta = 0, k = 1` gives a perfect mirror (reflectance 1 at every angle). Both are
/// `lane::fresnel` at width 1.
#[inline]
pub fn fresnel_conductor_1(cos_theta_i: f32, eta: f32, k: f32) -> f32 {
    crate::lane::fresnel::conductor_1(cos_theta_i, eta, k)
}

/// [`fresnel_conductor_1`] per RGB channel.
#[inline]
pub fn fresnel_conductor(cos_theta_i: f32, eta: Spectrum, k: Spectrum) -> Spectrum {
    Spectrum::new(
        fresnel_conductor_1(cos_theta_i, eta.x, k.x),
        fresnel_conductor_1(cos_theta_i, eta.y, k.y),
        fresnel_conductor_1(cos_theta_i, eta.z, k.z),
    )
}

/// Hemispherical average of the dielectric Fresnel reflectance under uniform (cosine-weighted)
/// illumination, as fitted by Egan & Hilgeman (1973) for η < 1 and by d'Eon & Irving (2011,
/// "A quantized-diffusion model for rendering translucent materials") for η ≥ 1 — the same choice
/// of fits as Mitsuba 3, so `plastic` matches it.
pub fn fresnel_diffuse_reflectance(eta: f32) -> f32 {
    if eta < 1.0 {
        -1.4399 * eta * eta + 0.7099 * eta + 0.6681 + 0.0636 / eta
    } else {
        let x = 1.0 / eta;
        0.919317 + x * (-3.4793 + x * (6.75335 + x * (-7.80989 + x * (4.98554 - 1.36881 * x))))
    }
}

/// Refract `wi` (pointing away from the surface) through a facet with normal `m`, given the
/// refracted cosine and η_i/η_t from [`fresnel_dielectric`] (the result points away on the other side).
#[inline]
pub fn refract(wi: Vec3, m: Vec3, cos_theta_t: f32, eta_ti: f32) -> Vec3 {
    m * (wi.dot(m) * eta_ti + cos_theta_t) - wi * eta_ti
}

/// Mirror reflection about the local normal `z`.
#[inline]
pub fn reflect_z(wi: Vec3) -> Vec3 {
    Vec3::new(-wi.x, -wi.y, wi.z)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dielectric_limits() {
        let f = fresnel_dielectric(1.0, 1.5);
        assert!((f.r - 0.04).abs() < 1e-6);
        assert!((f.cos_theta_t + 1.0).abs() < 1e-6);
        // From inside beyond the critical angle: total internal reflection.
        let f = fresnel_dielectric(-0.2, 1.5);
        assert_eq!(f.r, 1.0);
        assert_eq!(f.cos_theta_t, 0.0);
        assert_eq!(fresnel_dielectric(0.3, 1.0).r, 0.0);
        // Symmetry: from inside at the refracted angle gives the same reflectance.
        let f = fresnel_dielectric(0.6, 1.33);
        let g = fresnel_dielectric(f.cos_theta_t, 1.33);
        assert!((f.r - g.r).abs() < 1e-5);
        assert!((g.cos_theta_t - 0.6).abs() < 1e-5);
    }

    #[test]
    fn conductor_limits() {
        for c in [0.0f32, 0.1, 0.5, 1.0] {
            assert!((fresnel_conductor_1(c, 0.0, 1.0) - 1.0).abs() < 1e-5, "{c}");
        }
        // k = 0 reduces to the dielectric formula.
        for c in [0.1f32, 0.5, 0.9] {
            let a = fresnel_conductor_1(c, 1.5, 0.0);
            let b = fresnel_dielectric(c, 1.5).r;
            assert!((a - b).abs() < 1e-5, "{a} {b}");
        }
    }
}
