//! Orthonormal frames `(s, t, n)`: BSDFs are evaluated in the local frame where `n = z`.

use glam::Vec3;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    /// A frame around `n` with an arbitrary but continuous tangent
    /// (Duff et al. 2017, "Building an Orthonormal Basis, Revisited").
    #[inline]
    pub fn from_normal(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// A frame around `n` whose first tangent follows `dpdu` (Gram-Schmidt), as Mitsuba builds
    /// its shading frame. Falls back to [`Frame::from_normal`] when `dpdu` is degenerate.
    #[inline]
    pub fn from_normal_tangent(n: Vec3, dpdu: Vec3) -> Frame {
        let s = dpdu - n * n.dot(dpdu);
        let len2 = s.length_squared();
        if len2 <= 1e-20 || !len2.is_finite() {
            return Frame::from_normal(n);
        }
        let s = s / len2.sqrt();
        Frame {
            s,
            t: n.cross(s),
            n,
        }
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_and_round_trip() {
        let normals = [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.4, 0.2).normalize(),
            Vec3::new(0.0, 0.0, -0.999999).normalize(),
        ];
        for n in normals {
            let f = Frame::from_normal(n);
            assert!((f.s.length() - 1.0).abs() < 1e-5);
            assert!((f.t.length() - 1.0).abs() < 1e-5);
            assert!(f.s.dot(f.t).abs() < 1e-5 && f.s.dot(f.n).abs() < 1e-5);
            assert!((f.s.cross(f.t) - f.n).length() < 1e-5, "right-handed");
            let v = Vec3::new(0.1, 0.7, -0.2);
            assert!((f.to_world(f.to_local(v)) - v).length() < 1e-5);
        }
        let f = Frame::from_normal_tangent(Vec3::Z, Vec3::new(2.0, 0.0, 1.0));
        assert!((f.s - Vec3::X).length() < 1e-6);
        assert!((f.t - Vec3::Y).length() < 1e-6);
    }
}
