//! Geometry: rays, surface interactions, triangle meshes and the analytic shapes, with their
//! loaders (OBJ, PLY, Mitsuba serialized) and area sampling for emitters; instances of shape
//! groups.

pub mod attributes;
pub mod curve_surface;
pub mod curves;
pub mod cylinder;
pub mod hit;
pub mod instance;
pub mod interaction;
pub mod mesh;
pub mod obj;
pub mod ply;
pub mod ply_attributes;
pub mod ray;
pub mod sdfgrid;
pub mod serialized;
pub mod shapes;
pub mod sphere_map;
pub mod surface_lanes;
pub mod volfile;

pub use cylinder::Cylinder;
pub use hit::{Hit, NO_INSTANCE};
pub use instance::Instance;
pub use interaction::SurfaceInteraction;
pub use mesh::TriMesh;
pub use ray::Ray;
pub use shapes::{DirectionSample, PositionSample, Shape, ShapeKind};
