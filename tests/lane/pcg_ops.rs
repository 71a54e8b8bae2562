//! The PCG32 lane operations each width writes with its own instructions (`lane::pcg::PcgOps`:
//! the XSH-RR output and the gather of `u64` columns) equal a plain scalar reference bit for bit
//! in every lane, at width 1, 8 and 16 (the 16-wide half skipped, with a note, without
//! AVX-512), over every class of PCG state: 0, all ones, the high bit set, every rotation
//! (`s >> 59` from 0 to 31), single bits, and random states; then whole generators stepped
//! from such states against a scalar PCG32 written out here.

use groove::lane::pcg::{Pcg, PcgOps};
use groove::lane::wide::{ToArray, Wide};
use groove::math::Pcg32;

/// O'Neill's XSH-RR output of a 64-bit state, written out.
fn reference(s: u64) -> u32 {
    ((((s >> 18) ^ s) >> 27) as u32).rotate_right((s >> 59) as u32)
}

/// States of every class, `n` of them.
fn states(n: usize) -> Vec<u64> {
    let mut r = Pcg32::new(31, 17);
    let mut rnd = || (r.next_u32() as u64) << 32 | r.next_u32() as u64;
    let mut v = vec![
        0,
        u64::MAX,
        1 << 63,
        (1 << 63) - 1,
        1,
        0x5851_f42d_4c95_7f2d,
    ];
    v.extend((0..64).map(|b| 1u64 << b));
    v.extend((0..64).map(|b| !(1u64 << b)));
    for rot in 0..32u64 {
        v.push(rot << 59);
        v.push((rot << 59) | (rnd() >> 5));
        v.push((rot << 59) | ((1 << 59) - 1));
    }
    while v.len() < n {
        let x = rnd();
        v.push(match v.len() % 4 {
            0 => x | 1 << 63,
            1 => x & !(1 << 63),
            2 => x & 0xffff_ffff,
            _ => x,
        });
    }
    v
}

/// `xsh_rr` and `gather_u64` of width `W` against the reference, lane by lane, for every state
/// of `states` in every lane position, and gathers over random tables with indices in and out
/// of range (clamped to the last entry).
fn check<T: Wide<W>, const W: usize>(avx: T)
where
    T::U: PcgOps<T::I>,
{
    let s = states(20_000);
    for chunk in s.windows(W).step_by(3) {
        let a: [u64; W] = chunk.try_into().unwrap();
        let out = avx.run(
            #[inline(always)]
            || avx.load_u64(&a).xsh_rr().to_array(),
        );
        for k in 0..W {
            assert_eq!(
                out[k] as u32,
                reference(a[k]),
                "width {W} state {:#x}",
                a[k]
            );
            assert_eq!(
                a[k].xsh_rr() as u32,
                reference(a[k]),
                "width 1 state {:#x}",
                a[k]
            );
        }
    }
    let mut r = Pcg32::new(3, 8);
    for round in 0..2000 {
        let len = 1 + (r.next_u32() % 100) as usize;
        let table: Vec<u64> = (0..len).map(|j| s[(round * 7 + j) % s.len()]).collect();
        let mut idx = [0i32; W];
        for (k, i) in idx.iter_mut().enumerate() {
            *i = match (round + k) % 5 {
                0 => len as i32 - 1,
                1 => r.next_u32() as i32,
                2 => -(1 + (r.next_u32() % 4) as i32),
                _ => (r.next_u32() % len as u32) as i32,
            };
        }
        let got = avx.run(
            #[inline(always)]
            || T::U::gather_u64(&table, avx.load_i32(&idx)).to_array(),
        );
        for k in 0..W {
            let want = table[(idx[k] as u32 as usize).min(len - 1)];
            assert_eq!(got[k], want, "width {W} index {}", idx[k]);
            assert_eq!(
                u64::gather_u64(&table, idx[k]),
                want,
                "width 1 index {}",
                idx[k]
            );
        }
    }
    // Generators started from states of every class (increments odd, all ones among them),
    // 40 draws each, against a scalar PCG32 written out.
    for (c, chunk) in s.chunks_exact(W).enumerate().take(400) {
        let st: [u64; W] = chunk.try_into().unwrap();
        let inc: [u64; W] = std::array::from_fn(|k| s[(c * 13 + k * 7) % s.len()] | 1);
        let (u, f) = avx.run(
            #[inline(always)]
            || {
                let mut p = Pcg::<T::F>::from_parts(avx.load_u64(&st), avx.load_u64(&inc));
                let mut u = [[0i32; W]; 20];
                let mut f = [[0f32; W]; 20];
                for d in 0..20 {
                    u[d] = p.next_u32().to_array();
                    f[d] = p.next_f32().to_array();
                }
                (u, f)
            },
        );
        for k in 0..W {
            let mut state = st[k];
            let mut next = || {
                let old = state;
                state = old
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(inc[k]);
                reference(old)
            };
            let mut one = Pcg::<f32>::from_parts(st[k], inc[k]);
            for d in 0..20 {
                let want = next();
                assert_eq!(u[d][k] as u32, want, "width {W} draw {d}");
                assert_eq!(one.next_u32() as u32, want, "width 1 draw {d}");
                let want = (next() >> 8) as f32 / 16_777_216.0;
                assert_eq!(f[d][k].to_bits(), want.to_bits(), "width {W} draw {d}");
                assert_eq!(one.next_f32().to_bits(), want.to_bits(), "width 1 draw {d}");
            }
        }
    }
}

crate::at_8_and_16!(
    pcg_ops_equal_the_scalar_reference_8,
    pcg_ops_equal_the_scalar_reference_16,
    "pcg_ops",
    check
);

/// `Avx2::select_u64` (the compensated sampler's masked PCG32 steps) against a scalar
/// reference: every mask pattern, as bits (`mask_bits`) and from float compares with ±0, NaN
/// and ±∞ in the lanes, over states of every class (all ones, the high bit, 0) in both inputs.
#[test]
fn select_u64_equals_the_scalar_reference() {
    #[cfg(target_arch = "x86_64")]
    {
        use groove::lane::Lane;
        let Some(avx) = crate::harness::avx2_or_skip(
            "select_u64: this CPU has no AVX2/FMA, skipping the 8-wide check",
        ) else {
            return;
        };
        let s = states(4096);
        let edge = [
            0.0f32,
            -0.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            1.0,
        ];
        for bits in 0..256u32 {
            let a: [u64; 8] = std::array::from_fn(|k| s[(bits as usize * 8 + k) % s.len()]);
            let b: [u64; 8] =
                std::array::from_fn(|k| s[(bits as usize * 13 + 5 * k + 1) % s.len()]);
            let on: [bool; 8] = std::array::from_fn(|k| bits >> k & 1 == 1);
            let want: [u64; 8] = std::array::from_fn(|k| if on[k] { a[k] } else { b[k] });
            // The mask as bits, and the same lanes from a compare (`x < 0.5`: 0 where set,
            // an edge value at or above 0.5, or NaN, where not).
            let x: [f32; 8] = std::array::from_fn(|k| {
                let e = edge[(bits as usize + k) % edge.len()];
                match (on[k], e < 0.5) {
                    (true, true) | (false, false) => e,
                    (true, false) => 0.25,
                    (false, true) => 2.0,
                }
            });
            let (by_bits, by_cmp) = avx.run(
                #[inline(always)]
                || {
                    let (va, vb) = (avx.load_u64(&a), avx.load_u64(&b));
                    let m = avx.load(&x).lt(avx.splat(0.5));
                    (
                        avx.select_u64(avx.mask_bits(bits), va, vb).to_array(),
                        avx.select_u64(m, va, vb).to_array(),
                    )
                },
            );
            assert_eq!(by_bits, want, "mask bits {bits:#010b}");
            assert_eq!(by_cmp, want, "mask {bits:#010b} from {x:?}");
        }
    }
}
