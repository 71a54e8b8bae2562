//! `lane::LaneLookup::lookup8` (a permute by lane index, the light stage's small tables) equals
//! the scalar lookup `table[min(idx as u32, 7)]` bit for bit in every lane, at width 1, 8 and 16
//! (the 16-wide half skipped, with a note, without AVX-512): over random tables holding ±0,
//! subnormals, huge values, ±∞ and NaNs of several payloads, and indices in range, negative and
//! far out of range. `Avx2::lookup16` (two permutes and a blend, the surface gather's tables of
//! up to 16 triangles) likewise against `table[min(idx as u32, 15)]`.

use crate::harness::EDGES;
use groove::lane::wide::{ToArray, Wide};
use groove::lane::LaneLookup;
use groove::math::Pcg32;

fn check<T: Wide<W>, const W: usize>(avx: T)
where
    T::I: LaneLookup<T::F>,
{
    let mut r = Pcg32::new(12, 34);
    for round in 0..20_000 {
        let table: [f32; 8] = std::array::from_fn(|j| match (round + j) % 3 {
            0 => EDGES[r.next_u32() as usize % EDGES.len()],
            1 => f32::from_bits(r.next_u32()),
            _ => r.next_f32() * 4.0 - 2.0,
        });
        let idx: [i32; W] = std::array::from_fn(|k| match (round + k) % 6 {
            0 => 7,
            1 => 8,
            2 => -1 - (r.next_u32() % 3) as i32,
            3 => r.next_u32() as i32,
            _ => (r.next_u32() % 8) as i32,
        });
        let got = avx.run(
            #[inline(always)]
            || T::I::lookup8(&table, avx.load_i32(&idx)).to_array(),
        );
        for k in 0..W {
            let want = table[(idx[k] as u32).min(7) as usize];
            assert_eq!(
                got[k].to_bits(),
                want.to_bits(),
                "width {W} index {}",
                idx[k]
            );
            assert_eq!(
                i32::lookup8(&table, idx[k]).to_bits(),
                want.to_bits(),
                "width 1 index {}",
                idx[k]
            );
        }
    }
}

crate::at_8_and_16!(
    lookup8_equals_the_scalar_lookup_8,
    lookup8_equals_the_scalar_lookup_16,
    "lookup8",
    check
);

/// `Avx2::lookup16` (the surface gather's tables of meshes of 9 to 16 triangles) equals the
/// scalar lookup `table[min(idx as u32, 15)]` bit for bit in every lane: random tables of edge
/// floats and random bit patterns (NaN payloads, signalling ones included), every index 0 to 15
/// in every lane position, and indices past the table (16, 23, 24, −1, `i32::MIN`, random).
/// Skipped, with a note, without AVX2.
#[test]
fn lookup16_equals_the_scalar_lookup() {
    #[cfg(target_arch = "x86_64")]
    {
        let Some(avx) =
            crate::harness::avx2_or_skip("lookup16: this CPU has no AVX2/FMA, skipping")
        else {
            return;
        };
        let mut r = Pcg32::new(16, 26);
        for round in 0..20_000usize {
            let table: [f32; 16] = std::array::from_fn(|j| match (round + j) % 3 {
                0 => EDGES[r.next_u32() as usize % EDGES.len()],
                1 => f32::from_bits(r.next_u32()),
                _ => r.next_f32() * 4.0 - 2.0,
            });
            let idx: [i32; 8] = std::array::from_fn(|k| match (round / 16 + k) % 8 {
                // Every index in every lane over 16 rounds.
                0..=3 => ((round + k) % 16) as i32,
                4 => [16, 23, 24, -1, i32::MIN, i32::MAX, 8, 15][(round + k) % 8],
                5 => r.next_u32() as i32,
                _ => (r.next_u32() % 16) as i32,
            });
            let got = avx.run(
                #[inline(always)]
                || avx.lookup16(&table, avx.load_i32(&idx)).to_array(),
            );
            for k in 0..8 {
                let want = table[(idx[k] as u32).min(15) as usize];
                assert_eq!(got[k].to_bits(), want.to_bits(), "index {}", idx[k]);
            }
        }
    }
}

/// `Avx2::gather3_window` (the compensated table's 8 corner nodes per lookup) equals the
/// scalar reference bit for bit in every lane: lane k of row r is `table[i + offsets[r]]`
/// with i = `min(idx[k] as u32, len − 1 − max(offsets))`; where `idx[k] + max(offsets)` is
/// inside the table that is `Lane::gather3` at `idx[k] + offsets[r]` (checked too). Tables of
/// edge floats and random bit patterns (NaN payloads), indices at both ends of the window's
/// range, just past it, negative, `i32::MIN`, `i32::MAX` and random; offsets unsorted and
/// repeated, with 0 and the largest, and a window of one row (offsets all 0: `Lane::gather3`'s
/// path); a panic where the table is not longer than the largest
/// offset. Skipped, with a note, without AVX2.
#[test]
fn gather3_window_equals_the_scalar_rows() {
    #[cfg(target_arch = "x86_64")]
    {
        use glam::Vec3;
        use groove::lane::{F32x8, Lane};
        let Some(avx) =
            crate::harness::avx2_or_skip("gather3_window: this CPU has no AVX2/FMA, skipping")
        else {
            return;
        };
        let mut r = Pcg32::new(29, 7);
        let mut inside = 0;
        let offsets = [0usize, 1, 9, 10, 90, 91, 99, 100];
        let odd = [7usize, 0, 7, 3];
        // A window of one row (every offset 0): no neighbour row to read past.
        let flat = [0usize; 2];
        for round in 0..4000usize {
            let len = 101 + (r.next_u32() % 60) as usize;
            let table: Vec<Vec3> = (0..len)
                .map(|j| {
                    let mut f = |s: u32| match (round + j + s as usize) % 3 {
                        0 => EDGES[r.next_u32() as usize % EDGES.len()],
                        1 => f32::from_bits(r.next_u32()),
                        _ => r.next_f32() * 4.0 - 2.0,
                    };
                    Vec3::new(f(0), f(1), f(2))
                })
                .collect();
            let last = (len - 101) as i32; // the last index whose window is inside
            let idx: [i32; 8] = std::array::from_fn(|k| match (round + k) % 8 {
                0 => 0,
                1 => last,
                2 => last + 1,
                3 => [-1, i32::MIN, i32::MAX, len as i32][(round / 8 + k) % 4],
                4 => r.next_u32() as i32,
                _ => (r.next_u32() % (last as u32 + 1)) as i32,
            });
            let (got, got_odd, got_flat, each) = avx.run(
                #[inline(always)]
                || {
                    let i = avx.load_i32(&idx);
                    let w = avx.gather3_window(&table, i, &offsets);
                    let o = avx.gather3_window(&table, i, &odd);
                    let f = avx.gather3_window(&table, i, &flat);
                    let each: [[F32x8; 3]; 8] = std::array::from_fn(|row| {
                        let d = avx.load_i32(&[offsets[row] as i32; 8]);
                        F32x8::gather3(&table, groove::lane::LaneI32::add(i, d))
                    });
                    (
                        w.map(|v| v.map(|c| c.to_array())),
                        o.map(|v| v.map(|c| c.to_array())),
                        f.map(|v| v.map(|c| c.to_array())),
                        each.map(|v| v.map(|c| c.to_array())),
                    )
                },
            );
            for k in 0..8 {
                for (rows, offs) in [
                    (&got[..], &offsets[..]),
                    (&got_odd[..], &odd[..]),
                    (&got_flat[..], &flat[..]),
                ] {
                    let span = offs.iter().copied().max().unwrap_or(0);
                    let i = (idx[k] as u32).min((len - 1 - span) as u32) as usize;
                    for (row, &o) in rows.iter().zip(offs) {
                        let want = table[i + o].to_array();
                        for c in 0..3 {
                            let at = format!("len {len} index {} offset {o}", idx[k]);
                            assert_eq!(row[c][k].to_bits(), want[c].to_bits(), "{at}");
                        }
                    }
                }
                if idx[k] >= 0 && idx[k] <= last {
                    inside += 1;
                    for row in 0..8 {
                        for c in 0..3 {
                            assert_eq!(got[row][c][k].to_bits(), each[row][c][k].to_bits());
                        }
                    }
                }
            }
        }
        assert!(inside > 10_000, "{inside} lanes inside the table");
        let short = vec![Vec3::ONE; 100];
        let panicked = std::panic::catch_unwind(|| {
            avx.run(|| {
                avx.gather3_window(&short, avx.load_i32(&[0; 8]), &offsets);
            })
        });
        assert!(panicked.is_err(), "a table of 100 rows with offset 100");
    }
}

/// `Lane::gather3` at width 8 (a mesh's vertices and normals, a bitmap's texels) and
/// `Avx2::gather3_u32` (a mesh's triangles) equal the scalar rows
/// `table[min(idx as u32, len − 1)]` bit for bit in every lane: tables of 1, 2, 3 and random
/// lengths holding edge floats and random bit patterns (NaN payloads), indices 0, len − 1 (the
/// last row, where a load of whole rows would read past the table), len, −1, `i32::MIN`,
/// `i32::MAX` and random, in every lane position. Skipped, with a note, without AVX2.
#[test]
fn gather3_and_gather3_u32_equal_the_scalar_rows() {
    #[cfg(target_arch = "x86_64")]
    {
        use glam::Vec3;
        use groove::lane::{F32x8, Lane};
        let Some(avx) = crate::harness::avx2_or_skip("gather3: this CPU has no AVX2/FMA, skipping")
        else {
            return;
        };
        let mut r = Pcg32::new(31, 5);
        let mut lasts = 0;
        for round in 0..6000usize {
            let len = match round % 5 {
                0 => 1,
                1 => 2,
                2 => 3,
                3 => 4 + (r.next_u32() % 13) as usize,
                _ => 1 + (r.next_u32() % 300) as usize,
            };
            let words: Vec<[u32; 3]> = (0..len)
                .map(|j| {
                    std::array::from_fn(|c| match (round + j + c) % 3 {
                        0 => EDGES[r.next_u32() as usize % EDGES.len()].to_bits(),
                        _ => r.next_u32(),
                    })
                })
                .collect();
            let table: Vec<Vec3> = words
                .iter()
                .map(|w| {
                    Vec3::new(
                        f32::from_bits(w[0]),
                        f32::from_bits(w[1]),
                        f32::from_bits(w[2]),
                    )
                })
                .collect();
            let n = len as i32;
            let idx: [i32; 8] = std::array::from_fn(|k| match (round / 5 + k) % 8 {
                0 => 0,
                1 | 2 => n - 1,
                3 => n,
                4 => [-1, i32::MIN, i32::MAX, n + 1][(round / 40 + k) % 4],
                5 => r.next_u32() as i32,
                _ => (r.next_u32() % len as u32) as i32,
            });
            let (got, got_u32) = avx.run(
                #[inline(always)]
                || {
                    let i = avx.load_i32(&idx);
                    let f = F32x8::gather3(&table, i);
                    let u = avx.gather3_u32(&words, i);
                    (f.map(|c| c.to_array()), u.map(|c| c.to_array()))
                },
            );
            for k in 0..8 {
                let row = (idx[k] as u32).min(n as u32 - 1) as usize;
                lasts += usize::from(row == len - 1);
                let at = format!("len {len} index {} lane {k}", idx[k]);
                for c in 0..3 {
                    assert_eq!(
                        got[c][k].to_bits(),
                        words[row][c],
                        "gather3 {at} component {c}"
                    );
                    assert_eq!(
                        got_u32[c][k] as u32, words[row][c],
                        "gather3_u32 {at} word {c}"
                    );
                }
            }
        }
        assert!(lasts > 10_000, "{lasts} lanes on the last row");
    }
}
