//! What a ray query reports before the surface is reconstructed.

/// [`Hit::inst`] of a hit on a shape that is not seen through an `instance`.
pub const NO_INSTANCE: u32 = u32::MAX;

/// A ray–shape hit: which shape (`geom` is the index into the scene's shape list; for a hit
/// through an instance, the index of the shape group's member that was hit), which triangle, the
/// distance, Embree's barycentrics (`p = (1−u−v)·p0 + u·p1 + v·p2`; unused for spheres), and
/// which instance (`inst`, an index into the scene's instances, or [`NO_INSTANCE`]).
/// [`crate::geometry::Shape::interaction`] turns it into a `SurfaceInteraction`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub geom: u32,
    pub prim: u32,
    pub t: f32,
    pub u: f32,
    pub v: f32,
    pub inst: u32,
}
