//! The fused next-event query of microfacet normal mapping (`Bsdf::eval_pdf`) and the fused
//! eval/pdf inside explicit sampling agree with separate `eval` and `pdf` calls (deterministic
//! closed forms, spec §3 and §4): the optimisation must not change any value beyond rounding.

use crate::common;

use common::dir;
use glam::Vec3;
use groove::bsdf::mnm::facets::Microgeometry;
use groove::bsdf::mnm::{Evaluation, MicrofacetNormalMap, Tangent};
use groove::bsdf::*;
use groove::sampler::Sampler;

fn nested_nodes() -> Vec<BsdfNode> {
    vec![
        common::rough_gold(0.3),
        common::rough_plastic(MicrofacetType::Ggx, 0.2, true),
        BsdfNode::Diffuse(Diffuse {
            reflectance: Vec3::splat(0.7),
        }),
    ]
}

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-5 * a.abs().max(b.abs()) + 1e-7
}

/// `eval_pdf` at (wi, wo) equals separate `eval` and `pdf`. `eval_pdf` draws from `s`; `eval`
/// from `s_eval` when given (a walk's eval is stochastic: pass a sampler in `s`'s starting
/// state), else from `s` after it.
#[allow(clippy::too_many_arguments)]
fn assert_fused_matches(
    g: Microgeometry,
    t: Tangent,
    b: &Bsdf,
    ctx: &BsdfContext,
    wi: Vec3,
    wo: Vec3,
    s: &mut Sampler,
    s_eval: Option<&mut Sampler>,
) {
    let (f, p) = b.eval_pdf(ctx, wi, wo, s);
    let f0 = b.eval(ctx, wi, wo, s_eval.unwrap_or(s));
    let p0 = b.pdf(ctx, wi, wo);
    assert!(close(p, p0), "{g:?} {t:?} pdf {p} vs {p0}");
    for c in 0..3 {
        assert!(close(f[c], f0[c]), "{g:?} {t:?} eval {f} vs {f0}");
    }
}

/// Every (nested BSDF, microgeometry, query index) with `evaluation`: calls `f` with the
/// microgeometry, tangent, index, the microfacet normal-mapped BSDF and a (wi, wo) pair.
fn for_each_query(
    evaluation: Evaluation,
    mut f: impl FnMut(Microgeometry, Tangent, u64, &Bsdf, Vec3, Vec3),
) {
    let geometries = [
        (Microgeometry::Sawtooth, Tangent::Mirror),
        (Microgeometry::Sawtooth, Tangent::Same),
        (Microgeometry::VGroove, Tangent::Same),
        (Microgeometry::UGroove { fill: 0.5 }, Tangent::Same),
    ];
    for node in nested_nodes() {
        for (g, t) in geometries {
            for i in 0..400u64 {
                let mut arena = BsdfArena::new();
                let nested = arena.push(node);
                let wp = dir(70.0 * ((i * 7 % 400) as f32 / 400.0), 13.0 * i as f32);
                let root = arena.push_microfacet_normal_map(MicrofacetNormalMap::new(
                    nested, wp, g, t, evaluation, 256,
                ));
                let wi = dir(88.0 * (i as f32 / 400.0), 37.0 * i as f32);
                let wo = dir((3.0 + 0.7 * i as f32) % 89.0, 11.0 * i as f32 + 5.0);
                f(g, t, i, &arena.bsdf(root), wi, wo);
            }
        }
    }
}

#[test]
fn explicit_eval_pdf_and_sample_match_separate_queries() {
    let ctx = BsdfContext::default();
    let mut checked = 0;
    for_each_query(Evaluation::Explicit, |g, t, i, b, wi, wo| {
        let mut s = Sampler::from_seed(i, 3);
        assert_fused_matches(g, t, b, &ctx, wi, wo, &mut s, None);
        if let Some(bs) = b.sample(&ctx, wi, &mut s) {
            let f1 = b.eval(&ctx, wi, bs.wo, &mut s);
            let p1 = b.pdf(&ctx, wi, bs.wo);
            assert!(
                close(bs.pdf, p1),
                "{g:?} {t:?} sample pdf {} vs {p1}",
                bs.pdf
            );
            for c in 0..3 {
                assert!(close(bs.weight[c] * bs.pdf, f1[c]), "{g:?} {t:?} weight");
            }
            checked += 1;
        }
    });
    assert!(checked > 1000, "{checked}");
}

/// The lobes a BSDF declares (`Bsdf::lobes`, computed when its node is pushed) cover every lobe
/// its samples report, and a BSDF without smooth lobes evaluates to zero: for the nested BSDFs
/// and microfacet normal maps over them, both evaluations.
#[test]
fn sampled_lobes_are_declared() {
    let ctx = BsdfContext::default();
    let mut nodes = nested_nodes();
    nodes.push(common::rough_glass(0.3));
    let mut seen = 0;
    for node in nodes {
        for e in [Evaluation::Explicit, Evaluation::RandomWalk] {
            for i in 0..100u64 {
                let wp = dir(5.0 + 0.6 * i as f32, 29.0 * i as f32);
                let mut arena = BsdfArena::new();
                let nested = arena.push(node);
                let m = MicrofacetNormalMap::new(
                    nested,
                    wp,
                    Microgeometry::Sawtooth,
                    Tangent::Mirror,
                    e,
                    256,
                );
                let root = arena.push_microfacet_normal_map(m);
                let wi = dir(85.0 * (i as f32 / 100.0), 37.0 * i as f32);
                let mut s = Sampler::from_seed(i, 5);
                for b in [arena.bsdf(nested), arena.bsdf(root)] {
                    let declared = b.lobes();
                    assert!(!declared.is_empty());
                    if let Some(bs) = b.sample(&ctx, wi, &mut s) {
                        assert!(
                            declared.contains(bs.lobe),
                            "{:?} not in {declared:?}",
                            bs.lobe
                        );
                        seen += 1;
                    }
                    if !declared.is_smooth() {
                        let wo = dir(40.0, 11.0 * i as f32);
                        assert_eq!(b.eval(&ctx, wi, wo, &mut s), Vec3::ZERO);
                    }
                }
            }
        }
    }
    assert!(seen > 1000, "{seen}");
}

/// The random walk's fused next-event query: with the same random numbers, `eval_pdf` gives the
/// walk's `eval` estimate and the MIS density `pdf` up to rounding (the first vertices' nested
/// evaluations share their pdf with the density's terms). A sampled walk reports the density
/// `pdf` gives its direction (a single-vertex walk reuses the nested sample's own density).
#[test]
fn walk_eval_pdf_and_sample_pdf_match_separate_queries() {
    let ctx = BsdfContext::default();
    let mut sampled = 0;
    for_each_query(Evaluation::RandomWalk, |g, t, i, b, wi, wo| {
        let (mut sa, mut sb) = (Sampler::from_seed(i, 7), Sampler::from_seed(i, 7));
        assert_fused_matches(g, t, b, &ctx, wi, wo, &mut sa, Some(&mut sb));
        if let Some(bs) = b.sample(&ctx, wi, &mut sa) {
            let p1 = b.pdf(&ctx, wi, bs.wo);
            assert!(
                (bs.pdf - p1).abs() <= 1e-4 * p1.abs() + 1e-6,
                "{g:?} {t:?} sample pdf {} vs {p1}",
                bs.pdf
            );
            sampled += 1;
        }
    });
    assert!(sampled > 1000, "{sampled}");
}
