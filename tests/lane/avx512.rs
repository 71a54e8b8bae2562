//! Width 16 (the experimental AVX-512 `F32x16`) equals width 1 bit for bit in every lane, for
//! the maths the kernels use most: the polynomials, vectors, frames, warps, Fresnel, microfacets
//! and PCG32. The kernels are those of `bits` (written once, generic over the width); the inputs
//! are drawn as there (random bit patterns, the function's domain, every edge case in every lane
//! position of the first batch). Skipped, with a note, on a CPU without AVX-512.

use crate::bits::{
    Acos, Atan2, BeckmannAll, BeckmannVisible, Exp, FrameNormal, FrameTangent, Fresnel, GgxAll,
    GgxConcentric, GgxVisible, Log, Pow, ReflectionPdf, Sincos, VecOps, Warps,
};
use crate::harness::{count, count_composite, log_uniform, mixed, same, uniform, Kernel, EDGES};
use groove::math::Pcg32;

#[cfg(target_arch = "x86_64")]
use groove::lane::{Avx512, F32x16};

/// The token, or a printed note and `None` when the CPU lacks AVX-512.
#[cfg(target_arch = "x86_64")]
fn token(name: &str) -> Option<Avx512> {
    let t = Avx512::detect();
    if t.is_none() {
        eprintln!("{name}: this CPU has no AVX-512 F/DQ/BW/VL, skipping the 16-wide check");
    }
    t
}

/// Runs `K` on `n` inputs from `gen` at width 1 and width 16, lane by lane different inputs,
/// and fails on the first differing bits with the inputs that gave them.
fn check16<K: Kernel<I, O>, const I: usize, const O: usize>(
    name: &str,
    n: usize,
    gen: impl Fn(&mut Pcg32) -> [f32; I],
) {
    #[cfg(target_arch = "x86_64")]
    {
        let Some(avx) = token(name) else { return };
        const BATCH: usize = 4096;
        let seed = name.bytes().fold(0x8422_2325_cbf2_9ce4u64, |h, b| {
            (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
        });
        let mut rng = Pcg32::new(seed, 13);
        let mut xs: Vec<[f32; I]> = vec![[0.0; I]; BATCH];
        let mut o1: Vec<[f32; O]> = vec![[0.0; O]; BATCH];
        let mut o16: Vec<[f32; O]> = vec![[0.0; O]; BATCH];
        let mut done = 0;
        let mut first = true;
        while done < n {
            for (j, x) in xs.iter_mut().enumerate() {
                *x = gen(&mut rng);
                // The first batch pairs every edge case with every input and every lane
                // position (chunk k of 16, lane l: input k mod I gets edge k / I + l), as far
                // as 4096 inputs reach (all of it for up to 7 inputs).
                let (k, l) = (j / 16, j % 16);
                if first && k < EDGES.len() * I {
                    x[k % I] = EDGES[(k / I + l) % EDGES.len()];
                }
            }
            first = false;
            for (x, o) in xs.iter().zip(o1.iter_mut()) {
                *o = K::run::<f32>(*x);
            }
            avx.run(
                #[inline(always)]
                || {
                    for (xc, oc) in xs.chunks_exact(16).zip(o16.chunks_exact_mut(16)) {
                        let v: [F32x16; I] =
                            std::array::from_fn(|i| avx.load(&std::array::from_fn(|l| xc[l][i])));
                        let r = K::run(v);
                        for (i, ri) in r.iter().enumerate() {
                            let a = ri.to_array();
                            for l in 0..16 {
                                oc[l][i] = a[l];
                            }
                        }
                    }
                },
            );
            for j in 0..BATCH {
                for i in 0..O {
                    assert!(
                        same(o1[j][i], o16[j][i]),
                        "{name}: output {i} differs in lane {}: width 1 {:e} ({:#010x}), \
                         width 16 {:e} ({:#010x}); inputs {:?}",
                        j % 16,
                        o1[j][i],
                        o1[j][i].to_bits(),
                        o16[j][i],
                        o16[j][i].to_bits(),
                        xs[j].map(f32::to_bits)
                    );
                }
            }
            done += BATCH;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (name, n, gen);
        eprintln!("{name}: not x86-64, skipping the 16-wide check");
    }
}

fn any(r: &mut Pcg32) -> f32 {
    mixed(r, &|r| uniform(r, -10.0, 10.0))
}
fn unit(r: &mut Pcg32) -> f32 {
    mixed(r, &|r| r.next_f32())
}
fn signed_unit(r: &mut Pcg32) -> f32 {
    mixed(r, &|r| uniform(r, -1.0, 1.0))
}
/// A unit normal, one in eight arbitrary.
fn normal(r: &mut Pcg32) -> [f32; 3] {
    if r.next_u32() & 7 == 0 {
        return [any(r), any(r), any(r)];
    }
    glam::Vec3::new(
        uniform(r, -1.0, 1.0),
        uniform(r, -1.0, 1.0),
        uniform(r, -1.0, 1.0),
    )
    .normalize_or(glam::Vec3::Z)
    .to_array()
}
/// wi (3), m (3), u (2), alpha_u, alpha_v, as `bits`.
fn microfacet_inputs(r: &mut Pcg32) -> [f32; 10] {
    let wi = normal(r);
    let m = normal(r);
    [
        wi[0],
        wi[1],
        wi[2].abs(),
        m[0],
        m[1],
        m[2],
        unit(r),
        unit(r),
        mixed(r, &|r| uniform(r, 0.0, 1.0)),
        mixed(r, &|r| uniform(r, 0.0, 1.0)),
    ]
}

#[test]
fn math16() {
    let n = count() / 4;
    check16::<Sincos, 1, 2>("sincos16", n, |r| {
        [mixed(r, &|r| {
            if r.next_u32() & 1 == 0 {
                uniform(r, -7.0, 7.0)
            } else {
                log_uniform(r, -30, 30, true)
            }
        })]
    });
    check16::<Exp, 1, 1>("exp16", n, |r| [mixed(r, &|r| uniform(r, -110.0, 95.0))]);
    check16::<Log, 1, 1>("log16", n, |r| {
        [mixed(r, &|r| log_uniform(r, -149, 128, false))]
    });
    check16::<Pow, 2, 1>("pow16", n, |r| {
        let x = mixed(r, &|r| {
            let neg = r.next_u32() & 7 == 0;
            log_uniform(r, -20, 20, neg)
        });
        let y = mixed(r, &|r| uniform(r, -8.0, 8.0));
        [x, y]
    });
    check16::<Acos, 1, 1>("acos16", n, |r| [signed_unit(r)]);
    check16::<Atan2, 2, 1>("atan2_16", n, |r| [any(r), any(r)]);
    // Random bit patterns only (every float class, NaN payloads, denormals).
    check16::<Sincos, 1, 2>("sincos16_bits", n, |r| [f32::from_bits(r.next_u32())]);
    check16::<Pow, 2, 1>("pow16_bits", n, |r| {
        [f32::from_bits(r.next_u32()), f32::from_bits(r.next_u32())]
    });
}

#[test]
fn vec_frame_warp16() {
    let n = count_composite();
    check16::<VecOps, 6, 10>("vec16", n, |r| std::array::from_fn(|_| any(r)));
    let frame = |r: &mut Pcg32| {
        let n = normal(r);
        [n[0], n[1], n[2], any(r), any(r), any(r)]
    };
    check16::<FrameNormal, 6, 15>("frame16", n, frame);
    check16::<FrameTangent, 6, 6>("frame_tangent16", n, frame);
    check16::<Warps, 3, 17>("warps16", n, |r| [unit(r), unit(r), signed_unit(r)]);
}

#[test]
fn fresnel16() {
    check16::<Fresnel, 6, 8>("fresnel16", count_composite(), |r| {
        let mut a = [signed_unit(r), 0.0, 0.0, 0.0, 0.0, 0.0];
        for v in &mut a[1..] {
            *v = mixed(r, &|r| uniform(r, 0.0, 4.0));
        }
        a
    });
}

#[test]
fn microfacet16() {
    let n = count_composite();
    check16::<GgxVisible, 10, 11>("ggx_visible16", n, microfacet_inputs);
    check16::<GgxAll, 10, 11>("ggx_all16", n, microfacet_inputs);
    check16::<BeckmannAll, 10, 11>("beckmann_all16", n, microfacet_inputs);
    check16::<BeckmannVisible, 10, 11>("beckmann_visible16", n, microfacet_inputs);
    check16::<GgxConcentric, 10, 3>("ggx_concentric16", n, microfacet_inputs);
    check16::<ReflectionPdf, 10, 2>("reflection_pdf16", n, microfacet_inputs);
}

/// PCG32 per lane at width 16 (`vpmullq`, `vprorvd`, `vpmovqd`) equals sixteen scalar
/// generators (seeds and streams random, one stream all ones).
#[test]
fn pcg16() {
    #[cfg(target_arch = "x86_64")]
    {
        use groove::lane::pcg::Pcg;
        let Some(avx) = token("pcg16") else { return };
        let mut r = Pcg32::new(7, 5);
        let draws = 64;
        for _ in 0..count() / (16 * 2 * draws * 4) {
            let seeds: [u64; 16] =
                std::array::from_fn(|_| (r.next_u32() as u64) << 32 | r.next_u32() as u64);
            let streams: [u64; 16] = std::array::from_fn(|i| {
                if i == 9 {
                    u64::MAX
                } else {
                    (r.next_u32() as u64) << 32 | r.next_u32() as u64
                }
            });
            let mut one: Vec<Pcg<f32>> = (0..16).map(|i| Pcg::new(seeds[i], streams[i])).collect();
            let (u, f) = avx.run(
                #[inline(always)]
                || {
                    let mut p = Pcg::<F32x16>::new(avx.load_u64(&seeds), avx.load_u64(&streams));
                    let mut u = Vec::with_capacity(draws);
                    let mut f = Vec::with_capacity(draws);
                    for _ in 0..draws {
                        u.push(p.next_u32().to_array());
                        f.push(p.next_f32().to_array());
                    }
                    (u, f)
                },
            );
            for d in 0..draws {
                for l in 0..16 {
                    assert_eq!(u[d][l], one[l].next_u32(), "draw {d} lane {l}");
                    let g = one[l].next_f32();
                    assert_eq!(f[d][l].to_bits(), g.to_bits(), "draw {d} lane {l}");
                }
            }
        }
    }
}

/// The mask type and the integer lanes where the kernels above touch them only indirectly:
/// masks from booleans, any/all, and the integer compares/selects/shifts against `i32`.
#[test]
fn ints_and_masks16() {
    #[cfg(target_arch = "x86_64")]
    {
        use groove::lane::{Lane, LaneI32, LaneMask};
        let Some(avx) = token("ints16") else { return };
        let mut r = Pcg32::new(3, 9);
        for _ in 0..2000 {
            let a: [i32; 16] = std::array::from_fn(|_| r.next_u32() as i32);
            let b: [i32; 16] = std::array::from_fn(|i| {
                if i % 5 == 0 {
                    a[i]
                } else {
                    r.next_u32() as i32
                }
            });
            let bools: [bool; 16] = std::array::from_fn(|_| r.next_u32() & 1 == 1);
            let got = avx.run(|| {
                let (x, y) = (avx.load_i32(&a), avx.load_i32(&b));
                let m = avx.mask(&bools);
                (
                    x.eq(y).to_array(),
                    x.gt(y).to_array(),
                    I32x16Sel::select(m, x, y),
                    x.shl::<7>().to_array(),
                    x.shr::<13>().to_array(),
                    x.sar::<31>().to_array(),
                    x.rotate_right(y).to_array(),
                    x.andnot(y).to_array(),
                    x.to_f32().to_array(),
                    (m.any(), m.all(), (!m).to_array()),
                    F32x16::from_bits(x).round_i32().to_array(),
                    F32x16::from_bits(x).trunc_i32().to_array(),
                )
            });
            for l in 0..16 {
                let (x, y) = (a[l], b[l]);
                assert_eq!(got.0[l], x == y);
                assert_eq!(got.1[l], x > y);
                assert_eq!(got.2[l], if bools[l] { x } else { y });
                assert_eq!(got.3[l], x.wrapping_shl(7));
                assert_eq!(got.4[l], ((x as u32) >> 13) as i32);
                assert_eq!(got.5[l], x >> 31);
                assert_eq!(got.6[l], (x as u32).rotate_right(y as u32 & 31) as i32);
                assert_eq!(got.7[l], x & !y);
                assert!(same(got.8[l], LaneI32::to_f32(x)));
                assert_eq!(got.9 .2[l], !bools[l]);
                let f = f32::from_bits(x as u32);
                assert_eq!(got.10[l], Lane::round_i32(f), "{f:e}");
                assert_eq!(got.11[l], Lane::trunc_i32(f), "{f:e}");
            }
            assert_eq!(got.9 .0, bools.iter().any(|&b| b));
            assert_eq!(got.9 .1, bools.iter().all(|&b| b));
        }
    }
}

/// `LaneI32::select` returning an array (so the tuple above stays plain data).
#[cfg(target_arch = "x86_64")]
struct I32x16Sel;
#[cfg(target_arch = "x86_64")]
impl I32x16Sel {
    #[inline(always)]
    fn select(m: groove::lane::M16, a: groove::lane::I32x16, b: groove::lane::I32x16) -> [i32; 16] {
        <groove::lane::I32x16 as groove::lane::LaneI32>::select(m, a, b).to_array()
    }
}

/// `Avx512::ray_fields16` puts field f of ray i in lane i of its f-th vector, every bit kept
/// (random bit patterns, NaNs and signed zeros included), and its mask's `bits` are its lanes.
#[test]
fn ray_fields16_transposes_sixteen_rays() {
    #[cfg(target_arch = "x86_64")]
    {
        use groove::geometry::Ray;
        use groove::lane::Lane;
        let Some(avx) = token("ray_fields16") else {
            return;
        };
        let mut rng = Pcg32::new(16, 8);
        for _ in 0..64 {
            let rays: [Ray; 16] = core::array::from_fn(|_| {
                let mut f = || f32::from_bits(rng.next_u32());
                let v = |a, b, c| glam::Vec3::new(a, b, c);
                Ray {
                    o: v(f(), f(), f()),
                    d: v(f(), f(), f()),
                    tmin: f(),
                    tmax: f(),
                }
            });
            let got = avx.run(|| avx.ray_fields16(&rays).map(F32x16::to_array));
            for (i, r) in rays.iter().enumerate() {
                let want = [r.o.x, r.o.y, r.o.z, r.d.x, r.d.y, r.d.z, r.tmin, r.tmax];
                for (f, w) in want.iter().enumerate() {
                    assert_eq!(got[f][i].to_bits(), w.to_bits(), "ray {i} field {f}");
                }
            }
            let x = avx.load(&got[0]);
            let m = avx.run(|| x.lt(avx.splat(0.0)));
            let bits = (0..16).fold(0, |b, l| b | u32::from(got[0][l] < 0.0) << l);
            assert_eq!(m.bits(), bits);
        }
    }
}
