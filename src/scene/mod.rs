//! The renderable scene: geometry with its acceleration structure, materials, emitters and the
//! camera (how it is rendered, the integrator, film and sampler, is
//! [`crate::render::RenderSettings`]). Built from XML by `scene::xml` (parse, upgrade) and
//! `load`; later stages never look back at the XML.

pub mod xml;

use crate::accel::Accel;
use crate::bsdf::{BsdfArena, SurfaceBsdf};
use crate::camera::Camera;
use crate::emitter::{Emitter, LightSampler};
use crate::geometry::hit::NO_INSTANCE;
use crate::geometry::{Hit, Instance, Ray, Shape, SurfaceInteraction};
use crate::material::{MatId, Materials};
use crate::medium::{Medium, MediumId, MediumInterface};
use glam::Vec3;
use std::path::PathBuf;

pub struct Scene {
    /// Every surface: the shapes traced as they are, and the members of the shape groups (in
    /// group space, traced only through `instances`; each is a shape of its own for its
    /// material, so `SurfaceInteraction::shape` names the member that was hit).
    pub(crate) shapes: Vec<Shape>,
    /// The placements of shape groups (`instance`), indexed by `Hit::inst`.
    pub(crate) instances: Vec<Instance>,
    /// Material of each shape (every shape has one: Mitsuba's default is a 0.5 grey `diffuse`).
    pub(crate) shape_material: Vec<MatId>,
    /// Whether each shape's material reads a `mesh_attribute` texture of the shape: only those
    /// hits carry the mesh data to the texture lookups ([`crate::texture::TexPoint::on_shape`]);
    /// every other lookup is by uv alone, which keeps the common hit as cheap as before mesh
    /// attributes existed.
    pub(crate) shape_reads_mesh: Vec<bool>,
    /// The media on both sides of each shape (none: the surface does not change the medium).
    pub(crate) shape_media: Vec<MediumInterface>,
    /// Every participating medium, indexed by [`crate::medium::MediumId`].
    pub(crate) media: Vec<Medium>,
    /// The medium the sensor sits in (Mitsuba's sensor `medium`).
    pub(crate) camera_medium: Option<MediumId>,
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
    /// The instances of shape groups.
    pub fn instances(&self) -> &[Instance] {
        &self.instances
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
    /// The media on both sides of each shape.
    pub fn shape_media(&self) -> &[MediumInterface] {
        &self.shape_media
    }
    /// The participating media.
    pub fn media(&self) -> &[Medium] {
        &self.media
    }
    /// The medium the sensor sits in.
    pub fn camera_medium(&self) -> Option<MediumId> {
        self.camera_medium
    }
    /// The scene file this came from.
    pub fn source(&self) -> &std::path::Path {
        &self.source
    }
}

impl Scene {
    /// The environment emitters a ray leaving the scene in direction `d` sees, with their
    /// non-zero radiance: (emitter index, emitter, radiance). Each integrator weighs them its own
    /// way; the next-event density of one is `emitter.pdf_direct_env(d) · light_sampler.pmf(index)`.
    #[inline]
    pub fn env_emission(
        &self,
        d: Vec3,
    ) -> impl Iterator<Item = (usize, &Emitter, crate::spectrum::Spectrum)> + '_ {
        self.env_emitters.iter().filter_map(move |&e| {
            let em = &self.emitters[e as usize];
            let le = em.eval_env(d);
            (le != crate::spectrum::Spectrum::ZERO).then_some((e as usize, em, le))
        })
    }

    /// Nearest surface hit along `ray`.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<SurfaceInteraction> {
        let hit = self.accel.intersect(ray)?;
        Some(self.interaction(ray, &hit))
    }

    /// The surface interaction of `hit`, found by the accelerator along `ray` (the second half
    /// of [`Self::intersect`], for renderers that trace rays in packets first).
    #[inline]
    pub fn interaction(&self, ray: &Ray, hit: &Hit) -> SurfaceInteraction {
        let hit = *hit;
        let shape = &self.shapes[hit.geom as usize];
        if hit.inst == NO_INSTANCE {
            return shape.interaction(hit.geom, ray, &hit);
        }
        // A group member seen through an instance: its surface in group space, mapped back.
        let inst = &self.instances[hit.inst as usize];
        let local = shape.interaction(hit.geom, &inst.object_ray(ray), &hit);
        inst.interaction(local, ray)
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
        let root = self.bsdf_root(si, arena);
        SurfaceBsdf::new(arena.bsdf(root), si.sh, si.ng, si.wi)
    }

    /// The hit material's BSDF tree at `si`, pushed onto `arena` after what it holds (not
    /// cleared: the stream renderer's `mnm` kernel keeps 8 points' trees in one arena); returns
    /// its root. [`Self::bsdf_at`] is this on a cleared arena and the side test.
    #[inline]
    pub fn bsdf_root(&self, si: &SurfaceInteraction, arena: &mut BsdfArena) -> u32 {
        let shape = si.shape as usize;
        let material = self.shape_material[shape];
        if self.shape_reads_mesh[shape] {
            let at = crate::texture::TexPoint::on_shape(si, &self.shapes[shape]);
            self.materials.build_at(material, si, at, arena)
        } else {
            self.materials.build(material, si, arena)
        }
    }

    /// True when something blocks `ray` within (tmin, tmax).
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        self.accel.occluded(ray)
    }

    /// Bounding sphere of a set of shapes.
    pub fn bounding_sphere(shapes: &[Shape]) -> (Vec3, f32) {
        Scene::bounding_sphere_instanced(shapes, &[], &[])
    }

    /// Bounding sphere of what is traced: the shapes outside the `groups` (ranges of shape
    /// indices, as for `Accel::build_instanced`) and every instance's group under its
    /// transform.
    pub fn bounding_sphere_instanced(
        shapes: &[Shape],
        groups: &[std::ops::Range<u32>],
        instances: &[Instance],
    ) -> (Vec3, f32) {
        let empty = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let union = |(a, b): (Vec3, Vec3), (c, d): (Vec3, Vec3)| (a.min(c), b.max(d));
        let of = |r: std::ops::Range<u32>| {
            shapes
                .get(r.start as usize..r.end as usize)
                .unwrap_or(&[])
                .iter()
                .map(Shape::bounds)
                .fold(empty, union)
        };
        let mut member = vec![false; shapes.len()];
        for r in groups {
            for m in member
                .get_mut(r.start as usize..r.end as usize)
                .unwrap_or(&mut [])
            {
                *m = true;
            }
        }
        let mut bounds = shapes
            .iter()
            .zip(&member)
            .filter(|(_, &m)| !m)
            .map(|(s, _)| s.bounds())
            .fold(empty, union);
        for inst in instances {
            if let Some(r) = groups.get(inst.group() as usize) {
                bounds = union(bounds, inst.bounds(of(r.clone())));
            }
        }
        let (lo, hi) = bounds;
        if !lo.is_finite() || !hi.is_finite() {
            return (Vec3::ZERO, 1.0);
        }
        let c = 0.5 * (lo + hi);
        (c, (0.5 * (hi - lo).length()).max(1e-3))
    }
}
