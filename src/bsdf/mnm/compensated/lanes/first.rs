//! The compensated model's first order over the mirror sawtooth at up to 8 shading points in
//! lanes (issue 18): what `Collected::new`, the nested batch and `Collected::sum::<false>` of
//! `compensated.rs` compute per point — G1(ωo), ωo in the facet frame, the wall exit (R(ωo),
//! 1 − G1(R(ωo))), the nested BSDF's four paths per point (\[p\] and \[t,p\] from each of the two
//! entries) and their weighted sums — computed for the 8 points together, one lane per point,
//! from the points' microsurfaces, facet frames and entries copied once per chunk into
//! [`Points8`] (the entries themselves computed there in lanes, [`Points8::entries`]: what
//! `Entries::new` computes, in its operations), with each query's ωo in [`Mirror8`].
//!
//! Bit for bit the scalar first order: every lane runs the scalar code's operations in its
//! order (the same dot products, the same sums, term by term, with a missing entry or wall exit
//! skipped by a select where the scalar code skips the addition; a known term, the sample
//! record's, taken instead of the evaluated one), and the nested values come from the lane
//! form the scalar path's batch calls (the lane rule of [`crate::lane`]: a lane's values do not
//! depend on its neighbours). Paths that no lane needs are not evaluated (a horizontal test
//! whose both branches give the same bits). Under the [`Avx2`] token 8-wide, else lane by lane
//! at width 1 (the same source). Tested against the scalar model by `super::tests` (every
//! mirror-sawtooth point of the chunk tests goes through here) and width 1 against width 8
//! (`tests`).

#[cfg(test)]
use super::super::super::facet_bsdf::reflect_across;
#[cfg(test)]
use super::super::super::facets::g1_of;
use super::super::super::facets::FacetCols;
use super::super::super::lane_cols::Cols;
use super::super::super::nested_batch::LaneNested;
#[cfg(test)]
use super::super::Entries;
#[cfg(test)]
use super::super::Known;
#[cfg(test)]
use super::super::Leaves;
use super::super::Nested;
use crate::bsdf::mnm::MicrofacetNormalMap;
use crate::lane::frame::Frame as LaneFrame;
use crate::lane::vec::V3;
#[cfg(target_arch = "x86_64")]
use crate::lane::{Avx2, F32x8, M8};
use crate::lane::{Lane, LaneMask};
#[cfg(test)]
use crate::math::Frame;
use crate::spectrum::Spectrum;
use glam::Vec3;

#[cfg(target_arch = "x86_64")]
mod pack;

/// Entries per point over the mirror sawtooth: facet 0 directly and through the wall.
const ENTRIES: usize = 2;

/// The first-order inputs of up to 8 mirror-sawtooth points that depend on the point and its
/// ωi only, by lane (`[component][lane]`): the microsurface (area vectors of the facet and the
/// wall, the wall's normal), the facet's frame and the entries at ωi (weight, direction in the
/// facet frame, and 1 where the entry exists). Built once per chunk (`super::Chunk`) for both
/// queries. Unused lanes hold finite placeholders whose results are never read.
pub(in crate::bsdf::mnm::compensated) struct Points8 {
    v0: [[f32; 8]; 3],
    v1: [[f32; 8]; 3],
    n1: [[f32; 8]; 3],
    /// s, t, n of facet 0's frame.
    fr: [[[f32; 8]; 3]; 3],
    w: [[f32; 8]; ENTRIES],
    a: [[[f32; 8]; 3]; ENTRIES],
    has: [[f32; 8]; ENTRIES],
    /// ωi, and 1 where the entry of slot 0 is the wall's (no direct entry) and where there is
    /// a wall entry at all ([`Self::entries`]' inputs and what `Self::entries_of` reads).
    wi: [[f32; 8]; 3],
    wall0: [f32; 8],
    wall: [f32; 8],
    /// Bit k: lane k was pushed.
    pushed: u8,
}

/// Lane `k` of a [`Points8`] as [`super::super::leave`] reads a point's microsurface: facet
/// 0's frame, the area vectors of the facet and the wall, the wall's normal, the numbers of
/// the point's map ([`Points8::push_point`], [`Points8::of_facets`]) in the map's operations
/// (`Frame::to_world`, [`g1_of`], [`reflect_across`]). The tests' reference for
/// [`Points8::leave_dirs`] (the sampler computes those numbers for 8 lanes at once).
#[cfg(test)]
pub(in crate::bsdf::mnm::compensated) struct Lane8<'p> {
    p: &'p Points8,
    k: usize,
}

#[cfg(test)]
impl Lane8<'_> {
    #[inline(always)]
    fn get(&self, x: &[[f32; 8]; 3]) -> Vec3 {
        Vec3::new(x[0][self.k], x[1][self.k], x[2][self.k])
    }
}

#[cfg(test)]
impl Leaves for Lane8<'_> {
    #[inline(always)]
    fn facet_to_world(&self, k: usize, w: Vec3) -> Vec3 {
        debug_assert_eq!(k, 0, "over the mirror sawtooth every entry is facet 0's");
        let fr = &self.p.fr;
        Frame {
            s: self.get(&fr[0]),
            t: self.get(&fr[1]),
            n: self.get(&fr[2]),
        }
        .to_world(w)
    }
    #[inline(always)]
    fn mirror_wall(&self) -> bool {
        true
    }
    #[inline(always)]
    fn g1(&self, w: Vec3) -> f32 {
        g1_of(&[self.get(&self.p.v0), self.get(&self.p.v1)], w)
    }
    #[inline(always)]
    fn reflect_wall(&self, w: Vec3) -> Vec3 {
        reflect_across(w, self.get(&self.p.n1))
    }
}

/// One query's first-order inputs over [`Points8`], by lane: ωo, the known term (its path
/// `2 j + wall`, −1 for none) and the lanes the query evaluates (`on`: 1 where used, else 0;
/// `used`: the same as bits).
pub(in crate::bsdf::mnm::compensated) struct Mirror8 {
    wo: [[f32; 8]; 3],
    ks: [f32; 8],
    kf: [[f32; 8]; 3],
    kp: [f32; 8],
    on: [f32; 8],
    used: u8,
}

/// [`Mirror8::eval`]'s results by lane: the first order's f1·z(ωo) and density p1.
pub(in crate::bsdf::mnm::compensated) struct FirstOrders {
    pub(in crate::bsdf::mnm::compensated) f: [[f32; 8]; 3],
    pub(in crate::bsdf::mnm::compensated) p: [f32; 8],
}

impl FirstOrders {
    /// Every lane (0, 0).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn zero() -> Self {
        FirstOrders {
            f: [[0.0; 8]; 3],
            p: [0.0; 8],
        }
    }

    /// Lane `k` set to (`f`, `p`).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn set(&mut self, k: usize, f: Spectrum, p: f32) {
        set3(&mut self.f, k, f);
        self.p[k] = p;
    }

    /// Lane `k`'s (f1·z(ωo), p1).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn get(&self, k: usize) -> (Spectrum, f32) {
        (
            Vec3::new(self.f[0][k], self.f[1][k], self.f[2][k]),
            self.p[k],
        )
    }
}

/// [`Points8::leave_dirs`]' results by lane: u (a nested sample's ωo in the shading frame),
/// G1(u) and R(u).
pub(in crate::bsdf::mnm::compensated) struct Left {
    u: [[f32; 8]; 3],
    g: [f32; 8],
    r: [[f32; 8]; 3],
}

impl Left {
    #[inline(always)]
    fn zero() -> Self {
        Left {
            u: [[0.0; 8]; 3],
            g: [0.0; 8],
            r: [[0.0; 8]; 3],
        }
    }

    /// Lane `k`'s G1(u).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn g(&self, k: usize) -> f32 {
        self.g[k]
    }

    /// G1(u) by lane (the mirror wall's draws in lanes, `super::draws`).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn g_col(&self) -> &[f32; 8] {
        &self.g
    }

    /// The sampler's directions into `wo` (by component), for the lanes `on` (bit k: lane k;
    /// the others kept): R(u) in the lanes of `wall`, else u (`leave_mirror`'s choice). Call
    /// inside [`Cols::run`].
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn blend_into(
        &self,
        cols: Cols,
        on: u8,
        wall: u8,
        wo: &mut [[f32; 8]; 3],
    ) {
        cols.blend3(on & !wall, wo, &self.u);
        cols.blend3(on & wall, wo, &self.r);
    }

    /// Lane `k`'s (u, G1(u), R(u)).
    #[cfg(test)]
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn get(&self, k: usize) -> (Vec3, f32, Vec3) {
        let (u, r) = (&self.u, &self.r);
        (
            Vec3::new(u[0][k], u[1][k], u[2][k]),
            self.g[k],
            Vec3::new(r[0][k], r[1][k], r[2][k]),
        )
    }
}

/// `leave`'s numbers over the mirror sawtooth in lanes (`Lane8`'s operations): u = the facet
/// frame `fr`'s `to_world(wo)` (`Frame::to_world` is this lane form at width 1), G1(u) of the
/// microsurface (`g1`, `facets::g1_of`'s operations) and R(u) = u − (2 ⟨u, ωt⟩) ωt
/// (`facet_bsdf::reflect_across`: `w - 2.0 * w.dot(wt) * wt`; a product's factors commute bit
/// for bit).
#[inline(always)]
fn leave_lanes<L: Lane>(
    v0: V3<L>,
    v1: V3<L>,
    n1: V3<L>,
    fr: &LaneFrame<L>,
    wo: V3<L>,
) -> (V3<L>, L, V3<L>) {
    let u = fr.to_world(wo);
    let g = g1(v0, v1, u);
    let r = u - n1.scale(u.z.splat(2.0) * u.dot(n1));
    (u, g, r)
}

#[inline(always)]
fn set3(x: &mut [[f32; 8]; 3], k: usize, v: Vec3) {
    x[0][k] = v.x;
    x[1][k] = v.y;
    x[2][k] = v.z;
}

/// Column `x` (three rows of 8 lanes) as 8-wide lanes. A plain function, not a closure: a
/// closure may be compiled out of the SIMD function, and its loads become calls.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn l3_8(avx: Avx2, x: &[[f32; 8]; 3]) -> V3<F32x8> {
    V3::new(avx.load(&x[0]), avx.load(&x[1]), avx.load(&x[2]))
}

/// 8-wide lanes stored into column `x` (the inverse of [`l3_8`]).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn s3_8(v: V3<F32x8>, x: &mut [[f32; 8]; 3]) {
    v.x.store(&mut x[0]);
    v.y.store(&mut x[1]);
    v.z.store(&mut x[2]);
}

/// Lane `k` of column `x`.
#[inline(always)]
fn l3_1(x: &[[f32; 8]; 3], k: usize) -> V3<f32> {
    V3::new(x[0][k], x[1][k], x[2][k])
}

impl Points8 {
    /// The points' microsurface (area vectors `v0`, `v1`, normal `n1`) and facet frame, 8 wide.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn geometry8(&self, avx: Avx2) -> (V3<F32x8>, V3<F32x8>, V3<F32x8>, LaneFrame<F32x8>) {
        let fr = LaneFrame {
            s: l3_8(avx, &self.fr[0]),
            t: l3_8(avx, &self.fr[1]),
            n: l3_8(avx, &self.fr[2]),
        };
        (
            l3_8(avx, &self.v0),
            l3_8(avx, &self.v1),
            l3_8(avx, &self.n1),
            fr,
        )
    }

    /// [`Self::geometry8`] of lane `k`.
    #[inline(always)]
    fn geometry1(&self, k: usize) -> (V3<f32>, V3<f32>, V3<f32>, LaneFrame<f32>) {
        let fr = LaneFrame {
            s: l3_1(&self.fr[0], k),
            t: l3_1(&self.fr[1], k),
            n: l3_1(&self.fr[2], k),
        };
        (l3_1(&self.v0, k), l3_1(&self.v1, k), l3_1(&self.n1, k), fr)
    }

    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn new() -> Self {
        let z = [[0.0; 8], [0.0; 8], [1.0; 8]];
        Points8 {
            v0: z,
            v1: z,
            n1: z,
            fr: [z; 3],
            w: [[0.0; 8]; ENTRIES],
            a: [z; ENTRIES],
            has: [[0.0; 8]; ENTRIES],
            wi: z,
            wall0: [0.0; 8],
            wall: [0.0; 8],
            pushed: 0,
        }
    }

    /// The microsurfaces and facet frames of the lanes of `f` (the stream kernel's build,
    /// `MnmSettings::lanes_at`, over the mirror sawtooth): each lane that keeps both candidates
    /// ([`FacetCols::keeps`]) holds the numbers [`Self::push_point`] copies from its map (the
    /// map's facets and frame are these candidates, `Microsurface::of_lane`), without the map;
    /// its ωi then comes with [`Self::push_wi`]. Lanes never pushed are reset to placeholders
    /// by [`Self::clear_unpushed`].
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn of_facets(f: &FacetCols<8>) -> Self {
        Points8 {
            v0: *f.area_vectors(0),
            v1: *f.area_vectors(1),
            n1: *f.normals(1),
            fr: *f.frame(0),
            ..Self::new()
        }
    }

    /// Lane `k` (its microsurface from [`Self::of_facets`]) seen from `wi` (z > 0).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn push_wi(&mut self, k: usize, wi: Vec3) {
        set3(&mut self.wi, k, wi);
        self.pushed |= 1 << k;
    }

    /// [`Self::push_wi`] of the lanes `on` (bit k: lane k), ωi from lane k of `wi` (by
    /// component), the other lanes kept: a blend per column. Call inside [`Cols::run`].
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn push_wi_lanes(
        &mut self,
        cols: Cols,
        on: u8,
        wi: &[[f32; 8]; 3],
    ) {
        cols.blend3(on, &mut self.wi, wi);
        self.pushed |= on;
    }

    /// The lanes not pushed get [`Self::new`]'s placeholders (a lane of [`Self::of_facets`]
    /// without a point may hold a flat microsurface's non-finite wall normal).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn clear_unpushed(&mut self) {
        let z = Vec3::Z;
        // Over the lanes not pushed only (most chunks have none).
        let mut rest = !self.pushed;
        while rest != 0 {
            let k = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            set3(&mut self.v0, k, z);
            set3(&mut self.v1, k, z);
            set3(&mut self.n1, k, z);
            for c in 0..3 {
                set3(&mut self.fr[c], k, z);
            }
        }
    }

    /// Lane `k`'s microsurface as [`super::super::leave`] reads it.
    #[cfg(test)]
    pub(in crate::bsdf::mnm::compensated) fn lane(&self, k: usize) -> Lane8<'_> {
        Lane8 { p: self, k }
    }

    /// [`super::super::leave`]'s numbers before its draw over the mirror sawtooth, for every
    /// lane at once: u = facet 0's frame to the shading frame of the nested samples'
    /// directions `wo` (by component), G1(u) and the mirror wall's reflection R(u) (`Lane8`'s
    /// `facet_to_world(0, ·)`, `g1`, `reflect_wall`, in their operations and order: bit for bit,
    /// `tests`). 8-wide when the CPU has AVX2 and FMA, else lane by lane at width 1 (the same
    /// numbers). Lanes without a point or a sample hold any value.
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn leave_dirs(
        &self,
        cols: Cols,
        wo: &[[f32; 8]; 3],
    ) -> Left {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = cols.avx() {
            return avx.run(
                #[inline(always)]
                || {
                    let (v0, v1, n1, fr) = self.geometry8(avx);
                    let (u, g, r) = leave_lanes(v0, v1, n1, &fr, l3_8(avx, wo));
                    let mut out = Left::zero();
                    s3_8(u, &mut out.u);
                    g.store(&mut out.g);
                    s3_8(r, &mut out.r);
                    out
                },
            );
        }
        self.leave_dirs_width1(wo)
    }

    /// [`Self::leave_dirs`] lane by lane at width 1.
    #[inline(always)]
    fn leave_dirs_width1(&self, wo: &[[f32; 8]; 3]) -> Left {
        let mut out = Left::zero();
        for k in 0..8 {
            let (v0, v1, n1, fr) = self.geometry1(k);
            let (u, g, r) = leave_lanes(v0, v1, n1, &fr, l3_1(wo, k));
            set3(&mut out.u, k, u.into());
            out.g[k] = g;
            set3(&mut out.r, k, r.into());
        }
        out
    }

    /// Lane `k`: the point of map `m` (over the mirror sawtooth: `m.mirror_wall`) seen from
    /// `wi` (z > 0), whose entries [`Self::entries`] then computes with the other lanes'.
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn push_point(
        &mut self,
        k: usize,
        m: &MicrofacetNormalMap,
        wi: Vec3,
    ) {
        debug_assert!(m.mirror_wall);
        let surf = &m.surface;
        set3(&mut self.v0, k, surf.area_vector(0));
        set3(&mut self.v1, k, surf.area_vector(1));
        set3(&mut self.n1, k, surf.normal(1));
        let f = &m.frames[0];
        set3(&mut self.fr[0], k, f.s);
        set3(&mut self.fr[1], k, f.t);
        set3(&mut self.fr[2], k, f.n);
        set3(&mut self.wi, k, wi);
        self.pushed |= 1 << k;
    }

    /// `Entries::new` of every lane pushed by [`Self::push_point`], in lanes (8-wide when the
    /// CPU has AVX2 and FMA, else lane by lane at width 1: the same numbers), into the entry
    /// columns; `Self::entries_of` gives a lane's as the scalar `Entries`.
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn entries(&mut self, cols: Cols) {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = cols.avx() {
            avx.run(
                #[inline(always)]
                || {
                    let (v0, v1, n1, fr) = self.geometry8(avx);
                    let e = entries(v0, v1, n1, &fr, l3_8(avx, &self.wi));
                    for j in 0..ENTRIES {
                        e.w[j].store(&mut self.w[j]);
                        s3_8(e.a[j], &mut self.a[j]);
                        e.has[j].store(&mut self.has[j]);
                    }
                    e.wall0.store(&mut self.wall0);
                    e.wall.store(&mut self.wall);
                },
            );
            return;
        }
        self.entries_width1();
    }

    /// [`Self::entries`] lane by lane at width 1.
    #[inline(always)]
    fn entries_width1(&mut self) {
        for k in 0..8 {
            if self.pushed & (1 << k) == 0 {
                continue;
            }
            let (v0, v1, n1, fr) = self.geometry1(k);
            let e = entries(v0, v1, n1, &fr, l3_1(&self.wi, k));
            for j in 0..ENTRIES {
                self.w[j][k] = e.w[j];
                set3(&mut self.a[j], k, e.a[j].into());
                self.has[j][k] = e.has[j];
            }
            self.wall0[k] = e.wall0;
            self.wall[k] = e.wall;
        }
    }

    /// Lane `k`'s entries (computed by [`Self::entries`]) as `Entries::new` gives them (the
    /// tests' view: the sampler reads the columns, [`Self::pick`]).
    #[cfg(test)]
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn entries_of(&self, k: usize) -> Entries {
        let mut e = Entries::EMPTY;
        for j in 0..ENTRIES {
            if self.has[j][k] > 0.0 {
                let a = Vec3::new(self.a[j][0][k], self.a[j][1][k], self.a[j][2][k]);
                e.push(0, self.w[j][k], a);
            }
        }
        // The wall's entry is the last one.
        if self.wall[k] > 0.0 {
            e.via_wall = if self.wall0[k] > 0.0 { 1 } else { 2 };
        }
        e
    }

    /// `pick_entry` over lane `k`'s entries (`Self::entries_of`) from the columns: `None`
    /// without an entry, slot 0 when it is the only one, else slot 0 where `x` < 0 + w0
    /// (`pick_entry`'s running sum from 0) and slot 1 otherwise. A second slot exists only
    /// with a first (`entries`), so these are the scalar loop's cases for up to 2 entries.
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn pick(&self, k: usize, x: f32) -> Option<usize> {
        if self.has[0][k] <= 0.0 {
            return None;
        }
        if self.has[1][k] <= 0.0 {
            return Some(0);
        }
        let mut acc = 0.0f32;
        acc += self.w[0][k];
        Some(if x < acc { 0 } else { 1 })
    }

    /// [`Self::pick`] and [`Self::entry_dir`] of the 8 lanes at once, from the numbers `x` by
    /// lane: the lanes with an entry (`pick`'s `Some`: slot 0 exists, its 1 not at most 0), the
    /// lanes whose pick is slot 1 (a second slot, and `x` not below 0 + w0: `pick`'s sum and
    /// compare), and the picked entry's direction in facet 0's frame (lanes without an entry:
    /// any value). Call inside [`Avx2::run`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn pick8(
        &self,
        avx: Avx2,
        x: F32x8,
    ) -> (M8, M8, V3<F32x8>) {
        let zero = avx.splat(0.0);
        let some = !avx.load(&self.has[0]).le(zero);
        let two = !avx.load(&self.has[1]).le(zero);
        let acc = zero + avx.load(&self.w[0]);
        let second = some & two & !x.lt(acc);
        let a = V3::select(second, l3_8(avx, &self.a[1]), l3_8(avx, &self.a[0]));
        (some, second, a)
    }

    /// The direction of lane `k`'s entry `j` in facet 0's frame (`entries_of(k).a[j]`).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn entry_dir(&self, k: usize, j: usize) -> Vec3 {
        let a = &self.a[j];
        Vec3::new(a[0][k], a[1][k], a[2][k])
    }

    /// Lane `k`: the point of map `m` (over the mirror sawtooth: `m.mirror_wall`) with the
    /// entries `e` at its ωi given (the tests' random entries).
    #[cfg(test)]
    pub(in crate::bsdf::mnm::compensated) fn push(
        &mut self,
        k: usize,
        m: &MicrofacetNormalMap,
        e: &Entries,
    ) {
        debug_assert!(m.mirror_wall && e.len() <= ENTRIES);
        let surf = &m.surface;
        set3(&mut self.v0, k, surf.area_vector(0));
        set3(&mut self.v1, k, surf.area_vector(1));
        set3(&mut self.n1, k, surf.normal(1));
        let f = &m.frames[0];
        set3(&mut self.fr[0], k, f.s);
        set3(&mut self.fr[1], k, f.t);
        set3(&mut self.fr[2], k, f.n);
        for j in 0..e.len().min(ENTRIES) {
            self.w[j][k] = e.w[j];
            set3(&mut self.a[j], k, e.a[j]);
            self.has[j][k] = 1.0;
        }
    }
}

impl Mirror8 {
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn new() -> Self {
        Mirror8 {
            wo: [[0.0; 8], [0.0; 8], [1.0; 8]],
            ks: [-1.0; 8],
            kf: [[0.0; 8]; 3],
            kp: [0.0; 8],
            on: [0.0; 8],
            used: 0,
        }
    }

    /// A sampling query from columns: the lanes `live` (bit k: lane k, a point of the
    /// [`Points8`] it is evaluated over) toward lane k of `wo` (z > 0; by component), and the
    /// lanes `known` among them with the known term of the nested sample that drew them
    /// (path `ks[k]` = 2 j + wall, the sample's density `pdf[k]` and weight `w[..][k]`):
    /// `known_term`'s, kept where the density is finite and positive, its value the weight
    /// times the density per channel. What `Self::push` of each live lane with
    /// `known_term`'s `Option` gives, for the 8 lanes from their columns.
    /// 8-wide when the CPU has AVX2 and FMA (selects by the lanes' bits, the products `w · pdf`
    /// per lane: the same numbers), else lane by lane (`Cols::LOOPS`: the tests' reference).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn sampled(
        cols: Cols,
        live: u8,
        wo: &[[f32; 8]; 3],
        known: u8,
        ks: &[f32; 8],
        pdf: &[f32; 8],
        w: &[[f32; 8]; 3],
    ) -> Self {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = cols.avx() {
            return avx.run(
                #[inline(always)]
                || {
                    let mut m = Self::new();
                    let (zero, one) = (avx.splat(0.0), avx.splat(1.0));
                    let on = avx.mask_bits(u32::from(live));
                    let p = avx.load(pdf);
                    let kn = avx.mask_bits(u32::from(known)) & p.is_finite() & p.gt(zero);
                    let dflt = l3_8(avx, &m.wo);
                    s3_8(V3::select(on, l3_8(avx, wo), dflt), &mut m.wo);
                    let kf = l3_8(avx, w).scale(p);
                    s3_8(V3::select(kn, kf, V3::new(zero, zero, zero)), &mut m.kf);
                    F32x8::select(kn, avx.load(ks), avx.splat(-1.0)).store(&mut m.ks);
                    F32x8::select(kn, p, zero).store(&mut m.kp);
                    F32x8::select(on, one, zero).store(&mut m.on);
                    m.used = live;
                    m
                },
            );
        }
        let mut m = Self::new();
        for k in 0..8 {
            let on = live & (1 << k) != 0;
            let p = pdf[k];
            let kn = known & (1 << k) != 0 && p.is_finite() && p > 0.0;
            for c in 0..3 {
                m.wo[c][k] = if on { wo[c][k] } else { m.wo[c][k] };
                m.kf[c][k] = if kn { w[c][k] * p } else { 0.0 };
            }
            m.ks[k] = if kn { ks[k] } else { -1.0 };
            m.kp[k] = if kn { p } else { 0.0 };
            m.on[k] = if on { 1.0 } else { 0.0 };
        }
        m.used = live;
        m
    }

    /// Lane `k` (a point of the [`Points8`] this query is evaluated over) toward `wo`
    /// (z > 0), with the drawn path's `known` term (the tests' queries; the queries of
    /// `super` come from columns, [`Self::sampled`]).
    #[cfg(test)]
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn push(
        &mut self,
        k: usize,
        wo: Vec3,
        known: Option<Known>,
    ) {
        set3(&mut self.wo, k, wo);
        if let Some(kn) = known {
            self.ks[k] = (2 * kn.j + usize::from(kn.wall)) as f32;
            set3(&mut self.kf, k, kn.f);
            self.kp[k] = kn.p;
        }
        self.on[k] = 1.0;
        self.used |= 1 << k;
    }

    /// The first order of every pushed lane, its nested paths through `nested`'s lane form (the
    /// points' shared nested BSDF, a kind with one).
    #[inline(always)]
    pub(in crate::bsdf::mnm::compensated) fn eval(
        &self,
        cols: Cols,
        pts: &Points8,
        nested: Nested,
    ) -> FirstOrders {
        match nested {
            Nested::Diffuse(d) => self.eval_with(cols, pts, d),
            Nested::Conductor(c) => self.eval_with(cols, pts, c),
            Nested::Plastic(p) => self.eval_with(cols, pts, p),
            Nested::Other(_) => unreachable!("a point's nested BSDF has a lane form"),
        }
    }

    /// 8-wide when the CPU has AVX2 and FMA, else lane by lane at width 1 (the same numbers).
    #[inline(always)]
    fn eval_with<B: LaneNested>(&self, cols: Cols, pts: &Points8, b: &B) -> FirstOrders {
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = cols.avx() {
            return self.eval8(avx, pts, b, false);
        }
        self.eval_width1(pts, b)
    }

    /// [`Self::eval_with`] 8-wide: the paths' nested evaluations packed where that saves a call
    /// ([`pack::evals`]; always when `always_pack`, the tests' check of the packed form), else
    /// path by path.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn eval8<B: LaneNested>(
        &self,
        avx: Avx2,
        pts: &Points8,
        b: &B,
        always_pack: bool,
    ) -> FirstOrders {
        avx.run(
            #[inline(always)]
            || {
                let q = self.load8(avx, pts);
                let x = exits(&q);
                let pm = path_masks(&q, &x);
                let ev = match pack::evals(avx, b, &q, &x, &pm, always_pack) {
                    Some(ev) => ev,
                    None => evals_by_path(b, &q, &x, &pm),
                };
                let (f, p) = sum(&q, &x, &pm, &ev);
                let mut out = FirstOrders::zero();
                f.x.store(&mut out.f[0]);
                f.y.store(&mut out.f[1]);
                f.z.store(&mut out.f[2]);
                p.store(&mut out.p);
                out
            },
        )
    }

    /// [`Self::eval_with`] lane by lane at width 1.
    #[inline(always)]
    fn eval_width1<B: LaneNested>(&self, pts: &Points8, b: &B) -> FirstOrders {
        let mut out = FirstOrders::zero();
        for k in 0..8 {
            if self.used & (1 << k) == 0 {
                continue;
            }
            let (f, p) = first::<f32, B>(b, &self.load1(pts, k));
            set3(&mut out.f, k, f.into());
            out.p[k] = p;
        }
        out
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn load8(&self, avx: Avx2, p: &Points8) -> Lanes<F32x8> {
        // The entries of the lanes this query does not use are off (min with 0): their paths
        // are not evaluated for nothing.
        let on = avx.load(&self.on);
        let (v0, v1, n1, fr) = p.geometry8(avx);
        Lanes {
            v0,
            v1,
            n1,
            fr,
            w: [avx.load(&p.w[0]), avx.load(&p.w[1])],
            a: [l3_8(avx, &p.a[0]), l3_8(avx, &p.a[1])],
            has: [avx.load(&p.has[0]).min(on), avx.load(&p.has[1]).min(on)],
            wo: l3_8(avx, &self.wo),
            ks: avx.load(&self.ks),
            kf: l3_8(avx, &self.kf),
            kp: avx.load(&self.kp),
        }
    }

    #[inline(always)]
    fn load1(&self, p: &Points8, k: usize) -> Lanes<f32> {
        let (v0, v1, n1, fr) = p.geometry1(k);
        Lanes {
            v0,
            v1,
            n1,
            fr,
            w: [p.w[0][k], p.w[1][k]],
            a: [l3_1(&p.a[0], k), l3_1(&p.a[1], k)],
            has: [p.has[0][k].min(self.on[k]), p.has[1][k].min(self.on[k])],
            wo: l3_1(&self.wo, k),
            ks: self.ks[k],
            kf: l3_1(&self.kf, k),
            kp: self.kp[k],
        }
    }
}

/// [`entries`]' results, by lane: slot 0 the direct entry (or the wall's where there is no
/// direct one), slot 1 the wall's after a direct one; 1 where each slot exists; 1 where slot 0
/// is the wall's, and where a wall entry exists.
struct EntryLanes<L: Lane> {
    w: [L; ENTRIES],
    a: [V3<L>; ENTRIES],
    has: [L; ENTRIES],
    wall0: L,
    wall: L,
}

/// `Entries::new` over the mirror sawtooth in its operations and order, lane by lane: λ_k(ωi)
/// = a_k / Σ (`Microsurface::lambdas`: a_k = max(⟨ωi, v_k⟩, 0), Σ their sum, 0 where Σ ≤ 0);
/// the direct entry (facet 0 from ωi, weight λ0) where λ0 > 0, then the wall's (facet 0 from
/// R(ωi) = ωi − (2 ⟨ωi, ωt⟩) ωt, weight λ1) where λ1 > 0 and ⟨ωi, ωt⟩ > 0, compacted as the
/// scalar pushes them (no direct entry: the wall's is slot 0).
#[inline(always)]
fn entries<L: Lane>(
    v0: V3<L>,
    v1: V3<L>,
    n1: V3<L>,
    fr: &LaneFrame<L>,
    wi: V3<L>,
) -> EntryLanes<L> {
    let like = wi.z;
    let (zero, one) = (like.splat(0.0), like.splat(1.0));
    let (a0, a1) = (wi.dot(v0).max(zero), wi.dot(v1).max(zero));
    // Σ summed from 0 as `Microsurface::sigma` (Σ > 0 tests the same either way).
    let s = zero + a0 + a1;
    let pos = s.gt(zero);
    let l0 = L::select(pos, a0 / s, zero);
    let l1 = L::select(pos, a1 / s, zero);
    let d = wi.dot(n1);
    let direct = l0.gt(zero);
    let wall = l1.gt(zero) & d.gt(zero);
    let ad = fr.to_local(wi);
    let at = fr.to_local(wi - n1.scale(like.splat(2.0) * d));
    let zero3 = V3::new(zero, zero, zero);
    EntryLanes {
        w: [
            L::select(direct, l0, L::select(wall, l1, zero)),
            L::select(direct & wall, l1, zero),
        ],
        a: [
            V3::select(direct, ad, V3::select(wall, at, zero3)),
            V3::select(direct & wall, at, zero3),
        ],
        has: [
            L::select(direct | wall, one, zero),
            L::select(direct & wall, one, zero),
        ],
        wall0: L::select(!direct & wall, one, zero),
        wall: L::select(wall, one, zero),
    }
}

/// [`Mirror8`] loaded into lanes.
struct Lanes<L: Lane> {
    v0: V3<L>,
    v1: V3<L>,
    n1: V3<L>,
    fr: LaneFrame<L>,
    w: [L; ENTRIES],
    a: [V3<L>; ENTRIES],
    has: [L; ENTRIES],
    wo: V3<L>,
    ks: L,
    kf: V3<L>,
    kp: L,
}

/// `Microsurface::g1` of the two-facet microsurface (area vectors `v0`, `v1`) toward `w`, in
/// its operations and order: the facing facets' ⟨ω, v_k⟩ summed from 0, 1 when every facet
/// faces ω or the sum is not positive, else min(1, z / Σ); 0 below the surface.
#[inline(always)]
fn g1<L: Lane>(v0: V3<L>, v1: V3<L>, w: V3<L>) -> L {
    let like = w.z;
    let (zero, one) = (like.splat(0.0), like.splat(1.0));
    let (a0, a1) = (w.dot(v0), w.dot(v1));
    let (f0, f1) = (a0.ge(zero), a1.ge(zero));
    let s0 = L::select(f0, zero + a0, zero);
    let s = L::select(f1, s0 + a1, s0);
    let open = (f0 & f1) | s.le(zero);
    let g = L::select(open, one, (w.z / s).min(one));
    L::select(w.z.le(zero), zero, g)
}

/// The nested (f·|cos θo|, pdf) of the pairs (a, o) as the scalar path's batch evaluates them:
/// `eval_pdf_lanes` (here `eval_pdf_dirs` from the query's terms `s` and the directions' `da`,
/// `dout`: the same bits), and for the density-only lanes `po` of a kind with its own `pdf`,
/// `pdf_lanes`' density.
#[inline(always)]
fn nested<L: Lane, B: LaneNested>(
    b: &B,
    s: &B::Shared<L>,
    (a, da): (V3<L>, &B::Dir<L>),
    (o, dout): (V3<L>, &B::Dir<L>),
    po: L::Mask,
) -> (V3<L>, L) {
    let (f, p) = b.eval_pdf_dirs(s, a, da, o, dout);
    if B::SEPARATE_PDF && po.any() {
        (f, L::select(po, b.pdf_lanes(a, o), p))
    } else {
        (f, p)
    }
}

/// `b.dir(s, v)`, computed into `slot` the first time it is asked for (a direction's terms
/// serve up to two of the query's four evaluations: each entry's two paths, and each exit's
/// two entries).
#[inline(always)]
fn dir_once<L: Lane, B: LaneNested>(
    b: &B,
    s: &B::Shared<L>,
    slot: &mut Option<B::Dir<L>>,
    v: V3<L>,
) -> B::Dir<L> {
    match *slot {
        Some(d) => d,
        None => {
            let d = b.dir(s, v);
            *slot = Some(d);
            d
        }
    }
}

/// What the four paths of a query share, by lane: G1(ωo) (and where it is not positive, the
/// density-only lanes), ωo in the facet frame, the wall exit (R(ωo) in the facet frame, its
/// weight 1 − G1(R(ωo)), and where the wall lets ωo out).
struct Exits<L: Lane> {
    g1o: L,
    pdf_only: L::Mask,
    bo: V3<L>,
    rb: V3<L>,
    bt: L,
    exit: L::Mask,
}

/// [`Exits`] of every lane, in `Collected::new`'s operations.
#[inline(always)]
fn exits<L: Lane>(q: &Lanes<L>) -> Exits<L> {
    let like = q.wo.z;
    let zero = like.splat(0.0);
    let g1o = g1(q.v0, q.v1, q.wo);
    let pdf_only = g1o.le(zero);
    let bo = q.fr.to_local(q.wo);
    // The wall exit (`wall_exit`): R(ωo) = ωo − (2 ⟨ωo, ωt⟩) ωt where ωo faces the wall, and
    // 1 − G1(R(ωo)) > 0.
    let d = q.wo.dot(q.n1);
    let rwo = q.wo - q.n1.scale(like.splat(2.0) * d);
    let bt = like.splat(1.0) - g1(q.v0, q.v1, rwo);
    let exit = d.gt(zero) & bt.gt(zero);
    let rb = q.fr.to_local(rwo);
    Exits {
        g1o,
        pdf_only,
        bo,
        rb,
        bt,
        exit,
    }
}

/// Each path's lanes, by slot `2 j + wall` (computed once per query, for the evaluations and
/// the sums): those whose sum takes the path (entry j exists, and for the wall's path the wall
/// lets ωo out), and those among all whose term is the sample record's.
type PathMasks<L> = [(<L as Lane>::Mask, <L as Lane>::Mask); 2 * ENTRIES];

/// [`PathMasks`] of every lane.
#[inline(always)]
fn path_masks<L: Lane>(q: &Lanes<L>, x: &Exits<L>) -> PathMasks<L> {
    let like = q.wo.z;
    let zero = like.splat(0.0);
    let none = zero.lt(zero);
    let mut out = [(none, none); 2 * ENTRIES];
    for j in 0..ENTRIES {
        let has = q.has[j].gt(zero);
        for wall in 0..2 {
            let on = if wall == 0 { has } else { has & x.exit };
            let known = q.ks.eq(like.splat((2 * j + wall) as f32));
            out[2 * j + wall] = (on, known);
        }
    }
    out
}

/// The nested (f·|cos θo|, pdf) of the four paths by slot `2 j + wall`, each read only in its
/// lanes that evaluate (`on & !known` of [`PathMasks`]).
type Evals<L> = [(V3<L>, L); 2 * ENTRIES];

/// [`Evals`] path by path: one call of the nested BSDF's lane form for each path that a lane
/// needs (none for the others), a direction's terms computed once for the two paths that
/// share it.
#[inline(always)]
fn evals_by_path<L: Lane, B: LaneNested>(
    b: &B,
    q: &Lanes<L>,
    x: &Exits<L>,
    pm: &PathMasks<L>,
) -> Evals<L> {
    let like = q.wo.z;
    let zero = like.splat(0.0);
    let zero3 = V3::new(zero, zero, zero);
    let s = b.shared(like);
    // The exits' terms ([p] toward bo, [t,p] toward rb), each computed when first needed.
    let mut dout: [Option<B::Dir<L>>; 2] = [None, None];
    let mut out = [(zero3, zero); 2 * ENTRIES];
    for j in 0..ENTRIES {
        let mut da: Option<B::Dir<L>> = None;
        // Path [p] (slot 2j), then [t,p] (slot 2j + 1) where the wall lets ωo out.
        for (wall, dout) in dout.iter_mut().enumerate() {
            let (on, known) = pm[2 * j + wall];
            if (on & !known).any() {
                let o = if wall == 0 { x.bo } else { x.rb };
                let di = dir_once(b, &s, &mut da, q.a[j]);
                let dw = dir_once(b, &s, dout, o);
                out[2 * j + wall] = nested(b, &s, (q.a[j], &di), (o, &dw), x.pdf_only);
            }
        }
    }
    out
}

/// `Collected::sum::<false>`'s sums over the mirror sawtooth, lane by lane in its order: each
/// path's term (the known one where the path is the sample record's, 0 for f where only the
/// density is needed) weighted and added where the lane takes the path.
#[inline(always)]
fn sum<L: Lane>(q: &Lanes<L>, x: &Exits<L>, pm: &PathMasks<L>, ev: &Evals<L>) -> (V3<L>, L) {
    let like = q.wo.z;
    let zero = like.splat(0.0);
    let zero3 = V3::new(zero, zero, zero);
    let mut v = zero3;
    let mut p = zero;
    for j in 0..ENTRIES {
        let w = q.w[j];
        for wall in 0..2 {
            let (on, known) = pm[2 * j + wall];
            let (fe, pe) = ev[2 * j + wall];
            let f = V3::select(known, q.kf, V3::select(x.pdf_only, zero3, fe));
            let pd = L::select(known, q.kp, pe);
            let (wf, wp) = if wall == 0 {
                (w, w * x.g1o)
            } else {
                (w * x.bt, w * x.bt)
            };
            v = V3::select(on, v + f.scale(wf), v);
            p = L::select(on, p + wp * pd, p);
        }
    }
    (v.scale(x.g1o), p)
}

/// The first order (f1·z(ωo), p1) of every lane: `Collected::new` and `Collected::sum::<false>`
/// over the mirror sawtooth, lane by lane in their operations and order. The nested BSDF's
/// terms that do not change within the query (its parameters, a conductor's Fresnel terms) are
/// computed once, and those of each direction (a conductor's G1 toward its own normal) once
/// for the two evaluations that share it (`LaneNested::eval_pdf_dirs`: the same bits).
#[inline(always)]
fn first<L: Lane, B: LaneNested>(b: &B, q: &Lanes<L>) -> (V3<L>, L) {
    let x = exits(q);
    let pm = path_masks(q, &x);
    let ev = evals_by_path(b, q, &x, &pm);
    sum(q, &x, &pm, &ev)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::lanes::testing::{direction, same, same3};
    use crate::math::Pcg32;

    /// The entries in lanes ([`Points8::entries`], 8-wide, and lane by lane at width 1)
    /// equal `Entries::new` bit for bit, lane by lane: random mirror-sawtooth microsurfaces,
    /// ωi above the surface (some grazing: through the wall alone, or no entry).
    #[test]
    fn entries_in_lanes_equal_the_scalar_ones() {
        let mut rng = Pcg32::new(16, 7);
        let (mut compared, mut wall_only) = (0, 0);
        let mut picks = [0; 2];
        for round in 0..500 {
            let (mut wide, mut one) = (Points8::new(), Points8::new());
            let mut want = [None; 8];
            for (k, want) in want.iter_mut().enumerate() {
                let wp = direction(&mut rng);
                let wp = Vec3::new(wp.x, wp.y, wp.z.abs().max(0.05)).normalize();
                let m = MicrofacetNormalMap::new(
                    0,
                    wp,
                    crate::bsdf::mnm::facets::Microgeometry::Sawtooth,
                    crate::bsdf::mnm::Tangent::Mirror,
                    crate::bsdf::mnm::Evaluation::Compensated,
                    256,
                );
                if !m.mirror_wall || rng.next_f32() < 0.1 {
                    continue;
                }
                let wi = direction(&mut rng);
                let z = if rng.next_f32() < 0.3 { 0.02 } else { 1.0 };
                let wi = Vec3::new(wi.x, wi.y, z * wi.z.abs().max(1e-3)).normalize();
                wide.push_point(k, &m, wi);
                one.push_point(k, &m, wi);
                *want = Some(Entries::new(&m, wi));
            }
            wide.entries(Cols::detect());
            one.entries_width1();
            for (k, w) in want.iter().enumerate() {
                let Some(w) = w else { continue };
                let w = format!("{w:?}");
                assert_eq!(format!("{:?}", wide.entries_of(k)), w, "{round} {k}");
                assert_eq!(format!("{:?}", one.entries_of(k)), w, "{round} {k}");
                // The sampler's pick and direction from the columns: `pick_entry`'s over
                // the entries, for random numbers and each entry's edge (the weight itself,
                // its neighbours), 0, 1 and NaN.
                let e = wide.entries_of(k);
                let w0 = if e.len() > 0 { e.w[0] } else { 0.5 };
                for x in [
                    rng.next_f32(),
                    0.0,
                    1.0,
                    w0,
                    f32::from_bits(w0.to_bits().wrapping_add(1)),
                    f32::from_bits(w0.to_bits().wrapping_sub(1)),
                    f32::NAN,
                ] {
                    let want = super::super::super::pick_entry(&e, x);
                    assert_eq!(wide.pick(k, x), want, "{round} {k} {x}");
                    if let Some(j) = want {
                        assert!(same3(wide.entry_dir(k, j), e.a[j]), "{round} {k}");
                        picks[j] += 1;
                    }
                }
                compared += 1;
                wall_only += usize::from(w.contains("n: 1, via_wall: 1"));
            }
        }
        assert!(
            compared > 2500 && wall_only > 20 && picks[0] > 5000 && picks[1] > 1000,
            "{compared} lanes, {wall_only} through the wall alone, {picks:?} picks"
        );
    }

    /// `leave` from the numbers in lanes ([`Points8::leave_dirs`], 8-wide on this machine and
    /// at width 1, then `leave_mirror`) equals the scalar `leave` over the lane's microsurface
    /// (`Lane8`, the map's numbers) bit for bit, and leaves each sampler where it does: random
    /// mirror-sawtooth microsurfaces, nested samples' directions over both hemispheres (some
    /// grazing, non-unit) mixed with ±0, subnormals, huge values, ±∞ and NaN components,
    /// densities with the same edges (no known term where not finite and positive).
    #[test]
    fn leave_in_lanes_equals_the_scalar_one() {
        use super::super::super::{leave, leave_mirror};
        use crate::sampler::Sampler;
        const EDGES: [f32; 10] = [
            0.0,
            -0.0,
            1e-40,
            -1e-40,
            1.0,
            1e30,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let mut rng = Pcg32::new(22, 9);
        let (mut compared, mut walls) = (0, 0);
        for round in 0..1500 {
            let mut pts = Points8::new();
            for k in 0..8 {
                let wp = direction(&mut rng);
                let wp = Vec3::new(wp.x, wp.y, wp.z.abs().max(0.05)).normalize();
                let m = MicrofacetNormalMap::new(
                    0,
                    wp,
                    crate::bsdf::mnm::facets::Microgeometry::Sawtooth,
                    crate::bsdf::mnm::Tangent::Mirror,
                    crate::bsdf::mnm::Evaluation::Compensated,
                    256,
                );
                if !m.mirror_wall || rng.next_f32() < 0.1 {
                    continue;
                }
                let wi = direction(&mut rng);
                pts.push_point(k, &m, Vec3::new(wi.x, wi.y, wi.z.abs().max(1e-3)));
            }
            pts.clear_unpushed();
            let mut wo = [[0.0f32; 8]; 3];
            let mut sampled = [(Vec3::ZERO, 0.0f32, Vec3::ZERO); 8];
            for (k, smp) in sampled.iter_mut().enumerate() {
                let mut d = direction(&mut rng);
                for c in 0..3 {
                    if rng.next_f32() < 0.04 {
                        d[c] = EDGES[rng.next_u32() as usize % EDGES.len()];
                    }
                }
                let pdf = if rng.next_f32() < 0.1 {
                    EDGES[rng.next_u32() as usize % EDGES.len()]
                } else {
                    4.0 * rng.next_f32()
                };
                let w = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                set3(&mut wo, k, d);
                *smp = (d, pdf, w);
            }
            let (wide, one) = (
                pts.leave_dirs(Cols::detect(), &wo),
                pts.leave_dirs_width1(&wo),
            );
            for (k, &smp) in sampled.iter().enumerate() {
                if pts.pushed & (1 << k) == 0 {
                    continue;
                }
                let j = (rng.next_u32() % 2) as usize;
                let seed = u64::from(rng.next_u32());
                let mut s = Sampler::from_seed(seed, 3);
                let (want_wo, want_known) = leave(&pts.lane(k), 0, j, smp, &mut s);
                let want_next = s.next_1d();
                for l in [&wide, &one] {
                    let mut s = Sampler::from_seed(seed, 3);
                    let (u, g, r) = l.get(k);
                    let (got_wo, got_known) = leave_mirror(u, g, || r, j, (smp.1, smp.2), &mut s);
                    assert!(same3(got_wo, want_wo), "{round} {k}: {got_wo} {want_wo}");
                    // Debug prints each f32 as its shortest round-trip form.
                    assert_eq!(
                        format!("{got_known:?}"),
                        format!("{want_known:?}"),
                        "{round} {k}"
                    );
                    assert!(same(s.next_1d(), want_next), "{round} {k}");
                }
                compared += 1;
                walls += usize::from(want_known.is_some_and(|kn| kn.wall));
            }
        }
        assert!(
            compared > 5000 && walls > 200,
            "{compared} lanes, {walls} through the wall"
        );
    }

    /// The entry picks in lanes ([`Points8::pick8`]) equal [`Points8::pick`] and
    /// [`Points8::entry_dir`] lane by lane: slots present or not (1, 0, −0, NaN), weights and
    /// numbers with ±0, subnormals, ±∞, NaN, and numbers equal to the weight.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn picks_in_lanes_equal_the_scalar_ones() {
        let Some(avx) = Avx2::detect() else { return };
        const EDGES: [f32; 9] = [
            0.0,
            -0.0,
            1e-40,
            1.0,
            0.5,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            -1.0,
        ];
        let mut rng = Pcg32::new(28, 2);
        let num = |rng: &mut Pcg32| {
            if rng.next_f32() < 0.3 {
                EDGES[rng.next_u32() as usize % EDGES.len()]
            } else {
                rng.next_f32()
            }
        };
        let (mut seconds, mut nones) = (0, 0);
        for _ in 0..4000 {
            let mut p = Points8::new();
            let mut x = [0.0f32; 8];
            for (k, xk) in x.iter_mut().enumerate() {
                for j in 0..ENTRIES {
                    p.has[j][k] = [1.0, 0.0, -0.0, f32::NAN][rng.next_u32() as usize % 4];
                    p.w[j][k] = num(&mut rng);
                    for c in 0..3 {
                        p.a[j][c][k] = num(&mut rng);
                    }
                }
                *xk = if rng.next_f32() < 0.2 {
                    p.w[0][k]
                } else {
                    num(&mut rng)
                };
            }
            let (some, second, a) = avx.run(|| {
                let (some, second, a) = p.pick8(avx, avx.load(&x));
                let mut out = [[0.0f32; 8]; 3];
                s3_8(a, &mut out);
                (some.bits(), second.bits(), out)
            });
            for k in 0..8 {
                let want = p.pick(k, x[k]);
                assert_eq!(some >> k & 1 == 1, want.is_some(), "{k} {x:?}");
                let Some(j) = want else {
                    nones += 1;
                    continue;
                };
                assert_eq!(second >> k & 1 == 1, j == 1, "{k} {x:?}");
                seconds += usize::from(j == 1);
                let got = Vec3::new(a[0][k], a[1][k], a[2][k]);
                assert!(same3(got, p.entry_dir(k, j)), "{k}");
            }
        }
        assert!(
            seconds > 4000 && nones > 4000,
            "{seconds} second slots, {nones} none"
        );
    }

    /// A sampling query's inputs from columns ([`Mirror8::sampled`], 8-wide on this machine)
    /// equal the lane-by-lane form bit for bit (NaNs as NaNs), every column and the mask: random
    /// live and known lanes, densities and weights with ±0, subnormals, huge values, ±∞ and NaN
    /// (a known term only where the density is finite and positive).
    #[test]
    fn sampled_query_in_lanes_equals_the_loop() {
        const EDGES: [f32; 10] = [
            0.0,
            -0.0,
            1e-40,
            -1e-40,
            1.0,
            -1.0,
            f32::MAX,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        fn num(rng: &mut Pcg32) -> f32 {
            if rng.next_f32() < 0.25 {
                EDGES[rng.next_u32() as usize % EDGES.len()]
            } else {
                4.0 * rng.next_f32() - 1.0
            }
        }
        fn col(rng: &mut Pcg32) -> [f32; 8] {
            std::array::from_fn(|_| num(rng))
        }
        let mut rng = Pcg32::new(26, 11);
        let mut kept = 0;
        for round in 0..3000 {
            let (live, known) = (rng.next_u32() as u8, rng.next_u32() as u8);
            let wo = [col(&mut rng), col(&mut rng), col(&mut rng)];
            let w = [col(&mut rng), col(&mut rng), col(&mut rng)];
            let ks = std::array::from_fn(|_| (rng.next_u32() % 4) as f32);
            let pdf = col(&mut rng);
            let (a, b) = (
                Mirror8::sampled(Cols::detect(), live, &wo, known, &ks, &pdf, &w),
                Mirror8::sampled(Cols::LOOPS, live, &wo, known, &ks, &pdf, &w),
            );
            assert_eq!(a.used, b.used, "{round}");
            for k in 0..8 {
                for c in 0..3 {
                    assert!(same(a.wo[c][k], b.wo[c][k]), "{round} {k} {c}");
                    assert!(same(a.kf[c][k], b.kf[c][k]), "{round} {k} {c}");
                }
                assert!(same(a.ks[k], b.ks[k]), "{round} {k}");
                assert!(same(a.kp[k], b.kp[k]), "{round} {k}");
                assert!(same(a.on[k], b.on[k]), "{round} {k}");
                kept += usize::from(b.ks[k] >= 0.0);
            }
        }
        assert!(kept > 3000, "{kept} known terms kept");
    }

    /// The 8-wide first order equals the width-1 one lane by lane, bit for bit, on random
    /// inputs (the scalar model is checked against the 8-wide one by `super::super::tests`):
    /// the model's rough conductors and rough plastic, random microsurfaces, frames, entries
    /// (0, 1 or 2), ωo over both hemispheres and known terms on every path.
    #[test]
    fn width_8_equals_width_1() {
        let mut rng = Pcg32::new(15, 2);
        let mut arena = crate::bsdf::BsdfArena::new();
        let nested = super::super::super::tests::push_reflectors(&mut arena);
        let (mut compared, mut multi, mut spans) = (0, 0, 0);
        for round in 0..600 {
            let b = arena.bsdf(nested[round % 3]);
            let kind = Nested::of(&b);
            let mut pts = Points8::new();
            let mut q = Mirror8::new();
            for k in 0..8 {
                if rng.next_f32() < 0.15 {
                    continue;
                }
                let wp = direction(&mut rng);
                let wp = Vec3::new(wp.x, wp.y, wp.z.abs().max(0.05)).normalize();
                let m = MicrofacetNormalMap::new(
                    0,
                    wp,
                    crate::bsdf::mnm::facets::Microgeometry::Sawtooth,
                    crate::bsdf::mnm::Tangent::Mirror,
                    crate::bsdf::mnm::Evaluation::Compensated,
                    256,
                );
                if !m.mirror_wall {
                    continue;
                }
                let wi = direction(&mut rng);
                let e = Entries::new(&m, Vec3::new(wi.x, wi.y, wi.z.abs()));
                let known = (rng.next_f32() < 0.5).then(|| Known {
                    j: (rng.next_u32() % 2) as usize,
                    wall: rng.next_f32() < 0.5,
                    f: Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()),
                    p: rng.next_f32(),
                });
                pts.push(k, &m, &e);
                // Some points of the chunk are not part of the query.
                if rng.next_f32() < 0.9 {
                    q.push(k, direction(&mut rng), known);
                }
            }
            let wide = q.eval(Cols::detect(), &pts, kind);
            let one = match kind {
                Nested::Diffuse(d) => q.eval_width1(&pts, d),
                Nested::Conductor(c) => q.eval_width1(&pts, c),
                Nested::Plastic(p) => q.eval_width1(&pts, p),
                Nested::Other(_) => unreachable!(),
            };
            // The packed form on every query (8-wide only).
            #[cfg(target_arch = "x86_64")]
            let packed = crate::lane::Avx2::detect().map(|avx| match kind {
                Nested::Diffuse(d) => q.eval8(avx, &pts, d, true),
                Nested::Conductor(c) => q.eval8(avx, &pts, c, true),
                Nested::Plastic(p) => q.eval8(avx, &pts, p, true),
                Nested::Other(_) => unreachable!(),
            });
            #[cfg(not(target_arch = "x86_64"))]
            let packed: Option<FirstOrders> = None;
            // How the packed form was exercised: queries of more than one call, and paths
            // whose slots span two calls (their results blended from both).
            #[cfg(target_arch = "x86_64")]
            if let Some(avx) = crate::lane::Avx2::detect() {
                let (pairs, spanning) = avx.run(|| {
                    let ql = q.load8(avx, &pts);
                    let pm = path_masks(&ql, &exits(&ql));
                    let (mut start, mut spanning) = (0, 0);
                    for (on, known) in pm {
                        let n = (on & !known).bits();
                        spanning += usize::from(start % 8 + n.count_ones() > 8);
                        start += n.count_ones();
                    }
                    (start, spanning)
                });
                multi += usize::from(pairs > 8);
                spans += spanning;
            }
            for k in (0..8).filter(|&k| q.used & (1 << k) != 0) {
                let ((f8, p8), (f1, p1)) = (wide.get(k), one.get(k));
                assert!(same3(f8, f1) && same(p8, p1), "{round} {k}");
                if let Some(pk) = &packed {
                    let (fp, pp) = pk.get(k);
                    assert!(same3(fp, f1) && same(pp, p1), "packed: {round} {k}");
                }
                compared += 1;
            }
        }
        assert!(compared > 3000, "{compared} lanes");
        #[cfg(target_arch = "x86_64")]
        if crate::lane::Avx2::detect().is_some() {
            assert!(
                multi > 100 && spans > 50,
                "{multi} queries of several calls, {spans} paths over two calls"
            );
        }
    }
}
