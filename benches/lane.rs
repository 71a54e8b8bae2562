//! Throughput of the lane kernels (`groove::lane`, issue 16 item 2) at width 1 and width 8:
//! the polynomial functions, a frame round trip, GGX visible-normal sampling with its density,
//! and PCG32 draws. Every benchmark runs one function over the same 4096 inputs (SoA arrays),
//! so criterion's throughput is elements per second; `w1` is the scalar width, `w8` the AVX2
//! width inside `Avx2::run` (skipped, with a message, on a CPU without AVX2/FMA).
//! Run: `cargo bench --bench lane` (a filter such as `-- sin` picks functions).

use criterion::{black_box, criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use groove::bsdf::MicrofacetType;
#[cfg(target_arch = "x86_64")]
use groove::lane::batch::{map1_avx2, map2_avx2};
use groove::lane::batch::{map1_scalar, map2_scalar};
use groove::lane::frame::Frame;
use groove::lane::microfacet::Microfacet;
use groove::lane::pcg::Pcg;
use groove::lane::vec::{V2, V3};
use groove::lane::{fresnel, math, warp, Lane};
use groove::math::Pcg32;
use std::time::Duration;

const N: usize = 4096;

/// Inputs: `k` arrays of N floats in [lo, hi).
fn inputs(k: usize, lo: f32, hi: f32) -> Vec<Vec<f32>> {
    let mut r = Pcg32::new(1, 2);
    (0..k)
        .map(|_| (0..N).map(|_| lo + (hi - lo) * r.next_f32()).collect())
        .collect()
}

/// A frame built from a normal, then a vector to local and back (9 inputs per element:
/// the normal's three components are normalised by the kernel).
#[inline(always)]
fn frame_kernel<L: Lane>(x: [L; 6]) -> L {
    let n = V3::new(x[0], x[1], x[2]).normalize();
    let f = Frame::from_normal(n);
    let v = f.to_world(f.to_local(V3::new(x[3], x[4], x[5])));
    v.x + v.y + v.z
}

/// GGX visible-normal sample and its density.
#[inline(always)]
fn ggx_kernel<L: Lane>(x: [L; 6]) -> L {
    let d = Microfacet::new(MicrofacetType::Ggx, x[5], x[5], true);
    let wi = V3::new(x[0], x[1], x[2].abs()).normalize();
    let m = d.sample_visible_ggx(wi, V2::new(x[3], x[4]));
    d.pdf(wi, m)
}

/// A 6-input kernel over SoA arrays at width 1.
fn run6_w1(x: &[Vec<f32>], out: &mut [f32], f: impl Fn([f32; 6]) -> f32) {
    for (i, o) in out.iter_mut().enumerate() {
        *o = f(std::array::from_fn(|k| x[k][i]));
    }
}

fn bench(c: &mut Criterion) {
    #[cfg(target_arch = "x86_64")]
    let avx = groove::lane::Avx2::detect();
    #[cfg(target_arch = "x86_64")]
    if avx.is_none() {
        eprintln!("lane bench: this CPU has no AVX2/FMA, width 8 skipped");
    }
    let mut out = vec![0.0f32; N];

    // Function items, not pointers, so that each kernel inlines into its loop.
    macro_rules! bench1 {
        ($name:expr, $lo:expr, $hi:expr, $f:path) => {{
            let x = inputs(1, $lo, $hi);
            let mut g = c.benchmark_group(format!("lane/{}", $name));
            g.throughput(Throughput::Elements(N as u64));
            g.bench_function(BenchmarkId::new("w1", N), |b| {
                b.iter(|| map1_scalar(black_box(&x[0]), &mut out, $f))
            });
            #[cfg(target_arch = "x86_64")]
            if let Some(avx) = avx {
                g.bench_function(BenchmarkId::new("w8", N), |b| {
                    b.iter(|| map1_avx2(avx, black_box(&x[0]), &mut out, $f, $f))
                });
            }
            g.finish();
        }};
    }
    macro_rules! bench2 {
        ($name:expr, $f:path) => {{
            let x = inputs(2, 0.01, 10.0);
            let mut g = c.benchmark_group(format!("lane/{}", $name));
            g.throughput(Throughput::Elements(N as u64));
            g.bench_function(BenchmarkId::new("w1", N), |b| {
                b.iter(|| map2_scalar(black_box(&x[0]), &x[1], &mut out, $f))
            });
            #[cfg(target_arch = "x86_64")]
            if let Some(avx) = avx {
                g.bench_function(BenchmarkId::new("w8", N), |b| {
                    b.iter(|| map2_avx2(avx, black_box(&x[0]), &x[1], &mut out, $f, $f))
                });
            }
            g.finish();
        }};
    }
    bench1!("sin", -7.0, 7.0, math::sin);
    bench1!("exp", -80.0, 80.0, math::exp);
    bench1!("log", 1e-6, 1e6, math::log);
    bench1!("acos", -1.0, 1.0, math::acos);
    bench2!("atan2", math::atan2);
    bench2!("pow", math::pow);
    {
        // libm's sinf at width 1, for scale.
        let x = inputs(1, -7.0, 7.0);
        let mut g = c.benchmark_group("lane/libm_sin");
        g.throughput(Throughput::Elements(N as u64));
        g.bench_function(BenchmarkId::new("w1", N), |b| {
            b.iter(|| map1_scalar(black_box(&x[0]), &mut out, f32::sin))
        });
        g.finish();
    }

    for (name, kernel) in [("frame", 0usize), ("ggx_sample_pdf", 1usize)] {
        let x = inputs(6, 0.01, 1.0);
        let mut g = c.benchmark_group(format!("lane/{name}"));
        g.throughput(Throughput::Elements(N as u64));
        g.bench_function(BenchmarkId::new("w1", N), |b| {
            b.iter(|| {
                if kernel == 0 {
                    run6_w1(black_box(&x), &mut out, frame_kernel::<f32>)
                } else {
                    run6_w1(black_box(&x), &mut out, ggx_kernel::<f32>)
                }
            })
        });
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = avx {
            g.bench_function(BenchmarkId::new("w8", N), |b| {
                b.iter(|| {
                    let x = black_box(&x);
                    avx.run(
                        #[inline(always)]
                        || {
                            for (i, o) in out.chunks_exact_mut(8).enumerate() {
                                let v: [groove::lane::F32x8; 6] = std::array::from_fn(
                                    #[inline(always)]
                                    |k| avx.load(x[k][8 * i..8 * i + 8].try_into().expect("8")),
                                );
                                let r = if kernel == 0 {
                                    frame_kernel(v)
                                } else {
                                    ggx_kernel(v)
                                };
                                r.store(o.try_into().expect("8"));
                            }
                        },
                    )
                })
            });
        }
        g.finish();
    }

    let mut g = c.benchmark_group("lane/pcg_next_f32");
    g.throughput(Throughput::Elements(N as u64));
    g.bench_function(BenchmarkId::new("w1", N), |b| {
        let mut p: Vec<Pcg<f32>> = (0..8).map(|i| Pcg::new(i, 2 * i + 1)).collect();
        b.iter(|| {
            for (i, o) in out.iter_mut().enumerate() {
                *o = p[i & 7].next_f32();
            }
        })
    });
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = avx {
        let seeds: [u64; 8] = std::array::from_fn(|i| i as u64);
        let streams: [u64; 8] = std::array::from_fn(|i| 2 * i as u64 + 1);
        let mut p = Pcg::<groove::lane::F32x8>::new(avx.load_u64(&seeds), avx.load_u64(&streams));
        g.bench_function(BenchmarkId::new("w8", N), |b| {
            b.iter(|| {
                avx.run(
                    #[inline(always)]
                    || {
                        for o in out.chunks_exact_mut(8) {
                            p.next_f32().store(o.try_into().expect("8"));
                        }
                    },
                )
            })
        });
    }
    g.finish();
}

fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_millis(1000))
        .sample_size(20)
}

// Width 16 (AVX-512, experimental) against width 8 (AVX2) on the same batch work (twelfth
// session, h7): groups `lane16/<kernel>` with `w8` and `w16` over the same N elements, 6 SoA
// input arrays in [0.01, 1), each kernel mapping them to its domain.

/// `out = f(x)` over chunks of `W` lanes of the SoA arrays `x` (N a multiple of 16), with
/// `tok` the width's token (its `load`). A macro, not a function taking closures: a closure or
/// function item passed as `impl Fn` is called through a `Fn::call` shim that LLVM may leave out
/// of line, and the shim is compiled without the SIMD function's target features, so every
/// intrinsic in it became a call (the 8-wide warps ran ~90x slower than the 16-wide ones until
/// this was a macro; `array::from_fn` has the same trap).
macro_rules! soa_w {
    ($w:literal, $tok:expr, $x:expr, $out:expr, $f:path) => {{
        let (x, tok) = ($x, $tok);
        for (i, o) in $out.chunks_exact_mut($w).enumerate() {
            let at = |k: usize| -> &[f32; $w] { x[k][$w * i..$w * i + $w].try_into().expect("W") };
            let v = [
                tok.load(at(0)),
                tok.load(at(1)),
                tok.load(at(2)),
                tok.load(at(3)),
                tok.load(at(4)),
                tok.load(at(5)),
            ];
            $f(v).store(o.try_into().expect("W"));
        }
    }};
}

#[inline(always)]
fn k_sincos<L: Lane>(x: [L; 6]) -> L {
    let (s, c) = math::sincos(x[0] * x[0].splat(14.0) - x[0].splat(7.0));
    s + c
}
#[inline(always)]
fn k_exp<L: Lane>(x: [L; 6]) -> L {
    math::exp(x[0] * x[0].splat(160.0) - x[0].splat(80.0))
}
#[inline(always)]
fn k_log<L: Lane>(x: [L; 6]) -> L {
    math::log(x[0] * x[1] * x[2])
}
#[inline(always)]
fn k_pow<L: Lane>(x: [L; 6]) -> L {
    math::pow(
        x[0] * x[0].splat(4.0),
        x[1] * x[1].splat(8.0) - x[1].splat(4.0),
    )
}
#[inline(always)]
fn k_atan2<L: Lane>(x: [L; 6]) -> L {
    let h = x[0].splat(0.5);
    math::atan2(x[0] - h, x[1] - h)
}
#[inline(always)]
fn k_ggx_eval<L: Lane>(x: [L; 6]) -> L {
    let d = Microfacet::new(MicrofacetType::Ggx, x[5], x[5], true);
    let wi = V3::new(x[3], x[4], x[2]).normalize();
    let m = V3::new(x[0], x[1], x[2]).normalize();
    d.eval(m) * d.smith_g1(wi, m)
}
#[inline(always)]
fn k_fresnel<L: Lane>(x: [L; 6]) -> L {
    let one = x[0].splat(1.0);
    let d = fresnel::dielectric(x[0] + x[0] - one, x[1] + one);
    let c = fresnel::conductor_1(x[0], x[4] + x[4] + one, x[5] + x[5] + x[5]);
    d.r + c
}
#[inline(always)]
fn k_warps<L: Lane>(x: [L; 6]) -> L {
    let u = V2::new(x[0], x[1]);
    let h = warp::square_to_cosine_hemisphere(u);
    let s = warp::square_to_uniform_sphere(u);
    let c = warp::square_to_uniform_cone(u, x[2]);
    h.z + s.x + c.y + warp::cosine_hemisphere_pdf(h)
}

fn bench_wide(c: &mut Criterion) {
    #[cfg(target_arch = "x86_64")]
    {
        use groove::lane::{Avx2, Avx512, F32x16, F32x8};
        let (Some(a8), Some(a16)) = (Avx2::detect(), Avx512::detect()) else {
            eprintln!("lane16 bench: this CPU has no AVX-512 (or AVX2), skipped");
            return;
        };
        let x = inputs(6, 0.01, 1.0);
        let mut out = vec![0.0f32; N];
        macro_rules! wide {
            ($name:expr, $f:ident) => {{
                let mut g = c.benchmark_group(format!("lane16/{}", $name));
                g.throughput(Throughput::Elements(N as u64));
                g.bench_function(BenchmarkId::new("w8", N), |b| {
                    b.iter(|| {
                        a8.run(
                            #[inline(always)]
                            || soa_w!(8, a8, black_box(&x), &mut out, $f::<F32x8>),
                        )
                    })
                });
                g.bench_function(BenchmarkId::new("w16", N), |b| {
                    b.iter(|| {
                        a16.run(
                            #[inline(always)]
                            || soa_w!(16, a16, black_box(&x), &mut out, $f::<F32x16>),
                        )
                    })
                });
                g.finish();
            }};
        }
        wide!("sincos", k_sincos);
        wide!("exp", k_exp);
        wide!("log", k_log);
        wide!("pow", k_pow);
        wide!("atan2", k_atan2);
        wide!("ggx_eval_g1", k_ggx_eval);
        wide!("ggx_sample_pdf", ggx_kernel);
        wide!("fresnel", k_fresnel);
        wide!("warps", k_warps);
        wide!("frame", frame_kernel);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = c;
}

criterion_group! {
    name = benches;
    config = config();
    targets = bench, bench_wide
}
criterion_main!(benches);
