//! `I128x4::sum8` (a film pixel's eight samples' addends summed in registers before one add),
//! and `I128x4::sum` of two and four rows (a pixel's samples at 2 or 4 a pixel), against plain
//! `i128` wrapping sums: words with carries out of the low half in every
//! position, high words at and around the sign change, all-ones and zeros, and random ones.
//! Skipped, with a note, without AVX2.

use groove::lane::{I128x4, Words8};
use groove::math::Pcg32;

/// Low and high words that make carries and sign changes likely.
const EDGES: [u64; 8] = [
    0,
    1,
    u64::MAX,
    u64::MAX - 1,
    1 << 63,
    (1 << 63) - 1,
    (1 << 63) + 1,
    0xffff_ffff,
];

#[test]
fn sums_of_8_4_and_2_rows_equal_wrapping_sums() {
    #[cfg(target_arch = "x86_64")]
    {
        let Some(avx) = crate::harness::avx2_or_skip("sum8: this CPU has no AVX2/FMA, skipping")
        else {
            return;
        };
        let mut r = Pcg32::new(77, 3);
        for round in 0..200_000 {
            let mut word = || {
                let u = r.next_u32();
                if u & 3 == 0 {
                    EDGES[(u >> 8) as usize % EDGES.len()]
                } else {
                    ((r.next_u32() as u64) << 32) | r.next_u32() as u64
                }
            };
            let words: [Words8; 8] = core::array::from_fn(|_| {
                let mut w = [[0u64; 8]; 2];
                for half in &mut w {
                    for x in half.iter_mut().take(4) {
                        *x = word();
                    }
                }
                w
            });
            let rows = words.map(|w| I128x4::load(avx, &w));
            // The eight rows, the first two and the last four.
            let two = [rows[0], rows[1]];
            let four = [rows[4], rows[5], rows[6], rows[7]];
            let cases = [
                (I128x4::sum8(&rows).to_words(), &words[..]),
                (I128x4::sum(&two).to_words(), &words[..2]),
                (I128x4::sum(&four).to_words(), &words[4..]),
            ];
            for (got, words) in cases {
                for c in 0..4 {
                    let want = words.iter().fold(0i128, |s, w| {
                        s.wrapping_add((((w[1][c] as u128) << 64) | w[0][c] as u128) as i128)
                    });
                    let have = (((got[1][c] as u128) << 64) | got[0][c] as u128) as i128;
                    let n = words.len();
                    assert_eq!(have, want, "round {round}, {n} rows, value {c}");
                }
            }
        }
    }
}
