//! The record of a ray hitting a surface.

use crate::math::Frame;
use glam::{Vec2, Vec3};

/// Everything shading needs about a hit, in world space.
#[derive(Clone, Copy, Debug)]
pub struct SurfaceInteraction {
    /// Hit position.
    pub p: Vec3,
    /// Ray distance to the hit.
    pub t: f32,
    /// True geometric normal (unit; the triangle's winding / the sphere's outward normal, flipped
    /// by `flip_normals`). Not turned toward the ray.
    pub ng: Vec3,
    /// Shading frame: `n` is the interpolated vertex normal (or `ng`), `s` follows `dpdu`.
    pub sh: Frame,
    pub uv: Vec2,
    pub dpdu: Vec3,
    pub dpdv: Vec3,
    /// Index of the shape in the scene's shape list.
    pub shape: u32,
    /// Primitive (triangle) index inside the shape.
    pub prim: u32,
    /// Direction toward the previous vertex (−ray.d), world space.
    pub wi: Vec3,
}

impl SurfaceInteraction {
    /// A ray leaving the surface in direction `d` with an origin offset to `d`'s side.
    #[inline]
    pub fn spawn_ray(&self, d: Vec3) -> super::Ray {
        super::Ray::new(super::ray::offset_origin(self.p, self.ng, d), d)
    }

    /// A shadow ray toward the point `target` (which lies on a surface with normal `target_n`,
    /// or `None` for a point light), stopping just short of it.
    #[inline]
    pub fn spawn_ray_to(&self, target: Vec3, target_n: Option<Vec3>) -> super::Ray {
        let d0 = target - self.p;
        let o = super::ray::offset_origin(self.p, self.ng, d0);
        let t_end = match target_n {
            Some(n) => super::ray::offset_origin(target, n, -d0),
            None => target,
        };
        let d = t_end - o;
        let dist = d.length();
        let mut r = super::Ray::new(o, d / dist);
        r.tmax = dist * (1.0 - 1e-4);
        r
    }
}
