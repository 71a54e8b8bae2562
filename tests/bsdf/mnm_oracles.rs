//! Oracles of the microfacet normal-mapping spec (`mnm.md` §14) that need no histogram:
//! the ωp = ωg reduction, Variant M's reciprocity and Lambert closed form, the exact
//! Lambertian behaviour of the mirror walk over a white Lambertian, furnace albedos, and
//! random-walk reciprocity. Statistical thresholds are 4 standard errors of the estimate.

use crate::common;

use common::{dir, mean_se};

use glam::Vec3;
use groove::bsdf::mnm::facets::{Microgeometry, Microsurface};
use groove::bsdf::mnm::{Evaluation, MicrofacetNormalMap, Tangent};
use groove::bsdf::{BsdfArena, BsdfContext, BsdfNode, Diffuse};
use groove::math::warp;
use groove::sampler::Sampler;

const PI: f32 = std::f32::consts::PI;

struct Setup {
    arena: BsdfArena,
    root: u32,
    nested: u32,
}

fn mnm(rho: f32, wp: Vec3, g: Microgeometry, t: Tangent, e: Evaluation, max_order: u32) -> Setup {
    let mut arena = BsdfArena::new();
    let nested = arena.push(BsdfNode::Diffuse(Diffuse {
        reflectance: Vec3::splat(rho),
    }));
    // These oracles are about the walk itself: its Lambert closed forms (on by default over
    // diffuse) are tested against it in `mnm_lambert.rs`.
    let root = arena.push_microfacet_normal_map(
        MicrofacetNormalMap::new(nested, wp, g, t, e, max_order).with_lambert_closed_form(false),
    );
    Setup {
        arena,
        root,
        nested,
    }
}

fn eval(s: &Setup, wi: Vec3, wo: Vec3, smp: &mut Sampler) -> f32 {
    s.arena
        .bsdf(s.root)
        .eval(&BsdfContext::default(), wi, wo, smp)
        .x
}

const VARIANTS: [(Tangent, Evaluation); 4] = [
    (Tangent::Mirror, Evaluation::Explicit),
    (Tangent::Mirror, Evaluation::RandomWalk),
    (Tangent::Same, Evaluation::Explicit),
    (Tangent::Same, Evaluation::RandomWalk),
];

/// Oracle 2: with ωp = ωg every variant is the nested BSDF, bit for bit (same random numbers).
#[test]
fn unperturbed_normal_gives_the_nested_bsdf_bit_for_bit() {
    let ctx = BsdfContext::default();
    for (t, e) in VARIANTS {
        let s = mnm(0.7, Vec3::Z, Microgeometry::Sawtooth, t, e, 256);
        let outer = s.arena.bsdf(s.root);
        let inner = s.arena.bsdf(s.nested);
        for i in 0..200 {
            let wi = dir(80.0 * (i as f32 / 200.0), 37.0 * i as f32);
            let wo = dir(3.0 + 0.4 * i as f32 % 85.0, 11.0 * i as f32);
            let (mut a, mut b) = (Sampler::from_seed(i, 1), Sampler::from_seed(i, 1));
            assert_eq!(
                outer.eval(&ctx, wi, wo, &mut a).to_array(),
                inner.eval(&ctx, wi, wo, &mut b).to_array()
            );
            assert_eq!(
                outer.pdf(&ctx, wi, wo).to_bits(),
                inner.pdf(&ctx, wi, wo).to_bits()
            );
            let sa = outer
                .sample(&ctx, wi, &mut a)
                .map(|x| (x.wo.to_array(), x.weight.to_array(), x.pdf.to_bits()));
            let sb = inner
                .sample(&ctx, wi, &mut b)
                .map(|x| (x.wo.to_array(), x.weight.to_array(), x.pdf.to_bits()));
            assert_eq!(sa, sb, "{t:?} {e:?}");
        }
        // Continuity: θp = 1e-4 rad differs from the nested BSDF by < 1e-3 (explicit variants).
        if e == Evaluation::Explicit {
            let tiny = mnm(
                0.7,
                dir(1e-4f32.to_degrees(), 20.0),
                Microgeometry::Sawtooth,
                t,
                e,
                256,
            );
            let (wi, wo) = (dir(40.0, 10.0), dir(60.0, 200.0));
            let mut smp = Sampler::from_seed(5, 5);
            let a = eval(&tiny, wi, wo, &mut smp);
            let b = 0.7 / PI * wo.z;
            assert!((a / b - 1.0).abs() < 1e-3, "{a} vs {b}");
        }
    }
}

/// Oracle 3: Variant M is reciprocal: evalM(ωi,ωo)/z(ωo) = evalM(ωo,ωi)/z(ωi).
#[test]
fn explicit_mirror_is_reciprocal() {
    let mut r = Sampler::from_seed(3, 3);
    for tp in [20.0f32, 50.0, 75.0] {
        let s = mnm(
            0.8,
            dir(tp, 30.0),
            Microgeometry::Sawtooth,
            Tangent::Mirror,
            Evaluation::Explicit,
            256,
        );
        for _ in 0..2000 {
            let wi = warp::square_to_cosine_hemisphere(r.next_2d());
            let wo = warp::square_to_cosine_hemisphere(r.next_2d());
            if wi.z < 1e-3 || wo.z < 1e-3 {
                continue;
            }
            let a = eval(&s, wi, wo, &mut r) / wo.z;
            let b = eval(&s, wo, wi, &mut r) / wi.z;
            assert!(
                (a - b).abs() <= 1e-4 * a.abs().max(b.abs()) + 1e-7,
                "θp {tp}: {a} vs {b}"
            );
        }
    }
}

/// Oracle 4: Variant M over a Lambertian of albedo ρ has the closed form
/// (ρ cosθp/π)[λp(ωi) z(ωo) + λt(ωi) a_p(ωo) G1(ωo)], and at normal incidence its albedo is ρ cosθp.
#[test]
fn explicit_mirror_lambert_closed_form_and_albedo() {
    let rho = 0.6;
    let mut r = Sampler::from_seed(4, 4);
    for tp in [10.0f32, 30.0, 45.0, 60.0, 75.0, 85.0] {
        let wp = dir(tp, 120.0);
        let s = mnm(
            rho,
            wp,
            Microgeometry::Sawtooth,
            Tangent::Mirror,
            Evaluation::Explicit,
            256,
        );
        let surf = Microsurface::new(Microgeometry::Sawtooth, wp);
        for _ in 0..500 {
            let wi = warp::square_to_cosine_hemisphere(r.next_2d());
            let wo = warp::square_to_cosine_hemisphere(r.next_2d());
            let closed = rho * wp.z / PI
                * (surf.lambda(0, wi) * wo.z
                    + surf.lambda(1, wi) * surf.proj_area(0, wo) * surf.g1(wo));
            let v = eval(&s, wi, wo, &mut r);
            assert!(
                (v - closed).abs() < 1e-5 + 1e-4 * closed,
                "θp {tp}: {v} vs {closed}"
            );
        }
        // Albedo at normal incidence by quadrature (midpoint rule in cosθ, φ).
        let (nt, np) = (400, 400);
        let mut alb = 0.0f64;
        for i in 0..nt {
            for j in 0..np {
                let ct = (i as f32 + 0.5) / nt as f32;
                let ph = (j as f32 + 0.5) / np as f32 * 2.0 * PI;
                let st = (1.0 - ct * ct).sqrt();
                let wo = Vec3::new(st * ph.cos(), st * ph.sin(), ct);
                alb += eval(&s, Vec3::Z, wo, &mut r) as f64;
            }
        }
        alb *= 2.0 * std::f64::consts::PI / (nt * np) as f64;
        let expected = rho as f64 * (tp as f64).to_radians().cos();
        assert!(
            (alb - expected).abs() < 2e-3,
            "θp {tp}: albedo {alb} vs {expected}"
        );
    }
}

/// Correction 2: the mirror walk over a white Lambertian is exactly Lambertian, f ≡ 1/π, for
/// every ωi, ωo and θp (the expectation of the stochastic eval).
#[test]
fn mirror_walk_over_white_lambert_is_exactly_lambertian() {
    let mut r = Sampler::from_seed(6, 6);
    for tp in [30.0f32, 60.0, 80.0] {
        let s = mnm(
            1.0,
            dir(tp, 45.0),
            Microgeometry::Sawtooth,
            Tangent::Mirror,
            Evaluation::RandomWalk,
            256,
        );
        for (ti, pi_, to, po) in [
            (0.0, 0.0, 40.0, 0.0),
            (60.0, 45.0, 70.0, 225.0),
            (75.0, 225.0, 20.0, 90.0),
        ] {
            let (wi, wo) = (dir(ti, pi_), dir(to, po));
            let (m, se) = mean_se(200_000, || (eval(&s, wi, wo, &mut r) / wo.z) as f64);
            let want = 1.0 / std::f64::consts::PI;
            assert!(
                (m - want).abs() < 4.0 * se + 1e-4,
                "θp {tp}: f {m} ± {se} vs 1/π"
            );
        }
    }
}

/// Correction 2: with max_order = 2, the expected mirror-walk eval equals Variant M pointwise.
#[test]
fn mirror_walk_of_order_two_equals_explicit_mirror_in_expectation() {
    let mut r = Sampler::from_seed(7, 7);
    for tp in [35.0f32, 70.0] {
        let wp = dir(tp, 200.0);
        let w2 = mnm(
            0.9,
            wp,
            Microgeometry::Sawtooth,
            Tangent::Mirror,
            Evaluation::RandomWalk,
            2,
        );
        let m = mnm(
            0.9,
            wp,
            Microgeometry::Sawtooth,
            Tangent::Mirror,
            Evaluation::Explicit,
            2,
        );
        for (wi, wo) in [
            (dir(30.0, 20.0), dir(50.0, 200.0)),
            (dir(70.0, 200.0), dir(65.0, 20.0)),
            (dir(10.0, 90.0), dir(80.0, 0.0)),
        ] {
            let exact = eval(&m, wi, wo, &mut r) as f64;
            let (mean, se) = mean_se(200_000, || eval(&w2, wi, wo, &mut r) as f64);
            assert!(
                (mean - exact).abs() < 4.0 * se + 1e-6,
                "θp {tp}: walk {mean} ± {se} vs M {exact}"
            );
        }
    }
}

/// Oracle 11: white-furnace albedo (mean sample weight, failures count 0) of the walks is
/// 1 − P(length > max_order) ≈ 1 for moderate tilts; Variant M's is ρ·cosθp at normal incidence;
/// single scattering loses energy but never exceeds 1.
#[test]
fn furnace_albedo_of_each_variant() {
    let ctx = BsdfContext::default();
    let mut r = Sampler::from_seed(8, 8);
    for tp in [30.0f32, 60.0] {
        for g in [
            Microgeometry::Sawtooth,
            Microgeometry::VGroove,
            Microgeometry::UGroove { fill: 0.5 },
        ] {
            for (t, e) in VARIANTS {
                if g != Microgeometry::Sawtooth && t == Tangent::Mirror {
                    continue;
                }
                let s = mnm(1.0, dir(tp, 10.0), g, t, e, 256);
                let b = s.arena.bsdf(s.root);
                for wi in [Vec3::Z, dir(60.0, 10.0), dir(60.0, 190.0)] {
                    let (m, se) = mean_se(100_000, || {
                        b.sample(&ctx, wi, &mut r)
                            .map_or(0.0, |x| x.weight.x as f64)
                    });
                    let what = format!("{g:?} {t:?} {e:?} θp {tp} ωi {wi}");
                    assert!(m < 1.0 + 4.0 * se + 1e-4, "{what}: albedo {m} ± {se} > 1");
                    if e == Evaluation::RandomWalk {
                        // P(length > 256) < 1e-6 at these tilts.
                        assert!(
                            (m - 1.0).abs() < 4.0 * se + 1e-4,
                            "{what}: albedo {m} ± {se} ≠ 1"
                        );
                    } else if t == Tangent::Mirror && wi == Vec3::Z {
                        let want = (tp as f64).to_radians().cos();
                        assert!(
                            (m - want).abs() < 4.0 * se + 1e-4,
                            "{what}: albedo {m} vs {want}"
                        );
                    }
                }
            }
        }
    }
}

/// Oracle 10 (in total): the mean sample weight equals ∫ eval dω, for every variant.
#[test]
fn mean_sample_weight_equals_integral_of_eval() {
    let ctx = BsdfContext::default();
    let mut r = Sampler::from_seed(9, 9);
    for (t, e) in VARIANTS {
        let s = mnm(0.75, dir(55.0, 300.0), Microgeometry::Sawtooth, t, e, 256);
        let b = s.arena.bsdf(s.root);
        for wi in [dir(20.0, 300.0), dir(70.0, 120.0)] {
            let (ms, ses) = mean_se(200_000, || {
                b.sample(&ctx, wi, &mut r)
                    .map_or(0.0, |x| x.weight.x as f64)
            });
            let (mi, sei) = mean_se(200_000, || {
                let wo = warp::square_to_cosine_hemisphere(r.next_2d());
                let pdf = warp::cosine_hemisphere_pdf(wo);
                if pdf <= 0.0 {
                    0.0
                } else {
                    (b.eval(&ctx, wi, wo, &mut r).x / pdf) as f64
                }
            });
            let z = (ms - mi) / (ses * ses + sei * sei).sqrt();
            assert!(
                z.abs() < 4.0,
                "{t:?} {e:?} ωi {wi}: E[weight] {ms} ± {ses} vs ∫eval {mi} ± {sei}"
            );
        }
    }
}

/// Oracle 12: the random walks are reciprocal in expectation, for every microgeometry.
#[test]
fn random_walks_are_reciprocal() {
    let mut r = Sampler::from_seed(10, 10);
    let cases = [
        (Microgeometry::Sawtooth, Tangent::Mirror),
        (Microgeometry::Sawtooth, Tangent::Same),
        (Microgeometry::VGroove, Tangent::Same),
        (Microgeometry::UGroove { fill: 0.5 }, Tangent::Same),
    ];
    for (g, t) in cases {
        let s = mnm(0.9, dir(50.0, 0.0), g, t, Evaluation::RandomWalk, 256);
        for (wi, wo) in [
            (dir(30.0, 0.0), dir(60.0, 180.0)),
            (dir(70.0, 180.0), dir(40.0, 90.0)),
        ] {
            let (a, sa) = mean_se(200_000, || (eval(&s, wi, wo, &mut r) / wo.z) as f64);
            let (b, sb) = mean_se(200_000, || (eval(&s, wo, wi, &mut r) / wi.z) as f64);
            let z = (a - b) / (sa * sa + sb * sb).sqrt();
            assert!(
                z.abs() < 4.0,
                "{g:?} {t:?}: f(i,o) {a} ± {sa} vs f(o,i) {b} ± {sb}"
            );
        }
    }
}
