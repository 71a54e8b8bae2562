//! Robust ray origins in lanes: `geometry::ray::offset_origin` (Wächter & Binder 2019, Ray
//! Tracing Gems ch. 6) written over [`Lane`], the same operations in the same order, so every
//! lane equals the scalar function bit for bit (tested below, non-finite normals included).

#[cfg(target_arch = "x86_64")]
use crate::integrator::path::PathState;
use crate::lane::vec::V3;
use crate::lane::{Lane, LaneI32};
#[cfg(target_arch = "x86_64")]
use crate::stream::batch::PendingAdd;
#[cfg(target_arch = "x86_64")]
use crate::stream::kernels::light::x8::Cols3;

/// Moves `p` off the surface with geometric normal `n` to the side `dir` points to (see
/// `geometry::ray::offset_origin`).
#[inline(always)]
pub(crate) fn offset_origin<L: Lane>(p: V3<L>, n: V3<L>, dir: V3<L>) -> V3<L> {
    let flip = n.dot(dir).lt(p.x.splat(0.0));
    let n = V3::select(flip, -n, n);
    V3::new(offset_1(p.x, n.x), offset_1(p.y, n.y), offset_1(p.z, n.z))
}

/// The two origins [`offset_origin`] can give for one point `p` and normal `n`: moved along
/// `n` or along `−n`, whichever side a direction points to. A vertex spawns up to three rays
/// from its point (the light sample's toward a point and toward a direction at infinity, and
/// the BSDF sample's); their offsets differ only in that side, so both candidates are computed
/// once and each ray picks one ([`Offsets::toward`]): the same values as [`offset_origin`],
/// lane by lane (`offset_1` is per lane, so offsetting by the selected normal is selecting
/// between the offsets by either normal).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Offsets<L: Lane> {
    n: V3<L>,
    along: V3<L>,
    against: V3<L>,
}

impl<L: Lane> Offsets<L> {
    #[inline(always)]
    pub(crate) fn new(p: V3<L>, n: V3<L>) -> Self {
        let m = -n;
        Offsets {
            n,
            along: V3::new(offset_1(p.x, n.x), offset_1(p.y, n.y), offset_1(p.z, n.z)),
            against: V3::new(offset_1(p.x, m.x), offset_1(p.y, m.y), offset_1(p.z, m.z)),
        }
    }

    /// [`offset_origin`]`(p, n, dir)`.
    #[inline(always)]
    pub(crate) fn toward(&self, dir: V3<L>) -> V3<L> {
        let flip = self.n.dot(dir).lt(dir.x.splat(0.0));
        V3::select(flip, self.against, self.along)
    }
}

/// Where a surface point's rays start ([`offset_origin`] toward a direction): offset per ray
/// ([`AtPoint`]) or picked from the point's two offsets made once ([`Offsets`]). The kernels'
/// shared steps (`diffuse::light_out_from`, `vertex::SampleOut::at_with`) take either.
pub(crate) trait Origin<L: Lane> {
    /// [`offset_origin`]`(p, n, dir)` of the point.
    fn toward(&self, dir: V3<L>) -> V3<L>;
}

/// A point `p` and geometric normal `n` whose rays are offset one by one.
#[derive(Clone, Copy, Debug)]
pub(crate) struct AtPoint<L: Lane> {
    pub p: V3<L>,
    pub n: V3<L>,
}

impl<L: Lane> Origin<L> for AtPoint<L> {
    #[inline(always)]
    fn toward(&self, dir: V3<L>) -> V3<L> {
        offset_origin(self.p, self.n, dir)
    }
}

impl<L: Lane> Origin<L> for Offsets<L> {
    #[inline(always)]
    fn toward(&self, dir: V3<L>) -> V3<L> {
        Offsets::toward(self, dir)
    }
}

/// One coordinate of [`offset_origin`].
#[inline(always)]
fn offset_1<L: Lane>(p: L, n: L) -> L {
    const ORIGIN: f32 = 1.0 / 32.0;
    const FLOAT_SCALE: f32 = 1.0 / 65536.0;
    const INT_SCALE: f32 = 256.0;
    let k = |c: f32| p.splat(c);
    // Rust's saturating `as i32`: NaN → 0, ≥ 2³¹ → i32::MAX (`cvttps2dq` gives i32::MIN for
    // both, and for ≤ −2³¹, which is also what `as` gives there).
    let v = k(INT_SCALE) * n;
    let t = v.trunc_i32();
    let t = L::I32::select(v.ge(k(2_147_483_648.0)), t.splat(i32::MAX), t);
    let of_i = L::I32::select(v.is_nan(), t.splat(0), t);
    let step = L::I32::select(p.lt(k(0.0)), of_i.splat(0).sub(of_i), of_i);
    let p_i = L::from_bits(p.to_bits().add(step));
    L::select(p.abs().lt(k(ORIGIN)), p + k(FLOAT_SCALE) * n, p_i)
}

/// Rays from their fields in `W` lanes, one `Ray` per lane ([`crate::lane::Avx2::ray_rows`],
/// [`crate::lane::Avx512::ray_rows16`]: a transpose and one 32-byte store per ray, moves only),
/// so a kernel writes each lane's next ray into the batch's rows as one copy rather than six
/// scalar stores (`vertex::x8::advance`).
#[cfg(target_arch = "x86_64")]
pub(crate) trait RayRows<const W: usize>: crate::lane::Wide<W> {
    /// Lane `k`'s ray: `Ray { o: (o.x, o.y, o.z)[k], d: (d.x, d.y, d.z)[k], tmin: 0, tmax }`
    /// with `tmax` splat to every lane (`Ray::new` at `f32::INFINITY`): [`Self::segment_rows`]
    /// at one length.
    #[inline(always)]
    fn ray_rows(self, o: V3<Self::F>, d: V3<Self::F>, tmax: f32) -> [crate::geometry::Ray; W] {
        self.segment_rows(o, d, self.splat(tmax))
    }
    /// Each lane's row of the 8 fields `f`: row `k` is lane `k` of `f[0]`, …, `f[7]` (the same
    /// transpose, for the rows of the path states the kernels write whole).
    fn rows8(self, f: [Self::F; 8]) -> [[f32; 8]; W];
    /// Lane `k`'s segment: `Ray::segment((o.x, o.y, o.z)[k], (d.x, d.y, d.z)[k], tmax[k])`
    /// (the same transpose; the pending light samples' shadow rays, whose lengths differ per
    /// lane).
    fn segment_rows(
        self,
        o: V3<Self::F>,
        d: V3<Self::F>,
        tmax: Self::F,
    ) -> [crate::geometry::Ray; W];
    /// The throughputs of the path states `state[ids[k]]` in lanes (every bit as stored).
    /// Lane by lane here; [`crate::lane::Avx2`] gathers them (three `vpgatherdd`).
    #[inline(always)]
    fn throughputs(self, state: &[PathState], ids: &[u32; W]) -> V3<Self::F> {
        let mut tp = Cols3::<W>::default();
        for (k, &i) in ids.iter().enumerate() {
            tp.set(k, state[i as usize].throughput);
        }
        tp.load(self)
    }
    /// The `eta` and `depth` (its bits as an `i32`) of the path states `state[ids[k]]` in
    /// lanes (every bit as stored). Lane by lane here; [`crate::lane::Avx2`] gathers them
    /// (two `vpgatherdd`).
    #[inline(always)]
    fn eta_depth(self, state: &[PathState], ids: &[u32; W]) -> (Self::F, Self::I) {
        let (mut eta, mut depth) = ([0.0f32; W], [0i32; W]);
        for (k, &i) in ids.iter().enumerate() {
            let s = &state[i as usize];
            (eta[k], depth[k]) = (s.eta, s.depth as i32);
        }
        (self.load(&eta), self.load_i32(&depth))
    }
    /// Appends the lanes of `pass` (bit `k` for lane `k`) to the batch's pending light samples:
    /// in lane order, lane `k`'s shadow ray (`Ray::segment` of `o`, `d`, `tmax`, as
    /// [`Self::segment_rows`]) to `rays` and its path `ids[k]` and contribution `c` to `adds`;
    /// returns how many. Every slot of `rays` and `adds` may be written (those past the count
    /// hold other lanes: the list's slack, which the next append overwrites). Here every lane
    /// writes its row at the end and only a passing lane advances it; [`crate::lane::Avx2`]
    /// compresses the columns first.
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    fn push_pending(
        self,
        pass: u32,
        o: V3<Self::F>,
        d: V3<Self::F>,
        tmax: Self::F,
        ids: &[u32; W],
        c: &Cols3<W>,
        rays: &mut [crate::geometry::Ray; W],
        adds: &mut [PendingAdd; W],
    ) -> usize {
        const { assert!(W.is_power_of_two()) };
        let shadow = self.segment_rows(o, d, tmax);
        let mut j = 0;
        for k in 0..W {
            // j ≤ k < W, a power of two: the mask changes nothing (and drops the bounds test).
            rays[j & (W - 1)] = shadow[k];
            adds[j & (W - 1)] = PendingAdd {
                path: ids[k],
                contribution: c.get(k),
            };
            j += (pass >> k & 1) as usize;
        }
        j
    }
}

#[cfg(target_arch = "x86_64")]
impl RayRows<8> for crate::lane::Avx2 {
    #[inline(always)]
    fn rows8(self, f: [Self::F; 8]) -> [[f32; 8]; 8] {
        crate::lane::Avx2::rows8(self, f)
    }
    #[inline(always)]
    fn segment_rows(
        self,
        o: V3<Self::F>,
        d: V3<Self::F>,
        tmax: Self::F,
    ) -> [crate::geometry::Ray; 8] {
        let z = self.splat(0.0);
        crate::lane::Avx2::ray_rows(self, [o.x, o.y, o.z, d.x, d.y, d.z, z, tmax])
    }
    #[inline(always)]
    fn throughputs(self, state: &[PathState], ids: &[u32; 8]) -> V3<Self::F> {
        let [x, y, z] = self.gather_throughput(state, self.load_u32(ids));
        V3::new(x, y, z)
    }
    #[inline(always)]
    fn eta_depth(self, state: &[PathState], ids: &[u32; 8]) -> (Self::F, Self::I) {
        let idv = self.load_u32(ids);
        (self.gather_eta(state, idv), self.gather_depth(state, idv))
    }
    /// The passing lanes first, by one permute of every column ([`crate::lane::Avx2::compress_index`]),
    /// then the rays' transpose and the adds' (rows of 4), each stored whole: no per-lane
    /// index to carry from store to store.
    #[inline(always)]
    fn push_pending(
        self,
        pass: u32,
        o: V3<Self::F>,
        d: V3<Self::F>,
        tmax: Self::F,
        ids: &[u32; 8],
        c: &Cols3<8>,
        rays: &mut [crate::geometry::Ray; 8],
        adds: &mut [PendingAdd; 8],
    ) -> usize {
        use crate::lane::F32x8;
        let (perm, kept) = self.compress_index(pass);
        let z = self.splat(0.0);
        let f = [o.x, o.y, o.z, d.x, d.y, d.z, z, tmax];
        *rays = self.ray_rows(f.map(|x| x.permute(perm)));
        let c = c.load(self);
        let path = F32x8::from_bits(self.load_u32(ids).permute(perm));
        let rows = self.rows4([
            path,
            c.x.permute(perm),
            c.y.permute(perm),
            c.z.permute(perm),
        ]);
        for (a, r) in adds.iter_mut().zip(&rows) {
            *a = PendingAdd {
                path: r[0].to_bits(),
                contribution: glam::Vec3::new(r[1], r[2], r[3]),
            };
        }
        kept
    }
}

#[cfg(target_arch = "x86_64")]
impl RayRows<16> for crate::lane::Avx512 {
    #[inline(always)]
    fn rows8(self, f: [Self::F; 8]) -> [[f32; 8]; 16] {
        self.rows8_16(f)
    }
    #[inline(always)]
    fn segment_rows(
        self,
        o: V3<Self::F>,
        d: V3<Self::F>,
        tmax: Self::F,
    ) -> [crate::geometry::Ray; 16] {
        let z = self.splat(0.0);
        self.ray_rows16([o.x, o.y, o.z, d.x, d.y, d.z, z, tmax])
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::ray::offset_origin as scalar;
    use crate::math::Pcg32;
    use glam::Vec3;

    fn same(a: Vec3, b: Vec3) -> bool {
        a.to_array()
            .iter()
            .zip(b.to_array())
            .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
    }

    /// `Avx2::push_pending` (the compress of the passing lanes) against the per-lane append it
    /// replaces, for every mask: the count, and in the first `count` slots each passing lane's
    /// `Ray::segment` and (path, contribution), in lane order, every bit (NaN payloads, ±0,
    /// ±∞ among the fields); the slots past the count are the list's slack.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn push_pending_appends_the_passing_lanes() {
        use crate::geometry::Ray;
        use crate::stream::batch::PendingAdd;
        let Some(avx) = crate::lane::Avx2::detect() else {
            eprintln!("no AVX2/FMA: the pending samples' compress test is skipped");
            return;
        };
        const EDGES: [f32; 8] = [
            0.0,
            -0.0,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            1e-40,
            -3.5,
            7.25,
        ];
        let mut r = Pcg32::new(31, 7);
        let f = |r: &mut Pcg32| match r.next_u32() % 4 {
            0 => EDGES[(r.next_u32() % 8) as usize],
            1 => f32::from_bits(r.next_u32()),
            _ => r.next_f32() * 4.0 - 2.0,
        };
        for mask in 0u32..256 {
            let cols: [[f32; 8]; 10] = std::array::from_fn(|_| std::array::from_fn(|_| f(&mut r)));
            let ids: [u32; 8] = std::array::from_fn(|_| r.next_u32());
            let c = Cols3([cols[7], cols[8], cols[9]]);
            let pad = PendingAdd {
                path: 7,
                contribution: Vec3::ONE,
            };
            let mut rays = [Ray::new(Vec3::ZERO, Vec3::Z); 8];
            let mut adds = [pad; 8];
            let n = avx.run(
                #[inline(always)]
                || {
                    let o = V3::new(avx.load(&cols[0]), avx.load(&cols[1]), avx.load(&cols[2]));
                    let d = V3::new(avx.load(&cols[3]), avx.load(&cols[4]), avx.load(&cols[5]));
                    let tmax = avx.load(&cols[6]);
                    avx.push_pending(mask, o, d, tmax, &ids, &c, &mut rays, &mut adds)
                },
            );
            let passing: Vec<usize> = (0..8).filter(|&k| mask >> k & 1 == 1).collect();
            assert_eq!(n, passing.len(), "mask {mask:#x}");
            for (j, &k) in passing.iter().enumerate() {
                let want = Ray::segment(
                    Vec3::new(cols[0][k], cols[1][k], cols[2][k]),
                    Vec3::new(cols[3][k], cols[4][k], cols[5][k]),
                    cols[6][k],
                );
                let bits = |r: &Ray| {
                    [r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.tmin, r.tmax].map(f32::to_bits)
                };
                assert_eq!(bits(&rays[j]), bits(&want), "mask {mask:#x} slot {j}: ray");
                assert_eq!(adds[j].path, ids[k], "mask {mask:#x} slot {j}: path");
                let got = adds[j].contribution.to_array().map(f32::to_bits);
                let want = [cols[7][k], cols[8][k], cols[9][k]].map(f32::to_bits);
                assert_eq!(got, want, "mask {mask:#x} slot {j}: contribution");
            }
        }
    }

    /// Random points at every scale (near the origin, where the absolute step applies, and
    /// far), unit and non-finite normals: width 1 and width 8 equal the scalar function.
    #[test]
    fn lane_offsets_equal_the_scalar_ones() {
        let mut r = Pcg32::new(5, 9);
        let mut f = |scale: f32| (r.next_f32() * 2.0 - 1.0) * scale;
        let mut cases = Vec::new();
        for i in 0..20_000 {
            let s = [1e-3, 0.03, 1.0, 40.0, 1e5][i % 5];
            let p = Vec3::new(f(s), f(s), f(s));
            let n = Vec3::new(f(1.0), f(1.0), f(1.0)).normalize();
            let d = Vec3::new(f(1.0), f(1.0), f(1.0));
            cases.push((p, n, d));
        }
        for bad in [
            f32::NAN,
            f32::INFINITY,
            -f32::INFINITY,
            1e10,
            -1e10,
            0.0,
            -0.0,
        ] {
            cases.push((
                Vec3::new(0.5, -0.01, 3.0),
                Vec3::new(bad, 0.2, -bad),
                Vec3::ONE,
            ));
            cases.push((Vec3::new(bad, -2.0, 0.0), Vec3::Y, -Vec3::ONE));
        }
        for &(p, n, d) in &cases {
            let w1: Vec3 = offset_origin(V3::from(p), V3::from(n), V3::from(d)).into();
            assert!(
                same(w1, scalar(p, n, d)),
                "{p} {n} {d}: {w1} vs {}",
                scalar(p, n, d)
            );
            let shared: Vec3 = Offsets::new(V3::from(p), V3::from(n))
                .toward(V3::from(d))
                .into();
            assert!(same(shared, scalar(p, n, d)), "{p} {n} {d}: {shared}");
        }
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = crate::lane::Avx2::detect() {
            for c in cases.chunks_exact(8) {
                let col = |g: &dyn Fn(&(Vec3, Vec3, Vec3)) -> Vec3| {
                    let v: Vec<Vec3> = c.iter().map(g).collect();
                    V3::new(
                        avx.load(&std::array::from_fn(|k| v[k].x)),
                        avx.load(&std::array::from_fn(|k| v[k].y)),
                        avx.load(&std::array::from_fn(|k| v[k].z)),
                    )
                };
                let o = avx.run(|| offset_origin(col(&|x| x.0), col(&|x| x.1), col(&|x| x.2)));
                let (p8, n8) = (col(&|x| x.0), col(&|x| x.1));
                let shared = avx.run(|| Offsets::new(p8, n8).toward(col(&|x| x.2)));
                for (k, &(p, n, d)) in c.iter().enumerate() {
                    let got = Vec3::new(o.x.lane(k), o.y.lane(k), o.z.lane(k));
                    assert!(same(got, scalar(p, n, d)), "lane {k}: {p} {n} {d}");
                    let got = Vec3::new(shared.x.lane(k), shared.y.lane(k), shared.z.lane(k));
                    assert!(same(got, scalar(p, n, d)), "shared, lane {k}: {p} {n} {d}");
                }
            }
        }
    }

    /// The rows of [`RayRows`] are `Ray::segment` of each lane's fields (with one length or
    /// each lane's: `segment_rows`), and its `rows8` each
    /// lane's 8 fields, bit for bit (moves only), at width 8 and 16: random values and ±0, subnormals, huge values, ±∞ and NaNs
    /// with payloads, in every field.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn ray_rows_are_each_lanes_ray() {
        use crate::geometry::Ray;
        use crate::lane::{Avx2, Avx512};
        fn check<T: RayRows<W>, const W: usize>(t: T, r: &mut Pcg32) {
            const EDGES: [u32; 10] = [
                0x0000_0000,
                0x8000_0000,
                0x0000_0001,
                0x807f_ffff,
                0x7f7f_ffff,
                0x7f80_0000,
                0xff80_0000,
                0x7fc0_0000,
                0x7fa0_1234,
                0xffc0_0001,
            ];
            for round in 0..200 {
                let mut v = || {
                    let u = r.next_u32();
                    f32::from_bits(if u & 3 == 0 {
                        EDGES[(u >> 8) as usize % 10]
                    } else {
                        u
                    })
                };
                let f: [[f32; W]; 6] = core::array::from_fn(|_| core::array::from_fn(|_| v()));
                let tmax = [f32::INFINITY, v()][round % 2];
                let rows = t.run(|| {
                    let c = |j: usize| t.load(&f[j]);
                    t.ray_rows(V3::new(c(0), c(1), c(2)), V3::new(c(3), c(4), c(5)), tmax)
                });
                let g: [[f32; W]; 8] =
                    core::array::from_fn(|j| if j < 6 { f[j] } else { f[j - 6] });
                let plain = t.run(|| t.rows8(g.map(|c| t.load(&c))));
                for (k, row) in plain.iter().enumerate() {
                    let want: [u32; 8] = core::array::from_fn(|j| g[j][k].to_bits());
                    assert_eq!(row.map(f32::to_bits), want, "rows8, width {W}, lane {k}");
                }
                // Per-lane lengths: the shadow rays' segments.
                let tl: [f32; W] = core::array::from_fn(|_| v());
                let segs = t.run(|| {
                    let c = |j: usize| t.load(&f[j]);
                    t.segment_rows(
                        V3::new(c(0), c(1), c(2)),
                        V3::new(c(3), c(4), c(5)),
                        t.load(&tl),
                    )
                });
                let bits = |r: &Ray| {
                    [r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.tmin, r.tmax].map(f32::to_bits)
                };
                for (k, row) in segs.iter().enumerate() {
                    let want = Ray::segment(
                        Vec3::new(f[0][k], f[1][k], f[2][k]),
                        Vec3::new(f[3][k], f[4][k], f[5][k]),
                        tl[k],
                    );
                    assert_eq!(bits(row), bits(&want), "segment, width {W}, lane {k}");
                }
                for (k, row) in rows.iter().enumerate() {
                    let want = Ray::segment(
                        Vec3::new(f[0][k], f[1][k], f[2][k]),
                        Vec3::new(f[3][k], f[4][k], f[5][k]),
                        tmax,
                    );
                    assert_eq!(bits(row), bits(&want), "width {W}, lane {k}");
                }
            }
        }
        let mut r = Pcg32::new(3, 17);
        match Avx2::detect() {
            Some(t) => check(t, &mut r),
            None => eprintln!("note: no AVX2, width 8 not checked"),
        }
        match Avx512::detect() {
            Some(t) => check(t, &mut r),
            None => eprintln!("note: no AVX-512, width 16 not checked"),
        }
    }
}
