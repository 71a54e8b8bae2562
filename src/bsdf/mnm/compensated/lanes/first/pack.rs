//! The first order's nested evaluations packed (issue 18): a query evaluates the nested BSDF on
//! up to four paths per lane (`super::evals_by_path`: one 8-wide call per path that any lane
//! needs), but only the direct path \[p\] is needed in most lanes; the others (the second entry,
//! the wall exit) in some. Here the (path, lane) pairs that need an evaluation are listed in
//! path order and evaluated 8 pairs a call, where that saves a call; everything between the
//! query's registers and the calls is a permute, without a gather or a store of the inputs:
//! - the list is two 64-bit words of 4-bit lane numbers ([`KEPT`] of each path's mask,
//!   shifted to the path's first slot), and a call's 8 slots (32 bits of a word) become a
//!   permute index by [`Avx2::nibbles`];
//! - a pair's inputs are two permutes and a blend per component: its entry's direction from
//!   entry 0's and entry 1's registers (the blend: the slot lies in paths 2–3), its exit's from
//!   ωo's and R(ωo)'s in the facet frame (paths 1 and 3); the density-only test is the
//!   permuted G1(ωo)'s;
//! - each path's results span at most two calls (its slots are consecutive, at most 8): lane k
//!   reads slot `start + rank(k)` ([`RANKS`]), a permute of the one call or two permutes and a
//!   blend.
//!
//! Bit for bit the path-by-path results in every lane that reads them: a pair's arithmetic is
//! the lane form's on the pair's own inputs (the lane rule of [`crate::lane`]: a lane's values
//! do not depend on its neighbours; the query's shared terms are the BSDF's parameters, the
//! same in every lane; a direction's terms are computed in the lane of each pair that uses it,
//! the same function of the same direction). Checked against width 1 by
//! `super::tests::width_8_equals_width_1` (packed always, and as chosen).

use super::{nested, Evals, Exits, Lanes, PathMasks, ENTRIES};
use crate::bsdf::mnm::nested_batch::LaneNested;
use crate::lane::bits::BYTE_COUNTS as COUNTS;
use crate::lane::vec::V3;
use crate::lane::{Avx2, F32x8, I32x8, Lane, LaneI32, M8};

/// Paths per lane: \[p\] and \[t,p\] from each entry (slot `2 j + wall`).
const PATHS: usize = 2 * ENTRIES;

/// Per mask of 8 lanes (bit k: lane k), its set lanes' numbers in order, one per nibble
/// (nibble r: the r-th set lane), 0 past them.
const KEPT: [u32; 256] = {
    let mut t = [0u32; 256];
    let mut m = 0;
    while m < 256 {
        let (mut row, mut n, mut k) = (0u32, 0, 0);
        while k < 8 {
            if m >> k & 1 == 1 {
                row |= (k as u32) << (4 * n);
                n += 1;
            }
            k += 1;
        }
        t[m] = row;
        m += 1;
    }
    t
};

/// Per mask of 8 lanes, each lane's rank in nibble k: the number of set bits below bit k (a
/// set lane's place in its mask's list, [`KEPT`]).
const RANKS: [u32; 256] = {
    let mut t = [0u32; 256];
    let mut m = 0;
    while m < 256 {
        let (mut row, mut n, mut k) = (0u32, 0u32, 0);
        while k < 8 {
            row |= n << (4 * k);
            n += (m >> k & 1) as u32;
            k += 1;
        }
        t[m] = row;
        m += 1;
    }
    t
};

/// Lane i: lane `idx[i]` of `lo`, or of `hi` where `up` (two permutes and a blend).
#[inline(always)]
fn pick(lo: F32x8, hi: F32x8, idx: I32x8, up: M8) -> F32x8 {
    F32x8::select(up, hi.permute(idx), lo.permute(idx))
}

/// [`pick`] of each component.
#[inline(always)]
fn pick3(lo: V3<F32x8>, hi: V3<F32x8>, idx: I32x8, up: M8) -> V3<F32x8> {
    V3::new(
        pick(lo.x, hi.x, idx, up),
        pick(lo.y, hi.y, idx, up),
        pick(lo.z, hi.z, idx, up),
    )
}

/// Each path's first slot and the list of the pairs' lanes in path order (`need`: each path's
/// mask), a nibble per slot (slots past the last pair: lane 0 of path 3, valid inputs whose
/// results nobody reads), as two 64-bit halves (slots 0–15 and 16–31; a `u128` shift by a
/// variable amount took ~14 instructions). A path's list (at most 8 nibbles, [`KEPT`])
/// starting at slot `next` < 16 goes to the low half shifted by 4 next and its nibbles past
/// slot 15 to the high half (k >> (64 − 4 next), written as two shifts: 4 next may be 0);
/// one starting at 16 or later goes to the high half shifted by 4 next − 64, which is what
/// the 64-bit shift by 4 next does (its amount taken mod 64; at slot 32 the list is empty).
#[inline(always)]
fn list(need: &[u32; PATHS]) -> ([u32; PATHS], u64, u64) {
    let mut start = [0u32; PATHS];
    let (mut next, mut lo, mut hi) = (0u32, 0u64, 0u64);
    for p in 0..PATHS {
        start[p] = next;
        let k = u64::from(KEPT[need[p] as usize]);
        let sh = 4 * next;
        let shifted = k.wrapping_shl(sh);
        let carry = (k >> 1).wrapping_shr(63u32.wrapping_sub(sh));
        let low = next < 16;
        lo |= if low { shifted } else { 0 };
        hi |= if low { carry } else { shifted };
        next += u32::from(COUNTS[need[p] as usize]);
    }
    (start, lo, hi)
}

/// The paths' evaluations ([`Evals`]) with the pairs packed, or `None` where packing would not
/// save a call (unless `always`: the tests run the packed form on every query). `pm`: the
/// paths' lanes (a pair where a lane takes the path and its term is not the known one). Call
/// inside the AVX2 region of `avx`.
#[inline(always)]
pub(super) fn evals<B: LaneNested>(
    avx: Avx2,
    b: &B,
    q: &Lanes<F32x8>,
    x: &Exits<F32x8>,
    pm: &PathMasks<F32x8>,
    always: bool,
) -> Option<Evals<F32x8>> {
    // Each path's pairs (bits); packing saves a call where fewer calls of 8 pairs than
    // paths with a pair would do. (Counts from a table: inside the AVX2 region `count_ones`
    // has no `popcnt` and takes ~15 instructions.)
    let mut need = [0u32; PATHS];
    let (mut pairs, mut paths) = (0u32, 0u32);
    for (p, &(on, known)) in pm.iter().enumerate() {
        let m = (on & !known).bits();
        need[p] = m;
        pairs += u32::from(COUNTS[m as usize]);
        paths += u32::from(m != 0);
    }
    let calls = pairs.div_ceil(8) as usize;
    if !always && calls as u32 >= paths {
        return None;
    }
    let (start, lo, hi) = list(&need);
    let zero = avx.splat(0.0);
    let iota = avx.load_i32(&[0, 1, 2, 3, 4, 5, 6, 7]);
    // A slot lies in path p or after where it is above start[p] − 1.
    let s1 = iota.splat(start[1] as i32 - 1);
    let s2 = iota.splat(start[2] as i32 - 1);
    let s3 = iota.splat(start[3] as i32 - 1);
    let s = b.shared(q.wo.z);
    let mut r = [[zero; 4]; PATHS];
    for (c, rc) in r.iter_mut().enumerate().take(calls) {
        let half = if c < 2 { lo } else { hi };
        let idx = avx.nibbles((half >> (32 * (c % 2))) as u32);
        let slot = iota.add(iota.splat(8 * c as i32));
        let (g2, g3) = (slot.gt(s2), slot.gt(s3));
        // Entry 1 in paths 2 and 3; the wall exit in paths 1 and 3.
        let wall = (slot.gt(s1) & !g2) | g3;
        let av = pick3(q.a[0], q.a[1], idx, g2);
        let ov = pick3(x.bo, x.rb, idx, wall);
        let po = x.g1o.permute(idx).le(zero);
        let di = b.dir(&s, av);
        let dw = b.dir(&s, ov);
        let (f, p) = nested(b, &s, (av, &di), (ov, &dw), po);
        *rc = [f.x, f.y, f.z, p];
    }
    // Each path's lanes back from their slots (a path without a pair: 0, as path by path):
    // nibble k is (start mod 8) + rank(k) < 16, its bit 3 the next call.
    let zero3 = V3::new(zero, zero, zero);
    let mut out = [(zero3, zero); PATHS];
    for p in 0..PATHS {
        if need[p] == 0 {
            continue;
        }
        let (c0, at) = ((start[p] / 8) as usize, start[p] % 8);
        let idx = avx.nibbles(RANKS[need[p] as usize] + at * 0x1111_1111);
        let lo = r[c0];
        // (Written out: a closure, e.g. `array::from_fn`'s, may be compiled out of line.)
        let v: [F32x8; 4] = if at + u32::from(COUNTS[need[p] as usize]) > 8 {
            let hi = r[c0 + 1];
            let up = idx.shl::<28>().lt(idx.splat(0));
            [
                pick(lo[0], hi[0], idx, up),
                pick(lo[1], hi[1], idx, up),
                pick(lo[2], hi[2], idx, up),
                pick(lo[3], hi[3], idx, up),
            ]
        } else {
            [
                lo[0].permute(idx),
                lo[1].permute(idx),
                lo[2].permute(idx),
                lo[3].permute(idx),
            ]
        };
        out[p] = (V3::new(v[0], v[1], v[2]), v[3]);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::{list, COUNTS, KEPT, PATHS, RANKS};
    use crate::math::Pcg32;

    /// The list's two halves equal the list built as one `u128` (each path's [`KEPT`] shifted
    /// to its first slot), and the first slots are the running counts: every path's mask
    /// empty, full (32 slots: the last list ends at slot 31, the next start is 32) and one
    /// lane in each place, lists starting on and around slots 8, 15, 16, 17 and 24, and
    /// 100,000 random masks.
    #[test]
    fn the_list_halves_equal_one_wide_list() {
        let check = |need: [u32; PATHS]| {
            let (mut want, mut next) = (0u128, 0u32);
            let mut starts = [0u32; PATHS];
            for p in 0..PATHS {
                starts[p] = next;
                want |= u128::from(KEPT[need[p] as usize]) << (4 * next);
                next += u32::from(COUNTS[need[p] as usize]);
            }
            let (start, lo, hi) = list(&need);
            assert_eq!(start, starts, "{need:?}");
            assert_eq!(u128::from(lo) | u128::from(hi) << 64, want, "{need:?}");
        };
        let mut masks: Vec<u32> = vec![0, 0xff, 0x80, 0x01, 0x7f, 0xfe, 0x0f, 0xf0];
        masks.extend((0..8).map(|k| 1 << k));
        masks.extend([0x03, 0x07, 0x3f, 0x55, 0xaa, 0x7e]);
        for &a in &masks {
            for &b in &masks {
                for &c in &masks {
                    for &d in &masks {
                        check([a, b, c, d]);
                    }
                }
            }
        }
        let mut rng = Pcg32::new(31, 2);
        for _ in 0..100_000 {
            check(std::array::from_fn(|_| rng.next_u32() & 0xff));
        }
    }

    /// Each mask's list holds its set lanes in order then zeros, its count is its number of
    /// set lanes, and each lane's rank is the number of set bits below it, for every mask.
    #[test]
    fn lists_and_ranks_of_every_mask() {
        for m in 0..256usize {
            let set: Vec<u32> = (0..8).filter(|&k| m >> k & 1 == 1).collect();
            assert_eq!(usize::from(COUNTS[m]), set.len(), "{m}");
            for r in 0..8 {
                let want = set.get(r).copied().unwrap_or(0);
                assert_eq!(KEPT[m] >> (4 * r) & 15, want, "{m} {r}");
            }
            for k in 0..8 {
                let want = (m & ((1 << k) - 1)).count_ones();
                assert_eq!(RANKS[m] >> (4 * k) & 15, want, "{m} {k}");
            }
        }
    }
}
