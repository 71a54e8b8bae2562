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
use crate::geometry::Instance;
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
        let to_world = p.transform("to_world")?;
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
        let inst = Instance::new(g, &to_world).map_err(|m| Error::scene(loc, m))?;
        self.instances.push(inst);
        Ok(())
    }
}
