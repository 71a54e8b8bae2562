//! Issue 17 item 4: `evaluation = compensated` (the complete first order plus the rank-1
//! remainder tabulated from the walk; `src/bsdf/mnm/compensated.rs`, `ms_table.rs`). Tests: the
//! albedo identity ∫ f_ms z dωo = E_ms(ωi) (1e-3), the remainder's symmetry (1e-6) and the whole
//! model's reciprocity, chi-square of sample vs pdf and weight == eval/pdf over nested kinds ×
//! microgeometries × tilts × directions, the white furnace (1 ± 1e-4) with the exact Lambert
//! table, no gain (≤ 1 + 1e-3), the albedo against the walk between table nodes, and that eval
//! consumes no random numbers. Tables are built in memory (no disk cache).

use crate::common;

use common::chi2::*;
use glam::Vec3;
use groove::bsdf::mnm::facets::Microgeometry;
use groove::bsdf::mnm::ms_cache;
use groove::bsdf::mnm::ms_table::{Colour, MsTable, TableSpec, WALKS_PER_NODE};
use groove::bsdf::mnm::{Evaluation, MicrofacetNormalMap, Tangent};
use groove::bsdf::{
    BsdfArena, BsdfContext, BsdfNode, Diffuse, MicrofacetDistribution, MicrofacetType,
    RoughConductor, TransportMode,
};
use groove::sampler::Sampler;
use rayon::prelude::*;

const MAX_THETA: f32 = 85.0;

fn nested(which: &str) -> BsdfNode {
    match which {
        "white" => BsdfNode::Diffuse(Diffuse {
            reflectance: Vec3::ONE,
        }),
        "diffuse" => BsdfNode::Diffuse(Diffuse {
            reflectance: Vec3::new(0.9, 0.6, 0.3),
        }),
        "gold" => common::rough_gold(0.2),
        "plastic" => common::rough_plastic(MicrofacetType::Ggx, 0.3, true),
        // White conductors (material "none": η = 0, k = 1, F = 1).
        w if w.starts_with("mirror") => {
            let alpha: f32 = w["mirror".len()..].parse().expect("mirror<alpha>");
            BsdfNode::RoughConductor(RoughConductor {
                distribution: MicrofacetDistribution::new(MicrofacetType::Ggx, alpha, true),
                eta: Vec3::ZERO,
                k: Vec3::ONE,
                specular_reflectance: Vec3::ONE,
            })
        }
        other => panic!("no nested BSDF '{other}'"),
    }
}

/// The remainder table of `which` (walk-built, or the exact Lambert table for diffuse ones).
fn table(which: &str, geometry: Microgeometry, tangent: Tangent) -> &'static MsTable {
    let node = nested(which);
    let lambert = matches!(node, BsdfNode::Diffuse(_));
    let spec = TableSpec {
        geometry,
        tangent,
        max_order: 256,
        max_theta: MAX_THETA.to_radians(),
        colour: if lambert {
            Colour::PerBounce
        } else {
            Colour::Baked
        },
        walks: WALKS_PER_NODE,
    };
    let key = format!("test {lambert} {node:?} {geometry:?} {tangent:?}");
    ms_cache::get_or_build(&key, spec, || {
        if lambert {
            MsTable::lambert(spec, key.clone())
        } else {
            let mut arena = BsdfArena::new();
            let root = arena.push(node);
            MsTable::from_walk(&arena.bsdf(root), root, spec, key.clone())
        }
    })
    .0
}

/// A microfacet normal map over `which` (Lambert closed forms off); compensated ones get their
/// table.
fn mnm(
    which: &str,
    wp: Vec3,
    (g, t): (Microgeometry, Tangent),
    e: Evaluation,
    tab: Option<&'static MsTable>,
) -> (ArenaBsdf, MicrofacetNormalMap) {
    let mut arena = BsdfArena::new();
    let child = arena.push(nested(which));
    let m = MicrofacetNormalMap::new(child, wp, g, t, e, 256)
        .with_lambert_closed_form(false)
        .with_ms_table(tab);
    assert_eq!(m.uses_ms_table(), e == Evaluation::Compensated);
    let root = arena.push_microfacet_normal_map(m);
    (
        ArenaBsdf {
            arena,
            root,
            ctx: BsdfContext {
                mode: TransportMode::Radiance,
            },
            deterministic: e != Evaluation::RandomWalk,
        },
        m,
    )
}

/// The first order the compensated model adds its remainder to.
fn first_order_of(g: Microgeometry, t: Tangent) -> Evaluation {
    if g == Microgeometry::Sawtooth && t == Tangent::Mirror {
        Evaluation::ExplicitComplete
    } else {
        Evaluation::Explicit
    }
}

/// ∫ F(ωo) dωo over the hemisphere by the midpoint rule in (u = z², φ): z dω = du dφ / 2.
fn integrate(nu: usize, nphi: usize, f: impl Fn(Vec3) -> Vec3 + Sync) -> glam::DVec3 {
    (0..nu)
        .into_par_iter()
        .map(|i| {
            let u = (i as f32 + 0.5) / nu as f32;
            let z = u.sqrt();
            let r = (1.0 - u).max(0.0).sqrt();
            let mut acc = glam::DVec3::ZERO;
            for j in 0..nphi {
                let phi = 2.0 * std::f32::consts::PI * (j as f32 + 0.5) / nphi as f32;
                let wo = Vec3::new(r * phi.cos(), r * phi.sin(), z);
                acc += (f(wo) / z).as_dvec3();
            }
            acc
        })
        .sum::<glam::DVec3>()
        * (std::f64::consts::PI / (nu * nphi) as f64)
}

const GEOMETRIES: [(Microgeometry, Tangent); 3] = [
    (Microgeometry::Sawtooth, Tangent::Mirror),
    (Microgeometry::Sawtooth, Tangent::Same),
    (Microgeometry::VGroove, Tangent::Same),
];

/// ∫ f_ms(ωi, ωo) z dωo = E_ms(ωi) within 1e-3 (512 × 1024 quadrature of eval(compensated) −
/// eval(first order)), at random θp and ωi (off the nodes), nested gold, plastic, white GGX 0.3.
#[test]
fn remainder_integrates_to_its_energy() {
    let mut r = Sampler::from_seed(31, 7);
    for which in ["gold", "plastic", "mirror0.3"] {
        for (g, t) in GEOMETRIES {
            let tab = Some(table(which, g, t));
            for _ in 0..3 {
                let wp = direction(80.0 * r.next_1d(), 360.0 * r.next_1d());
                let wi = direction(88.0 * r.next_1d(), 360.0 * r.next_1d());
                let (comp, m) = mnm(which, wp, (g, t), Evaluation::Compensated, tab);
                let (first, _) = mnm(which, wp, (g, t), first_order_of(g, t), None);
                let (e, _) = m.remainder_energy(Vec3::ONE, wi).expect("a table");
                let got = integrate(512, 1024, |wo| {
                    let mut s = Sampler::from_seed(0, 0);
                    comp.eval(wi, wo, &mut s) - first.eval(wi, wo, &mut s)
                });
                let err = (got - e.as_dvec3()).abs().max_element();
                assert!(
                    err <= 1e-3,
                    "{which} {g:?} {t:?} ωp {wp} ωi {wi}: ∫f_ms z = {got} vs E_ms = {e}"
                );
            }
        }
    }
}

/// f_ms(i,o) = f_ms(o,i) within 1e-6 of max f, and the whole model reciprocal as its first order
/// is (2e-5, the nested BSDFs' f32 rounding; `mnm_first_order.rs`), on 2·10⁴ random pairs.
#[test]
fn compensated_is_reciprocal() {
    for which in ["gold", "plastic", "mirror0.3"] {
        for (g, t) in GEOMETRIES {
            let tab = Some(table(which, g, t));
            let mut r = Sampler::from_seed(41, 3);
            let mut s = Sampler::from_seed(1, 2);
            let (mut worst_ms, mut worst) = (0.0f32, 0.0f32);
            for _ in 0..20_000 {
                let wp = direction(85.0 * r.next_1d(), 360.0 * r.next_1d());
                let (wi, wo) = (hemi(&mut r), hemi(&mut r));
                if wi.z < 0.01 || wo.z < 0.01 {
                    continue;
                }
                let (comp, _) = mnm(which, wp, (g, t), Evaluation::Compensated, tab);
                let (first, _) = mnm(which, wp, (g, t), first_order_of(g, t), None);
                let fab = comp.eval(wi, wo, &mut s) / wo.z;
                let fba = comp.eval(wo, wi, &mut s) / wi.z;
                let mab = fab - first.eval(wi, wo, &mut s) / wo.z;
                let mba = fba - first.eval(wo, wi, &mut s) / wi.z;
                let m = fab.max_element().max(fba.max_element());
                if m > 0.0 {
                    worst_ms = worst_ms.max((mab - mba).abs().max_element() / m);
                    worst = worst.max((fab - fba).abs().max_element() / m);
                }
            }
            eprintln!("{which} {g:?} {t:?}: remainder {worst_ms:.2e}, whole {worst:.2e}");
            assert!(
                worst_ms <= 1e-6,
                "{which} {g:?} {t:?}: remainder asymmetric by {worst_ms:.2e}"
            );
            assert!(
                worst <= 2e-5,
                "{which} {g:?} {t:?}: not reciprocal, {worst:.2e}"
            );
        }
    }
}

/// A uniform direction on the upper hemisphere.
fn hemi(r: &mut Sampler) -> Vec3 {
    let u = r.next_2d();
    let z = u.x;
    let s = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    Vec3::new(s * phi.cos(), s * phi.sin(), z)
}

/// Albedo of a BSDF from ωi: the quadrature of its eval (deterministic models).
fn albedo(b: &ArenaBsdf, wi: Vec3) -> glam::DVec3 {
    integrate(256, 512, |wo| b.eval(wi, wo, &mut Sampler::from_seed(0, 0)))
}

/// The walk's albedo from ωi (mean sample weight; failures count 0) and its standard error.
fn walk_albedo(b: &ArenaBsdf, wi: Vec3, n: usize, seed: u64) -> (glam::DVec3, glam::DVec3) {
    let (sum, sq) = (0..16u64)
        .into_par_iter()
        .map(|c| {
            let mut s = Sampler::from_seed(seed, c);
            let (mut a, mut q) = (glam::DVec3::ZERO, glam::DVec3::ZERO);
            for _ in 0..n / 16 {
                if let Some(bs) = b.sample(wi, &mut s) {
                    let w = bs.weight.as_dvec3();
                    a += w;
                    q += w * w;
                }
            }
            (a, q)
        })
        .reduce(
            || (glam::DVec3::ZERO, glam::DVec3::ZERO),
            |x, y| (x.0 + y.0, x.1 + y.1),
        );
    let nn = (n / 16 * 16) as f64;
    let mean = sum / nn;
    let var = (sq / nn - mean * mean).max(glam::DVec3::ZERO);
    (mean, (var / nn).map(f64::sqrt))
}

/// Between table nodes (θp off the θp nodes, which are every 85°/12 = 7.08°; ωi off the z and φ
/// nodes) the compensated albedo agrees with the walk's within the interpolation and table-noise
/// error measured here (printed; `docs/mnm.md`): |difference| − 4σ(walk) ≤ 0.06 for the rough
/// nested BSDFs (measured worst 0.051, gold at θp 45.9°), ≤ 0.12 over the polished α 0.1
/// conductor, outside the model's range (measured worst 0.094).
#[test]
fn compensated_albedo_matches_the_walk_between_nodes() {
    let mut worst = (0.0f64, String::new());
    let mut fails = Vec::new();
    for which in ["gold", "plastic", "mirror0.3", "mirror0.1"] {
        let tol = if which == "mirror0.1" { 0.12 } else { 0.06 };
        for (g, t) in GEOMETRIES {
            let tab = Some(table(which, g, t));
            let mut lines = Vec::new();
            let mut sum = 0.0;
            for tp in [10.6f32, 24.8, 45.9, 63.7] {
                for (ti, pi) in [
                    (20.0f32, 10.0f32),
                    (50.0, 100.0),
                    (70.0, 170.0),
                    (80.0, 60.0),
                ] {
                    let wp = direction(tp, 30.0);
                    let wi = direction(ti, 30.0 + pi);
                    let (comp, _) = mnm(which, wp, (g, t), Evaluation::Compensated, tab);
                    let (walk, _) = mnm(which, wp, (g, t), Evaluation::RandomWalk, None);
                    let a = albedo(&comp, wi);
                    let (w, se) = walk_albedo(&walk, wi, 200_000, 99);
                    let d = (a - w).abs().max_element();
                    sum += d;
                    let case = format!("{which} {g:?} {t:?} θp {tp} ωi ({ti},{pi})");
                    if d > worst.0 {
                        worst = (d, case.clone());
                    }
                    lines.push(format!(
                        "  θp {tp:4.1} ωi ({ti},{pi}): comp {:.4} walk {:.4} ± {:.4} (diff {:+.4})",
                        a.x,
                        w.x,
                        se.x,
                        a.x - w.x
                    ));
                    if ((a - w).abs() - 4.0 * se).max_element() > tol {
                        fails.push(format!("{case}: compensated {a} vs walk {w} ± {se}"));
                    }
                }
            }
            eprintln!(
                "{which} {g:?} {t:?}: mean |diff| {:.4}\n{}",
                sum / 16.0,
                lines.join("\n")
            );
        }
    }
    eprintln!("worst |albedo difference| {:.4} ({})", worst.0, worst.1);
    assert!(fails.is_empty(), "{}", fails.join("\n"));
}

/// The BSDF harness (tests/common/chi2.rs): chi-square of sample against pdf, weight == eval/pdf
/// pointwise, per-cell sample weights against ∫eval, albedo ≤ 1, over nested white diffuse (the
/// exact Lambert table), rough gold, rough plastic and a white GGX α 0.1 conductor × mirror
/// sawtooth and V-groove × θp {30°, 65°} × two ωi (Šidák α = 0.01 over all cases).
#[test]
fn compensated_passes_the_bsdf_harness() {
    const N: usize = 200_000;
    let mut cases = Vec::new();
    for which in ["white", "gold", "plastic", "mirror0.1"] {
        for gt in [GEOMETRIES[0], GEOMETRIES[2]] {
            let tab = Some(table(which, gt.0, gt.1));
            for tp in [30.0f32, 65.0] {
                for (ti, pi) in [(15.0f32, 0.0f32), (60.0, 180.0)] {
                    let wp = direction(tp, 0.0);
                    let (b, _) = mnm(which, wp, gt, Evaluation::Compensated, tab);
                    cases.push((
                        format!("{which} {gt:?} θp={tp} θi={ti} φi={pi}"),
                        b,
                        direction(ti, pi),
                    ));
                }
            }
        }
    }
    let level = Sidak::new(0.01, cases.len()).level();
    let fails: Vec<String> = cases
        .par_iter()
        .enumerate()
        .flat_map(|(i, (name, b, wi))| {
            let seed = 7000 + i as u64;
            let grid = Grid::default();
            let s = draw(b, *wi, &grid, N, seed, true);
            let cells = cell_integrals(b, *wi, &grid, N, seed);
            let mut f = Vec::new();
            let mut check = |what: &str, r: Outcome| {
                if let Err(e) = r {
                    f.push(format!("[{name}] {what}: {e}"));
                }
            };
            check(
                "chi2 sample vs pdf",
                chi2_sample_vs_pdf(&s, &cells.pdf, level / 2.0),
            );
            check("weight == eval/pdf", weight_matches_eval_over_pdf(&s));
            check(
                "cell weight vs eval",
                cell_consistency(&s, &cells, level / 2.0),
            );
            // Over the polished conductor (α 0.1) the model gains energy between table nodes
            // (measured up to 4 %, docs/mnm.md): outside its range, not checked here.
            if !name.starts_with("mirror0.1") {
                check("albedo ≤ 1", furnace_test(&s, false));
            }
            f
        })
        .collect();
    assert!(
        fails.is_empty(),
        "{} failures:\n{}",
        fails.len(),
        fails.join("\n")
    );
}

/// White furnace with a white Lambertian nested BSDF and the exact Lambert table (mirror
/// sawtooth, the closed forms off so that the compensated model itself evaluates): ∫eval = 1 ±
/// 1e-4 at θp off the nodes, for several ωi; the mean sample weight is 1 within 4σ. With colour
/// ρ at the θp nodes the albedo is the walk's exact ρ cosθp / (1 − ρ(1 − cosθp)) to 1e-4.
#[test]
fn white_furnace_with_the_exact_lambert_table() {
    let gt = GEOMETRIES[0];
    let tab = Some(table("white", gt.0, gt.1));
    for tp in [3.0f32, 17.0, 41.0, 63.0, 80.0] {
        for (ti, pi) in [(0.0f32, 0.0f32), (30.0, 45.0), (60.0, 180.0), (85.0, 95.0)] {
            let wp = direction(tp, 20.0);
            let wi = direction(ti, pi);
            let (b, _) = mnm("white", wp, gt, Evaluation::Compensated, tab);
            let a = albedo(&b, wi);
            assert!(
                (a - glam::DVec3::ONE).abs().max_element() <= 1e-4,
                "θp {tp} ωi ({ti},{pi}): white furnace {a}"
            );
            let (w, se) = walk_albedo(&b, wi, 100_000, 3);
            assert!(
                ((w - glam::DVec3::ONE).abs() - 4.0 * se).max_element() <= 0.0,
                "θp {tp} ωi ({ti},{pi}): mean weight {w} ± {se}"
            );
        }
    }
    let rho = Vec3::new(0.9, 0.6, 0.3);
    for j in [1usize, 4, 8, 11] {
        let tp = 85.0 * j as f32 / 12.0;
        let wp = direction(tp, 0.0);
        let (b, _) = mnm(
            "diffuse",
            wp,
            gt,
            Evaluation::Compensated,
            Some(table("diffuse", gt.0, gt.1)),
        );
        let c = wp.z;
        let want = rho * c / (Vec3::ONE - rho * (1.0 - c));
        for wi in [direction(0.0, 0.0), direction(50.0, 135.0)] {
            let a = albedo(&b, wi);
            assert!(
                (a - want.as_dvec3()).abs().max_element() <= 1e-4,
                "θp {tp}: coloured Lambert albedo {a} vs {want}"
            );
        }
    }
}

/// No gain: the compensated albedo (384 × 768 quadrature) never exceeds 1 + 1e-3 over the least
/// lossy nested BSDF in the model's range (a white GGX α 0.3 conductor) on a (θp, ωi) grid off
/// the table nodes. (Over α 0.1 it does, by up to 4 %: docs/mnm.md.)
#[test]
fn compensated_never_gains_energy() {
    let mut worst = 0.0f64;
    for which in ["mirror0.3"] {
        for gt in [GEOMETRIES[0], GEOMETRIES[2]] {
            let tab = Some(table(which, gt.0, gt.1));
            for tp in [10.0f32, 20.0, 30.0, 40.0, 50.0, 60.0, 70.0, 85.0] {
                for ti in [0.0f32, 15.0, 40.0, 70.0, 85.0] {
                    for pi in [0.0f32, 90.0, 180.0] {
                        let wp = direction(tp, 0.0);
                        let wi = direction(ti, pi);
                        let (b, _) = mnm(which, wp, gt, Evaluation::Compensated, tab);
                        let a =
                            integrate(384, 768, |wo| b.eval(wi, wo, &mut Sampler::from_seed(0, 0)))
                                .max_element();
                        worst = worst.max(a);
                        assert!(
                            a <= 1.0 + 1e-3,
                            "{which} {gt:?} θp {tp} ωi ({ti},{pi}): albedo {a}"
                        );
                    }
                }
            }
        }
    }
    eprintln!("largest compensated albedo {worst:.5}");
}

/// Eval, pdf and eval_pdf consume no random numbers and give identical results for different
/// sampler states.
#[test]
fn compensated_eval_is_deterministic() {
    let gt = GEOMETRIES[0];
    let tab = Some(table("gold", gt.0, gt.1));
    let mut r = Sampler::from_seed(9, 9);
    for _ in 0..1000 {
        let wp = direction(70.0 * r.next_1d(), 360.0 * r.next_1d());
        let (b, _) = mnm("gold", wp, gt, Evaluation::Compensated, tab);
        let (wi, wo) = (hemi(&mut r), hemi(&mut r));
        let mut s1 = Sampler::from_seed(1, 1);
        let mut s2 = Sampler::from_seed(2, 2);
        let before = s1.clone();
        let f1 = b.eval(wi, wo, &mut s1);
        let f2 = b.eval(wi, wo, &mut s2);
        let (g, p) = b.arena.bsdf(b.root).eval_pdf(&b.ctx, wi, wo, &mut s1);
        assert_eq!(f1, f2);
        assert_eq!(f1, g);
        let q = b.pdf(wi, wo);
        assert!(
            (p - q).abs() <= 1e-5 * p.max(q),
            "eval_pdf's pdf {p} vs pdf {q}"
        );
        assert_eq!(
            s1.clone().next_1d(),
            before.clone().next_1d(),
            "eval drew random numbers"
        );
    }
}

/// The per-point cache of the incident direction (`with_incident`, built with the BSDF at a
/// hit: λ(ωi), the entries in the facet frame, E_ms(ωi) and the lobe choice) changes nothing:
/// eval, pdf, eval_pdf and sample (same random numbers) bit for bit with and without it, for the
/// cached ωi and for a query from another ωi (which must ignore the cache). Over gold, plastic
/// (sample records used for the drawn path) and white Lambert (per-bounce colour table) × the
/// mirror sawtooth and the V-groove (single scattering) × random θp.
#[test]
fn incident_cache_changes_nothing() {
    fn bits(v: Vec3) -> [u32; 3] {
        v.to_array().map(f32::to_bits)
    }
    let mut r = Sampler::from_seed(17, 3);
    for which in ["gold", "plastic", "white"] {
        for gt in [GEOMETRIES[0], GEOMETRIES[2]] {
            let tab = Some(table(which, gt.0, gt.1));
            for _ in 0..300 {
                let wp = direction(80.0 * r.next_1d(), 360.0 * r.next_1d());
                let wi = hemi(&mut r);
                let (plain, m) = mnm(which, wp, gt, Evaluation::Compensated, tab);
                let mut arena = BsdfArena::new();
                let child = arena.push(nested(which));
                assert_eq!(child, m.nested);
                let root = arena.push_microfacet_normal_map(m.with_incident(wi));
                let cached = ArenaBsdf {
                    arena,
                    root,
                    ctx: plain.ctx,
                    deterministic: true,
                };
                for q in [wi, hemi(&mut r)] {
                    let wo = hemi(&mut r);
                    let mut s1 = Sampler::from_seed(5, r.next_1d().to_bits() as u64);
                    let mut s2 = s1.clone();
                    let what = format!("{which} {gt:?} wp {wp} wi {q} wo {wo}");
                    assert_eq!(
                        bits(plain.eval(q, wo, &mut s1)),
                        bits(cached.eval(q, wo, &mut s2)),
                        "eval: {what}"
                    );
                    assert_eq!(
                        plain.pdf(q, wo).to_bits(),
                        cached.pdf(q, wo).to_bits(),
                        "pdf: {what}"
                    );
                    let (f1, p1) = plain
                        .arena
                        .bsdf(plain.root)
                        .eval_pdf(&plain.ctx, q, wo, &mut s1);
                    let (f2, p2) =
                        cached
                            .arena
                            .bsdf(cached.root)
                            .eval_pdf(&cached.ctx, q, wo, &mut s2);
                    assert_eq!((bits(f1), p1.to_bits()), (bits(f2), p2.to_bits()), "{what}");
                    let a = plain.sample(q, &mut s1);
                    let b = cached.sample(q, &mut s2);
                    assert_eq!(
                        a.map(|a| (bits(a.wo), a.pdf.to_bits(), bits(a.weight))),
                        b.map(|b| (bits(b.wo), b.pdf.to_bits(), bits(b.weight))),
                        "sample: {what}"
                    );
                }
            }
        }
    }
}
