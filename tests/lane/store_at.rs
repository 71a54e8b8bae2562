//! `Wide::store_u64_at` (the write-back of gathered 64-bit values, `kernels::draws`' PCG32
//! states) at width 8 and 16 against a scalar reference: per lane, from the last lane to the
//! first, `table[idx[k]] = new[k]` where `on[k]`, else `old[k]`, so that a repeated index keeps
//! its lowest lane's value; every other entry untouched; every mask pattern at width 8 and
//! random ones at 16; indices at both ends of the table, repeated, and out of range (a panic
//! before any store).

use groove::lane::wide::Wide;
use groove::math::Pcg32;

fn reference<const W: usize>(
    table: &mut [u64],
    idx: &[i32; W],
    on: &[bool; W],
    new: &[u64; W],
    old: &[u64; W],
) {
    for k in (0..W).rev() {
        table[idx[k] as u32 as usize] = if on[k] { new[k] } else { old[k] };
    }
}

fn check<T: Wide<W>, const W: usize>(avx: T) {
    let mut r = Pcg32::new(41, 7);
    let u64s = |r: &mut Pcg32| ((r.next_u32() as u64) << 32) | r.next_u32() as u64;
    let rounds = if W == 8 { 256 * 8 } else { 4096 };
    for round in 0..rounds {
        let len = [1usize, 2, 5, 17, 64][round % 5];
        let table: Vec<u64> = (0..len).map(|_| u64s(&mut r)).collect();
        let bits = if W == 8 {
            (round / 8) as u32
        } else {
            r.next_u32()
        };
        let on: [bool; W] = std::array::from_fn(|k| bits >> k & 1 == 1);
        // Indices: random, the ends, and every fourth round a padded chunk's repeats (the
        // last lanes copy an earlier one).
        let mut idx: [i32; W] = std::array::from_fn(|k| match (round + k) % 7 {
            0 => 0,
            1 => len as i32 - 1,
            _ => (r.next_u32() as usize % len) as i32,
        });
        if round % 4 == 0 {
            let from = 1 + round % (W - 1);
            let copy = idx[from - 1];
            for i in &mut idx[from..] {
                *i = copy;
            }
        }
        let new: [u64; W] = std::array::from_fn(|_| u64s(&mut r));
        let old: [u64; W] = std::array::from_fn(|_| u64s(&mut r));
        let mut want = table.clone();
        reference(&mut want, &idx, &on, &new, &old);
        let mut got = table.clone();
        avx.run(
            #[inline(always)]
            || {
                avx.store_u64_at(
                    &mut got,
                    avx.load_i32(&idx),
                    avx.mask(&on),
                    avx.load_u64(&new),
                    avx.load_u64(&old),
                )
            },
        );
        assert_eq!(got, want, "round {round} width {W}: idx {idx:?} on {on:?}");
    }
    // Out of range (len, u32::MAX as -1, i32::MIN): a panic, and the table untouched.
    for bad in [5i32, -1, i32::MIN] {
        let mut table = vec![7u64; 5];
        let mut idx = [0i32; W];
        idx[W / 2] = bad;
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            avx.run(
                #[inline(always)]
                || {
                    avx.store_u64_at(
                        &mut table,
                        avx.load_i32(&idx),
                        avx.mask(&[true; W]),
                        avx.load_u64(&[1; W]),
                        avx.load_u64(&[2; W]),
                    )
                },
            )
        }));
        assert!(result.is_err(), "index {bad} width {W} did not panic");
        assert_eq!(table, vec![7u64; 5], "index {bad} width {W} stored");
    }
}

crate::at_8_and_16!(store_u64_at_8, store_u64_at_16, "store_u64_at", check);
