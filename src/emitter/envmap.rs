//! `envmap`: an environment lit by a latitude-longitude image (Mitsuba 3's `envmap`).
//!
//! Conventions, checked numerically against Mitsuba 3.9.1 (`scalar_rgb`, `emitter.eval` on a 64×32
//! test map at 200 random directions, relative difference < 1e-5):
//! * a direction `d` toward the environment, in the map's frame (`to_world`⁻¹ · d), has
//!   u = atan2(d.x, −d.z) / 2π (wrapped to [0,1)) and v = acos(d.y) / π: +y is up, the first
//!   image row is the +y pole and the last row the −y pole; u = 0 looks along −z, u = ¼ along +x;
//! * the radiance is the bilinear interpolation of the texels (times `scale`) at the continuous
//!   texel position x = u·W − ½ (texel centres at u = (i + ½)/W, wrapping around in u) and
//!   y = v·(H − 1) (row j sits at v = j/(H − 1), so the first and last rows are the poles).
//!
//! Importance sampling: a piecewise-constant density over the (H − 1) × W bilinear patches
//! between texel centres, each weighted by the mean luminance of its four corners times the mean
//! of sin θ over its latitude band (a discrete version of pbrt's luminance × sin θ map, pbrt 3rd
//! ed. §14.2.4). Every patch with any non-zero corner has non-zero density, so the estimator is
//! unbiased for the bilinear radiance; the density in solid angle is p(u, v) / (2π² sin θ).

use super::DirectSample;
use crate::lane::math as lm;
use crate::math::{Distribution2D, PI};
use crate::spectrum::{luminance, Spectrum};
use glam::{Mat3, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct EnvMapLight {
    width: usize,
    height: usize,
    /// Radiance of each texel (already multiplied by `scale`), row-major, row 0 at the +y pole.
    texels: Vec<Spectrum>,
    /// Map frame → world (a rotation) and its inverse.
    to_world: Mat3,
    to_local: Mat3,
    /// Over the patches: x = W patches between texel centres (wrapping), y = H − 1 latitude bands.
    dist: Distribution2D,
    /// Mean luminance of the radiance over the sphere, ∫ Y(L) dω / 4π.
    mean_luminance: f32,
}

impl EnvMapLight {
    /// From a `width` × `height` RGB image (row 0 on top), a `scale`, and a rotation `to_world`.
    /// Errors (plain messages, located by the caller) for images smaller than 1 × 2, non-finite
    /// or negative texels, and maps without any emission.
    pub fn new(
        width: usize,
        height: usize,
        pixels: &[[f32; 3]],
        scale: f32,
        to_world: Mat3,
    ) -> Result<EnvMapLight, String> {
        if width < 1 || height < 2 || pixels.len() != width * height {
            return Err(format!(
                "the environment map must be at least 1x2 pixels (it is {width}x{height})"
            ));
        }
        if !(scale.is_finite() && scale >= 0.0) {
            return Err(format!(
                "'scale' must be finite and not negative (it is {scale})"
            ));
        }
        let mut texels = Vec::with_capacity(pixels.len());
        for (i, p) in pixels.iter().enumerate() {
            let c = Spectrum::from_array(*p);
            if !crate::spectrum::is_finite(c) {
                return Err(format!(
                    "texel ({}, {}) is not finite ({:?})",
                    i % width,
                    i / width,
                    p
                ));
            }
            if c.min_element() < 0.0 {
                return Err(format!(
                    "texel ({}, {}) is negative ({:?}); an emitter cannot emit negative radiance",
                    i % width,
                    i / width,
                    p
                ));
            }
            texels.push(c * scale);
        }
        let (w, h) = (width, height);
        let bands = h - 1;
        let lum: Vec<f32> = texels.iter().map(|&c| luminance(c).max(0.0)).collect();
        let mut weights = vec![0.0f32; w * bands];
        let mut integral = 0.0f64;
        for j in 0..bands {
            let (t0, t1) = (
                PI * j as f32 / bands as f32,
                PI * (j + 1) as f32 / bands as f32,
            );
            let mean_sin = (t0.cos() - t1.cos()) / (t1 - t0);
            for i in 0..w {
                let i1 = (i + 1) % w;
                let m = 0.25
                    * (lum[j * w + i]
                        + lum[j * w + i1]
                        + lum[(j + 1) * w + i]
                        + lum[(j + 1) * w + i1]);
                weights[j * w + i] = m * mean_sin;
                integral += (m * mean_sin) as f64;
            }
        }
        // ∫ Y dω ≈ Σ patch mean × (2π² sin θ) du dv, du dv = 1 / (W (H − 1)).
        let integral = integral * 2.0 * (PI as f64).powi(2) / (w * bands) as f64;
        let dist = Distribution2D::new(&weights, w, bands)
            .ok_or("the environment map emits no light (all texels are zero)")?;
        Ok(EnvMapLight {
            width: w,
            height: h,
            texels,
            to_world,
            to_local: to_world.transpose(),
            dist,
            mean_luminance: (integral / (4.0 * PI as f64)) as f32,
        })
    }

    /// Mean luminance of the radiance over all directions.
    pub fn mean_luminance(&self) -> f32 {
        self.mean_luminance
    }

    /// (u, v) of a unit direction given in the map's frame.
    #[inline]
    pub fn uv_of_local(d: Vec3) -> Vec2 {
        let mut u = lm::atan2(d.x, -d.z) * (0.5 / PI);
        if u < 0.0 {
            u += 1.0;
        }
        if u >= 1.0 {
            u = 0.0;
        }
        Vec2::new(u, lm::acos(d.y.clamp(-1.0, 1.0)) / PI)
    }

    /// Unit direction in the map's frame of (u, v).
    #[inline]
    pub fn local_of_uv(uv: Vec2) -> Vec3 {
        let (sp, cp) = lm::sincos(2.0 * PI * uv.x);
        let (st, ct) = lm::sincos(PI * uv.y);
        Vec3::new(st * sp, ct, -st * cp)
    }

    #[inline]
    fn texel(&self, i: usize, j: usize) -> Spectrum {
        self.texels[j * self.width + i]
    }

    /// Bilinearly interpolated radiance at (u, v).
    pub fn lookup(&self, uv: Vec2) -> Spectrum {
        let (w, h) = (self.width, self.height);
        let x = uv.x * w as f32 - 0.5;
        let y = (uv.y * (h - 1) as f32).clamp(0.0, (h - 1) as f32);
        let xf = crate::math::floor(x);
        let fx = x - xf;
        let i0 = (xf as i64).rem_euclid(w as i64) as usize;
        let i1 = (i0 + 1) % w;
        let j0 = (crate::math::floor(y) as usize).min(h - 2);
        let fy = y - j0 as f32;
        let top = self.texel(i0, j0) * (1.0 - fx) + self.texel(i1, j0) * fx;
        let bottom = self.texel(i0, j0 + 1) * (1.0 - fx) + self.texel(i1, j0 + 1) * fx;
        top * (1.0 - fy) + bottom * fy
    }

    /// Radiance arriving along world direction `-d` from the environment in direction `d`.
    pub fn eval(&self, d: Vec3) -> Spectrum {
        let l = (self.to_local * d).normalize_or_zero();
        if l == Vec3::ZERO {
            return Spectrum::ZERO;
        }
        self.lookup(Self::uv_of_local(l))
    }

    /// The first step of [`Self::sample_direct`]: the walk of the 2-D table from `u`, and the
    /// texture-space (u, v) of the point it picks (`None` where the density is not positive).
    /// Shared with the stream renderer's lanes (`stream::kernels::emitters`), which walk the
    /// table lane by lane and do the rest 8-wide.
    #[inline]
    pub(crate) fn sample_uv(&self, u: Vec2) -> Option<Vec2> {
        let (p, pdf_uv) = self.dist.sample(u);
        if pdf_uv.is_nan() || pdf_uv <= 0.0 {
            return None;
        }
        // Patch space → texture space: patches start at texel centres, half a texel into u.
        let mut uu = p.x + self.half_texel();
        if uu >= 1.0 {
            uu -= 1.0;
        }
        Some(Vec2::new(uu, p.y))
    }

    /// Half a texel in u, `0.5 / width`: the shift between patch and texture space.
    #[inline]
    pub(crate) fn half_texel(&self) -> f32 {
        0.5 / self.width as f32
    }

    /// Map frame → world (a rotation), and its inverse.
    pub(crate) fn frames(&self) -> (Mat3, Mat3) {
        (self.to_world, self.to_local)
    }

    /// The density of the 2-D table at the patch-space point `p` ([`Self::pdf_direct`]'s
    /// lookup, before the change to solid angle).
    #[inline]
    pub(crate) fn patch_pdf(&self, p: Vec2) -> f32 {
        self.dist.pdf(p)
    }

    pub fn sample_direct(&self, ref_p: Vec3, u: Vec2) -> Option<DirectSample> {
        let uv = self.sample_uv(u)?;
        if lm::sin(PI * uv.y) <= 0.0 {
            return None;
        }
        let d = (self.to_world * Self::local_of_uv(uv)).normalize();
        // The density and radiance are recomputed from `d` exactly as `pdf_direct` and `eval`
        // do for a BSDF-sampled ray, so MIS sees identical values for the same direction (a
        // point within rounding of a patch edge might otherwise get its neighbour's density).
        let pdf = self.pdf_direct(d);
        if !(pdf.is_finite() && pdf > 0.0) {
            return None;
        }
        Some(DirectSample {
            d,
            dist: f32::INFINITY,
            p: ref_p + d,
            n: None,
            pdf,
            value: self.eval(d),
            delta: false,
        })
    }

    /// Solid-angle density with which `sample_direct` picks the world direction `d`.
    pub fn pdf_direct(&self, d: Vec3) -> f32 {
        let l = (self.to_local * d).normalize_or_zero();
        if l == Vec3::ZERO {
            return 0.0;
        }
        let uv = Self::uv_of_local(l);
        let sin_theta = lm::sin(PI * uv.y);
        if sin_theta.is_nan() || sin_theta <= 0.0 {
            return 0.0;
        }
        let mut px = uv.x - self.half_texel();
        if px < 0.0 {
            px += 1.0;
        }
        self.dist.pdf(Vec2::new(px, uv.y)) / (2.0 * PI * PI * sin_theta)
    }
}
