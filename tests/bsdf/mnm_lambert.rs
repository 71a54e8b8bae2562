//! Issue 17 item 1: the random walk's exact closed forms over a Lambertian nested BSDF
//! (`src/bsdf/mnm/lambert.rs`) against the walk itself (`lambert_closed_form` off): albedo
//! within 4σ over θp × ρ × ωi for every microgeometry, the walk's samples against the closed
//! form's distribution (chi-square for white facets, whose walk weights are 1; per-cell weight
//! z-tests for coloured ones), reciprocity, determinism and the white furnace. The closed forms'
//! own sample/pdf chi-square and weight == eval/pdf run in `mnm_harness.rs` (diffuse cases).

use crate::common;

use common::chi2::*;
use glam::Vec3;
use groove::bsdf::mnm::facets::Microgeometry;
use groove::bsdf::mnm::{Evaluation, MicrofacetNormalMap, Tangent};
use groove::bsdf::{BsdfArena, BsdfContext, BsdfNode, Diffuse, TransportMode};
use groove::sampler::Sampler;
use rayon::prelude::*;

const GEOMETRIES: [(&str, Microgeometry, Tangent); 4] = [
    ("mirror sawtooth", Microgeometry::Sawtooth, Tangent::Mirror),
    ("same-wall sawtooth", Microgeometry::Sawtooth, Tangent::Same),
    ("vgroove", Microgeometry::VGroove, Tangent::Same),
    (
        "ugroove 0.5",
        Microgeometry::UGroove { fill: 0.5 },
        Tangent::Same,
    ),
];

/// The walk BSDF over `nested` (closed form on or off), and whether the closed form is in use.
fn mnm(nested: BsdfNode, wp: Vec3, g: Microgeometry, t: Tangent, closed: bool) -> ArenaBsdf {
    let mut arena = BsdfArena::new();
    let child = arena.push(nested);
    let m = MicrofacetNormalMap::new(child, wp, g, t, Evaluation::RandomWalk, 256)
        .with_lambert_closed_form(closed);
    let root = arena.push_microfacet_normal_map(m);
    ArenaBsdf {
        arena,
        root,
        ctx: BsdfContext {
            mode: TransportMode::Radiance,
        },
        deterministic: closed,
    }
}

fn diffuse(rho: Vec3) -> BsdfNode {
    BsdfNode::Diffuse(Diffuse { reflectance: rho })
}

/// ∫ eval dωo over the upper hemisphere by the midpoint rule in (cos θ, φ) (deterministic eval).
fn albedo_quadrature(b: &ArenaBsdf, wi: Vec3) -> Vec3 {
    let (nz, np) = (192, 384);
    let mut s = Sampler::from_seed(1, 1);
    let mut acc = glam::DVec3::ZERO;
    for i in 0..nz {
        let z = (i as f32 + 0.5) / nz as f32;
        let r = (1.0 - z * z).sqrt();
        for j in 0..np {
            let p = (j as f32 + 0.5) / np as f32 * std::f32::consts::TAU;
            let wo = Vec3::new(r * p.cos(), r * p.sin(), z);
            acc += b.eval(wi, wo, &mut s).as_dvec3();
        }
    }
    (acc * (2.0 * std::f64::consts::PI / (nz * np) as f64)).as_vec3()
}

/// Albedo of the closed form == mean walk sample weight, within 4σ (plus 3e-4 for the
/// quadrature and the walk's truncation at 256 vertices), over every microgeometry, θp ∈
/// {10…85}°, ρ ∈ {0.2, 0.5, 0.8, 1}, four ωi. The mirror sawtooth's is also ρ cosθp/(1 − ρ(1 −
/// cosθp)) exactly.
#[test]
fn closed_form_albedo_equals_the_walk() {
    let mut cases = Vec::new();
    for gi in 0..GEOMETRIES.len() {
        for tp in [10.0f32, 30.0, 50.0, 70.0, 85.0] {
            for rho in [0.2f32, 0.5, 0.8, 1.0] {
                for (ti, pi) in [(0.0f32, 0.0f32), (40.0, 0.0), (60.0, 180.0), (75.0, 90.0)] {
                    cases.push((gi, tp, rho, ti, pi));
                }
            }
        }
    }
    let fails: Vec<String> = cases
        .par_iter()
        .enumerate()
        .filter_map(|(i, &(gi, tp, rho, ti, pi))| {
            let (name, g, t) = GEOMETRIES[gi];
            let wp = direction(tp, 20.0);
            let wi = direction(ti, pi);
            let closed = mnm(diffuse(Vec3::splat(rho)), wp, g, t, true);
            let walk = mnm(diffuse(Vec3::splat(rho)), wp, g, t, false);
            let a = albedo_quadrature(&closed, wi).x as f64;
            let n = 20_000;
            let mut s = Sampler::from_seed(900 + i as u64, 1);
            let (mut sum, mut sq) = (0.0f64, 0.0f64);
            for _ in 0..n {
                if let Some(bs) = walk.sample(wi, &mut s) {
                    let w = bs.weight.x as f64;
                    sum += w;
                    sq += w * w;
                }
            }
            let mean = sum / n as f64;
            let se = ((sq / n as f64 - mean * mean).max(0.0) / n as f64).sqrt();
            let mut err = None;
            if (a - mean).abs() > 4.0 * se + 3e-4 {
                err = Some(format!(
                    "{name} θp {tp} ρ {rho} ωi ({ti},{pi}): closed {a:.5} walk {mean:.5} ± {se:.5}"
                ));
            }
            if gi == 0 {
                let c = wp.z as f64;
                let r = rho as f64;
                let exact = r * c / (1.0 - r * (1.0 - c));
                if (a - exact).abs() > 2e-4 {
                    err = Some(format!(
                        "{name} θp {tp} ρ {rho}: quadrature {a} vs ρ_eff {exact}"
                    ));
                }
            }
            err
        })
        .collect();
    assert!(
        fails.is_empty(),
        "{} failures:\n{}",
        fails.len(),
        fails.join("\n")
    );
}

/// The walk's samples against the closed form's distribution, on 16 × 32 cells: white facets
/// (walk weights 1) by a chi-square of the walk's sample counts against ∫_cell eval of the
/// closed form; coloured facets by per-cell z-tests of the walk's weights against it. Šidák over
/// all cases at α = 0.01, fixed seeds.
#[test]
fn walk_samples_follow_the_closed_form_per_cell() {
    let mut cases = Vec::new();
    for gi in 0..GEOMETRIES.len() {
        for tp in [30.0f32, 70.0] {
            for (ti, pi) in [(20.0f32, 0.0f32), (65.0, 160.0)] {
                for white in [true, false] {
                    cases.push((gi, tp, ti, pi, white));
                }
            }
        }
    }
    let level = Sidak::new(0.01, cases.len()).level();
    let grid = Grid {
        n_cos: 16,
        n_phi: 32,
    };
    let n = 200_000;
    let fails: Vec<String> = cases
        .par_iter()
        .enumerate()
        .filter_map(|(i, &(gi, tp, ti, pi, white))| {
            let (name, g, t) = GEOMETRIES[gi];
            let rho = if white {
                Vec3::ONE
            } else {
                Vec3::new(0.9, 0.6, 0.3)
            };
            let wp = direction(tp, 0.0);
            let wi = direction(ti, pi);
            let closed = mnm(diffuse(rho), wp, g, t, true);
            let walk = mnm(diffuse(rho), wp, g, t, false);
            let seed = 7100 + i as u64;
            let cells = cell_integrals(&closed, wi, &grid, n, seed);
            let s = draw(&walk, wi, &grid, n, seed, false);
            let r = if white {
                let pdf: Vec<f64> = cells.eval.iter().map(|e| e / 3.0).collect();
                chi2_sample_vs_pdf(&s, &pdf, level)
            } else {
                cell_consistency(&s, &cells, level)
            };
            r.err()
                .map(|e| format!("{name} θp {tp} ωi ({ti},{pi}) white {white}: {e}"))
        })
        .collect();
    assert!(
        fails.is_empty(),
        "{} failures:\n{}",
        fails.len(),
        fails.join("\n")
    );
}

/// The closed forms are reciprocal (f(i,o) = f(o,i) to 1e-5 relative) and deterministic (two
/// evaluations with different sampler states agree bit for bit), also under `twosided`.
#[test]
fn closed_forms_are_reciprocal_and_deterministic() {
    let mut rng = Sampler::from_seed(42, 3);
    for (name, g, t) in GEOMETRIES {
        for k in 0..2000 {
            let tp = 85.0 * rng.next_1d();
            let wp = direction(tp, 360.0 * rng.next_1d());
            let rho = Vec3::new(rng.next_1d(), rng.next_1d(), rng.next_1d());
            let b = if k % 2 == 0 {
                mnm(diffuse(rho), wp, g, t, true)
            } else {
                // twosided(diffuse, diffuse of another colour): the walk sees the front only.
                let mut arena = BsdfArena::new();
                let f = arena.push(diffuse(rho));
                let bk = arena.push(diffuse(Vec3::splat(0.1)));
                let ts = arena.push(BsdfNode::TwoSided { front: f, back: bk });
                let m = MicrofacetNormalMap::new(ts, wp, g, t, Evaluation::RandomWalk, 256);
                let root = arena.push_microfacet_normal_map(m);
                ArenaBsdf {
                    arena,
                    root,
                    ctx: BsdfContext::default(),
                    deterministic: true,
                }
            };
            let wi = groove::math::warp::square_to_cosine_hemisphere(rng.next_2d());
            let wo = groove::math::warp::square_to_cosine_hemisphere(rng.next_2d());
            if wi.z < 1e-3 || wo.z < 1e-3 {
                continue;
            }
            let mut s1 = Sampler::from_seed(1, 1);
            let mut s2 = Sampler::from_seed(2, 9);
            let fab = b.eval(wi, wo, &mut s1);
            assert_eq!(
                fab,
                b.eval(wi, wo, &mut s2),
                "{name}: eval not deterministic"
            );
            let fab = fab / wo.z;
            let fba = b.eval(wo, wi, &mut s1) / wi.z;
            let tol = 1e-5 * fab.max_element().max(fba.max_element()) + 1e-9;
            assert!(
                (fab - fba).abs().max_element() <= tol,
                "{name} θp {tp}: f(i,o) {fab} vs f(o,i) {fba}"
            );
        }
    }
}

/// White furnace: ρ = 1 gives albedo 1 for every microgeometry (quadrature, 1 ± 3e-4) and,
/// for the mirror sawtooth, every sample weight is exactly 1.
#[test]
fn white_furnace() {
    for (name, g, t) in GEOMETRIES {
        for tp in [5.0f32, 45.0, 85.0] {
            let b = mnm(diffuse(Vec3::ONE), direction(tp, 70.0), g, t, true);
            for wi in [
                direction(0.0, 0.0),
                direction(50.0, 250.0),
                direction(80.0, 70.0),
            ] {
                let a = albedo_quadrature(&b, wi);
                assert!(
                    (a - Vec3::ONE).abs().max_element() < 3e-4,
                    "{name} θp {tp} ωi {wi}: albedo {a}"
                );
                if t == Tangent::Mirror {
                    let mut s = Sampler::from_seed(5, 5);
                    for _ in 0..1000 {
                        let bs = b.sample(wi, &mut s).expect("cosine sample");
                        assert!((bs.weight - Vec3::ONE).abs().max_element() < 1e-6);
                    }
                }
            }
        }
    }
}

/// The closed form applies only where the walk would agree: not with `max_order` truncating
/// visibly, not when switched off, and not over a non-Lambertian nested BSDF.
#[test]
fn closed_form_applies_only_where_it_equals_the_walk() {
    let wp = direction(40.0, 0.0);
    let uses = |nested: BsdfNode, order: u32, closed: bool| {
        let mut arena = BsdfArena::new();
        let child = arena.push(nested);
        let m = MicrofacetNormalMap::new(
            child,
            wp,
            Microgeometry::Sawtooth,
            Tangent::Mirror,
            Evaluation::RandomWalk,
            order,
        )
        .with_lambert_closed_form(closed);
        let root = arena.push_microfacet_normal_map(m);
        // The mirror sawtooth's closed form samples a cosine lobe (pdf z/π exactly); the walk's
        // MIS pdf is the mixture of decision 3.
        let (wi, wo) = (direction(30.0, 10.0), direction(50.0, 200.0));
        let p = arena.bsdf(root).pdf(&BsdfContext::default(), wi, wo);
        p == wo.z * std::f32::consts::FRAC_1_PI
    };
    assert!(uses(diffuse(Vec3::splat(0.8)), 256, true));
    assert!(!uses(diffuse(Vec3::splat(0.8)), 256, false));
    assert!(!uses(diffuse(Vec3::splat(0.8)), 3, true));
    assert!(!uses(common::rough_gold(0.3), 256, true));
}
