//! Orthonormal frames `(s, t, n)` of lanes, built exactly as `math::Frame` builds them (Duff et
//! al. 2017, "Building an Orthonormal Basis, Revisited"; Gram–Schmidt along `dpdu`), so width 1
//! equals `math::Frame` bit for bit.

use super::vec::V3;
use super::{Lane, LaneMask};

#[derive(Clone, Copy, Debug)]
pub struct Frame<L> {
    pub s: V3<L>,
    pub t: V3<L>,
    pub n: V3<L>,
}

impl<L: Lane> Frame<L> {
    /// A frame around the unit normal `n` with a continuous tangent (Duff et al. 2017).
    #[inline(always)]
    pub fn from_normal(n: V3<L>) -> Self {
        let one = n.z.splat(1.0);
        let sign = one.copysign(n.z);
        let a = -one / (sign + n.z);
        let b = n.x * n.y * a;
        let s = V3::new(one + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = V3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    /// A frame around `n` whose first tangent follows `dpdu` (Gram–Schmidt); the
    /// [`Frame::from_normal`] frame where `dpdu` is degenerate (|s|² ≤ 1e-20 or not finite).
    #[inline(always)]
    pub fn from_normal_tangent(n: V3<L>, dpdu: V3<L>) -> Self {
        let s = dpdu - n.scale(n.dot(dpdu));
        let len2 = s.length_squared();
        let bad = len2.le(len2.splat(1e-20)) | !len2.is_finite();
        let s = s.div_by(len2.sqrt());
        if !bad.any() {
            // Fast path (same bits as the selects below): no lane falls back.
            return Frame {
                s,
                t: n.cross(s),
                n,
            };
        }
        let f = Frame::from_normal(n);
        Frame {
            s: V3::select(bad, f.s, s),
            t: V3::select(bad, f.t, n.cross(s)),
            n,
        }
    }

    #[inline(always)]
    pub fn to_local(&self, v: V3<L>) -> V3<L> {
        V3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    #[inline(always)]
    pub fn to_world(&self, v: V3<L>) -> V3<L> {
        self.s.scale(v.x) + self.t.scale(v.y) + self.n.scale(v.z)
    }
}
