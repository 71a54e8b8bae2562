//! 3- and 2-vectors of lanes (structure of arrays: one lane type per component). The operation
//! order is glam's (`dot = x·x' + y·y' + z·z'` left to right, `normalize = v · (1/|v|)`,
//! glam's `cross`), so width 1 gives exactly the numbers of `glam::Vec3`.

use super::Lane;
use core::ops::{Add, Mul, Neg, Sub};

/// A 3-vector whose components are lanes.
#[derive(Clone, Copy, Debug)]
pub struct V3<L> {
    pub x: L,
    pub y: L,
    pub z: L,
}

/// A 2-vector whose components are lanes.
#[derive(Clone, Copy, Debug)]
pub struct V2<L> {
    pub x: L,
    pub y: L,
}

impl<L: Lane> V3<L> {
    #[inline(always)]
    pub fn new(x: L, y: L, z: L) -> Self {
        V3 { x, y, z }
    }
    /// `(x, y, z)` in every lane, with the width of `like`.
    #[inline(always)]
    pub fn splat(like: L, x: f32, y: f32, z: f32) -> Self {
        V3::new(like.splat(x), like.splat(y), like.splat(z))
    }
    #[inline(always)]
    pub fn dot(self, o: Self) -> L {
        self.x * o.x + self.y * o.y + self.z * o.z
    }
    #[inline(always)]
    pub fn cross(self, o: Self) -> Self {
        V3::new(
            self.y * o.z - o.y * self.z,
            self.z * o.x - o.z * self.x,
            self.x * o.y - o.x * self.y,
        )
    }
    #[inline(always)]
    pub fn length_squared(self) -> L {
        self.dot(self)
    }
    #[inline(always)]
    pub fn length(self) -> L {
        self.dot(self).sqrt()
    }
    /// `self · (1/|self|)` (glam's `normalize`; not finite for a zero vector).
    #[inline(always)]
    pub fn normalize(self) -> Self {
        let l = self.length();
        self.scale(l.splat(1.0) / l)
    }
    /// Each component times `s`.
    #[inline(always)]
    pub fn scale(self, s: L) -> Self {
        V3::new(self.x * s, self.y * s, self.z * s)
    }
    /// Each component divided by `s`.
    #[inline(always)]
    pub fn div_by(self, s: L) -> Self {
        V3::new(self.x / s, self.y / s, self.z / s)
    }
    /// Per lane `if m { a } else { b }`.
    #[inline(always)]
    pub fn select(m: L::Mask, a: Self, b: Self) -> Self {
        V3::new(
            L::select(m, a.x, b.x),
            L::select(m, a.y, b.y),
            L::select(m, a.z, b.z),
        )
    }
}

impl<L: Lane> V2<L> {
    #[inline(always)]
    pub fn new(x: L, y: L) -> Self {
        V2 { x, y }
    }
    #[inline(always)]
    pub fn length_squared(self) -> L {
        self.x * self.x + self.y * self.y
    }
    #[inline(always)]
    pub fn select(m: L::Mask, a: Self, b: Self) -> Self {
        V2::new(L::select(m, a.x, b.x), L::select(m, a.y, b.y))
    }
}

impl<L: Lane> Add for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn add(self, o: Self) -> Self {
        V3::new(self.x + o.x, self.y + o.y, self.z + o.z)
    }
}
impl<L: Lane> Sub for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn sub(self, o: Self) -> Self {
        V3::new(self.x - o.x, self.y - o.y, self.z - o.z)
    }
}
/// Component-wise product.
impl<L: Lane> Mul for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn mul(self, o: Self) -> Self {
        V3::new(self.x * o.x, self.y * o.y, self.z * o.z)
    }
}
impl<L: Lane> Neg for V3<L> {
    type Output = Self;
    #[inline(always)]
    fn neg(self) -> Self {
        V3::new(-self.x, -self.y, -self.z)
    }
}

impl From<glam::Vec3> for V3<f32> {
    #[inline(always)]
    fn from(v: glam::Vec3) -> Self {
        V3::new(v.x, v.y, v.z)
    }
}
impl From<V3<f32>> for glam::Vec3 {
    #[inline(always)]
    fn from(v: V3<f32>) -> Self {
        glam::Vec3::new(v.x, v.y, v.z)
    }
}
impl From<V2<f32>> for glam::Vec2 {
    #[inline(always)]
    fn from(v: V2<f32>) -> Self {
        glam::Vec2::new(v.x, v.y)
    }
}
impl From<glam::Vec2> for V2<f32> {
    #[inline(always)]
    fn from(v: glam::Vec2) -> Self {
        V2::new(v.x, v.y)
    }
}
