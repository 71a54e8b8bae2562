//! Shared test machinery: kernels written once and run at both widths, input generators, and
//! the bit comparison.

use groove::lane::Lane;
use groove::math::Pcg32;

/// A function of `I` float lanes to `O` float lanes, generic over the width.
pub trait Kernel<const I: usize, const O: usize> {
    fn run<L: Lane>(x: [L; I]) -> [L; O];
}

/// `kernel!(Name, I, O, |x| body)` defines a unit struct implementing [`Kernel`].
#[macro_export]
macro_rules! kernel {
    ($name:ident, $i:literal, $o:literal, |$x:ident| $body:expr) => {
        pub struct $name;
        impl $crate::harness::Kernel<$i, $o> for $name {
            #[inline(always)]
            fn run<L: groove::lane::Lane>($x: [L; $i]) -> [L; $o] {
                $body
            }
        }
    };
}

/// `at_8_and_16!(test8, test16, "label", check)` defines two tests that run `check(avx)` at
/// width 8 (AVX2/FMA) and at width 16 (AVX-512), each saying so and passing on a CPU without
/// those lanes.
#[macro_export]
macro_rules! at_8_and_16 {
    ($t8:ident, $t16:ident, $label:literal, $check:ident) => {
        #[test]
        fn $t8() {
            #[cfg(target_arch = "x86_64")]
            {
                let Some(avx) = $crate::harness::avx2_or_skip(concat!(
                    $label,
                    " 8: this CPU has no AVX2/FMA, skipping the 8-wide check"
                )) else {
                    return;
                };
                $check(avx);
            }
        }

        #[test]
        fn $t16() {
            #[cfg(target_arch = "x86_64")]
            {
                let Some(avx) = groove::lane::Avx512::detect() else {
                    eprintln!(concat!(
                        $label,
                        " 16: this CPU has no AVX-512 F/DQ/BW/VL, skipping the 16-wide check"
                    ));
                    return;
                };
                $check(avx);
            }
        }
    };
}

/// Inputs per polynomial function and for PCG32 (`GROOVE_LANE_N`, default 10⁷).
pub fn count() -> usize {
    std::env::var("GROOVE_LANE_N")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10_000_000)
}

/// Inputs per composite kernel (vectors, frames, warps, Fresnel, microfacets), which are built
/// from the operations and polynomials tested at [`count`]: 2·10⁵ by default (to keep the
/// default run to a few seconds), all of `GROOVE_LANE_N` when it is set.
pub fn count_composite() -> usize {
    if std::env::var("GROOVE_LANE_N").is_ok() {
        count()
    } else {
        count() / 50
    }
}

/// Same bits, or both NaN (Rust does not specify NaN payloads).
pub fn same(a: f32, b: f32) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

/// Edge cases every generator mixes in.
pub const EDGES: [f32; 36] = [
    0.0,
    -0.0,
    1.0,
    -1.0,
    0.5,
    -0.5,
    2.0,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::NAN,
    -f32::NAN,
    f32::MIN_POSITIVE,
    -f32::MIN_POSITIVE,
    1e-45,
    -1e-45,
    1e-40,
    -3e-39,
    f32::MAX,
    f32::MIN,
    1e30,
    -1e30,
    1e10,
    16_777_216.0,
    2_147_483_648.0,
    std::f32::consts::PI,
    std::f32::consts::FRAC_PI_2,
    std::f32::consts::FRAC_PI_4,
    88.722_83,
    88.8,
    -103.9,
    -87.5,
    -150.0,
    f32::EPSILON,
    1.0 - f32::EPSILON / 2.0,
    0.999_999_9,
    6434.0,
];

/// A third of the time an edge case of [`EDGES`], else a random bit pattern (every float
/// class, NaN payloads among them): the inputs of the lane tests that check bits moved as they
/// are (gathers, row loads, permutes).
pub fn edge_or_bits(r: &mut Pcg32) -> f32 {
    match r.next_u32() % 3 {
        0 => EDGES[r.next_u32() as usize % EDGES.len()],
        _ => f32::from_bits(r.next_u32()),
    }
}

/// One input: a quarter random bit patterns (every float class), an eighth edge cases, the
/// rest from `domain`.
pub fn mixed(r: &mut Pcg32, domain: &impl Fn(&mut Pcg32) -> f32) -> f32 {
    match r.next_u32() & 7 {
        0 | 1 => f32::from_bits(r.next_u32()),
        2 => EDGES[(r.next_u32() as usize) % EDGES.len()],
        _ => domain(r),
    }
}

/// Uniform in [lo, hi).
pub fn uniform(r: &mut Pcg32, lo: f32, hi: f32) -> f32 {
    lo + (hi - lo) * r.next_f32()
}

/// A float with a uniformly distributed binary exponent in [2^lo, 2^hi), random sign if `signed`.
pub fn log_uniform(r: &mut Pcg32, lo: i32, hi: i32, signed: bool) -> f32 {
    let e = lo + (r.next_u32() % (hi - lo) as u32) as i32;
    let m = 1.0 + r.next_f32();
    let v = if (-126..128).contains(&e) {
        m * f32::from_bits(((e + 127) as u32) << 23)
    } else {
        m * 2f32.powi(e)
    };
    if signed && r.next_u32() & 1 == 1 {
        -v
    } else {
        v
    }
}

/// Runs `K` on `n` inputs from `gen` at width 1 and (where the CPU has AVX2) width 8, lane by
/// lane different inputs, and fails on the first differing bits with the inputs that gave them.
pub fn check_bits<K: Kernel<I, O>, const I: usize, const O: usize>(
    name: &str,
    n: usize,
    gen: impl Fn(&mut Pcg32) -> [f32; I],
) {
    #[cfg(target_arch = "x86_64")]
    {
        let Some(avx) = avx2_or_skip(&format!(
            "{name}: this CPU has no AVX2/FMA, skipping the 8-wide half"
        )) else {
            return;
        };
        const BATCH: usize = 4096;
        let seed = name.bytes().fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
            (h ^ b as u64).wrapping_mul(0x100_0000_01b3)
        });
        let mut rng = Pcg32::new(seed, 11);
        let mut xs: Vec<[f32; I]> = (0..BATCH).map(|_| [0.0; I]).collect();
        let mut o1: Vec<[f32; O]> = (0..BATCH).map(|_| [0.0; O]).collect();
        let mut o8: Vec<[f32; O]> = (0..BATCH).map(|_| [0.0; O]).collect();
        let mut done = 0;
        let mut first = true;
        while done < n {
            for (j, x) in xs.iter_mut().enumerate() {
                *x = gen(&mut rng);
                // The first batch also pairs every edge case with every lane position.
                if first && j < EDGES.len() * I {
                    x[j % I] = EDGES[j / I];
                }
            }
            first = false;
            for (x, o) in xs.iter().zip(o1.iter_mut()) {
                *o = K::run::<f32>(*x);
            }
            avx.run(
                #[inline(always)]
                || {
                    for (xc, oc) in xs.chunks_exact(8).zip(o8.chunks_exact_mut(8)) {
                        let v: [groove::lane::F32x8; I] =
                            std::array::from_fn(|i| avx.load(&std::array::from_fn(|l| xc[l][i])));
                        let r = K::run(v);
                        for (i, ri) in r.iter().enumerate() {
                            let a = ri.to_array();
                            for l in 0..8 {
                                oc[l][i] = a[l];
                            }
                        }
                    }
                },
            );
            for j in 0..BATCH {
                for i in 0..O {
                    if !same(o1[j][i], o8[j][i]) {
                        let bits: Vec<String> = xs[j]
                            .iter()
                            .map(|x| format!("{x:e} ({:#010x})", x.to_bits()))
                            .collect();
                        panic!(
                            "{name}: output {i} differs in lane {}: width 1 {:e} ({:#010x}), width 8 {:e} ({:#010x}); inputs {}",
                            j % 8,
                            o1[j][i],
                            o1[j][i].to_bits(),
                            o8[j][i],
                            o8[j][i].to_bits(),
                            bits.join(", ")
                        );
                    }
                }
            }
            done += BATCH;
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (name, n, gen);
        eprintln!("{name}: not x86-64, skipping the 8-wide half");
    }
}

/// The AVX2 token, or None after printing `skip_note` (the calling test's 8-wide part does not
/// run on a CPU without AVX2/FMA): the lane tests' one skip preamble.
#[cfg(target_arch = "x86_64")]
pub fn avx2_or_skip(skip_note: &str) -> Option<groove::lane::Avx2> {
    let avx = groove::lane::Avx2::detect();
    if avx.is_none() {
        eprintln!("{skip_note}");
    }
    avx
}
