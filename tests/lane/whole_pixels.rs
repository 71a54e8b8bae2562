//! The batch fill's streams of a chunk of whole pixels (`sampler::for_whole_pixels_x8`: a
//! chunk of 8 paths that is 8, 4 or 2 pixels' 1, 2 or 4 samples) against
//! `Sampler::for_sample` path by path, and its lane pieces: the stream keys of four pixels in
//! one register (`U64x4`) against the 1-lane `stream_key`, `U64x4::spread` and
//! `U64x8::from_u32` against scalar references. Skipped, with a note, without AVX2.

#[cfg(target_arch = "x86_64")]
use groove::lane::{LaneU64, U64x4, U64x8};
#[cfg(target_arch = "x86_64")]
use groove::math::Pcg32;
#[cfg(target_arch = "x86_64")]
use groove::sampler::{
    for_whole_pixels_x8, stream_key, Sampler, SamplerDesc, SamplerKind, Samplers,
};

/// A 64-bit value that is often an edge (0, all ones, a carry across the 32-bit halves).
#[cfg(target_arch = "x86_64")]
fn word(r: &mut Pcg32) -> u64 {
    const EDGES: [u64; 6] = [0, 1, u64::MAX, u32::MAX as u64, 1 << 32, 1 << 63];
    let u = r.next_u32();
    if u & 3 == 0 {
        EDGES[(u >> 8) as usize % EDGES.len()]
    } else {
        ((r.next_u32() as u64) << 32) | r.next_u32() as u64
    }
}

#[test]
fn four_keys_in_one_register_and_their_spread() {
    #[cfg(target_arch = "x86_64")]
    {
        let Some(avx) =
            crate::harness::avx2_or_skip("whole pixels: this CPU has no AVX2/FMA, skipping")
        else {
            return;
        };
        let mut r = Pcg32::new(5, 17);
        for round in 0..20_000 {
            let seed = word(&mut r);
            let pixel: [u64; 4] = core::array::from_fn(|_| word(&mut r));
            // Random lane choices per result lane, as 32-bit word pairs.
            let lanes: [usize; 8] = core::array::from_fn(|_| r.next_u32() as usize % 4);
            let words: [[i32; 8]; 2] = core::array::from_fn(|h| {
                core::array::from_fn(|w| (2 * lanes[4 * h + w / 2] + w % 2) as i32)
            });
            let u32s: [i32; 8] = core::array::from_fn(|_| r.next_u32() as i32);
            let (keys, spread, wide) = avx.run(
                #[inline(always)]
                || {
                    let p = U64x4::load(avx, &pixel);
                    let k = stream_key(p.splat(seed), p);
                    let wide = U64x8::from_u32(avx.load_i32(&u32s));
                    (
                        k.to_array(),
                        k.spread(avx, &words).to_array(),
                        wide.to_array(),
                    )
                },
            );
            for i in 0..4 {
                assert_eq!(
                    keys[i],
                    stream_key(seed, pixel[i]),
                    "round {round}, lane {i}"
                );
            }
            for j in 0..8 {
                assert_eq!(spread[j], keys[lanes[j]], "round {round}, lane {j}");
                assert_eq!(wide[j], u32s[j] as u32 as u64, "round {round}, lane {j}");
            }
            // The low words (lanes 0–3, again in 4–7).
            let low = avx.run(
                #[inline(always)]
                || {
                    let k = U64x4::load(avx, &pixel);
                    k.low_u32().to_array()
                },
            );
            for j in 0..8 {
                assert_eq!(low[j], pixel[j % 4] as u32 as i32, "round {round}, low {j}");
            }
        }
    }
}

#[test]
fn whole_pixel_chunks_equal_for_sample() {
    #[cfg(target_arch = "x86_64")]
    {
        let Some(avx) =
            crate::harness::avx2_or_skip("whole pixels: this CPU has no AVX2/FMA, skipping")
        else {
            return;
        };
        let mut r = Pcg32::new(23, 9);
        let kinds = [
            (SamplerKind::Independent, 16),
            (SamplerKind::Stratified { jitter: true }, 16),
            (SamplerKind::Stratified { jitter: false }, 4),
            (SamplerKind::Stratified { jitter: true }, 2),
        ];
        for round in 0..4_000 {
            let (kind, sample_count) = kinds[round % kinds.len()];
            let d = SamplerDesc {
                kind,
                sample_count,
                seed: word(&mut r),
            };
            let sh = r.next_u32() % 3;
            let spp = 1u32 << sh;
            // Columns up to the largest the lanes take, rows and sample ranges anywhere.
            let x = match r.next_u32() % 4 {
                0 => i32::MAX as u32 - 7,
                1 => r.next_u32() % 4096,
                _ => r.next_u32() % (i32::MAX as u32 - 7),
            };
            let y = r.next_u32() % (1 << 20);
            let first = match r.next_u32() % 3 {
                0 => u64::MAX - 7,
                _ => word(&mut r) >> (r.next_u32() % 64),
            }
            .min(u64::MAX - 7);
            let s_lo = r.next_u32() % (u32::MAX - spp);
            // Appended after what the columns hold.
            let mut cols = Samplers::default();
            cols.push(&Sampler::from_seed(1, 2));
            let mut pos = vec![glam::Vec2::NAN];
            avx.run(
                #[inline(always)]
                || for_whole_pixels_x8(avx, &d, (first, x, y), sh, s_lo, &mut cols, &mut pos),
            );
            assert_eq!((cols.len(), pos.len()), (9, 9));
            for j in 0..8u32 {
                let (dx, ds) = (j >> sh, j & (spp - 1));
                let ctx = (round, kind, d.seed, first, x, y, sh, s_lo, j);
                let mut want = Sampler::for_sample(&d, first + dx as u64, s_lo + ds);
                let p = glam::Vec2::new((x + dx) as f32, y as f32) + want.next_2d();
                assert_eq!(
                    pos[1 + j as usize].to_array().map(f32::to_bits),
                    p.to_array().map(f32::to_bits),
                    "{ctx:?}"
                );
                let mut got = cols.get(1 + j as usize);
                assert_eq!(got.plain_parts(), want.plain_parts(), "{ctx:?}");
                for _ in 0..3 {
                    assert_eq!(got.next_2d(), want.next_2d(), "{ctx:?}");
                    assert_eq!(got.next_1d(), want.next_1d(), "{ctx:?}");
                }
            }
        }
    }
}
