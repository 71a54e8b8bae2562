//! `microgeometry`: the BSDF-level measurements of the microgeometries (issue 5, spec §10)
//! printed as Markdown tables for `docs/microgeometry.md`.
//!
//! Microgeometries: the sawtooth with a mirror wall and with a wall of the nested BSDF, the
//! V-groove, the U-groove at fills 0.25, 0.5 and 1, and a deliberately broken microsurface (a
//! V-groove that reuses the sawtooth's areas 1/cosθp and tanθp, so closure fails; spec §10.4).
//! All use the random walk (the V-/U-groove have no explicit form). Nested BSDFs: white Lambert
//! (ρ = 1); a GGX α = 0.2 rough conductor with η = 0, k = 1 (Mitsuba's material "none": Fresnel
//! ≡ 1, so every loss is the microfacet model's own); a GGX α = 0.2 rough dielectric, η = 1.5.
//!
//! Measured per combination:
//! - furnace albedo = mean sample weight (a failed sample counts 0), batches drawn until the
//!   standard error is ≤ `SE_TARGET`; for the dielectric in importance mode, reflected +
//!   transmitted;
//! - albedo by ∫eval (Monte Carlo over ωo) next to it at θp = 45°, the check that sampling and
//!   eval describe the same BSDF (and the only energy check that could see a broken closure);
//! - reciprocity: z-scores of f(ωi,ωo) against f(ωo,ωi) from independent eval estimates over a
//!   fixed random set of (ωp, ωi, ωo); for the dielectric also pairs across the interface, with
//!   generalized reciprocity (in the order light travels, f(i→o)/ηo² = f(o→i)/ηi²; radiance mode);
//! - mean walk length (vertices per sampled walk, `BsdfArena::take_walk_counts`), ωi = ωg.

use crate::common::{dir, mean_se};

use glam::Vec3;
use groove::bsdf::mnm::facets::{Microgeometry, Microsurface};
use groove::bsdf::mnm::{Evaluation, MicrofacetNormalMap, Tangent};
use groove::bsdf::{
    Bsdf, BsdfArena, BsdfContext, BsdfNode, Diffuse, MicrofacetDistribution, MicrofacetType,
    RoughConductor, RoughDielectric, TransportMode,
};
use groove::math::{warp, Frame};
use groove::sampler::Sampler;
use statrs::distribution::{ContinuousCDF, Normal};

/// Largest standard error accepted for a furnace albedo.
const SE_TARGET: f64 = 0.0015;
/// Samples per batch of the adaptive albedo estimate, and the cap.
const BATCH: usize = 8192;
const MAX_SAMPLES: usize = 1 << 20;
/// Eval calls per direction of a reciprocity pair. The walk's eval over a rough dielectric has a
/// heavy tail where f is small (rare walks that reach a near-specular transmission), so at 20k
/// evals its standard error is often underestimated (|z| up to 15 in pairs that pass at 200k+);
/// it gets 5× more.
const RECIP_EVALS: usize = 20_000;
const RECIP_EVALS_DIELECTRIC: usize = 100_000;
/// Eval calls per direction in the final dielectric up/down table.
const RECHECK_DIELECTRIC: usize = 200_000;
/// Eval calls per direction when the pair with the largest |z| is measured again.
const RECHECK_EVALS: usize = 1_000_000;
/// Random pairs per reciprocity test (per pair class).
const RECIP_PAIRS: usize = 64;
/// Eval calls per ∫eval albedo.
const INT_EVALS: usize = 200_000;
/// Index of refraction of the dielectric (inside = lower hemisphere).
const ETA: f32 = 1.5;

#[derive(Clone, Copy, PartialEq)]
enum Geo {
    Standard(Microgeometry, Tangent),
    /// A V-groove with the sawtooth's areas: closure violated.
    Broken,
}

const GEOS: [(&str, Geo); 7] = [
    (
        "sawtooth, mirror wall",
        Geo::Standard(Microgeometry::Sawtooth, Tangent::Mirror),
    ),
    (
        "sawtooth, same wall",
        Geo::Standard(Microgeometry::Sawtooth, Tangent::Same),
    ),
    (
        "V-groove",
        Geo::Standard(Microgeometry::VGroove, Tangent::Same),
    ),
    (
        "U-groove s = 0.25",
        Geo::Standard(Microgeometry::UGroove { fill: 0.25 }, Tangent::Same),
    ),
    (
        "U-groove s = 0.5",
        Geo::Standard(Microgeometry::UGroove { fill: 0.5 }, Tangent::Same),
    ),
    (
        "U-groove s = 1",
        Geo::Standard(Microgeometry::UGroove { fill: 1.0 }, Tangent::Same),
    ),
    ("V-groove, sawtooth areas (broken)", Geo::Broken),
];

#[derive(Clone, Copy, PartialEq)]
enum Nested {
    Diffuse,
    Conductor,
    Dielectric,
}

const NESTED: [(&str, Nested); 3] = [
    ("white diffuse ρ = 1", Nested::Diffuse),
    (
        "rough conductor GGX α 0.2, η 0 k 1 (F ≡ 1)",
        Nested::Conductor,
    ),
    ("rough dielectric GGX α 0.2, η 1.5", Nested::Dielectric),
];

fn nested_node(n: Nested) -> BsdfNode {
    let ggx = MicrofacetDistribution::new(MicrofacetType::Ggx, 0.2, true);
    match n {
        Nested::Diffuse => BsdfNode::Diffuse(Diffuse {
            reflectance: Vec3::ONE,
        }),
        Nested::Conductor => BsdfNode::RoughConductor(RoughConductor {
            distribution: ggx,
            eta: Vec3::ZERO,
            k: Vec3::ONE,
            specular_reflectance: Vec3::ONE,
        }),
        Nested::Dielectric => {
            BsdfNode::RoughDielectric(RoughDielectric::new(ggx, ETA, 1.0, Vec3::ONE, Vec3::ONE))
        }
    }
}

/// The broken microsurface of spec §10.4: facets ωp and its mirror, with areas 1/cosθp and tanθp.
fn broken_surface(wp: Vec3) -> Microsurface {
    let mirror = Vec3::new(-wp.x, -wp.y, wp.z);
    let tan = (1.0 - wp.z * wp.z).max(0.0).sqrt() / wp.z;
    Microsurface::from_area_vectors(&[wp / wp.z, mirror * tan])
}

fn build(n: Nested, g: Geo, wp: Vec3) -> (BsdfArena, u32) {
    let mut arena = BsdfArena::new();
    let nested = arena.push(nested_node(n));
    let node = match g {
        Geo::Standard(geo, t) => {
            MicrofacetNormalMap::new(nested, wp, geo, t, Evaluation::RandomWalk, 256)
        }
        Geo::Broken => MicrofacetNormalMap::with_surface(nested, wp, broken_surface(wp), 256),
    };
    let root = arena.push_microfacet_normal_map(node);
    (arena, root)
}

/// The context of the furnace: importance mode for the dielectric (no 1/η² radiance scaling, so
/// a lossless interface has albedo 1), radiance otherwise (identical for reflection).
fn furnace_ctx(n: Nested) -> BsdfContext {
    BsdfContext {
        mode: if n == Nested::Dielectric {
            TransportMode::Importance
        } else {
            TransportMode::Radiance
        },
    }
}

/// Mean sample weight and its standard error, in batches until SE ≤ `SE_TARGET` (at least two
/// batches, at most `MAX_SAMPLES`); also returns the sample count.
fn albedo(b: &Bsdf, ctx: &BsdfContext, wi: Vec3, s: &mut Sampler) -> (f64, f64, usize) {
    let (mut a, mut a2, mut n) = (0.0f64, 0.0f64, 0usize);
    loop {
        for _ in 0..BATCH {
            let w = b.sample(ctx, wi, s).map_or(0.0, |x| x.weight.x as f64);
            a += w;
            a2 += w * w;
        }
        n += BATCH;
        let m = a / n as f64;
        let se = ((a2 / n as f64 - m * m).max(0.0) / n as f64).sqrt();
        if (n >= 2 * BATCH && se <= SE_TARGET) || n >= MAX_SAMPLES {
            return (m, se, n);
        }
    }
}

/// ∫ eval dωo by Monte Carlo, one-sample mixture of three strategies with equal weight: the
/// cosine lobe (mirrored to either side at random for the dielectric) and the nested BSDF's own
/// sampling in the frames of ωp and of its mirror image (−x, −y, z). The density of a mixture
/// sample is the mean of the three densities (a failed component sample counts 0, which keeps the
/// estimate unbiased as long as each pdf is the density of its sample). The cosine lobe alone
/// leaves the dielectric's ∫eval with SE ≈ 0.02–0.03 at 200k evals.
fn eval_albedo(
    arena: &BsdfArena,
    root: u32,
    ctx: &BsdfContext,
    transmits: bool,
    wp: Vec3,
    wi: Vec3,
    s: &mut Sampler,
) -> (f64, f64) {
    let b = arena.bsdf(root);
    let nested = arena.bsdf(0);
    let frames = [
        Frame::from_normal(wp),
        Frame::from_normal(Vec3::new(-wp.x, -wp.y, wp.z)),
    ];
    let lobe_pdf = |wo: Vec3| {
        let p = warp::cosine_hemisphere_pdf(Vec3::new(wo.x, wo.y, wo.z.abs()));
        if transmits {
            0.5 * p
        } else if wo.z > 0.0 {
            p
        } else {
            0.0
        }
    };
    mean_se(INT_EVALS, || {
        let c = s.next_1d();
        let wo = if c < 1.0 / 3.0 {
            let w = warp::square_to_cosine_hemisphere(s.next_2d());
            if transmits && s.next_1d() < 0.5 {
                -w
            } else {
                w
            }
        } else {
            let f = &frames[usize::from(c >= 2.0 / 3.0)];
            match nested.sample(ctx, f.to_local(wi), s) {
                Some(x) => f.to_world(x.wo),
                None => return 0.0,
            }
        };
        let pdf = (lobe_pdf(wo)
            + frames
                .iter()
                .map(|f| nested.pdf(ctx, f.to_local(wi), f.to_local(wo)))
                .sum::<f32>())
            / 3.0;
        if pdf > 0.0 && wo.is_finite() {
            (b.eval(ctx, wi, wo, s).x / pdf) as f64
        } else {
            0.0
        }
    })
}

/// η of the medium a direction lies in (the dielectric's inside is the lower hemisphere).
fn eta_of(w: Vec3, n: Nested) -> f64 {
    if n == Nested::Dielectric && w.z < 0.0 {
        ETA as f64
    } else {
        1.0
    }
}

/// z-score of f(wi,wo)/ηi² against f(wo,wi)/ηo² (f = eval / |cos|), from independent estimates;
/// `None` when both sides are identically zero. groove's `wi` is the direction radiance leaves
/// toward (light flows wo → wi), so Veach's f(ωi→ωo)/ηo² = f(ωo→ωi)/ηi², written in the order
/// light travels, reads f(wi,wo)/η(wi)² = f(wo,wi)/η(wo)² in groove's argument order (checked on
/// the nested dielectric alone at the start of the experiment).
fn recip_z(b: &Bsdf, n: Nested, wi: Vec3, wo: Vec3, evals: usize, s: &mut Sampler) -> Option<f64> {
    let ctx = BsdfContext::default();
    let (ei2, eo2) = (eta_of(wi, n).powi(2), eta_of(wo, n).powi(2));
    let (x, sx) = mean_se(evals, || {
        b.eval(&ctx, wi, wo, s).x as f64 / wo.z.abs() as f64 / ei2
    });
    let (y, sy) = mean_se(evals, || {
        b.eval(&ctx, wo, wi, s).x as f64 / wi.z.abs() as f64 / eo2
    });
    let se = (sx * sx + sy * sy).sqrt();
    if se == 0.0 {
        return if x == y { None } else { Some(f64::INFINITY) };
    }
    Some((x - y) / se)
}

/// A random direction in the upper hemisphere at most 85° from the normal (uniform in solid angle).
fn upper(s: &mut Sampler) -> Vec3 {
    loop {
        let w = warp::square_to_uniform_sphere(s.next_2d());
        let w = Vec3::new(w.x, w.y, w.z.abs());
        if w.z > 85f32.to_radians().cos() {
            return w;
        }
    }
}

/// One (ωp, ωi, ωo) configuration.
type Triple = (Vec3, Vec3, Vec3);

/// The fixed random (ωp, ωi, ωo) sets: θp uniform in [10°, 70°], any azimuth.
fn pairs(seed: u64, cross: bool) -> Vec<Triple> {
    let mut s = Sampler::from_seed(seed, 7);
    (0..RECIP_PAIRS)
        .map(|_| {
            let u = s.next_2d();
            let wp = dir(10.0 + 60.0 * u.x, 360.0 * u.y);
            let wi = upper(&mut s);
            let wo = upper(&mut s);
            (wp, wi, if cross { -wo } else { wo })
        })
        .collect()
}

/// The 95% quantile of max |z| over `n` independent standard normal draws: the largest value a
/// reciprocal model should show in 19 runs out of 20.
fn max_abs_z_q95(n: usize) -> f64 {
    let p_tail = 1.0 - 0.95f64.powf(1.0 / n as f64);
    Normal::new(0.0, 1.0)
        .unwrap()
        .inverse_cdf(1.0 - p_tail / 2.0)
}

fn cell(m: f64, se: f64) -> String {
    format!("{m:.4} ± {se:.4}")
}

/// Prints the tables (Markdown) on stdout; panics if the nested dielectric's η² convention, which
/// the reciprocity z-scores rely on, does not hold.
pub fn run() {
    let theta_p = [0.0f32, 20.0, 45.0, 60.0, 70.0, 80.0];
    let theta_i = [0.0f32, 30.0, 60.0, 80.0];
    let mut s = Sampler::from_seed(2024, 5);

    // Which way generalized reciprocity reads in groove's argument order, checked on the nested
    // dielectric alone (deterministic eval, f32: agreement to ~1e-3 near grazing): the order of
    // `recip_z` must hold, the other not.
    {
        let mut arena = BsdfArena::new();
        let r = arena.push(nested_node(Nested::Dielectric));
        let b = arena.bsdf(r);
        let ctx = BsdfContext::default();
        let (mut worst_used, mut worst_other) = (0.0f64, 0.0f64);
        for (_, wi, wo) in pairs(99, true) {
            let a = b.eval(&ctx, wi, wo, &mut s).x as f64 / wo.z.abs() as f64;
            let c = b.eval(&ctx, wo, wi, &mut s).x as f64 / wi.z.abs() as f64;
            let (ei2, eo2) = (
                eta_of(wi, Nested::Dielectric).powi(2),
                eta_of(wo, Nested::Dielectric).powi(2),
            );
            let rel = |x: f64, y: f64| (x - y).abs() / x.max(y);
            if a > 0.0 || c > 0.0 {
                worst_used = worst_used.max(rel(a / ei2, c / eo2));
                worst_other = worst_other.max(rel(a / eo2, c / ei2));
            }
        }
        println!("Nested dielectric alone, {RECIP_PAIRS} up/down pairs, largest relative violation of f(wi,wo)/η(wi)² = f(wo,wi)/η(wo)² (used): {worst_used:.2e}; of f(wi,wo)/η(wo)² = f(wo,wi)/η(wi)²: {worst_other:.2e}\n");
        assert!(
            worst_used < 1e-2 && worst_other > 0.5,
            "the η² convention does not hold for the nested BSDF"
        );
    }

    // Closure error |Σ A_k m_k − ωg| of every microsurface.
    println!("Closure error |Σ A_k m_k − ωg|:\n");
    println!("| microgeometry | θp 20° | θp 45° | θp 70° |");
    println!("|---|---|---|---|");
    for (gname, g) in GEOS {
        let mut row = format!("| {gname} |");
        for tp in [20.0f32, 45.0, 70.0] {
            let surface = match g {
                Geo::Standard(geo, _) => Microsurface::new(geo, dir(tp, 0.0)),
                Geo::Broken => broken_surface(dir(tp, 0.0)),
            };
            row += &format!(" {:.2e} |", surface.closure_error());
        }
        println!("{row}");
    }
    println!();

    for (nname, n) in NESTED {
        let ctx = furnace_ctx(n);
        println!("### Nested: {nname}\n");

        // Albedo and walk length vs θp at normal incidence.
        println!("Furnace albedo (mean sample weight ± SE), ωi = ωg:\n");
        let mut head = "| microgeometry |".to_string();
        let mut rule = "|---|".to_string();
        for tp in theta_p {
            head += &format!(" θp {tp}° |");
            rule += "---|";
        }
        println!("{head}\n{rule}");
        let mut walk_rows = Vec::new();
        let mut max_n = 0;
        for (gname, g) in GEOS {
            let mut row = format!("| {gname} |");
            let mut wrow = format!("| {gname} |");
            for tp in theta_p {
                let (arena, root) = build(n, g, dir(tp, 0.0));
                let b = arena.bsdf(root);
                let _ = arena.take_walk_counts();
                let (m, se, cnt) = albedo(&b, &ctx, Vec3::Z, &mut s);
                let w = arena.take_walk_counts();
                max_n = max_n.max(cnt);
                row += &format!(" {} |", cell(m, se));
                if w.walks > 0 {
                    wrow += &format!(" {:.3} |", w.vertices as f64 / w.walks as f64);
                } else {
                    wrow += " (nested) |";
                }
            }
            println!("{row}");
            walk_rows.push(wrow);
        }
        println!("\n(at most {max_n} samples per cell)\n");

        println!("Mean walk length (vertices per sampled walk, mirror reflections included), ωi = ωg; θp = 0° delegates to the nested BSDF:\n");
        println!("{head}\n{rule}");
        for r in walk_rows {
            println!("{r}");
        }
        println!();

        // Albedo vs θi, in the plane of ωp: toward = ωi on the side ωp leans to (φ = 0°, the
        // perturbed facet seen face-on), away = the other side (φ = 180°, ωi sees the wall).
        for tp in [45.0f32, 70.0] {
            println!("Furnace albedo vs θi, θp = {tp}°, ωi in the plane of ωp (toward: φ = 0°, the side ωp leans to; away: φ = 180°):\n");
            let mut head = "| microgeometry |".to_string();
            let mut rule = "|---|".to_string();
            let mut dirs = Vec::new();
            for ti in theta_i {
                if ti == 0.0 {
                    head += " θi 0° |";
                    rule += "---|";
                    dirs.push(Vec3::Z);
                } else {
                    head += &format!(" θi {ti}° toward | θi {ti}° away |");
                    rule += "---|---|";
                    dirs.push(dir(ti, 0.0));
                    dirs.push(dir(ti, 180.0));
                }
            }
            println!("{head}\n{rule}");
            for (gname, g) in GEOS {
                let (arena, root) = build(n, g, dir(tp, 0.0));
                let b = arena.bsdf(root);
                let mut row = format!("| {gname} |");
                for &wi in &dirs {
                    let (m, se, _) = albedo(&b, &ctx, wi, &mut s);
                    row += &format!(" {} |", cell(m, se));
                }
                println!("{row}");
            }
            println!();
        }

        // Sample weights against ∫eval at θp = 45°.
        println!("Albedo by sample weights vs by ∫eval ({INT_EVALS} evals), θp = 45°:\n");
        println!("| microgeometry | ωi | sample weights | ∫eval | z |");
        println!("|---|---|---|---|---|");
        for (gname, g) in GEOS {
            let (arena, root) = build(n, g, dir(45.0, 0.0));
            let b = arena.bsdf(root);
            for (wname, wi) in [
                ("0°", Vec3::Z),
                ("60° toward", dir(60.0, 0.0)),
                ("60° away", dir(60.0, 180.0)),
            ] {
                let (m, se, _) = albedo(&b, &ctx, wi, &mut s);
                let (mi, sei) = eval_albedo(
                    &arena,
                    root,
                    &ctx,
                    n == Nested::Dielectric,
                    dir(45.0, 0.0),
                    wi,
                    &mut s,
                );
                let z = (m - mi) / (se * se + sei * sei).sqrt();
                println!(
                    "| {gname} | {wname} | {} | {} | {z:+.2} |",
                    cell(m, se),
                    cell(mi, sei)
                );
            }
        }
        println!();

        // Reciprocity.
        let classes: Vec<(&str, Vec<Triple>)> = if n == Nested::Dielectric {
            vec![("up/up", pairs(11, false)), ("up/down", pairs(12, true))]
        } else {
            vec![("up/up", pairs(11, false))]
        };
        let evals = if n == Nested::Dielectric {
            RECIP_EVALS_DIELECTRIC
        } else {
            RECIP_EVALS
        };
        println!("Reciprocity: z of f(wi,wo)/η(wi)² vs f(wo,wi)/η(wo)² (groove argument order, light flows wo → wi), {evals} evals per direction, θp uniform in [10°, 70°], ωi, ωo uniform within 85° of the normal (for N standard normal draws: mean |z| √(2/π) = {:.3}, median |z| {:.3}, 95% quantile of max |z| {:.2} for N = {RECIP_PAIRS}). Eval is a stochastic estimate with a heavy tail where f is small, so the pair with the largest |z| is measured again with {RECHECK_EVALS} evals:\n", (2.0 / std::f64::consts::PI).sqrt(), Normal::new(0.0, 1.0).unwrap().inverse_cdf(0.75), max_abs_z_q95(RECIP_PAIRS));
        println!("| microgeometry | pairs | N (non-zero) | mean abs z | median abs z | max abs z | that pair again, {RECHECK_EVALS} evals, new random numbers |");
        println!("|---|---|---|---|---|---|---|");
        for (gname, g) in GEOS {
            for (cname, set) in &classes {
                let mut zs: Vec<(f64, usize)> = set
                    .iter()
                    .enumerate()
                    .filter_map(|(k, &(wp, wi, wo))| {
                        let (arena, root) = build(n, g, wp);
                        recip_z(&arena.bsdf(root), n, wi, wo, evals, &mut s).map(|z| (z, k))
                    })
                    .collect();
                zs.sort_by(|a, b| a.0.abs().total_cmp(&b.0.abs()));
                let mean = zs.iter().map(|z| z.0.abs()).sum::<f64>() / zs.len().max(1) as f64;
                let median = zs.get(zs.len() / 2).map_or(0.0, |z| z.0.abs());
                let (zmax, kmax) = zs.last().copied().unwrap_or((0.0, 0));
                let (wp, wi, wo) = set[kmax];
                let (arena, root) = build(n, g, wp);
                let again =
                    recip_z(&arena.bsdf(root), n, wi, wo, RECHECK_EVALS, &mut s).unwrap_or(0.0);
                println!(
                    "| {gname} | {cname} | {} | {mean:.2} | {median:.2} | {:.2} | {again:+.2} |",
                    zs.len(),
                    zmax.abs()
                );
            }
        }
        println!();
    }

    // The dielectric's up/down pairs again with twice the evals per direction (its eval's heavy
    // tail makes the 100k z-scores above unreliable in a few pairs), valid geometries only.
    let n = Nested::Dielectric;
    let set = pairs(12, true);
    println!(
        "Rough dielectric, the same up/down pairs with {RECHECK_DIELECTRIC} evals per direction:\n"
    );
    println!("| microgeometry | N | mean abs z | median abs z | max abs z |");
    println!("|---|---|---|---|---|");
    for (gname, g) in GEOS.iter().filter(|(_, g)| *g != Geo::Broken) {
        let mut zs: Vec<f64> = set
            .iter()
            .filter_map(|&(wp, wi, wo)| {
                let (arena, root) = build(n, *g, wp);
                recip_z(&arena.bsdf(root), n, wi, wo, RECHECK_DIELECTRIC, &mut s)
            })
            .map(f64::abs)
            .collect();
        zs.sort_by(f64::total_cmp);
        let mean = zs.iter().sum::<f64>() / zs.len().max(1) as f64;
        println!(
            "| {gname} | {} | {mean:.2} | {:.2} | {:.2} |",
            zs.len(),
            zs.get(zs.len() / 2).copied().unwrap_or(0.0),
            zs.last().copied().unwrap_or(0.0)
        );
    }
    println!();
}
