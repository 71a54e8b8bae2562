//! The surface of a `linearcurve` / `bsplinecurve` at an Embree hit, as Mitsuba 3.9.1's
//! `compute_surface_interaction` gives it (`src/shapes/linearcurve.cpp`, `bsplinecurve.cpp`).
//!
//! Embree reports the segment (`primID`) and the curve parameter `v` ∈ [0, 1] along it
//! (`hit.u`). With c(v) the centre line and r(v) the radius there:
//! - normal: linear, the direction from c(v) to the hit point; B-spline, that direction
//!   corrected for the curvature and the radius change, n ∝ (|c′|² − (p − c)·c″)(p − c) − r r′ c′;
//! - uv: u = φ/2π, the angle of p − c around the axis in the frame (v_rad, v_rot) where v_rot
//!   is +z made orthogonal to the axis (+y when the axis is ±z) and v_rad = v_rot × axis;
//!   v = (v_local + segment) / segment count, along all segments of the shape;
//! - dp/du, dp/dv: linear, zero (Mitsuba 3.9.1 leaves them unset, so the shading frame's
//!   tangent is `coordinate_system(n)`); B-spline, the tube's partials from the curve's
//!   Frenet–Serret frame (curvature κ, torsion τ), u scaled to [0, 2π) and v to the shape's
//!   global parameter, and the shading tangent dp/du made orthogonal to n.
//!
//! The partials use the hit's own segment and parameter. Mitsuba 3.9.1 recomputes the segment
//! from the global v, which for v = 1 on a shape's last segment indexes one past the end (it
//! crashed on `tests/data/scenes/mat_hair.xml` until that segment was hidden; clamped upstream
//! after 3.9.1).

use super::curves::{CurveBasis, Curves};
use crate::math::{Frame, INV_2PI, PI};
use glam::{Vec2, Vec3};

/// What a curve hit contributes to the surface interaction.
#[derive(Clone, Copy, Debug)]
pub struct CurvePoint {
    /// Unit normal (geometric and shading).
    pub n: Vec3,
    pub uv: Vec2,
    pub dpdu: Vec3,
    pub dpdv: Vec3,
}

impl Curves {
    /// The surface at the hit point `p` of segment `prim` at Embree's curve parameter `v_local`.
    pub fn surface(&self, prim: u32, v_local: f32, p: Vec3) -> CurvePoint {
        let seg = self.segment(prim);
        let count = self.segments.len() as f32;
        let v = (v_local + prim as f32) / count;
        match self.basis {
            CurveBasis::Linear => {
                let (p0, p1) = (pos(&seg[0]), pos(&seg[1]));
                let axis = (p1 - p0).normalize_or_zero();
                let c = p0 * (1.0 - v_local) + p1 * v_local;
                let n = (p - c).try_normalize().unwrap_or_else(|| any_normal(axis));
                let (rot, rad) = local_frame(axis);
                CurvePoint {
                    n,
                    uv: Vec2::new(angle(rot, rad, n), v),
                    dpdu: Vec3::ZERO,
                    dpdv: Vec3::ZERO,
                }
            }
            CurveBasis::BSpline => {
                let k = Cubic::at(seg, v_local);
                let rv = p - k.c;
                let n = ((k.dc.length_squared() - rv.dot(k.dcc)) * rv - (k.dr * k.r) * k.dc)
                    .try_normalize()
                    .unwrap_or_else(|| any_normal(k.dc.normalize_or_zero()));
                let axis = k.dc.normalize_or_zero();
                let (rot, rad) = local_frame(axis);
                let u = angle(rot, rad, rv.normalize_or_zero());
                let (dpdu, dpdv) = k.partials(u, count);
                CurvePoint {
                    n,
                    uv: Vec2::new(u, v),
                    dpdu,
                    dpdv,
                }
            }
        }
    }
}

#[inline]
fn pos(c: &[f32; 4]) -> Vec3 {
    Vec3::new(c[0], c[1], c[2])
}

/// A unit vector orthogonal to `axis` (for a hit exactly on the centre line).
fn any_normal(axis: Vec3) -> Vec3 {
    if axis == Vec3::ZERO {
        Vec3::Z
    } else {
        Frame::from_normal(axis).s
    }
}

/// Mitsuba's `local_frame(axis)`: (v_rot, v_rad), v_rot being +z made orthogonal to the axis
/// (+y when the axis is exactly ±z) and v_rad = v_rot × axis.
fn local_frame(axis: Vec3) -> (Vec3, Vec3) {
    let rot = if axis.z.abs() == 1.0 {
        Vec3::Y
    } else {
        (Vec3::Z - axis * axis.z).normalize_or_zero()
    };
    (rot, rot.cross(axis))
}

/// u = φ/2π ∈ [0, 1) of the unit radial direction `d` in the frame (rad, rot).
fn angle(rot: Vec3, rad: Vec3, d: Vec3) -> f32 {
    let mut phi = rot.dot(d).atan2(rad.dot(d));
    if phi < 0.0 {
        phi += 2.0 * PI;
    }
    phi * INV_2PI
}

/// A uniform cubic B-spline segment at v: centre c and its first three derivatives, radius r
/// and its derivative (Mitsuba's `cubic_interpolation`).
struct Cubic {
    c: Vec3,
    dc: Vec3,
    dcc: Vec3,
    dccc: Vec3,
    r: f32,
    dr: f32,
}

impl Cubic {
    fn at(seg: &[[f32; 4]], v: f32) -> Cubic {
        let (v2, v3) = (v * v, v * v * v);
        // The basis functions and their derivatives, control point by control point.
        let b = [
            (-v3 + 3.0 * v2 - 3.0 * v + 1.0) / 6.0,
            (3.0 * v3 - 6.0 * v2 + 4.0) / 6.0,
            (-3.0 * v3 + 3.0 * v2 + 3.0 * v + 1.0) / 6.0,
            v3 / 6.0,
        ];
        let db = [
            (-3.0 * v2 + 6.0 * v - 3.0) / 6.0,
            (9.0 * v2 - 12.0 * v) / 6.0,
            (-9.0 * v2 + 6.0 * v + 3.0) / 6.0,
            3.0 * v2 / 6.0,
        ];
        let ddb = [1.0 - v, 3.0 * v - 2.0, 1.0 - 3.0 * v, v];
        let dddb = [-1.0, 3.0, -3.0, 1.0];
        let mut k = Cubic {
            c: Vec3::ZERO,
            dc: Vec3::ZERO,
            dcc: Vec3::ZERO,
            dccc: Vec3::ZERO,
            r: 0.0,
            dr: 0.0,
        };
        for (i, cp) in seg.iter().enumerate().take(4) {
            let p = pos(cp);
            k.c += p * b[i];
            k.dc += p * db[i];
            k.dcc += p * ddb[i];
            k.dccc += p * dddb[i];
            k.r += cp[3] * b[i];
            k.dr += cp[3] * db[i];
        }
        k
    }

    /// dp/du and dp/dv of the tube at u (∈ [0, 1), around) for a shape of `count` segments
    /// (Mitsuba's `partials`: the radial direction differentiated in the Frenet–Serret frame).
    fn partials(&self, u: f32, count: f32) -> (Vec3, Vec3) {
        let norm = self.dc.length();
        let cross = self.dc.cross(self.dcc);
        let cross_len = cross.length();
        let t = self.dc / norm;
        let mut kappa = cross_len / (norm * norm * norm);
        let mut tau = self.dccc.dot(cross) / (cross_len * cross_len);
        if cross_len < 1e-6 || self.dccc.length() < 1e-6 {
            tau = 0.0;
        }
        let (fn_, fb) = if kappa < f32::EPSILON * 0.5 || !kappa.is_finite() {
            // A straight piece: no Frenet frame; any frame around the tangent.
            kappa = 0.0;
            tau = 0.0;
            let f = Frame::from_normal(t);
            (f.s, f.t)
        } else {
            let fn_ = cross.cross(self.dc).normalize();
            (fn_, t.cross(fn_).normalize())
        };
        let (rot, rad_dir) = local_frame(t);
        let (s, c) = (2.0 * PI * u).sin_cos();
        let rad = rad_dir * c + rot * s;
        let (cos_t, sin_t) = (fn_.dot(rad), fb.dot(rad));
        let radu = -sin_t * fn_ + cos_t * fb;
        let radv = norm * cos_t * (-kappa * t + tau * fb) + norm * sin_t * (-tau * fn_);
        let dpdu = self.r * radu * (2.0 * PI);
        let dpdv = (self.dc + self.dr * rad + self.r * radv) * count;
        (dpdu, dpdv)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn curves(basis: CurveBasis, points: Vec<[f32; 4]>, segments: Vec<u32>) -> Curves {
        Curves {
            basis,
            points,
            segments,
        }
    }

    #[test]
    fn linear_normal_uv_and_frame_follow_mitsuba() {
        // Along +x: v_rot = +z, v_rad = z × x = +y; u = 0 at +y, 1/4 at +z.
        let c = curves(
            CurveBasis::Linear,
            vec![
                [0.0, 0.0, 0.0, 0.5],
                [2.0, 0.0, 0.0, 0.5],
                [4.0, 0.0, 0.0, 0.5],
            ],
            vec![0, 1],
        );
        let s = c.surface(1, 0.25, Vec3::new(2.5, 0.0, 0.5));
        assert!((s.n - Vec3::Z).length() < 1e-6, "{:?}", s.n);
        assert!(
            (s.uv - Vec2::new(0.25, 0.625)).length() < 1e-6,
            "{:?}",
            s.uv
        );
        let s = c.surface(0, 0.5, Vec3::new(1.0, 0.5, 0.0));
        assert!((s.uv - Vec2::new(0.0, 0.25)).length() < 1e-6, "{:?}", s.uv);
        assert_eq!((s.dpdu, s.dpdv), (Vec3::ZERO, Vec3::ZERO));
        // Along z the frame is singular: v_rot = +y, v_rad = y × z = +x.
        let z = curves(
            CurveBasis::Linear,
            vec![[0.0, 0.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0]],
            vec![0],
        );
        let s = z.surface(0, 0.5, Vec3::new(0.0, -1.0, 0.5));
        assert!((s.uv.x - 0.75).abs() < 1e-6, "{:?}", s.uv);
    }

    #[test]
    fn bspline_partials_match_finite_differences() {
        // A bent, twisted segment with varying radius.
        let c = curves(
            CurveBasis::BSpline,
            vec![
                [0.0, 0.0, 0.0, 0.2],
                [1.0, 0.5, 0.2, 0.3],
                [2.0, -0.3, 0.8, 0.25],
                [3.0, 0.4, 1.5, 0.1],
            ],
            vec![0],
        );
        let seg = c.segment(0);
        // The surface point at (u, v_local): Mitsuba's parameterisation c + r (cos, sin) frame.
        let point = |u: f32, v: f32| {
            let k = Cubic::at(seg, v);
            let (rot, rad) = local_frame(k.dc.normalize());
            let (s, co) = (2.0 * PI * u).sin_cos();
            k.c + (rad * co + rot * s) * k.r
        };
        for &(u, v) in &[(0.1f32, 0.3f32), (0.6, 0.5), (0.85, 0.8)] {
            let p = point(u, v);
            let s = c.surface(0, v, p);
            assert!(
                (s.uv.x - u).abs() < 1e-4 && (s.uv.y - v).abs() < 1e-6,
                "{:?}",
                s.uv
            );
            let h = 1e-3;
            let du = (point(u + h, v) - point(u - h, v)) / (2.0 * h);
            let dv = (point(u, v + h) - point(u, v - h)) / (2.0 * h);
            assert!(
                (s.dpdu - du).length() < 2e-2 * du.length(),
                "{} vs {du}",
                s.dpdu
            );
            // Mitsuba carries the radial direction along v in the Frenet frame, not in the
            // (v_rad, v_rot) frame of the uv map: only the part of dp/dv across dp/du agrees.
            let across = |w: Vec3| w - du.normalize() * w.dot(du.normalize());
            let (a, b) = (across(s.dpdv), across(dv));
            assert!((a - b).length() < 2e-2 * b.length(), "{a} vs {b}");
            // The normal is orthogonal to both partials.
            assert!(
                s.n.dot(du.normalize()).abs() < 1e-2,
                "n·du {}",
                s.n.dot(du.normalize())
            );
            assert!(
                s.n.dot(dv.normalize()).abs() < 1e-2,
                "n·dv {}",
                s.n.dot(dv.normalize())
            );
            assert!(s.n.dot(p - Cubic::at(seg, v).c) > 0.0);
        }
    }
}
