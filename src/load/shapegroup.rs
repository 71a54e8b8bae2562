//! Mitsuba 3's `shapegroup` (`src/shapes/shapegroup.cpp`, `src/render/shapegroup.cpp`) and the
//! loading of `instance` (the shape itself: `geometry/instance.rs`, with its parameter table).
//!
//! A `shapegroup` holds shapes that are not rendered by themselves; each `instance` that names
//! the group (nested in it, or by `<ref id>`) places all of them. The group is built once, when
//! it is met at the top level or first named by an instance, whichever comes first.
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | (nested objects) | `shape` (nested, or `<ref>`s to shapes) | none | the members: meshes and analytic shapes, each with its own BSDF, in group space |
//! | `to_world` | transform | identity | read and ignored, as in Mitsuba 3.9.1 (a warning says so): the instances place the group |
//!
//! Refused as Mitsuba 3.9.1 refuses them, each at its element: any object but a shape, a nested
//! `shapegroup`, an `instance` inside a group, and a member carrying an emitter (Mitsuba does
//! not instance emitters).

use super::Builder;
use crate::error::{Error, Result};
use crate::geometry::{Instance, Shape, ShapeKind};
use crate::scene::xml::ir::Node;

/// What one instance costs in memory besides its XML elements, for the budget: groove's
/// [`Instance`], Embree's instance geometry and its share of the top-level BVH. Measured: peak RSS
/// 701 MB for 200 000 instances of a one-sphere group, ~2.5 kB an instance beyond the elements'
/// own reservation; 4 kB leaves a margin.
const INSTANCE_BYTES: u64 = 4096;

impl<'d> Builder<'d> {
    /// The group `n` (a `<shape type="shapegroup">`), built on first use; returns its index.
    pub(super) fn shape_group(&mut self, n: &'d Node) -> Result<u32> {
        let key = n as *const Node;
        if let Some(&g) = self.group_index.get(&key) {
            return Ok(g);
        }
        let p = self.props(n)?;
        if p.transform_opt("to_world")?.is_some() {
            self.warnings.push(format!(
                "{}: a shapegroup's to_world is ignored (as in Mitsuba 3.9.1); \
                 the instances' to_world places the group",
                p.loc()
            ));
        }
        // Check every member before building any.
        let mut members = Vec::new();
        for c in p.objects() {
            let m = self.ids.resolve(c, "shape")?;
            if m.tag != "shape" {
                return Err(Error::scene(
                    &c.loc,
                    format!("a shapegroup holds only shapes, not <{}>", m.tag),
                ));
            }
            match m.attr("type") {
                Some("shapegroup") => {
                    return Err(Error::scene(
                        &c.loc,
                        "a shapegroup cannot hold another shapegroup (nested shape groups are \
                         not permitted, as in Mitsuba)",
                    ))
                }
                Some("instance") => {
                    return Err(Error::scene(
                        &c.loc,
                        "a shapegroup cannot hold an instance (nested instancing is not \
                         permitted, as in Mitsuba)",
                    ))
                }
                _ => {}
            }
            if let Some(e) = m.children.iter().find(|e| self.ids.kind(e) == "emitter") {
                return Err(Error::scene(
                    &e.loc,
                    "a shape inside a shapegroup cannot carry an emitter (Mitsuba does not \
                     instance emitters): place the emitting shape outside the group",
                ));
            }
            members.push(m);
        }
        p.finish()?;
        let start = self.shapes.len() as u32;
        for m in members {
            self.shape(m)?;
        }
        let end = self.shapes.len() as u32;
        let g = self.groups.len() as u32;
        self.groups.push(start..end);
        self.group_index.insert(key, g);
        Ok(g)
    }

    /// An `<shape type="instance">`: its group (built if needed) under its `to_world`.
    pub(super) fn instance(&mut self, n: &'d Node) -> Result<()> {
        let p = self.props(n)?;
        let xf = p.transform_full("to_world")?;
        let mut group = None;
        for c in p.objects() {
            let g = self.ids.resolve(c, "shape")?;
            if g.tag != "shape" || g.attr("type") != Some("shapegroup") {
                let what = match g.attr("type") {
                    Some(t) if g.tag == "shape" => format!("a '{t}' shape"),
                    _ => format!("<{}>", g.tag),
                };
                return Err(Error::scene(
                    &c.loc,
                    format!("an instance takes only a shapegroup, not {what}"),
                ));
            }
            if group.is_some() {
                return Err(Error::scene(
                    &c.loc,
                    "an instance takes only one shapegroup",
                ));
            }
            group = Some(g);
        }
        let g = group.ok_or_else(|| {
            Error::scene(
                p.loc(),
                "an instance needs a shapegroup (a <ref id=\"...\"/> to one, or one nested)",
            )
        })?;
        let loc = p.loc();
        p.finish()?;
        self.budget
            .reserve(INSTANCE_BYTES, "an instance")
            .map_err(|m| Error::scene(loc, m))?;
        let g = self.shape_group(g)?;
        let inst =
            Instance::with_mitsuba_inverse(g, &xf.matrix, xf.quirk_inverse_transpose.as_ref())
                .map_err(|m| Error::scene(loc, m))?;
        self.placed
            .push(Placed::Instance(self.instances.len() as u32));
        self.instances.push(inst);
        Ok(())
    }

    /// Numbers the shapes and instances as Mitsuba 3.9.1's `scene.shapes()` lists them (the
    /// `aov` integrator's `shape_index`, from 1). Its parser hands the scene's children to the
    /// `merge` shape (`src/shapes/merge.cpp`), which keeps every object that is not a mesh (or is
    /// a mesh with attributes) in file order and appends the meshes after them, merged by
    /// material, from a hash table keyed by object addresses: the meshes' order changes from run
    /// to run there (seen with ten rectangles). groove numbers the non-meshes (spheres, disks,
    /// cylinders, curves, instances; meshes with attributes) in file order, then each mesh
    /// (`obj`, `ply`, `serialized`, `rectangle`, `cube`) in the reverse of the file's order, one
    /// of the orders Mitsuba produces, without merging. Members of shape groups are not in the
    /// list (a hit through an instance reports the instance's number).
    pub(super) fn number_shapes(&mut self) {
        let mut member = vec![false; self.shapes.len()];
        for r in &self.groups {
            for i in r.clone() {
                member[i as usize] = true;
            }
        }
        let in_group = |i: u32| member[i as usize];
        let is_mesh = |s: &Shape| {
            matches!(s.kind, ShapeKind::Mesh(_) | ShapeKind::Rectangle { .. })
                && s.attributes().is_empty()
        };
        let mut first = Vec::new();
        let mut meshes = Vec::new();
        for &p in &self.placed {
            match p {
                Placed::Shape(i) if in_group(i) => {}
                Placed::Shape(i) if is_mesh(&self.shapes[i as usize]) => meshes.push(p),
                _ => first.push(p),
            }
        }
        for (k, p) in first.iter().chain(meshes.iter().rev()).enumerate() {
            let n = k as u32 + 1;
            match *p {
                Placed::Shape(i) => self.shapes[i as usize].scene_index = n,
                Placed::Instance(i) => self.instances[i as usize].scene_index = n,
            }
        }
    }
}

/// A shape or an instance (its index in the builder's list), in the order they were built.
#[derive(Clone, Copy, Debug)]
pub(super) enum Placed {
    Shape(u32),
    Instance(u32),
}
