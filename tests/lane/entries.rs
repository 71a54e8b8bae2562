//! The 8 entries of a column at 8 ids with one bounds check (`Avx2::entries_at`,
//! `Avx2::for_each_at_mut`: the emission stage's path states of a full chunk) against plain
//! indexing: random, repeated and edge ids (0, the last entry, the length, `u32::MAX`), and the
//! panic of `for_each_at_mut` before anything is written. Skipped, with a note, without AVX2.

#[cfg(target_arch = "x86_64")]
use groove::math::Pcg32;

#[test]
fn entries_at_eight_ids_equal_indexing() {
    #[cfg(target_arch = "x86_64")]
    {
        let Some(avx) = crate::harness::avx2_or_skip("entries: this CPU has no AVX2/FMA, skipping")
        else {
            return;
        };
        let mut r = Pcg32::new(41, 5);
        for round in 0..50_000 {
            let len = (r.next_u32() % 40) as usize;
            let items: Vec<u64> = (0..len).map(|i| (i as u64) << 32 | round).collect();
            let ids: [u32; 8] = core::array::from_fn(|_| match r.next_u32() % 8 {
                0 => len as u32,
                1 => u32::MAX,
                2 => (len as u32).wrapping_sub(1),
                3 => 0,
                _ => r.next_u32() % (len as u32 + 1).max(1),
            });
            let inside = ids.iter().all(|&i| (i as usize) < len);
            let got = avx.run(
                #[inline(always)]
                || avx.entries_at(&items, &ids).map(|e| e.map(|x| *x)),
            );
            let want = inside.then(|| ids.map(|i| items[i as usize]));
            assert_eq!(got, want, "round {round}, ids {ids:?}, len {len}");

            // The writes: each id's entry gets its lanes' values in lane order (the panic
            // checked on a few rounds only: each prints its message).
            if !inside && round % 2000 != 0 {
                continue;
            }
            let mut col = items.clone();
            let done = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                avx.run(
                    #[inline(always)]
                    || {
                        avx.for_each_at_mut(
                            &mut col,
                            &ids,
                            #[inline(always)]
                            |k, e| *e = e.wrapping_mul(3).wrapping_add(k as u64),
                        )
                    },
                )
            }));
            let mut want = items.clone();
            if inside {
                for (k, &i) in ids.iter().enumerate() {
                    let e = &mut want[i as usize];
                    *e = e.wrapping_mul(3).wrapping_add(k as u64);
                }
            }
            assert_eq!(
                done.is_ok(),
                inside,
                "round {round}, ids {ids:?}, len {len}"
            );
            assert_eq!(col, want, "round {round}, ids {ids:?}, len {len}");
        }
    }
}
