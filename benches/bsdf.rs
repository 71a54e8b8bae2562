//! Per-call cost of `eval`, `sample` and `pdf` for every normal-mapping mode over several nested
//! BSDFs (issue 5), and of the nested BSDF alone as the baseline.
//!
//! Modes: classic `normalmap` (both Mitsuba 3 flags off: the plain model of the benchmarks'
//! classic side), the explicit sawtooth with a mirror wall (Variant M, and the complete first
//! order `explicit4`), the compensated model (`compensated`: the complete first order plus the
//! tabulated rank-1 remainder; its table is built once, before timing), the random walk with a mirror wall and with a wall of the nested BSDF, the
//! V-groove and the U-groove (s = 0.5). Over diffuse the walks run as their exact closed forms
//! (issue 17); the `*_walk_only` modes switch those off, and `*/build` times the per-hit
//! construction that prepares them.
//! Nested: diffuse, rough conductor (GGX α 0.2, gold), rough plastic (GGX α 0.2), rough
//! dielectric (GGX α 0.2, η 1.5; not with the explicit form, which has no transmission).
//!
//! Every benchmark cycles through the same 256 precomputed (ωp, ωi, ωo): θp uniform in cos over
//! [0°, 60°], ωi cosine-distributed, ωo uniform over the hemisphere (over the sphere for the
//! dielectric), so the branch mix is that of varied shading points rather than one lucky
//! configuration. One iteration = one call, so criterion's time is the time per call. The BSDF
//! nodes are built beforehand (one per ωp): building them per hit is the renderer's cost, not
//! the BSDF's. Run: `cargo bench --bench bsdf`.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use glam::Vec3;
use groove::bsdf::mnm::facets::Microgeometry;
use groove::bsdf::mnm::ms_cache;
use groove::bsdf::mnm::ms_table::{Colour, MsTable, TableSpec, WALKS_PER_NODE};
use groove::bsdf::mnm::{Evaluation, MicrofacetNormalMap, Tangent};
use groove::bsdf::{
    named_conductor, BsdfArena, BsdfContext, BsdfNode, Diffuse, MicrofacetDistribution,
    MicrofacetType, NormalMap, RoughConductor, RoughDielectric, RoughPlastic,
};
use groove::math::warp;
use groove::sampler::Sampler;
use std::time::Duration;

/// Inputs cycled through by every benchmark.
const INPUTS: usize = 256;

#[derive(Clone, Copy, PartialEq)]
enum Mode {
    NestedAlone,
    Classic,
    /// Microfacet normal mapping; the last field is `lambert_closed_form` (over diffuse, false
    /// runs the walk itself instead of its exact closed form).
    Mnm(Microgeometry, Tangent, Evaluation, bool),
}

const MODES: [(&str, Mode); 14] = [
    ("nested_alone", Mode::NestedAlone),
    ("classic", Mode::Classic),
    (
        "explicit_mirror",
        Mode::Mnm(
            Microgeometry::Sawtooth,
            Tangent::Mirror,
            Evaluation::Explicit,
            true,
        ),
    ),
    (
        "explicit4_mirror",
        Mode::Mnm(
            Microgeometry::Sawtooth,
            Tangent::Mirror,
            Evaluation::ExplicitComplete,
            true,
        ),
    ),
    (
        "compensated_mirror",
        Mode::Mnm(
            Microgeometry::Sawtooth,
            Tangent::Mirror,
            Evaluation::Compensated,
            true,
        ),
    ),
    (
        "compensated_mirror_walk_only",
        Mode::Mnm(
            Microgeometry::Sawtooth,
            Tangent::Mirror,
            Evaluation::Compensated,
            false,
        ),
    ),
    (
        "walk_mirror",
        Mode::Mnm(
            Microgeometry::Sawtooth,
            Tangent::Mirror,
            Evaluation::RandomWalk,
            true,
        ),
    ),
    (
        "walk_mirror_walk_only",
        Mode::Mnm(
            Microgeometry::Sawtooth,
            Tangent::Mirror,
            Evaluation::RandomWalk,
            false,
        ),
    ),
    (
        "walk_same",
        Mode::Mnm(
            Microgeometry::Sawtooth,
            Tangent::Same,
            Evaluation::RandomWalk,
            true,
        ),
    ),
    (
        "walk_same_walk_only",
        Mode::Mnm(
            Microgeometry::Sawtooth,
            Tangent::Same,
            Evaluation::RandomWalk,
            false,
        ),
    ),
    (
        "vgroove",
        Mode::Mnm(
            Microgeometry::VGroove,
            Tangent::Same,
            Evaluation::RandomWalk,
            true,
        ),
    ),
    (
        "vgroove_walk_only",
        Mode::Mnm(
            Microgeometry::VGroove,
            Tangent::Same,
            Evaluation::RandomWalk,
            false,
        ),
    ),
    (
        "ugroove_0.5",
        Mode::Mnm(
            Microgeometry::UGroove { fill: 0.5 },
            Tangent::Same,
            Evaluation::RandomWalk,
            true,
        ),
    ),
    (
        "ugroove_0.5_walk_only",
        Mode::Mnm(
            Microgeometry::UGroove { fill: 0.5 },
            Tangent::Same,
            Evaluation::RandomWalk,
            false,
        ),
    ),
];

fn nested_nodes() -> [(&'static str, BsdfNode, bool); 4] {
    let ggx = MicrofacetDistribution::new(MicrofacetType::Ggx, 0.2, true);
    let (eta, k) = named_conductor("Au").expect("gold is in the conductor table");
    [
        (
            "diffuse",
            BsdfNode::Diffuse(Diffuse {
                reflectance: Vec3::new(0.8, 0.6, 0.4),
            }),
            false,
        ),
        (
            "roughconductor",
            BsdfNode::RoughConductor(RoughConductor {
                distribution: ggx,
                eta,
                k,
                specular_reflectance: Vec3::ONE,
            }),
            false,
        ),
        (
            "roughplastic",
            BsdfNode::RoughPlastic(RoughPlastic::new(
                MicrofacetType::Ggx,
                0.2,
                true,
                Vec3::new(0.2, 0.4, 0.7),
                Vec3::ONE,
                1.49,
                1.000277,
                false,
            )),
            false,
        ),
        (
            "roughdielectric",
            BsdfNode::RoughDielectric(RoughDielectric::new(ggx, 1.5, 1.0, Vec3::ONE, Vec3::ONE)),
            true,
        ),
    ]
}

/// The fixed (ωp, ωi, ωo) inputs; ωo is mirrored into the upper hemisphere unless `transmits`.
fn inputs(transmits: bool) -> Vec<(Vec3, Vec3, Vec3)> {
    let mut s = Sampler::from_seed(17, 3);
    let cos_max = 60f32.to_radians().cos();
    (0..INPUTS)
        .map(|_| {
            let wp = warp::square_to_uniform_cone(s.next_2d(), cos_max);
            let wi = warp::square_to_cosine_hemisphere(s.next_2d());
            let wo = warp::square_to_uniform_sphere(s.next_2d());
            let wo = if transmits {
                wo
            } else {
                Vec3::new(wo.x, wo.y, wo.z.abs())
            };
            (wp, wi, wo)
        })
        .collect()
}

/// One arena holding the nested node and one root per input (the root for input i is roots[i]).
fn build(mode: Mode, nested: BsdfNode, ins: &[(Vec3, Vec3, Vec3)]) -> (BsdfArena, Vec<u32>) {
    let mut arena = BsdfArena::new();
    let n = arena.push(nested);
    let roots = ins
        .iter()
        .map(|&(wp, _, _)| match mode {
            Mode::NestedAlone => n,
            Mode::Classic => arena.push(BsdfNode::NormalMap(NormalMap::new(n, wp, false, false))),
            Mode::Mnm(g, t, e, closed) => {
                let table = (e == Evaluation::Compensated).then(|| ms_table(nested, g, t));
                arena.push_microfacet_normal_map(
                    MicrofacetNormalMap::new(n, wp, g, t, e, 256)
                        .with_lambert_closed_form(closed)
                        .with_ms_table(table),
                )
            }
        })
        .collect();
    (arena, roots)
}

/// The compensated model's remainder table for `nested` (built once per process: the walk's,
/// or the exact Lambert table over diffuse), as the loader builds it.
fn ms_table(nested: BsdfNode, g: Microgeometry, t: Tangent) -> &'static MsTable {
    let lambert = matches!(nested, BsdfNode::Diffuse(_));
    let spec = TableSpec {
        geometry: g,
        tangent: t,
        max_order: 256,
        max_theta: 85f32.to_radians(),
        colour: if lambert {
            Colour::PerBounce
        } else {
            Colour::Baked
        },
        walks: WALKS_PER_NODE,
    };
    let key = format!("bench {nested:?} {g:?} {t:?}");
    ms_cache::get_or_build(&key, spec, || {
        if lambert {
            MsTable::lambert(spec, key.clone())
        } else {
            let mut arena = BsdfArena::new();
            let root = arena.push(nested);
            MsTable::from_walk(&arena.bsdf(root), root, spec, key.clone())
        }
    })
    .0
}

fn bsdf_calls(c: &mut Criterion) {
    let ctx = BsdfContext::default();
    for (nname, node, transmits) in nested_nodes() {
        let ins = inputs(transmits);
        let mut g = c.benchmark_group(nname);
        for (mname, mode) in MODES {
            if transmits
                && matches!(mode, Mode::Mnm(_, _, e, _) if e.is_explicit() || e == Evaluation::Compensated)
            {
                continue; // the explicit and compensated forms have no transmission
            }
            if nname != "diffuse" && matches!(mode, Mode::Mnm(_, _, _, false)) {
                continue; // the switch only matters over diffuse
            }
            if nname == "diffuse" {
                if let Mode::Mnm(geo, t, e, closed) = mode {
                    // The per-hit construction, which prepares the closed form over diffuse.
                    let mut arena = BsdfArena::new();
                    let mut i = 0usize;
                    let table = (e == Evaluation::Compensated).then(|| ms_table(node, geo, t));
                    g.bench_function(format!("{mname}/build"), |b| {
                        b.iter(|| {
                            i = (i + 1) % INPUTS;
                            arena.clear();
                            let n = arena.push(node);
                            let m = MicrofacetNormalMap::new(n, ins[i].0, geo, t, e, 256)
                                .with_lambert_closed_form(closed)
                                .with_ms_table(table);
                            black_box(arena.push_microfacet_normal_map(m))
                        })
                    });
                }
            }
            let (arena, roots) = build(mode, node, &ins);
            let mut s = Sampler::from_seed(1, 1);
            let mut i = 0usize;
            g.bench_function(format!("{mname}/eval"), |b| {
                b.iter(|| {
                    i = (i + 1) % INPUTS;
                    let (_, wi, wo) = ins[i];
                    black_box(arena.bsdf(roots[i]).eval(&ctx, wi, wo, &mut s))
                })
            });
            g.bench_function(format!("{mname}/sample"), |b| {
                b.iter(|| {
                    i = (i + 1) % INPUTS;
                    let (_, wi, _) = ins[i];
                    black_box(arena.bsdf(roots[i]).sample(&ctx, wi, &mut s))
                })
            });
            g.bench_function(format!("{mname}/pdf"), |b| {
                b.iter(|| {
                    i = (i + 1) % INPUTS;
                    let (_, wi, wo) = ins[i];
                    black_box(arena.bsdf(roots[i]).pdf(&ctx, wi, wo))
                })
            });
        }
        g.finish();
    }
}

/// 90 benchmarks: short warm-up and measurement keep the whole run near three minutes on a
/// loaded two-core machine; 50 samples still give criterion a confidence interval.
fn config() -> Criterion {
    Criterion::default()
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_millis(1500))
        .sample_size(50)
}

criterion_group! {
    name = benches;
    config = config();
    targets = bsdf_calls
}
criterion_main!(benches);
