//! Area lights sampled in lanes, the same operations in the same order
//! as the scalar code, so every lane equals it bit for bit:
//! - the light selection (`LightSampler::sample`): up to 8 emitters, the count of selection-CDF
//!   entries `<= u_sel` by a compare and add per entry, then each count's emitter and
//!   probability from a table (`Distribution1D::bin_of_prefix`); one emitter needs no count;
//!   more than 8 are searched lane by lane (`x8::Gather::add_x8`); when every selectable
//!   emitter is an untextured rectangle, a constant, point or directional light, the lanes'
//!   emitter data are gathered 8-wide by that count from per-count columns (`x8::Gather::add_table`);
//! - triangle meshes: `Shape::sample_position`'s point on the triangle that
//!   `Shape::pick_triangle` chose (for the untextured lights of one mesh per chunk, 8-wide: a
//!   binary search of the area CDF and the vertex gathers; else lane by lane), uniform triangle
//!   sampling (Shirley & Chiu / Osada et al. 2002's square-root map, `lane::warp`);
//! - rectangles: `Shape::sample_position`'s point `to_world · (2u − 1, 0)`;
//! - spheres seen from outside: `Shape::sample_direction`'s uniform cone of directions toward
//!   the sphere (Mitsuba 3's `Sphere::sample_direction`) and its nearest intersection;
//!
//! then, for the first two, the conversion from area to solid angle (`Shape::sample_direction`),
//! and for all `AreaLight::sample_direct`'s front-side test. A textured radiance (on meshes and
//! rectangles) is looked up at the sampled point's uv in `x8::Gather::finish` (bitmaps 8-wide,
//! `BitmapTexture::eval_x8`; other textures lane by lane). Other emitters, textured sphere
//! lights and a reference point inside (or on) a sphere light stay with the scalar code, lane
//! by lane.

use crate::emitter::Emitter;
use crate::geometry::ShapeKind;
use crate::lane::frame::Frame;
use crate::lane::vec::{V2, V3};
use crate::lane::{warp, Lane};
use crate::scene::Scene;
use crate::spectrum::Spectrum;
use crate::texture::Texture;
use glam::Vec3;

/// An emitter that the kernels sample in lanes: an area light of a constant, non-zero radiance
/// on a triangle mesh of positive area, a rectangle or a sphere, with what the lanes need of
/// its shape (per-shape constants computed once, by the scalar functions).
#[derive(Clone, Copy, Debug)]
pub(crate) enum LaneLight {
    /// On the triangle mesh `shapes[shape]`; `textured`: its radiance is the emitter's texture
    /// at the point's uv (`radiance` unused), looked up in [`x8::Gather::finish`].
    Triangles {
        shape: u32,
        inv_area: f32,
        sign: f32,
        radiance: Spectrum,
        textured: bool,
    },
    /// On a rectangle: the columns of its `to_world` (x, y, z, translation) and the normal of its
    /// points (after `flip_normals`).
    Rectangle {
        axes: [Vec3; 4],
        n: Vec3,
        inv_area: f32,
        radiance: Spectrum,
        /// As for `Triangles` (the uv of a rectangle's point is the sample `u`).
        textured: bool,
    },
    /// On a sphere (sampled in lanes from outside its cone threshold only).
    Sphere {
        center: Vec3,
        radius: f32,
        sign: f32,
        radiance: Spectrum,
    },
    /// `point` ([`super::emitters::sample_point`]).
    Point { position: Vec3, intensity: Spectrum },
    /// `spot` ([`super::emitters::sample_spot`]): the columns of its world-to-light matrix and
    /// its cone; with a texture, `uv_factor` (tan cutoff), the texture looked up in
    /// [`x8::Gather::finish`] ([`super::emitters::spot_uv`]).
    Spot {
        textured: bool,
        uv_factor: f32,
        position: Vec3,
        to_local: [Vec3; 3],
        intensity: Spectrum,
        cos_cutoff: f32,
        cos_beam: f32,
        cutoff: f32,
        beam_width: f32,
    },
    /// `directional`: `d` is minus its direction of travel.
    Directional { d: Vec3, irradiance: Spectrum },
    /// `constant`.
    Constant { radiance: Spectrum },
    /// `envmap`: emitter `emitter` of the scene (its table walk and texel lookups, lane by
    /// lane), its frames' columns and half texel.
    EnvMap {
        emitter: u32,
        to_world: [Vec3; 3],
        to_local: [Vec3; 3],
        half_texel: f32,
    },
}

/// The kinds of light the kernels sample in lanes, in the order of
/// `LaneCounters::kernel_lights`: triangle meshes, rectangles, spheres, point, spot,
/// directional, constant, envmap.
pub(crate) const KINDS: usize = 8;

impl LaneLight {
    /// Per emitter of `scene`, how the kernels sample it in lanes (`None`: lane by lane through
    /// its scalar `sample_direct`).
    pub(crate) fn table(scene: &Scene) -> Vec<Option<LaneLight>> {
        scene
            .emitters
            .iter()
            .enumerate()
            .map(|(i, e)| {
                let cols = |m: glam::Mat3| [m.x_axis, m.y_axis, m.z_axis];
                let a = match e {
                    Emitter::Area(a) => a,
                    Emitter::Point(p) => {
                        return Some(LaneLight::Point {
                            position: p.position,
                            intensity: p.intensity,
                        })
                    }
                    Emitter::Spot(s) => {
                        return Some(LaneLight::Spot {
                            textured: s.texture.is_some(),
                            uv_factor: s.uv_factor,
                            position: s.position,
                            to_local: cols(s.to_local),
                            intensity: s.intensity,
                            cos_cutoff: s.cos_cutoff,
                            cos_beam: s.cos_beam,
                            cutoff: s.cutoff,
                            beam_width: s.beam_width,
                        })
                    }
                    Emitter::Directional(d) => {
                        return Some(LaneLight::Directional {
                            d: -d.direction,
                            irradiance: d.irradiance,
                        })
                    }
                    Emitter::Constant(c) => {
                        return Some(LaneLight::Constant {
                            radiance: c.radiance,
                        })
                    }
                    Emitter::EnvMap(m) => {
                        let (to_world, to_local) = m.frames();
                        return Some(LaneLight::EnvMap {
                            emitter: i as u32,
                            to_world: cols(to_world),
                            to_local: cols(to_local),
                            half_texel: m.half_texel(),
                        });
                    }
                    _ => return None,
                };
                // A textured radiance: looked up in lanes at the sampled point's uv (bitmaps
                // 8-wide, other textures lane by lane); a zero constant one is never sampled.
                let (radiance, textured) = match a.radiance {
                    Texture::Constant(c) if c == Spectrum::ZERO => return None,
                    Texture::Constant(c) => (c, false),
                    _ => (Spectrum::ZERO, true),
                };
                let shape = &scene.shapes[a.shape as usize];
                let sign = if shape.flip_normals { -1.0 } else { 1.0 };
                // As `Shape::sample_position` computes its pdf.
                let inv_area = 1.0 / shape.area();
                match &shape.kind {
                    ShapeKind::Mesh(_) if shape.samples_triangles() => Some(LaneLight::Triangles {
                        shape: a.shape,
                        inv_area,
                        sign,
                        radiance,
                        textured,
                    }),
                    ShapeKind::Rectangle { to_world } => Some(LaneLight::Rectangle {
                        axes: [
                            to_world.x_axis.truncate(),
                            to_world.y_axis.truncate(),
                            to_world.z_axis.truncate(),
                            to_world.w_axis.truncate(),
                        ],
                        n: shape.rectangle_normal() * sign,
                        inv_area,
                        radiance,
                        textured,
                    }),
                    // A textured sphere light: lane by lane (its uv map is not in lanes).
                    ShapeKind::Sphere { .. } if textured => None,
                    ShapeKind::Sphere { center, radius, .. } => Some(LaneLight::Sphere {
                        center: *center,
                        radius: *radius,
                        sign,
                        radiance,
                    }),
                    _ => None,
                }
            })
            .collect()
    }
}

/// One triangle per lane: its corners, optional per-vertex normals, the mesh's
/// `1 / area`, the sign of `flip_normals` and the rescaled sample `u`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Triangle<L: Lane> {
    pub p: [V3<L>; 3],
    /// Vertex normals, where `has_normals`.
    pub n: [V3<L>; 3],
    pub has_normals: L::Mask,
    pub inv_area: L,
    /// −1 where the shape flips its normals, else 1.
    pub sign: L,
    pub u: V2<L>,
}

/// One rectangle per lane: the columns of its `to_world`, the normal of its points (signed),
/// `1 / area` and the sample `u`.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Rectangle<L: Lane> {
    pub axes: [V3<L>; 4],
    pub n: V3<L>,
    pub inv_area: L,
    pub u: V2<L>,
}

/// One sphere per lane, seen from outside its cone threshold (`shapes::sphere_sees_cone`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Sphere<L: Lane> {
    pub center: V3<L>,
    pub radius: L,
    /// −1 where the shape flips its normals, else 1.
    pub sign: L,
    pub u: V2<L>,
}

/// A light point sampled from `ref_p` (see `emitter::DirectSample`); `ok` where
/// `Shape::sample_direction` and the area light accept it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct AreaPoint<L: Lane> {
    pub ok: L::Mask,
    pub d: V3<L>,
    pub dist: L,
    pub p: V3<L>,
    pub n: V3<L>,
    pub pdf: L,
}

/// glam's `try_normalize(v)`: `v · (1/|v|)`, and where that reciprocal is finite and positive.
#[inline(always)]
fn try_normalize<L: Lane>(v: V3<L>) -> (V3<L>, L::Mask) {
    let rcp = v.x.splat(1.0) / v.length();
    (v.scale(rcp), rcp.is_finite() & rcp.gt(v.x.splat(0.0)))
}

/// glam's `try_normalize(v).unwrap_or(fallback)`.
#[inline(always)]
fn normalize_or<L: Lane>(v: V3<L>, fallback: V3<L>) -> V3<L> {
    let (n, ok) = try_normalize(v);
    V3::select(ok, n, fallback)
}

/// A point `p` with normal `n` sampled by area with density `pdf_area`, seen from `ref_p`:
/// `Shape::sample_direction`'s conversion to solid angle and `AreaLight::sample_direct`'s test.
#[inline(always)]
fn by_area<L: Lane>(p: V3<L>, n: V3<L>, pdf_area: L, ref_p: V3<L>) -> AreaPoint<L> {
    let k = |c: f32| ref_p.x.splat(c);
    let v = p - ref_p;
    let dist2 = v.length_squared();
    let dist = dist2.sqrt();
    let ok = !pdf_area.eq(k(0.0)) & !(dist.is_nan() | dist.le(k(0.0)));
    let d = v.div_by(dist);
    let cos = d.dot(n).abs();
    let pdf = pdf_area * dist2 / cos;
    let ok = ok & cos.gt(k(0.0)) & pdf.is_finite();
    AreaPoint {
        ok: ok & front(n, d, pdf),
        d,
        dist,
        p,
        n,
        pdf,
    }
}

/// `AreaLight::sample_direct`'s test: the light point faces the reference point and the density
/// is positive and finite.
#[inline(always)]
fn front<L: Lane>(n: V3<L>, d: V3<L>, pdf: L) -> L::Mask {
    let zero = pdf.splat(0.0);
    !n.dot(-d).le(zero) & pdf.is_finite() & pdf.gt(zero)
}

/// A point on each lane's triangle seen from `ref_p`.
#[inline(always)]
pub(crate) fn sample_triangle<L: Lane>(t: &Triangle<L>, ref_p: V3<L>) -> AreaPoint<L> {
    let k = |c: f32| ref_p.x.splat(c);
    // Shape::sample_position.
    let b = warp::square_to_uniform_triangle(t.u);
    let b0 = k(1.0) - b.x - b.y;
    let [p0, p1, p2] = t.p;
    let e1 = p1 - p0;
    let e2 = p2 - p0;
    let p = (p0 + e1.scale(b.x)) + e2.scale(b.y);
    let ng = normalize_or(e1.cross(e2), V3::new(k(0.0), k(0.0), k(1.0)));
    let [n0, n1, n2] = t.n;
    let ns = normalize_or((n0.scale(b0) + n1.scale(b.x)) + n2.scale(b.y), ng);
    let n = V3::select(t.has_normals, ns, ng).scale(t.sign);
    by_area(p, n, t.inv_area, ref_p)
}

/// A point on each lane's rectangle seen from `ref_p`.
#[inline(always)]
pub(crate) fn sample_rectangle<L: Lane>(r: &Rectangle<L>, ref_p: V3<L>) -> AreaPoint<L> {
    let k = |c: f32| ref_p.x.splat(c);
    // Shape::sample_position: l = (2u − 1, 0), then glam's `Mat4::transform_point3` in its
    // order, w + (z·l.z + (y·l.y + x·l.x)) (the zero l.z kept: it can carry a −0 or a NaN).
    let (lx, ly, lz) = (k(2.0) * r.u.x - k(1.0), k(2.0) * r.u.y - k(1.0), k(0.0));
    let [ax, ay, az, aw] = r.axes;
    let p = aw + (az.scale(lz) + (ay.scale(ly) + ax.scale(lx)));
    by_area(p, r.n, r.inv_area, ref_p)
}

/// A point on each lane's sphere seen from `ref_p` outside it: the direction uniform in the
/// cone the sphere subtends, the point its nearest intersection (PBRT-v3 §14.2.3 / Mitsuba 3's
/// `Sphere::sample_direction`, as `Shape::sample_direction` writes it).
#[inline(always)]
pub(crate) fn sample_sphere<L: Lane>(s: &Sphere<L>, ref_p: V3<L>) -> AreaPoint<L> {
    let k = |c: f32| ref_p.x.splat(c);
    let dc = s.center - ref_p;
    let dist_c = dc.length();
    let sin_a = s.radius / dist_c;
    let cos_a = warp::safe_sqrt(k(1.0) - sin_a * sin_a);
    let axis = dc.div_by(dist_c);
    let d = Frame::from_normal(axis).to_world(warp::square_to_uniform_cone(s.u, cos_a));
    let b = d.dot(dc);
    let disc = (s.radius * s.radius - (dist_c * dist_c - b * b)).max(k(0.0));
    let t = b - disc.sqrt();
    let (n0, ok) = try_normalize((ref_p + d.scale(t)) - s.center);
    let p = s.center + n0.scale(s.radius);
    let v = p - ref_p;
    let dist = v.length();
    let pdf = warp::uniform_cone_pdf(cos_a);
    let ok = ok & dist.gt(k(0.0)) & pdf.is_finite();
    let n = n0.scale(s.sign);
    let d = v.div_by(dist);
    AreaPoint {
        ok: ok & front(n, d, pdf),
        d,
        dist,
        p,
        n,
        pdf,
    }
}

/// The light points of 8 paths, gathered lane by lane and completed 8-wide: the one gather of
/// every kernel (`diffuse`, the plastic kernel and the wrapper-chain driver).
#[cfg(target_arch = "x86_64")]
pub(crate) mod x8 {
    use super::*;
    use crate::geometry::shapes::sphere_sees_cone;
    use crate::lane::{Lane, LaneI32, ToArray, Wide};
    use crate::stream::kernels::diffuse::LightPoint;
    use crate::stream::kernels::emitters::{self as em, Env, FreePoint, Spot};
    use glam::Vec2;
    use std::sync::Arc;

    /// The kinds of `Batch::light_lanes` (index + 1; [`KINDS`]), as `i32`s: [`Gather`]'s
    /// `kind` column is loaded into integer lanes as it is.
    const KIND_TRIANGLE: i32 = 1;
    const KIND_RECTANGLE: i32 = 2;
    const KIND_SPHERE: i32 = 3;
    const KIND_POINT: i32 = 4;
    const KIND_SPOT: i32 = 5;
    const KIND_DIRECTIONAL: i32 = 6;
    const KIND_CONSTANT: i32 = 7;
    const KIND_ENVMAP: i32 = 8;

    /// Three columns of 8 floats (a 3-vector per lane).
    #[derive(Clone, Copy)]
    pub(crate) struct Cols3<const W: usize = 8>(pub [[f32; W]; 3]);

    impl<const W: usize> Default for Cols3<W> {
        #[inline(always)]
        fn default() -> Self {
            Cols3([[0.0; W]; 3])
        }
    }

    /// Three column triples loaded, written out: `std::array::from_fn` there was an
    /// out-of-line call compiled without the lanes' target features (~380 instructions per
    /// call, `docs/bench/README.md`, fourteenth session).
    #[inline(always)]
    fn load3<T: Wide<W>, const W: usize>(avx: T, c: &[Cols3<W>; 3]) -> [V3<T::F>; 3] {
        [c[0].load(avx), c[1].load(avx), c[2].load(avx)]
    }

    /// [`load3`] of four.
    #[inline(always)]
    fn load4<T: Wide<W>, const W: usize>(avx: T, c: &[Cols3<W>; 4]) -> [V3<T::F>; 4] {
        [
            c[0].load(avx),
            c[1].load(avx),
            c[2].load(avx),
            c[3].load(avx),
        ]
    }

    impl<const W: usize> Cols3<W> {
        #[inline(always)]
        pub(crate) fn set(&mut self, k: usize, v: Vec3) {
            self.0[0][k] = v.x;
            self.0[1][k] = v.y;
            self.0[2][k] = v.z;
        }
        #[inline(always)]
        pub(crate) fn get(&self, k: usize) -> Vec3 {
            Vec3::new(self.0[0][k], self.0[1][k], self.0[2][k])
        }
        #[inline(always)]
        pub(crate) fn load<T: Wide<W>>(&self, avx: T) -> V3<T::F> {
            V3::new(
                avx.load(&self.0[0]),
                avx.load(&self.0[1]),
                avx.load(&self.0[2]),
            )
        }
        #[inline(always)]
        pub(crate) fn store<L: Lane + crate::lane::ToArray<f32, W>>(v: V3<L>) -> Cols3<W> {
            Cols3([v.x.to_array(), v.y.to_array(), v.z.to_array()])
        }
    }

    /// Column `col` of a [`Table`] at each lane's selection count (`SMALL`: every count is
    /// below 8, so the column's first 8 entries are looked up by a permute, not gathered).
    #[inline(always)]
    fn by_count<T: Wide<W>, const W: usize, const SMALL: bool>(
        col: &[f32; 10],
        count: T::I,
    ) -> [f32; W] {
        match col.first_chunk::<8>() {
            Some(head) if SMALL => lookup8::<T::F>(head, count).to_array(),
            _ => T::F::gather(col, count).to_array(),
        }
    }

    /// Entry `c` of a [`Table`]'s three columns in every lane.
    #[inline(always)]
    fn splat_at<const W: usize>(col: &[[f32; 10]; 3], c: usize) -> Cols3<W> {
        Cols3([[col[0][c]; W], [col[1][c]; W], [col[2][c]; W]])
    }

    /// `table[idx]` per lane for a table of at most 8 entries (`lane::LaneLookup::lookup8`:
    /// `vpermps`, where a gather would load every lane).
    #[inline(always)]
    fn lookup8<L: Lane>(table: &[f32; 8], idx: L::I32) -> L {
        <L::I32 as crate::lane::LaneLookup<L>>::lookup8(table, idx)
    }

    /// A mesh light of at most 8 triangles as tables by triangle, for
    /// [`Gather::triangles_x8`]'s lookups (a permute per column instead of the gathers of the
    /// vertex indices, then of their positions and normals); built from the mesh at the first
    /// chunk of a run that picks its triangles.
    #[derive(Clone, Copy)]
    struct SmallMesh {
        /// The shape it was built from (`u32::MAX`: none yet).
        shape: u32,
        /// The triangle CDF (`Shape::triangle_cdf`), zero after its `m` entries.
        cdf: [f32; 8],
        /// Corner `c`'s position and vertex normal, component by component, per triangle.
        pos: [[[f32; 8]; 3]; 3],
        norm: [[[f32; 8]; 3]; 3],
    }

    /// The largest mesh light [`SmallMesh`] holds.
    const SMALL_MESH: usize = 8;

    impl SmallMesh {
        const NONE: SmallMesh = SmallMesh {
            shape: u32::MAX,
            cdf: [0.0; 8],
            pos: [[[0.0; 8]; 3]; 3],
            norm: [[[0.0; 8]; 3]; 3],
        };

        /// The tables of mesh `shape` (`m` ≤ 8 triangles, triangle CDF `cdf`).
        fn new(shape: u32, mesh: &crate::geometry::TriMesh, cdf: &[f32]) -> SmallMesh {
            let mut s = SmallMesh::NONE;
            s.shape = shape;
            for (t, &c) in cdf.iter().enumerate().take(SMALL_MESH) {
                s.cdf[t] = c;
                for (corner, &j) in mesh.indices[t].iter().enumerate() {
                    let p = mesh.positions[j as usize];
                    (
                        s.pos[corner][0][t],
                        s.pos[corner][1][t],
                        s.pos[corner][2][t],
                    ) = (p.x, p.y, p.z);
                    if let Some(ns) = &mesh.normals {
                        let n = ns[j as usize];
                        (
                            s.norm[corner][0][t],
                            s.norm[corner][1][t],
                            s.norm[corner][2][t],
                        ) = (n.x, n.y, n.z);
                    }
                }
            }
            s
        }
    }

    /// The number of lanes set in `bits` (at most 16 lanes): two lookups in the bytes' counts
    /// ([`crate::lane::bits::BYTE_COUNTS`]).
    #[inline(always)]
    fn lane_count(bits: u32) -> u32 {
        let c = &crate::lane::bits::BYTE_COUNTS;
        c[(bits & 0xff) as usize] as u32 + c[(bits >> 8 & 0xff) as usize] as u32
    }

    /// The bits of the lanes of a chunk `w` lanes wide (bits `0..w`).
    #[inline(always)]
    pub(crate) const fn lane_bits(w: usize) -> u32 {
        if w >= 32 {
            u32::MAX
        } else {
            (1 << w) - 1
        }
    }

    /// Sets or clears bit `k` of `bits` by `on`.
    #[inline(always)]
    fn set_bit(bits: &mut u32, k: usize, on: bool) {
        *bits = (*bits & !(1 << k)) | (on as u32) << k;
    }

    /// The lanes whose kind (`kinds`: [`Gather`]'s `kind` column as integers) is `c`.
    #[inline(always)]
    fn is_kind<T: Wide<W>, const W: usize>(kinds: T::I, c: i32) -> T::M {
        kinds.eq(kinds.splat(c))
    }

    /// `new` where `on`, else the column `old` (`WHOLE`: `new` everywhere).
    #[inline(always)]
    fn keep<T: Wide<W>, const W: usize, const WHOLE: bool>(
        avx: T,
        on: T::M,
        new: V3<T::F>,
        old: &Cols3<W>,
    ) -> V3<T::F> {
        if WHOLE {
            new
        } else {
            V3::select(on, new, old.load(avx))
        }
    }

    /// Where `on`, the light point `q` of an 8-wide area-light sampler (its density times the
    /// selection probability `sel`) replaces the lane-by-lane one.
    #[inline(always)]
    fn merge<L: Lane>(lp: &mut LightPoint<L>, on: L::Mask, q: &AreaPoint<L>, sel: L) {
        lp.some = lp.some | (on & q.ok);
        lp.d = V3::select(on, q.d, lp.d);
        lp.p = V3::select(on, q.p, lp.p);
        lp.n = V3::select(on, q.n, lp.n);
        lp.has_n = lp.has_n | on;
        lp.finite = (on & q.dist.is_finite()) | (!on & lp.finite);
        lp.pdf = L::select(on, q.pdf * sel, lp.pdf);
    }

    /// Where `on`, the light sample `q` of an emitter without a surface (density times the
    /// selection probability `sel`) replaces the lane-by-lane one; a zero `value` is no sample
    /// (`nee::sample_emitter`).
    #[inline(always)]
    fn merge_free<L: Lane>(lp: &mut LightPoint<L>, on: L::Mask, q: &FreePoint<L>, sel: L) {
        let z = sel.splat(0.0);
        let nonzero = !(q.value.x.eq(z) & q.value.y.eq(z) & q.value.z.eq(z));
        lp.some = lp.some | (on & q.ok & nonzero);
        lp.d = V3::select(on, q.d, lp.d);
        lp.p = V3::select(on, q.p, lp.p);
        lp.finite = (on & q.dist.is_finite()) | (!on & lp.finite);
        lp.pdf = L::select(on, q.pdf * sel, lp.pdf);
        lp.value = V3::select(on, q.value, lp.value);
    }

    /// The part of a [`Gather`] that [`Gather::reset`] clears per chunk, in one block of 32-bit
    /// words (`repr(C)`), so that the clear is a few vector stores: spread over the gather as
    /// separate fields, the flags as bits cost ~27 instructions per chunk to clear
    /// (`docs/bench/README.md`, twenty-fifth session, h3).
    #[derive(Clone, Copy)]
    #[repr(C)]
    struct Flags<const W: usize> {
        /// Per-lane flags as bits (bit `k` for lane `k`): masks in [`Gather::finish`] by
        /// `Wide::mask_bits`, without `[bool; W]` stores read back as vectors.
        some: u32,
        has_n: u32,
        finite: u32,
        /// No MIS weight (delta lights, `light_only`).
        one: u32,
        /// Bits: the lane's triangle has vertex normals.
        tnorm_some: u32,
        /// Lanes of the chunk with a textured light (`textured` is written by every lane that
        /// picks a triangle, rectangle or spot light, and read only where this is positive).
        n_textured: u32,
        /// The lanes (bits) whose triangle (of mesh `tri_shape`, untextured) [`Gather::add_x8`]
        /// picks 8-wide after its lane-by-lane pass, and how many there are.
        deferred: u32,
        n_deferred: u32,
        /// The lane's light sampled 8-wide: 0 none, else `KIND_*`.
        kind: [i32; W],
        counts: [u32; KINDS],
    }

    impl<const W: usize> Flags<W> {
        /// No light point in any lane.
        const ZERO: Flags<W> = Flags {
            some: 0,
            has_n: 0,
            finite: 0,
            one: 0,
            tnorm_some: 0,
            n_textured: 0,
            deferred: 0,
            n_deferred: 0,
            kind: [0; W],
            counts: [0; KINDS],
        };
    }

    /// `nee::sample_emitter` for 8 paths: [`Gather::add_x8`] (the light selection 8-wide, one
    /// mesh light's triangles picked 8-wide; lane by lane the
    /// point of every emitter that has no [`LaneLight`] through its own scalar
    /// `sample_direct`, a sphere light lane by lane from inside its cone threshold, an
    /// environment map's table walk), then [`Gather::finish`] samples the lanes' triangles,
    /// rectangles, spheres, point, spot, directional, constant and environment lights 8-wide
    /// (an environment map's density and texels looked up lane by lane in between).
    pub(crate) struct Gather<const W: usize = 8> {
        ld: Cols3<W>,
        lpp: Cols3<W>,
        ln: Cols3<W>,
        lv: Cols3<W>,
        lpdf: [f32; W],
        /// What [`Gather::reset`] clears per chunk: the flags, kinds and counts.
        f: Flags<W>,
        tpos: [Cols3<W>; 3],
        tnorm: [Cols3<W>; 3],
        raxes: [Cols3<W>; 4],
        rn: Cols3<W>,
        /// A sphere's centre, a point or spot light's position, a directional light's direction.
        center: Cols3<W>,
        /// A spot light's world-to-light columns, an environment map's map-to-world ones.
        mat: [Cols3<W>; 3],
        /// An environment map's world-to-map columns.
        mat2: [Cols3<W>; 3],
        /// A spot light's cos cutoff, cos beam width, cutoff, beam width.
        cone: [[f32; W]; 4],
        half_texel: [f32; W],
        /// An environment map's emitter index.
        emitter: [u32; W],
        radius: [f32; W],
        inv_area: [f32; W],
        sign: [f32; W],
        sel: [f32; W],
        tux: [f32; W],
        tuy: [f32; W],
        /// Bits: the lane's radiance (area) or intensity factor (spot) is emitter
        /// `emitter[k]`'s texture, looked up in [`Gather::finish`].
        textured: u32,
        /// A textured triangle's corner uvs (u, v per corner), where `tuv_some` (else the
        /// barycentrics are its uv, as `Shape::sample_position`).
        tuv: [[[f32; W]; 2]; 3],
        /// Bits: where the textured triangle has corner uvs.
        tuv_some: u32,
        /// A textured spot light's `tan cutoff`.
        uv_factor: [f32; W],
        tri_shape: u32,
        /// The light selection in lanes, made from the scene's light sampler at the first
        /// [`Gather::add_x8`] (a gather serves one scene; shared, not copied, per chunk; an
        /// `Arc`, so that a worker's batch, which keeps its gathers for the whole render, may
        /// move between threads).
        select: Option<Arc<Select>>,
        /// The small mesh light last picked from ([`SmallMesh`]).
        small: SmallMesh,
        /// Whether [`Gather::triangles_x8`] may use [`SmallMesh`] (tests turn it off to
        /// compare with the gathers).
        small_ok: bool,
        /// The columns of a [`Table::fixed`] table (rectangle, `center`) hold its constants in
        /// every lane, written by an earlier [`Gather::add_table`]; cleared by every other
        /// writer of those columns.
        table_fixed: bool,
    }

    /// `LightSampler::sample`'s emitter and probability for 8 lanes at once: the count of CDF
    /// entries `<= u_sel` (`Distribution1D::sample`'s counted form, ≤ 8 bins) by a compare and
    /// add per entry in lanes, then the bin of each count from a table
    /// (`Distribution1D::bin_of_prefix`, the zero-mass skipping included). The rescaled `u`
    /// is not needed (`nee::sample_emitter` drops it).
    #[derive(Clone, Copy, Debug)]
    struct Select {
        /// No emitter (`None` from the sampler), one bin for every count, counted, or
        /// searched lane by lane (more bins than the counted form takes).
        mode: SelectMode,
        /// The CDF's entries (`n + 1`, at most 9).
        cdf: [f32; 9],
        n: usize,
        /// Per count of entries `<= u` (0..=n + 1): the emitter and its probability.
        emitter: [u32; 10],
        pmf: [f32; 10],
        /// Per count, what [`Gather::add_selected`] writes for its emitter, when every
        /// count's emitter is one whose writes do not depend on the lane ([`Table`]).
        table: Option<Table>,
    }

    /// [`Select`]'s emitters as columns indexed by the count of CDF entries `<= u_sel`, for
    /// [`Gather::add_table`]: made when every emitter of the selection is an untextured
    /// rectangle, a constant, a point or a directional light (the writes of
    /// [`Gather::add_selected`] are then constants of the emitter: no triangle to pick, no
    /// cone test, no table walk), so that 8 lanes' writes are 8-wide gathers (by count) instead
    /// of a pass lane by lane. Unused entries of a column are 0 (never read: a lane's kind masks
    /// them in [`Gather::finish`]).
    #[derive(Clone, Copy, Debug, Default)]
    struct Table {
        /// The `KIND_*` of each count's emitter, as integers and as the bits of floats (looked
        /// up by a permute).
        kind: [u32; 10],
        kind_bits: [f32; 10],
        /// Bit `c − 1` for each `KIND_*` `c` some count's emitter has.
        kinds: u32,
        /// The radiance (intensity, irradiance) of each count's emitter.
        le: [[f32; 10]; 3],
        /// A rectangle's columns (x, y, z, translation) and normal, and `1 / area`.
        axes: [[[f32; 10]; 3]; 4],
        n: [[f32; 10]; 3],
        inv_area: [f32; 10],
        /// A point light's position or a directional light's direction.
        center: [[f32; 10]; 3],
        /// Which of the columns above some emitter uses.
        rect: bool,
        center_used: bool,
        /// The rectangle columns (`axes`, `n`, `inv_area`) and the `center` column each hold
        /// one emitter's values at every count that sets them (one rectangle; one point or
        /// directional light), at count `fixed_at.0` and `fixed_at.1`: [`Gather::add_table`]
        /// then writes them once per gather, as constants in every lane, not per chunk.
        fixed: bool,
        fixed_at: (usize, usize),
    }

    impl Table {
        /// The table of the emitters `emitter[..=n + 1]` (`lights`: `LaneLight::table`), or
        /// `None` if one is not a constant of its emitter.
        fn new(lights: &[Option<LaneLight>], emitter: &[u32; 10], n: usize) -> Option<Table> {
            let mut t = Table::default();
            for (c, &e) in emitter.iter().enumerate().take(n + 2) {
                let set3 = |col: &mut [[f32; 10]; 3], v: Vec3| {
                    (col[0][c], col[1][c], col[2][c]) = (v.x, v.y, v.z);
                };
                let (kind, le) = match *lights.get(e as usize)? {
                    Some(LaneLight::Rectangle {
                        axes,
                        n,
                        inv_area,
                        radiance,
                        textured: false,
                    }) => {
                        for (col, a) in t.axes.iter_mut().zip(axes) {
                            set3(col, a);
                        }
                        set3(&mut t.n, n);
                        t.inv_area[c] = inv_area;
                        t.rect = true;
                        (KIND_RECTANGLE, radiance)
                    }
                    Some(LaneLight::Constant { radiance }) => (KIND_CONSTANT, radiance),
                    Some(LaneLight::Point {
                        position,
                        intensity,
                    }) => {
                        set3(&mut t.center, position);
                        t.center_used = true;
                        (KIND_POINT, intensity)
                    }
                    Some(LaneLight::Directional { d, irradiance }) => {
                        set3(&mut t.center, d);
                        t.center_used = true;
                        (KIND_DIRECTIONAL, irradiance)
                    }
                    _ => return None,
                };
                t.kind[c] = kind as u32;
                t.kind_bits[c] = f32::from_bits(kind as u32);
                t.kinds |= 1 << (kind - 1);
                set3(&mut t.le, le);
            }
            t.set_fixed(n);
            Some(t)
        }

        /// [`Table::fixed`] and [`Table::fixed_at`] of the first `n + 2` counts: whether every
        /// count of a rectangle has the first one's rectangle columns (bit for bit), and every
        /// count of a point or directional light the first one's `center`.
        /// (No allocation: a selection is made per gather, and the compensated kernel makes a
        /// gather per run; with `Vec`s here its allocations cost ~69 instructions a sample.)
        fn set_fixed(&mut self, n: usize) {
            let same = |col: &[[f32; 10]; 3], a: usize, b: usize| {
                (0..3).all(|i| col[i][a].to_bits() == col[i][b].to_bits())
            };
            let (mut r0, mut c0, mut fixed) = (None, None, true);
            for c in 0..n + 2 {
                match self.kind[c] as i32 {
                    KIND_RECTANGLE => {
                        let r = *r0.get_or_insert(c);
                        fixed &= self.axes.iter().all(|a| same(a, r, c))
                            && same(&self.n, r, c)
                            && self.inv_area[r].to_bits() == self.inv_area[c].to_bits();
                    }
                    KIND_POINT | KIND_DIRECTIONAL => {
                        let r = *c0.get_or_insert(c);
                        fixed &= same(&self.center, r, c);
                    }
                    _ => {}
                }
            }
            self.fixed = fixed;
            self.fixed_at = (r0.unwrap_or(0), c0.unwrap_or(0));
        }
    }

    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    enum SelectMode {
        Empty,
        One,
        Counted,
        Searched,
    }

    impl Select {
        fn new(scene: &Scene, lights: &[Option<LaneLight>]) -> Select {
            let mut s = Select {
                mode: SelectMode::Empty,
                cdf: [0.0; 9],
                n: 0,
                emitter: [0; 10],
                pmf: [0.0; 10],
                table: None,
            };
            let Some(d) = scene.light_sampler.distribution() else {
                return s;
            };
            if !d.is_counted() {
                s.mode = SelectMode::Searched;
                return s;
            }
            s.n = d.len();
            s.cdf[..=s.n].copy_from_slice(d.cdf());
            for c in 0..=s.n + 1 {
                let i = d.bin_of_prefix(c);
                (s.emitter[c], s.pmf[c]) = (i as u32, d.pmf(i));
            }
            let one = (0..=s.n + 1).all(|c| s.emitter[c] == s.emitter[0]);
            s.mode = if one {
                SelectMode::One
            } else {
                SelectMode::Counted
            };
            s.table = Table::new(lights, &s.emitter, s.n);
            s
        }
    }

    /// The kind of light ([`KINDS`], `KIND_*`) that [`Gather::finish`] samples emitter `e` as
    /// (0: none, its scalar `sample_direct` lane by lane).
    fn kind_of(lights: &[Option<LaneLight>], e: u32) -> u32 {
        let kind = match lights.get(e as usize) {
            Some(Some(l)) => match l {
                LaneLight::Triangles { .. } => KIND_TRIANGLE,
                LaneLight::Rectangle { .. } => KIND_RECTANGLE,
                LaneLight::Sphere { .. } => KIND_SPHERE,
                LaneLight::Point { .. } => KIND_POINT,
                LaneLight::Spot { .. } => KIND_SPOT,
                LaneLight::Directional { .. } => KIND_DIRECTIONAL,
                LaneLight::Constant { .. } => KIND_CONSTANT,
                LaneLight::EnvMap { .. } => KIND_ENVMAP,
            },
            _ => 0,
        };
        kind as u32
    }

    /// A threshold `t` on the light selection's number `u_sel` that splits the scene's
    /// emitters by kind: every emitter that a `u_sel < t` selects is of another kind than
    /// every one that a `u_sel >= t` selects (`LightSampler::sample`'s counted form: the
    /// count of CDF entries `<= u_sel` is at least `c` exactly where `cdf[c − 1] <= u_sel`).
    /// `None` when the selection is not counted ([`SelectMode::Counted`]) or no threshold
    /// separates the kinds (one kind, or kinds interleaved in the CDF's order).
    ///
    /// The material sort uses it as a grouping hint (`Batch::sort_by_material`): paths whose
    /// next number is on the same side of `t` sample the same kinds of light, so a chunk of
    /// them skips the other kinds in [`Gather::finish`] (its samplers run per kind some lane
    /// picked). A hint only: nothing computed depends on it.
    pub(crate) fn kind_split(scene: &Scene, lights: &[Option<LaneLight>]) -> Option<f32> {
        let s = Select::new(scene, lights);
        if s.mode != SelectMode::Counted {
            return None;
        }
        // The counts a number in [0, 1) reaches when the CDF runs from 0 to 1: 1..=n (the
        // others only make the split a worse hint).
        let kinds: Vec<u32> = (1..=s.n).map(|c| kind_of(lights, s.emitter[c])).collect();
        let set = |ks: &[u32]| ks.iter().fold(0u32, |b, &k| b | 1 << k);
        // The split nearest the middle of the probability among those that separate the kinds.
        (2..=s.n)
            .filter(|&c| set(&kinds[..c - 1]) & set(&kinds[c - 1..]) == 0)
            .map(|c| s.cdf[c - 1])
            .min_by(|a, b| (a - 0.5).abs().total_cmp(&(b - 0.5).abs()))
    }

    impl<const W: usize> Gather<W> {
        /// Ready for a chunk: no light point in any lane. Only the flags are cleared: the
        /// columns keep the last chunk's values in the lanes that [`Gather::add_x8`] does not
        /// write, which the masks of [`Gather::finish`] and of the kernels drop (resetting
        /// ~2 KB per chunk cost ~350 instructions per sample on the Cornell box).
        #[inline(always)]
        pub(crate) fn reset(&mut self) {
            self.f = Flags::ZERO;
        }

        /// No light point in any lane (made once per run of a material, [`Gather::reset`] per
        /// chunk).
        #[inline(always)]
        pub(crate) fn new() -> Gather<W> {
            Gather {
                ld: Cols3::default(),
                lpp: Cols3::default(),
                ln: Cols3::default(),
                lv: Cols3::default(),
                lpdf: [1.0; W],
                f: Flags::ZERO,
                tpos: Default::default(),
                tnorm: Default::default(),
                raxes: Default::default(),
                rn: Cols3::default(),
                center: Cols3::default(),
                mat: Default::default(),
                mat2: Default::default(),
                cone: [[0.0; W]; 4],
                half_texel: [0.0; W],
                emitter: [0; W],
                radius: [0.0; W],
                inv_area: [0.0; W],
                sign: [1.0; W],
                sel: [1.0; W],
                tux: [0.0; W],
                tuy: [0.0; W],
                textured: 0,
                tuv: [[[0.0; W]; 2]; 3],
                tuv_some: 0,
                uv_factor: [1.0; W],
                tri_shape: 0,
                select: None,
                small: SmallMesh::NONE,
                small_ok: true,
                table_fixed: false,
            }
        }

        /// The same gather with [`SmallMesh`] turned off: every mesh light's triangles
        /// gathered (tests: the lookups equal the gathers).
        #[cfg(test)]
        pub(crate) fn without_small_meshes(mut self) -> Gather<W> {
            self.small_ok = false;
            self
        }

        /// The light points of the lanes `on` (bit `k` for lane `k`: the kernels' side test as
        /// bits, `surface::x8::Prologue::bits`, so that no mask is rebuilt from booleans) of a
        /// chunk (`lights`: `LaneLight::table`;
        /// `light_only`: the MIS weight is 1): the light selection 8-wide ([`Select`]) and the
        /// triangles of one untextured mesh light picked 8-wide ([`Gather::triangles_x8`]); the
        /// rest lane by lane ([`Gather::add_selected`]). `u_sel`, `u`:
        /// the lanes' light-sample numbers; `p`: their surface points.
        #[inline(always)]
        #[allow(clippy::too_many_arguments)]
        pub(crate) fn add_x8<T: Wide<W>>(
            &mut self,
            avx: T,
            scene: &Scene,
            lights: &[Option<LaneLight>],
            light_only: bool,
            on: u32,
            u_sel: &[f32; W],
            u: &[[f32; W]; 2],
            p: &Cols3<W>,
        ) {
            // The selection moved out and back (not an `Arc` clone and drop per chunk).
            let sel = match self.select.take() {
                Some(s) => s,
                None => Arc::new(Select::new(scene, lights)),
            };
            self.add_with(avx, &sel, scene, lights, light_only, on, u_sel, u, p);
            self.select = Some(sel);
        }

        /// [`Gather::add_x8`] with the scene's selection `sel`.
        #[inline(always)]
        #[allow(clippy::too_many_arguments)]
        fn add_with<T: Wide<W>>(
            &mut self,
            avx: T,
            sel: &Select,
            scene: &Scene,
            lights: &[Option<LaneLight>],
            light_only: bool,
            on: u32,
            u_sel: &[f32; W],
            u: &[[f32; W]; 2],
            p: &Cols3<W>,
        ) {
            if sel.mode == SelectMode::Empty {
                return;
            }
            // The lanes of the chunk only (a caller's bits above `W` are not lanes).
            let on_bits = on & lane_bits(W);
            let lane_on = |k: usize| on_bits >> k & 1 != 0;
            // Distribution1D::sample's count of the CDF entries <= u, 8-wide (one count,
            // 0, for every lane where one emitter takes every count).
            let count = if sel.mode == SelectMode::Counted {
                let us = avx.load(u_sel);
                let (zero, one) = (avx.splat(0.0), avx.splat(1.0));
                let mut count = zero;
                for &c in &sel.cdf[..=sel.n] {
                    count = count + T::F::select(avx.splat(c).le(us), one, zero);
                }
                count.trunc_i32()
            } else {
                avx.load_i32(&[0; W])
            };
            // One emitter keeps the whole-chunk path below (`add_uniform`), which is cheaper
            // than the table's gathers.
            if let (Some(t), SelectMode::Counted) = (&sel.table, sel.mode) {
                // Counts 0..=n + 1: below 8, the columns are looked up by a permute.
                if sel.n + 2 <= 8 {
                    self.add_table::<T, true>(avx, t, &sel.pmf, count, light_only, on_bits, u);
                } else {
                    self.add_table::<T, false>(avx, t, &sel.pmf, count, light_only, on_bits, u);
                }
                return;
            }
            // The writers below may change the rectangle and `center` columns.
            self.table_fixed = false;
            let mut emitter = [sel.emitter[0]; W];
            let mut pmf = [sel.pmf[0]; W];
            match sel.mode {
                SelectMode::Empty | SelectMode::One => {}
                SelectMode::Counted => {
                    let count = count.to_array();
                    for k in 0..W {
                        let c = count[k] as usize;
                        (emitter[k], pmf[k]) = (sel.emitter[c], sel.pmf[c]);
                    }
                }
                SelectMode::Searched => {
                    for k in 0..W {
                        if lane_on(k) {
                            if let Some((e, q, _)) = scene.light_sampler.sample(u_sel[k]) {
                                (emitter[k], pmf[k]) = (e as u32, q);
                            }
                        }
                    }
                }
            }
            let same = sel.mode == SelectMode::One;
            if self.add_uniform(avx, lights, light_only, on_bits, &emitter, &pmf, u, same) {
                if self.f.n_deferred > 0 {
                    self.triangles_x8::<T, true>(avx, scene, u);
                }
                return;
            }
            for k in 0..W {
                if lane_on(k) {
                    let uk = Vec2::new(u[0][k], u[1][k]);
                    let e = emitter[k] as usize;
                    self.add_selected(k, scene, lights, light_only, e, pmf[k], uk, p.get(k), true);
                }
            }
            if self.f.n_deferred > 0 {
                self.triangles_x8::<T, false>(avx, scene, u);
            }
        }

        /// [`Gather::add_selected`]'s writes for the lanes `on` (bits) whose selection counts
        /// are `count` (`pmf`: [`Select::pmf`]), from the selection's [`Table`]: every column
        /// 8-wide, gathered by count (written whole: the lanes off have no `kind` and are
        /// dropped by [`Gather::finish`]'s masks); the kinds' lane counts and the delta flags
        /// from a compare per kind of the table, not lane by lane.
        #[inline(always)]
        #[allow(clippy::too_many_arguments)]
        fn add_table<T: Wide<W>, const SMALL: bool>(
            &mut self,
            avx: T,
            t: &Table,
            pmf: &[f32; 10],
            count: T::I,
            light_only: bool,
            on: u32,
            u: &[[f32; W]; 2],
        ) {
            // A function, not a closure (a closure is compiled outside the lanes' target
            // features, `kernels`).
            let g = by_count::<T, W, SMALL>;
            let zi = count.splat(0);
            // Every count's kind is positive (`Table::new`): the lanes with a kind are `on`.
            let kind = match t.kind_bits.first_chunk::<8>() {
                Some(head) if SMALL => lookup8::<T::F>(head, count).to_bits(),
                _ => T::I::gather_u32(&t.kind, count),
            };
            let kind = T::I::select(avx.mask_bits(on), kind, zi);
            self.f.kind = kind.to_array();
            // Per kind of the table: its lanes, counted, and the delta lights' (no MIS weight).
            let mut delta = 0u32;
            let mut kinds = t.kinds;
            while kinds != 0 {
                let c = kinds.trailing_zeros() as i32 + 1;
                kinds &= kinds - 1;
                let lanes = T::bits(is_kind::<T, W>(kind, c));
                self.f.counts[c as usize - 1] += lane_count(lanes);
                if matches!(c, KIND_POINT | KIND_DIRECTIONAL) {
                    delta |= lanes;
                }
            }
            self.f.one = (self.f.one & !on) | if light_only { on } else { delta };
            self.textured = 0;
            if t.fixed {
                // One rectangle and at most one point or directional light: their columns are
                // the same in every lane of every chunk (a lane of another kind computes a
                // point there that its kind's mask drops), written at the first chunk only.
                if !self.table_fixed {
                    let (r, c) = t.fixed_at;
                    let at = splat_at::<W>;
                    if t.rect {
                        for (col, a) in self.raxes.iter_mut().zip(&t.axes) {
                            *col = at(a, r);
                        }
                        self.rn = at(&t.n, r);
                        self.inv_area = [t.inv_area[r]; W];
                    }
                    if t.center_used {
                        self.center = at(&t.center, c);
                    }
                    self.table_fixed = true;
                }
            } else {
                if t.rect {
                    for (col, a) in self.raxes.iter_mut().zip(&t.axes) {
                        *col = Cols3([g(&a[0], count), g(&a[1], count), g(&a[2], count)]);
                    }
                    self.rn = Cols3([g(&t.n[0], count), g(&t.n[1], count), g(&t.n[2], count)]);
                    self.inv_area = g(&t.inv_area, count);
                }
                if t.center_used {
                    self.center = Cols3([
                        g(&t.center[0], count),
                        g(&t.center[1], count),
                        g(&t.center[2], count),
                    ]);
                }
            }
            (self.tux, self.tuy) = (u[0], u[1]);
            self.sel = g(pmf, count);
            self.lv = Cols3([g(&t.le[0], count), g(&t.le[1], count), g(&t.le[2], count)]);
        }

        /// Where every lane of `on_bits` selected the same
        /// emitter and it is an untextured mesh or rectangle light, [`Gather::add_selected`]'s
        /// writes for all of them at once (whole columns: the lanes off have no `kind` and are
        /// dropped by [`Gather::finish`]'s masks); returns whether it did (else nothing is
        /// written). `same`: every lane's `emitter` is the same (one emitter takes every
        /// count), not tested again.
        #[inline(always)]
        #[allow(clippy::too_many_arguments)]
        fn add_uniform<T: Wide<W>>(
            &mut self,
            avx: T,
            lights: &[Option<LaneLight>],
            light_only: bool,
            on_bits: u32,
            emitter: &[u32; W],
            pmf: &[f32; W],
            u: &[[f32; W]; 2],
            same: bool,
        ) -> bool {
            if on_bits == 0 {
                return true;
            }
            let e = emitter[on_bits.trailing_zeros() as usize];
            if !same && (0..W).any(|k| on_bits >> k & 1 != 0 && emitter[k] != e) {
                return false;
            }
            let n_on = lane_count(on_bits);
            let (kind, le) = match lights[e as usize] {
                Some(LaneLight::Triangles {
                    shape,
                    inv_area,
                    sign,
                    radiance,
                    textured: false,
                }) => {
                    self.f.deferred = on_bits;
                    self.f.n_deferred = n_on;
                    self.tri_shape = shape;
                    self.inv_area = [inv_area; W];
                    self.sign = [sign; W];
                    (KIND_TRIANGLE, radiance)
                }
                Some(LaneLight::Rectangle {
                    axes,
                    n,
                    inv_area,
                    radiance,
                    textured: false,
                }) => {
                    for (col, a) in self.raxes.iter_mut().zip(axes) {
                        *col = Cols3([[a.x; W], [a.y; W], [a.z; W]]);
                    }
                    self.rn = Cols3([[n.x; W], [n.y; W], [n.z; W]]);
                    self.inv_area = [inv_area; W];
                    (KIND_RECTANGLE, radiance)
                }
                _ => return false,
            };
            // In lanes and bits (the lanes off keep their values).
            let old = avx.load_i32(&self.f.kind);
            self.f.kind = T::I::select(avx.mask_bits(on_bits), old.splat(kind), old).to_array();
            self.textured &= !on_bits;
            self.f.one = (self.f.one & !on_bits) | if light_only { on_bits } else { 0 };
            self.f.counts[kind as usize - 1] += n_on;
            (self.tux, self.tuy) = (u[0], u[1]);
            self.sel = *pmf;
            self.lv = Cols3([[le.x; W], [le.y; W], [le.z; W]]);
            true
        }

        /// `Shape::pick_triangle` and the corners (and vertex normals) of the picked triangles
        /// for the lanes `deferred` (all on mesh `tri_shape`), 8-wide, into the columns that
        /// [`Gather::finish`] reads: the count of triangle-CDF entries `<= u.y` (the
        /// partition point: the entries `<= u.y` are a prefix) by a binary search in lanes,
        /// then the same `u.y` rescaling, and the vertex indices, positions and normals
        /// gathered. `WHOLE`: every lane with a light is deferred ([`Gather::add_uniform`]), so
        /// the columns are written whole (the other lanes have no `kind`).
        #[inline(always)]
        fn triangles_x8<T: Wide<W>, const WHOLE: bool>(
            &mut self,
            avx: T,
            scene: &Scene,
            u: &[[f32; W]; 2],
        ) {
            let shape = &scene.shapes[self.tri_shape as usize];
            let ShapeKind::Mesh(mesh) = &shape.kind else {
                unreachable!("LaneLight::table: a mesh")
            };
            let cdf = shape.triangle_cdf();
            let m = cdf.len();
            // At most 8 triangles: the CDF and the corners looked up by permutes (`SmallMesh`).
            let small = m <= SMALL_MESH && self.small_ok;
            if small && self.small.shape != self.tri_shape {
                self.small = SmallMesh::new(self.tri_shape, mesh, cdf);
            }
            let on = avx.mask_bits(self.f.deferred);
            let uy = avx.load(&u[1]);
            let zi = avx.load_i32(&[0; W]);
            let (one_i, last) = (zi.splat(1), zi.splat(m as i32 - 1));
            let zero = avx.splat(0.0);
            let (i, lo, w) = if small {
                // The partition point as the count of the entries <= u.y (a prefix of the
                // nondecreasing CDF: the same count as the search below).
                let t = &self.small.cdf;
                let mut count = zi;
                for &c in &t[..m] {
                    count = count.add(T::I::select(avx.splat(c).le(uy), one_i, zi));
                }
                let i = T::I::select(count.gt(last), last, count);
                let lo = T::F::select(i.eq(zi), zero, lookup8::<T::F>(t, i.sub(one_i)));
                (i, lo, lookup8::<T::F>(t, i) - lo)
            } else {
                // The partition point, by powers of two from the largest <= m down: take a
                // step where the entry before its end is <= u.y (and the end is within the
                // CDF).
                let mut count = zi;
                let mut step = 1usize << (usize::BITS - 1 - m.leading_zeros());
                while step > 0 {
                    let next = count.add(zi.splat(step as i32));
                    let c = T::F::gather_slice(cdf, next.sub(one_i));
                    let take = c.le(uy) & !next.gt(zi.splat(m as i32));
                    count = T::I::select(take, next, count);
                    step >>= 1;
                }
                let i = T::I::select(count.gt(last), last, count);
                let lo = T::F::select(i.eq(zi), zero, T::F::gather_slice(cdf, i.sub(one_i)));
                (i, lo, T::F::gather_slice(cdf, i) - lo)
            };
            // f32::clamp(0, 1 − ε/2), as written there.
            let r = (uy - lo) / w;
            let r = T::F::select(r.lt(zero), zero, r);
            let top = avx.splat(1.0 - f32::EPSILON * 0.5);
            let r = T::F::select(r.gt(top), top, r);
            let uy = T::F::select(w.gt(zero), r, avx.splat(0.5));
            self.tuy = if WHOLE {
                uy
            } else {
                T::F::select(on, uy, avx.load(&self.tuy))
            }
            .to_array();
            let flat = mesh.indices.as_flattened();
            let i3 = i.add(i).add(i);
            for c in 0..3 {
                // Written out per branch, not through closures (which may be left out of line,
                // outside the SIMD target features).
                let (p, n) = if small {
                    let (sp, sn) = (&self.small.pos[c], &self.small.norm[c]);
                    let p = V3::new(
                        lookup8::<T::F>(&sp[0], i),
                        lookup8::<T::F>(&sp[1], i),
                        lookup8::<T::F>(&sp[2], i),
                    );
                    let n = V3::new(
                        lookup8::<T::F>(&sn[0], i),
                        lookup8::<T::F>(&sn[1], i),
                        lookup8::<T::F>(&sn[2], i),
                    );
                    (p, n)
                } else {
                    let vi = T::I::gather_u32(flat, i3.add(zi.splat(c as i32)));
                    let [x, y, z] = T::F::gather3(&mesh.positions, vi);
                    let n = match &mesh.normals {
                        Some(ns) => {
                            let [x, y, z] = T::F::gather3(ns, vi);
                            V3::new(x, y, z)
                        }
                        None => V3::new(zero, zero, zero),
                    };
                    (V3::new(x, y, z), n)
                };
                self.tpos[c] = Cols3::store(keep::<T, W, WHOLE>(avx, on, p, &self.tpos[c]));
                if mesh.normals.is_some() {
                    self.tnorm[c] = Cols3::store(keep::<T, W, WHOLE>(avx, on, n, &self.tnorm[c]));
                }
            }
            if mesh.normals.is_some() {
                self.f.tnorm_some |= self.f.deferred;
            }
        }

        /// Lane `k`'s light point from `u`, seen from `p`, for emitter `e` selected with
        /// probability `sel_pdf`; `defer`: an untextured triangle of the chunk's first mesh
        /// light is left to [`Gather::triangles_x8`].
        #[inline(always)]
        #[allow(clippy::too_many_arguments)]
        fn add_selected(
            &mut self,
            k: usize,
            scene: &Scene,
            lights: &[Option<LaneLight>],
            light_only: bool,
            e: usize,
            sel_pdf: f32,
            u: Vec2,
            p: Vec3,
            defer: bool,
        ) {
            let lane_light = match &lights[e] {
                Some(LaneLight::Sphere { center, radius, .. })
                    if !sphere_sees_cone((*center - p).length(), *radius) =>
                {
                    None
                }
                l => l.as_ref(),
            };
            let Some(ll) = lane_light else {
                if let Some(ds) = scene.emitters[e].sample_direct(&scene.shapes, p, u) {
                    if ds.value != Spectrum::ZERO {
                        self.f.some |= 1 << k;
                        self.ld.set(k, ds.d);
                        self.lpp.set(k, ds.p);
                        if let Some(n) = ds.n {
                            self.f.has_n |= 1 << k;
                            self.ln.set(k, n);
                        }
                        set_bit(&mut self.f.finite, k, ds.dist.is_finite());
                        self.lpdf[k] = ds.pdf * sel_pdf;
                        self.lv.set(k, ds.value);
                        set_bit(&mut self.f.one, k, ds.delta || light_only);
                    }
                }
                return;
            };
            let mut su = u;
            let le = match *ll {
                LaneLight::Triangles {
                    shape,
                    inv_area,
                    sign,
                    radiance,
                    textured,
                } if defer && !textured && (self.f.n_deferred == 0 || self.tri_shape == shape) => {
                    // The triangle and its rescaled u.y in `triangles_x8`.
                    self.f.kind[k] = KIND_TRIANGLE;
                    set_bit(&mut self.textured, k, false);
                    self.f.deferred |= 1 << k;
                    self.f.n_deferred += 1;
                    self.tri_shape = shape;
                    (self.inv_area[k], self.sign[k]) = (inv_area, sign);
                    radiance
                }
                LaneLight::Triangles {
                    shape,
                    inv_area,
                    sign,
                    radiance,
                    textured,
                } => {
                    let shape = &scene.shapes[shape as usize];
                    let ShapeKind::Mesh(mesh) = &shape.kind else {
                        unreachable!("LaneLight::table: a mesh")
                    };
                    let (t, ut) = shape.pick_triangle(u);
                    su = ut;
                    let idx = mesh.indices[t].map(|j| j as usize);
                    self.f.kind[k] = KIND_TRIANGLE;
                    for (col, &j) in self.tpos.iter_mut().zip(&idx) {
                        col.set(k, mesh.positions[j]);
                    }
                    if let Some(ns) = &mesh.normals {
                        self.f.tnorm_some |= 1 << k;
                        for (col, &j) in self.tnorm.iter_mut().zip(&idx) {
                            col.set(k, ns[j]);
                        }
                    }
                    set_bit(&mut self.textured, k, textured);
                    if textured {
                        self.f.n_textured += 1;
                        self.emitter[k] = e as u32;
                        set_bit(&mut self.tuv_some, k, mesh.uvs.is_some());
                        if let Some(uvs) = &mesh.uvs {
                            for (col, &j) in self.tuv.iter_mut().zip(&idx) {
                                (col[0][k], col[1][k]) = (uvs[j].x, uvs[j].y);
                            }
                        }
                    }
                    (self.inv_area[k], self.sign[k]) = (inv_area, sign);
                    radiance
                }
                LaneLight::Rectangle {
                    axes,
                    n,
                    inv_area,
                    radiance,
                    textured,
                } => {
                    self.f.kind[k] = KIND_RECTANGLE;
                    set_bit(&mut self.textured, k, textured);
                    if textured {
                        self.f.n_textured += 1;
                        self.emitter[k] = e as u32;
                    }
                    for (col, a) in self.raxes.iter_mut().zip(axes) {
                        col.set(k, a);
                    }
                    self.rn.set(k, n);
                    self.inv_area[k] = inv_area;
                    radiance
                }
                LaneLight::Sphere {
                    center,
                    radius,
                    sign,
                    radiance,
                } => {
                    self.f.kind[k] = KIND_SPHERE;
                    self.center.set(k, center);
                    (self.radius[k], self.sign[k]) = (radius, sign);
                    radiance
                }
                LaneLight::Point {
                    position,
                    intensity,
                } => {
                    self.f.kind[k] = KIND_POINT;
                    self.center.set(k, position);
                    intensity
                }
                LaneLight::Spot {
                    textured,
                    uv_factor,
                    position,
                    to_local,
                    intensity,
                    cos_cutoff,
                    cos_beam,
                    cutoff,
                    beam_width,
                } => {
                    self.f.kind[k] = KIND_SPOT;
                    set_bit(&mut self.textured, k, textured);
                    if textured {
                        self.f.n_textured += 1;
                        self.emitter[k] = e as u32;
                        self.uv_factor[k] = uv_factor;
                    }
                    self.center.set(k, position);
                    for (col, c) in self.mat.iter_mut().zip(to_local) {
                        col.set(k, c);
                    }
                    for (col, c) in self
                        .cone
                        .iter_mut()
                        .zip([cos_cutoff, cos_beam, cutoff, beam_width])
                    {
                        col[k] = c;
                    }
                    intensity
                }
                LaneLight::Directional { d, irradiance } => {
                    self.f.kind[k] = KIND_DIRECTIONAL;
                    self.center.set(k, d);
                    irradiance
                }
                LaneLight::Constant { radiance } => {
                    self.f.kind[k] = KIND_CONSTANT;
                    radiance
                }
                LaneLight::EnvMap {
                    emitter,
                    to_world,
                    to_local,
                    half_texel,
                } => {
                    let Emitter::EnvMap(m) = &scene.emitters[emitter as usize] else {
                        unreachable!("LaneLight::table: an envmap")
                    };
                    // The table walk, lane by lane.
                    let Some(uv) = m.sample_uv(u) else { return };
                    su = uv;
                    self.f.kind[k] = KIND_ENVMAP;
                    for (col, c) in self.mat.iter_mut().zip(to_world) {
                        col.set(k, c);
                    }
                    for (col, c) in self.mat2.iter_mut().zip(to_local) {
                        col.set(k, c);
                    }
                    self.half_texel[k] = half_texel;
                    self.emitter[k] = emitter;
                    // The radiance is looked up in `finish`, at the direction's (u, v).
                    Spectrum::ZERO
                }
            };
            let kind = self.f.kind[k];
            self.f.counts[kind as usize - 1] += 1;
            (self.tux[k], self.tuy[k]) = (su.x, su.y);
            self.sel[k] = sel_pdf;
            self.lv.set(k, le);
            // Delta lights take no MIS weight.
            let delta = matches!(kind, KIND_POINT | KIND_SPOT | KIND_DIRECTIONAL);
            set_bit(&mut self.f.one, k, light_only || delta);
        }

        /// Whether a lane of `on` (bits) has a textured light.
        #[inline(always)]
        fn any_textured(&self, on: u32) -> bool {
            self.f.n_textured > 0 && on & self.textured != 0
        }

        /// The textures of the textured lanes of `on` (bits) where `ok`, at `uv`: per distinct
        /// emitter among them, a bitmap 8-wide (`BitmapTexture::eval_x8`, the other lanes' uvs
        /// set to 0.5 so that they stay in its exact range), any other texture lane by lane,
        /// both `Texture::eval` bit for bit. Returns the lanes looked up and their values.
        #[inline(always)]
        fn textures<T: Wide<W>>(
            &self,
            avx: T,
            scene: &Scene,
            on: u32,
            ok: T::M,
            uv: V2<T::F>,
        ) -> (T::M, V3<T::F>) {
            let look = on & T::bits(ok) & self.textured;
            let half = uv.x.splat(0.5);
            let mut out = V3::new(half, half, half);
            let mut left = look;
            while left != 0 {
                let e = self.emitter[left.trailing_zeros() as usize];
                let mut mine = 0u32;
                for k in 0..W {
                    if left >> k & 1 == 1 && self.emitter[k] == e {
                        mine |= 1 << k;
                    }
                }
                left &= !mine;
                let tex = match &scene.emitters[e as usize] {
                    Emitter::Area(a) => &a.radiance,
                    Emitter::Spot(s) => s.texture.as_ref().expect("LaneLight::table: textured"),
                    _ => unreachable!("LaneLight::table: an area or spot light"),
                };
                let mm = avx.mask_bits(mine);
                let v = match tex {
                    Texture::Bitmap(b) => b.eval_x8(
                        avx,
                        V2::new(T::F::select(mm, uv.x, half), T::F::select(mm, uv.y, half)),
                    ),
                    t => {
                        let (u, v) = (uv.x.to_array(), uv.y.to_array());
                        let mut c = Cols3::default();
                        for k in (0..W).filter(|&k| mine >> k & 1 == 1) {
                            c.set(k, t.eval(Vec2::new(u[k], v[k])));
                        }
                        c.load(avx)
                    }
                };
                out = V3::select(mm, v, out);
            }
            (avx.mask_bits(look), out)
        }

        /// The 8 light points seen from `ref_p` (the lanes' surface points of `scene`), the
        /// 8-wide samplers run for the kinds some lane picked; adds the lanes sampled in lanes
        /// per kind to `light_lanes` (`Batch::light_lanes`).
        #[inline(always)]
        pub(crate) fn finish<T: Wide<W>>(
            &self,
            avx: T,
            scene: &Scene,
            ref_p: V3<T::F>,
            light_lanes: &mut [u64; KINDS],
        ) -> LightPoint<T::F> {
            // Masks through `avx.mask_bits` directly (from the flags' bits): a closure here
            // may be left out of line, outside the SIMD target features
            // (`tests/cli/simd_calls.rs`).
            let mut lp = LightPoint {
                some: avx.mask_bits(self.f.some),
                d: self.ld.load(avx),
                p: self.lpp.load(avx),
                n: self.ln.load(avx),
                has_n: avx.mask_bits(self.f.has_n),
                finite: avx.mask_bits(self.f.finite),
                pdf: avx.load(&self.lpdf),
                value: self.lv.load(avx),
                weight_one: avx.mask_bits(self.f.one),
            };
            let su = V2::new(avx.load(&self.tux), avx.load(&self.tuy));
            let sel8 = avx.load(&self.sel);
            // The lanes' kinds as integers, compared 8-wide per kind (not 8 byte compares and
            // a mask built from them).
            let kinds = avx.load_i32(&self.f.kind);
            if self.f.counts[0] > 0 {
                let q = sample_triangle(
                    &Triangle {
                        p: load3(avx, &self.tpos),
                        n: load3(avx, &self.tnorm),
                        has_normals: avx.mask_bits(self.f.tnorm_some),
                        inv_area: avx.load(&self.inv_area),
                        sign: avx.load(&self.sign),
                        u: su,
                    },
                    ref_p,
                );
                merge(&mut lp, is_kind::<T, W>(kinds, KIND_TRIANGLE), &q, sel8);
            }
            if self.f.counts[1] > 0 {
                let q = sample_rectangle(
                    &Rectangle {
                        axes: load4(avx, &self.raxes),
                        n: self.rn.load(avx),
                        inv_area: avx.load(&self.inv_area),
                        u: su,
                    },
                    ref_p,
                );
                merge(&mut lp, is_kind::<T, W>(kinds, KIND_RECTANGLE), &q, sel8);
            }
            if self.f.counts[2] > 0 {
                let q = sample_sphere(
                    &Sphere {
                        center: self.center.load(avx),
                        radius: avx.load(&self.radius),
                        sign: avx.load(&self.sign),
                        u: su,
                    },
                    ref_p,
                );
                merge(&mut lp, is_kind::<T, W>(kinds, KIND_SPHERE), &q, sel8);
            }
            // The textured area lights' lanes (the compares made only when a lane has one).
            let on_area = if self.f.n_textured > 0 {
                let area =
                    is_kind::<T, W>(kinds, KIND_TRIANGLE) | is_kind::<T, W>(kinds, KIND_RECTANGLE);
                T::bits(area)
            } else {
                0
            };
            if self.any_textured(on_area) {
                // AreaLight::sample_direct's `radiance.eval(uv)` at the sampled point (triangles:
                // `Shape::sample_position`'s uv from the same barycentrics; rectangles: `u`),
                // then `nee::sample_emitter`'s zero test.
                let b = warp::square_to_uniform_triangle(su);
                let b0 = sel8.splat(1.0) - b.x - b.y;
                // Written out, not through closures (which LLVM may leave out of line, outside
                // the SIMD target features: `tests/cli/simd_calls.rs`).
                let t = &self.tuv;
                let (u0, u1, u2) = (avx.load(&t[0][0]), avx.load(&t[1][0]), avx.load(&t[2][0]));
                let (v0, v1, v2) = (avx.load(&t[0][1]), avx.load(&t[1][1]), avx.load(&t[2][1]));
                let tri_u = (u0 * b0 + u1 * b.x) + u2 * b.y;
                let tri_v = (v0 * b0 + v1 * b.x) + v2 * b.y;
                let has = avx.mask_bits(self.tuv_some);
                let tri_uv = V2::new(T::F::select(has, tri_u, b.x), T::F::select(has, tri_v, b.y));
                let rect = is_kind::<T, W>(kinds, KIND_RECTANGLE);
                let uv = V2::new(
                    T::F::select(rect, su.x, tri_uv.x),
                    T::F::select(rect, su.y, tri_uv.y),
                );
                let (look, t) = self.textures(avx, scene, on_area, lp.some, uv);
                let z = sel8.splat(0.0);
                let zero = t.x.eq(z) & t.y.eq(z) & t.z.eq(z);
                lp.value = V3::select(look, t, lp.value);
                lp.some = lp.some & !(look & zero);
            }
            let lv = self.lv.load(avx);
            if self.f.counts[3] > 0 {
                let q = em::sample_point(self.center.load(avx), lv, ref_p);
                merge_free(&mut lp, is_kind::<T, W>(kinds, KIND_POINT), &q, sel8);
            }
            if self.f.counts[4] > 0 {
                // Four loads, not `self.cone.map(..)`: the closure may be left out of line.
                let [cos_cutoff, cos_beam, cutoff, beam_width] = [
                    avx.load(&self.cone[0]),
                    avx.load(&self.cone[1]),
                    avx.load(&self.cone[2]),
                    avx.load(&self.cone[3]),
                ];
                let spot = Spot {
                    pos: self.center.load(avx),
                    to_local: load3(avx, &self.mat),
                    intensity: lv,
                    cos_cutoff,
                    cos_beam,
                    cutoff,
                    beam_width,
                };
                let mut q = em::sample_spot(&spot, ref_p);
                let on = is_kind::<T, W>(kinds, KIND_SPOT);
                let on_bits = T::bits(on);
                if self.any_textured(on_bits) {
                    // SpotLight::sample_direct: `value *= texture(uv)`, where it is sampled.
                    let uv = em::spot_uv(&spot.to_local, q.d, avx.load(&self.uv_factor));
                    let (look, t) = self.textures(avx, scene, on_bits, q.ok, uv);
                    q.value = V3::select(look, q.value * t, q.value);
                }
                merge_free(&mut lp, on, &q, sel8);
            }
            if self.f.counts[5] > 0 {
                let q = em::sample_directional(self.center.load(avx), lv, ref_p);
                merge_free(&mut lp, is_kind::<T, W>(kinds, KIND_DIRECTIONAL), &q, sel8);
            }
            if self.f.counts[6] > 0 {
                let q = em::sample_constant(lv, su);
                merge_free(&mut lp, is_kind::<T, W>(kinds, KIND_CONSTANT), &q, sel8);
            }
            if self.f.counts[7] > 0 {
                let on = is_kind::<T, W>(kinds, KIND_ENVMAP);
                let e = em::env_direction(&Env {
                    to_world: load3(avx, &self.mat),
                    to_local: load3(avx, &self.mat2),
                    half_texel: avx.load(&self.half_texel),
                    uv: su,
                });
                // The table's density and the texels, lane by lane (data-dependent lookups).
                let look = T::bits(on & e.ok);
                let (u, v) = (e.uv.x.to_array(), e.uv.y.to_array());
                let px = e.patch.x.to_array();
                let mut patch_pdf = [0.0f32; W];
                let mut value = Cols3::default();
                for k in 0..W {
                    if look >> k & 1 == 1 {
                        let Emitter::EnvMap(env) = &scene.emitters[self.emitter[k] as usize] else {
                            unreachable!("LaneLight::table: an envmap")
                        };
                        patch_pdf[k] = env.patch_pdf(Vec2::new(px[k], v[k]));
                        value.set(k, env.lookup(Vec2::new(u[k], v[k])));
                    }
                }
                let (pdf, pdf_ok) = em::env_pdf(avx.load(&patch_pdf), e.sin_theta);
                let q = FreePoint {
                    ok: e.ok & pdf_ok,
                    d: e.d,
                    dist: sel8.splat(f32::INFINITY),
                    p: ref_p + e.d,
                    pdf,
                    value: value.load(avx),
                };
                merge_free(&mut lp, on, &q, sel8);
            }
            for (total, c) in light_lanes.iter_mut().zip(self.f.counts) {
                *total += c as u64;
            }
            lp
        }
    }

    #[cfg(test)]
    mod table_tests {
        use super::*;

        fn rect(x: f32, inv_area: f32) -> Option<LaneLight> {
            Some(LaneLight::Rectangle {
                axes: [Vec3::X * x, Vec3::Y, Vec3::Z, Vec3::new(0.0, 4.5, 3.0)],
                n: Vec3::NEG_Y,
                inv_area,
                radiance: Vec3::splat(8.0),
                textured: false,
            })
        }

        /// A table whose counts' emitters are `emitters` (indices into `lights`).
        fn table(lights: &[Option<LaneLight>], emitters: &[u32]) -> Table {
            let mut e = [0u32; 10];
            e[..emitters.len()].copy_from_slice(emitters);
            Table::new(lights, &e, emitters.len() - 2).expect("a table")
        }

        /// `Table::fixed` (the rectangle and `center` columns written once per gather) holds
        /// exactly when every count of a rectangle has the same rectangle (bit for bit: −0 is
        /// not 0) and every count of a point or directional light the same `center`, and
        /// `fixed_at` names a count of each.
        #[test]
        fn fixed_tables_have_one_rectangle_and_one_center() {
            let constant = Some(LaneLight::Constant {
                radiance: Vec3::splat(0.15),
            });
            let point = |x: f32| {
                Some(LaneLight::Point {
                    position: Vec3::new(x, 1.0, 2.0),
                    intensity: Vec3::ONE,
                })
            };
            let dir = Some(LaneLight::Directional {
                d: Vec3::Y,
                irradiance: Vec3::ONE,
            });
            let lights = [
                rect(2.0, 0.25),
                constant,
                rect(2.0, 0.5),
                rect(-0.0, 0.25),
                rect(0.0, 0.25),
                point(1.0),
                point(1.5),
                dir,
            ];
            // (emitter per count, fixed, fixed_at)
            let cases: [(&[u32], bool, (usize, usize)); 10] = [
                (&[0, 1, 1], true, (0, 0)),
                (&[1, 0, 0, 1], true, (1, 0)),
                (&[1, 1, 1], true, (0, 0)),
                (&[0, 1, 2], false, (0, 0)),
                (&[3, 4, 1], false, (0, 0)),
                (&[3, 1, 3, 3], true, (0, 0)),
                (&[1, 5, 0, 5], true, (2, 1)),
                (&[5, 6, 1], false, (0, 0)),
                (&[5, 7, 1], false, (0, 0)),
                (&[7, 1, 7, 0], true, (3, 0)),
            ];
            for (emitters, fixed, at) in cases {
                let t = table(&lights, emitters);
                assert_eq!(t.fixed, fixed, "{emitters:?}");
                if fixed {
                    assert_eq!(t.fixed_at, at, "{emitters:?}");
                }
            }
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;
    use crate::math::Pcg32;
    use glam::{Mat4, Vec2};

    /// Equal bits (NaN equals NaN).
    pub(crate) fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    /// Equal bits per component.
    pub(crate) fn same3(a: V3<f32>, b: Vec3) -> bool {
        same(a.x, b.x) && same(a.y, b.y) && same(a.z, b.z)
    }

    /// `x8::Gather::add_x8` then `finish` (the light selection 8-wide, mesh triangles picked
    /// and gathered 8-wide) equal `nee::sample_emitter`'s scalar selection and
    /// `sample_direct` bit for bit, on the mesh-light test scenes (one selection counted, one
    /// searched) at random reference points and numbers, with `u_sel` and `u.y` also at the
    /// selection's and the ball's triangle CDF entries and their neighbours, lanes off at
    /// random.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn lane_selection_and_triangles_equal_the_scalar_sampling() {
        use super::x8::{Cols3, Gather};
        use crate::lane::Avx2;
        let Some(avx) = Avx2::detect() else {
            eprintln!("no AVX2: not run");
            return;
        };
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/scenes/");
        for name in ["stream_mesh_lights.xml", "stream_mesh_lights_many.xml"] {
            let path = std::path::PathBuf::from(dir).join(name);
            let l = crate::load::load_scene(&path, &Default::default()).unwrap();
            let scene = &l.scene;
            let lights = LaneLight::table(scene);
            let dist = scene.light_sampler.distribution().unwrap();
            let mut edges: Vec<f32> = Vec::new();
            let ball = scene.shapes.iter().max_by_key(|s| s.triangle_cdf().len());
            for c in dist.cdf().iter().chain(ball.unwrap().triangle_cdf()) {
                edges.extend([*c, c.next_down(), c.next_up()]);
            }
            edges.retain(|u| (0.0..1.0).contains(u));
            let mut r = Pcg32::new(5, 11);
            let mut counts = [0usize; 3];
            for round in 0..3000 {
                let mut f = |a: f32, b: f32| a + (b - a) * r.next_f32();
                let mut on = [false; 8];
                let (mut u_sel, mut u) = ([0.0f32; 8], [[0.0f32; 8]; 2]);
                let mut p = Cols3::<8>::default();
                for k in 0..8 {
                    on[k] = f(0.0, 1.0) < 0.9;
                    u_sel[k] = f(0.0, 1.0);
                    u[0][k] = f(0.0, 1.0);
                    u[1][k] = f(0.0, 1.0);
                    if round % 4 == 1 {
                        let j = (f(0.0, 1.0) * edges.len() as f32) as usize;
                        u_sel[k] = edges[j.min(edges.len() - 1)];
                        let j = (f(0.0, 1.0) * edges.len() as f32) as usize;
                        u[1][k] = edges[j.min(edges.len() - 1)];
                    }
                    p.set(k, Vec3::new(f(-2.5, 2.5), f(0.0, 3.6), f(-2.5, 2.5)));
                }
                let mut g = Gather::<8>::new();
                let mut slow = Gather::<8>::new().without_small_meshes();
                let mut kinds = [0u64; KINDS];
                // The lanes as bits; some rounds set bits above the chunk's (not lanes: ignored).
                let on_bits = (0..8).fold(0u32, |b, k| b | (on[k] as u32) << k)
                    | if round % 3 == 2 { 0xff00 } else { 0 };
                let (lp, lp_slow) = avx.run(|| {
                    g.reset();
                    g.add_x8(avx, scene, &lights, false, on_bits, &u_sel, &u, &p);
                    slow.reset();
                    slow.add_x8(avx, scene, &lights, false, on_bits, &u_sel, &u, &p);
                    (
                        g.finish(avx, scene, p.load(avx), &mut kinds),
                        slow.finish(avx, scene, p.load(avx), &mut kinds),
                    )
                });
                // The small meshes' lookups equal the gathers bit for bit in every lane (the
                // octahedron light has 8 triangles), the lanes without a point included.
                let bits = |l: &crate::stream::kernels::diffuse::LightPoint<crate::lane::F32x8>| {
                    let c = |v: V3<crate::lane::F32x8>| {
                        [v.x.to_array(), v.y.to_array(), v.z.to_array()]
                            .map(|a| a.map(f32::to_bits))
                    };
                    (
                        l.some.to_array(),
                        c(l.d),
                        c(l.p),
                        c(l.n),
                        l.pdf.to_array().map(f32::to_bits),
                        c(l.value),
                        l.finite.to_array(),
                        (l.has_n.to_array(), l.weight_one.to_array()),
                    )
                };
                assert_eq!(bits(&lp), bits(&lp_slow), "{name} {round}");
                let some = lp.some.to_array();
                let (d, q, n) = (Cols3::store(lp.d), Cols3::store(lp.p), Cols3::store(lp.n));
                let (pdf, value) = (lp.pdf.to_array(), Cols3::store(lp.value));
                for k in 0..8 {
                    let uk = Vec2::new(u[0][k], u[1][k]);
                    let want = if on[k] {
                        crate::integrator::nee::sample_emitter(scene, p.get(k), u_sel[k], uk)
                    } else {
                        None
                    };
                    assert_eq!(some[k], want.is_some(), "{name} {round} lane {k}");
                    let Some((ds, sel)) = want else { continue };
                    let e = scene.light_sampler.sample(u_sel[k]).unwrap().0;
                    if let Emitter::Area(a) = &scene.emitters[e] {
                        counts[scene.shapes[a.shape as usize].triangle_cdf().len().min(2)] += 1;
                    }
                    let v3 = |c: &Cols3<8>| V3::new(c.0[0][k], c.0[1][k], c.0[2][k]);
                    assert!(
                        same3(v3(&d), ds.d)
                            && same3(v3(&q), ds.p)
                            && same3(v3(&n), ds.n.unwrap())
                            && same(pdf[k], ds.pdf * sel)
                            && same3(v3(&value), ds.value),
                        "{name} {round} lane {k}"
                    );
                }
            }
            // Lanes on the ball (and the octahedron) and on the other lights were compared.
            assert!(counts[2] > 1000 && counts[0] > 1000, "{name}: {counts:?}");
        }
    }

    /// Width 1 of the lane samplers equals `AreaLight::sample_direct` (through
    /// `Shape::sample_direction`) bit for bit on random rectangles and spheres seen from random
    /// points, accepted or not, flipped normals included (width 8: `tests/render/stream.rs`).
    #[test]
    fn lane_rectangles_and_spheres_equal_the_scalar_sampling() {
        use crate::emitter::area::AreaLight;
        use crate::geometry::Shape;
        let mut r = Pcg32::new(21, 4);
        let mut f = |a: f32, b: f32| a + (b - a) * r.next_f32();
        let mut rect_cases = Vec::new();
        let mut sphere_cases = Vec::new();
        for i in 0..4000 {
            let flip = i % 3 == 0;
            let m = Mat4::from_scale_rotation_translation(
                Vec3::new(f(0.1, 3.0), f(0.1, 3.0), f(0.1, 3.0)),
                glam::Quat::from_euler(
                    glam::EulerRot::XYZ,
                    f(-3.0, 3.0),
                    f(-3.0, 3.0),
                    f(-3.0, 3.0),
                ),
                Vec3::new(f(-2.0, 2.0), f(-2.0, 2.0), f(-2.0, 2.0)),
            );
            // Every fourth with a shading normal of its own (a non-unit `<rotate>`).
            let nm = glam::Mat3::from_cols(
                Vec3::new(1.0, f(-0.3, 0.3), 0.0),
                Vec3::Y,
                Vec3::new(f(-0.3, 0.3), 0.0, 1.0),
            );
            let rect = Shape::rectangle_with_normals(&m, (i % 4 == 1).then_some(&nm), flip);
            let refp = Vec3::new(f(-4.0, 4.0), f(-4.0, 4.0), f(-4.0, 4.0));
            let u = Vec2::new(f(0.0, 1.0), f(0.0, 1.0));
            rect_cases.push((rect, refp, u));
            let center = Vec3::new(f(-2.0, 2.0), f(-2.0, 2.0), f(-2.0, 2.0));
            let sph = Shape::sphere(center, f(0.05, 1.5), &Mat4::IDENTITY, flip).unwrap();
            sphere_cases.push((sph, refp, u));
        }
        let le = Spectrum::ONE;
        let mut checked = [0usize; 2];
        for (c, cases) in [&rect_cases, &sphere_cases].into_iter().enumerate() {
            for (shape, refp, u) in cases {
                let scene_less = [shape.clone()];
                let light = AreaLight {
                    shape: 0,
                    radiance: Texture::Constant(le),
                };
                let ds = light.sample_direct(&scene_less, *refp, *u);
                let sign = if shape.flip_normals { -1.0 } else { 1.0 };
                let q = match &shape.kind {
                    ShapeKind::Rectangle { to_world } => sample_rectangle(
                        &Rectangle {
                            axes: [
                                to_world.x_axis.truncate().into(),
                                to_world.y_axis.truncate().into(),
                                to_world.z_axis.truncate().into(),
                                to_world.w_axis.truncate().into(),
                            ],
                            n: (shape.rectangle_normal() * sign).into(),
                            inv_area: 1.0 / shape.area(),
                            u: (*u).into(),
                        },
                        (*refp).into(),
                    ),
                    ShapeKind::Sphere { center, radius, .. } => {
                        if !crate::geometry::shapes::sphere_sees_cone(
                            (*center - *refp).length(),
                            *radius,
                        ) {
                            continue;
                        }
                        sample_sphere(
                            &Sphere {
                                center: (*center).into(),
                                radius: *radius,
                                sign,
                                u: (*u).into(),
                            },
                            (*refp).into(),
                        )
                    }
                    _ => unreachable!(),
                };
                assert_eq!(q.ok, ds.is_some(), "{c}: {refp} {u}");
                if let Some(ds) = ds {
                    checked[c] += 1;
                    assert!(
                        same3(q.p, ds.p)
                            && same3(q.d, ds.d)
                            && same3(q.n, ds.n.unwrap())
                            && same(q.pdf, ds.pdf)
                            && same(q.dist, ds.dist),
                        "{c}: {refp} {u}"
                    );
                }
            }
        }
        // Roughly half of the random pairs face each other.
        assert!(checked.iter().all(|&n| n > 1000), "{checked:?}");
    }
}
