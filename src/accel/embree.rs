//! The only FFI module: a thin, safe wrapper over Embree 3's C API (through `embree3::sys`).
//!
//! One device and one scene per [`EmbreeScene`]; geometry `i` is attached with id `i`, so Embree's
//! `geomID` is the caller's shape index. Shape groups are scenes of their own, instanced into the
//! top-level scene (`build_instanced_with`). Embree scenes are immutable after `rtcCommitScene` and
//! `rtcIntersect1` / `rtcOccluded1` are thread-safe (Embree 3 API docs, "rtcIntersect1"), which is
//! what makes the wrapper `Send + Sync`.

use crate::accel::HitRow;
use crate::geometry::sdfgrid::SdfGrid;
use crate::geometry::Cylinder;
use crate::geometry::Hit;
use crate::geometry::Ray;
use embree3::sys::*;
use glam::{Mat4, Vec3};
use std::ffi::{c_char, c_void, CStr};
use std::ptr;
use std::sync::Mutex;

/// Embree's device configuration: at most AVX2 kernels. On an AVX-512 host (Zen 4) Debian's
/// Embree 3.13.5 picks its AVX-512 kernels, whose coherent `rtcOccluded1M` over a scene with an
/// instance, rays of mixed octants, never returns when the stack below the caller holds non-zero
/// bytes: a read of uninitialised memory inside Embree, not a bad input from groove (thirteenth
/// session; reproduction in C: `docs/bench/embree/avx512_occluded_hang.c`). Capped at AVX2 it
/// returns, AVX-512 was not faster in wall clock (`docs/bench/README.md`), and the renderer's
/// 8-wide packets match the kernels' width.
const EMBREE_CONFIG: &CStr = c"isa=avx2";

/// Geometry handed to Embree, borrowed from the shapes.
pub(crate) enum GeomDesc<'a> {
    Triangles {
        positions: &'a [Vec3],
        indices: &'a [[u32; 3]],
    },
    /// A sphere: an Embree user geometry intersected by the callbacks below (measured faster
    /// than Embree's `RTC_GEOMETRY_TYPE_SPHERE_POINT`, whose curve-style intersector does more
    /// work per ray for a single sphere).
    Sphere { center: Vec3, radius: f32 },
    /// The unit disk (z = 0, r ≤ 1) of object space mapped by `to_world`: an Embree user
    /// geometry intersected exactly by the callbacks below.
    Disk { to_world: Mat4 },
    /// The square [−1,1]² (z = 0) of object space mapped by `to_world`. At the top level Embree
    /// traces a thin box of triangles around it whose hits a filter decides exactly
    /// ([`RectSlab`]: the user geometry's hits and misses without its callbacks); inside a
    /// shape group (or without filter functions) it is a user geometry like the disk.
    Rectangle { to_world: Mat4 },
    /// The box [−1,1]³ of object space mapped by an invertible `to_world`, given as the 6 faces
    /// of a triangle mesh (corners in order around each face, triangles (0,1,2) and (3,0,2) of
    /// face `f` numbered 2f and 2f+1): a user geometry that reports the triangle and the
    /// barycentrics Embree's triangle intersector would, so the mesh's shading code applies.
    Box {
        to_world: Mat4,
        faces: &'a [[[f32; 3]; 4]; 6],
    },
    /// Mitsuba's open cylinder: a user geometry intersected by [`Cylinder::hit`].
    Cylinder(&'a Cylinder),
    /// Mitsuba's `linearcurve` / `bsplinecurve`: Embree's round linear or round B-spline curves
    /// (see [`curve_geometry`]).
    Curves(CurveDesc<'a>),
    /// Mitsuba's `sdfgrid`: a user geometry of one primitive per occupied voxel, intersected by
    /// [`SdfGrid::hit`].
    SdfGrid(std::sync::Arc<SdfGrid>),
    /// Nothing to trace (a degenerate shape); its id stays unused.
    Empty,
}

/// An instance of a shape group: the group's index in the `groups` given to
/// [`EmbreeScene::build_instanced_with`] and its object-to-world map (affine, invertible).
pub(crate) struct InstanceDesc {
    pub(crate) group: u32,
    pub(crate) to_world: Mat4,
}

/// A user-geometry hit: ray parameter, and the triangle and barycentrics reported as Embree's
/// `primID`, `u`, `v` (zero for shapes that have no triangles).
#[derive(Clone, Copy, Debug, PartialEq)]
struct UserHit {
    t: f32,
    prim: u32,
    u: f32,
    v: f32,
}

impl UserHit {
    fn at(t: f32) -> UserHit {
        UserHit {
            t,
            prim: 0,
            u: 0.0,
            v: 0.0,
        }
    }
}

/// A shape Embree intersects through user-geometry callbacks (one primitive each).
trait UserShape {
    /// World-space bounding box (lower, upper).
    fn bounds(&self) -> (Vec3, Vec3);
    /// The nearest hit with its ray parameter in the open interval (tnear, tfar), if any.
    fn hit(&self, o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> Option<UserHit>;
}

/// A user geometry of several primitives, each with its own bounds and intersection (Embree
/// passes the primitive's index as `primID`). Every [`UserShape`] is one of a single primitive.
trait UserPrims {
    /// The number of primitives.
    fn count(&self) -> u32;
    /// Primitive `k`'s world-space bounding box (lower, upper).
    fn prim_bounds(&self, k: u32) -> (Vec3, Vec3);
    /// The nearest hit on primitive `k` with its ray parameter in (tnear, tfar), if any.
    fn prim_hit(&self, k: u32, o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> Option<UserHit>;
}

impl<T: UserShape> UserPrims for T {
    #[inline]
    fn count(&self) -> u32 {
        1
    }
    #[inline]
    fn prim_bounds(&self, _: u32) -> (Vec3, Vec3) {
        self.bounds()
    }
    #[inline(always)]
    fn prim_hit(&self, _: u32, o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> Option<UserHit> {
        self.hit(o, d, tnear, tfar)
    }
}

/// The SDF grid's voxels, each a primitive reported with its index.
impl UserPrims for SdfGrid {
    fn count(&self) -> u32 {
        self.primitive_count()
    }
    fn prim_bounds(&self, k: u32) -> (Vec3, Vec3) {
        self.primitive_bounds(k)
    }
    fn prim_hit(&self, k: u32, o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> Option<UserHit> {
        self.hit(k, o, d, tnear, tfar).map(|t| UserHit {
            t,
            prim: k,
            u: 0.0,
            v: 0.0,
        })
    }
}

/// What the sphere callbacks need, owned by the scene.
struct SphereData {
    center: Vec3,
    radius: f32,
}

impl UserShape for SphereData {
    fn bounds(&self) -> (Vec3, Vec3) {
        let pad = (self.center.abs() + Vec3::splat(self.radius)) * 1e-6;
        let r = Vec3::splat(self.radius);
        (self.center - r - pad, self.center + r + pad)
    }

    /// Both roots of |o + t d − c|² = r², with the discriminant taken from the distance of the
    /// line to the centre and the small root from the product of the roots, which keeps
    /// precision for distant spheres and grazing rays ("Precision Improvements for Ray/Sphere
    /// Intersection", Haines et al., Ray Tracing Gems, 2019, ch. 7).
    fn hit(&self, o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> Option<UserHit> {
        let f = o - self.center;
        let a = d.dot(d);
        let b = f.dot(d);
        let l = f - d * (b / a);
        let r2 = self.radius * self.radius;
        let disc = r2 - l.dot(l);
        if disc.is_nan() || disc < 0.0 || a == 0.0 {
            return None;
        }
        let c = f.dot(f) - r2;
        let q = -b - (a * disc).sqrt().copysign(b);
        let (mut t0, mut t1) = (q / a, if q != 0.0 { c / q } else { q / a });
        if t0 > t1 {
            std::mem::swap(&mut t0, &mut t1);
        }
        let t = if t0 > tnear && t0 < tfar {
            t0
        } else if t1 > tnear && t1 < tfar {
            t1
        } else {
            return None;
        };
        Some(UserHit::at(t))
    }
}

/// An affinely mapped object-space shape: the inverse map (rays are intersected in object
/// space, where the ray parameter is the same as in world space) and the world-space bounds.
struct ObjectSpace {
    to_object: Mat4,
    lower: Vec3,
    upper: Vec3,
}

impl ObjectSpace {
    /// `ext`: the half extent, per world axis, of the shape around `to_world`'s origin image;
    /// the bounds are padded by a few ulps.
    fn new(to_world: &Mat4, ext: Vec3) -> ObjectSpace {
        let c = to_world.transform_point3(Vec3::ZERO);
        let pad = (c.abs() + ext) * 1e-6;
        ObjectSpace {
            to_object: to_world.inverse(),
            lower: c - ext - pad,
            upper: c + ext + pad,
        }
    }

    /// The ray in object space.
    #[inline]
    fn ray(&self, o: Vec3, d: Vec3) -> (Vec3, Vec3) {
        (
            self.to_object.transform_point3(o),
            self.to_object.transform_vector3(d),
        )
    }
}

/// The ray parameter where the object-space ray `ol + t·dl` meets the plane z = 0: the
/// disk's and rectangle's callbacks (and so the rectangle's filter) and tier A's planar kernel
/// all compute it so.
#[inline(always)]
fn plane_t(ol: Vec3, dl: Vec3) -> f32 {
    -ol.z / dl.z
}

/// The thin box Embree traces for a top-level rectangle ([`RectSlab`]): the square [−1,1]² of
/// `to_world`'s z = 0 plane widened by `pad` along both of its axes and thickened by `pad`
/// to either side of the plane (`pad`: 2⁻¹⁶ of the rectangle's world coordinates' scale,
/// ~256 ulps of them), as 8 corners (bit 0: +x side, bit 1: +y, bit 2: +normal) and the 12
/// triangles of its 6 faces. `None` for a degenerate rectangle.
fn rectangle_slab(to_world: &Mat4) -> Option<([Vec3; 8], [[u32; 3]; 12])> {
    let c = to_world.transform_point3(Vec3::ZERO);
    let ax = to_world.transform_vector3(Vec3::X);
    let ay = to_world.transform_vector3(Vec3::Y);
    let n = ax.cross(ay).normalize_or_zero();
    let pad = (c.abs().max_element() + ax.length() + ay.length()) * (1.0 / 65536.0);
    let (ex, ey) = (
        ax + ax.normalize_or_zero() * pad,
        ay + ay.normalize_or_zero() * pad,
    );
    if n == Vec3::ZERO || !(pad.is_finite() && ex.is_finite() && ey.is_finite()) {
        return None;
    }
    let corners = std::array::from_fn(|k| {
        let s = |bit: usize| if k & bit != 0 { 1.0 } else { -1.0 };
        c + ex * s(1) + ey * s(2) + n * (pad * s(4))
    });
    // Each face as a quad (a, b, c, d) in order around it: triangles (a, b, c) and (a, c, d).
    let faces: [[u32; 4]; 6] = [
        [0, 1, 3, 2],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 3, 7, 6],
        [0, 2, 6, 4],
        [1, 3, 7, 5],
    ];
    let mut tris = [[0; 3]; 12];
    for (f, q) in faces.iter().enumerate() {
        tris[2 * f] = [q[0], q[1], q[2]];
        tris[2 * f + 1] = [q[0], q[2], q[3]];
    }
    Some((corners, tris))
}

/// A top-level rectangle traced by Embree as the thin box of [`rectangle_slab`] around it,
/// with Embree's own triangle intersector (no user-geometry callback: ~270 of ~5,000
/// instructions per sample on the million-triangle scene went to the callbacks), and a
/// filter function on the box's hits that decides with the rectangle's exact intersection
/// ([`PlanarData::hit`], the callbacks' and tier A's arithmetic) what the user geometry would
/// have reported: the box contains every point the exact test can accept, by a margin far
/// above rounding, so every ray the exact test hits crosses one of its faces, and each
/// crossing is filtered. The ray's interval comes from what groove stores in the ray and hit:
/// - the query's tmax, in the ray's `id` (Embree copies it into its packets; [`EmbreeScene::ray`]);
/// - the t of the hit found so far, when the hit came from a user geometry or a rectangle (their
///   callbacks and this filter store it in the hit's `Ng_x`, which groove reads nowhere else),
///   with the callbacks' tie rule ([`tie_tfar`]). A hit found so far on a triangle mesh, curve or
///   instance has no exact t groove knows (Embree's filter sees tfar already set to the
///   candidate's): the filter then accepts the rectangle's hit marked [`UNSURE`], and the query
///   settles it afterwards by tracing again up to the rectangle's t ([`EmbreeScene::settle`]).
///
/// Reported like the user geometry: the rectangle's t, primitive 0, zero barycentrics.
struct RectSlab {
    exact: PlanarData,
    /// Per top-level geometry id: whether its hits store their t in `Ng_x` (`EmbreeScene::known`).
    known: *const [bool],
}

/// Whether the top-level rectangles of `geoms` are traced as [`RectSlab`]s: when the level has
/// triangles and no user geometry but rectangles. Embree keeps one BVH per geometry type and
/// traverses each: there the slabs remove the user-geometry BVH (and the callbacks of every
/// ray that reaches a rectangle's bounds, e.g. each shadow ray toward a rectangular light)
/// without adding a triangle BVH. Elsewhere they were measured slower (`docs/bench/README.md`,
/// fourteenth session, h3): a scene of user geometries gains a second BVH, and a ray that hits
/// a rectangle costs Embree's filtered triangle epilog, about twice a callback.
fn slabs_pay(geoms: &[GeomDesc]) -> bool {
    geoms
        .iter()
        .any(|g| matches!(g, GeomDesc::Triangles { .. }))
        && geoms.iter().all(|g| {
            matches!(
                g,
                GeomDesc::Triangles { .. }
                    | GeomDesc::Rectangle { .. }
                    | GeomDesc::Curves(_)
                    | GeomDesc::Empty
            )
        })
}

/// The primitive id a rectangle's filter gives a hit it accepted over a hit of unknown t.
const UNSURE: u32 = 1;

/// Word index of the ray's `id` (the query's tmax).
const RAY_ID: usize = 10;

/// The rectangle's intersection filter (nearest hits).
unsafe extern "C" fn rect_intersect_filter(args: *const RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes a ray-hit packet and a candidate hit packet of width N with N valid
    // flags (Embree 3 API, "RTCFilterFunctionN"; for nearest-hit queries `ray` points to the
    // ray-hit, whose hit is the one found so far); the user pointer is the scene's boxed
    // `RectSlab`, whose `known` lives as long as the scene.
    unsafe {
        let a = &*args;
        let slab = &*(a.geometryUserPtr as *const RectSlab);
        let known = &*slab.known;
        each_valid_lane(a.valid, a.ray as *mut u32, a.N as usize, |r| {
            let cand = Lane {
                base: a.hit as *mut u32,
                ..r
            };
            let geom = cand.get(GEOM_ID).to_bits();
            let so_far = r.hit();
            let (hit_geom, hit_inst) =
                (so_far.get(GEOM_ID).to_bits(), so_far.get(INST_ID).to_bits());
            let tmax = f32::from_bits(r.get(RAY_ID).to_bits());
            let (tfar, unsure) = if hit_geom == u32::MAX {
                (tmax, false)
            } else if hit_inst == u32::MAX && known.get(hit_geom as usize) == Some(&true) {
                let t = so_far.get(NG_X);
                let flat = cand.get(INST_ID).to_bits() == u32::MAX;
                if flat && geom < hit_geom && (0.0..f32::INFINITY).contains(&t) {
                    (f32::from_bits(t.to_bits() + 1), false)
                } else {
                    (t, false)
                }
            } else {
                (tmax, true)
            };
            let (o, d) = (r.vec(ORG_X), r.vec(DIR_X));
            match slab.exact.hit(o, d, r.get(TNEAR), tfar) {
                Some(h) => {
                    r.set(TFAR, h.t.to_bits());
                    cand.set(NG_X, h.t.to_bits());
                    cand.set(HIT_U, 0);
                    cand.set(HIT_V, 0);
                    cand.set(PRIM_ID, if unsure { UNSURE } else { 0 });
                }
                None => *a.valid.add(r.i) = 0,
            }
        });
    }
}

/// The rectangle's occlusion filter: the exact test over (tnear, the query's tmax).
unsafe extern "C" fn rect_occluded_filter(args: *const RTCFilterFunctionNArguments) {
    // SAFETY: as in `rect_intersect_filter`, with a ray packet.
    unsafe {
        let a = &*args;
        let slab = &*(a.geometryUserPtr as *const RectSlab);
        each_valid_lane(a.valid, a.ray as *mut u32, a.N as usize, |r| {
            let tmax = f32::from_bits(r.get(RAY_ID).to_bits());
            if slab
                .exact
                .hit(r.vec(ORG_X), r.vec(DIR_X), r.get(TNEAR), tmax)
                .is_none()
            {
                *a.valid.add(r.i) = 0;
            }
        });
    }
}

/// What the callbacks of a disk or rectangle need, owned by the scene (Embree holds a raw
/// pointer to it).
struct PlanarData {
    /// The unit square [−1,1]² instead of the unit disk.
    square: bool,
    space: ObjectSpace,
}

impl PlanarData {
    fn new(to_world: &Mat4, square: bool) -> PlanarData {
        let ax = to_world.transform_vector3(Vec3::X);
        let ay = to_world.transform_vector3(Vec3::Y);
        // Exact bounds of the parallelogram c ± ax ± ay, or of the ellipse c + ax cos φ + ay sin φ.
        let ext = if square {
            ax.abs() + ay.abs()
        } else {
            Vec3::new(ax.x.hypot(ay.x), ax.y.hypot(ay.y), ax.z.hypot(ay.z))
        };
        PlanarData {
            square,
            space: ObjectSpace::new(to_world, ext),
        }
    }
}

impl UserShape for PlanarData {
    fn bounds(&self) -> (Vec3, Vec3) {
        (self.space.lower, self.space.upper)
    }

    fn hit(&self, o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> Option<UserHit> {
        let (ol, dl) = self.space.ray(o, d);
        let t = plane_t(ol, dl);
        let l = ol + dl * t;
        let inside = if self.square {
            l.x.abs() <= 1.0 && l.y.abs() <= 1.0
        } else {
            l.x * l.x + l.y * l.y <= 1.0
        };
        (t > tnear && t < tfar && inside).then_some(UserHit::at(t))
    }
}

/// One face of a [`BoxData`]: a corner and the two edges from it, each divided by its squared
/// length (so a dot product gives the fraction along the edge), and the face's mesh index.
#[derive(Clone, Copy)]
struct BoxFace {
    corner: Vec3,
    edge1: Vec3,
    edge3: Vec3,
    index: u32,
}

/// What the callbacks of a box need: the box [−1,1]³ of object space under `to_world`, with its
/// faces indexed by `2·axis + (side > 0)`.
struct BoxData {
    faces: [BoxFace; 6],
    space: ObjectSpace,
}

impl BoxData {
    fn new(to_world: &Mat4, faces: &[[[f32; 3]; 4]; 6]) -> BoxData {
        let mut slots = [BoxFace {
            corner: Vec3::ZERO,
            edge1: Vec3::ZERO,
            edge3: Vec3::ZERO,
            index: 0,
        }; 6];
        for (f, c) in faces.iter().enumerate() {
            let [c0, c1, c2, c3] = c.map(Vec3::from_array);
            // The face's plane: the coordinate all four corners share.
            let centre = (c0 + c1 + c2 + c3) * 0.25;
            let axis = (0..3).max_by(|&a, &b| centre[a].abs().total_cmp(&centre[b].abs()));
            let axis = axis.unwrap_or(0);
            let (e1, e3) = (c1 - c0, c3 - c0);
            slots[2 * axis + usize::from(centre[axis] > 0.0)] = BoxFace {
                corner: c0,
                edge1: e1 / e1.length_squared(),
                edge3: e3 / e3.length_squared(),
                index: f as u32,
            };
        }
        // Exact bounds of the parallelepiped c ± ax ± ay ± az.
        let ext = [Vec3::X, Vec3::Y, Vec3::Z]
            .map(|a| to_world.transform_vector3(a).abs())
            .into_iter()
            .sum();
        BoxData {
            faces: slots,
            space: ObjectSpace::new(to_world, ext),
        }
    }
}

impl UserShape for BoxData {
    fn bounds(&self) -> (Vec3, Vec3) {
        (self.space.lower, self.space.upper)
    }

    /// The slab test in object space (the affine map keeps the ray parameter), then the hit
    /// point's fractions (a, b) along the face's two edges pick the triangle and its
    /// barycentrics: (0,1,2) holds a ≥ b with (u, v) = (a − b, b); (3,0,2) holds a < b with
    /// (u, v) = (1 − b, a).
    fn hit(&self, o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> Option<UserHit> {
        let (ol, dl) = self.space.ray(o, d);
        let inv = dl.recip();
        let t_lo = (Vec3::NEG_ONE - ol) * inv;
        let t_hi = (Vec3::ONE - ol) * inv;
        let near = t_lo.min(t_hi);
        let far = t_lo.max(t_hi);
        let enter = near.max_element();
        let exit = far.min_element();
        // (A NaN bound fails both interval tests below.)
        if enter > exit {
            return None;
        }
        // The entry face is on the side the ray comes from, the exit face on the side it goes to.
        let (t, axis, positive) = if enter > tnear && enter < tfar {
            let axis = if near.x == enter {
                0
            } else if near.y == enter {
                1
            } else {
                2
            };
            (enter, axis, dl[axis] < 0.0)
        } else if exit > tnear && exit < tfar {
            let axis = if far.x == exit {
                0
            } else if far.y == exit {
                1
            } else {
                2
            };
            (exit, axis, dl[axis] > 0.0)
        } else {
            return None;
        };
        let face = &self.faces[2 * axis + usize::from(positive)];
        let r = ol + dl * t - face.corner;
        let a = r.dot(face.edge1).clamp(0.0, 1.0);
        let b = r.dot(face.edge3).clamp(0.0, 1.0);
        let (prim, u, v) = if a >= b {
            (2 * face.index, a - b, b)
        } else {
            (2 * face.index + 1, 1.0 - b, a)
        };
        Some(UserHit { t, prim, u, v })
    }
}

/// The cylinder's callbacks use its own exact intersection (f64 in object space).
impl UserShape for Cylinder {
    fn bounds(&self) -> (Vec3, Vec3) {
        let (lo, hi) = Cylinder::bounds(self);
        let pad = (lo.abs().max(hi.abs()) + (hi - lo)) * 1e-6;
        (lo - pad, hi + pad)
    }

    fn hit(&self, o: Vec3, d: Vec3, tnear: f32, tfar: f32) -> Option<UserHit> {
        Cylinder::hit(self, o, d, tnear, tfar).map(UserHit::at)
    }
}

unsafe extern "C" fn user_bounds<T: UserPrims>(args: *const RTCBoundsFunctionArguments) {
    // SAFETY: Embree passes valid arguments; the user pointer is the scene's boxed `T`.
    unsafe {
        let a = &*args;
        let shape = &*(a.geometryUserPtr as *const T);
        let (lower, upper) = shape.prim_bounds(a.primID);
        let b = &mut *a.bounds_o;
        (b.lower_x, b.lower_y, b.lower_z) = (lower.x, lower.y, lower.z);
        (b.upper_x, b.upper_y, b.upper_z) = (upper.x, upper.y, upper.z);
    }
}

/// Lane `i` of an Embree ray or ray-hit packet of width `n`: structure of arrays, field `f` of
/// lane `i` at 32-bit word `f·n + i`, the hit's fields after the ray's 12 (Embree 3 API,
/// "RTCRayN", "RTCHitN", "RTCRayHitN"). Width 1 is `RTCRay`/`RTCRayHit`'s own layout, so one
/// accessor serves `rtcIntersect1` and the 8-wide queries alike.
#[derive(Clone, Copy)]
struct Lane {
    base: *mut u32,
    n: usize,
    i: usize,
}

/// Word indices of the ray's fields ...
const ORG_X: usize = 0;
const TNEAR: usize = 3;
const DIR_X: usize = 4;
const TFAR: usize = 8;
/// ... and of the hit's, counted from the hit's start.
const NG_X: usize = 0;
const HIT_U: usize = 3;
const HIT_V: usize = 4;
const PRIM_ID: usize = 5;
const GEOM_ID: usize = 6;
const INST_ID: usize = 7;
/// Words of a ray: the hit of a ray-hit packet starts at word `RAY_WORDS·n`.
const RAY_WORDS: usize = 12;

impl Lane {
    /// # Safety
    /// `base` points to a packet of width `n` (ray or ray-hit, as used) and `i < n`.
    unsafe fn get(self, field: usize) -> f32 {
        // SAFETY: in bounds by the constructor's contract.
        unsafe { f32::from_bits(*self.base.add(field * self.n + self.i)) }
    }
    unsafe fn set(self, field: usize, bits: u32) {
        // SAFETY: as in `get`.
        unsafe { *self.base.add(field * self.n + self.i) = bits }
    }
    unsafe fn vec(self, field: usize) -> Vec3 {
        // SAFETY: as in `get`.
        unsafe { Vec3::new(self.get(field), self.get(field + 1), self.get(field + 2)) }
    }
    /// The same lane of the hit that follows this ray in a ray-hit packet.
    fn hit(self) -> Lane {
        Lane {
            // SAFETY-free arithmetic: only dereferenced under the callers' contracts.
            base: self.base.wrapping_add(RAY_WORDS * self.n),
            ..self
        }
    }
}

/// Calls `f` with each lane of the width-`n` packet at `base` whose `valid` flag is set.
///
/// # Safety
/// `valid` points to `n` flags and `base` to a packet of width `n` (see [`Lane`]).
unsafe fn each_valid_lane(valid: *const i32, base: *mut u32, n: usize, mut f: impl FnMut(Lane)) {
    for i in 0..n {
        // SAFETY: i < n, the caller's contract.
        if unsafe { *valid.add(i) } != 0 {
            f(Lane { base, n, i });
        }
    }
}

unsafe extern "C" fn user_intersect<T: UserPrims>(args: *const RTCIntersectFunctionNArguments) {
    // SAFETY: Embree passes a ray-hit packet of width N with N valid flags (Embree 3 API,
    // "rtcSetGeometryIntersectFunction"); the user pointer is the scene's boxed `T`.
    unsafe {
        let a = &*args;
        let shape = &*(a.geometryUserPtr as *const T);
        if a.N == 1 {
            // The renderer's single rays, with RTCRayHit's typed layout (measurably cheaper
            // than the lane arithmetic below).
            if *a.valid == 0 {
                return;
            }
            let rh = &mut *(a.rayhit as *mut RTCRayHit);
            let r = &rh.ray;
            let o = Vec3::new(r.org_x, r.org_y, r.org_z);
            let d = Vec3::new(r.dir_x, r.dir_y, r.dir_z);
            let tfar = tie_tfar(r.tfar, a.geomID, rh.hit.geomID, rh.hit.instID[0], a);
            if let Some(h) = shape.prim_hit(a.primID, o, d, r.tnear, tfar) {
                rh.ray.tfar = h.t;
                // The t, for the rectangles' filter (`RectSlab`).
                rh.hit.Ng_x = h.t;
                rh.hit.u = h.u;
                rh.hit.v = h.v;
                rh.hit.primID = h.prim;
                rh.hit.geomID = a.geomID;
                rh.hit.instID = (*a.context).instID;
            }
            return;
        }
        user_intersect_n(a, shape);
    }
}

/// The far end of the open interval a user geometry's callback accepts: the ray's `tfar`, or
/// just past it when the current hit (shape `hit_geom`, seen through no instance) has a higher
/// index than this shape (`geom`, also not instanced), so that of two shapes hit at the same t
/// the lower index wins whatever order Embree tests them in, as in tier A (`brute.rs`).
///
/// # Safety
/// `a.context` is the valid context Embree passes.
#[inline(always)]
unsafe fn tie_tfar(
    tfar: f32,
    geom: u32,
    hit_geom: u32,
    hit_inst: u32,
    a: &RTCIntersectFunctionNArguments,
) -> f32 {
    // SAFETY: the caller's contract.
    let inst = unsafe { (*a.context).instID[0] };
    let flat = inst == u32::MAX && hit_inst == u32::MAX;
    if flat && hit_geom != u32::MAX && geom < hit_geom && (0.0..f32::INFINITY).contains(&tfar) {
        // The next float up (a hit's t is finite and not negative).
        f32::from_bits(tfar.to_bits() + 1)
    } else {
        tfar
    }
}

/// [`user_intersect`] of a packet (out of line: the single-ray path stays small).
///
/// # Safety
/// As for `user_intersect`.
#[inline(never)]
unsafe fn user_intersect_n<T: UserPrims>(a: &RTCIntersectFunctionNArguments, shape: &T) {
    // SAFETY: the caller's contract.
    unsafe {
        each_valid_lane(a.valid, a.rayhit as *mut u32, a.N as usize, |r| {
            // groove reads no normal from Embree: Ng_x holds the hit's t for the rectangles'
            // filter (`RectSlab`), Ng_y and Ng_z stay unset.
            let hit = r.hit();
            let (geom, inst) = (hit.get(GEOM_ID).to_bits(), hit.get(INST_ID).to_bits());
            let tfar = tie_tfar(r.get(TFAR), a.geomID, geom, inst, a);
            let (o, d) = (r.vec(ORG_X), r.vec(DIR_X));
            if let Some(h) = shape.prim_hit(a.primID, o, d, r.get(TNEAR), tfar) {
                r.set(TFAR, h.t.to_bits());
                hit.set(NG_X, h.t.to_bits());
                hit.set(HIT_U, h.u.to_bits());
                hit.set(HIT_V, h.v.to_bits());
                hit.set(PRIM_ID, h.prim);
                hit.set(GEOM_ID, a.geomID);
                hit.set(INST_ID, (*a.context).instID[0]);
            }
        });
    }
}

unsafe extern "C" fn user_occluded<T: UserPrims>(args: *const RTCOccludedFunctionNArguments) {
    // SAFETY: as in `user_intersect`, with a ray packet of width N.
    unsafe {
        let a = &*args;
        let shape = &*(a.geometryUserPtr as *const T);
        if a.N == 1 {
            // As in `user_intersect`: RTCRay's typed layout for single rays.
            if *a.valid == 0 {
                return;
            }
            let r = &mut *(a.ray as *mut RTCRay);
            let o = Vec3::new(r.org_x, r.org_y, r.org_z);
            let d = Vec3::new(r.dir_x, r.dir_y, r.dir_z);
            if shape.prim_hit(a.primID, o, d, r.tnear, r.tfar).is_some() {
                r.tfar = f32::NEG_INFINITY;
            }
            return;
        }
        user_occluded_n(a, shape);
    }
}

/// [`user_occluded`] of a packet (out of line, as [`user_intersect_n`]).
///
/// # Safety
/// As for `user_occluded`.
#[inline(never)]
unsafe fn user_occluded_n<T: UserPrims>(a: &RTCOccludedFunctionNArguments, shape: &T) {
    // SAFETY: the caller's contract.
    unsafe {
        each_valid_lane(a.valid, a.ray as *mut u32, a.N as usize, |r| {
            if shape
                .prim_hit(
                    a.primID,
                    r.vec(ORG_X),
                    r.vec(DIR_X),
                    r.get(TNEAR),
                    r.get(TFAR),
                )
                .is_some()
            {
                r.set(TFAR, f32::NEG_INFINITY.to_bits());
            }
        });
    }
}

/// A new user geometry of `shape.count()` primitives intersected by `T`'s callbacks; `shape` must
/// stay at its address for the life of the scene (the caller keeps it boxed).
///
/// # Safety
/// `device` is a valid Embree device.
unsafe fn user_geometry<T: UserPrims>(device: RTCDevice, shape: &T) -> Option<RTCGeometry> {
    // SAFETY: plain C calls on a valid device; the user pointer outlives the geometry (above).
    unsafe {
        let geom = rtcNewGeometry(device, RTCGeometryType::USER);
        if geom.is_null() {
            return None;
        }
        rtcSetGeometryUserPrimitiveCount(geom, shape.count());
        rtcSetGeometryUserData(geom, shape as *const T as *mut c_void);
        rtcSetGeometryBoundsFunction(geom, Some(user_bounds::<T>), ptr::null_mut());
        rtcSetGeometryIntersectFunction(geom, Some(user_intersect::<T>));
        rtcSetGeometryOccludedFunction(geom, Some(user_occluded::<T>));
        Some(geom)
    }
}

/// The curves of a `linearcurve` or `bsplinecurve` shape, borrowed from the shape.
#[derive(Clone, Copy)]
pub(crate) struct CurveDesc<'a> {
    /// Cubic uniform B-spline segments (4 control points each) instead of linear ones (2).
    pub bspline: bool,
    /// World-space control points (x, y, z, radius).
    pub points: &'a [[f32; 4]],
    /// The first control point of each segment (Embree's index buffer).
    pub segments: &'a [u32],
}

/// Embree's curve type for Mitsuba's curve shapes: Mitsuba 3.9.1 (`src/render/scene_embree.inl`)
/// hands both to Embree as `RTC_GEOMETRY_TYPE_ROUND_BSPLINE_CURVE` or
/// `RTC_GEOMETRY_TYPE_ROUND_LINEAR_CURVE` (true tubes; the linear ones are cones joined and
/// capped by spheres, Embree finding a segment's neighbours from consecutive indices), with a
/// float4 (x, y, z, r) vertex buffer and one uint index per segment.
///
/// Mitsuba builds its Embree with `EMBREE_BACKFACE_CULLING_CURVES`, so a curve is never hit
/// from inside; Debian's Embree is built without it, so unless the device reports it a filter
/// rejects the hits whose geometric normal faces along the ray, in both queries.
///
/// # Safety
/// `device` is a valid Embree device.
unsafe fn curve_geometry(device: RTCDevice, c: &CurveDesc) -> Result<RTCGeometry, &'static str> {
    let kind = if c.bspline {
        RTCGeometryType::ROUND_BSPLINE_CURVE
    } else {
        RTCGeometryType::ROUND_LINEAR_CURVE
    };
    // SAFETY: plain C calls on a valid device; the buffers are Embree's, filled within their
    // allocated length.
    unsafe {
        let culled =
            rtcGetDeviceProperty(device, RTCDeviceProperty::BACKFACE_CULLING_CURVES_ENABLED);
        let filters = rtcGetDeviceProperty(device, RTCDeviceProperty::FILTER_FUNCTION_SUPPORTED);
        if culled == 0 && filters == 0 {
            return Err("this Embree has neither curve backface culling nor filter functions");
        }
        let geom = rtcNewGeometry(device, kind);
        if geom.is_null() {
            return Err("rtcNewGeometry (curves) failed");
        }
        let vb = rtcSetNewGeometryBuffer(
            geom,
            RTCBufferType::VERTEX,
            0,
            RTCFormat::FLOAT4,
            16,
            c.points.len(),
        ) as *mut [f32; 4];
        let ib = rtcSetNewGeometryBuffer(
            geom,
            RTCBufferType::INDEX,
            0,
            RTCFormat::UINT,
            4,
            c.segments.len(),
        ) as *mut u32;
        if vb.is_null() || ib.is_null() {
            rtcReleaseGeometry(geom);
            return Err("curve buffer allocation failed");
        }
        std::slice::from_raw_parts_mut(vb, c.points.len()).copy_from_slice(c.points);
        std::slice::from_raw_parts_mut(ib, c.segments.len()).copy_from_slice(c.segments);
        if culled == 0 {
            rtcSetGeometryIntersectFilterFunction(geom, Some(cull_curve_backface));
            rtcSetGeometryOccludedFilterFunction(geom, Some(cull_curve_backface));
        }
        Ok(geom)
    }
}

/// Rejects a curve hit seen from inside (ray direction · geometric normal > 0), as Mitsuba's
/// own triangle backface filter does (`embree_backface_cull`).
unsafe extern "C" fn cull_curve_backface(args: *const RTCFilterFunctionNArguments) {
    // SAFETY: Embree passes a ray and a hit packet of width N with N valid flags (Embree 3 API,
    // "RTCFilterFunctionN").
    unsafe {
        let a = &*args;
        each_valid_lane(a.valid, a.ray as *mut u32, a.N as usize, |r| {
            let h = Lane {
                base: a.hit as *mut u32,
                ..r
            };
            if r.vec(DIR_X).dot(h.vec(NG_X)) > 0.0 {
                *a.valid.add(r.i) = 0;
            }
        });
    }
}

/// A committed Embree scene with its device.
pub(crate) struct EmbreeScene {
    /// The AVX2 token where the CPU has it: the 8-wide packets' rays are laid out in lanes.
    #[cfg(target_arch = "x86_64")]
    avx: Option<crate::lane::Avx2>,
    device: RTCDevice,
    scene: RTCScene,
    /// The committed scenes of the shape groups, each instanced by one or more
    /// `RTC_GEOMETRY_TYPE_INSTANCE` geometries of `scene` (released in Drop, after `scene`).
    groups: Vec<RTCScene>,
    /// Messages reported by Embree's error callback (the callback's user pointer points here).
    _errors: Box<Mutex<Vec<String>>>,
    /// Per top-level geometry id: a rectangle traced as a [`RectSlab`].
    rects: Vec<bool>,
    /// Per top-level geometry id: its hits store their t in `Ng_x` (user geometries and
    /// rectangles; read by [`rect_intersect_filter`]).
    known: Box<[bool]>,
    #[allow(clippy::vec_box)]
    _slabs: Vec<Box<RectSlab>>,
    /// User data of the user geometries; boxed so the addresses Embree holds stay valid while
    /// the Vecs grow (hence the allow: the Box is what pins each address).
    #[allow(clippy::vec_box)]
    _planes: Vec<Box<PlanarData>>,
    #[allow(clippy::vec_box)]
    _spheres: Vec<Box<SphereData>>,
    #[allow(clippy::vec_box)]
    _boxes: Vec<Box<BoxData>>,
    #[allow(clippy::vec_box)]
    _cylinders: Vec<Box<Cylinder>>,
    /// The SDF grids (shared with their shapes; the `Arc` pins each address).
    _sdfgrids: Vec<std::sync::Arc<SdfGrid>>,
}

// SAFETY: the scene is committed and never mutated afterwards; Embree documents traversal
// (rtcIntersect1/rtcOccluded1) of a committed scene as thread-safe. The handles are released
// exactly once, in Drop.
unsafe impl Send for EmbreeScene {}
unsafe impl Sync for EmbreeScene {}

unsafe extern "C" fn on_error(user: *mut c_void, code: RTCError, msg: *const c_char) {
    if user.is_null() {
        return;
    }
    // SAFETY: `user` is the address of the boxed Mutex owned by the EmbreeScene, which outlives
    // the device (the device is released first in Drop).
    let errors = unsafe { &*(user as *const Mutex<Vec<String>>) };
    let text = if msg.is_null() {
        String::new()
    } else {
        // SAFETY: Embree passes a NUL-terminated string valid for the duration of the call.
        unsafe { CStr::from_ptr(msg) }
            .to_string_lossy()
            .into_owned()
    };
    if let Ok(mut e) = errors.lock() {
        e.push(format!("{code:?}: {text}"));
    }
}

impl EmbreeScene {
    /// Builds and commits a scene; geometry `i` gets Embree id `i`.
    #[cfg(test)]
    pub(crate) fn build(geoms: &[GeomDesc]) -> Result<EmbreeScene, String> {
        Self::build_instanced_with(geoms, &[], &[], false)
    }

    /// Builds and commits a scene with instancing: geometry `i` of `geoms` gets Embree id `i`;
    /// each of `groups` becomes its own committed scene (geometry `j` of a group has id `j`
    /// there), stored once however often it is instanced; instance `k` of `instances` gets id
    /// `geoms.len() + k` in the top-level scene. A hit through instance `k` reports that id as
    /// [`Hit::inst`], and the group's geometry and primitive as `geom` and `prim` (Embree 3 API,
    /// `RTC_GEOMETRY_TYPE_INSTANCE`); without an instance `inst` is `u32::MAX`.
    /// `rect_slabs`: the top-level rectangles become [`RectSlab`]s whatever the scene holds
    /// (else only where [`slabs_pay`]).
    pub(crate) fn build_instanced_with(
        geoms: &[GeomDesc],
        groups: &[Vec<GeomDesc>],
        instances: &[InstanceDesc],
        rect_slabs: bool,
    ) -> Result<EmbreeScene, String> {
        let errors = Box::new(Mutex::new(Vec::new()));
        // SAFETY: plain C calls; every handle is checked for null before use, and ownership of
        // the device/scene passes to the returned value (released in Drop, also on error paths
        // because `this` is constructed before anything can fail).
        unsafe {
            let device = rtcNewDevice(EMBREE_CONFIG.as_ptr());
            if device.is_null() {
                return Err("Embree: rtcNewDevice failed (unsupported CPU?)".into());
            }
            rtcSetDeviceErrorFunction(
                device,
                Some(on_error),
                &*errors as *const Mutex<Vec<String>> as *mut c_void,
            );
            let scene = rtcNewScene(device);
            let mut this = EmbreeScene {
                #[cfg(target_arch = "x86_64")]
                avx: crate::lane::Avx2::detect(),
                device,
                scene,
                groups: Vec::new(),
                _errors: errors,
                rects: Vec::new(),
                known: Box::new([]),
                _slabs: Vec::new(),
                _planes: Vec::new(),
                _spheres: Vec::new(),
                _boxes: Vec::new(),
                _cylinders: Vec::new(),
                _sdfgrids: Vec::new(),
            };
            if scene.is_null() {
                return Err(this.error_text("rtcNewScene failed"));
            }
            // Embree wants each instanced scene committed before the instances that use it.
            for g in groups {
                let group = rtcNewScene(device);
                if group.is_null() {
                    return Err(this.error_text("rtcNewScene failed"));
                }
                this.groups.push(group);
                Self::attach(&mut this, group, g, false, false)?;
                rtcCommitScene(group);
            }
            Self::attach(&mut this, scene, geoms, true, rect_slabs)?;
            Self::attach_instances(&mut this, geoms.len(), instances)?;
            rtcCommitScene(scene);
            let code = rtcGetDeviceError(device);
            if code != RTCError::NONE {
                return Err(this.error_text(&format!("scene build failed ({code:?})")));
            }
            if let Ok(e) = this._errors.lock() {
                if !e.is_empty() {
                    return Err(format!("Embree: {}", e.join("; ")));
                }
            }
            Ok(this)
        }
    }

    /// Attaches `geoms` to `scene` (a scene of `this`'s device), geometry `i` with id `i`;
    /// `top`: `scene` is the top-level scene (whose rectangles may become [`RectSlab`]s, always
    /// with `rect_slabs`).
    ///
    /// # Safety
    /// `scene` is a valid, uncommitted scene of `this.device`.
    unsafe fn attach(
        this: &mut EmbreeScene,
        scene: RTCScene,
        geoms: &[GeomDesc],
        top: bool,
        rect_slabs: bool,
    ) -> Result<(), String> {
        // SAFETY: plain C calls on valid handles (the caller's contract); Embree copies the
        // triangle buffers, and the user geometries' data is kept boxed in `this`.
        unsafe {
            let device = this.device;
            // Without filter functions a rectangle stays a user geometry; see `slabs_pay`.
            let slabs = top
                && (rect_slabs || slabs_pay(geoms))
                && rtcGetDeviceProperty(device, RTCDeviceProperty::FILTER_FUNCTION_SUPPORTED) != 0;
            if top {
                this.known = geoms
                    .iter()
                    .map(|g| {
                        !matches!(
                            g,
                            GeomDesc::Triangles { .. } | GeomDesc::Curves(_) | GeomDesc::Empty
                        )
                    })
                    .collect();
                this.rects = vec![false; geoms.len()];
            }
            for (id, g) in geoms.iter().enumerate() {
                let slab = match g {
                    GeomDesc::Rectangle { to_world } if slabs => {
                        rectangle_slab(to_world).map(|mesh| (mesh, PlanarData::new(to_world, true)))
                    }
                    _ => None,
                };
                let slab_desc;
                let g = match &slab {
                    Some(((corners, tris), _)) => {
                        slab_desc = GeomDesc::Triangles {
                            positions: corners,
                            indices: tris,
                        };
                        &slab_desc
                    }
                    None => g,
                };
                let geom = match g {
                    GeomDesc::Empty => continue,
                    GeomDesc::Triangles { positions, indices } => {
                        let geom = rtcNewGeometry(device, RTCGeometryType::TRIANGLE);
                        if geom.is_null() {
                            return Err(this.error_text("rtcNewGeometry failed"));
                        }
                        let vb = rtcSetNewGeometryBuffer(
                            geom,
                            RTCBufferType::VERTEX,
                            0,
                            RTCFormat::FLOAT3,
                            12,
                            positions.len(),
                        ) as *mut f32;
                        let ib = rtcSetNewGeometryBuffer(
                            geom,
                            RTCBufferType::INDEX,
                            0,
                            RTCFormat::UINT3,
                            12,
                            indices.len(),
                        ) as *mut u32;
                        if vb.is_null() || ib.is_null() {
                            rtcReleaseGeometry(geom);
                            return Err(this.error_text("geometry buffer allocation failed"));
                        }
                        // SAFETY: Embree allocated `len` items of the given stride (plus padding).
                        let vs = std::slice::from_raw_parts_mut(vb, positions.len() * 3);
                        for (k, p) in positions.iter().enumerate() {
                            vs[3 * k..3 * k + 3].copy_from_slice(&p.to_array());
                        }
                        let is = std::slice::from_raw_parts_mut(ib, indices.len() * 3);
                        for (k, t) in indices.iter().enumerate() {
                            is[3 * k..3 * k + 3].copy_from_slice(t);
                        }
                        geom
                    }
                    GeomDesc::Sphere { center, radius } => {
                        let data = Box::new(SphereData {
                            center: *center,
                            radius: *radius,
                        });
                        let geom = user_geometry(device, &*data)
                            .ok_or_else(|| this.error_text("rtcNewGeometry failed"))?;
                        this._spheres.push(data);
                        geom
                    }
                    GeomDesc::Disk { to_world } | GeomDesc::Rectangle { to_world } => {
                        let square = matches!(g, GeomDesc::Rectangle { .. });
                        let data = Box::new(PlanarData::new(to_world, square));
                        let geom = user_geometry(device, &*data)
                            .ok_or_else(|| this.error_text("rtcNewGeometry failed"))?;
                        this._planes.push(data);
                        geom
                    }
                    GeomDesc::Box { to_world, faces } => {
                        let data = Box::new(BoxData::new(to_world, faces));
                        let geom = user_geometry(device, &*data)
                            .ok_or_else(|| this.error_text("rtcNewGeometry failed"))?;
                        this._boxes.push(data);
                        geom
                    }
                    GeomDesc::Cylinder(c) => {
                        let data = Box::new((*c).clone());
                        let geom = user_geometry(device, &*data)
                            .ok_or_else(|| this.error_text("rtcNewGeometry failed"))?;
                        this._cylinders.push(data);
                        geom
                    }
                    GeomDesc::Curves(c) => {
                        curve_geometry(device, c).map_err(|e| this.error_text(e))?
                    }
                    GeomDesc::SdfGrid(g) => {
                        let geom = user_geometry(device, &**g)
                            .ok_or_else(|| this.error_text("rtcNewGeometry failed"))?;
                        this._sdfgrids.push(g.clone());
                        geom
                    }
                };
                if let Some((_, exact)) = slab {
                    let data = Box::new(RectSlab {
                        exact,
                        known: &*this.known as *const [bool],
                    });
                    rtcSetGeometryUserData(geom, &*data as *const RectSlab as *mut c_void);
                    rtcSetGeometryIntersectFilterFunction(geom, Some(rect_intersect_filter));
                    rtcSetGeometryOccludedFilterFunction(geom, Some(rect_occluded_filter));
                    this._slabs.push(data);
                    this.rects[id] = true;
                }
                rtcCommitGeometry(geom);
                rtcAttachGeometryByID(scene, geom, id as u32);
                // The scene holds its own reference.
                rtcReleaseGeometry(geom);
            }
            Ok(())
        }
    }

    /// Attaches instance `k` of `instances` to the top-level scene with id `base + k`: an
    /// `RTC_GEOMETRY_TYPE_INSTANCE` of the group's committed scene under its `to_world`, given
    /// as a column-major 3×4 matrix (Embree copies it).
    ///
    /// # Safety
    /// `this.scene` is uncommitted and every group scene of `this` is committed.
    unsafe fn attach_instances(
        this: &mut EmbreeScene,
        base: usize,
        instances: &[InstanceDesc],
    ) -> Result<(), String> {
        for (k, inst) in instances.iter().enumerate() {
            let Some(&group) = this.groups.get(inst.group as usize) else {
                return Err(format!("Embree: instance {k} names a missing group"));
            };
            let id = u32::try_from(base + k)
                .ok()
                .filter(|&id| id != u32::MAX)
                .ok_or_else(|| "Embree: too many geometries".to_string())?;
            let m = inst.to_world;
            let xfm: [f32; 12] = [
                m.x_axis.x, m.x_axis.y, m.x_axis.z, m.y_axis.x, m.y_axis.y, m.y_axis.z, m.z_axis.x,
                m.z_axis.y, m.z_axis.z, m.w_axis.x, m.w_axis.y, m.w_axis.z,
            ];
            // SAFETY: valid device and committed group scene (the caller's contract); `xfm`
            // lives through the call, which copies it.
            unsafe {
                let geom = rtcNewGeometry(this.device, RTCGeometryType::INSTANCE);
                if geom.is_null() {
                    return Err(this.error_text("rtcNewGeometry (instance) failed"));
                }
                rtcSetGeometryInstancedScene(geom, group);
                rtcSetGeometryTransform(
                    geom,
                    0,
                    RTCFormat::FLOAT3X4_COLUMN_MAJOR,
                    xfm.as_ptr() as *const c_void,
                );
                rtcCommitGeometry(geom);
                rtcAttachGeometryByID(this.scene, geom, id);
                rtcReleaseGeometry(geom);
            }
        }
        Ok(())
    }

    fn error_text(&self, what: &str) -> String {
        let extra = self
            ._errors
            .lock()
            .map(|e| e.join("; "))
            .unwrap_or_default();
        format!("Embree: {what} {extra}").trim_end().to_string()
    }

    fn context() -> RTCIntersectContext {
        // What the C inline rtcInitIntersectContext does: incoherent rays, no filter, no instance.
        RTCIntersectContext {
            flags: RTCIntersectContextFlags(0),
            filter: None,
            instID: [u32::MAX],
        }
    }

    fn ray(o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> RTCRay {
        RTCRay {
            org_x: o.x,
            org_y: o.y,
            org_z: o.z,
            tnear: tmin,
            dir_x: d.x,
            dir_y: d.y,
            dir_z: d.z,
            time: 0.0,
            tfar: tmax,
            mask: u32::MAX,
            // The query's tmax, for the rectangles' filters (`RectSlab`).
            id: tmax.to_bits(),
            flags: 0,
        }
    }

    /// A ray with no hit yet (geometry id invalid).
    #[inline]
    fn ray_hit(o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> RTCRayHit {
        RTCRayHit {
            ray: Self::ray(o, d, tmin, tmax),
            hit: NO_HIT,
        }
    }

    /// Nearest hit with t in [tmin, tmax].
    pub(crate) fn intersect(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        let mut ctx = Self::context();
        let mut rh = Self::ray_hit(o, d, tmin, tmax);
        // SAFETY: the scene is committed; ctx and rh are valid, properly aligned locals.
        unsafe { rtcIntersect1(self.scene, &mut ctx, &mut rh) };
        (rh.hit.geomID != u32::MAX).then(|| {
            let hit = Hit {
                geom: rh.hit.geomID,
                prim: rh.hit.primID,
                t: rh.ray.tfar,
                u: rh.hit.u,
                v: rh.hit.v,
                inst: rh.hit.instID[0],
            };
            self.settle(hit, o, d, tmin)
        })
    }

    /// `hit`, found by a nearest-hit query of the ray `o + t·d` from `tmin`, as the callbacks
    /// would have found it: a rectangle's hit the filter accepted over a hit of unknown t
    /// ([`UNSURE`]) is checked by tracing again up to its t (Embree's triangles are closed at
    /// tfar, the rectangle's filter is not): a hit there is nearer, or as near and wins the
    /// tie unless it is a top-level shape of higher index (tier A's rule).
    #[inline(always)]
    fn settle(&self, mut hit: Hit, o: Vec3, d: Vec3, tmin: f32) -> Hit {
        if hit.prim == UNSURE
            && hit.inst == u32::MAX
            && self.rects.get(hit.geom as usize) == Some(&true)
        {
            hit.prim = 0;
            if let Some(x) = self.intersect(o, d, tmin, hit.t) {
                if !(x.t == hit.t && x.inst == u32::MAX && hit.geom < x.geom) {
                    return x;
                }
            }
        }
        hit
    }

    /// Whether anything is hit with t in [tmin, tmax].
    pub(crate) fn occluded(&self, o: Vec3, d: Vec3, tmin: f32, tmax: f32) -> bool {
        let mut ctx = Self::context();
        let mut r = Self::ray(o, d, tmin, tmax);
        // SAFETY: as in `intersect`.
        unsafe { rtcOccluded1(self.scene, &mut ctx, &mut r) };
        // Embree sets tfar to −∞ when the ray is occluded.
        r.tfar == f32::NEG_INFINITY
    }
}

/// A valid mask for the 8-wide queries, 32-byte aligned: Embree reads it with aligned AVX
/// loads, and the `embree3` crate's `ValidMaskN` is only 16-byte aligned (`align(16)`).
#[repr(C, align(32))]
struct Valid8([i32; 8]);

impl Valid8 {
    /// Lanes `0..n` valid (−1), the others not (0).
    fn first(n: usize) -> Valid8 {
        Valid8(std::array::from_fn(|i| if i < n { -1 } else { 0 }))
    }
}

impl EmbreeScene {
    /// Eight rays (or fewer: lanes past `n` are off; lane `k` is `ray(k)`) in Embree's packet
    /// layout, written as [`Self::set_rays8_fast`] writes them.
    #[inline(always)]
    fn ray8<'r>(&self, n: usize, ray: impl Fn(usize) -> &'r Ray) -> RTCRay8 {
        let mut p = EMPTY8.ray;
        self.set_rays8_fast(&mut p, n, ray);
        p
    }

    /// [`Self::set_rays8`], in lanes where the CPU has AVX2: each ray's row loaded whole, an
    /// 8×8 transpose, one store per field (~45 instructions a packet, where the fields ray by
    /// ray took ~18 a ray).
    #[inline(always)]
    fn set_rays8_fast<'r>(&self, p: &mut RTCRay8, n: usize, ray: impl Fn(usize) -> &'r Ray) {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            use crate::lane::{F32x8, Lane};
            return avx.run(
                #[inline(always)]
                || {
                    // Lanes past `n` as `set_rays8` leaves them: every field 0.
                    let mut rows = [avx.splat(0.0); 8];
                    for (k, row) in rows.iter_mut().enumerate().take(n.min(8)) {
                        *row = avx.ray_row(ray(k));
                    }
                    let [ox, oy, oz, dx, dy, dz, tmin, tmax] = F32x8::transpose8(rows);
                    ox.store(&mut p.org_x);
                    oy.store(&mut p.org_y);
                    oz.store(&mut p.org_z);
                    dx.store(&mut p.dir_x);
                    dy.store(&mut p.dir_y);
                    dz.store(&mut p.dir_z);
                    tmin.store(&mut p.tnear);
                    tmax.store(&mut p.tfar);
                    // As in `ray`: the id is tmax's bits.
                    p.id = tmax.to_bits().to_array().map(|b| b as u32);
                },
            );
        }
        Self::set_rays8(p, n, ray);
    }

    /// Writes lanes `0..n` of `p` from `ray(0)`, … `ray(n − 1)` and, when `n < 8`, the ray
    /// fields of lanes `n..8` as [`EMPTY8`] has them, so that the packet holds what a fresh
    /// [`Self::ray8`] would (its mask, time and flags, which Embree only reads, stay as
    /// [`EMPTY8`] set them).
    #[inline(always)]
    fn set_rays8<'r>(p: &mut RTCRay8, n: usize, ray: impl Fn(usize) -> &'r Ray) {
        let n = n.min(8);
        for i in 0..n {
            let r = ray(i);
            (p.org_x[i], p.org_y[i], p.org_z[i]) = (r.o.x, r.o.y, r.o.z);
            (p.dir_x[i], p.dir_y[i], p.dir_z[i]) = (r.d.x, r.d.y, r.d.z);
            (p.tnear[i], p.tfar[i]) = (r.tmin, r.tmax);
            // As in `ray`.
            p.id[i] = r.tmax.to_bits();
        }
        for i in n..8 {
            (p.org_x[i], p.org_y[i], p.org_z[i]) = (0.0, 0.0, 0.0);
            (p.dir_x[i], p.dir_y[i], p.dir_z[i]) = (0.0, 0.0, 0.0);
            (p.tnear[i], p.tfar[i], p.id[i]) = (0.0, 0.0, 0);
        }
    }

    /// Nearest hits of up to 8 rays traced as one `rtcIntersect8` packet: `out[i]` is the hit
    /// of `rays[i]` (`coherent`: the rays start near each other and point alike, e.g. camera
    /// rays of one pixel, which Embree may use to traverse them together).
    pub(crate) fn intersect8(&self, rays: &[Ray], coherent: bool, out: &mut [Option<Hit>; 8]) {
        *out = [None; 8];
        let mut rh = EMPTY8;
        self.intersect8_into(
            &mut rh,
            rays.len(),
            coherent,
            |k| &rays[k],
            |k, h| out[k] = h,
        );
    }

    /// [`Self::intersect8`] of the `n` (at most 8) rays `ray(0)`, … `ray(n − 1)`, each hit
    /// handed to `out(k, row)` in lane order as its [`HitRow`] (the scene's own ids, as
    /// [`Self::intersect8`] gives them: the caller maps instances): the rays read from, and the
    /// rows written to, wherever the caller keeps them (the stream renderer's path columns),
    /// without a packet of rays or of hits in between. The packet Embree reads is `buf`'s, kept
    /// from query to query: only its used lanes and hit ids are rewritten, where building one
    /// afresh cost two 640-byte copies and its zeroing per query. Where the CPU has AVX2 the
    /// rows are built in lanes from the packet's columns ([`Self::hit_rows8`]), and only a lane
    /// whose hit may need settling ([`Self::settle`]) reads its ray again.
    #[inline(always)]
    pub(crate) fn intersect8_with<'r>(
        &self,
        buf: &mut RayBuf,
        n: usize,
        coherent: bool,
        ray: impl Fn(usize) -> &'r Ray,
        mut out: impl FnMut(usize, HitRow),
    ) {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            let n = n.min(8);
            let rh = &mut buf.packet;
            self.trace8(rh, n, coherent, &ray);
            let mut rows = [HitRow::NONE; 8];
            let (unsure, _) = Self::hit_rows8(avx, rh, &mut rows);
            self.settle_rows(&mut rows, unsure & ((1u32 << n) - 1), &ray);
            for (k, row) in rows.iter().enumerate().take(n) {
                out(k, *row);
            }
            return;
        }
        self.intersect8_into(&mut buf.packet, n, coherent, ray, |k, h| {
            out(k, HitRow::new(h))
        });
    }

    /// [`Self::intersect8_with`] of a full packet, `rays[k]` in lane `k`, its hits' rows
    /// stored into `rows` (the caller's own, e.g. the stream renderer's hit column) straight
    /// from the lanes: one 32-byte store a row inside the AVX2 region, where returning the 8
    /// rows from it cost a 256-byte `memcpy` a packet and handing them on one by one a
    /// closure call, a reload and a four-part store a lane. Returns the lanes (bit `k` for
    /// lane `k`) whose hit is on an instance (the caller maps them, as the rows hold the
    /// scene's own ids). Without AVX2, through [`Self::intersect8_with`].
    #[inline(always)]
    pub(crate) fn intersect8_rows(
        &self,
        buf: &mut RayBuf,
        coherent: bool,
        rays: &[Ray; 8],
        rows: &mut [HitRow; 8],
    ) -> u32 {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            let rh = &mut buf.packet;
            self.trace8(rh, 8, coherent, |k| &rays[k]);
            let (unsure, mut on_inst) = Self::hit_rows8(avx, rh, rows);
            if unsure != 0 {
                self.settle_rows(rows, unsure, |k| &rays[k]);
                // A settled hit is a new hit (perhaps on an instance).
                for k in (0..8).filter(|k| unsure >> k & 1 != 0) {
                    let on = rows[k].is_hit() && rows[k].inst() != u32::MAX;
                    on_inst = on_inst & !(1 << k) | u32::from(on) << k;
                }
            }
            return on_inst;
        }
        self.intersect8_with(buf, 8, coherent, |k| &rays[k], |k, row| rows[k] = row);
        (0..8).fold(0, |m, k| {
            let on = rows[k].is_hit() && rows[k].inst() != u32::MAX;
            m | u32::from(on) << k
        })
    }

    /// Settles ([`Self::settle`]) the rows of the lanes `lanes` (bit `k` for lane `k`, each ray
    /// `ray(k)`): `settle` changes only a hit whose primitive id is UNSURE (a rectangle's hit
    /// over one of unknown t), so the other rows are their hits' as they are.
    #[inline(always)]
    fn settle_rows<'r>(&self, rows: &mut [HitRow; 8], lanes: u32, ray: impl Fn(usize) -> &'r Ray) {
        let mut check = lanes & 0xff;
        while check != 0 {
            let k = check.trailing_zeros() as usize;
            check &= check - 1;
            if let Some(h) = rows[k].get() {
                let r = ray(k);
                rows[k] = HitRow::new(Some(self.settle(h, r.o, r.d, r.tmin)));
            }
        }
    }

    /// The rows ([`HitRow`]) of a traced packet's 8 lanes, built in lanes and stored in `rows`:
    /// `geom`, `prim`, `t` (`tfar`), `u`, `v` and `inst` from the packet's columns, every word
    /// but `geom` zeroed in a lane without a hit (`geom` invalid: [`HitRow::MISS`], so
    /// [`HitRow::NONE`]), two zero words; one transpose and one store a row, inside the AVX2
    /// region (the words of [`HitRow::new`] of the lane's hit, bit for bit). Returns the lanes
    /// (bit `k` for lane `k`) whose hit has the primitive id [`UNSURE`], and those whose hit is
    /// on an instance (`inst` valid).
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn hit_rows8(avx: crate::lane::Avx2, rh: &RTCRayHit8, rows: &mut [HitRow; 8]) -> (u32, u32) {
        use crate::lane::{F32x8, Lane, LaneI32};
        avx.run(
            #[inline(always)]
            || {
                let h = &rh.hit;
                let geom = avx.load_u32(&h.geomID);
                let miss = geom.eq(geom.splat(HitRow::MISS as i32));
                let z = geom.splat(0);
                let prim = LaneI32::select(miss, z, avx.load_u32(&h.primID));
                let t = LaneI32::select(miss, z, avx.load(&rh.ray.tfar).to_bits());
                let u = LaneI32::select(miss, z, avx.load(&h.u).to_bits());
                let v = LaneI32::select(miss, z, avx.load(&h.v).to_bits());
                let inst = LaneI32::select(miss, z, avx.load_u32(&h.instID[0]));
                let unsure = prim.eq(prim.splat(UNSURE as i32)).bits();
                // A miss lane's inst is 0 here: only a hit's is tested.
                let on_inst = !inst.eq(inst.splat(-1)).bits() & !miss.bits() & 0xff;
                // Written out, not `array::map` (compiled out of line, it would call the
                // casts' intrinsics).
                let words = F32x8::transpose8([
                    F32x8::from_bits(geom),
                    F32x8::from_bits(prim),
                    F32x8::from_bits(t),
                    F32x8::from_bits(u),
                    F32x8::from_bits(v),
                    F32x8::from_bits(inst),
                    F32x8::from_bits(z),
                    F32x8::from_bits(z),
                ]);
                for k in 0..8 {
                    words[k].store_bits(&mut rows[k].0);
                }
                (unsure, on_inst)
            },
        )
    }

    /// [`Self::intersect8_with`] through the packet `rh`, whose ray fields
    /// [`Self::set_rays8`] rewrites and whose hit ids are reset (Embree writes a hit's other
    /// fields, and nothing reads them without a hit).
    #[inline(always)]
    fn intersect8_into<'r>(
        &self,
        rh: &mut RTCRayHit8,
        n: usize,
        coherent: bool,
        ray: impl Fn(usize) -> &'r Ray,
        mut out: impl FnMut(usize, Option<Hit>),
    ) {
        let n = n.min(8);
        self.trace8(rh, n, coherent, &ray);
        for i in 0..n {
            let h = (rh.hit.geomID[i] != u32::MAX).then(|| {
                let hit = Hit {
                    geom: rh.hit.geomID[i],
                    prim: rh.hit.primID[i],
                    t: rh.ray.tfar[i],
                    u: rh.hit.u[i],
                    v: rh.hit.v[i],
                    inst: rh.hit.instID[0][i],
                };
                let r = ray(i);
                self.settle(hit, r.o, r.d, r.tmin)
            });
            out(i, h);
        }
    }

    /// Traces the `n` (at most 8) rays `ray(k)` as one `rtcIntersect8` packet through `rh`,
    /// whose ray fields [`Self::set_rays8_fast`] rewrites and whose hit ids are reset first.
    #[inline(always)]
    fn trace8<'r>(
        &self,
        rh: &mut RTCRayHit8,
        n: usize,
        coherent: bool,
        ray: impl Fn(usize) -> &'r Ray,
    ) {
        let valid = Valid8::first(n);
        let mut ctx = Self::context();
        if coherent {
            ctx.flags = RTCIntersectContextFlags::COHERENT;
        }
        self.set_rays8_fast(&mut rh.ray, n, ray);
        rh.hit.primID = [u32::MAX; 8];
        rh.hit.geomID = [u32::MAX; 8];
        rh.hit.instID = [[u32::MAX; 8]];
        // SAFETY: the scene is committed; the mask, context and packet are valid, with the
        // alignments Embree requires (32 bytes for the mask and the packet: `RTCRayHit8` is
        // `align(32)` wherever it lives).
        unsafe { rtcIntersect8(valid.0.as_ptr(), self.scene, &mut ctx, rh) };
    }

    /// Occlusion of up to 8 rays traced as one `rtcOccluded8` packet: bit `i` set when
    /// `rays[i]` is blocked.
    pub(crate) fn occluded8(&self, rays: &[Ray]) -> u8 {
        let n = rays.len().min(8);
        let valid = Valid8::first(n);
        let mut ctx = Self::context();
        let mut r = self.ray8(n, |k| &rays[k]);
        // SAFETY: as in `intersect8`.
        unsafe { rtcOccluded8(valid.0.as_ptr(), self.scene, &mut ctx, &mut r) };
        (0..n).fold(0, |m, i| {
            m | (((r.tfar[i] == f32::NEG_INFINITY) as u8) << i)
        })
    }
}

/// A reusable array of rays for Embree's stream queries (`rtcIntersect1M`, `rtcOccluded1M`):
/// one per worker thread, grown to the largest stream once and reused, so a query allocates
/// nothing. Filled ([`RayBuf::fill`]) and traced ([`EmbreeScene::intersect_filled`],
/// [`EmbreeScene::occluded_filled`]) in two steps, so that the caller can note what goes in
/// (the stream renderer's shadow stage lists the pending paths as it fills).
pub(crate) struct RayBuf {
    /// Slots, never shrunk; the first `n` hold the stream.
    rh: Vec<RTCRayHit>,
    n: usize,
    /// The packet of [`EmbreeScene::intersect8_with`], reused from query to query.
    packet: RTCRayHit8,
    /// The AVX2 token where the CPU has it: [`RayBuf::fill`] writes each ray's fields from
    /// lanes ([`crate::lane::Avx2::embree_ray`]).
    #[cfg(target_arch = "x86_64")]
    avx: Option<crate::lane::Avx2>,
}

/// The hit half of a ray-hit with no hit yet (every id invalid).
const NO_HIT: RTCHit = RTCHit {
    Ng_x: 0.0,
    Ng_y: 0.0,
    Ng_z: 0.0,
    u: 0.0,
    v: 0.0,
    primID: u32::MAX,
    geomID: u32::MAX,
    instID: [u32::MAX],
};

// `RayBuf::fill` writes an `RTCRay` as 12 four-byte fields in Embree's order (o.x, o.y, o.z,
// tnear, d.x, d.y, d.z, time, tfar, mask, id, flags), with no padding between or after them.
const _: () = assert!(std::mem::size_of::<RTCRay>() == 48);
const _: () = assert!(std::mem::offset_of!(RTCRay, tfar) == 32);
const _: () = assert!(std::mem::offset_of!(RTCRay, flags) == 44);

/// The ray of `slot` as the 12 floats' bits [`crate::lane::Avx2::embree_ray`] writes.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn ray_floats(slot: &mut RTCRayHit) -> &mut [f32; 12] {
    // SAFETY: `RTCRay` is `repr(C)`, 48 bytes of 12 four-byte fields (f32 and u32, asserted
    // above) at 16-byte alignment, so it is a valid `[f32; 12]` to write; any bits written are
    // valid values of its f32 and u32 fields. The borrow is `slot`'s.
    unsafe { &mut *(&mut slot.ray as *mut RTCRay).cast::<[f32; 12]>() }
}

// `hit_words` reads an `RTCHit` as 8 four-byte words in Embree's order (Ng.x, Ng.y, Ng.z, u, v,
// primID, geomID, instID), with no padding.
const _: () = assert!(std::mem::size_of::<RTCHit>() == 32);
const _: () = assert!(std::mem::offset_of!(RTCHit, u) == 12);
const _: () = assert!(std::mem::offset_of!(RTCHit, primID) == 20);
const _: () = assert!(std::mem::offset_of!(RTCHit, geomID) == 24);
const _: () = assert!(std::mem::offset_of!(RTCHit, instID) == 28);

/// The hit half of a ray-hit as the 8 words [`crate::lane::Avx2::embree_hit_row`] reads.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn hit_words(hit: &RTCHit) -> &[u32; 8] {
    // SAFETY: `RTCHit` is `repr(C)`, 32 bytes of 8 four-byte fields (f32 and u32, asserted
    // above) at 16-byte alignment, so it is a valid `[u32; 8]` to read (any f32's bits are a
    // valid u32). The borrow is `hit`'s.
    unsafe { &*(hit as *const RTCHit).cast::<[u32; 8]>() }
}

/// An empty packet: every ray field zero but the mask (all bits), every hit id invalid.
const EMPTY8: RTCRayHit8 = RTCRayHit8 {
    ray: RTCRay8 {
        org_x: [0.0; 8],
        org_y: [0.0; 8],
        org_z: [0.0; 8],
        tnear: [0.0; 8],
        dir_x: [0.0; 8],
        dir_y: [0.0; 8],
        dir_z: [0.0; 8],
        time: [0.0; 8],
        tfar: [0.0; 8],
        mask: [u32::MAX; 8],
        id: [0; 8],
        flags: [0; 8],
    },
    hit: RTCHit8 {
        Ng_x: [0.0; 8],
        Ng_y: [0.0; 8],
        Ng_z: [0.0; 8],
        u: [0.0; 8],
        v: [0.0; 8],
        primID: [u32::MAX; 8],
        geomID: [u32::MAX; 8],
        instID: [[u32::MAX; 8]],
    },
};

impl Default for RayBuf {
    fn default() -> RayBuf {
        RayBuf {
            rh: Vec::new(),
            n: 0,
            packet: EMPTY8,
            #[cfg(target_arch = "x86_64")]
            avx: crate::lane::Avx2::detect(),
        }
    }
}

impl RayBuf {
    /// Refills the buffer with `rays` (tnear, tfar from each ray; no hit yet); returns how many.
    /// The rays are written into slots grown beforehand to the iterator's upper bound, so
    /// a ray costs no capacity check and no length store (as `Vec::extend` paid for iterators
    /// without a trusted length: 33 instructions per ray on million.xml's bounce stream).
    #[inline(always)]
    pub(crate) fn fill<'r>(&mut self, mut rays: impl Iterator<Item = &'r Ray>) -> usize {
        let (lo, hi) = rays.size_hint();
        let want = hi.unwrap_or(lo);
        if self.rh.len() < want {
            let empty = EmbreeScene::ray_hit(Vec3::ZERO, Vec3::Z, 0.0, 0.0);
            self.rh.resize(want, empty);
        }
        let mut n = 0;
        // The slots first: `zip` stops when they run out without taking a ray. The iterator
        // and the count are moved into the AVX2 region's closure, into its locals, and handed
        // back, not captured by reference: captured, they lived in memory (the slots' stores
        // may alias them, and a ray's index may panic), so each ray reloaded and stored the
        // iterator's position and the count (million.xml's bounce stream: 22 instructions a
        // ray, 16 a shadow ray).
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            let rh = &mut self.rh[..];
            (n, rays) = avx.run(
                #[inline(always)]
                move || {
                    let (mut n, mut rays) = (0, rays);
                    for (slot, r) in rh.iter_mut().zip(&mut rays) {
                        avx.embree_ray(r, ray_floats(slot));
                        slot.hit = NO_HIT;
                        n += 1;
                    }
                    (n, rays)
                },
            );
        }
        // (Without AVX2, or the slots the lanes left: none, they take every slot.)
        for (slot, r) in self.rh[n..].iter_mut().zip(&mut rays) {
            *slot = EmbreeScene::ray_hit(r.o, r.d, r.tmin, r.tmax);
            n += 1;
        }
        // An iterator longer than its upper bound said, or without one (the slots ran out, so
        // `n` is their number).
        for r in rays {
            self.rh.push(EmbreeScene::ray_hit(r.o, r.d, r.tmin, r.tmax));
            n += 1;
        }
        self.n = n;
        n
    }

    /// The rays of the stream, as given to [`Self::fill`] (before a query changes their tfar).
    pub(crate) fn rays(&self) -> impl Iterator<Item = Ray> + '_ {
        self.rh[..self.n].iter().map(|rh| {
            let r = &rh.ray;
            Ray {
                o: Vec3::new(r.org_x, r.org_y, r.org_z),
                d: Vec3::new(r.dir_x, r.dir_y, r.dir_z),
                tmin: r.tnear,
                tmax: r.tfar,
            }
        })
    }

    /// How many rays the stream holds.
    pub(crate) fn len(&self) -> usize {
        self.n
    }
}

impl EmbreeScene {
    /// A context whose flags say whether the rays of a stream are coherent (Embree then traces
    /// them together, `intersectN`) or not (Embree 3.13: 8-wide packets for nearest hits,
    /// octant-sorted streams for occlusion; `bvh_intersector_stream_filters.cpp`).
    fn stream_context(coherent: bool) -> RTCIntersectContext {
        let mut ctx = Self::context();
        if coherent {
            ctx.flags = RTCIntersectContextFlags::COHERENT;
        }
        ctx
    }

    /// Nearest hits of the rays [`RayBuf::fill`] put in `buf`, traced as one `rtcIntersect1M`
    /// stream: `out(k, row)` for the `k`-th ray, in order, its hit as a [`HitRow`] (the scene's
    /// own ids: the caller maps instances) written from the ray-hit's words, without an
    /// `Option<Hit>` in between; only a hit whose primitive id is [`UNSURE`] is settled
    /// ([`Self::settle`] changes no other).
    pub(crate) fn intersect_filled(
        &self,
        coherent: bool,
        buf: &mut RayBuf,
        mut out: impl FnMut(usize, HitRow),
    ) {
        self.trace_filled(coherent, buf);
        for (k, rh) in buf.rh[..buf.n].iter().enumerate() {
            let (r, h) = (&rh.ray, &rh.hit);
            let row = if h.geomID == HitRow::MISS {
                HitRow::NONE
            } else if h.primID == UNSURE {
                self.settled_row(rh)
            } else {
                // `HitRow::new`'s words.
                HitRow([
                    h.geomID,
                    h.primID,
                    r.tfar.to_bits(),
                    h.u.to_bits(),
                    h.v.to_bits(),
                    h.instID[0],
                    0,
                    0,
                ])
            };
            out(k, row);
        }
    }

    /// [`Self::intersect_filled`] with each ray's row stored in place: the `k`-th ray's in
    /// `rows[ids[k]]` (`ids` holds at least as many as the stream: the stream renderer's
    /// active paths, `rows` its hit column). `map` is the caller's mapping of instances,
    /// which must leave a row without an instance as it is ([`crate::accel::Accel`]'s
    /// `world_row`): it is applied to each hit on an instance and each settled hit, and
    /// without AVX2 to every row. With AVX2 a hit's row is one blend, one
    /// permute and one 32-byte store ([`crate::lane::Avx2::embree_hit_row`]) inside the AVX2
    /// region; handed on by value, the row was taken apart into its words again.
    pub(crate) fn intersect_filled_into(
        &self,
        coherent: bool,
        buf: &mut RayBuf,
        ids: &[u32],
        rows: &mut [HitRow],
        map: impl Fn(HitRow) -> HitRow,
    ) {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.avx {
            self.trace_filled(coherent, buf);
            let rh = &buf.rh[..buf.n];
            return avx.run(
                #[inline(always)]
                || {
                    for (rh, &i) in rh.iter().zip(ids) {
                        let (h, slot) = (&rh.hit, &mut rows[i as usize]);
                        if h.geomID == HitRow::MISS {
                            *slot = HitRow::NONE;
                        } else if h.primID == UNSURE {
                            *slot = map(self.settled_row(rh));
                        } else {
                            avx.embree_hit_row(hit_words(h), rh.ray.tfar, &mut slot.0);
                            if h.instID[0] != u32::MAX {
                                *slot = map(*slot);
                            }
                        }
                    }
                },
            );
        }
        self.intersect_filled(coherent, buf, |k, row| rows[ids[k] as usize] = map(row));
    }

    /// Traces the rays [`RayBuf::fill`] put in `buf` as one `rtcIntersect1M` stream (each
    /// ray-hit's hit and tfar then hold its nearest hit, if any).
    fn trace_filled(&self, coherent: bool, buf: &mut RayBuf) {
        let mut ctx = Self::stream_context(coherent);
        let rh = &mut buf.rh[..buf.n];
        for part in rh.chunks_mut(u32::MAX as usize) {
            // SAFETY: the scene is committed; `part` holds `part.len()` ray-hits of
            // `RTCRayHit`'s size and 16-byte alignment, which is the stride given.
            unsafe {
                rtcIntersect1M(
                    self.scene,
                    &mut ctx,
                    part.as_mut_ptr(),
                    part.len() as u32,
                    std::mem::size_of::<RTCRayHit>(),
                )
            };
        }
    }

    /// The row of a traced ray-hit whose hit has the primitive id [`UNSURE`], settled
    /// ([`Self::settle`]).
    #[inline(always)]
    fn settled_row(&self, rh: &RTCRayHit) -> HitRow {
        let (r, h) = (&rh.ray, &rh.hit);
        let hit = Hit {
            geom: h.geomID,
            prim: h.primID,
            t: r.tfar,
            u: h.u,
            v: h.v,
            inst: h.instID[0],
        };
        // Embree leaves org and dir as given.
        let o = Vec3::new(r.org_x, r.org_y, r.org_z);
        let d = Vec3::new(r.dir_x, r.dir_y, r.dir_z);
        HitRow::new(Some(self.settle(hit, o, d, r.tnear)))
    }

    /// Occlusion of the rays [`RayBuf::fill`] put in `buf`, traced as one `rtcOccluded1M`
    /// stream: `out(k, blocked)` for the `k`-th ray, in order.
    pub(crate) fn occluded_filled(
        &self,
        coherent: bool,
        buf: &mut RayBuf,
        mut out: impl FnMut(usize, bool),
    ) {
        let mut ctx = Self::stream_context(coherent);
        let rh = &mut buf.rh[..buf.n];
        for part in rh.chunks_mut(u32::MAX as usize) {
            // SAFETY: as in `trace_filled`; each ray is the first member of its
            // `RTCRayHit` (`repr(C)`), so the rays lie `size_of::<RTCRayHit>()` bytes apart, and
            // the hit after each (geomID invalid) is what Embree's stream filter reads past it.
            unsafe {
                rtcOccluded1M(
                    self.scene,
                    &mut ctx,
                    part.as_mut_ptr() as *mut RTCRay,
                    part.len() as u32,
                    std::mem::size_of::<RTCRayHit>(),
                )
            };
        }
        for (k, rh) in rh.iter().enumerate() {
            // Embree sets tfar to −∞ when the ray is occluded.
            out(k, rh.ray.tfar == f32::NEG_INFINITY);
        }
    }
}

impl Drop for EmbreeScene {
    fn drop(&mut self) {
        // SAFETY: handles created in `build`, released exactly once; the scene before its device
        // (and both before the user geometries' data, which the struct drops after this body).
        unsafe {
            if !self.scene.is_null() {
                rtcReleaseScene(self.scene);
            }
            for &g in &self.groups {
                rtcReleaseScene(g);
            }
            rtcReleaseDevice(self.device);
        }
    }
}

/// Sets flush-to-zero and denormals-are-zero for the calling thread (Embree's recommendation for
/// performance, "Embree API: Performance Recommendations").
pub(crate) fn set_flush_denormals() {
    #[cfg(target_arch = "x86_64")]
    #[allow(deprecated)]
    // SAFETY: only sets the FTZ (bit 15) and DAZ (bit 6) flags of this thread's MXCSR.
    unsafe {
        use std::arch::x86_64::{_mm_getcsr, _mm_setcsr};
        _mm_setcsr(_mm_getcsr() | 0x8040);
    }
}

#[cfg(test)]
mod tests {
    /// The rays' fields written in lanes ([`RayBuf::fill`]'s slots, [`EmbreeScene::set_rays8_fast`]'s
    /// packets) have the bits of the fields written one by one ([`EmbreeScene::ray_hit`],
    /// [`EmbreeScene::set_rays8`]), for rays with ±0, infinities, NaNs and subnormals in every
    /// field, and packets of every length.
    #[test]
    fn rays_in_lanes_have_the_fields_bits() {
        let edges = [
            0.0f32,
            -0.0,
            1.0,
            -2.5,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::from_bits(0xffc0_0001),
            f32::from_bits(1),
            f32::MAX,
            3e-39,
        ];
        let mut rng = crate::math::Pcg32::new(17, 3);
        let pick = |rng: &mut crate::math::Pcg32| {
            let r = rng.next_u32();
            if r.is_multiple_of(3) {
                edges[(r >> 8) as usize % edges.len()]
            } else {
                f32::from_bits(rng.next_u32())
            }
        };
        let rays: Vec<Ray> = (0..500)
            .map(|_| {
                let mut f = [0.0f32; 8];
                f.iter_mut().for_each(|x| *x = pick(&mut rng));
                Ray {
                    o: Vec3::new(f[0], f[1], f[2]),
                    d: Vec3::new(f[3], f[4], f[5]),
                    tmin: f[6],
                    tmax: f[7],
                }
            })
            .collect();
        let bytes = |rh: &RTCRayHit| -> [u8; 80] {
            // SAFETY: a ray-hit is 80 bytes of four-byte fields, no padding.
            unsafe { std::mem::transmute_copy(rh) }
        };
        let mut buf = RayBuf::default();
        assert_eq!(buf.fill(rays.iter()), rays.len());
        for (slot, r) in buf.rh.iter().zip(&rays) {
            let want = EmbreeScene::ray_hit(r.o, r.d, r.tmin, r.tmax);
            assert_eq!(bytes(slot), bytes(&want), "{r:?}");
        }
        let scene = EmbreeScene::build(&[]).unwrap();
        let packet_bytes = |p: &RTCRay8| -> [u8; 384] {
            // SAFETY: a packet's ray half is 12 arrays of eight four-byte fields.
            unsafe { std::mem::transmute_copy(p) }
        };
        for (c, chunk) in rays.chunks(8).enumerate() {
            let n = 1 + c % 8;
            let (mut fast, mut slow) = (EMPTY8.ray, EMPTY8.ray);
            // Lanes past `n` hold an earlier packet's rays first.
            for p in [&mut fast, &mut slow] {
                EmbreeScene::set_rays8(p, 8, |k| &rays[(k + 3 * c) % rays.len()]);
            }
            scene.set_rays8_fast(&mut fast, n.min(chunk.len()), |k| &chunk[k]);
            EmbreeScene::set_rays8(&mut slow, n.min(chunk.len()), |k| &chunk[k]);
            assert_eq!(
                packet_bytes(&fast),
                packet_bytes(&slow),
                "packet {c}, {n} rays"
            );
        }
    }

    /// The hit rows built in lanes (a stream's, [`crate::lane::Avx2::embree_hit_row`]; a
    /// packet's, [`EmbreeScene::hit_rows8`], with its unsure and instance lanes) have the
    /// words [`HitRow::new`] gives the hit, for hits whose fields are any bits (NaNs,
    /// infinities, subnormals), misses among them in the packets.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn hit_rows_in_lanes_have_the_fields_bits() {
        let Some(avx) = crate::lane::Avx2::detect() else {
            eprintln!("no AVX2: skipped");
            return;
        };
        let mut rng = crate::math::Pcg32::new(29, 5);
        let word = |rng: &mut crate::math::Pcg32| match rng.next_u32() % 8 {
            0 => u32::MAX,
            1 => UNSURE,
            2 => 0,
            3 => f32::NAN.to_bits(),
            4 => 1,
            _ => rng.next_u32(),
        };
        for c in 0..400 {
            let mut p = EMPTY8;
            let mut want = [HitRow::NONE; 8];
            let (mut unsure, mut on_inst) = (0u32, 0u32);
            for (k, want) in want.iter_mut().enumerate() {
                let w: [u32; 9] = std::array::from_fn(|_| word(&mut rng));
                let h = RTCHit {
                    Ng_x: f32::from_bits(w[0]),
                    Ng_y: f32::from_bits(w[1]),
                    Ng_z: f32::from_bits(w[2]),
                    u: f32::from_bits(w[3]),
                    v: f32::from_bits(w[4]),
                    primID: w[5],
                    geomID: if c % 3 == 0 { w[6] } else { w[6] & 0xff },
                    instID: [w[7]],
                };
                let tfar = f32::from_bits(w[8]);
                let hit = (h.geomID != HitRow::MISS).then_some(Hit {
                    geom: h.geomID,
                    prim: h.primID,
                    t: tfar,
                    u: h.u,
                    v: h.v,
                    inst: h.instID[0],
                });
                *want = HitRow::new(hit);
                if let Some(x) = hit {
                    let mut row = HitRow([7; 8]);
                    avx.run(|| avx.embree_hit_row(hit_words(&h), tfar, &mut row.0));
                    assert_eq!(row, *want, "hit {c}.{k}: {h:?}, tfar {tfar:?}");
                    unsure |= u32::from(x.prim == UNSURE) << k;
                    on_inst |= u32::from(x.inst != u32::MAX) << k;
                }
                (p.hit.Ng_x[k], p.hit.Ng_y[k], p.hit.Ng_z[k]) = (h.Ng_x, h.Ng_y, h.Ng_z);
                (p.hit.u[k], p.hit.v[k], p.ray.tfar[k]) = (h.u, h.v, tfar);
                (p.hit.primID[k], p.hit.geomID[k], p.hit.instID[0][k]) =
                    (h.primID, h.geomID, h.instID[0]);
            }
            let mut rows = [HitRow([7; 8]); 8];
            let lanes = EmbreeScene::hit_rows8(avx, &p, &mut rows);
            assert_eq!(rows, want, "packet {c}");
            assert_eq!(lanes, (unsure, on_inst), "packet {c}'s lanes");
        }
    }

    use super::*;

    #[test]
    fn sphere_roots_are_precise_from_far_away_from_inside_and_at_grazing_angles() {
        let s = SphereData {
            center: Vec3::new(0.0, 0.0, 1.0e4),
            radius: 1.0,
        };
        // From 10⁴ radii away, unnormalised direction: the near root is 9999 / 2.
        let t = s
            .hit(Vec3::ZERO, Vec3::new(0.0, 0.0, 2.0), 0.0, f32::MAX)
            .unwrap()
            .t;
        assert!((t - 4999.5).abs() <= 4999.5 * 2.0 * f32::EPSILON, "t = {t}");
        // From the centre: the far root only, whatever tnear.
        let t = s.hit(s.center, Vec3::X, 1e-4, f32::MAX).unwrap().t;
        assert!((t - 1.0).abs() < 1e-6);
        // Just inside and just outside the silhouette, seen from far away.
        let graze = |x: f32| s.hit(Vec3::new(x, 0.0, 0.0), Vec3::Z, 0.0, f32::MAX);
        assert!(graze(0.999).is_some());
        assert!(graze(1.001).is_none());
        // The interval is open: a hit beyond tfar, or behind tnear, is no hit.
        assert!(s.hit(Vec3::ZERO, Vec3::Z, 0.0, 9998.0).is_none());
        assert!(s.hit(Vec3::ZERO, -Vec3::Z, 0.0, f32::MAX).is_none());
    }

    /// A top-level rectangle, traced as a filtered slab of triangles, reports exactly what its
    /// user geometry (still used inside shape groups) reports: hit or miss, the same t bits,
    /// primitive 0, zero barycentrics, for single rays, packets and streams, and the same
    /// occlusion; over rays aimed at and beyond its edges, rays from points on it, rays in its
    /// plane, and tmin or tmax at, just before and just after the hit.
    #[test]
    fn a_rectangle_as_a_slab_reports_the_exact_rectangle_hit() {
        let to_world = Mat4::from_translation(Vec3::new(0.3, -0.2, 0.5))
            * Mat4::from_rotation_x(0.7)
            * Mat4::from_scale(Vec3::new(0.8, 0.5, 1.0));
        let scene =
            EmbreeScene::build_instanced_with(&[GeomDesc::Rectangle { to_world }], &[], &[], true)
                .unwrap();
        assert!(scene.rects[0], "traced as a slab");
        let exact = PlanarData::new(&to_world, true);
        let mut rng = crate::math::Pcg32::new(3, 11);
        let mut unit = || 2.0 * rng.next_f32() - 1.0;
        let mut rays = Vec::new();
        for k in 0..40_000 {
            let o = Vec3::new(unit(), unit(), unit()).normalize_or(Vec3::Z) * 3.0;
            // Aimed at the square, its edges (1 ± a few ulps) and beyond.
            let (x, y) = match k % 3 {
                0 => (1.2 * unit(), 1.2 * unit()),
                1 => (
                    f32::from_bits(1f32.to_bits() + (k % 5) as u32 - 2) * unit().signum(),
                    unit(),
                ),
                _ => (unit(), unit()),
            };
            let target = to_world.transform_point3(Vec3::new(x, y, 0.0));
            let mut ray = Ray::new(o, (target - o).normalize());
            match k % 7 {
                // From a point on the plane, any direction.
                0 => {
                    ray = Ray::new(
                        target,
                        Vec3::new(unit(), unit(), unit()).normalize_or(Vec3::X),
                    )
                }
                // In the plane.
                1 => {
                    let d = to_world
                        .transform_vector3(Vec3::new(unit(), unit(), 0.0))
                        .normalize_or(Vec3::X);
                    ray = Ray::new(target - d * 3.0, d);
                }
                2..=4 => {
                    if let Some(h) = exact.hit(ray.o, ray.d, ray.tmin, ray.tmax) {
                        let b = h.t.to_bits();
                        match k % 6 {
                            0 => ray.tmax = h.t,
                            1 => ray.tmax = f32::from_bits(b + 1),
                            2 => ray.tmax = f32::from_bits(b - 1),
                            3 => ray.tmin = h.t,
                            4 => ray.tmin = f32::from_bits(b - 1),
                            _ => ray.tmin = f32::from_bits(b + 1),
                        }
                    }
                }
                _ => {}
            }
            rays.push(ray);
        }
        let mut hits = 0;
        for ray in &rays {
            let want = exact.hit(ray.o, ray.d, ray.tmin, ray.tmax).map(|h| Hit {
                geom: 0,
                prim: 0,
                t: h.t,
                u: 0.0,
                v: 0.0,
                inst: u32::MAX,
            });
            let got = scene.intersect(ray.o, ray.d, ray.tmin, ray.tmax);
            assert_eq!(
                got.map(|h| h.t.to_bits()),
                want.map(|h| h.t.to_bits()),
                "{ray:?}"
            );
            assert_eq!(got, want, "{ray:?}");
            assert_eq!(
                scene.occluded(ray.o, ray.d, ray.tmin, ray.tmax),
                want.is_some(),
                "{ray:?}"
            );
            hits += usize::from(want.is_some());
        }
        assert!(hits > 8_000, "{hits} hits");
        // Packets and the stream give the single-ray hits.
        for chunk in rays.chunks(8) {
            let mut got = [None; 8];
            scene.intersect8(chunk, false, &mut got);
            let blocked = scene.occluded8(chunk);
            for (i, (r, g)) in chunk.iter().zip(got).enumerate() {
                let want = scene.intersect(r.o, r.d, r.tmin, r.tmax);
                assert_eq!(g, want);
                assert_eq!(blocked & (1 << i) != 0, want.is_some());
            }
        }
        let mut buf = RayBuf::default();
        buf.fill(rays.iter());
        scene.intersect_filled(false, &mut buf, |k, g| {
            let r = &rays[k];
            assert_eq!(g.get(), scene.intersect(r.o, r.d, r.tmin, r.tmax));
        });
        buf.fill(rays.iter());
        scene.occluded_filled(false, &mut buf, |k, b| {
            let r = &rays[k];
            assert_eq!(b, scene.occluded(r.o, r.d, r.tmin, r.tmax));
        });
    }

    /// A rectangle's hit found after a mesh hit (whose t the filter cannot see) is settled by
    /// tracing again: the nearer of the two wins whatever order Embree finds them in, for a
    /// mesh just in front of, at, or just behind the rectangle.
    #[test]
    fn a_rectangle_behind_or_before_a_mesh_gives_the_nearer_hit() {
        for dz in [-1e-3f32, -1e-6, 0.0, 1e-6, 1e-3] {
            let positions = [
                Vec3::new(-2.0, -2.0, dz),
                Vec3::new(2.0, -2.0, dz),
                Vec3::new(2.0, 2.0, dz),
                Vec3::new(-2.0, 2.0, dz),
            ];
            let indices = [[0, 1, 2], [0, 2, 3]];
            for rect_first in [false, true] {
                let mesh = GeomDesc::Triangles {
                    positions: &positions,
                    indices: &indices,
                };
                let rect = GeomDesc::Rectangle {
                    to_world: Mat4::IDENTITY,
                };
                let geoms = if rect_first {
                    [rect, mesh]
                } else {
                    [mesh, rect]
                };
                let scene = EmbreeScene::build(&geoms).unwrap();
                let (rect_id, mesh_id) = if rect_first { (0, 1) } else { (1, 0) };
                let mut rng = crate::math::Pcg32::new(5, 1);
                let rays: Vec<Ray> = (0..2_000)
                    .map(|_| {
                        let o = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, 2.0);
                        let target =
                            Vec3::new(1.8 * rng.next_f32() - 0.9, 1.8 * rng.next_f32() - 0.9, 0.0);
                        Ray::new(o, (target - o).normalize())
                    })
                    .collect();
                // The packets' rows (`intersect8_with`: built in lanes, only the lanes whose
                // primitive id is UNSURE settled; full and partial packets) and the stream's
                // rows (`intersect_filled`) are the single rays' hits.
                let single: Vec<HitRow> = rays
                    .iter()
                    .map(|r| HitRow::new(scene.intersect(r.o, r.d, r.tmin, r.tmax)))
                    .collect();
                let mut buf = RayBuf::default();
                for (c, chunk) in rays.chunks(8).enumerate() {
                    let n = chunk.len() - c % 3;
                    let mut seen = 0;
                    let ray = |k: usize| &chunk[k];
                    scene.intersect8_with(&mut buf, n, c % 2 == 0, ray, |k, row| {
                        assert_eq!(row, single[8 * c + k], "{dz} packet {c} lane {k}");
                        seen += 1;
                    });
                    assert_eq!(seen, n);
                }
                buf.fill(rays.iter());
                scene.intersect_filled(false, &mut buf, |k, row| {
                    assert_eq!(row, single[k], "{dz} stream ray {k}");
                });
                // The full packets' rows stored in place (`intersect8_rows`), and the stream's
                // (`intersect_filled_into`, ray `k`'s row at `ids[k]`, here reversed; the
                // other rows kept), with no instance to map.
                for (c, chunk) in rays.chunks_exact(8).enumerate() {
                    let mut rows = [HitRow([7; 8]); 8];
                    let on_inst = scene.intersect8_rows(
                        &mut buf,
                        c % 2 == 0,
                        chunk.try_into().unwrap(),
                        &mut rows,
                    );
                    assert_eq!(rows[..], single[8 * c..8 * c + 8], "{dz} packet {c} (rows)");
                    assert_eq!(on_inst, 0, "{dz} packet {c}: no instance");
                }
                let half = rays.len() / 2;
                buf.fill(rays[..half].iter().rev());
                let ids: Vec<u32> = (0..half as u32).rev().collect();
                let mut rows = vec![HitRow([7; 8]); rays.len()];
                // (`map` sees the settled rows too, none of them on an instance here.)
                scene.intersect_filled_into(false, &mut buf, &ids, &mut rows, |r| {
                    assert_eq!(r.inst(), u32::MAX, "no instance");
                    r
                });
                assert_eq!(rows[..half], single[..half], "{dz} stream in place");
                assert!(rows[half..].iter().all(|r| *r == HitRow([7; 8])));
                for ray in &rays {
                    let h = scene.intersect(ray.o, ray.d, ray.tmin, ray.tmax).unwrap();
                    let r = PlanarData::new(&Mat4::IDENTITY, true)
                        .hit(ray.o, ray.d, 0.0, f32::INFINITY)
                        .unwrap();
                    let m = scene.intersect(ray.o, ray.d, ray.tmin, r.t);
                    // `m`: the nearest hit up to the rectangle's t (closed), i.e. the mesh when
                    // it is at least as near.
                    match m {
                        Some(m) if m.t < r.t || (m.t == r.t && mesh_id < rect_id) => {
                            assert_eq!((h.geom, h.t), (mesh_id, m.t), "{dz} {ray:?}");
                        }
                        _ => assert_eq!((h.geom, h.prim, h.t), (rect_id, 0, r.t), "{dz} {ray:?}"),
                    }
                }
            }
        }
    }
}
