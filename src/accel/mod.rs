//! Ray queries against the scene's shapes, backed by Embree 3 (`embree.rs` holds all FFI).

mod embree;

use crate::error::{Error, Result};
use crate::geometry::shapes::{Shape, ShapeKind};
use crate::geometry::Ray;

/// A ray–shape hit: which shape (`geom` is the index into the scene's shape list), which
/// triangle, the distance, and Embree's barycentrics (`p = (1−u−v)·p0 + u·p1 + v·p2`; unused for
/// spheres).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub geom: u32,
    pub prim: u32,
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// The acceleration structure over a scene's shapes. `Send + Sync`: queries run from any thread.
pub struct Accel {
    scene: embree::EmbreeScene,
}

impl Accel {
    /// Builds the BVH; shape `i` is reported as `Hit::geom == i`.
    pub fn build(shapes: &[Shape]) -> Result<Accel> {
        let descs: Vec<embree::GeomDesc> = shapes
            .iter()
            .map(|s| match &s.kind {
                ShapeKind::Mesh(m) if m.indices.is_empty() => embree::GeomDesc::Empty,
                ShapeKind::Mesh(m) => embree::GeomDesc::Triangles {
                    positions: &m.positions,
                    indices: &m.indices,
                },
                ShapeKind::Sphere { center, radius, .. } => embree::GeomDesc::Sphere {
                    center: *center,
                    radius: *radius,
                },
                ShapeKind::Disk { to_world } => embree::GeomDesc::Disk {
                    to_world: *to_world,
                },
                ShapeKind::Rectangle { to_world } => embree::GeomDesc::Rectangle {
                    to_world: *to_world,
                },
            })
            .collect();
        let scene = embree::EmbreeScene::build(&descs).map_err(Error::Native)?;
        Ok(Accel { scene })
    }

    /// The nearest hit with `t` in `[ray.tmin, ray.tmax]`.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.scene
            .intersect(ray.o, ray.d, ray.tmin, ray.tmax)
            .map(|h| Hit {
                geom: h.geom,
                prim: h.prim,
                t: h.t,
                u: h.u,
                v: h.v,
            })
    }

    /// Whether any surface lies on the ray within `[ray.tmin, ray.tmax]`.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.scene.occluded(ray.o, ray.d, ray.tmin, ray.tmax)
    }
}

/// Sets FTZ and DAZ in MXCSR for the calling thread (x86_64; a no-op elsewhere). Embree
/// recommends it; call it on every rayon worker (`ThreadPoolBuilder::start_handler`).
pub fn set_flush_denormals() {
    embree::set_flush_denormals();
}

#[cfg(test)]
mod tests {
    use super::*;
    fn assert_send_sync<T: Send + Sync>() {}
    #[test]
    fn accel_is_send_and_sync() {
        assert_send_sync::<Accel>();
    }
}
