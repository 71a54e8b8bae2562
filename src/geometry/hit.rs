//! What a ray query reports before the surface is reconstructed.

/// A ray–shape hit: which shape (`geom` is the index into the scene's shape list), which
/// triangle, the distance, and Embree's barycentrics (`p = (1−u−v)·p0 + u·p1 + v·p2`; unused for
/// spheres). [`crate::geometry::Shape::interaction`] turns it into a `SurfaceInteraction`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub geom: u32,
    pub prim: u32,
    pub t: f32,
    pub u: f32,
    pub v: f32,
}
