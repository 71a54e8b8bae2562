//! Statistical verification of every BSDF model (see `tests/common/chi2.rs` for the tests).
//!
//! Sample counts: each case draws N = 200 000 samples. With a 40 × 80 grid (~3 200 cells, the
//! chi-square statistic has sd ≈ √(2·dof) ≈ 80), a relative pdf error ε over a region holding a
//! fraction p of the samples adds ≈ N p ε² to the statistic, so errors with p ε² ≳ 2e-3 are caught
//! (e.g. 15% on a lobe carrying 10% of the mass, 5% on the whole distribution; a wrong
//! normalisation of the whole pdf shows in the "rest" outcome at ≈ 4/√N ≈ 1%). The per-cell
//! weight test (Šidák over ~10³ cells, |z| ≳ 5.5) detects a bias of ≈ 5.5 cv/√(N p_cell) in one
//! cell: ~4% in a cell holding 1% of the samples when the weights vary by 30% (cv); its Σz² and
//! whole-sphere groups catch a bias spread over every cell down to ≈ 0.1% (guard test: 5%).
//! A full run takes ~35 s on 2 shared cores (release, after the build).

use crate::common;

use common::chi2::*;
use glam::Vec3;
use groove::bsdf::fresnel::{fresnel_conductor, fresnel_dielectric};
use groove::bsdf::*;
use groove::sampler::Sampler;
use rayon::prelude::*;

const N: usize = 200_000;

struct Case {
    name: String,
    bsdf: ArenaBsdf,
    wi: Vec3,
    lossless: bool,
    /// Check E[weight] ≤ 1 (not for radiance transport into a denser medium, which focuses).
    furnace: bool,
    /// Known constant-factor pdf error to fit out (see `chi2_sample_vs_pdf_opts`), 0 if none.
    renormalize: f64,
}

/// Tolerance of the fitted pdf normalisation: Beckmann visible-normal pdfs use Walter's G1
/// approximation (as Mitsuba does), exact only to ~0.4%.
fn beckmann_visible(kind: MicrofacetType, sample_visible: bool) -> f64 {
    if kind == MicrofacetType::Beckmann && sample_visible {
        0.005
    } else {
        0.0
    }
}

fn dist_name(k: MicrofacetType) -> &'static str {
    match k {
        MicrofacetType::Beckmann => "beckmann",
        MicrofacetType::Ggx => "ggx",
    }
}

const ROUGHNESS: [(f32, f32); 4] = [(0.05, 0.05), (0.2, 0.2), (0.6, 0.6), (0.1, 0.4)];
const THETA_UP: [f32; 4] = [0.0, 30.0, 60.0, 85.0];
const KINDS: [MicrofacetType; 2] = [MicrofacetType::Beckmann, MicrofacetType::Ggx];

fn cases() -> Vec<Case> {
    let mut v = Vec::new();
    let mode_name = |m: TransportMode| {
        if m == TransportMode::Radiance {
            "rad"
        } else {
            "imp"
        }
    };
    for t in THETA_UP {
        v.push(Case {
            name: format!("diffuse θi={t}"),
            bsdf: ArenaBsdf::new(
                BsdfNode::Diffuse(Diffuse {
                    reflectance: Vec3::new(0.2, 0.5, 0.8),
                }),
                TransportMode::Radiance,
            ),
            wi: direction(t, 40.0),
            lossless: false,
            furnace: true,
            renormalize: 0.0,
        });
    }
    // twosided diffuse seen from below
    {
        let mut arena = BsdfArena::new();
        let d = arena.push(BsdfNode::Diffuse(Diffuse {
            reflectance: Vec3::splat(1.0),
        }));
        let root = arena.push(BsdfNode::TwoSided { front: d, back: d });
        v.push(Case {
            name: "twosided(diffuse) θi=140".into(),
            bsdf: ArenaBsdf {
                arena,
                root,
                ctx: BsdfContext::default(),
                deterministic: true,
            },
            wi: direction(140.0, 10.0),
            lossless: true,
            furnace: true,
            renormalize: 0.0,
        });
    }
    let (cu_eta, cu_k) = named_conductor("Cu").unwrap();
    for kind in KINDS {
        for (au, av) in ROUGHNESS {
            for sv in [true, false] {
                for t in THETA_UP {
                    let distribution = MicrofacetDistribution::anisotropic(kind, au, av, sv);
                    v.push(Case {
                        name: format!(
                            "roughconductor Cu {} α=({au},{av}) visible={sv} θi={t}",
                            dist_name(kind)
                        ),
                        bsdf: ArenaBsdf::new(
                            BsdfNode::RoughConductor(RoughConductor {
                                distribution,
                                eta: cu_eta,
                                k: cu_k,
                                specular_reflectance: Vec3::ONE,
                            }),
                            TransportMode::Radiance,
                        ),
                        wi: direction(t, 40.0),
                        lossless: false,
                        furnace: true,
                        renormalize: beckmann_visible(kind, sv),
                    });
                }
            }
        }
    }
    for kind in KINDS {
        for (au, av) in ROUGHNESS {
            for sv in [true, false] {
                let modes: &[TransportMode] = if au == 0.2 {
                    &[TransportMode::Importance, TransportMode::Radiance]
                } else {
                    &[TransportMode::Importance]
                };
                for &mode in modes {
                    for t in [0.0, 30.0, 60.0, 85.0, 150.0, 120.0] {
                        let distribution = MicrofacetDistribution::anisotropic(kind, au, av, sv);
                        let wi = direction(t, 40.0);
                        v.push(Case {
                            name: format!(
                                "roughdielectric {} α=({au},{av}) visible={sv} {} θi={t}",
                                dist_name(kind),
                                mode_name(mode)
                            ),
                            bsdf: ArenaBsdf::new(
                                BsdfNode::RoughDielectric(RoughDielectric::new(
                                    distribution,
                                    1.5046,
                                    1.000277,
                                    Vec3::ONE,
                                    Vec3::ONE,
                                )),
                                mode,
                            ),
                            wi,
                            lossless: false,
                            furnace: mode == TransportMode::Importance || wi.z > 0.0,
                            renormalize: beckmann_visible(kind, sv),
                        });
                    }
                }
            }
        }
    }
    for kind in KINDS {
        for a in [0.05, 0.2, 0.6] {
            for sv in [true, false] {
                for (i, t) in THETA_UP.into_iter().enumerate() {
                    let nonlinear = i % 2 == 1;
                    v.push(Case {
                        name: format!(
                            "roughplastic {} α={a} visible={sv} nonlinear={nonlinear} θi={t}",
                            dist_name(kind)
                        ),
                        bsdf: ArenaBsdf::new(
                            BsdfNode::RoughPlastic(RoughPlastic::new(
                                kind,
                                a,
                                sv,
                                Vec3::new(0.2, 0.5, 0.8),
                                Vec3::ONE,
                                1.49,
                                1.000277,
                                nonlinear,
                            )),
                            TransportMode::Radiance,
                        ),
                        wi: direction(t, 40.0),
                        lossless: false,
                        furnace: true,
                        renormalize: beckmann_visible(kind, sv),
                    });
                }
            }
        }
    }
    // Delta-only models: all mass in the "rest" outcome; lossless in importance mode.
    for t in [0.0, 60.0, 150.0] {
        for (name, node) in [
            ("dielectric", BsdfNode::Dielectric(Dielectric::default())),
            (
                "thindielectric",
                BsdfNode::ThinDielectric(ThinDielectric::default()),
            ),
            ("conductor none", BsdfNode::Conductor(Conductor::default())),
        ] {
            if name.starts_with("conductor") && t > 90.0 {
                continue;
            }
            v.push(Case {
                name: format!("{name} imp θi={t}"),
                bsdf: ArenaBsdf::new(node, TransportMode::Importance),
                wi: direction(t, 40.0),
                lossless: true,
                furnace: true,
                renormalize: 0.0,
            });
        }
    }
    for nonlinear in [false, true] {
        for t in THETA_UP {
            v.push(Case {
                name: format!("plastic nonlinear={nonlinear} θi={t}"),
                bsdf: ArenaBsdf::new(
                    BsdfNode::Plastic(Plastic::new(
                        Vec3::new(0.2, 0.5, 0.8),
                        Vec3::ONE,
                        1.49,
                        1.000277,
                        nonlinear,
                    )),
                    TransportMode::Radiance,
                ),
                wi: direction(t, 40.0),
                lossless: false,
                furnace: true,
                renormalize: 0.0,
            });
        }
    }
    v
}

/// Run the statistical tests of one case; `level` is its Šidák share (two p-value tests per case).
fn run_case(c: &Case, seed: u64, level: f64) -> Vec<String> {
    let grid = Grid::default();
    let cells = cell_integrals(&c.bsdf, c.wi, &grid, N, seed);
    let s = draw(&c.bsdf, c.wi, &grid, N, seed, c.bsdf.deterministic());
    let mut fails = Vec::new();
    let mut check = |what: &str, r: Outcome| {
        if let Err(e) = r {
            fails.push(format!("[{}] {what}: {e}", c.name));
        }
    };
    check(
        "chi2 sample vs pdf",
        chi2_sample_vs_pdf_opts(&s, &cells.pdf, level / 2.0, c.renormalize),
    );
    check(
        "cell weight vs eval",
        cell_consistency_opts(&s, &cells, level / 2.0, c.renormalize),
    );
    if c.bsdf.deterministic() {
        check("weight == eval/pdf", weight_matches_eval_over_pdf(&s));
    }
    if c.furnace {
        check("white furnace", furnace_test(&s, c.lossless));
    }
    fails
}

/// Run the cases of one model (the first word of a case name). The Šidák level accounts for all
/// cases of all models, so the whole suite keeps α = 0.01.
fn run_model(models: &[&str]) {
    let all = cases();
    let level = Sidak::new(0.01, all.len()).level();
    let mine: Vec<(usize, &Case)> = all
        .iter()
        .enumerate()
        .filter(|(_, c)| models.contains(&c.name.split(' ').next().unwrap()))
        .collect();
    assert!(!mine.is_empty());
    let fails: Vec<String> = mine
        .par_iter()
        .flat_map(|(i, c)| run_case(c, 1000 + *i as u64, level))
        .collect();
    assert!(
        fails.is_empty(),
        "{} failures in {} cases:\n{}",
        fails.len(),
        mine.len(),
        fails.join("\n")
    );
}

#[test]
fn statistics_diffuse_and_twosided() {
    run_model(&["diffuse", "twosided(diffuse)"]);
}

#[test]
fn statistics_roughconductor() {
    run_model(&["roughconductor"]);
}

#[test]
fn statistics_roughdielectric() {
    run_model(&["roughdielectric"]);
}

#[test]
fn statistics_plastic_and_roughplastic() {
    run_model(&["plastic", "roughplastic"]);
}

#[test]
fn statistics_delta_models() {
    run_model(&["dielectric", "thindielectric", "conductor"]);
}

/// Every case belongs to one of the tests above.
/// Next-event estimation asks `eval_pdf`; it must agree with `eval` and `pdf`, for every case
/// and for the wrappers with a fused path (classic normal map, twosided).
#[test]
fn eval_pdf_equals_eval_and_pdf() {
    let mut fails = Vec::new();
    for (i, c) in cases().iter().enumerate() {
        if let Err(e) = c.bsdf.check_eval_pdf(4000, 500 + i as u64) {
            fails.push(format!("[{}] {e}", c.name));
        }
    }
    let leaves = [
        common::rough_gold(0.3),
        common::rough_plastic(MicrofacetType::Beckmann, 0.2, false),
    ];
    for (k, leaf) in leaves.into_iter().enumerate() {
        for flags in [false, true] {
            let mut arena = BsdfArena::new();
            let nested = arena.push(leaf);
            let nm = arena.push(BsdfNode::NormalMap(NormalMap::new(
                nested,
                Vec3::new(0.4, -0.3, 0.8),
                flags,
                flags,
            )));
            let root = arena.push(BsdfNode::TwoSided {
                front: nm,
                back: nested,
            });
            let b = ArenaBsdf {
                arena,
                root,
                ctx: BsdfContext::default(),
                deterministic: true,
            };
            if let Err(e) = b.check_eval_pdf(4000, 900 + k as u64) {
                fails.push(format!(
                    "[twosided(normalmap(leaf {k}), flags {flags})] {e}"
                ));
            }
        }
    }
    assert!(fails.is_empty(), "{}", fails.join("\n"));
}

#[test]
fn every_case_is_run() {
    let known = [
        "diffuse",
        "twosided(diffuse)",
        "roughconductor",
        "roughdielectric",
        "plastic",
        "roughplastic",
        "dielectric",
        "thindielectric",
        "conductor",
    ];
    for c in cases() {
        assert!(
            known.contains(&c.name.split(' ').next().unwrap()),
            "{}",
            c.name
        );
    }
}

/// The harness must be able to fail: cosine-weighted sampling reported with a uniform pdf.
struct WrongPdf(Diffuse);
impl TestBsdf for WrongPdf {
    fn eval(&self, wi: Vec3, wo: Vec3, _: &mut Sampler) -> Vec3 {
        self.0.eval(wi, wo)
    }
    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if wi.z > 0.0 && wo.z > 0.0 {
            0.5 * std::f32::consts::FRAC_1_PI
        } else {
            0.0
        }
    }
    fn sample(&self, wi: Vec3, s: &mut Sampler) -> Option<BsdfSample> {
        self.0.sample(wi, s.next_2d())
    }
}

/// A "stochastic" BSDF whose sample weights are 5% too high: only the per-cell test can see it.
struct BiasedWeight(Diffuse);
impl TestBsdf for BiasedWeight {
    fn eval(&self, wi: Vec3, wo: Vec3, _: &mut Sampler) -> Vec3 {
        self.0.eval(wi, wo)
    }
    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.0.pdf(wi, wo)
    }
    fn sample(&self, wi: Vec3, s: &mut Sampler) -> Option<BsdfSample> {
        let mut b = self.0.sample(wi, s.next_2d())?;
        // Noisy like a random walk, but biased.
        b.weight *= 1.05 * (0.5 + s.next_1d());
        Some(b)
    }
    fn deterministic(&self) -> bool {
        false
    }
}

#[test]
fn guard_the_harness_rejects_a_wrong_pdf_and_a_biased_weight() {
    let grid = Grid::default();
    let d = Diffuse {
        reflectance: Vec3::splat(0.7),
    };
    let wi = direction(30.0, 0.0);
    let level = Sidak::new(0.01, 1).level();

    let wrong = WrongPdf(d);
    let cells = cell_integrals(&wrong, wi, &grid, N, 1);
    let s = draw(&wrong, wi, &grid, N, 1, false);
    assert!(
        chi2_sample_vs_pdf(&s, &cells.pdf, level).is_err(),
        "uniform pdf for cosine samples accepted"
    );

    let biased = BiasedWeight(d);
    let cells = cell_integrals(&biased, wi, &grid, N, 4);
    let s = draw(&biased, wi, &grid, N, 4, false);
    chi2_sample_vs_pdf(&s, &cells.pdf, level).expect("the directions are right");
    assert!(
        cell_consistency(&s, &cells, level).is_err(),
        "5% weight bias accepted"
    );

    // And the correct diffuse passes both.
    let ok = ArenaBsdf::new(BsdfNode::Diffuse(d), TransportMode::Radiance);
    let cells = cell_integrals(&ok, wi, &grid, N, 3);
    let s = draw(&ok, wi, &grid, N, 3, true);
    chi2_sample_vs_pdf(&s, &cells.pdf, level).unwrap();
    cell_consistency(&s, &cells, level).unwrap();
    weight_matches_eval_over_pdf(&s).unwrap();
}

/// A stochastic BSDF done right: a rough conductor whose `eval` and sample weights are multiplied
/// by independent noise of mean 1 (as a random walk's estimates are). It must pass, with the
/// eval noise accounted for in the per-cell test; the same noise with a 3% bias must not.
struct Noisy {
    inner: ArenaBsdf,
    bias: f32,
}
impl TestBsdf for Noisy {
    fn eval(&self, wi: Vec3, wo: Vec3, s: &mut Sampler) -> Vec3 {
        self.inner.eval(wi, wo, s) * (0.5 + s.next_1d())
    }
    fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.inner.pdf(wi, wo)
    }
    fn sample(&self, wi: Vec3, s: &mut Sampler) -> Option<BsdfSample> {
        let mut b = self.inner.sample(wi, s)?;
        b.weight *= self.bias * (0.5 + s.next_1d());
        Some(b)
    }
    fn deterministic(&self) -> bool {
        false
    }
}

#[test]
fn stochastic_bsdfs_are_tested_in_expectation() {
    let grid = Grid::default();
    let level = Sidak::new(0.01, 2).level();
    let wi = direction(50.0, 10.0);
    let (eta, k) = named_conductor("Au").unwrap();
    for (bias, should_pass) in [(1.0, true), (1.03, false)] {
        let b = Noisy {
            inner: ArenaBsdf::new(
                BsdfNode::RoughConductor(RoughConductor {
                    distribution: MicrofacetDistribution::new(MicrofacetType::Ggx, 0.3, true),
                    eta,
                    k,
                    specular_reflectance: Vec3::ONE,
                }),
                TransportMode::Radiance,
            ),
            bias,
        };
        let cells = cell_integrals(&b, wi, &grid, N, 21);
        let s = draw(&b, wi, &grid, N, 21, false);
        chi2_sample_vs_pdf(&s, &cells.pdf, level).unwrap();
        let r = cell_consistency(&s, &cells, level);
        assert_eq!(r.is_ok(), should_pass, "bias {bias}: {r:?}");
    }
}

#[test]
fn reciprocity_where_it_must_hold() {
    let mut fails = Vec::new();
    let (au_eta, au_k) = named_conductor("Au").unwrap();
    let one = |_: Vec3, _: Vec3| 1.0f32;
    for kind in KINDS {
        for (au, av) in ROUGHNESS {
            let distribution = MicrofacetDistribution::anisotropic(kind, au, av, true);
            let rc = ArenaBsdf::new(
                BsdfNode::RoughConductor(RoughConductor {
                    distribution,
                    eta: au_eta,
                    k: au_k,
                    specular_reflectance: Vec3::ONE,
                }),
                TransportMode::Radiance,
            );
            if let Err(e) = reciprocity(&rc, 2000, 5, &one) {
                fails.push(format!("roughconductor {kind:?} ({au},{av}): {e}"));
            }
            // Radiance mode: f(wo, wi) = (η_o/η_i)² f(wi, wo), η on each direction's side.
            let eta: f32 = 1.5046 / 1.000277;
            let rd = ArenaBsdf::new(
                BsdfNode::RoughDielectric(RoughDielectric::new(
                    distribution,
                    1.5046,
                    1.000277,
                    Vec3::ONE,
                    Vec3::ONE,
                )),
                TransportMode::Radiance,
            );
            let side = move |w: Vec3| -> f32 {
                if w.z > 0.0 {
                    1.0
                } else {
                    eta
                }
            };
            let factor = move |wi: Vec3, wo: Vec3| (side(wo) / side(wi)).powi(2);
            if let Err(e) = reciprocity(&rd, 2000, 6, &factor) {
                fails.push(format!(
                    "roughdielectric radiance {kind:?} ({au},{av}): {e}"
                ));
            }
            // Importance mode: f(wo, wi) = (η_i/η_o)² f(wi, wo).
            let ri = ArenaBsdf::new(
                BsdfNode::RoughDielectric(RoughDielectric::new(
                    distribution,
                    1.5046,
                    1.000277,
                    Vec3::ONE,
                    Vec3::ONE,
                )),
                TransportMode::Importance,
            );
            let factor_i = move |wi: Vec3, wo: Vec3| (side(wi) / side(wo)).powi(2);
            if let Err(e) = reciprocity(&ri, 2000, 7, &factor_i) {
                fails.push(format!(
                    "roughdielectric importance {kind:?} ({au},{av}): {e}"
                ));
            }
            if au == av {
                let rp = ArenaBsdf::new(
                    BsdfNode::RoughPlastic(RoughPlastic::new(
                        kind,
                        au,
                        true,
                        Vec3::new(0.2, 0.5, 0.8),
                        Vec3::ONE,
                        1.49,
                        1.000277,
                        true,
                    )),
                    TransportMode::Radiance,
                );
                if let Err(e) = reciprocity(&rp, 2000, 8, &one) {
                    fails.push(format!("roughplastic {kind:?} {au}: {e}"));
                }
            }
        }
    }
    let p = ArenaBsdf::new(
        BsdfNode::Plastic(Plastic::default()),
        TransportMode::Radiance,
    );
    if let Err(e) = reciprocity(&p, 2000, 9, &one) {
        fails.push(format!("plastic: {e}"));
    }
    assert!(fails.is_empty(), "{}", fails.join("\n"));
}

/// Delta lobes: exact directions, exact weights, and lobe frequencies equal to the Fresnel terms.
#[test]
fn delta_lobes_directions_and_weights() {
    let ctx_r = BsdfContext {
        mode: TransportMode::Radiance,
    };
    let ctx_i = BsdfContext {
        mode: TransportMode::Importance,
    };
    let mut s = Sampler::from_seed(77, 1);
    let mut arena = BsdfArena::new();
    let thetas = [0.0, 30.0, 60.0, 85.0, 100.0, 140.0, 170.0];
    // Conductors: mirror direction, weight = F(η, k) · specular_reflectance; one-sided.
    for name in ["none", "Au", "Cr"] {
        let (eta, k) = named_conductor(name).unwrap();
        arena.clear();
        let root = arena.push(BsdfNode::Conductor(Conductor {
            eta,
            k,
            specular_reflectance: Vec3::new(1.0, 0.5, 0.25),
        }));
        let b = arena.bsdf(root);
        for t in thetas {
            let wi = direction(t, 25.0);
            let r = b.sample(&ctx_r, wi, &mut s);
            if wi.z <= 0.0 {
                assert!(r.is_none(), "conductor is one-sided");
                continue;
            }
            let r = r.unwrap();
            assert!((r.wo - Vec3::new(-wi.x, -wi.y, wi.z)).length() < 1e-6);
            let f = fresnel_conductor(wi.z, eta, k) * Vec3::new(1.0, 0.5, 0.25);
            assert!((r.weight - f).abs().max_element() < 1e-6, "{name} {t}");
            assert_eq!(r.lobe, Lobes::DELTA_REFLECTION);
            assert_eq!(b.eval(&ctx_r, wi, r.wo, &mut s), Vec3::ZERO);
            assert_eq!(b.pdf(&ctx_r, wi, r.wo), 0.0);
        }
        if name == "none" {
            let r = b.sample(&ctx_r, direction(70.0, 0.0), &mut s).unwrap();
            assert!(
                (r.weight - Vec3::new(1.0, 0.5, 0.25)).abs().max_element() < 1e-6,
                "perfect mirror"
            );
        }
    }
    // Dielectric and thin dielectric: lobe frequency = F (binomial z-test, |z| < 5), exact
    // directions (Snell), weights 1 in importance mode and (η_i/η_t)² for radiance refraction.
    let eta = 1.5046f32 / 1.000277;
    let n = 100_000;
    for thin in [false, true] {
        for t in thetas {
            let wi = direction(t, 25.0);
            arena.clear();
            let root = if thin {
                arena.push(BsdfNode::ThinDielectric(ThinDielectric::default()))
            } else {
                arena.push(BsdfNode::Dielectric(Dielectric::default()))
            };
            let b = arena.bsdf(root);
            let f = fresnel_dielectric(wi.z, eta);
            let r_expect = if thin {
                let r = fresnel_dielectric(wi.z.abs(), eta).r;
                2.0 * r / (1.0 + r)
            } else {
                f.r
            };
            let mut refl = 0;
            for i in 0..n {
                let ctx = if i % 2 == 0 { &ctx_r } else { &ctx_i };
                let r = b
                    .sample(ctx, wi, &mut s)
                    .expect("dielectrics always sample");
                if r.lobe == Lobes::DELTA_REFLECTION {
                    refl += 1;
                    assert!((r.wo - Vec3::new(-wi.x, -wi.y, wi.z)).length() < 1e-6);
                    assert_eq!(r.weight, Vec3::ONE);
                    assert_eq!(r.eta, 1.0);
                } else {
                    assert_eq!(r.lobe, Lobes::DELTA_TRANSMISSION);
                    if thin {
                        assert!((r.wo + wi).length() < 1e-6);
                        assert_eq!(r.weight, Vec3::ONE);
                    } else {
                        // Snell: η_i sin θi = η_t sin θt, same azimuth plane, opposite side.
                        let (eta_i, eta_t) = if wi.z > 0.0 { (1.0, eta) } else { (eta, 1.0) };
                        let sin_i = (1.0 - wi.z * wi.z).sqrt();
                        let sin_t = eta_i / eta_t * sin_i;
                        assert!(((1.0 - r.wo.z * r.wo.z).sqrt() - sin_t).abs() < 1e-5);
                        assert!(r.wo.z * wi.z < 0.0 && (r.wo.length() - 1.0).abs() < 1e-5);
                        assert!(
                            (r.wo.x * wi.y - r.wo.y * wi.x).abs() < 1e-6,
                            "plane of incidence"
                        );
                        let expect = if i % 2 == 0 {
                            (eta_i / eta_t).powi(2)
                        } else {
                            1.0
                        };
                        assert!((r.weight - Vec3::splat(expect)).abs().max_element() < 1e-5);
                        assert!((r.eta - eta_t / eta_i).abs() < 1e-5);
                    }
                }
            }
            let p = r_expect as f64;
            let z = (refl as f64 - n as f64 * p) / (n as f64 * p * (1.0 - p)).sqrt().max(1e-9);
            assert!(
                z.abs() < 5.0 || (p == 1.0 && refl == n) || (p == 0.0 && refl == 0),
                "thin={thin} θi={t}: {refl} reflections of {n}, expected F = {p}"
            );
            if f.r == 1.0 && !thin {
                assert_eq!(refl, n, "total internal reflection");
            }
        }
    }
}

/// Grazing and degenerate inputs never produce NaN or infinite values, for every model.
#[test]
fn no_nan_at_grazing_angles_and_sample_corners() {
    let (cu_eta, cu_k) = named_conductor("Cu").unwrap();
    let mut nodes = vec![
        BsdfNode::Conductor(Conductor::default()),
        BsdfNode::Dielectric(Dielectric::default()),
        BsdfNode::ThinDielectric(ThinDielectric::default()),
        BsdfNode::Plastic(Plastic::default()),
    ];
    for kind in KINDS {
        for (au, av) in [(1e-4, 1e-4), (0.05, 0.05), (0.1, 0.4), (1.0, 1.0)] {
            for sv in [true, false] {
                let d = MicrofacetDistribution::anisotropic(kind, au, av, sv);
                nodes.push(BsdfNode::RoughConductor(RoughConductor {
                    distribution: d,
                    eta: cu_eta,
                    k: cu_k,
                    specular_reflectance: Vec3::ONE,
                }));
                nodes.push(BsdfNode::RoughDielectric(RoughDielectric::new(
                    d,
                    1.5046,
                    1.000277,
                    Vec3::ONE,
                    Vec3::ONE,
                )));
                if au == av && au >= 0.05 {
                    nodes.push(BsdfNode::RoughPlastic(RoughPlastic::new(
                        kind,
                        au,
                        sv,
                        Vec3::splat(0.5),
                        Vec3::ONE,
                        1.49,
                        1.000277,
                        false,
                    )));
                }
            }
        }
    }
    let dirs = [
        Vec3::Z,
        -Vec3::Z,
        Vec3::X,
        Vec3::new(1.0, 0.0, 1e-7).normalize(),
        Vec3::new(0.0, 1.0, -1e-7).normalize(),
        direction(89.99, 30.0),
        direction(90.01, 200.0),
        direction(0.01, 0.0),
        direction(179.99, 0.0),
    ];
    let corners = [0.0f32, 1e-7, 0.5, 1.0 - f32::EPSILON];
    let mut arena = BsdfArena::new();
    let mut s = Sampler::from_seed(3, 3);
    for mode in [TransportMode::Radiance, TransportMode::Importance] {
        let ctx = BsdfContext { mode };
        for node in &nodes {
            arena.clear();
            let root = arena.push(*node);
            let b = arena.bsdf(root);
            for wi in dirs {
                for wo in dirs {
                    let e = b.eval(&ctx, wi, wo, &mut s);
                    let p = b.pdf(&ctx, wi, wo);
                    assert!(
                        e.is_finite() && e.min_element() >= 0.0,
                        "{node:?} eval({wi}, {wo}) = {e}"
                    );
                    assert!(p.is_finite() && p >= 0.0, "{node:?} pdf({wi}, {wo}) = {p}");
                }
                // Sample-space corners through the model's own sample function.
                for &u1 in &corners {
                    for &ux in &corners {
                        for &uy in &corners {
                            let u2 = glam::Vec2::new(ux, uy);
                            let r = match node {
                                BsdfNode::RoughConductor(m) => m.sample(wi, u2),
                                BsdfNode::RoughDielectric(m) => m.sample(mode, wi, u1, u2),
                                BsdfNode::RoughPlastic(m) => m.sample(wi, u1, u2),
                                BsdfNode::Plastic(m) => m.sample(wi, u1, u2),
                                BsdfNode::Dielectric(m) => m.sample(mode, wi, u1),
                                BsdfNode::ThinDielectric(m) => m.sample(wi, u1),
                                BsdfNode::Conductor(m) => m.sample(wi),
                                _ => None,
                            };
                            if let Some(r) = r {
                                assert!(
                                    r.wo.is_finite() && (r.wo.length() - 1.0).abs() < 1e-3,
                                    "{node:?} wi {wi} u ({u1}, {u2}): wo {}",
                                    r.wo
                                );
                                assert!(
                                    r.weight.is_finite()
                                        && r.weight.min_element() >= 0.0
                                        && r.pdf.is_finite()
                                        && r.pdf >= 0.0,
                                    "{node:?} wi {wi} u ({u1}, {u2}): {r:?}"
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}
