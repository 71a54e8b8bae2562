//! Orthonormal frames `(s, t, n)`: BSDFs are evaluated in the local frame where `n = z`.
//! The arithmetic is `lane::frame` at width 1 (one source for the 1- and 8-lane renderers).

use crate::lane::frame::Frame as LaneFrame;
use crate::lane::vec::V3;
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
        LaneFrame::from_normal(V3::from(n)).into()
    }

    /// A frame around `n` whose first tangent follows `dpdu` (Gram-Schmidt), as Mitsuba builds
    /// its shading frame. Falls back to [`Frame::from_normal`] when `dpdu` is degenerate.
    #[inline]
    pub fn from_normal_tangent(n: Vec3, dpdu: Vec3) -> Frame {
        LaneFrame::from_normal_tangent(V3::from(n), V3::from(dpdu)).into()
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        self.lanes().to_local(V3::from(v)).into()
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.lanes().to_world(V3::from(v)).into()
    }

    /// The same frame as a width-1 lane frame.
    #[inline(always)]
    fn lanes(&self) -> LaneFrame<f32> {
        LaneFrame {
            s: self.s.into(),
            t: self.t.into(),
            n: self.n.into(),
        }
    }
}

impl From<LaneFrame<f32>> for Frame {
    #[inline(always)]
    fn from(f: LaneFrame<f32>) -> Frame {
        Frame {
            s: f.s.into(),
            t: f.t.into(),
            n: f.n.into(),
        }
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
