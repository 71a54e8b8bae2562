//! Rays and robust ray origins.

use glam::Vec3;

#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub o: Vec3,
    /// Direction; unit length by convention (emitters and the integrator rely on it).
    pub d: Vec3,
    pub tmin: f32,
    pub tmax: f32,
}

impl Ray {
    #[inline]
    pub fn new(o: Vec3, d: Vec3) -> Ray {
        Ray {
            o,
            d,
            tmin: 0.0,
            tmax: f32::INFINITY,
        }
    }

    /// The segment from `o` along `d` up to distance `tmax` (a shadow ray toward a light point).
    #[inline]
    pub fn segment(o: Vec3, d: Vec3, tmax: f32) -> Ray {
        Ray {
            o,
            d,
            tmin: 0.0,
            tmax,
        }
    }

    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.o + self.d * t
    }
}

/// Moves `p` off the surface with geometric normal `n`, to the side `dir` points to, by a few
/// ulps of the coordinates (Wächter & Binder 2019, "A Fast and Robust Method for Avoiding
/// Self-Intersection", Ray Tracing Gems ch. 6): integer ulp steps far from the origin, a small
/// absolute step near it. No epsilon in scene units, so no light leaks through thin geometry.
#[inline]
pub fn offset_origin(p: Vec3, n: Vec3, dir: Vec3) -> Vec3 {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let n = if n.dot(dir) < 0.0 { -n } else { n };
    let of_i = [
        (INT_SCALE * n.x) as i32,
        (INT_SCALE * n.y) as i32,
        (INT_SCALE * n.z) as i32,
    ];
    let pa = p.to_array();
    let na = n.to_array();
    let mut out = [0.0f32; 3];
    for k in 0..3 {
        let bits = pa[k].to_bits() as i32;
        let step = if pa[k] < 0.0 { -of_i[k] } else { of_i[k] };
        let p_i = f32::from_bits(bits.wrapping_add(step) as u32);
        out[k] = if pa[k].abs() < ORIGIN {
            pa[k] + FLOAT_SCALE * na[k]
        } else {
            p_i
        };
    }
    Vec3::from_array(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn offset_moves_to_the_requested_side() {
        for p in [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(500.0, 1.0, -300.0),
            Vec3::new(-1e4, 3.0, 2.0),
        ] {
            let n = Vec3::new(0.2, 0.9, -0.1).normalize();
            let up = offset_origin(p, n, n);
            let down = offset_origin(p, n, -n);
            assert!((up - p).dot(n) > 0.0);
            assert!((down - p).dot(n) < 0.0);
            assert!((up - p).length() < 1e-2 * (1.0 + p.length() * 1e-3));
        }
    }
}
