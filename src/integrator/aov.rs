//! `aov` (Mitsuba 3.9.1 `src/integrators/aov.cpp`): arbitrary output variables of the surface
//! the camera ray meets first, beside the images of nested integrators.
//!
//! Channels, in Mitsuba's order: for every inner integrator `NAME`, its image `NAME.R/G/B/A`
//! (A: the inner integrator's valid mask); then every inner integrator's own channels
//! (`NAME.<channel>`); then the entries of the `aovs` string `name:type,...`:
//!
//! | type | channels | value (0 where the ray misses) |
//! |---|---|---|
//! | `depth` | `name.T` | ray distance from the near-clip plane (Mitsuba's camera ray origin) |
//! | `position` | `name.X/Y/Z` | world-space hit point |
//! | `uv` | `name.U/V` | surface uv |
//! | `geo_normal` | `name.X/Y/Z` | geometric normal (flipped by `flip_normals`) |
//! | `sh_normal` | `name.X/Y/Z` | shading normal |
//! | `dp_du`, `dp_dv` | `name.X/Y/Z` | position partials with respect to uv |
//! | `prim_index` | `name.I` | triangle index inside a mesh; 0 on spheres, disks, rectangles |
//! | `shape_index` | `name.I` | Mitsuba 3.9.1's number of the shape in `scene.shapes()`, from 1 (0: background): the shapes that are not meshes and the instances in file order, then the meshes (see `Builder::number_shapes` in `load/shapegroup.rs`); a hit through an instance reports the instance's number, as Mitsuba (`si.instance` before `si.shape`) |
//!
//! On analytic shapes Mitsuba 3.9.1's `prim_index` is 0 on some pixels and 1 on others (a
//! rectangle floor in `tests/data/scenes/aov.xml`); groove reports 0 there.
//!
//! The RGB image is the first inner integrator's estimate (black without inner integrators).
//! Mitsuba 3.9.1 renders each inner integrator a second time for the image it returns from
//! `mi.render`; what its film writes to disk (and what groove writes) is this single pass.

use super::{IntegratorDesc, RayKind, Scratch};
use crate::geometry::hit::NO_INSTANCE;
use crate::geometry::{Ray, ShapeKind, SurfaceInteraction};
use crate::sampler::Sampler;
use crate::scene::Scene;
use crate::spectrum::Spectrum;
use glam::Vec3;

/// ∂p/∂u and ∂p/∂v as Mitsuba 3.9.1 reports them (`mesh.cpp`): a mesh without texture
/// coordinates is parameterised by its barycentrics, so they are the triangle's edges p1 − p0
/// and p2 − p0; every other case is the interaction's own (groove's interaction uses a frame
/// around the normal for uv-less meshes, as Mitsuba does only for degenerate uvs).
fn uv_partials(scene: &Scene, si: &SurfaceInteraction) -> (Vec3, Vec3) {
    if let Some(shape) = scene.shapes.get(si.shape as usize) {
        if let ShapeKind::Mesh(m) = &shape.kind {
            if m.uvs.is_none() {
                if let Some(tri) = m.indices.get(si.prim as usize) {
                    let [p0, p1, p2] = tri.map(|i| m.positions[i as usize]);
                    return (p1 - p0, p2 - p0);
                }
            }
        }
    }
    (si.dpdu, si.dpdv)
}

/// One AOV type of the `aovs` string.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AovKind {
    Depth,
    Position,
    Uv,
    GeoNormal,
    ShNormal,
    DpDu,
    DpDv,
    PrimIndex,
    ShapeIndex,
}

impl AovKind {
    /// The type names groove knows, as the `aovs` string spells them.
    pub const NAMES: [&'static str; 9] = [
        "depth",
        "position",
        "uv",
        "geo_normal",
        "sh_normal",
        "dp_du",
        "dp_dv",
        "prim_index",
        "shape_index",
    ];

    /// The type named `s`, if groove supports it.
    pub fn parse(s: &str) -> Option<AovKind> {
        Some(match s {
            "depth" => AovKind::Depth,
            "position" => AovKind::Position,
            "uv" => AovKind::Uv,
            "geo_normal" => AovKind::GeoNormal,
            "sh_normal" => AovKind::ShNormal,
            "dp_du" => AovKind::DpDu,
            "dp_dv" => AovKind::DpDv,
            "prim_index" => AovKind::PrimIndex,
            "shape_index" => AovKind::ShapeIndex,
            _ => return None,
        })
    }

    /// Channel suffixes, as Mitsuba names them.
    pub fn channels(self) -> &'static [&'static str] {
        match self {
            AovKind::Depth => &["T"],
            AovKind::Uv => &["U", "V"],
            AovKind::PrimIndex | AovKind::ShapeIndex => &["I"],
            AovKind::Position
            | AovKind::GeoNormal
            | AovKind::ShNormal
            | AovKind::DpDu
            | AovKind::DpDv => &["X", "Y", "Z"],
        }
    }
}

/// The inner integrators (named) and the AOV entries (name, type) in the order given.
#[derive(Clone, Debug)]
pub struct AovSettings {
    pub inner: Vec<(String, IntegratorDesc)>,
    pub entries: Vec<(String, AovKind)>,
}

impl AovSettings {
    pub fn aov_count(&self) -> usize {
        let inner: usize = self.inner.iter().map(|(_, i)| 4 + i.aov_count()).sum();
        inner
            + self
                .entries
                .iter()
                .map(|(_, k)| k.channels().len())
                .sum::<usize>()
    }

    pub fn aov_names(&self) -> Vec<String> {
        let mut names = Vec::with_capacity(self.aov_count());
        for (name, _) in &self.inner {
            names.extend(["R", "G", "B", "A"].map(|c| format!("{name}.{c}")));
        }
        for (name, inner) in &self.inner {
            names.extend(inner.aov_names().iter().map(|a| format!("{name}.{a}")));
        }
        for (name, kind) in &self.entries {
            names.extend(kind.channels().iter().map(|c| format!("{name}.{c}")));
        }
        names
    }

    /// The first inner integrator's radiance; the channels go to `aovs` when it is long enough.
    pub fn sample(
        &self,
        scene: &Scene,
        ray: Ray,
        sampler: &mut Sampler,
        scratch: &mut Scratch,
        aovs: &mut [f32],
    ) -> Spectrum {
        let write = aovs.len() >= self.aov_count();
        let mut result = Spectrum::ZERO;
        if !write {
            if let Some((_, inner)) = self.inner.first() {
                result = inner.sample(scene, ray, sampler, scratch, &mut []);
                // The other inner integrators draw from the sampler too, as in Mitsuba.
                for (_, i) in &self.inner[1..] {
                    i.sample(scene, ray, sampler, scratch, &mut []);
                }
            }
            return result;
        }
        let hit = scratch.rays.intersect(scene, &ray, RayKind::Camera);
        let n_rgba = 4 * self.inner.len();
        let mut off = n_rgba;
        for (i, (_, inner)) in self.inner.iter().enumerate() {
            let n = inner.aov_count();
            let l = inner.sample(scene, ray, sampler, scratch, &mut aovs[off..off + n]);
            off += n;
            let v = l.to_array();
            let valid = inner.valid(scene, hit.as_ref());
            aovs[4 * i..4 * i + 4].copy_from_slice(&[v[0], v[1], v[2], valid as u32 as f32]);
            if i == 0 {
                result = l;
            }
        }
        for &(_, kind) in &self.entries {
            let out = &mut aovs[off..off + kind.channels().len()];
            off += out.len();
            let Some(si) = &hit else {
                out.fill(0.0);
                continue;
            };
            match kind {
                // groove's camera rays start at the camera with tmin on the near plane; Mitsuba's
                // start on the near plane.
                AovKind::Depth => out[0] = si.t - ray.tmin,
                AovKind::Position => out.copy_from_slice(&si.p.to_array()),
                AovKind::Uv => out.copy_from_slice(&si.uv.to_array()),
                AovKind::GeoNormal => out.copy_from_slice(&si.ng.to_array()),
                AovKind::ShNormal => out.copy_from_slice(&si.sh.n.to_array()),
                AovKind::DpDu => out.copy_from_slice(&uv_partials(scene, si).0.to_array()),
                AovKind::DpDv => out.copy_from_slice(&uv_partials(scene, si).1.to_array()),
                AovKind::PrimIndex => out[0] = si.prim as f32,
                // Mitsuba 3.9.1 numbers `scene->shapes()` from 1 (the loader computed each
                // shape's and instance's number); a hit through an instance reports the
                // instance, whose index only the ray query's hit carries.
                AovKind::ShapeIndex => {
                    let inst = scene.accel.intersect(&ray).map_or(NO_INSTANCE, |h| h.inst);
                    out[0] = match scene.instances.get(inst as usize) {
                        Some(i) => i.scene_index,
                        None => scene.shapes[si.shape as usize].scene_index,
                    } as f32;
                }
            }
        }
        result
    }
}
