//! `energy`: the white-furnace energy table of spec §4.5 (docs/mnm.md, "Energy table") as
//! measured by groove.
//! Albedo = mean sample weight over 200k samples (failed samples count 0), white Lambertian
//! nested BSDF; "far side" is ωi at 80° on the side ωp leans away from.

use crate::common::dir;
use glam::Vec3;
use groove::bsdf::mnm::facets::Microgeometry;
use groove::bsdf::mnm::{Evaluation, MicrofacetNormalMap, Tangent};
use groove::bsdf::{BsdfArena, BsdfContext, BsdfNode, Diffuse};
use groove::sampler::Sampler;

fn albedo(g: Microgeometry, t: Tangent, e: Evaluation, tp: f32, wi: Vec3) -> (f64, f64) {
    let mut arena = BsdfArena::new();
    let nested = arena.push(BsdfNode::Diffuse(Diffuse {
        reflectance: Vec3::ONE,
    }));
    let root = arena.push_microfacet_normal_map(MicrofacetNormalMap::new(
        nested,
        dir(tp, 0.0),
        g,
        t,
        e,
        256,
    ));
    let b = arena.bsdf(root);
    let ctx = BsdfContext::default();
    let mut s = Sampler::from_seed(tp.to_bits() as u64, 1);
    let n = 200_000;
    let (mut a, mut a2) = (0.0f64, 0.0f64);
    for _ in 0..n {
        let w = b
            .sample(&ctx, wi, &mut s)
            .map_or(0.0, |x| x.weight.x as f64);
        a += w;
        a2 += w * w;
    }
    let m = a / n as f64;
    (m, ((a2 / n as f64 - m * m) / n as f64).sqrt())
}

/// Prints the table (Markdown) on stdout.
pub fn run() {
    println!("| θp | classic (1+cosθp)/2 | explicit mirror, ωi = ωg | explicit mirror, ωi 80° far side | mirror walk, ωi = ωg | same-material walk, ωi = ωg | V-groove walk | U-groove walk (s=0.5) |");
    println!("|---|---|---|---|---|---|---|---|");
    for tp in [10.0f32, 30.0, 45.0, 60.0, 75.0, 85.0] {
        let far = dir(80.0, 180.0);
        let saw = Microgeometry::Sawtooth;
        let f = |x: (f64, f64)| format!("{:.3} ± {:.3}", x.0, x.1);
        println!(
            "| {tp}° | {:.3} | {} | {} | {} | {} | {} | {} |",
            (1.0 + (tp as f64).to_radians().cos()) / 2.0,
            f(albedo(
                saw,
                Tangent::Mirror,
                Evaluation::Explicit,
                tp,
                Vec3::Z
            )),
            f(albedo(saw, Tangent::Mirror, Evaluation::Explicit, tp, far)),
            f(albedo(
                saw,
                Tangent::Mirror,
                Evaluation::RandomWalk,
                tp,
                Vec3::Z
            )),
            f(albedo(
                saw,
                Tangent::Same,
                Evaluation::RandomWalk,
                tp,
                Vec3::Z
            )),
            f(albedo(
                Microgeometry::VGroove,
                Tangent::Same,
                Evaluation::RandomWalk,
                tp,
                Vec3::Z
            )),
            f(albedo(
                Microgeometry::UGroove { fill: 0.5 },
                Tangent::Same,
                Evaluation::RandomWalk,
                tp,
                Vec3::Z
            )),
        );
    }
}
