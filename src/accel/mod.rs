//! Ray queries against the scene's shapes, in one of two tiers (issue 16 item 3), chosen per
//! scene by [`Accel::build_instanced`]:
//! - **Embree** (`embree.rs` holds all FFI): a BVH over triangles, curves, instances and the
//!   analytic shapes as user geometries;
//! - **tier A** (`brute.rs`, kernels in `analytic.rs` and `triangle.rs`): scenes of a few
//!   spheres, disks, rectangles, boxes and mesh triangles and nothing else (within the budget
//!   of [`BRUTE_MAX_SHAPES`] and [`BRUTE_MAX_TRIANGLES`], no instances), intersected by brute
//!   force 8 lanes at a time. For the analytic shapes both tiers report the same [`Hit`] bit
//!   for bit; for triangles tier A's own arithmetic (Möller–Trumbore) differs from Embree's in
//!   the last bits (`tests/scene/tier_a.rs`).

mod analytic;
mod brute;
#[cfg(test)]
mod curve_tests;
mod embree;
mod triangle;

use crate::error::{Error, Result};
use crate::geometry::curves::CurveBasis;
use crate::geometry::hit::NO_INSTANCE;
use crate::geometry::shapes::{Shape, ShapeKind, CUBE_FACES};
use crate::geometry::{Hit, Instance, Ray};
use std::ops::Range;

/// A hit as one row of 8 words (32 bytes, one aligned vector): `geom`, `prim`, the bits of
/// `t`, `u` and `v`, `inst`, then two zero words; no hit is `geom` = [`HitRow::MISS`] (no shape
/// has that index: Embree's invalid geometry id). The stream renderer keeps its paths' hits so
/// ([`crate::stream`]), and tier A's 8-wide packets write them in lanes, one transpose and one
/// row store per ray ([`Accel::intersect8_with`]), instead of building an `Option<Hit>`
/// (28 bytes, a tag and six fields) per lane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C, align(32))]
pub struct HitRow(pub [u32; 8]);

impl HitRow {
    /// The `geom` word of a row without a hit.
    pub const MISS: u32 = u32::MAX;
    /// No hit.
    pub const NONE: HitRow = HitRow([Self::MISS, 0, 0, 0, 0, 0, 0, 0]);

    /// The row of `hit`.
    #[inline(always)]
    pub fn new(hit: Option<Hit>) -> HitRow {
        match hit {
            Some(h) => HitRow([
                h.geom,
                h.prim,
                h.t.to_bits(),
                h.u.to_bits(),
                h.v.to_bits(),
                h.inst,
                0,
                0,
            ]),
            None => Self::NONE,
        }
    }

    /// The row's hit (`None` for a miss).
    #[inline(always)]
    pub fn get(&self) -> Option<Hit> {
        let w = &self.0;
        (w[0] != Self::MISS).then(|| Hit {
            geom: w[0],
            prim: w[1],
            t: f32::from_bits(w[2]),
            u: f32::from_bits(w[3]),
            v: f32::from_bits(w[4]),
            inst: w[5],
        })
    }

    /// Whether the row holds a hit.
    #[inline(always)]
    pub fn is_hit(&self) -> bool {
        self.0[0] != Self::MISS
    }

    /// The shape's index ([`Hit::geom`]), or [`Self::MISS`].
    #[inline(always)]
    pub fn geom(&self) -> u32 {
        self.0[0]
    }

    /// The instance ([`Hit::inst`]) of a hit.
    #[inline(always)]
    pub fn inst(&self) -> u32 {
        self.0[5]
    }
}

/// Scenes of at most this many analytic primitives (and nothing else) take tier A: the
/// crossover of the replay throughputs measured in `docs/bench/README.md` ("Tier A").
pub const BRUTE_MAX_SHAPES: usize = 16;

/// Scenes of at most this many mesh triangles (and nothing else) take tier A. A scene of both
/// takes it when `analytic / BRUTE_MAX_SHAPES + triangles / BRUTE_MAX_TRIANGLES ≤ 1` (each
/// budget the crossover with Embree of its own kind, so the mixed cost is their sum).
/// Measured on the Cornell box (38 triangles) with a sphere of N more triangles in view
/// (`docs/bench/tier_triangles.py`, `docs/bench/README.md`, "eighteenth session, h4"): tier A
/// costs about 30 instructions per sample more per visible triangle, Embree almost nothing, and
/// they cross near 70 triangles.
pub const BRUTE_MAX_TRIANGLES: usize = 64;

/// The most triangles [`Tier::Brute`] accepts when forced (a bound on the cost of a query).
pub const BRUTE_FORCED_MAX_TRIANGLES: usize = 4096;

/// The number of primitives (analytic shapes and mesh triangles) tier A would trace in
/// `shapes`, or `None` when a shape needs Embree (a cylinder, curves, an SDF grid, a mesh of
/// more than 4096 triangles).
pub fn analytic_primitives(shapes: &[Shape]) -> Option<usize> {
    brute::primitive_counts(shapes).map(|(a, t)| a + t)
}

/// Whether a scene of `analytic` analytic primitives and `triangles` mesh triangles is within
/// tier A's budget ([`BRUTE_MAX_TRIANGLES`]).
pub fn within_brute_budget(analytic: usize, triangles: usize) -> bool {
    analytic * BRUTE_MAX_TRIANGLES + triangles * BRUTE_MAX_SHAPES
        <= BRUTE_MAX_SHAPES * BRUTE_MAX_TRIANGLES
}

/// Which intersection tier a scene uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Tier {
    /// Tier A when the scene qualifies (only spheres, disks, rectangles, boxes and triangle
    /// meshes, within [`within_brute_budget`], no instances), else Embree.
    Auto,
    /// Embree for every scene.
    Embree,
    /// Tier A, whatever the count; an error for a scene it cannot trace.
    Brute,
}

impl Tier {
    /// The environment variable that forces a tier for tests and benches: `auto`, `embree` or
    /// `brute` (unset: `auto`).
    pub const ENV: &'static str = "GROOVE_TIER";

    /// The tier [`Self::ENV`] asks for.
    pub fn from_env() -> Result<Tier> {
        match std::env::var(Self::ENV) {
            Err(std::env::VarError::NotPresent) => Ok(Tier::Auto),
            Ok(v) if v == "auto" => Ok(Tier::Auto),
            Ok(v) if v == "embree" => Ok(Tier::Embree),
            Ok(v) if v == "brute" => Ok(Tier::Brute),
            Ok(v) => Err(Error::Native(format!(
                "{}={v}: expected auto, embree or brute",
                Self::ENV
            ))),
            Err(e) => Err(Error::Native(format!("{}: {e}", Self::ENV))),
        }
    }
}

/// A reusable ray array for [`Accel::intersect_stream`] and [`Accel::occluded_stream`] (one
/// per worker thread: a stream query then allocates nothing once it has grown), and the
/// reused packet of [`Accel::intersect8_with`].
#[derive(Default)]
pub struct RayBuf(embree::RayBuf);

impl RayBuf {
    /// Fills the buffer with `rays` for [`Accel::intersect_filled`] or
    /// [`Accel::occluded_filled`]; returns how many.
    #[inline(always)]
    pub fn fill<'r>(&mut self, rays: impl Iterator<Item = &'r Ray>) -> usize {
        self.0.fill(rays)
    }

    /// The rays [`Self::fill`] put in, in order (as given: before a query changes them).
    pub fn rays(&self) -> impl Iterator<Item = Ray> + '_ {
        self.0.rays()
    }

    /// How many rays the buffer holds.
    #[inline(always)]
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether the buffer holds no ray.
    #[inline(always)]
    pub fn is_empty(&self) -> bool {
        self.0.len() == 0
    }
}

/// The acceleration structure over a scene's shapes. `Send + Sync`: queries run from any thread.
pub struct Accel {
    /// Tier A's tables, when the scene takes tier A (then `scene` is `None`).
    brute: Option<brute::Brute>,
    scene: Option<embree::EmbreeScene>,
    /// Embree id of instance 0 in the top-level scene (the number of shapes).
    inst_base: u32,
    /// Per instance: the shape index of its group's first member.
    first_member: Vec<u32>,
}

impl Accel {
    /// Builds the BVH; shape `i` is reported as `Hit::geom == i`.
    pub fn build(shapes: &[Shape]) -> Result<Accel> {
        Accel::build_instanced(shapes, &[], &[])
    }

    /// [`Self::build_tiered`] with the tier of [`Tier::from_env`].
    pub fn build_instanced(
        shapes: &[Shape],
        groups: &[Range<u32>],
        instances: &[Instance],
    ) -> Result<Accel> {
        Accel::build_tiered(shapes, groups, instances, Tier::from_env()?)
    }

    /// The tier this structure traces with ([`Tier::Embree`] or [`Tier::Brute`]).
    pub fn tier(&self) -> Tier {
        if self.brute.is_some() {
            Tier::Brute
        } else {
            Tier::Embree
        }
    }

    /// Builds the structure of `tier` (see [`Self::build_embree`] for the arguments).
    pub fn build_tiered(
        shapes: &[Shape],
        groups: &[Range<u32>],
        instances: &[Instance],
        tier: Tier,
    ) -> Result<Accel> {
        let flat = groups.is_empty() && instances.is_empty();
        let count = brute::primitive_counts(shapes).filter(|_| flat);
        let brute = match (tier, count) {
            (Tier::Embree, _) => None,
            (Tier::Auto, Some((a, t))) if within_brute_budget(a, t) => brute::Brute::new(shapes),
            (Tier::Auto, _) => None,
            (Tier::Brute, Some((_, t))) if t <= BRUTE_FORCED_MAX_TRIANGLES => {
                brute::Brute::new(shapes)
            }
            (Tier::Brute, _) => {
                return Err(Error::Native(format!(
                    "tier A (brute force) traces only spheres, disks, rectangles, cubes and \
                     at most {BRUTE_FORCED_MAX_TRIANGLES} mesh triangles, without instances: \
                     this scene needs Embree"
                )))
            }
        };
        match brute {
            Some(b) => Ok(Accel {
                brute: Some(b),
                scene: None,
                inst_base: 0,
                first_member: Vec::new(),
            }),
            None => Accel::build_embree(shapes, groups, instances),
        }
    }

    /// Builds the BVH of a scene with shape groups and instances. `groups[g]` is the range of
    /// shape indices that are the members of group `g` (in group space, not traced by
    /// themselves); every other shape is traced as it is. A hit on member `j` of the group of
    /// instance `k` is reported as `Hit::geom == j`, `Hit::inst == k`; other hits have
    /// `Hit::inst == NO_INSTANCE`. Each group's geometry is built once.
    pub fn build_embree(
        shapes: &[Shape],
        groups: &[Range<u32>],
        instances: &[Instance],
    ) -> Result<Accel> {
        Accel::build_embree_with(shapes, groups, instances, false)
    }

    /// [`Self::build_embree`] of a scene without groups, with every top-level rectangle traced
    /// as a filtered slab of triangles whatever the scene holds (by default only where that
    /// pays: scenes of triangle meshes and rectangles). Both give the same hits; this lets the
    /// tests compare the slabs with tier A on scenes of analytic shapes.
    pub fn build_embree_rect_slabs(shapes: &[Shape]) -> Result<Accel> {
        Accel::build_embree_with(shapes, &[], &[], true)
    }

    fn build_embree_with(
        shapes: &[Shape],
        groups: &[Range<u32>],
        instances: &[Instance],
        rect_slabs: bool,
    ) -> Result<Accel> {
        let descs: Vec<embree::GeomDesc> = shapes
            .iter()
            .map(|s| match (&s.kind, s.box_to_world) {
                (ShapeKind::Mesh(m), _) if m.indices.is_empty() => embree::GeomDesc::Empty,
                (ShapeKind::Mesh(_), Some(to_world)) => embree::GeomDesc::Box {
                    to_world,
                    faces: &CUBE_FACES,
                },
                (ShapeKind::Mesh(m), None) => embree::GeomDesc::Triangles {
                    positions: &m.positions,
                    indices: &m.indices,
                },
                (ShapeKind::Sphere { center, radius, .. }, _) => embree::GeomDesc::Sphere {
                    center: *center,
                    radius: *radius,
                },
                // The disk rays meet (see `ShapeKind::Disk`).
                (ShapeKind::Disk { hit_to_world, .. }, _) => embree::GeomDesc::Disk {
                    to_world: *hit_to_world,
                },
                (ShapeKind::Rectangle { to_world }, _) => embree::GeomDesc::Rectangle {
                    to_world: *to_world,
                },
                (ShapeKind::Cylinder(c), _) => embree::GeomDesc::Cylinder(c),
                (ShapeKind::SdfGrid(g), _) => embree::GeomDesc::SdfGrid(g.clone()),
                (ShapeKind::Curves(c), _) => embree::GeomDesc::Curves(embree::CurveDesc {
                    bspline: c.basis == CurveBasis::BSpline,
                    points: &c.points,
                    segments: &c.segments,
                }),
            })
            .collect();
        let mut descs = descs;
        let in_range = |r: &Range<u32>| r.start <= r.end && r.end as usize <= descs.len();
        if !groups.iter().all(in_range)
            || instances.iter().any(|i| i.group() as usize >= groups.len())
        {
            return Err(Error::Native("shape group out of range".into()));
        }
        // The members leave the top level for their group's own scene.
        let group_descs: Vec<Vec<embree::GeomDesc>> = groups
            .iter()
            .map(|r| {
                (r.start as usize..r.end as usize)
                    .map(|i| std::mem::replace(&mut descs[i], embree::GeomDesc::Empty))
                    .collect()
            })
            .collect();
        let inst_descs: Vec<embree::InstanceDesc> = instances
            .iter()
            .map(|i| embree::InstanceDesc {
                group: i.group(),
                to_world: *i.to_world(),
            })
            .collect();
        let scene = embree::EmbreeScene::build_instanced_with(
            &descs,
            &group_descs,
            &inst_descs,
            rect_slabs,
        )
        .map_err(Error::Native)?;
        Ok(Accel {
            brute: None,
            scene: Some(scene),
            inst_base: shapes.len() as u32,
            first_member: instances
                .iter()
                .map(|i| groups[i.group() as usize].start)
                .collect(),
        })
    }

    /// The nearest hit with `t` in `[ray.tmin, ray.tmax]`.
    #[inline]
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        if let Some(b) = &self.brute {
            return b.intersect(ray);
        }
        let hit = self
            .scene
            .as_ref()?
            .intersect(ray.o, ray.d, ray.tmin, ray.tmax)?;
        self.world_hit(hit)
    }

    /// [`Self::intersect`] of up to 8 rays traced as one Embree packet (`out[i]` for
    /// `rays[i]`; `coherent` when the rays start together and point alike, as camera rays of
    /// one pixel do). `groove bench`'s packet ceiling; the stream renderer's trace.
    pub fn intersect8(&self, rays: &[Ray], coherent: bool, out: &mut [Option<Hit>; 8]) {
        if let Some(b) = &self.brute {
            return b.intersect8(rays, out);
        }
        let Some(scene) = &self.scene else {
            *out = [None; 8];
            return;
        };
        scene.intersect8(rays, coherent, out);
        for hit in out.iter_mut() {
            *hit = hit.and_then(|h| self.world_hit(h));
        }
    }

    /// [`Self::intersect8`] of the `n` (at most 8) rays `ray(0)`, … `ray(n − 1)`, each hit handed
    /// to `out(k, row)` in lane order as a [`HitRow`]: no packet of rays or of hits in between
    /// (the stream renderer's 8-wide packets, read from and written to its path columns); under
    /// Embree the one packet is `buf`'s, reused from query to query, tier A loads each ray's
    /// row in place and builds the hits' rows in lanes ([`brute::Brute::intersect8_with`]).
    #[inline(always)]
    pub fn intersect8_with<'r>(
        &self,
        buf: &mut RayBuf,
        n: usize,
        coherent: bool,
        ray: impl Fn(usize) -> &'r Ray,
        mut out: impl FnMut(usize, HitRow),
    ) {
        let n = n.min(8);
        match (&self.brute, &self.scene) {
            (Some(b), _) => b.intersect8_with(n, ray, out),
            (None, Some(s)) => s.intersect8_with(&mut buf.0, n, coherent, ray, |k, row| {
                out(k, self.world_row(row))
            }),
            (None, None) => (0..n).for_each(|k| out(k, HitRow::NONE)),
        }
    }

    /// [`Self::intersect8_with`] of a full packet, `rays[k]`'s hit stored in `rows[k]` (the
    /// stream renderer's camera packets, whose paths are consecutive: `rows` is its own hit
    /// column). Under Embree with AVX2 the rows are stored from the lanes
    /// ([`embree::EmbreeScene::intersect8_rows`]), and only the rows on an instance go
    /// through [`Self::world_row`]; tier A from and to the lanes too
    /// ([`brute::Brute::intersect8_rows`]), Embree without AVX2 as [`Self::intersect8_with`].
    #[inline(always)]
    pub fn intersect8_rows(
        &self,
        buf: &mut RayBuf,
        coherent: bool,
        rays: &[Ray; 8],
        rows: &mut [HitRow; 8],
    ) {
        match (&self.brute, &self.scene) {
            (None, Some(s)) => {
                let mut on_inst = s.intersect8_rows(&mut buf.0, coherent, rays, rows);
                while on_inst != 0 {
                    let k = on_inst.trailing_zeros() as usize;
                    on_inst &= on_inst - 1;
                    rows[k] = self.world_row(rows[k]);
                }
            }
            (Some(b), _) => b.intersect8_rows(rays, rows),
            _ => self.intersect8_with(buf, 8, coherent, |k| &rays[k], |k, row| rows[k] = row),
        }
    }

    /// [`Self::intersect8_with`] of the rays `rays[ids[k]]`, `k < ids.len()` (at most 8), ray
    /// `k`'s hit stored in `hit[ids[k]]` (the stream renderer's packets of active paths, from
    /// and to its path columns). Tier A stores the rows from the lanes
    /// ([`brute::Brute::intersect8_scatter`]); Embree as [`Self::intersect8_with`].
    #[inline(always)]
    pub fn intersect8_scatter(
        &self,
        buf: &mut RayBuf,
        coherent: bool,
        ids: &[u32],
        rays: &[Ray],
        hit: &mut [HitRow],
    ) {
        let ids = &ids[..ids.len().min(8)];
        match &self.brute {
            Some(b) => b.intersect8_scatter(ids, rays, hit),
            None => self.intersect8_with(
                buf,
                ids.len(),
                coherent,
                |k| &rays[ids[k] as usize],
                |k, row| hit[ids[k] as usize] = row,
            ),
        }
    }

    /// [`Self::intersect8`] of up to 16 rays (`out[i]` for `rays[i]`, the others `None`): tier A
    /// traces them as one 16-wide packet on AVX-512 (each lane's hit bit for bit the single
    /// ray's, `tests/scene/tier_a.rs`); Embree, and tier A without AVX-512, as two 8-wide
    /// packets.
    pub fn intersect16(&self, rays: &[Ray], coherent: bool, out: &mut [Option<Hit>; 16]) {
        if let Some(b) = &self.brute {
            return b.intersect16(rays, out);
        }
        let rays = &rays[..rays.len().min(16)];
        let (lo, hi) = rays.split_at(rays.len().min(8));
        let mut half = [None; 8];
        self.intersect8(lo, coherent, &mut half);
        out[..8].copy_from_slice(&half);
        self.intersect8(hi, coherent, &mut half);
        out[8..].copy_from_slice(&half);
    }

    /// [`Self::intersect16`] of the `n` (at most 16) rays `ray(0)`, … `ray(n − 1)`, each hit
    /// handed to `out(k, row)` in lane order as a [`HitRow`], as [`Self::intersect8_with`]: tier
    /// A reads the rays in place and builds the rows in lanes, one 16-wide packet on AVX-512
    /// (`Brute::intersect16_with`); Embree traces two 8-wide packets.
    #[inline(always)]
    pub fn intersect16_with<'r>(
        &self,
        buf: &mut RayBuf,
        n: usize,
        coherent: bool,
        ray: impl Fn(usize) -> &'r Ray,
        mut out: impl FnMut(usize, HitRow),
    ) {
        let n = n.min(16);
        if let Some(b) = &self.brute {
            return b.intersect16_with(n, ray, out);
        }
        let lo = n.min(8);
        self.intersect8_with(buf, lo, coherent, &ray, &mut out);
        self.intersect8_with(buf, n - lo, coherent, |k| ray(8 + k), |k, h| out(8 + k, h));
    }

    /// [`Self::occluded8`] of up to 16 rays: bit `i` for `rays[i]` (one 16-wide packet under
    /// tier A on AVX-512, else two 8-wide packets).
    pub fn occluded16(&self, rays: &[Ray]) -> u16 {
        if let Some(b) = &self.brute {
            return b.occluded16(rays);
        }
        let rays = &rays[..rays.len().min(16)];
        let (lo, hi) = rays.split_at(rays.len().min(8));
        u16::from(self.occluded8(lo)) | u16::from(self.occluded8(hi)) << 8
    }

    /// Whether [`Self::intersect16`] and [`Self::occluded16`] trace 16 rays as one packet (tier
    /// A on a CPU with AVX-512); elsewhere they cost what two 8-wide packets cost.
    pub fn packets16(&self) -> bool {
        self.brute.as_ref().is_some_and(brute::Brute::sixteen_wide)
    }

    /// [`Self::intersect`] of many rays traced as one Embree stream (`rtcIntersect1M` through
    /// the reusable `buf`): `out(k, row)` for the `k`-th ray, in order, its hit as a
    /// [`HitRow`] (as [`Self::intersect8_with`] hands them). `coherent` as for
    /// [`Self::intersect8`]. Tier A traces them as 8-wide packets. Each ray gets the hit a
    /// single ray gets (`tests/scene/packets.rs`).
    pub fn intersect_stream<'r>(
        &self,
        rays: impl Iterator<Item = &'r Ray>,
        coherent: bool,
        buf: &mut RayBuf,
        out: impl FnMut(usize, HitRow),
    ) {
        buf.fill(rays);
        self.intersect_filled(coherent, buf, out);
    }

    /// [`Self::intersect_stream`] of the rays [`RayBuf::fill`] put in `buf`.
    pub fn intersect_filled(
        &self,
        coherent: bool,
        buf: &mut RayBuf,
        mut out: impl FnMut(usize, HitRow),
    ) {
        match (&self.brute, &self.scene) {
            (None, Some(s)) => {
                s.intersect_filled(coherent, &mut buf.0, |k, row| out(k, self.world_row(row)))
            }
            (Some(b), _) => brute_intersect(b, buf.0.rays(), |k, h| out(k, HitRow::new(h))),
            (None, None) => (0..buf.0.len()).for_each(|k| out(k, HitRow::NONE)),
        }
    }

    /// [`Self::intersect_filled`] with each ray's row stored in place: the `k`-th ray's in
    /// `rows[ids[k]]` (`ids` at least as long as the stream: the stream renderer's active
    /// paths and hit column). Under Embree with AVX2 each hit's row is built and stored in
    /// lanes ([`embree::EmbreeScene::intersect_filled_into`]), and only the rows on an
    /// instance go through [`Self::world_row`].
    pub fn intersect_filled_into(
        &self,
        coherent: bool,
        buf: &mut RayBuf,
        ids: &[u32],
        rows: &mut [HitRow],
    ) {
        match (&self.brute, &self.scene) {
            (None, Some(s)) => {
                s.intersect_filled_into(coherent, &mut buf.0, ids, rows, |r| self.world_row(r))
            }
            _ => self.intersect_filled(coherent, buf, |k, row| rows[ids[k] as usize] = row),
        }
    }

    /// [`Self::occluded_stream`] of the rays [`RayBuf::fill`] put in `buf`.
    pub fn occluded_filled(
        &self,
        coherent: bool,
        buf: &mut RayBuf,
        mut out: impl FnMut(usize, bool),
    ) {
        match (&self.brute, &self.scene) {
            (None, Some(s)) => s.occluded_filled(coherent, &mut buf.0, out),
            (Some(b), _) => brute_occluded(b, buf.0.rays(), out),
            (None, None) => (0..buf.0.len()).for_each(|k| out(k, false)),
        }
    }

    /// [`Self::occluded`] of many rays traced as one Embree stream (`rtcOccluded1M` through
    /// `buf`): `out(k, blocked)` for the `k`-th ray, in order.
    pub fn occluded_stream<'r>(
        &self,
        rays: impl Iterator<Item = &'r Ray>,
        coherent: bool,
        buf: &mut RayBuf,
        out: impl FnMut(usize, bool),
    ) {
        buf.fill(rays);
        self.occluded_filled(coherent, buf, out);
    }

    /// An Embree hit's row with its instance mapped as [`Self::world_hit`] maps the hit (a
    /// miss, and a hit on a top-level shape, as they are: one test of the row's words).
    #[inline(always)]
    fn world_row(&self, row: HitRow) -> HitRow {
        if row.inst() == NO_INSTANCE || !row.is_hit() {
            row
        } else {
            HitRow::new(row.get().and_then(|h| self.world_hit(h)))
        }
    }

    /// An Embree hit with its instance id and the group's geometry id turned into scene
    /// indices (`None` for an instance id out of range).
    #[inline]
    fn world_hit(&self, mut h: Hit) -> Option<Hit> {
        if h.inst != NO_INSTANCE {
            let k = h.inst.wrapping_sub(self.inst_base);
            h.geom += *self.first_member.get(k as usize)?;
            h.inst = k;
        }
        Some(h)
    }

    /// [`Self::occluded`] of up to 8 rays traced as one Embree packet: bit `i` for `rays[i]`.
    pub fn occluded8(&self, rays: &[Ray]) -> u8 {
        if let Some(b) = &self.brute {
            return b.occluded8(rays);
        }
        self.scene.as_ref().map_or(0, |s| s.occluded8(rays))
    }

    /// Whether any surface lies on the ray within `[ray.tmin, ray.tmax]`.
    #[inline]
    pub fn occluded(&self, ray: &Ray) -> bool {
        if let Some(b) = &self.brute {
            return b.occluded(ray);
        }
        self.scene
            .as_ref()
            .is_some_and(|s| s.occluded(ray.o, ray.d, ray.tmin, ray.tmax))
    }
}

/// Tier A's streams: `rays` as 8-wide packets, `out(k, hit)` for the `k`-th ray, in order.
fn brute_intersect(
    b: &brute::Brute,
    rays: impl Iterator<Item = Ray>,
    mut out: impl FnMut(usize, Option<Hit>),
) {
    let mut k = 0;
    for_each_8(rays, |p| {
        let mut hits = [None; 8];
        b.intersect8(p, &mut hits);
        for h in &hits[..p.len()] {
            out(k, *h);
            k += 1;
        }
    })
}

/// [`brute_intersect`] for occlusion: `out(k, blocked)`.
fn brute_occluded(
    b: &brute::Brute,
    rays: impl Iterator<Item = Ray>,
    mut out: impl FnMut(usize, bool),
) {
    let mut k = 0;
    for_each_8(rays, |p| {
        let blocked = b.occluded8(p);
        for i in 0..p.len() {
            out(k, blocked >> i & 1 == 1);
            k += 1;
        }
    })
}

/// Calls `f` with `rays` cut into consecutive packets of 8 (the last one shorter).
fn for_each_8(rays: impl Iterator<Item = Ray>, mut f: impl FnMut(&[Ray])) {
    let mut p = [Ray::new(glam::Vec3::ZERO, glam::Vec3::Z); 8];
    let mut n = 0;
    for r in rays {
        p[n] = r;
        n += 1;
        if n == 8 {
            f(&p);
            n = 0;
        }
    }
    if n > 0 {
        f(&p[..n]);
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

    /// The exact box reports what Embree's triangles report for the same cube mesh: the same
    /// triangle (away from the diagonal, where either is right), ray parameter and barycentric
    /// point, for rays from outside and from inside, under a rotated, sheared, non-uniformly
    /// scaled and mirrored transform.
    #[test]
    fn exact_box_matches_the_cube_mesh() {
        use crate::math::rng::Pcg32;
        use glam::{Mat4, Quat, Vec3};
        let to_world = Mat4::from_translation(Vec3::new(1.3, 0.75, -2.0))
            * Mat4::from_quat(Quat::from_euler(glam::EulerRot::XYZ, 0.4, 0.7, -0.2))
            * Mat4::from_cols_array(&[
                0.75, 0.0, 0.0, 0.0, 0.2, 1.5, 0.0, 0.0, 0.0, 0.0, -0.5, 0.0, 0.0, 0.0, 0.0, 1.0,
            ]);
        let cube = Shape::cube(&to_world, false);
        let ShapeKind::Mesh(mesh) = &cube.kind else {
            panic!("the cube is a mesh")
        };
        assert_eq!(cube.box_to_world, Some(to_world));
        let tris = embree::EmbreeScene::build(&[embree::GeomDesc::Triangles {
            positions: &mesh.positions,
            indices: &mesh.indices,
        }])
        .unwrap();
        let exact = embree::EmbreeScene::build(&[embree::GeomDesc::Box {
            to_world,
            faces: &CUBE_FACES,
        }])
        .unwrap();
        let point = |h: &Hit| {
            let [p0, p1, p2] = mesh.indices[h.prim as usize].map(|i| mesh.positions[i as usize]);
            p0 * (1.0 - h.u - h.v) + p1 * h.u + p2 * h.v
        };
        let mut rng = Pcg32::new(11, 5);
        let mut unit = || 2.0 * rng.next_f32() - 1.0;
        let (mut hits, mut same_prim) = (0, 0);
        for k in 0..20_000 {
            // Half the rays start inside the box, half on a sphere of radius 4 around it.
            let inside = k % 2 == 0;
            let l = Vec3::new(unit(), unit(), unit()) * if inside { 0.99 } else { 4.0 };
            let o = to_world.transform_point3(l);
            let target = to_world.transform_point3(Vec3::new(unit(), unit(), unit()) * 1.2);
            let d = (target - o).normalize();
            let (a, b) = (
                tris.intersect(o, d, 0.0, f32::INFINITY),
                exact.intersect(o, d, 0.0, f32::INFINITY),
            );
            assert_eq!(tris.occluded(o, d, 0.0, f32::INFINITY), a.is_some());
            assert_eq!(exact.occluded(o, d, 0.0, f32::INFINITY), b.is_some());
            let (a, b) = match (a, b) {
                (None, None) => continue,
                (Some(a), Some(b)) => (a, b),
                // A ray grazing an edge may slip past one of the two.
                (a, b) => {
                    let h = a.or(b).unwrap();
                    let pl = to_world.inverse().transform_point3(point(&h));
                    let edge = pl.abs().to_array().iter().filter(|c| **c > 0.999).count() >= 2;
                    assert!(edge, "ray {k}: one hit only, at {pl} (not an edge)");
                    continue;
                }
            };
            hits += 1;
            assert!(
                (a.t - b.t).abs() <= 1e-5 * a.t.max(1.0),
                "ray {k}: t {} vs {}",
                a.t,
                b.t
            );
            let (pa, pb) = (point(&a), point(&b));
            assert!(
                (pa - pb).length() <= 2e-5 * pa.length().max(1.0),
                "ray {k}: {pa} vs {pb}"
            );
            assert_eq!(a.prim / 2, b.prim / 2, "ray {k}: another face");
            same_prim += usize::from(a.prim == b.prim);
        }
        assert!(hits > 12_000, "{hits} hits");
        assert!(
            same_prim + 20 >= hits,
            "{same_prim} of {hits} on the same triangle"
        );
    }
}
