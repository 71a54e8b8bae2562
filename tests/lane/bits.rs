//! Width 8 equals width 1 bit for bit in every lane, for every function of `groove::lane`.

use crate::harness::{check_bits, count, count_composite, log_uniform, mixed, uniform};
use crate::kernel;
use groove::bsdf::MicrofacetType;
use groove::lane::frame::Frame;
use groove::lane::microfacet::Microfacet;
use groove::lane::vec::{V2, V3};
use groove::lane::{fresnel, math, warp};
use groove::math::Pcg32;

fn any(r: &mut Pcg32) -> f32 {
    mixed(r, &|r| uniform(r, -10.0, 10.0))
}
fn unit(r: &mut Pcg32) -> f32 {
    mixed(r, &|r| r.next_f32())
}
fn signed_unit(r: &mut Pcg32) -> f32 {
    mixed(r, &|r| uniform(r, -1.0, 1.0))
}
fn v3<L: groove::lane::Lane>(x: &[L]) -> V3<L> {
    V3::new(x[0], x[1], x[2])
}

kernel!(Sincos, 1, 2, |x| {
    let (s, c) = math::sincos(x[0]);
    [s, c]
});
kernel!(Exp, 1, 1, |x| [math::exp(x[0])]);
kernel!(Log, 1, 1, |x| [math::log(x[0])]);
kernel!(Pow, 2, 1, |x| [math::pow(x[0], x[1])]);
kernel!(Acos, 1, 1, |x| [math::acos(x[0])]);
kernel!(Atan2, 2, 1, |x| [math::atan2(x[0], x[1])]);

#[test]
fn sincos() {
    check_bits::<Sincos, 1, 2>("sincos", count(), |r| {
        [mixed(r, &|r| {
            if r.next_u32() & 1 == 0 {
                uniform(r, -7.0, 7.0)
            } else {
                log_uniform(r, -30, 30, true)
            }
        })]
    });
}

#[test]
fn exp() {
    check_bits::<Exp, 1, 1>("exp", count(), |r| {
        [mixed(r, &|r| uniform(r, -110.0, 95.0))]
    });
}

#[test]
fn log() {
    check_bits::<Log, 1, 1>("log", count(), |r| {
        [mixed(r, &|r| log_uniform(r, -149, 128, false))]
    });
}

#[test]
fn pow() {
    check_bits::<Pow, 2, 1>("pow", count(), |r| {
        let x = mixed(r, &|r| {
            let neg = r.next_u32() & 7 == 0;
            log_uniform(r, -20, 20, neg)
        });
        let y = mixed(r, &|r| {
            if r.next_u32() & 3 == 0 {
                (r.next_u32() % 21) as f32 - 10.0
            } else {
                uniform(r, -8.0, 8.0)
            }
        });
        [x, y]
    });
}

#[test]
fn acos() {
    check_bits::<Acos, 1, 1>("acos", count(), |r| [signed_unit(r)]);
}

#[test]
fn atan2() {
    check_bits::<Atan2, 2, 1>("atan2", count(), |r| [any(r), any(r)]);
}

kernel!(VecOps, 6, 10, |x| {
    let (a, b) = (v3(&x[..3]), v3(&x[3..]));
    let c = a.cross(b);
    let n = a.normalize();
    [
        a.dot(b),
        c.x,
        c.y,
        c.z,
        n.x,
        n.y,
        n.z,
        a.length(),
        (a - b).length_squared(),
        (a + b).div_by(x[0]).x,
    ]
});

#[test]
fn vec_ops() {
    check_bits::<VecOps, 6, 10>("vec", count_composite(), |r| {
        std::array::from_fn(|_| any(r))
    });
}

/// A unit normal from random inputs (as the renderer passes), with edge cases mixed in.
fn normal(r: &mut Pcg32) -> [f32; 3] {
    if r.next_u32() & 7 == 0 {
        return [any(r), any(r), any(r)];
    }
    let v = glam::Vec3::new(
        uniform(r, -1.0, 1.0),
        uniform(r, -1.0, 1.0),
        uniform(r, -1.0, 1.0),
    )
    .normalize_or(glam::Vec3::Z);
    v.to_array()
}

kernel!(FrameNormal, 6, 15, |x| {
    let f = Frame::from_normal(v3(&x[..3]));
    let l = f.to_local(v3(&x[3..]));
    let w = f.to_world(v3(&x[3..]));
    [
        f.s.x, f.s.y, f.s.z, f.t.x, f.t.y, f.t.z, f.n.x, f.n.y, f.n.z, l.x, l.y, l.z, w.x, w.y, w.z,
    ]
});
kernel!(FrameTangent, 6, 6, |x| {
    let f = Frame::from_normal_tangent(v3(&x[..3]), v3(&x[3..]));
    [f.s.x, f.s.y, f.s.z, f.t.x, f.t.y, f.t.z]
});

#[test]
fn frames() {
    let gen = |r: &mut Pcg32| {
        let n = normal(r);
        [n[0], n[1], n[2], any(r), any(r), any(r)]
    };
    check_bits::<FrameNormal, 6, 15>("frame", count_composite(), gen);
    check_bits::<FrameTangent, 6, 6>("frame_tangent", count_composite(), gen);
}

kernel!(Warps, 3, 17, |x| {
    let u = V2::new(x[0], x[1]);
    let d = warp::square_to_disk_concentric(u);
    let h = warp::square_to_cosine_hemisphere(u);
    let s = warp::square_to_uniform_sphere(u);
    let c = warp::square_to_uniform_cone(u, x[2]);
    let t = warp::square_to_uniform_triangle(u);
    [
        d.x,
        d.y,
        h.x,
        h.y,
        h.z,
        warp::cosine_hemisphere_pdf(h),
        s.x,
        s.y,
        s.z,
        c.x,
        c.y,
        c.z,
        warp::uniform_cone_pdf(x[2]),
        t.x,
        t.y,
        warp::safe_sqrt(x[2]),
        warp::uniform_sphere_pdf(x[0]),
    ]
});

#[test]
fn warps() {
    check_bits::<Warps, 3, 17>("warps", count_composite(), |r| {
        [unit(r), unit(r), signed_unit(r)]
    });
}

kernel!(Fresnel, 6, 8, |x| {
    let d = fresnel::dielectric(x[0], x[1]);
    let c = fresnel::conductor(x[0], v3(&x[1..4]), v3(&x[3..6]));
    [
        d.r,
        d.cos_theta_t,
        d.eta_it,
        d.eta_ti,
        c.x,
        c.y,
        c.z,
        fresnel::conductor_1(x[0], x[4], x[5]),
    ]
});

#[test]
fn fresnel() {
    check_bits::<Fresnel, 6, 8>("fresnel", count_composite(), |r| {
        let mut a = [signed_unit(r), 0.0, 0.0, 0.0, 0.0, 0.0];
        for v in &mut a[1..] {
            *v = mixed(r, &|r| uniform(r, 0.0, 4.0));
        }
        a
    });
}

/// Inputs: wi (3), m (3), u (2), alpha_u, alpha_v.
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

macro_rules! microfacet_kernel {
    ($name:ident, $kind:expr, $visible:expr) => {
        kernel!($name, 10, 11, |x| {
            let d = Microfacet::new($kind, x[8], x[9], $visible);
            let (wi, m, u) = (v3(&x[..3]), v3(&x[3..6]), V2::new(x[6], x[7]));
            let s = d.sample_all_normals(u);
            let v = d.sample_normal(wi, u);
            [
                d.eval(m),
                d.lambda(wi),
                d.smith_g1(wi, m),
                d.g(wi, v3(&x[2..5]), m),
                d.pdf(wi, m),
                s.x,
                s.y,
                s.z,
                v.x,
                v.y,
                v.z,
            ]
        });
    };
}
microfacet_kernel!(GgxVisible, MicrofacetType::Ggx, true);
microfacet_kernel!(GgxAll, MicrofacetType::Ggx, false);
microfacet_kernel!(BeckmannAll, MicrofacetType::Beckmann, false);
microfacet_kernel!(BeckmannVisible, MicrofacetType::Beckmann, true);

// Mitsuba's map of `roughplastic`'s tables (GGX: Heitz 2018 over the concentric disk).
kernel!(GgxConcentric, 10, 3, |x| {
    let d = Microfacet::new(MicrofacetType::Ggx, x[8], x[9], true);
    let v = d.sample_normal_mitsuba_map(v3(&x[..3]), V2::new(x[6], x[7]));
    [v.x, v.y, v.z]
});

// The reflection density from (D, G1) of the half vector, both sampling strategies (wo = m's
// inputs, h = wi + wo normalised, d and g1 from the kernel itself).
kernel!(ReflectionPdf, 10, 2, |x| {
    let (wi, wo) = (v3(&x[..3]), v3(&x[3..6]));
    let h = (wi + wo).normalize();
    let v = Microfacet::new(MicrofacetType::Beckmann, x[8], x[9], true);
    let a = Microfacet::new(MicrofacetType::Ggx, x[8], x[9], false);
    [
        v.reflection_pdf(wi, wo, h, v.eval(h), v.smith_g1(wi, h)),
        a.reflection_pdf(wi, wo, h, a.eval(h), x[6]),
    ]
});

// Visible Beckmann normals alone (per-lane Newton stops: lanes of one 8-wide call converge
// after different step counts).
kernel!(BeckmannVisibleOnly, 10, 3, |x| {
    let d = Microfacet::new(MicrofacetType::Beckmann, x[8], x[9], true);
    let v = d.sample_visible_beckmann(v3(&x[..3]), V2::new(x[6], x[7]));
    [v.x, v.y, v.z]
});

#[test]
fn microfacet() {
    check_bits::<GgxVisible, 10, 11>("ggx_visible", count_composite(), microfacet_inputs);
    check_bits::<GgxAll, 10, 11>("ggx_all", count_composite(), microfacet_inputs);
    check_bits::<BeckmannAll, 10, 11>("beckmann_all", count_composite(), microfacet_inputs);
    check_bits::<BeckmannVisible, 10, 11>("beckmann_visible", count_composite(), microfacet_inputs);
    check_bits::<GgxConcentric, 10, 3>("ggx_concentric", count_composite(), microfacet_inputs);
    check_bits::<ReflectionPdf, 10, 2>("reflection_pdf", count_composite(), microfacet_inputs);
}

/// PCG32 per lane: the 8-wide generator equals eight scalar ones (seeds and streams random),
/// over `count()` draws in total.
#[test]
fn pcg() {
    #[cfg(target_arch = "x86_64")]
    {
        use groove::lane::pcg::Pcg;
        let Some(avx) =
            crate::harness::avx2_or_skip("pcg: this CPU has no AVX2/FMA, skipping the 8-wide half")
        else {
            return;
        };
        let mut r = Pcg32::new(5, 7);
        let draws = 64;
        for _ in 0..count() / (8 * 2 * draws) {
            let seeds: [u64; 8] =
                std::array::from_fn(|_| (r.next_u32() as u64) << 32 | r.next_u32() as u64);
            let streams: [u64; 8] = std::array::from_fn(|i| {
                if i == 0 {
                    u64::MAX
                } else {
                    (r.next_u32() as u64) << 32 | r.next_u32() as u64
                }
            });
            let mut one: Vec<Pcg<f32>> = (0..8).map(|i| Pcg::new(seeds[i], streams[i])).collect();
            let (u, f) = avx.run(
                #[inline(always)]
                || {
                    let mut p = Pcg::<groove::lane::F32x8>::new(
                        avx.load_u64(&seeds),
                        avx.load_u64(&streams),
                    );
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
                for l in 0..8 {
                    assert_eq!(u[d][l], one[l].next_u32(), "draw {d} lane {l}");
                    assert_eq!(
                        f[d][l].to_bits(),
                        one[l].next_f32().to_bits(),
                        "draw {d} lane {l}"
                    );
                }
            }
        }
    }
}

/// The long sweep: `GROOVE_LANE_N` inputs (set it to 10⁸ or more) over the polynomial
/// functions, whose input spaces are the largest.
#[test]
#[ignore]
fn long_sweep() {
    let n = count();
    check_bits::<Sincos, 1, 2>("sincos_long", n, |r| [f32::from_bits(r.next_u32())]);
    check_bits::<Exp, 1, 1>("exp_long", n, |r| [f32::from_bits(r.next_u32())]);
    check_bits::<Log, 1, 1>("log_long", n, |r| [f32::from_bits(r.next_u32())]);
    check_bits::<Acos, 1, 1>("acos_long", n, |r| [f32::from_bits(r.next_u32())]);
    check_bits::<Atan2, 2, 1>("atan2_long", n, |r| {
        [f32::from_bits(r.next_u32()), f32::from_bits(r.next_u32())]
    });
    check_bits::<Pow, 2, 1>("pow_long", n, |r| {
        [f32::from_bits(r.next_u32()), f32::from_bits(r.next_u32())]
    });
    // The samplers with data-dependent work (Beckmann's Newton steps) and Mitsuba's GGX map.
    check_bits::<BeckmannVisibleOnly, 10, 3>("beckmann_visible_long", n, microfacet_inputs);
    check_bits::<GgxConcentric, 10, 3>("ggx_concentric_long", n, microfacet_inputs);
}
