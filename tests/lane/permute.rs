//! `Avx2::nibbles` (eight 4-bit numbers of a word spread to the lanes) and `F32x8::permute`
//! (lane `i` takes lane `idx[i] & 7`), the compensated first order's packed pairs, against
//! plain scalar references bit for bit: words 0, all ones, one nibble set in each position,
//! the identity list and random words; floats holding ±0, subnormals, huge values, ±∞ and NaNs
//! of several payloads, indices in range, with high bits set, negative, `i32::MIN` and
//! `i32::MAX`. Skipped, with a note, without AVX2/FMA.

use crate::harness::EDGES;
use groove::math::Pcg32;

#[test]
fn nibbles_and_permute_equal_the_scalar_references() {
    let Some(avx) =
        crate::harness::avx2_or_skip("no AVX2/FMA: the 8-wide nibbles and permute are not tested")
    else {
        return;
    };
    let mut r = Pcg32::new(30, 2);
    let mut rows = vec![
        0u32,
        u32::MAX,
        0x7654_3210,
        0x0123_4567,
        0x8888_8888,
        0xffff_fff0,
    ];
    rows.extend((0..8).map(|i| 0xfu32 << (4 * i)));
    rows.extend((0..8).map(|i| 1u32 << (4 * i + 3)));
    rows.extend((0..5000).map(|_| r.next_u32()));
    for &row in &rows {
        let got = avx.run(
            #[inline(always)]
            || avx.nibbles(row).to_array(),
        );
        for (i, &g) in got.iter().enumerate() {
            assert_eq!(g, ((row >> (4 * i)) & 15) as i32, "row {row:#x} lane {i}");
        }
    }
    for round in 0..20_000 {
        let v: [f32; 8] = std::array::from_fn(|j| match (round + j) % 4 {
            0 => EDGES[r.next_u32() as usize % EDGES.len()],
            1 => f32::from_bits(r.next_u32()),
            2 => f32::from_bits(0x7f80_0001 + r.next_u32() % 0x7f_ffff),
            _ => r.next_f32() * 4.0 - 2.0,
        });
        let idx: [i32; 8] = std::array::from_fn(|k| match (round + k) % 8 {
            0 => 7,
            1 => 8 + (r.next_u32() % 8) as i32,
            2 => -1 - (r.next_u32() % 9) as i32,
            3 => r.next_u32() as i32,
            4 => i32::MIN + (r.next_u32() % 8) as i32,
            5 => i32::MAX - (r.next_u32() % 8) as i32,
            _ => (r.next_u32() % 8) as i32,
        });
        let got = avx.run(
            #[inline(always)]
            || avx.load(&v).permute(avx.load_i32(&idx)).to_array(),
        );
        for k in 0..8 {
            let want = v[(idx[k] & 7) as usize];
            assert_eq!(
                got[k].to_bits(),
                want.to_bits(),
                "round {round} index {}",
                idx[k]
            );
        }
    }
}
