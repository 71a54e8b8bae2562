//! Microgeometries for microfacet-based normal mapping (Schüssler et al. 2017; spec `mnm.md`
//! §2 and §10.1): a few planar facets per shading point whose area-weighted normals sum to the
//! geometric normal ωg = +z (the closure identity), so the microsurface is a valid heightfield.
//!
//! Each facet k is stored as its *area vector* `v_k = A_k · m_k` (area per unit macro area times
//! unit normal). Then the projected area toward ω is `a_k(ω) = ⟨ω, v_k⟩`, closure reads
//! `Σ v_k = ωg`, and no formula divides by cos θp or sin θp (the robust form of §2.4).
//!
//! The per-hit build has a lane form ([`Candidates`], [`MaxTilt::clamp_lanes`]) with the
//! arithmetic of the scalar build ([`Microsurface::new`], [`MaxTilt::clamp`]): the stream
//! renderer's compensated kernel runs it 8 points at a time, then keeps each lane's facets
//! with [`Microsurface::of_lane`] (the same dropped facets, so the same microsurface bit for
//! bit; `tests`). The scalar renderer keeps the scalar build: at width 1 the lane form (every
//! candidate, frame and select computed, then stored) cost it ~4% more instructions.

use super::lane_cols::Cols;
use crate::lane::frame::Frame as LaneFrame;
use crate::lane::vec::V3;
use crate::lane::{Lane, ToArray};
use crate::math::Frame;
use glam::Vec3;

/// Most facets any microgeometry here uses.
pub const MAX_FACETS: usize = 3;

/// Which microgeometry to build from the perturbed normal ωp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Microgeometry {
    /// The paper's sawtooth: perturbed facet ωp plus a vertical "tangent" wall ωt.
    Sawtooth,
    /// Symmetric V-groove: ωp and its mirror image (−x, −y, z), each of area 1/(2 cos θp).
    VGroove,
    /// Three facets: ωp, a flat bottom ωg and the tangent wall; `fill` s ∈ (0, 1] (§10.3):
    /// A_p = s / cos θp, A_t = s · tan θp, A_n = 1 − s. s = 1 is the sawtooth.
    UGroove { fill: f32 },
}

/// Area vectors shorter than this are left out of a microsurface (zero-area facets).
const MIN_AREA: f32 = 1e-7;

/// Every candidate facet of a microgeometry at one or more shading points (lanes), before the
/// zero-area ones are dropped: area vectors, their lengths and unit normals (`v / |v|`, not
/// finite for a zero vector), and the facet frames (tangent along the shading frame's s) of
/// the first `framed` candidates. [`Microsurface::of_lane`] keeps lane `i`'s facets (of the
/// stored form, [`Candidates::cols`]).
#[derive(Clone, Copy, Debug)]
pub struct Candidates<L: Lane> {
    v: [V3<L>; MAX_FACETS],
    len: [L; MAX_FACETS],
    m: [V3<L>; MAX_FACETS],
    frames: [LaneFrame<L>; MAX_FACETS],
    /// Candidates of the microgeometry (2 or 3).
    n: usize,
    /// Candidates with a frame in `frames` (the first ones).
    framed: usize,
}

impl<L: Lane> Candidates<L> {
    /// The candidates for the perturbed normals `wp` (unit, z > 0) with the frames of the
    /// first `framed` of them, with the arithmetic of [`Microsurface::new`].
    #[inline(always)]
    pub fn new(geometry: Microgeometry, wp: V3<L>, framed: usize) -> Self {
        let like = wp.z;
        let inv_cos = like.splat(1.0) / wp.z;
        // ωt_u = ωg (ωg·ωp) − ωp: horizontal, length sin θp, pointing away from ωp's lean.
        let wt_u = V3::new(-wp.x, -wp.y, like.splat(0.0));
        let zero = V3::splat(like, 0.0, 0.0, 0.0);
        let (v, n) = match geometry {
            Microgeometry::Sawtooth => ([wp.scale(inv_cos), wt_u.scale(inv_cos), zero], 2),
            Microgeometry::VGroove => {
                let mirror = V3::new(-wp.x, -wp.y, wp.z);
                let a = like.splat(0.5) * inv_cos;
                ([wp.scale(a), mirror.scale(a), zero], 2)
            }
            Microgeometry::UGroove { fill } => {
                let a = like.splat(fill) * inv_cos;
                let flat = V3::splat(like, 0.0, 0.0, 1.0 - fill);
                ([wp.scale(a), flat, wt_u.scale(a)], 3)
            }
        };
        // Explicit loops, no closures (`array::from_fn`, `map`): a closure may be compiled
        // out of the kernel's SIMD function, and its 8-wide operations become calls.
        let z = V3::splat(like, 0.0, 0.0, 1.0);
        // The microgeometry's candidates only (a sawtooth's third slot keeps the placeholders:
        // no reader looks past `n`).
        let (mut len, mut m) = ([like; MAX_FACETS], [z; MAX_FACETS]);
        for k in 0..n {
            len[k] = v[k].length();
            m[k] = v[k].div_by(len[k]);
        }
        let framed = framed.min(n);
        let x = V3::splat(like, 1.0, 0.0, 0.0);
        let mut frames = [LaneFrame { s: z, t: z, n: z }; MAX_FACETS];
        for k in 0..framed {
            // Tangent along the shading frame's s (= dp/du), as Mitsuba's normalmap does.
            frames[k] = LaneFrame::from_normal_tangent(m[k], x);
        }
        Candidates {
            v,
            len,
            m,
            frames,
            n,
            framed,
        }
    }
}

impl<L: Lane> Candidates<L> {
    /// The lanes stored as arrays of `W` (the lane width): what [`Microsurface::of_lane`]
    /// reads, plain numbers (the per-point writes need no SIMD instruction).
    #[inline(always)]
    pub fn cols<const W: usize>(&self) -> FacetCols<W>
    where
        L: ToArray<f32, W>,
    {
        // Every row stored once, straight from the lanes, rather than every row zeroed and
        // then the used ones overwritten: the candidates past `n` and the frames past
        // `framed` hold [`Self::new`]'s placeholders, which no reader takes (`n` and
        // `framed` guard every read). Written out: a closure may be compiled out of line.
        const { assert!(MAX_FACETS == 3) };
        FacetCols {
            v: [store3(self.v[0]), store3(self.v[1]), store3(self.v[2])],
            len: [
                self.len[0].to_array(),
                self.len[1].to_array(),
                self.len[2].to_array(),
            ],
            m: [store3(self.m[0]), store3(self.m[1]), store3(self.m[2])],
            frames: [
                frame_cols(&self.frames[0]),
                frame_cols(&self.frames[1]),
                frame_cols(&self.frames[2]),
            ],
            n: self.n,
            framed: self.framed,
        }
    }
}

/// A frame's s, t, n stored as `[vector][component][lane]`.
#[inline(always)]
fn frame_cols<L: ToArray<f32, W>, const W: usize>(f: &LaneFrame<L>) -> [[[f32; W]; 3]; 3] {
    [store3(f.s), store3(f.t), store3(f.n)]
}

/// `v` stored as `[component][lane]`.
#[inline(always)]
pub(crate) fn store3<L: ToArray<f32, W>, const W: usize>(v: V3<L>) -> [[f32; W]; 3] {
    [v.x.to_array(), v.y.to_array(), v.z.to_array()]
}

/// [`Candidates`] stored per lane ([`Candidates::cols`]): `[component][lane]`.
#[derive(Clone, Copy, Debug)]
pub struct FacetCols<const W: usize> {
    v: [[[f32; W]; 3]; MAX_FACETS],
    len: [[f32; W]; MAX_FACETS],
    m: [[[f32; W]; 3]; MAX_FACETS],
    /// s, t, n of the first `framed` candidates' frames.
    frames: [[[[f32; W]; 3]; 3]; MAX_FACETS],
    n: usize,
    framed: usize,
}

impl<const W: usize> FacetCols<W> {
    /// Candidate `j`'s area vectors, `[component][lane]`.
    #[inline(always)]
    pub(crate) fn area_vectors(&self, j: usize) -> &[[f32; W]; 3] {
        &self.v[j]
    }

    /// Candidate `j`'s unit normals, `[component][lane]`.
    #[inline(always)]
    pub(crate) fn normals(&self, j: usize) -> &[[f32; W]; 3] {
        &self.m[j]
    }

    /// Candidate `j`'s frame (s, t, n, each `[component][lane]`; `j` below `framed`).
    #[inline(always)]
    pub(crate) fn frame(&self, j: usize) -> &[[[f32; W]; 3]; 3] {
        debug_assert!(j < self.framed);
        &self.frames[j]
    }

    /// Every candidate's area vectors, `[candidate][component][lane]` (the masked walks'
    /// columns as they are, `compensated::lanes::walk`).
    #[inline(always)]
    pub(crate) fn area_vector_cols(&self) -> &[[[f32; W]; 3]; MAX_FACETS] {
        &self.v
    }

    /// Every candidate's unit normals, `[candidate][component][lane]`.
    #[inline(always)]
    pub(crate) fn normal_cols(&self) -> &[[[f32; W]; 3]; MAX_FACETS] {
        &self.m
    }

    /// Every candidate's frame, `[candidate][s, t, n][component][lane]`: the first `framed`
    /// are the candidates' frames, the others [`Candidates::new`]'s placeholders.
    #[inline(always)]
    pub(crate) fn frame_cols(&self) -> &[[[[f32; W]; 3]; 3]; MAX_FACETS] {
        &self.frames
    }

    /// The microgeometry's candidates (2 or 3).
    #[inline(always)]
    pub(crate) fn candidates(&self) -> usize {
        self.n
    }

    /// Whether lane `i` keeps its first `n` candidates, in order, as its facets
    /// ([`Microsurface::of_lane`]'s test: none of them of zero area).
    #[inline(always)]
    pub(crate) fn keeps(&self, n: usize, i: usize) -> bool {
        let mut all = n <= self.n;
        for j in 0..n.min(self.n) {
            all &= self.len[j][i] > MIN_AREA;
        }
        all
    }
}

impl FacetCols<8> {
    /// [`Self::keeps`] of every lane, as bits (bit i: lane i), each candidate's test as one
    /// compare of its 8 lanes ([`Cols::gt_bits`]; call inside [`Cols::run`]).
    #[inline(always)]
    pub(crate) fn keeps_bits8(&self, cols: Cols, n: usize) -> u8 {
        let mut bits = if n <= self.n { u8::MAX } else { 0 };
        for j in 0..n.min(self.n) {
            bits &= cols.gt_bits(&self.len[j], MIN_AREA);
        }
        bits
    }
}

/// The facets at one shading point, in the macro (shading) frame where ωg = +z.
#[derive(Clone, Copy, Debug)]
pub struct Microsurface {
    /// Area vectors A_k · m_k.
    v: [Vec3; MAX_FACETS],
    /// Unit normals m_k.
    m: [Vec3; MAX_FACETS],
    n: usize,
}

impl Microsurface {
    /// Build the facets for the perturbed normal `wp` (unit, `wp.z > 0`; callers clamp it).
    /// Facets of zero area (e.g. the wall when ωp = ωg) are left out.
    pub fn new(geometry: Microgeometry, wp: Vec3) -> Microsurface {
        let inv_cos = 1.0 / wp.z;
        // ωt_u = ωg (ωg·ωp) − ωp: horizontal, length sin θp, pointing away from ωp's lean.
        let wt_u = Vec3::new(-wp.x, -wp.y, 0.0);
        let mut s = Microsurface {
            v: [Vec3::ZERO; MAX_FACETS],
            m: [Vec3::ZERO; MAX_FACETS],
            n: 0,
        };
        match geometry {
            Microgeometry::Sawtooth => {
                s.push(wp * inv_cos);
                s.push(wt_u * inv_cos);
            }
            Microgeometry::VGroove => {
                let mirror = Vec3::new(-wp.x, -wp.y, wp.z);
                s.push(wp * (0.5 * inv_cos));
                s.push(mirror * (0.5 * inv_cos));
            }
            Microgeometry::UGroove { fill } => {
                s.push(wp * (fill * inv_cos));
                s.push(Vec3::new(0.0, 0.0, 1.0 - fill));
                s.push(wt_u * (fill * inv_cos));
            }
        }
        s
    }

    /// The microsurface of lane `i` of `c`: its candidates of nonzero area, in order (as
    /// [`Self::new`] keeps them: the same test), and for each kept facet `k` its candidate's
    /// index.
    #[inline(always)]
    pub fn of_lane<const W: usize>(c: &FacetCols<W>, i: usize) -> (Microsurface, [u8; MAX_FACETS]) {
        let mut s = Microsurface {
            v: [Vec3::ZERO; MAX_FACETS],
            m: [Vec3::ZERO; MAX_FACETS],
            n: 0,
        };
        let mut from = [0u8; MAX_FACETS];
        for j in 0..c.n {
            if c.len[j][i] > MIN_AREA {
                from[s.n] = j as u8;
                s.v[s.n] = lane3(&c.v[j], i);
                s.m[s.n] = lane3(&c.m[j], i);
                s.n += 1;
            }
        }
        (s, from)
    }

    /// The frame of facet `k` of lane `i`'s microsurface (`from`: [`Self::of_lane`]'s
    /// candidate indices): `Frame::from_normal_tangent(normal(k), +x)`, taken from `c` when it
    /// holds that candidate's frame (the same bits: the same normal and arithmetic).
    #[inline(always)]
    pub fn frame_of_lane<const W: usize>(
        &self,
        c: &FacetCols<W>,
        from: &[u8; MAX_FACETS],
        i: usize,
        k: usize,
    ) -> Frame {
        let j = from[k] as usize;
        if j < c.framed {
            let f = &c.frames[j];
            Frame {
                s: lane3(&f[0], i),
                t: lane3(&f[1], i),
                n: lane3(&f[2], i),
            }
        } else {
            Frame::from_normal_tangent(self.m[k], Vec3::X)
        }
    }

    /// A microsurface from explicit area vectors (experiments and tests, e.g. a deliberately
    /// broken closure). At most [`MAX_FACETS`] are used; zero vectors are skipped.
    pub fn from_area_vectors(vs: &[Vec3]) -> Microsurface {
        let mut s = Microsurface {
            v: [Vec3::ZERO; MAX_FACETS],
            m: [Vec3::ZERO; MAX_FACETS],
            n: 0,
        };
        for &v in vs.iter().take(MAX_FACETS) {
            s.push(v);
        }
        s
    }

    /// |Σ_k A_k m_k − ωg|: zero for a valid microsurface (the closure identity).
    pub fn closure_error(&self) -> f32 {
        ((0..self.n).map(|k| self.v[k]).sum::<Vec3>() - Vec3::Z).length()
    }

    fn push(&mut self, v: Vec3) {
        let len = v.length();
        if len > MIN_AREA {
            self.v[self.n] = v;
            self.m[self.n] = v / len;
            self.n += 1;
        }
    }

    /// Number of facets.
    #[inline]
    pub fn len(&self) -> usize {
        self.n
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Unit normal of facet `k`.
    #[inline]
    pub fn normal(&self, k: usize) -> Vec3 {
        self.m[k]
    }

    /// Area vector A_k · m_k of facet `k`.
    #[inline]
    pub fn area_vector(&self, k: usize) -> Vec3 {
        self.v[k]
    }

    /// Projected area of facet `k` toward ω: a_k(ω) = A_k ⟨ω, m_k⟩.
    #[inline]
    pub fn proj_area(&self, k: usize, w: Vec3) -> f32 {
        w.dot(self.v[k]).max(0.0)
    }

    /// Σ_k a_k(ω): the microsurface's projected area toward ω (≥ z(ω) by closure).
    #[inline]
    pub fn sigma(&self, w: Vec3) -> f32 {
        (0..self.n).map(|k| self.proj_area(k, w)).sum()
    }

    /// Smith masking of the macro surface seen from ω: G1(ω) = χ(z)·min(1, z / Σ(ω)).
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        g1_of(&self.v[..self.n], w)
    }

    /// λ_k(ω) for every facet with Σ(ω) computed once (entries past [`len`](Self::len) are 0);
    /// each entry equals [`lambda`](Self::lambda)`(k, ω)` bit for bit.
    #[inline]
    pub fn lambdas(&self, w: Vec3) -> [f32; MAX_FACETS] {
        let mut l = [0.0; MAX_FACETS];
        let s = self.sigma(w);
        if s > 0.0 {
            for (k, lk) in l.iter_mut().enumerate().take(self.n) {
                *lk = self.proj_area(k, w) / s;
            }
        }
        l
    }

    /// Probability that a ray arriving from ω (pointing away, above the surface) first hits
    /// facet k: λ_k(ω) = a_k(ω) / Σ(ω).
    #[inline]
    pub fn lambda(&self, k: usize, w: Vec3) -> f32 {
        let s = self.sigma(w);
        if s > 0.0 {
            self.proj_area(k, w) / s
        } else {
            0.0
        }
    }

    /// Choose the facet hit by a ray arriving from ω (∝ a_k(ω)) with `u ∈ [0,1)`; returns the
    /// facet and its probability. `None` when no facet faces ω.
    #[inline]
    pub fn pick(&self, w: Vec3, u: f32) -> Option<(usize, f32)> {
        let s = self.sigma(w);
        if s <= 0.0 {
            return None;
        }
        let target = u * s;
        let mut acc = 0.0;
        let mut last = None;
        for k in 0..self.n {
            let a = self.proj_area(k, w);
            if a <= 0.0 {
                continue;
            }
            acc += a;
            last = Some((k, a / s));
            if target < acc {
                return last;
            }
        }
        last
    }
}

/// The perturbed normal used by microfacet normal mapping: `n` (from the normal map, in the
/// shading frame) normalised, with its tilt clamped to `max_theta` (radians) and a normal below
/// the horizon clamped as well (decisions page: `max_theta`, default 85°). [`MaxTilt::clamp`]
/// with the cosine and sine of `max_theta` computed here.
pub fn clamp_perturbed_normal(n: Vec3, max_theta: f32) -> Vec3 {
    MaxTilt::new(max_theta).clamp(n)
}

/// The largest tilt `max_theta` of the perturbed normal (radians) with its cosine and sine
/// computed once (a material's setting: the per-hit clamp, [`Self::clamp`], then makes no
/// `cos`/`sin` call).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaxTilt {
    radians: f32,
    cos: f32,
    sin: f32,
}

impl MaxTilt {
    pub fn new(radians: f32) -> Self {
        MaxTilt {
            radians,
            cos: radians.cos(),
            sin: radians.sin(),
        }
    }

    /// The tilt in radians.
    #[inline]
    pub fn radians(&self) -> f32 {
        self.radians
    }

    /// [`clamp_perturbed_normal`] of `n` for this tilt, bit for bit.
    #[inline]
    pub fn clamp(&self, n: Vec3) -> Vec3 {
        let Some(n) = n.try_normalize() else {
            return Vec3::Z;
        };
        let cos_min = self.cos;
        if n.z >= cos_min {
            return n;
        }
        let h = Vec3::new(n.x, n.y, 0.0);
        match h.try_normalize() {
            Some(h) => h * self.sin + Vec3::Z * cos_min,
            None => Vec3::Z, // straight down: no meaningful tilt direction
        }
    }

    /// [`Self::clamp`] per lane, bit for bit: `n` normalised (glam's `try_normalize`: times 1/|n| where that
    /// is finite and positive, else +z), its tilt clamped to this one (the horizontal part
    /// normalised the same way, times sin, plus +z times cos; +z when it has none).
    #[inline(always)]
    pub fn clamp_lanes<L: Lane>(&self, n: V3<L>) -> V3<L> {
        let like = n.z;
        let (zero, one) = (like.splat(0.0), like.splat(1.0));
        let z = V3::new(zero, zero, one);
        let (n, ok) = try_normalize(n);
        let cos_min = like.splat(self.cos);
        let h = V3::new(n.x, n.y, zero);
        let (h, h_ok) = try_normalize(h);
        let tilted = h.scale(like.splat(self.sin)) + z.scale(cos_min);
        // Straight down (no horizontal part): no meaningful tilt direction, +z.
        let clamped = V3::select(h_ok, tilted, z);
        V3::select(ok, V3::select(n.z.ge(cos_min), n, clamped), z)
    }
}

/// glam's `try_normalize` per lane: `v · (1/|v|)` and whether `1/|v|` is finite and positive.
#[inline(always)]
fn try_normalize<L: Lane>(v: V3<L>) -> (V3<L>, L::Mask) {
    let rcp = v.z.splat(1.0) / v.length();
    (v.scale(rcp), rcp.is_finite() & rcp.gt(rcp.splat(0.0)))
}

/// Lane `i` of the stored vector `v` (`[component][lane]`).
#[inline(always)]
fn lane3<const W: usize>(v: &[[f32; W]; 3], i: usize) -> Vec3 {
    Vec3::new(v[0][i], v[1][i], v[2][i])
}

/// [`Microsurface::g1`] of the microsurface with the area vectors `v` (its facets, in order):
/// also the stream kernel's mirror-sawtooth points, whose facets are kept in columns
/// (`compensated::lanes`), so that both compute G1 in the same operations.
#[inline(always)]
pub(crate) fn g1_of(v: &[Vec3], w: Vec3) -> f32 {
    if w.z <= 0.0 {
        return 0.0;
    }
    // One pass over the facets gives both the test below and Σ(ω) (each ⟨ω, v_k⟩ once; the
    // sum is [`Microsurface::sigma`]'s, bit for bit: negative terms add nothing).
    let mut s = 0.0;
    let mut all_face = true;
    for vk in v {
        let a = w.dot(*vk);
        if a >= 0.0 {
            s += a;
        } else {
            all_face = false;
        }
    }
    // Every facet faces ω: nothing can block it. Closure makes Σ = z exactly then; testing
    // it directly keeps rounding (z/Σ = 0.9999999) from inventing blocked rays.
    if all_face {
        return 1.0;
    }
    if s <= 0.0 {
        return 1.0;
    }
    (w.z / s).min(1.0)
}

/// [`Microsurface`]'s queries per lane (the random walk of several points at once, issue 18:
/// `compensated::lanes::walk`): each lane's area vectors `v` (its facets in order, the slots
/// past its [`Microsurface::len`] zero). A zero slot adds nothing bit for bit: its ⟨ω, v⟩ is
/// ±0, which counts as facing in [`Self::g1`] (as a real facet at 0 would) and adds ±0 to a
/// sum that is +0 or positive, and is not positive, so [`Self::pick`] skips it as the scalar
/// loop skips an a_k ≤ 0.
#[derive(Clone, Copy, Debug)]
pub(crate) struct SurfaceLanes<L: Lane> {
    pub v: [V3<L>; MAX_FACETS],
}

impl<L: Lane> SurfaceLanes<L> {
    /// [`Microsurface::g1`] per lane ([`g1_of`] in its operations and order): 0 below the
    /// surface; the facing facets' ⟨ω, v_k⟩ summed from 0; 1 when every facet faces ω or the
    /// sum is not positive, else min(1, z / Σ).
    #[inline(always)]
    pub fn g1(&self, w: V3<L>) -> L {
        let like = w.z;
        let (zero, one) = (like.splat(0.0), like.splat(1.0));
        let mut s = zero;
        let mut all_face: Option<L::Mask> = None;
        for vk in &self.v {
            let a = w.dot(*vk);
            let f = a.ge(zero);
            s = L::select(f, s + a, s);
            all_face = Some(match all_face {
                Some(m) => m & f,
                None => f,
            });
        }
        let all_face = all_face.expect("a microsurface has facets");
        let open = all_face | s.le(zero);
        let g = L::select(open, one, (w.z / s).min(one));
        L::select(w.z.le(zero), zero, g)
    }

    /// [`Microsurface::pick`] per lane from `u`: whether a facet faces ω (Σ(ω) > 0, the scalar
    /// `Some`) and the picked facet as one mask per slot (one set where a facet is picked):
    /// the first facet whose running sum of the positive a_k exceeds u·Σ, else the last
    /// positive one (the scalar loop's `last`). Σ is [`Microsurface::sigma`] (a_k = max(⟨ω,
    /// v_k⟩, 0) summed in order).
    #[inline(always)]
    pub fn pick(&self, w: V3<L>, u: L) -> (L::Mask, [L::Mask; MAX_FACETS]) {
        let zero = w.z.splat(0.0);
        let mut a = [zero; MAX_FACETS];
        let mut s = zero;
        for (ak, vk) in a.iter_mut().zip(&self.v) {
            *ak = w.dot(*vk).max(zero);
            s = s + *ak;
        }
        let some = !s.le(zero);
        let target = u * s;
        let mut acc = zero;
        let never = zero.lt(zero);
        let mut chosen = never;
        let mut took = [never; MAX_FACETS];
        let mut pos = [never; MAX_FACETS];
        for k in 0..MAX_FACETS {
            pos[k] = a[k].gt(zero);
            acc = L::select(pos[k], acc + a[k], acc);
            took[k] = pos[k] & !chosen & target.lt(acc);
            chosen = chosen | took[k];
        }
        // No running sum passed the target (rounding): the last positive facet.
        let mut later = never;
        for k in (0..MAX_FACETS).rev() {
            took[k] = took[k] | (!chosen & pos[k] & !later);
            later = later | pos[k];
        }
        (some, took)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::warp::square_to_uniform_sphere;
    use crate::math::Pcg32;
    use glam::Vec2;

    fn random_wp(r: &mut Pcg32, max_theta_deg: f32) -> Vec3 {
        let theta = r.next_f32() * max_theta_deg.to_radians();
        let phi = r.next_f32() * std::f32::consts::TAU;
        Vec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    }

    fn geometries() -> [Microgeometry; 5] {
        [
            Microgeometry::Sawtooth,
            Microgeometry::VGroove,
            Microgeometry::UGroove { fill: 0.25 },
            Microgeometry::UGroove { fill: 0.5 },
            Microgeometry::UGroove { fill: 1.0 },
        ]
    }

    /// Oracle 1 (closure): Σ A_k (ω·m_k) = z(ω) for every ω; λ sums to 1; 0 ≤ G1 ≤ 1; G1 = 1
    /// when every facet faces ω; no NaN for θp up to 85°.
    #[test]
    fn closure_lambda_and_masking_bounds() {
        let mut r = Pcg32::new(1, 1);
        for g in geometries() {
            for _ in 0..2000 {
                let wp = random_wp(&mut r, 85.0);
                let s = Microsurface::new(g, wp);
                let sum: Vec3 = (0..s.len()).map(|k| s.area_vector(k)).sum();
                assert!((sum - Vec3::Z).length() < 1e-4, "{g:?} {wp} {sum}");
                let w = square_to_uniform_sphere(Vec2::new(r.next_f32(), r.next_f32()));
                let signed: f32 = (0..s.len()).map(|k| w.dot(s.area_vector(k))).sum();
                assert!((signed - w.z).abs() < 1e-4);
                let g1 = s.g1(w);
                assert!(g1.is_finite() && (0.0..=1.0).contains(&g1));
                if w.z > 0.0 {
                    let l: f32 = (0..s.len()).map(|k| s.lambda(k, w)).sum();
                    assert!((l - 1.0).abs() < 1e-5);
                    assert!(s.sigma(w) >= w.z * (1.0 - 1e-5));
                    if (0..s.len()).all(|k| w.dot(s.normal(k)) > 0.0) {
                        assert!((g1 - 1.0).abs() < 1e-4, "{g:?} all facets face ω: G1 {g1}");
                    }
                } else {
                    assert_eq!(g1, 0.0);
                }
            }
        }
    }

    /// The sawtooth's masking equals the reference form min(1, z·cosθp/(⟨ω,ωp⟩ + ⟨ω,ωt⟩ sinθp)).
    #[test]
    fn sawtooth_masking_matches_the_reference_form() {
        let mut r = Pcg32::new(2, 1);
        for _ in 0..2000 {
            let wp = random_wp(&mut r, 80.0);
            let s = Microsurface::new(Microgeometry::Sawtooth, wp);
            let w = square_to_uniform_sphere(Vec2::new(r.next_f32(), r.next_f32()));
            if w.z <= 0.0 || wp.z > 0.9999 {
                continue;
            }
            let sin_p = (1.0 - wp.z * wp.z).sqrt();
            let wt = Vec3::new(-wp.x, -wp.y, 0.0) / sin_p;
            let denom = w.dot(wp).max(0.0) + w.dot(wt).max(0.0) * sin_p;
            let reference = (w.z * wp.z / denom).min(1.0);
            assert!(
                (s.g1(w) - reference).abs() < 1e-4,
                "{} vs {reference}",
                s.g1(w)
            );
        }
    }

    /// V-groove, in-plane directions: Torrance–Sparrow masking min(1, 2 cosθp cosθω / (ω·m)) for
    /// the facet facing away (§10.2).
    #[test]
    fn vgroove_matches_torrance_sparrow_in_plane() {
        let tp = 40f32.to_radians();
        let wp = Vec3::new(tp.sin(), 0.0, tp.cos());
        let s = Microsurface::new(Microgeometry::VGroove, wp);
        for deg in [-80.0f32, -60.0, -30.0, 0.0, 20.0, 55.0, 75.0] {
            let t = deg.to_radians();
            let w = Vec3::new(t.sin(), 0.0, t.cos());
            let ts = (0..2)
                .map(|k| {
                    let m = s.normal(k);
                    if w.dot(m) > 0.0 {
                        (2.0 * m.z * w.z / w.dot(m)).min(1.0)
                    } else {
                        1.0
                    }
                })
                .fold(1.0f32, f32::min);
            assert!((s.g1(w) - ts).abs() < 1e-5, "θ {deg}: {} vs {ts}", s.g1(w));
        }
    }

    #[test]
    fn flat_normal_leaves_a_single_flat_facet() {
        for g in geometries() {
            let s = Microsurface::new(g, Vec3::Z);
            let sum: Vec3 = (0..s.len()).map(|k| s.area_vector(k)).sum();
            assert!((sum - Vec3::Z).length() < 1e-6);
            assert!((0..s.len()).all(|k| (s.normal(k) - Vec3::Z).length() < 1e-6));
            assert_eq!(s.g1(Vec3::new(0.6, 0.0, 0.8)), 1.0);
        }
    }

    #[test]
    fn pick_follows_projected_areas() {
        let wp = Vec3::new(0.5, 0.2, 0.8).normalize();
        let s = Microsurface::new(Microgeometry::UGroove { fill: 0.5 }, wp);
        let w = Vec3::new(-0.3, 0.1, 0.9).normalize();
        let n = 30_000;
        let mut counts = [0usize; MAX_FACETS];
        for i in 0..n {
            let (k, p) = s.pick(w, (i as f32 + 0.5) / n as f32).unwrap();
            assert!((p - s.lambda(k, w)).abs() < 1e-6);
            counts[k] += 1;
        }
        for (k, &c) in counts.iter().enumerate().take(s.len()) {
            assert!((c as f32 / n as f32 - s.lambda(k, w)).abs() < 1e-3);
        }
    }

    #[test]
    fn perturbed_normal_clamp() {
        let mt = 85f32.to_radians();
        let n = clamp_perturbed_normal(Vec3::new(1.0, 0.0, 0.01), mt);
        assert!((n.z - mt.cos()).abs() < 1e-5 && (n.length() - 1.0).abs() < 1e-5);
        let below = clamp_perturbed_normal(Vec3::new(0.0, 1.0, -0.5), mt);
        assert!((below.z - mt.cos()).abs() < 1e-5 && below.y > 0.0);
        let ok = Vec3::new(0.3, 0.0, 0.9).normalize();
        assert_eq!(clamp_perturbed_normal(ok, mt), ok);
        assert_eq!(clamp_perturbed_normal(Vec3::ZERO, mt), Vec3::Z);
    }

    /// The per-hit build 8 hits at a time (`MnmSettings::lanes_at` then `map_lane_into`, as
    /// the stream renderer's compensated kernel runs it) writes the map `map_into` builds (the
    /// scalar renderer's, this module's code at width 1) bit for bit, lane by lane: every
    /// microgeometry (a U-groove that drops its flat bottom, fill = 1), baked and per-bounce
    /// tables and no table, compensated and random walk; normal map values anywhere in the
    /// cube (tilts beyond the clamp, below the horizon), flat and nearly flat, zero and
    /// straight down.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn per_hit_build_in_lanes_equals_the_scalar_build_bit_for_bit() {
        use super::super::ms_table::{Colour, MsTable};
        use super::super::{Evaluation, MicrofacetNormalMap, Tangent, TransmissionWalk};
        use crate::lane::vec::V3;
        use crate::lane::Avx2;
        use crate::material::MnmSettings;
        let Some(avx) = Avx2::detect() else { return };
        fn bits(m: &MicrofacetNormalMap) -> Vec<u32> {
            let mut b = vec![
                m.nested,
                m.max_order,
                m.degenerate as u32,
                m.mirror_wall as u32,
            ];
            let mut v3 = |v: Vec3| b.extend(v.to_array().map(f32::to_bits));
            v3(m.wp);
            for k in 0..MAX_FACETS {
                v3(m.surface.v[k]);
                v3(m.surface.m[k]);
                v3(m.frames[k].s);
                v3(m.frames[k].t);
                v3(m.frames[k].n);
            }
            b.push(m.surface.n as u32);
            b.push(m.mis_c.map_or(u32::MAX, f32::to_bits));
            b.push(m.blend.to_bits());
            b.push(m.lambert_closed_form as u32);
            if let Some(r) = &m.ms {
                b.extend([r.cell.j as u32, r.cell.t.to_bits()]);
                b.extend([r.cell.axis.x.to_bits(), r.cell.axis.y.to_bits()]);
                b.push(std::ptr::from_ref(r.table) as usize as u32);
            }
            b
        }
        let cases = [
            (
                Microgeometry::Sawtooth,
                Tangent::Mirror,
                Some(Colour::Baked),
            ),
            (
                Microgeometry::VGroove,
                Tangent::Same,
                Some(Colour::PerBounce),
            ),
            (Microgeometry::UGroove { fill: 0.6 }, Tangent::Same, None),
            (Microgeometry::UGroove { fill: 1.0 }, Tangent::Same, None),
            (Microgeometry::Sawtooth, Tangent::Same, None),
        ];
        let special = [
            Vec3::new(0.5, 0.5, 1.0),
            Vec3::new(0.5, 0.5, 0.5),
            Vec3::new(0.5, 0.5, 0.0),
            Vec3::new(0.5 + 2e-7, 0.5, 1.0),
            Vec3::new(0.5, 0.5 + 1e-6, 0.9),
            Vec3::new(1.0, 0.5, 0.5),
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.9, 0.1, 0.55),
        ];
        let mut r = Pcg32::new(14, 2);
        let mut flat = 0;
        for (geometry, tangent, colour) in cases {
            let ms_table = colour.map(|c| MsTable::unit_lambert(geometry, tangent, c));
            for evaluation in [Evaluation::Compensated, Evaluation::RandomWalk] {
                let settings = MnmSettings {
                    geometry,
                    tangent,
                    evaluation,
                    max_order: 256,
                    max_theta: MaxTilt::new(70f32.to_radians()),
                    transmission_walk: TransmissionWalk::TwoSided,
                    lambert_closed_form: true,
                    ms_table,
                };
                for chunk in 0..200 {
                    let rgb: [Vec3; 8] = std::array::from_fn(|k| {
                        if chunk == 0 {
                            special[k]
                        } else {
                            Vec3::new(r.next_f32(), r.next_f32(), r.next_f32())
                        }
                    });
                    let lanes = avx.run(|| {
                        let col = |c: usize| avx.load(&rgb.map(|v| v[c]));
                        settings
                            .lanes_at(V3::new(col(0), col(1), col(2)))
                            .cols::<8>()
                    });
                    // `keeps_bits8` is `keeps` of each lane, 8-wide and lane by lane.
                    for cols in [Cols::detect(), Cols::LOOPS] {
                        for n in 1..=3 {
                            let bits = cols.run(|c| lanes.facets().keeps_bits8(c, n));
                            for k in 0..8 {
                                let want = lanes.facets().keeps(n, k);
                                assert_eq!(bits & (1 << k) != 0, want, "{geometry:?} {n} {k}");
                            }
                        }
                    }
                    // The stream kernel's points (with cells): `two_facets_with_cell` of each,
                    // 8-wide and lane by lane.
                    if lanes.cells().is_some() {
                        for cols in [Cols::detect(), Cols::LOOPS] {
                            let pts = crate::stream::kernels::mnm::point_bits(cols, &lanes);
                            for k in 0..8 {
                                let want = lanes.two_facets_with_cell(k);
                                assert_eq!(pts & (1 << k) != 0, want, "{geometry:?} {k}");
                            }
                        }
                    }
                    for (k, &rgb) in rgb.iter().enumerate() {
                        let mut want = MicrofacetNormalMap::placeholder();
                        settings.map_into(&mut want, 3, rgb);
                        let mut got = MicrofacetNormalMap::placeholder();
                        settings.map_lane_into(&mut got, 3, &lanes, k);
                        assert_eq!(bits(&got), bits(&want), "{geometry:?} {evaluation:?} {rgb}");
                        flat += want.degenerate as usize;
                    }
                }
            }
        }
        assert!(flat >= 5 * 2 * 3, "the flat cases ran: {flat}");
    }
}
