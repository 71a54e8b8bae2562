//! Tier A: the few analytic primitives of a scene intersected by brute force, 8 lanes at a time
//! (issue 16 item 3), instead of an Embree BVH over user geometries with per-ray callbacks.
//!
//! Primitives (spheres, disks and rectangles, exact boxes) sit in structure-of-arrays tables of
//! 8 per chunk, padded with NaN parameters (which fail every interval test). Two forms, both
//! over the kernels of [`super::analytic`]:
//! - one ray × 8 primitives ([`Brute::intersect`], [`Brute::occluded`]): the scalar renderer's
//!   rays, each chunk one 8-wide test;
//! - 8 rays × every primitive ([`Brute::intersect8`], [`Brute::occluded8`]): a packet, each
//!   primitive splat across the lanes.
//!
//! Without AVX2 both run at width 1 over every primitive. Every form reports the same [`Hit`]:
//! the smallest t in the open interval (tmin, tmax) (Embree shrinks tfar after each accepted
//! hit and the callbacks test the open interval, so Embree's answer is that minimum too), ties on
//! equal t broken by the lower shape index, and the callbacks' primitive and barycentrics (the
//! box's triangle; zero for the others), computed at width 1 for the winner only.

use super::analytic::{cube, planar, sphere, Affine, BoxHit, RayL};
use crate::geometry::hit::NO_INSTANCE;
use crate::geometry::shapes::{Shape, ShapeKind, CUBE_FACES};
use crate::geometry::{Hit, Ray};
use crate::lane::{vec::V3, Lane, LaneI32, LaneMask};
#[cfg(target_arch = "x86_64")]
use crate::lane::{Avx2, F32x8};
use glam::{Mat4, Vec3};

/// Lanes per chunk.
const W: usize = 8;
/// The shape index of an empty lane (never hit: its parameters are NaN).
const NONE: i32 = i32::MAX;

/// 8 spheres: centre components, radius, shape index.
#[derive(Clone, Copy)]
struct Spheres {
    c: [[f32; W]; 3],
    r: [f32; W],
    geom: [i32; W],
}

/// 8 affinely mapped unit shapes (disks and rectangles, or boxes): the 12 entries of the
/// world-to-object map by column, 1 for a square (rectangle), and the shape index.
#[derive(Clone, Copy)]
struct Mapped {
    m: [[f32; W]; 12],
    square: [f32; W],
    geom: [i32; W],
}

/// Which table holds shape `i`, and at which row.
#[derive(Clone, Copy, Debug)]
enum Slot {
    /// A sphere, disk or rectangle (nothing to add to the hit), or an empty mesh (never hit).
    Plain,
    /// A box at this row of the box table.
    Box(u32),
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
    spheres: Vec<Spheres>,
    planes: Vec<Mapped>,
    boxes: Vec<Mapped>,
    /// Live rows per table (the last chunk may be partly empty).
    rows: [usize; 3],
    slots: Vec<Slot>,
    /// Box faces indexed by `2·axis + (side > 0)`.
    faces: [Face; 6],
    #[cfg(target_arch = "x86_64")]
    avx: Option<Avx2>,
}

/// Whether tier A can trace `shape` (and how: `Some(None)` for an empty mesh).
fn slot_kind(shape: &Shape) -> Option<Option<u8>> {
    match (&shape.kind, shape.box_to_world) {
        (ShapeKind::Mesh(m), _) if m.indices.is_empty() => Some(None),
        (ShapeKind::Mesh(_), Some(_)) => Some(Some(2)),
        (ShapeKind::Sphere { .. }, _) => Some(Some(0)),
        (ShapeKind::Disk { .. } | ShapeKind::Rectangle { .. }, _) => Some(Some(1)),
        _ => None,
    }
}

/// The number of primitives tier A would trace, or `None` when a shape needs Embree (a
/// triangle mesh, cylinder or curves).
pub(crate) fn analytic_count(shapes: &[Shape]) -> Option<usize> {
    shapes
        .iter()
        .try_fold(0, |n, s| slot_kind(s).map(|k| n + usize::from(k.is_some())))
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
        analytic_count(shapes)?;
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
        let mut b = Brute {
            spheres: Vec::new(),
            planes: Vec::new(),
            boxes: Vec::new(),
            rows: [0; 3],
            slots: Vec::with_capacity(shapes.len()),
            faces: box_faces(),
            #[cfg(target_arch = "x86_64")]
            avx: Avx2::detect(),
        };
        let mapped = |t: &mut Mapped, l: usize, to_world: &Mat4, square: bool, geom: usize| {
            let inv = to_world.inverse();
            let cols = [inv.x_axis, inv.y_axis, inv.z_axis, inv.w_axis];
            for (k, c) in cols.iter().enumerate() {
                for j in 0..3 {
                    t.m[3 * k + j][l] = c[j];
                }
            }
            t.square[l] = if square { 1.0 } else { 0.0 };
            t.geom[l] = geom as i32;
        };
        for (i, s) in shapes.iter().enumerate() {
            let slot = match (&s.kind, s.box_to_world) {
                (ShapeKind::Mesh(m), _) if m.indices.is_empty() => Slot::Plain,
                (ShapeKind::Mesh(_), Some(to_world)) => {
                    let (c, l) = push_row(&mut b.boxes, &mut b.rows[2], empty_mapped);
                    mapped(&mut b.boxes[c], l, &to_world, false, i);
                    Slot::Box((c * W + l) as u32)
                }
                (ShapeKind::Sphere { center, radius, .. }, _) => {
                    let (c, l) = push_row(&mut b.spheres, &mut b.rows[0], empty_sphere);
                    let t = &mut b.spheres[c];
                    (t.c[0][l], t.c[1][l], t.c[2][l]) = (center.x, center.y, center.z);
                    t.r[l] = *radius;
                    t.geom[l] = i as i32;
                    Slot::Plain
                }
                (ShapeKind::Disk { hit_to_world, .. }, _) => {
                    let (c, l) = push_row(&mut b.planes, &mut b.rows[1], empty_mapped);
                    mapped(&mut b.planes[c], l, hit_to_world, false, i);
                    Slot::Plain
                }
                (ShapeKind::Rectangle { to_world }, _) => {
                    let (c, l) = push_row(&mut b.planes, &mut b.rows[1], empty_mapped);
                    mapped(&mut b.planes[c], l, to_world, true, i);
                    Slot::Plain
                }
                _ => return None,
            };
            b.slots.push(slot);
        }
        Some(b)
    }

    /// The nearest hit of `ray` in (tmin, tmax): one ray against 8 primitives at a time.
    #[inline]
    pub(crate) fn intersect(&self, ray: &Ray) -> Option<Hit> {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            let (t, geom) = avx.run(
                #[inline(always)]
                || self.nearest_across(avx, ray),
            );
            return self.finish(ray, t, geom);
        }
        let r = ray_lanes(ray);
        let (t, geom) = self.nearest_of_each(&r, 0.0f32, NONE);
        self.finish(ray, t, geom)
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
        self.any_of_each(&ray_lanes(ray)).any()
    }

    /// [`Self::intersect`] of up to 8 rays as one packet: `out[i]` for `rays[i]`, the others
    /// `None`.
    pub(crate) fn intersect8(&self, rays: &[Ray], out: &mut [Option<Hit>; 8]) {
        let rays = &rays[..rays.len().min(W)];
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            let (ts, geoms) = avx.run(
                #[inline(always)]
                || {
                    let (t, g) = self.nearest_of_each(&packet(avx, rays), avx.splat(0.0), NONE);
                    (t.to_array(), g.to_array())
                },
            );
            for (i, o) in out.iter_mut().enumerate() {
                *o = rays
                    .get(i)
                    .and_then(|ray| self.finish(ray, ts[i], geoms[i]));
            }
            return;
        }
        for (i, o) in out.iter_mut().enumerate() {
            *o = rays.get(i).and_then(|ray| {
                let (t, g) = self.nearest_of_each(&ray_lanes(ray), 0.0f32, NONE);
                self.finish(ray, t, g)
            });
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
                    let m = self.any_of_each(&packet(avx, &rays[..n])).to_array();
                    (0..n).fold(0u8, |b, i| b | (u8::from(m[i]) << i))
                },
            );
        }
        (0..n).fold(0u8, |b, i| {
            b | (u8::from(self.any_of_each(&ray_lanes(&rays[i])).any()) << i)
        })
    }

    /// The hit of shape `geom` at `t` (its winner), with the box's triangle and barycentrics.
    #[inline]
    fn finish(&self, ray: &Ray, t: f32, geom: i32) -> Option<Hit> {
        let slot = *self.slots.get(usize::try_from(geom).ok()?)?;
        let mut hit = Hit {
            geom: geom as u32,
            prim: 0,
            t,
            u: 0.0,
            v: 0.0,
            inst: NO_INSTANCE,
        };
        if let Slot::Box(row) = slot {
            let b = &self.boxes[row as usize / W];
            let to_object = mapped_lanes(b, row as usize % W, 0.0f32);
            let bh = cube(&ray_lanes(ray), &to_object);
            (hit.prim, hit.u, hit.v) = self.box_triangle(&bh);
        }
        Some(hit)
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
    fn nearest_of_each<L: Lane>(&self, ray: &RayL<L>, like: L, none: i32) -> (L, L::I32) {
        let gi = like.to_bits();
        let mut best = (like.splat(f32::INFINITY), gi.splat(none));
        for row in 0..self.rows[0] {
            let s = &self.spheres[row / W];
            let (c, r) = sphere_lanes(s, row % W, like);
            let (t, m) = sphere(ray, c, r);
            keep(&mut best, t, m, gi.splat(s.geom[row % W]));
        }
        for row in 0..self.rows[1] {
            let p = &self.planes[row / W];
            let sq = like.splat(p.square[row % W]).gt(like.splat(0.0));
            let (t, m) = planar(ray, &mapped_lanes(p, row % W, like), sq);
            keep(&mut best, t, m, gi.splat(p.geom[row % W]));
        }
        for row in 0..self.rows[2] {
            let b = &self.boxes[row / W];
            let h = cube(ray, &mapped_lanes(b, row % W, like));
            keep(&mut best, h.t, h.hit, gi.splat(b.geom[row % W]));
        }
        best
    }

    /// Per lane of `ray`, whether any primitive is hit (stops once every lane is).
    #[inline(always)]
    fn any_of_each<L: Lane>(&self, ray: &RayL<L>) -> L::Mask {
        let like = ray.tnear;
        // All lanes false (`x < x` fails even for NaN).
        let mut any = like.lt(like);
        for row in 0..self.rows[0] {
            let (c, r) = sphere_lanes(&self.spheres[row / W], row % W, like);
            any = any | sphere(ray, c, r).1;
            if any.all() {
                return any;
            }
        }
        for row in 0..self.rows[1] {
            let p = &self.planes[row / W];
            let sq = like.splat(p.square[row % W]).gt(like.splat(0.0));
            any = any | planar(ray, &mapped_lanes(p, row % W, like), sq).1;
            if any.all() {
                return any;
            }
        }
        for row in 0..self.rows[2] {
            let b = &self.boxes[row / W];
            any = any | cube(ray, &mapped_lanes(b, row % W, like)).hit;
            if any.all() {
                return any;
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
    fn nearest_across(&self, avx: Avx2, ray: &Ray) -> (f32, i32) {
        let r = splat_ray(avx, ray);
        let load = Load(avx);
        let mut best = (avx.splat(f32::INFINITY), avx.load_i32(&[NONE; W]));
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
        let (ts, gs) = (best.0.to_array(), best.1.to_array());
        (0..W).fold((f32::INFINITY, NONE), |(t, g), i| {
            if ts[i] < t || (ts[i] == t && gs[i] < g) {
                (ts[i], gs[i])
            } else {
                (t, g)
            }
        })
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
        self.boxes
            .iter()
            .any(|b| cube(&r, &mapped_chunk(avx, b)).hit.any())
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

/// Up to 8 rays, one per lane; lanes past `rays.len()` get a NaN interval (never hit).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn packet(avx: Avx2, rays: &[Ray]) -> RayL<F32x8> {
    let mut a = [[0.0f32; W]; 8];
    a[5] = [1.0; W];
    a[6] = [f32::NAN; W];
    a[7] = [f32::NAN; W];
    for (i, r) in rays.iter().take(W).enumerate() {
        for (k, x) in [r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.tmin, r.tmax]
            .into_iter()
            .enumerate()
        {
            a[k][i] = x;
        }
    }
    RayL {
        o: V3::new(avx.load(&a[0]), avx.load(&a[1]), avx.load(&a[2])),
        d: V3::new(avx.load(&a[3]), avx.load(&a[4]), avx.load(&a[5])),
        tnear: avx.load(&a[6]),
        tfar: avx.load(&a[7]),
    }
}

/// Row `l` of a sphere chunk, splat to the width of `like`.
#[inline(always)]
fn sphere_lanes<L: Lane>(s: &Spheres, l: usize, like: L) -> (V3<L>, L) {
    (
        V3::new(
            like.splat(s.c[0][l]),
            like.splat(s.c[1][l]),
            like.splat(s.c[2][l]),
        ),
        like.splat(s.r[l]),
    )
}

/// Row `l` of a mapped chunk's world-to-object map, splat to the width of `like`.
#[inline(always)]
fn mapped_lanes<L: Lane>(p: &Mapped, l: usize, like: L) -> Affine<L> {
    let m = &p.m;
    Affine {
        x: V3::new(
            like.splat(m[0][l]),
            like.splat(m[1][l]),
            like.splat(m[2][l]),
        ),
        y: V3::new(
            like.splat(m[3][l]),
            like.splat(m[4][l]),
            like.splat(m[5][l]),
        ),
        z: V3::new(
            like.splat(m[6][l]),
            like.splat(m[7][l]),
            like.splat(m[8][l]),
        ),
        w: V3::new(
            like.splat(m[9][l]),
            like.splat(m[10][l]),
            like.splat(m[11][l]),
        ),
    }
}

/// Keeps, per lane, the hit (t, shape index `g`) of mask `m` when it comes before `best`: a
/// smaller t, or the same t and a lower index.
#[inline(always)]
fn keep<L: Lane>(best: &mut (L, L::I32), t: L, m: L::Mask, g: L::I32) {
    let better = m & (t.lt(best.0) | (t.eq(best.0) & g.lt(best.1)));
    *best = (
        L::select(better, t, best.0),
        L::I32::select(better, g, best.1),
    );
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
