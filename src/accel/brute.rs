//! Tier A: the few primitives of a scene intersected by brute force, 8 lanes at a time (issue
//! 16 item 3; mesh triangles since issue 18), instead of an Embree BVH (with per-ray callbacks
//! for the analytic shapes).
//!
//! Primitives (spheres, disks and rectangles, exact boxes, mesh triangles) sit in
//! structure-of-arrays tables of 8 per chunk, padded with NaN parameters (which fail every
//! interval test; a triangle lane's mesh box is empty). Two forms, both over the kernels of
//! [`super::analytic`] and
//! [`super::triangle`]:
//! - one ray × 8 primitives ([`Brute::intersect`], [`Brute::occluded`]): the scalar renderer's
//!   rays, each chunk one 8-wide test;
//! - 8 rays × every primitive ([`Brute::intersect8`], [`Brute::occluded8`]): a packet (the rays
//!   turned into lanes by one 8×8 transpose), each primitive splat across the lanes from a
//!   second copy of the tables, one primitive per row (rectangles and disks apart); a primitive
//!   no lane can hit stops after its first half (the sphere's discriminant, the plane's t, the
//!   triangle's edge tests);
//! - 16 rays × every primitive on AVX-512 ([`Brute::intersect16`], [`Brute::occluded16`]): the
//!   same generic packet functions at width 16, so every lane gets the same bits.
//!
//! Without AVX2 both run at width 1 over every primitive. Every form reports the same [`Hit`]:
//! the smallest t in the open interval (tmin, tmax) (Embree shrinks tfar after each accepted
//! hit and the callbacks test the open interval, so Embree's answer is that minimum too), ties on
//! equal t broken by the lower key (shape index, then triangle index), and the primitive and
//! barycentrics (the box's triangle as the callbacks report it; the mesh triangle's u and v;
//! zero for the others), computed at width 1 for the winner only.

use super::analytic::{
    cube, in_disk, in_square, planar, plane_cross, sphere, sphere_disc, sphere_roots, Affine,
    BoxHit, RayL,
};
use super::triangle::{
    in_bounds, in_bounds_until, slab, tri_data, tri_edges, tri_plane, triangle, TriL, TriPlane,
};
use super::HitRow;
use crate::geometry::hit::NO_INSTANCE;
use crate::geometry::shapes::{Shape, ShapeKind, CUBE_FACES};
use crate::geometry::{Hit, Ray};
use crate::lane::{vec::V3, Lane, LaneI32, LaneMask};
#[cfg(target_arch = "x86_64")]
use crate::lane::{Avx2, Avx512, F32x16, F32x8};
use glam::{Mat4, Vec3};

/// Lanes per chunk.
const W: usize = 8;
/// Rays per wide packet ([`Brute::intersect16`], AVX-512).
pub(crate) const W16: usize = 16;
/// The key of an empty lane (never hit: its parameters are NaN).
const NONE: i32 = i32::MAX;
/// A primitive's key is `shape index << PRIM_BITS | triangle index` (0 for the analytic
/// shapes): one integer whose order is that of (shape, triangle), for the tie rule.
const PRIM_BITS: u32 = 12;
/// [`PRIM_BITS`] as a shift count of the lanes.
const PRIM_BITS_I: i32 = PRIM_BITS as i32;
/// Meshes of more triangles than this, and scenes of more shapes than [`MAX_KEYED_SHAPES`],
/// do not fit a key (and are far past any budget).
pub(crate) const MAX_MESH_TRIANGLES: usize = 1 << PRIM_BITS;
const MAX_KEYED_SHAPES: usize = 1 << (31 - PRIM_BITS);

/// The key of triangle `prim` of shape `geom`.
fn key(geom: usize, prim: usize) -> i32 {
    ((geom << PRIM_BITS) | prim) as i32
}

/// 8 spheres: centre components, radius, key.
#[derive(Clone, Copy)]
struct Spheres {
    c: [[f32; W]; 3],
    r: [f32; W],
    geom: [i32; W],
}

/// 8 affinely mapped unit shapes (disks and rectangles, or boxes): the 12 entries of the
/// world-to-object map by column, 1 for a square (rectangle), and the key.
#[derive(Clone, Copy)]
struct Mapped {
    m: [[f32; W]; 12],
    square: [f32; W],
    geom: [i32; W],
}

/// One sphere for the packet form (8 rays × one primitive): centre, radius, key.
#[derive(Clone, Copy)]
struct SphereRow {
    c: [f32; 3],
    r: f32,
    geom: i32,
}

/// One affinely mapped unit shape for the packet form: the 12 entries of its world-to-object
/// map by column, and the key.
#[derive(Clone, Copy)]
struct MappedRow {
    m: [f32; 12],
    geom: i32,
}

/// 8 triangles: the 12 numbers of each ([`tri_data`]: corner, two edges, normal) by component,
/// the padded bounding box of each one's mesh, and the key.
#[derive(Clone, Copy)]
struct Tris {
    v: [[f32; W]; 12],
    lo: [[f32; W]; 3],
    hi: [[f32; W]; 3],
    geom: [i32; W],
}

/// A mesh for the packet form: its padded bounding box ([`mesh_bounds`]) and its rows of
/// [`Brute::tri_rows`]. A ray outside the box hits none of its triangles, in every form.
#[derive(Clone)]
struct MeshBox {
    lo: [f32; 3],
    hi: [f32; 3],
    rows: std::ops::Range<usize>,
}

/// One triangle for the packet form: its 12 numbers and its key.
#[derive(Clone, Copy)]
struct TriRow {
    v: [f32; 12],
    geom: i32,
}

/// Which table holds shape `i`, and at which row.
#[derive(Clone, Copy, Debug)]
enum Slot {
    /// A sphere, disk or rectangle (nothing to add to the hit), or an empty mesh (never hit).
    Plain,
    /// A box at this row of the box table.
    Box(u32),
    /// A triangle mesh (its hits carry their barycentrics from the test).
    Mesh,
}

/// A box face as `BoxData` in `embree.rs` keeps it: a corner, its two edges each divided by
/// its squared length, and the face's index in [`CUBE_FACES`].
#[derive(Clone, Copy)]
struct Face {
    corner: Vec3,
    edge1: Vec3,
    edge3: Vec3,
    index: u32,
}

/// The tier-A tables of one scene.
pub(crate) struct Brute {
    /// Chunks of 8 primitives, for one ray at a time.
    spheres: Vec<Spheres>,
    planes: Vec<Mapped>,
    boxes: Vec<Mapped>,
    tris: Vec<Tris>,
    /// Live rows per chunk table (the last chunk may be partly empty).
    rows: [usize; 4],
    /// The same primitives one per row, for packets and width 1 (each splat across the
    /// lanes); rectangles and disks apart, so that neither pays for the other's inside test
    /// (the order of the tests cannot change a strict lexicographic minimum, [`keep`]).
    sphere_rows: Vec<SphereRow>,
    square_rows: Vec<MappedRow>,
    disk_rows: Vec<MappedRow>,
    /// Row `k` is the box at [`Slot::Box`]`(k)`.
    box_rows: Vec<MappedRow>,
    /// Every mesh's triangles in shape order, each mesh's in its own order.
    tri_rows: Vec<TriRow>,
    /// The meshes by their boxes' largest extent, smallest first (stable: shape order on
    /// ties).
    meshes: Vec<MeshBox>,
    slots: Vec<Slot>,
    /// Box faces indexed by `2·axis + (side > 0)`.
    faces: [Face; 6],
    #[cfg(target_arch = "x86_64")]
    avx: Option<Avx2>,
    /// For the 16-ray packets.
    #[cfg(target_arch = "x86_64")]
    avx512: Option<Avx512>,
}

/// What tier A traces of `shape`: `Some((analytic primitives, triangles))`, or `None` for a
/// shape it cannot trace (a cylinder, curves, an SDF grid, a mesh of more than
/// [`MAX_MESH_TRIANGLES`] or with a vertex index out of range).
fn slot_kind(shape: &Shape) -> Option<(usize, usize)> {
    match (&shape.kind, shape.box_to_world) {
        (ShapeKind::Mesh(m), _) if m.indices.is_empty() => Some((0, 0)),
        (ShapeKind::Mesh(_), Some(_)) => Some((1, 0)),
        (ShapeKind::Mesh(m), None) => {
            let n = m.positions.len();
            let valid = m.indices.iter().flatten().all(|&i| (i as usize) < n);
            (valid && m.indices.len() <= MAX_MESH_TRIANGLES).then_some((0, m.indices.len()))
        }
        (ShapeKind::Sphere { .. }, _) => Some((1, 0)),
        (ShapeKind::Disk { .. } | ShapeKind::Rectangle { .. }, _) => Some((1, 0)),
        _ => None,
    }
}

/// The numbers of analytic primitives (spheres, disks, rectangles, boxes) and of mesh
/// triangles tier A would trace, or `None` when a shape needs Embree (a cylinder, curves, an
/// SDF grid, a large mesh) or the scene has too many shapes for a key.
pub(crate) fn primitive_counts(shapes: &[Shape]) -> Option<(usize, usize)> {
    if shapes.len() >= MAX_KEYED_SHAPES {
        return None;
    }
    shapes.iter().try_fold((0, 0), |(a, t), s| {
        slot_kind(s).map(|(da, dt)| (a + da, t + dt))
    })
}

fn push_row<T: Copy>(table: &mut Vec<T>, rows: &mut usize, empty: T) -> (usize, usize) {
    if (*rows).is_multiple_of(W) {
        table.push(empty);
    }
    *rows += 1;
    ((*rows - 1) / W, (*rows - 1) % W)
}

impl Brute {
    /// The tables of `shapes` (shape `i` reported as `Hit::geom == i`), or `None` when a shape
    /// is of a kind tier A does not trace.
    pub(crate) fn new(shapes: &[Shape]) -> Option<Brute> {
        primitive_counts(shapes)?;
        let nan = [f32::NAN; W];
        let empty_sphere = Spheres {
            c: [nan; 3],
            r: nan,
            geom: [NONE; W],
        };
        let empty_mapped = Mapped {
            m: [nan; 12],
            square: [0.0; W],
            geom: [NONE; W],
        };
        // An empty lane's box is empty (lo = +∞, hi = −∞): every ray enters it at +∞ and leaves
        // at −∞, so it is culled whatever the ray (a NaN box would be kept, `in_bounds`).
        let empty_tris = Tris {
            v: [nan; 12],
            lo: [[f32::INFINITY; W]; 3],
            hi: [[f32::NEG_INFINITY; W]; 3],
            geom: [NONE; W],
        };
        let mut b = Brute {
            spheres: Vec::new(),
            planes: Vec::new(),
            boxes: Vec::new(),
            tris: Vec::new(),
            rows: [0; 4],
            sphere_rows: Vec::new(),
            square_rows: Vec::new(),
            disk_rows: Vec::new(),
            box_rows: Vec::new(),
            tri_rows: Vec::new(),
            meshes: Vec::new(),
            slots: Vec::with_capacity(shapes.len()),
            faces: box_faces(),
            #[cfg(target_arch = "x86_64")]
            avx: Avx2::detect(),
            #[cfg(target_arch = "x86_64")]
            avx512: Avx512::detect(),
        };
        let mapped = |t: &mut Mapped, l: usize, to_world: &Mat4, square: bool, geom: usize| {
            let m = to_object(to_world);
            for (k, x) in m.into_iter().enumerate() {
                t.m[k][l] = x;
            }
            t.square[l] = if square { 1.0 } else { 0.0 };
            t.geom[l] = key(geom, 0);
            MappedRow {
                m,
                geom: key(geom, 0),
            }
        };
        for (i, s) in shapes.iter().enumerate() {
            let slot = match (&s.kind, s.box_to_world) {
                (ShapeKind::Mesh(m), _) if m.indices.is_empty() => Slot::Plain,
                (ShapeKind::Mesh(_), Some(to_world)) => {
                    let (c, l) = push_row(&mut b.boxes, &mut b.rows[2], empty_mapped);
                    let row = mapped(&mut b.boxes[c], l, &to_world, false, i);
                    b.box_rows.push(row);
                    Slot::Box((c * W + l) as u32)
                }
                (ShapeKind::Mesh(m), None) => {
                    let first = b.tri_rows.len();
                    let (lo, hi) = mesh_bounds(m);
                    for (k, idx) in m.indices.iter().enumerate() {
                        let [p0, p1, p2] = idx.map(|i| m.positions[i as usize]);
                        let v = tri_data(p0, p1, p2);
                        let (c, l) = push_row(&mut b.tris, &mut b.rows[3], empty_tris);
                        let t = &mut b.tris[c];
                        for (j, x) in v.into_iter().enumerate() {
                            t.v[j][l] = x;
                        }
                        for j in 0..3 {
                            (t.lo[j][l], t.hi[j][l]) = (lo[j], hi[j]);
                        }
                        t.geom[l] = key(i, k);
                        b.tri_rows.push(TriRow { v, geom: key(i, k) });
                    }
                    b.meshes.push(MeshBox {
                        lo: lo.to_array(),
                        hi: hi.to_array(),
                        rows: first..b.tri_rows.len(),
                    });
                    Slot::Mesh
                }
                (ShapeKind::Sphere { center, radius, .. }, _) => {
                    let (c, l) = push_row(&mut b.spheres, &mut b.rows[0], empty_sphere);
                    let t = &mut b.spheres[c];
                    (t.c[0][l], t.c[1][l], t.c[2][l]) = (center.x, center.y, center.z);
                    t.r[l] = *radius;
                    t.geom[l] = key(i, 0);
                    b.sphere_rows.push(SphereRow {
                        c: center.to_array(),
                        r: *radius,
                        geom: key(i, 0),
                    });
                    Slot::Plain
                }
                (ShapeKind::Disk { hit_to_world, .. }, _) => {
                    let (c, l) = push_row(&mut b.planes, &mut b.rows[1], empty_mapped);
                    let row = mapped(&mut b.planes[c], l, hit_to_world, false, i);
                    b.disk_rows.push(row);
                    Slot::Plain
                }
                (ShapeKind::Rectangle { to_world }, _) => {
                    let (c, l) = push_row(&mut b.planes, &mut b.rows[1], empty_mapped);
                    let row = mapped(&mut b.planes[c], l, to_world, true, i);
                    b.square_rows.push(row);
                    Slot::Plain
                }
                _ => return None,
            };
            b.slots.push(slot);
        }
        // The packets test the meshes of smallest extent first: in a closed room (the Cornell
        // boxes) the walls are the largest and lie behind everything else, so a ray that hits
        // an object first has its t before it reaches them, and their rows stop at the plane
        // half. The order cannot change a hit: the nearest is a strict minimum of (t, key),
        // and the cull keeps every crossing at or before it.
        b.meshes.sort_by(|p, q| extent(p).total_cmp(&extent(q)));
        Some(b)
    }

    /// The nearest hit of `ray` in (tmin, tmax): one ray against 8 primitives at a time.
    #[inline]
    pub(crate) fn intersect(&self, ray: &Ray) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            let (t, geom, u, v) = avx.run(
                #[inline(always)]
                || self.nearest_across(avx, ray),
            );
            return self.finish(ray, t, geom, u, v);
        }
        let b = self.nearest_of_each(&ray_lanes(ray), 0.0f32, NONE);
        self.finish(ray, b.t, b.g, b.u / b.a, b.v / b.a)
    }

    /// Whether anything lies on `ray` in (tmin, tmax).
    #[inline]
    pub(crate) fn occluded(&self, ray: &Ray) -> bool {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            return avx.run(
                #[inline(always)]
                || self.any_across(avx, ray),
            );
        }
        self.any_of_each(&ray_lanes(ray), false)
    }

    /// [`Self::intersect`] of up to 8 rays as one packet: `out[i]` for `rays[i]`, the others
    /// `None`.
    pub(crate) fn intersect8(&self, rays: &[Ray], out: &mut [Option<Hit>; 8]) {
        let rays = &rays[..rays.len().min(W)];
        *out = [None; W];
        self.intersect8_with(rays.len(), |k| &rays[k], |k, h| out[k] = h.get());
    }

    /// [`Self::intersect8`] of the `n` (at most 8) rays `ray(0)`, … `ray(n − 1)`, each read
    /// where it lies (one row load, [`Avx2::ray_row`], not a packet of rays copied first),
    /// each hit handed to `out(k, row)` in lane order as a [`HitRow`] (not a packet of hits):
    /// the stream renderer's trace, from and to its path columns. The same hits as
    /// [`Self::intersect8`]. With AVX2 the rows are built in lanes ([`Self::hit_fields`], one
    /// 8×8 transpose).
    #[inline(always)]
    pub(crate) fn intersect8_with<'r>(
        &self,
        n: usize,
        ray: impl Fn(usize) -> &'r Ray,
        mut out: impl FnMut(usize, HitRow),
    ) {
        let n = n.min(W);
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            let mut rows = avx.run(
                #[inline(always)]
                || {
                    let b = self.nearest_of_each(&packet_with(avx, n, &ray), avx.splat(0.0), NONE);
                    avx.rows8(self.hit_fields(&b)).map(hit_row)
                },
            );
            self.hand_rows(&mut rows, n, &ray, &mut out);
            return;
        }
        for k in 0..n {
            let r = ray(k);
            let b = self.nearest_of_each(&ray_lanes(r), 0.0f32, NONE);
            out(
                k,
                HitRow::new(self.finish(r, b.t, b.g, b.u / b.a, b.v / b.a)),
            );
        }
    }

    /// [`Self::intersect8_with`] of the rays `rays[ids[k]]`, `k < ids.len()` (at most 8), each
    /// hit's row stored from the lanes straight into `hit[ids[k]]` (one 32-byte store a row):
    /// the stream renderer's packets, whose rays and hits are their paths' entries of the ray
    /// and hit columns. Handing the rows out of the AVX2 region instead cost a 256-byte copy a
    /// packet and, a lane, the closure's reload and four-part store (metal_plastic's bounce
    /// packets: 13.5 instructions a ray). A full packet reads and stores through
    /// [`Avx2::ray_rows_through`], which checks the 8 ids against both columns at once; a
    /// partial one reads its rays one by one ([`packet_with`]). Where the scene has boxes,
    /// through [`Self::intersect8_with`] (a box's row is completed outside the lanes,
    /// [`Self::box_row`]). The same rows.
    #[inline(always)]
    pub(crate) fn intersect8_scatter(&self, ids: &[u32], rays: &[Ray], hit: &mut [HitRow]) {
        let ids = &ids[..ids.len().min(W)];
        let ray = |k: usize| &rays[ids[k] as usize];
        #[cfg(target_arch = "x86_64")]
        if let (Some(avx), true) = (self.avx, self.box_rows.is_empty()) {
            if let Ok(all) = <&[u32; W]>::try_from(ids) {
                avx.run(
                    #[inline(always)]
                    || {
                        avx.ray_rows_through(
                            rays,
                            all,
                            hit,
                            #[inline(always)]
                            |f| self.trace_fields(avx, f),
                        );
                    },
                );
                return;
            }
            avx.run(
                #[inline(always)]
                || {
                    let b = self.nearest_of_each(
                        &packet_with(avx, ids.len(), &ray),
                        avx.splat(0.0),
                        NONE,
                    );
                    let rows = F32x8::transpose8(self.hit_fields(&b));
                    for (row, &i) in rows.iter().zip(ids) {
                        row.store_bits(&mut hit[i as usize].0);
                    }
                },
            );
            return;
        }
        self.intersect8_with(ids.len(), ray, |k, row| hit[ids[k] as usize] = row);
    }

    /// [`Self::intersect8_scatter`] of 8 consecutive rays into 8 consecutive rows (the stream
    /// renderer's camera packets, whose paths are consecutive): without boxes the rows are read
    /// and stored at fixed places, with no bounds check and no id; with boxes through
    /// [`Self::intersect8_with`]. A form of its own, so that the bounce packets' code (ids
    /// checked against the columns, [`Avx2::ray_rows_through`]) is not also the camera's: as
    /// one instantiation the camera packets paid for the checks (glass, with its boxes: +19
    /// instructions a sample). The same rows.
    #[inline(always)]
    pub(crate) fn intersect8_rows(&self, rays: &[Ray; W], rows: &mut [HitRow; W]) {
        #[cfg(target_arch = "x86_64")]
        if let (Some(avx), true) = (self.avx, self.box_rows.is_empty()) {
            avx.run(
                #[inline(always)]
                || {
                    let f = F32x8::transpose8(std::array::from_fn(
                        #[inline(always)]
                        |k| avx.ray_row(&rays[k]),
                    ));
                    let out = F32x8::transpose8(self.trace_fields(avx, f));
                    for (o, row) in out.iter().zip(rows) {
                        o.store_bits(&mut row.0);
                    }
                },
            );
            return;
        }
        self.intersect8_with(W, |k| &rays[k], |k, row| rows[k] = row);
    }

    /// The nearest hits of a packet whose rays are in lanes as 8 fields (o.x, o.y, o.z, d.x,
    /// d.y, d.z, tmin, tmax) as the 8 fields of their rows ([`Self::hit_fields`]).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn trace_fields(&self, avx: Avx2, f: [F32x8; 8]) -> [F32x8; 8] {
        let b = self.nearest_of_each(&fields_ray(f), avx.splat(0.0), NONE);
        self.hit_fields(&b)
    }

    /// Hands the first `n` of a packet's rows to `out` in lane order, each box hit's triangle
    /// and barycentrics added first ([`Self::box_row`], only where the scene has boxes): the
    /// end of the in-place packets of both widths.
    #[inline(always)]
    fn hand_rows<'r>(
        &self,
        rows: &mut [HitRow],
        n: usize,
        ray: impl Fn(usize) -> &'r Ray,
        mut out: impl FnMut(usize, HitRow),
    ) {
        if !self.box_rows.is_empty() {
            for (k, row) in rows.iter_mut().enumerate().take(n) {
                self.box_row(row, || ray(k));
            }
        }
        for (k, row) in rows.iter().enumerate().take(n) {
            out(k, *row);
        }
    }

    /// The lanes' hits of `b` as the 8 words of their rows ([`HitRow`]), all in lanes:
    /// [`Self::finish`] but for a box's triangle and barycentrics ([`Self::box_row`] adds
    /// them). The key splits into `geom` (its high bits; [`HitRow::MISS`] for [`NONE`]) and
    /// `prim` (its low bits); `t` as kept; `u`, `v` the lanes' quotients, which are the winning
    /// triangle's barycentrics on a mesh lane and +0 on every other (`Best::new`'s 0 / 1: the
    /// meshes are tested last, so no other primitive can win after a triangle set them);
    /// `inst` [`NO_INSTANCE`]; two zero words. The same words `finish` puts in a [`Hit`].
    #[inline(always)]
    fn hit_fields<L: Lane>(&self, b: &Best<L>) -> [L; 8] {
        let g = b.g;
        let miss = g.eq(g.splat(NONE));
        let geom = LaneI32::select(miss, g.splat(HitRow::MISS as i32), g.shr::<PRIM_BITS_I>());
        let prim = g.and(g.splat((1 << PRIM_BITS) - 1));
        let zero = b.t.splat(0.0);
        let (u, v) = if self.tri_rows.is_empty() {
            (zero, zero)
        } else {
            (b.u / b.a, b.v / b.a)
        };
        let inst = g.splat(NO_INSTANCE as i32);
        [
            L::from_bits(geom),
            L::from_bits(prim),
            b.t,
            u,
            v,
            L::from_bits(inst),
            zero,
            zero,
        ]
    }

    /// A row of [`Self::hit_fields`] completed where its shape is a box: the triangle and
    /// barycentrics [`Self::finish`] gives it (the ray read through `ray` only then).
    #[inline(always)]
    fn box_row<'r>(&self, row: &mut HitRow, ray: impl FnOnce() -> &'r Ray) {
        let geom = row.0[0];
        if geom == HitRow::MISS {
            return;
        }
        if let Some(&Slot::Box(b)) = self.slots.get(geom as usize) {
            let (prim, u, v) = self.box_hit(ray(), b as usize);
            (row.0[1], row.0[3], row.0[4]) = (prim, u.to_bits(), v.to_bits());
        }
    }

    /// [`Self::occluded`] of up to 8 rays as one packet: bit `i` for `rays[i]`.
    pub(crate) fn occluded8(&self, rays: &[Ray]) -> u8 {
        let n = rays.len().min(W);
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            return avx.run(
                #[inline(always)]
                || {
                    // The lanes past `n` start done, so that a partial packet can stop early.
                    let idx = avx.load_i32(&[0, 1, 2, 3, 4, 5, 6, 7]);
                    let live = idx.lt(idx.splat(n as i32));
                    let any = self.any_of_each(&packet(avx, &rays[..n]), !live) & live;
                    any.bits() as u8
                },
            );
        }
        let mut blocked = 0u8;
        for (i, ray) in rays[..n].iter().enumerate() {
            blocked |= u8::from(self.any_of_each(&ray_lanes(ray), false)) << i;
        }
        blocked
    }

    /// Whether [`Self::intersect16`] runs 16 lanes (the CPU has AVX-512).
    pub(crate) fn sixteen_wide(&self) -> bool {
        #[cfg(target_arch = "x86_64")]
        return self.avx512.is_some();
        #[cfg(not(target_arch = "x86_64"))]
        false
    }

    /// [`Self::intersect8`] of up to 16 rays as one packet: `out[i]` for `rays[i]`, the others
    /// `None`. 16 lanes on AVX-512: the same generic test as the 8-wide packet (the same
    /// operations per lane, FMA where it has FMA and nowhere else; the same minimum and tie
    /// key), so every lane gets the hit bit for bit; without AVX-512, two 8-wide packets.
    pub(crate) fn intersect16(&self, rays: &[Ray], out: &mut [Option<Hit>; W16]) {
        let rays = &rays[..rays.len().min(W16)];
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx512 {
            let (ts, geoms, us, vs) = avx.run(
                #[inline(always)]
                || {
                    let b = self.nearest_of_each(&packet16(avx, rays), avx.splat(0.0), NONE);
                    let (t, g) = (b.t.to_array(), b.g.to_array());
                    if self.tri_rows.is_empty() {
                        return (t, g, [0.0; W16], [0.0; W16]);
                    }
                    (t, g, (b.u / b.a).to_array(), (b.v / b.a).to_array())
                },
            );
            *out = [None; W16];
            for (i, ray) in rays.iter().enumerate() {
                out[i] = self.finish(ray, ts[i], geoms[i], us[i], vs[i]);
            }
            return;
        }
        let (lo, hi) = rays.split_at(rays.len().min(W));
        let mut half = [None; W];
        self.intersect8(lo, &mut half);
        out[..W].copy_from_slice(&half);
        self.intersect8(hi, &mut half);
        out[W..].copy_from_slice(&half);
    }

    /// [`Self::intersect16`] of the `n` (at most 16) rays `ray(0)`, … `ray(n − 1)`, each read
    /// where it lies ([`Avx512::ray_fields16_at`]), each hit handed to `out(k, row)` in lane
    /// order as a [`HitRow`] built in lanes ([`Self::hit_fields`], [`Avx512::rows8_16`]): the
    /// stream renderer's 16-ray packets, from and to its path columns, as
    /// [`Self::intersect8_with`] at width 8. Without AVX-512, two 8-wide packets.
    #[inline(always)]
    pub(crate) fn intersect16_with<'r>(
        &self,
        n: usize,
        ray: impl Fn(usize) -> &'r Ray,
        mut out: impl FnMut(usize, HitRow),
    ) {
        let n = n.min(W16);
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx512 {
            let mut rows = avx.run(
                #[inline(always)]
                || {
                    let fields = if n == W16 {
                        avx.ray_fields16_at(&ray)
                    } else {
                        avx.ray_fields16_at(|k| if k < n { ray(k) } else { &PAD_RAY })
                    };
                    let [ox, oy, oz, dx, dy, dz, tnear, tfar] = fields;
                    let r = RayL {
                        o: V3::new(ox, oy, oz),
                        d: V3::new(dx, dy, dz),
                        tnear,
                        tfar,
                    };
                    let b = self.nearest_of_each(&r, avx.splat(0.0), NONE);
                    avx.rows8_16(self.hit_fields(&b)).map(hit_row)
                },
            );
            self.hand_rows(&mut rows, n, &ray, &mut out);
            return;
        }
        let lo = n.min(W);
        self.intersect8_with(lo, &ray, &mut out);
        self.intersect8_with(n - lo, |k| ray(W + k), |k, h| out(W + k, h));
    }

    /// [`Self::occluded8`] of up to 16 rays as one packet: bit `i` for `rays[i]` (16 lanes on
    /// AVX-512, else two 8-wide packets).
    pub(crate) fn occluded16(&self, rays: &[Ray]) -> u16 {
        let n = rays.len().min(W16);
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx512 {
            return avx.run(
                #[inline(always)]
                || {
                    // The lanes past `n` start done, so that a partial packet can stop early.
                    let idx = avx.load_i32(&core::array::from_fn(|i| i as i32));
                    let live = idx.lt(idx.splat(n as i32));
                    let any = self.any_of_each(&packet16(avx, &rays[..n]), !live) & live;
                    any.bits() as u16
                },
            );
        }
        let (lo, hi) = rays[..n].split_at(n.min(W));
        u16::from(self.occluded8(lo)) | u16::from(self.occluded8(hi)) << W
    }

    /// The hit of the primitive of key `key` at `t` (its winner; `None` for [`NONE`]), with the
    /// triangle and barycentrics of a box, or the barycentrics `u`, `v` of a mesh triangle (the
    /// test's numerators over |d·n|, divided in lanes or at width 1 alike).
    #[inline(always)]
    fn finish(&self, ray: &Ray, t: f32, key: i32, u: f32, v: f32) -> Option<Hit> {
        if key == NONE {
            return None;
        }
        let geom = (key as u32) >> PRIM_BITS;
        let prim = (key as u32) & ((1 << PRIM_BITS) - 1);
        let mut hit = Hit {
            geom,
            prim,
            t,
            u: 0.0,
            v: 0.0,
            inst: NO_INSTANCE,
        };
        if self.box_rows.is_empty() && self.tri_rows.is_empty() {
            return Some(hit);
        }
        match self.slots.get(geom as usize) {
            Some(&Slot::Box(row)) => (hit.prim, hit.u, hit.v) = self.box_hit(ray, row as usize),
            Some(&Slot::Mesh) => (hit.u, hit.v) = (u, v),
            _ => {}
        }
        Some(hit)
    }

    /// The triangle and barycentrics of the box at `row` where `ray` hits it (width 1).
    #[inline(never)]
    fn box_hit(&self, ray: &Ray, row: usize) -> (u32, f32, f32) {
        let to_object = row_map(&self.box_rows[row], 0.0f32);
        self.box_triangle(&cube(&ray_lanes(ray), &to_object))
    }

    /// The triangle of the face hit and its barycentrics, as `BoxData::hit` picks them: the
    /// face on the side the ray comes from (entry) or goes to (exit), the hit point's fractions
    /// (a, b) along its two edges; (0,1,2) holds a ≥ b with (u, v) = (a − b, b), (3,0,2) holds
    /// a < b with (u, v) = (1 − b, a).
    fn box_triangle(&self, h: &BoxHit<f32>) -> (u32, f32, f32) {
        let (slab, t) = (if h.entering { h.near } else { h.far }, h.t);
        let axis = if slab.x == t {
            0
        } else if slab.y == t {
            1
        } else {
            2
        };
        let dl = [h.dl.x, h.dl.y, h.dl.z][axis];
        let positive = if h.entering { dl < 0.0 } else { dl > 0.0 };
        let face = &self.faces[2 * axis + usize::from(positive)];
        let (ol, dl) = (Vec3::from(h.ol), Vec3::from(h.dl));
        let r = ol + dl * t - face.corner;
        let a = r.dot(face.edge1).clamp(0.0, 1.0);
        let b = r.dot(face.edge3).clamp(0.0, 1.0);
        if a >= b {
            (2 * face.index, a - b, b)
        } else {
            (2 * face.index + 1, 1.0 - b, a)
        }
    }

    /// Width 1 or 8 rays (`ray`'s width) against every primitive, each splat across the lanes:
    /// per lane the smallest t and, on equal t, the lowest shape index (`NONE`: no hit).
    #[inline(always)]
    fn nearest_of_each<L: Lane>(&self, ray: &RayL<L>, like: L, none: i32) -> Best<L> {
        let gi = like.to_bits();
        let mut best = Best::new(like, none);
        // A primitive that no lane can hit is left at its first half: its mask would be
        // false in every lane, and `keep` would keep nothing.
        for s in &self.sphere_rows {
            let c = V3::new(like.splat(s.c[0]), like.splat(s.c[1]), like.splat(s.c[2]));
            let d = sphere_disc(ray, c, like.splat(s.r));
            if d.real.any() {
                let (t, m) = sphere_roots(ray, &d);
                keep(&mut best, t, m, gi.splat(s.geom));
            }
        }
        for p in &self.square_rows {
            let c = plane_cross(ray, &row_map(p, like));
            if c.within.any() {
                let (x, y) = c.at();
                keep(&mut best, c.t, c.within & in_square(x, y), gi.splat(p.geom));
            }
        }
        for p in &self.disk_rows {
            let c = plane_cross(ray, &row_map(p, like));
            if c.within.any() {
                let (x, y) = c.at();
                keep(&mut best, c.t, c.within & in_disk(x, y), gi.splat(p.geom));
            }
        }
        for b in &self.box_rows {
            let h = cube(ray, &row_map(b, like));
            keep(&mut best, h.t, h.hit, gi.splat(b.geom));
        }
        if !self.meshes.is_empty() {
            let s = slab(ray);
            for mesh in &self.meshes {
                // Up to the nearest hit so far: a crossing behind it is never kept (the rows'
                // cull below), and one at it lies inside the padded box, so it enters first
                // (the padding is far above the slab test's rounding, see `mesh_bounds`). A
                // lane's NaN tfar (an empty lane) stays NaN and rejects.
                let tmax = best.t.min(ray.tfar);
                let within = in_bounds_until(ray, &s, v3(like, mesh.lo), v3(like, mesh.hi), tmax);
                if !within.any() {
                    continue;
                }
                for r in &self.tri_rows[mesh.rows.clone()] {
                    let tri = tri_row(r, like);
                    let p = tri_plane(ray, &tri);
                    // Only a crossing in the interval, at or before the nearest hit so far,
                    // can be kept (`keep_tri`), so the edge half may be skipped without it.
                    if (within & p.t.gt(ray.tnear) & p.t.le(best.t)).any() {
                        let (u, v, m) = tri_edges(ray, &tri, &p);
                        keep_tri(&mut best, &p, u, v, m & within, gi.splat(r.geom));
                    }
                }
            }
        }
        best
    }

    /// Per lane of `ray`, whether any primitive is hit, starting from the lanes of `done`
    /// (stops once every lane is).
    #[inline(always)]
    fn any_of_each<L: Lane>(&self, ray: &RayL<L>, done: L::Mask) -> L::Mask {
        let like = ray.tnear;
        let mut any = done;
        if any.all() {
            return any;
        }
        for s in &self.sphere_rows {
            let c = V3::new(like.splat(s.c[0]), like.splat(s.c[1]), like.splat(s.c[2]));
            let d = sphere_disc(ray, c, like.splat(s.r));
            if d.real.any() {
                any = any | sphere_roots(ray, &d).1;
                if any.all() {
                    return any;
                }
            }
        }
        for p in &self.square_rows {
            let c = plane_cross(ray, &row_map(p, like));
            if c.within.any() {
                let (x, y) = c.at();
                any = any | (c.within & in_square(x, y));
                if any.all() {
                    return any;
                }
            }
        }
        for p in &self.disk_rows {
            let c = plane_cross(ray, &row_map(p, like));
            if c.within.any() {
                let (x, y) = c.at();
                any = any | (c.within & in_disk(x, y));
                if any.all() {
                    return any;
                }
            }
        }
        for b in &self.box_rows {
            any = any | cube(ray, &row_map(b, like)).hit;
            if any.all() {
                return any;
            }
        }
        if self.meshes.is_empty() {
            return any;
        }
        let s = slab(ray);
        for mesh in &self.meshes {
            // Only the lanes not yet blocked.
            let mut within = in_bounds(ray, &s, v3(like, mesh.lo), v3(like, mesh.hi)) & !any;
            if !within.any() {
                continue;
            }
            for r in &self.tri_rows[mesh.rows.clone()] {
                let tri = tri_row(r, like);
                let p = tri_plane(ray, &tri);
                if (within & p.t.gt(ray.tnear) & p.t.lt(ray.tfar)).any() {
                    any = any | (tri_edges(ray, &tri, &p).2 & within);
                    if any.all() {
                        return any;
                    }
                    // A lane blocked by this row needs none of the mesh's other rows.
                    within = within & !any;
                    if !within.any() {
                        break;
                    }
                }
            }
        }
        any
    }
}

#[cfg(target_arch = "x86_64")]
impl Brute {
    /// One ray against the tables 8 primitives at a time: per lane the smallest (t, shape
    /// index), then the smallest over the lanes (the order of the comparisons cannot change a
    /// strict lexicographic minimum). `(∞, NONE)` when nothing is hit.
    #[inline(always)]
    fn nearest_across(&self, avx: Avx2, ray: &Ray) -> (f32, i32, f32, f32) {
        let r = splat_ray(avx, ray);
        let load = Load(avx);
        let mut best = Best::new(avx.splat(0.0), NONE);
        for s in &self.spheres {
            let c = V3::new(load.f(&s.c[0]), load.f(&s.c[1]), load.f(&s.c[2]));
            let (t, m) = sphere(&r, c, load.f(&s.r));
            keep(&mut best, t, m, avx.load_i32(&s.geom));
        }
        for p in &self.planes {
            let sq = load.f(&p.square).gt(avx.splat(0.0));
            let (t, m) = planar(&r, &mapped_chunk(avx, p), sq);
            keep(&mut best, t, m, avx.load_i32(&p.geom));
        }
        for b in &self.boxes {
            let h = cube(&r, &mapped_chunk(avx, b));
            keep(&mut best, h.t, h.hit, avx.load_i32(&b.geom));
        }
        if !self.tris.is_empty() {
            let s = slab(&r);
            for c in &self.tris {
                let within = in_bounds(&r, &s, chunk_v3(load, &c.lo), chunk_v3(load, &c.hi));
                if within.any() {
                    let (p, u, v, m) = triangle(&r, &tri_chunk(avx, c));
                    keep_tri(&mut best, &p, u, v, m & within, avx.load_i32(&c.geom));
                }
            }
        }
        let (ts, gs) = (best.t.to_array(), best.g.to_array());
        let mut k = 0;
        for i in 1..W {
            if ts[i] < ts[k] || (ts[i] == ts[k] && gs[i] < gs[k]) {
                k = i;
            }
        }
        let (us, vs, a) = (best.u.to_array(), best.v.to_array(), best.a.to_array());
        (ts[k], gs[k], us[k] / a[k], vs[k] / a[k])
    }

    /// One ray: whether any chunk has a lane hit.
    #[inline(always)]
    fn any_across(&self, avx: Avx2, ray: &Ray) -> bool {
        let r = splat_ray(avx, ray);
        let load = Load(avx);
        for s in &self.spheres {
            let c = V3::new(load.f(&s.c[0]), load.f(&s.c[1]), load.f(&s.c[2]));
            if sphere(&r, c, load.f(&s.r)).1.any() {
                return true;
            }
        }
        for p in &self.planes {
            let sq = load.f(&p.square).gt(avx.splat(0.0));
            if planar(&r, &mapped_chunk(avx, p), sq).1.any() {
                return true;
            }
        }
        for b in &self.boxes {
            if cube(&r, &mapped_chunk(avx, b)).hit.any() {
                return true;
            }
        }
        if !self.tris.is_empty() {
            let s = slab(&r);
            for c in &self.tris {
                let within = in_bounds(&r, &s, chunk_v3(load, &c.lo), chunk_v3(load, &c.hi));
                if within.any() && (triangle(&r, &tri_chunk(avx, c)).3 & within).any() {
                    return true;
                }
            }
        }
        false
    }
}

/// The ray at width 1.
#[inline(always)]
fn ray_lanes(ray: &Ray) -> RayL<f32> {
    RayL {
        o: ray.o.into(),
        d: ray.d.into(),
        tnear: ray.tmin,
        tfar: ray.tmax,
    }
}

/// One ray in all 8 lanes.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn splat_ray(avx: Avx2, ray: &Ray) -> RayL<F32x8> {
    RayL {
        o: V3::new(avx.splat(ray.o.x), avx.splat(ray.o.y), avx.splat(ray.o.z)),
        d: V3::new(avx.splat(ray.d.x), avx.splat(ray.d.y), avx.splat(ray.d.z)),
        tnear: avx.splat(ray.tmin),
        tfar: avx.splat(ray.tmax),
    }
}

/// Up to 8 rays, one per lane; lanes past `rays.len()` get a NaN interval (never hit). Each
/// ray is one row of 8 floats loaded in place ([`packet_with`]), turned into 8 lanes per field
/// by one 8×8 transpose (moves only).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn packet(avx: Avx2, rays: &[Ray]) -> RayL<F32x8> {
    packet_with(avx, rays.len().min(W), &|k| &rays[k])
}

/// [`packet`] of the `n` (at most 8) rays `ray(0)`, … `ray(n − 1)`, each row loaded where the
/// ray lies ([`Avx2::ray_row`]); the same lanes.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn packet_with<'r>(avx: Avx2, n: usize, ray: &impl Fn(usize) -> &'r Ray) -> RayL<F32x8> {
    const PAD: [f32; W] = [0.0, 0.0, 0.0, 0.0, 0.0, 1.0, f32::NAN, f32::NAN];
    let mut rows = [Load(avx).f(&PAD); W];
    if n >= W {
        for (k, row) in rows.iter_mut().enumerate() {
            *row = avx.ray_row(ray(k));
        }
    } else {
        for (k, row) in rows.iter_mut().enumerate().take(n) {
            *row = avx.ray_row(ray(k));
        }
    }
    fields_ray(F32x8::transpose8(rows))
}

/// A packet's rays from their 8 fields in lanes (o.x, o.y, o.z, d.x, d.y, d.z, tmin, tmax: the
/// transposed rows of [`packet_with`] and [`Avx2::ray_rows_through`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn fields_ray([ox, oy, oz, dx, dy, dz, tnear, tfar]: [F32x8; 8]) -> RayL<F32x8> {
    RayL {
        o: V3::new(ox, oy, oz),
        d: V3::new(dx, dy, dz),
        tnear,
        tfar,
    }
}

/// Up to 16 rays, one per lane ([`packet`] at width 16): a full packet loaded in place
/// ([`Avx512::ray_fields16`]), a partial one first copied after rays with a NaN interval
/// (never hit).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn packet16(avx: Avx512, rays: &[Ray]) -> RayL<F32x16> {
    let mut padded = [PAD_RAY; W16];
    let all: &[Ray; W16] = match rays.try_into() {
        Ok(all) => all,
        Err(_) => {
            padded[..rays.len()].copy_from_slice(rays);
            &padded
        }
    };
    let [ox, oy, oz, dx, dy, dz, tnear, tfar] = avx.ray_fields16(all);
    RayL {
        o: V3::new(ox, oy, oz),
        d: V3::new(dx, dy, dz),
        tnear,
        tfar,
    }
}

/// A lane that holds no ray: a NaN interval, which every test rejects (the padding of
/// [`packet_with`] and [`packet16`]).
const PAD_RAY: Ray = Ray {
    o: Vec3::ZERO,
    d: Vec3::Z,
    tmin: f32::NAN,
    tmax: f32::NAN,
};

/// One lane's row of [`Brute::hit_fields`] as a [`HitRow`] (its words' bits).
#[inline(always)]
fn hit_row(r: [f32; 8]) -> HitRow {
    HitRow(r.map(f32::to_bits))
}

/// A row's world-to-object map, splat to the width of `like`.
#[inline(always)]
fn row_map<L: Lane>(p: &MappedRow, like: L) -> Affine<L> {
    let m = &p.m;
    Affine {
        x: V3::new(like.splat(m[0]), like.splat(m[1]), like.splat(m[2])),
        y: V3::new(like.splat(m[3]), like.splat(m[4]), like.splat(m[5])),
        z: V3::new(like.splat(m[6]), like.splat(m[7]), like.splat(m[8])),
        w: V3::new(like.splat(m[9]), like.splat(m[10]), like.splat(m[11])),
    }
}

/// `a` splat to the width of `like`.
#[inline(always)]
fn v3<L: Lane>(like: L, a: [f32; 3]) -> V3<L> {
    V3::new(like.splat(a[0]), like.splat(a[1]), like.splat(a[2]))
}

/// The per-lane vectors of a chunk's three component rows.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn chunk_v3(load: Load, a: &[[f32; W]; 3]) -> V3<F32x8> {
    V3::new(load.f(&a[0]), load.f(&a[1]), load.f(&a[2]))
}

/// A mesh's bounding box, padded on every side by 10⁻⁴ of its largest extent plus its largest
/// coordinate magnitude: far more than the rounding of the triangle test (about 10⁻⁷ of
/// |p0| + |o| + t, divided by the cosine of the incidence), so that the box culls no hit the
/// triangle test would report but at grazing incidence below a cosine of about 10⁻³.
fn mesh_bounds(m: &crate::geometry::mesh::TriMesh) -> (Vec3, Vec3) {
    let (lo, hi) = m
        .indices
        .iter()
        .flatten()
        .map(|&i| m.positions[i as usize])
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p), hi.max(p))
        });
    let pad = 1e-4 * ((hi - lo).max_element() + lo.abs().max(hi.abs()).max_element());
    (lo - Vec3::splat(pad), hi + Vec3::splat(pad))
}

/// A mesh box's largest extent (the order of [`Brute::meshes`]).
fn extent(m: &MeshBox) -> f32 {
    (Vec3::from(m.hi) - Vec3::from(m.lo)).max_element()
}

/// A triangle row splat to the width of `like`.
#[inline(always)]
fn tri_row<L: Lane>(r: &TriRow, like: L) -> TriL<L> {
    let v = &r.v;
    TriL {
        p0: V3::new(like.splat(v[0]), like.splat(v[1]), like.splat(v[2])),
        e1: V3::new(like.splat(v[3]), like.splat(v[4]), like.splat(v[5])),
        e2: V3::new(like.splat(v[6]), like.splat(v[7]), like.splat(v[8])),
        n: V3::new(like.splat(v[9]), like.splat(v[10]), like.splat(v[11])),
    }
}

/// A triangle chunk's 8 triangles, one per lane.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn tri_chunk(avx: Avx2, c: &Tris) -> TriL<F32x8> {
    let v = &c.v;
    TriL {
        p0: V3::new(avx.load(&v[0]), avx.load(&v[1]), avx.load(&v[2])),
        e1: V3::new(avx.load(&v[3]), avx.load(&v[4]), avx.load(&v[5])),
        e2: V3::new(avx.load(&v[6]), avx.load(&v[7]), avx.load(&v[8])),
        n: V3::new(avx.load(&v[9]), avx.load(&v[10]), avx.load(&v[11])),
    }
}

/// The 12 entries by column of the inverse of `to_world` (its upper 3×4 part).
fn to_object(to_world: &Mat4) -> [f32; 12] {
    let inv = to_world.inverse();
    let mut m = [0.0; 12];
    for (k, c) in [inv.x_axis, inv.y_axis, inv.z_axis, inv.w_axis]
        .iter()
        .enumerate()
    {
        m[3 * k..3 * k + 3].copy_from_slice(&c.to_array()[..3]);
    }
    m
}

/// Per lane, the nearest hit so far: t, key, and for a mesh triangle the numerators of u and v
/// and |d·n| (stale for the other kinds, whose barycentrics come from elsewhere).
#[derive(Clone, Copy)]
struct Best<L: Lane> {
    t: L,
    g: L::I32,
    u: L,
    v: L,
    a: L,
}

impl<L: Lane> Best<L> {
    /// No hit yet (t = ∞, key `none`), at the width of `like`.
    #[inline(always)]
    fn new(like: L, none: i32) -> Self {
        Best {
            t: like.splat(f32::INFINITY),
            g: like.to_bits().splat(none),
            u: like.splat(0.0),
            v: like.splat(0.0),
            a: like.splat(1.0),
        }
    }
}

/// Keeps, per lane, the hit (t, key `g`) of mask `m` when it comes before `best`: a smaller t,
/// or the same t and a lower key. Returns where it kept.
#[inline(always)]
fn keep<L: Lane>(best: &mut Best<L>, t: L, m: L::Mask, g: L::I32) -> L::Mask {
    let better = m & (t.lt(best.t) | (t.eq(best.t) & g.lt(best.g)));
    best.t = L::select(better, t, best.t);
    best.g = L::I32::select(better, g, best.g);
    better
}

/// [`keep`] of a triangle's hit, with its barycentric numerators `u`, `v` and |d·n|.
#[inline(always)]
fn keep_tri<L: Lane>(best: &mut Best<L>, p: &TriPlane<L>, u: L, v: L, m: L::Mask, g: L::I32) {
    let better = keep(best, p.t, m, g);
    best.u = L::select(better, u, best.u);
    best.v = L::select(better, v, best.v);
    best.a = L::select(better, p.a, best.a);
}

/// 8-wide loads (a named helper: closures in `Avx2::run` bodies are not always inlined).
#[cfg(target_arch = "x86_64")]
#[derive(Clone, Copy)]
struct Load(Avx2);

#[cfg(target_arch = "x86_64")]
impl Load {
    #[inline(always)]
    fn f(self, a: &[f32; W]) -> F32x8 {
        self.0.load(a)
    }
}

/// A mapped chunk's 8 maps, one per lane.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn mapped_chunk(avx: Avx2, p: &Mapped) -> Affine<F32x8> {
    let m = &p.m;
    Affine {
        x: V3::new(avx.load(&m[0]), avx.load(&m[1]), avx.load(&m[2])),
        y: V3::new(avx.load(&m[3]), avx.load(&m[4]), avx.load(&m[5])),
        z: V3::new(avx.load(&m[6]), avx.load(&m[7]), avx.load(&m[8])),
        w: V3::new(avx.load(&m[9]), avx.load(&m[10]), avx.load(&m[11])),
    }
}

/// The faces of [`CUBE_FACES`] as `BoxData::new` in `embree.rs` indexes them: by the axis of
/// their plane and its side.
fn box_faces() -> [Face; 6] {
    let mut slots = [Face {
        corner: Vec3::ZERO,
        edge1: Vec3::ZERO,
        edge3: Vec3::ZERO,
        index: 0,
    }; 6];
    for (f, c) in CUBE_FACES.iter().enumerate() {
        let [c0, c1, c2, c3] = c.map(Vec3::from_array);
        let centre = (c0 + c1 + c2 + c3) * 0.25;
        let axis = (0..3)
            .max_by(|&a, &b| centre[a].abs().total_cmp(&centre[b].abs()))
            .unwrap_or(0);
        let (e1, e3) = (c1 - c0, c3 - c0);
        slots[2 * axis + usize::from(centre[axis] > 0.0)] = Face {
            corner: c0,
            edge1: e1 / e1.length_squared(),
            edge3: e3 / e3.length_squared(),
            index: f as u32,
        };
    }
    slots
}

#[cfg(test)]
mod tests {
    use super::super::analytic::{max_num, min_num};
    use std::hint::black_box;

    /// The box test relies on `min_num`/`max_num` being what `f32::min`/`max` compile to (glam's
    /// `Vec3::min`, `max_element`): check every pair of special values, signed zeros included.
    #[test]
    fn min_num_and_max_num_are_rusts_min_and_max() {
        let v = [
            0.0f32,
            -0.0,
            f32::NAN,
            1.0,
            -1.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        for &a in &v {
            for &b in &v {
                let (m, x) = (
                    black_box(a).min(black_box(b)),
                    black_box(a).max(black_box(b)),
                );
                let same =
                    |p: f32, q: f32| p.to_bits() == q.to_bits() || (p.is_nan() && q.is_nan());
                assert!(same(m, min_num(a, b)), "min({a}, {b})");
                assert!(same(x, max_num(a, b)), "max({a}, {b})");
            }
        }
    }
}
