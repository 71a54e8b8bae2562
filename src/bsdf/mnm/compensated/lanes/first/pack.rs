//! The first order's nested evaluations packed (issue 18): a query evaluates the nested BSDF on
//! up to four paths per lane (`super::evals_by_path`: one 8-wide call per path that any lane
//! needs), but only the direct path [p] is needed in most lanes; the others (the second entry,
//! the wall exit) in some. Here the (path, lane) pairs that need an evaluation are listed in
//! order (a compress of each path's lane numbers, [`Avx2::compress_store`]), their inputs
//! gathered 8 pairs per call (entry direction, exit direction, the density-only test), the
//! calls' results stored in list order and each path's lanes gathered back from them (an
//! expand: lane k of a path reads slot `start + rank(k)`, its rank among the path's lanes,
//! from [`RANKS`]). Used where it saves a call (fewer calls of 8 pairs than paths with a
//! pair), else the path-by-path form runs.
//!
//! Bit for bit the path-by-path results in every lane that reads them: a pair's arithmetic is
//! the lane form's on the pair's own inputs (the lane rule of [`crate::lane`]: a lane's values
//! do not depend on its neighbours; the query's shared terms are the BSDF's parameters,
//! the same in every lane; a direction's terms are recomputed in the lane of each pair that
//! uses it, the same function of the same direction). Checked against width 1 by
//! `super::tests::width_8_equals_width_1` (packed always, and as chosen).

use super::{nested, path_lanes, Evals, Exits, Lanes, ENTRIES};
use crate::bsdf::mnm::nested_batch::LaneNested;
use crate::lane::vec::V3;
use crate::lane::{Avx2, F32x8, Lane, LaneI32};

/// Paths per lane: [p] and [t,p] from each entry (slot `2 j + wall`).
const PATHS: usize = 2 * ENTRIES;

/// Per mask of 8 lanes (bit k: lane k), each lane's rank: the number of set bits below its own
/// (a kept lane's place in the compressed list of its mask).
const RANKS: [[i32; 8]; 256] = {
    let mut t = [[0i32; 8]; 256];
    let mut m = 0;
    while m < 256 {
        let mut n = 0;
        let mut k = 0;
        while k < 8 {
            t[m][k] = n;
            n += (m >> k & 1) as i32;
            k += 1;
        }
        m += 1;
    }
    t
};

/// Column `v`'s three components stored into `dst[c][8 h..8 h + 8]`.
#[inline(always)]
fn put3(v: V3<F32x8>, dst: &mut [[f32; 16]; 3], h: usize) {
    for (c, x) in [v.x, v.y, v.z].into_iter().enumerate() {
        x.store(slot8(&mut dst[c], h));
    }
}

/// `x[8 h..8 h + 8]` as an array.
#[inline(always)]
fn slot8<const N: usize>(x: &mut [f32; N], h: usize) -> &mut [f32; 8] {
    (&mut x[8 * h..8 * h + 8]).try_into().expect("8 slots")
}

/// The paths' evaluations ([`Evals`]) with the pairs packed, or `None` where packing would not
/// save a call (unless `always`: the tests run the packed form on every query). Call inside
/// the AVX2 region of `avx`.
#[inline(always)]
pub(super) fn evals<B: LaneNested>(
    avx: Avx2,
    b: &B,
    q: &Lanes<F32x8>,
    x: &Exits<F32x8>,
    always: bool,
) -> Option<Evals<F32x8>> {
    let zero = avx.splat(0.0);
    let mut need = [avx.mask_bits(0); PATHS];
    let mut bits = [0usize; PATHS];
    let (mut pairs, mut paths) = (0usize, 0usize);
    for j in 0..ENTRIES {
        for wall in 0..2 {
            let (on, known) = path_lanes(q, x, j, wall);
            let n = on & !known;
            let m = n.bits() as usize;
            need[2 * j + wall] = n;
            bits[2 * j + wall] = m;
            pairs += m.count_ones() as usize;
            paths += usize::from(m != 0);
        }
    }
    let calls = pairs.div_ceil(8);
    if !always && calls >= paths {
        return None;
    }
    // The list of pairs, path by path in lane order: 8 p + k for lane k of path p (the slots
    // past `pairs` that the last call reads hold valid pairs too: an append's tail, or 0).
    let iota = avx.load_i32(&[0, 1, 2, 3, 4, 5, 6, 7]);
    let mut list = [0u32; PATHS * 8 + 8];
    let mut start = [0i32; PATHS];
    let mut at = 0;
    for p in 0..PATHS {
        start[p] = at as i32;
        if bits[p] != 0 {
            at = avx.compress_store(iota.add(iota.splat(8 * p as i32)), need[p], &mut list, at);
        }
    }
    // The pairs' inputs: entry j's direction at 8 j + k, the exit's (ωo's, R(ωo)'s) at
    // 8 wall + k, G1(ωo) at k.
    let (mut a, mut o, mut g) = ([[0.0; 16]; 3], [[0.0; 16]; 3], [0.0; 8]);
    put3(q.a[0], &mut a, 0);
    put3(q.a[1], &mut a, 1);
    put3(x.bo, &mut o, 0);
    put3(x.rb, &mut o, 1);
    x.g1o.store(&mut g);
    let s = b.shared(q.wo.z);
    let mut r = [[0.0; PATHS * 8]; 4];
    for c in 0..calls {
        let ids: &[u32; 8] = list[8 * c..8 * c + 8].try_into().expect("8 slots");
        let pair = avx.load_u32(ids);
        let k = pair.and(pair.splat(7));
        let ia = pair.shr::<4>().shl::<3>().or(k);
        let io = pair.and(pair.splat(15));
        let av = V3::new(
            F32x8::gather(&a[0], ia),
            F32x8::gather(&a[1], ia),
            F32x8::gather(&a[2], ia),
        );
        let ov = V3::new(
            F32x8::gather(&o[0], io),
            F32x8::gather(&o[1], io),
            F32x8::gather(&o[2], io),
        );
        let po = F32x8::gather(&g, k).le(zero);
        let di = b.dir(&s, av);
        let dw = b.dir(&s, ov);
        let (f, p) = nested(b, &s, (av, &di), (ov, &dw), po);
        f.x.store(slot8(&mut r[0], c));
        f.y.store(slot8(&mut r[1], c));
        f.z.store(slot8(&mut r[2], c));
        p.store(slot8(&mut r[3], c));
    }
    // Each path's lanes back from their slots (a path without a pair: 0, as path by path).
    let zero3 = V3::new(zero, zero, zero);
    let mut out = [(zero3, zero); PATHS];
    for p in 0..PATHS {
        if bits[p] == 0 {
            continue;
        }
        let slot = avx.load_i32(&RANKS[bits[p]]).add(iota.splat(start[p]));
        out[p] = (
            V3::new(
                F32x8::gather(&r[0], slot),
                F32x8::gather(&r[1], slot),
                F32x8::gather(&r[2], slot),
            ),
            F32x8::gather(&r[3], slot),
        );
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::RANKS;

    /// Each lane's rank is the number of set bits below it, for every mask.
    #[test]
    fn ranks_count_the_lanes_below() {
        for (m, row) in RANKS.iter().enumerate() {
            for (k, &r) in row.iter().enumerate() {
                assert_eq!(r, (m & ((1 << k) - 1)).count_ones() as i32, "{m} {k}");
            }
        }
    }
}
