//! `Avx2::compress_store` (the stream's lists of path ids filtered 8 at a time), `Avx2::load_u32`
//! (8 ids as `i32` lanes), `Avx2::vec2_columns` / `Avx2::append_vec2_rows` (8 film positions' x
//! and y columns and back, every bit moved, NaN payloads among them) and `Avx2::append_u64`
//! (8 words appended from lanes) against scalar references: every mask pattern, ids with
//! edge values (0, −1, `i32::MIN`, `i32::MAX`), lists at every offset up to the last one that
//! fits 8 slots (the slots outside `at..at + 8` untouched, the kept ids first in lane order,
//! then the others in lane order), a panic before any store when 8 slots do not fit; the
//! compress permutation alone (`Avx2::compress_index`) for every mask. (The
//! path states' gathers, `Avx2::gather_depth` among them: `state_gathers.rs`.)

use groove::math::Pcg32;

#[test]
fn compress_store_equals_the_filter() {
    let Some(avx) = crate::harness::avx2_or_skip("no AVX2/FMA: the compress test is skipped")
    else {
        return;
    };
    let mut r = Pcg32::new(28, 1);
    let len = 40;
    for mask in 0u32..256 {
        for at in [0usize, 1, 7, 13, len - 9, len - 8] {
            let ids: [i32; 8] = std::array::from_fn(|k| match (mask as usize + k + at) % 6 {
                0 => 0,
                1 => -1,
                2 => i32::MIN,
                3 => i32::MAX,
                _ => r.next_u32() as i32,
            });
            let keep: [bool; 8] = std::array::from_fn(|k| mask >> k & 1 == 1);
            let before: Vec<u32> = (0..len).map(|_| r.next_u32()).collect();
            let mut got = before.clone();
            let end = avx.run(
                #[inline(always)]
                || avx.compress_store(avx.load_i32(&ids), avx.mask(&keep), &mut got, at),
            );
            let kept: Vec<u32> = (0..8).filter(|&k| keep[k]).map(|k| ids[k] as u32).collect();
            let others = (0..8).filter(|&k| !keep[k]).map(|k| ids[k] as u32);
            let mut want = before.clone();
            for (slot, id) in want[at..at + 8]
                .iter_mut()
                .zip(kept.iter().copied().chain(others))
            {
                *slot = id;
            }
            assert_eq!(end, at + kept.len(), "mask {mask:#x} at {at}");
            assert_eq!(got, want, "mask {mask:#x} at {at}: ids {ids:?}");
        }
    }
    // 8 slots past `at` do not fit: a panic, and the list untouched.
    for at in [len - 7, len - 1, len, len + 3] {
        let mut list = vec![5u32; len];
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            avx.run(
                #[inline(always)]
                || avx.compress_store(avx.load_i32(&[1; 8]), avx.mask(&[true; 8]), &mut list, at),
            )
        }));
        assert!(result.is_err(), "at {at}: no panic");
        assert!(
            list.iter().all(|&v| v == 5),
            "at {at}: a store before the panic"
        );
    }
}

/// `Avx2::vec2_columns` gives point `k`'s x and y as lane `k` of two columns, and
/// `Avx2::append_vec2_rows` appends two columns' lane `k` as point `len + k` (inverting it),
/// every bit moved (NaN payloads, ±0, infinities, subnormals, ±`f32::MAX`), after the points
/// the vector held (untouched), whatever its spare room (0 to 9 points held, capacity exact or
/// not).
#[test]
fn vec2_columns_and_rows_move_every_bit() {
    let Some(avx) =
        crate::harness::avx2_or_skip("no AVX2/FMA: the 2-D columns and rows test is skipped")
    else {
        return;
    };
    let mut r = Pcg32::new(28, 5);
    let edges = [
        0.0f32,
        -0.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        1e-40,
        f32::MAX,
        -f32::MAX,
    ];
    for round in 0..4000 {
        let mut col = || -> [f32; 8] {
            std::array::from_fn(|k| match (round + k) % 5 {
                0 => edges[r.next_u32() as usize % edges.len()],
                // NaNs with their payloads and every other bit pattern.
                _ => f32::from_bits(r.next_u32()),
            })
        };
        let (x, y) = (col(), col());
        let points: [glam::Vec2; 8] = std::array::from_fn(|k| glam::Vec2::new(x[k], y[k]));
        let held = round % 10;
        let before: Vec<glam::Vec2> = (0..held).map(|j| glam::Vec2::splat(j as f32)).collect();
        let mut out = if round % 2 == 0 {
            before.clone()
        } else {
            let mut v = Vec::with_capacity(held + 8 + round % 3);
            v.extend_from_slice(&before);
            v
        };
        let (cols, back) = avx.run(
            #[inline(always)]
            || {
                let cols = avx.vec2_columns(&points).map(|c| c.to_array());
                avx.append_vec2_rows(&mut out, avx.load(&x), avx.load(&y));
                let rows: &[glam::Vec2; 8] = out[held..].try_into().expect("8 points appended");
                (cols, avx.vec2_columns(rows).map(|c| c.to_array()))
            },
        );
        assert_eq!(out.len(), held + 8, "round {round}");
        assert_eq!(&out[..held], &before[..], "round {round}: the points held");
        let rows = &out[held..];
        for k in 0..8 {
            let bits = |v: [f32; 2]| v.map(f32::to_bits);
            let want = bits([x[k], y[k]]);
            assert_eq!(
                bits([cols[0][k], cols[1][k]]),
                want,
                "round {round} lane {k}: columns"
            );
            assert_eq!(
                bits([rows[k].x, rows[k].y]),
                want,
                "round {round} lane {k}: rows"
            );
            assert_eq!(
                bits([back[0][k], back[1][k]]),
                want,
                "round {round} lane {k}: back"
            );
        }
    }
}

/// `Avx2::load_u32` gives each `u32` as `x as i32` in its lane, bit for bit: ids at the
/// edges (0, 1, 2³¹ − 1, 2³¹, `u32::MAX`) in every lane and random ones.
#[test]
fn load_u32_equals_the_casts() {
    let Some(avx) = crate::harness::avx2_or_skip("no AVX2/FMA: the id load test is skipped") else {
        return;
    };
    let mut r = Pcg32::new(28, 6);
    let edges = [0u32, 1, i32::MAX as u32, 1 << 31, u32::MAX];
    for round in 0..500 {
        let a: [u32; 8] = std::array::from_fn(|k| {
            if round < 40 {
                edges[(round + k) % edges.len()]
            } else {
                r.next_u32()
            }
        });
        let got = avx.run(
            #[inline(always)]
            || avx.load_u32(&a).to_array(),
        );
        assert_eq!(got, a.map(|x| x as i32), "round {round}");
    }
}

/// `Avx2::compress_index` (one mask's compress permutation, for several columns) against a
/// scalar reference: for every mask, with bits above 7 set or not (ignored), the index lists
/// the kept lanes in lane order, then the others in lane order, and the count is the kept
/// lanes'; permuting floats by it (`F32x8::permute`) moves every bit (edge floats, NaN
/// payloads).
#[test]
fn compress_index_equals_the_filter() {
    let Some(avx) = crate::harness::avx2_or_skip("no AVX2/FMA: the compress index test is skipped")
    else {
        return;
    };
    let mut r = Pcg32::new(31, 2);
    for mask in 0u32..256 {
        for high in [0u32, 0x100, 0xffff_ff00, 0x8000_0000] {
            let order: Vec<i32> = (0..8)
                .filter(|&k| mask >> k & 1 == 1)
                .chain((0..8).filter(|&k| mask >> k & 1 == 0))
                .collect();
            let x: [f32; 8] = std::array::from_fn(|_| crate::harness::edge_or_bits(&mut r));
            let (idx, kept, moved) = avx.run(
                #[inline(always)]
                || {
                    let (idx, kept) = avx.compress_index(mask | high);
                    (idx.to_array(), kept, avx.load(&x).permute(idx).to_array())
                },
            );
            assert_eq!(idx.to_vec(), order, "mask {mask:#x} high {high:#x}");
            assert_eq!(kept, mask.count_ones() as usize, "mask {mask:#x}: count");
            for j in 0..8 {
                let want = x[order[j] as usize].to_bits();
                assert_eq!(moved[j].to_bits(), want, "mask {mask:#x}: lane {j}");
            }
        }
    }
}

/// `Avx2::append_u64` appends lane `k` as element `len + k`, every bit, after the elements the
/// vector held (untouched), whatever its spare room (0 to 10 held, capacity exact or not).
#[test]
fn append_u64_writes_every_bit_after_the_held_elements() {
    let Some(avx) = crate::harness::avx2_or_skip("no AVX2/FMA: the appends test is skipped") else {
        return;
    };
    let mut r = Pcg32::new(35, 1);
    for round in 0..2000usize {
        let held = round % 11;
        let words: [u64; 8] = std::array::from_fn(|k| match (round + k) % 4 {
            0 => [0, 1, u64::MAX, 1 << 63][r.next_u32() as usize % 4],
            _ => (r.next_u32() as u64) << 32 | r.next_u32() as u64,
        });
        let before: Vec<u64> = (0..held as u64).map(|j| j * 7 + 1).collect();
        let mut out = if round % 2 == 0 {
            before.clone()
        } else {
            let mut v = Vec::with_capacity(held + 8 + round % 3);
            v.extend_from_slice(&before);
            v
        };
        avx.run(
            #[inline(always)]
            || avx.append_u64(&mut out, avx.load_u64(&words)),
        );
        assert_eq!(out.len(), held + 8, "round {round}");
        assert_eq!(&out[..held], &before[..], "round {round}: the words held");
        assert_eq!(
            &out[held..],
            &words[..],
            "round {round}: the words appended"
        );
    }
}
