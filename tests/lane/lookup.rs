//! `lane::LaneLookup::lookup8` (a permute by lane index, the light stage's small tables) equals
//! the scalar lookup `table[min(idx as u32, 7)]` bit for bit in every lane, at width 1, 8 and 16
//! (the 16-wide half skipped, with a note, without AVX-512): over random tables holding ±0,
//! subnormals, huge values, ±∞ and NaNs of several payloads, and indices in range, negative and
//! far out of range.

use groove::lane::wide::{ToArray, Wide};
use groove::lane::LaneLookup;
use groove::math::Pcg32;

const EDGES: [f32; 12] = [
    0.0,
    -0.0,
    1e-45,
    -1.2e-38,
    3.4e38,
    -3.4e38,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
    1.0,
    -0.5,
    f32::MIN_POSITIVE,
];

fn check<T: Wide<W>, const W: usize>(avx: T)
where
    T::I: LaneLookup<T::F>,
{
    let mut r = Pcg32::new(12, 34);
    for round in 0..20_000 {
        let table: [f32; 8] = std::array::from_fn(|j| match (round + j) % 3 {
            0 => EDGES[(r.next_u32() % 12) as usize],
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
