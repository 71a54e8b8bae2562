//! The renderable scene: geometry with its acceleration structure, materials, emitters and the
//! camera (how it is rendered, the integrator, film and sampler, is
//! [`crate::render::RenderSettings`]). Built from XML by `scene::xml` (parse, upgrade) and
//! `load`; later stages never look back at the XML.

pub mod xml;

use crate::accel::Accel;
use crate::bsdf::{BsdfArena, SurfaceBsdf};
use crate::camera::Camera;
use crate::emitter::{Emitter, LightSampler};
use crate::geometry::{Ray, Shape, SurfaceInteraction};
use crate::material::{MatId, Materials};
use glam::Vec3;
use std::path::PathBuf;

pub struct Scene {
    pub(crate) shapes: Vec<Shape>,
    /// Material of each shape (every shape has one: Mitsuba's default is a 0.5 grey `diffuse`).
    pub(crate) shape_material: Vec<MatId>,
    /// Area emitter of each shape, as an index into `emitters`.
    pub(crate) shape_emitter: Vec<Option<u32>>,
    pub(crate) accel: Accel,
    pub(crate) materials: Materials,
    pub(crate) emitters: Vec<Emitter>,
    /// Indices of the environment emitters (seen by escaping rays).
    pub(crate) env_emitters: Vec<u32>,
    pub(crate) light_sampler: LightSampler,
    pub(crate) camera: Camera,
    /// Bounding sphere of the geometry (centre, radius).
    pub(crate) bsphere: (Vec3, f32),
    /// The scene file this came from.
    pub(crate) source: PathBuf,
}

/// Read-only views for tools and tests (the fields are the loader's to set).
impl Scene {
    pub fn shapes(&self) -> &[Shape] {
        &self.shapes
    }
    /// Material of each shape.
    pub fn shape_materials(&self) -> &[MatId] {
        &self.shape_material
    }
    pub fn materials(&self) -> &Materials {
        &self.materials
    }
    pub fn emitters(&self) -> &[Emitter] {
        &self.emitters
    }
    /// Indices of the environment emitters.
    pub fn env_emitters(&self) -> &[u32] {
        &self.env_emitters
    }
    pub fn light_sampler(&self) -> &LightSampler {
        &self.light_sampler
    }
    pub fn camera(&self) -> &Camera {
        &self.camera
    }
    pub fn accel(&self) -> &Accel {
        &self.accel
    }
    /// Bounding sphere of the geometry (centre, radius).
    pub fn bsphere(&self) -> (Vec3, f32) {
        self.bsphere
    }
    /// The scene file this came from.
    pub fn source(&self) -> &std::path::Path {
        &self.source
    }
}

impl Scene {
    /// Nearest surface hit along `ray`.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceInteraction> {
        let hit = self.accel.intersect(ray)?;
        Some(self.shapes[hit.geom as usize].interaction(hit.geom, ray, &hit))
    }

    /// Build the BSDF of the surface hit by `si` into `arena`, as seen from `si.wi`; `None`
    /// when `wi`'s sides in the shading and true-normal frames disagree (such a direction
    /// carries no light: Veach's strict normals, [`SurfaceBsdf`]).
    #[inline]
    pub fn bsdf_at<'a>(
        &self,
        si: &SurfaceInteraction,
        arena: &'a mut BsdfArena,
    ) -> Option<SurfaceBsdf<'a>> {
        arena.clear();
        let material = self.shape_material[si.shape as usize];
        let at = crate::texture::TexPoint::on_shape(si, &self.shapes[si.shape as usize]);
        let root = self.materials.build_at(material, si, &at, arena);
        SurfaceBsdf::new(arena.bsdf(root), si.sh, si.ng, si.wi)
    }

    /// True when something blocks `ray` within (tmin, tmax).
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.accel.occluded(ray)
    }

    /// Bounding sphere of a set of shapes.
    pub fn bounding_sphere(shapes: &[Shape]) -> (Vec3, f32) {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for s in shapes {
            let (a, b) = s.bounds();
            lo = lo.min(a);
            hi = hi.max(b);
        }
        if !lo.is_finite() || !hi.is_finite() {
            return (Vec3::ZERO, 1.0);
        }
        let c = 0.5 * (lo + hi);
        (c, (0.5 * (hi - lo).length()).max(1e-3))
    }
}
