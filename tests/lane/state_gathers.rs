//! `Avx2::gather_eta`, `Avx2::gather_throughput` and `Avx2::gather_depth` (8 path states'
//! index products, throughputs and depths: the stream renderer's vertex end, wrapper-chain
//! kernels and emission stage) against the fields read one by one: every bit moved (edge
//! floats: ±0, ±∞, NaN payloads, subnormals; depths 0, `u32::MAX` and random), indices inside,
//! at the ends of and out of the slice (clamped to its last state), a panic on an empty slice.

use crate::harness::edge_or_bits;
use groove::integrator::path::PathState;
use groove::math::Pcg32;

#[test]
fn state_gathers_read_each_field() {
    let Some(avx) = crate::harness::avx2_or_skip("no AVX2/FMA: the state gather test is skipped")
    else {
        return;
    };
    let mut r = Pcg32::new(29, 1);
    for len in [1usize, 2, 9, 1024] {
        let states: Vec<PathState> = (0..len)
            .map(|_| {
                let mut s = PathState::new();
                s.throughput = glam::Vec3::new(
                    edge_or_bits(&mut r),
                    edge_or_bits(&mut r),
                    edge_or_bits(&mut r),
                );
                s.eta = edge_or_bits(&mut r);
                s.depth = match r.next_u32() % 4 {
                    0 => 0,
                    1 => u32::MAX,
                    _ => r.next_u32(),
                };
                s.result = glam::Vec3::splat(edge_or_bits(&mut r));
                s
            })
            .collect();
        for round in 0..200 {
            let idx: [i32; 8] = std::array::from_fn(|k| match (round + k) % 7 {
                0 => 0,
                1 => len as i32 - 1,
                2 => len as i32,
                3 => -1,
                4 => i32::MIN,
                _ => (r.next_u32() as usize % len) as i32,
            });
            let (eta, [x, y, z], depth) = avx.run(
                #[inline(always)]
                || {
                    let i = avx.load_i32(&idx);
                    let t = avx.gather_throughput(&states, i);
                    (
                        avx.gather_eta(&states, i).to_array(),
                        t.map(|c| c.to_array()),
                        avx.gather_depth(&states, i).to_array(),
                    )
                },
            );
            for k in 0..8 {
                // Out of range (as u32): the last state.
                let s = &states[(idx[k] as u32 as usize).min(len - 1)];
                let ctx = format!("len {len} round {round} lane {k}");
                assert_eq!(eta[k].to_bits(), s.eta.to_bits(), "{ctx}");
                assert_eq!(x[k].to_bits(), s.throughput.x.to_bits(), "{ctx}");
                assert_eq!(y[k].to_bits(), s.throughput.y.to_bits(), "{ctx}");
                assert_eq!(z[k].to_bits(), s.throughput.z.to_bits(), "{ctx}");
                assert_eq!(depth[k] as u32, s.depth, "{ctx}");
            }
        }
    }
    for f in [0, 1, 2] {
        let result = std::panic::catch_unwind(|| {
            avx.run(
                #[inline(always)]
                || {
                    let i = avx.load_i32(&[0; 8]);
                    match f {
                        0 => avx.gather_eta(&[], i).to_array()[0],
                        1 => avx.gather_throughput(&[], i)[0].to_array()[0],
                        _ => avx.gather_depth(&[], i).to_array()[0] as f32,
                    }
                },
            )
        });
        assert!(result.is_err(), "an empty slice: no panic ({f})");
    }
}
