//! The compensated sampler's random numbers over the mirror sawtooth, drawn for the chunk's 8
//! points at once (issue 18): each point draws from its own stream of the batch's columns
//! (`Samplers`), in the scalar `compensated::sample`'s order, so the draws of different points
//! may run side by side. A stream's `next_1d` is one PCG32 float whatever its strata, and its
//! `next_2d` two plain floats once its stratified draws are spent (`Sampler::plain_parts`;
//! always under `independent`), so the chunk's (state, increment) pairs are gathered into one
//! 8-wide PCG32 (`lane::pcg::Pcg::gather`) and each of the scalar code's draws is one masked
//! step (a lane that does not draw it keeps its state, `Avx2::select_u64`), the states then
//! stored back (`Avx2::store_u64_at`). A stream whose 2-D draw is still stratified draws that
//! number alone, after the others (its last draw of the pass: its order is kept). Every
//! stream ends where the scalar draws leave it (`super::tests`: independent and stratified
//! streams). The chunk's paths must be distinct (the stream kernel's chunks are).
//!
//! Pass 1 ([`first8`]): the lobe choice u0 (the cosine lobe where u0 < s(ωi)); the cosine
//! lobe's 2-D number, or the entry's number, the entry picked from the chunk's columns
//! ([`super::first::Points8::pick8`]), the nested sample's `u1` (a kind that draws it) and
//! `u2`. Pass 3 ([`wall8`]): the mirror wall's draw of the lanes whose nested sample is kept.

use super::sample::Asks;
use super::{Chunk, Drawn};
use crate::lane::pcg::Pcg;
use crate::lane::vec::{V2, V3};
use crate::lane::{Avx2, F32x8, Lane, M8};
use crate::sampler::Samplers;

/// One PCG32 float per lane, the state advanced only in the lanes of `on`.
#[inline(always)]
pub(super) fn step(avx: Avx2, rng: &mut Pcg<F32x8>, on: M8) -> F32x8 {
    let (old, inc) = rng.parts();
    let u = rng.next_f32();
    *rng = Pcg::from_parts(avx.select_u64(on, rng.parts().0, old), inc);
    u
}

/// Pass 1 of the sampler for the points of `c` seen from above (`c` over the mirror sawtooth),
/// each from stream `ids[k]` of `samplers`: the cosine lobe's directions into `wc` (by
/// component, those lanes only) and the nested samples' asks into `asks` (`draws_u1`: the
/// nested kind draws `u1`), as the scalar loop of `sample_x8_cols` does lane by lane.
#[inline(always)]
pub(super) fn first8(
    avx: Avx2,
    c: &Chunk,
    samplers: &mut Samplers,
    ids: &[u32; 8],
    draws_u1: bool,
    asks: &mut Asks,
    wc: &mut [[f32; 8]; 3],
) -> Drawn {
    let above = c.above;
    // The lanes whose 2-D draw is plain (all, where no stream has strata).
    let mut plain = u8::MAX;
    if !samplers.all_plain() {
        plain = 0;
        let mut rest = above;
        while rest != 0 {
            let k = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            plain |= u8::from(samplers.plain(ids[k] as usize)) << k;
        }
    }
    avx.run(
        #[inline(always)]
        || {
            let zero = avx.splat(0.0);
            let idx = avx.load_u32(ids);
            let (states, incs) = samplers.pcg_mut();
            let mut rng = Pcg::<F32x8>::gather(states, incs, idx);
            let old = rng.parts().0;
            let on = avx.mask_bits(u32::from(above));
            // u0 < s(ωi): the cosine lobe; else the entry by weight.
            let u0 = step(avx, &mut rng, on);
            let cosine = on & u0.lt(avx.load(&c.sel));
            let entry = on & !cosine;
            let u = step(avx, &mut rng, entry);
            let (some, second, a) = c.geo.pick8(avx, u);
            let asked = entry & some;
            let u1 = if draws_u1 {
                step(avx, &mut rng, asked)
            } else {
                zero
            };
            // The 2-D number: the cosine lobe's, or the nested sample's `u2`.
            let two = cosine | asked;
            let flat = two & avx.mask_bits(u32::from(plain));
            let mut x = step(avx, &mut rng, flat);
            let mut y = step(avx, &mut rng, flat);
            avx.store_u64_at(states, idx, on, rng.parts().0, old);
            let late = two.bits() as u8 & !plain;
            if late != 0 {
                let (mut xs, mut ys) = ([0.0f32; 8], [0.0f32; 8]);
                x.store(&mut xs);
                y.store(&mut ys);
                stratified(samplers, ids, late, &mut xs, &mut ys);
                (x, y) = (avx.load(&xs), avx.load(&ys));
            }
            let d = crate::lane::warp::square_to_cosine_hemisphere(V2::new(x, y));
            let dflt = V3::new(avx.load(&wc[0]), avx.load(&wc[1]), avx.load(&wc[2]));
            let d = V3::select(cosine, d, dflt);
            d.x.store(&mut wc[0]);
            d.y.store(&mut wc[1]);
            d.z.store(&mut wc[2]);
            asks.set_lanes(avx, asked, a, u1, V2::new(x, y));
            let asked = asked.bits() as u8;
            Drawn {
                cosine: cosine.bits() as u8,
                asked,
                second: second.bits() as u8 & asked,
            }
        },
    )
}

/// The 2-D numbers of the lanes `late` (streams still stratified) drawn stream by stream
/// (`Samplers::next_2d`: the stratum), into lanes of `x` and `y`.
#[inline(never)]
#[cold]
pub(super) fn stratified(
    samplers: &mut Samplers,
    ids: &[u32; 8],
    late: u8,
    x: &mut [f32; 8],
    y: &mut [f32; 8],
) {
    let mut rest = late;
    while rest != 0 {
        let k = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        let u = samplers.next_2d(ids[k] as usize);
        (x[k], y[k]) = (u.x, u.y);
    }
}

/// Pass 3 over the mirror sawtooth: the lanes `rest` (a kept nested sample) each draw u from
/// stream `ids[k]` and leave through the wall where u is not below G1 (`g`, by lane), as
/// `leave_mirror` does per lane. Returns the lanes through the wall and each lane's path
/// 2 j + wall (`second`: the lanes whose entry j is 1), as lane bits and a column.
#[inline(always)]
pub(super) fn wall8(
    avx: Avx2,
    samplers: &mut Samplers,
    ids: &[u32; 8],
    rest: u8,
    g: &[f32; 8],
    second: u8,
) -> (u8, [f32; 8]) {
    avx.run(
        #[inline(always)]
        || {
            let idx = avx.load_u32(ids);
            let (states, incs) = samplers.pcg_mut();
            let mut rng = Pcg::<F32x8>::gather(states, incs, idx);
            let old = rng.parts().0;
            let on = avx.mask_bits(u32::from(rest));
            let u = step(avx, &mut rng, on);
            let wall = on & !u.lt(avx.load(g));
            avx.store_u64_at(states, idx, on, rng.parts().0, old);
            let zero = avx.splat(0.0);
            let j = F32x8::select(
                avx.mask_bits(u32::from(second & rest)),
                avx.splat(2.0),
                zero,
            );
            let ks = j + F32x8::select(wall, avx.splat(1.0), zero);
            let mut out = [0.0f32; 8];
            ks.store(&mut out);
            (wall.bits() as u8, out)
        },
    )
}
