//! `nested-glass` and `glass-furnace`: the two measurements behind docs/mnm.md's discussion of
//! the glass furnace's loss under microfacet normal mapping (not checks: the bounds that are
//! asserted live in tests/render/mnm.rs and tests/bsdf/mnm_exit_on_refraction.rs).

use crate::common::{self, dir, image_mean, mean_se, render_scene, test_scene};
use groove::bsdf::{BsdfArena, BsdfContext, TransportMode};
use groove::sampler::Sampler;

/// Albedo (importance mode, mean sample weight) of the glass furnace's nested BSDF alone (GGX
/// α = 0.05, η = 1.5) by incidence angle, from the air and from inside, to compare with the
/// furnace's loss under the normal map, where the walk queries the facets at steeper local angles.
pub fn nested_glass_albedo_by_angle() {
    let ctx = BsdfContext {
        mode: TransportMode::Importance,
    };
    let mut arena = BsdfArena::new();
    let root = arena.push(common::rough_glass(0.05));
    let b = arena.bsdf(root);
    let mut s = Sampler::from_seed(47, 48);
    for theta in [0.0f32, 30.0, 45.0, 60.0, 70.0, 80.0, 85.0, 89.0] {
        let mut row = format!("θ {theta:>4}:");
        for wi in [dir(theta, 0.0), -dir(theta, 0.0)] {
            let (m, se) = mean_se(400_000, || {
                b.sample(&ctx, wi, &mut s)
                    .map_or(0.0, |x| x.weight.x as f64)
            });
            row += &format!(" {m:.4} ± {se:.4}");
        }
        println!("{row} (from air, from inside)");
    }
}

/// Mean of the central 8×8 pixels of a 24×24 render (all on the furnace's glass sphere).
fn centre_mean(r: &common::Rendered) -> f64 {
    let w = r.mean.width;
    let (c0, c1) = (w / 2 - 4, w / 2 + 4);
    let mut sum = 0.0;
    for y in c0..c1 {
        for x in c0..c1 {
            sum += r.mean.get(x, y)[0];
        }
    }
    sum / 64.0
}

/// The glass furnace's (tests/data/scenes/mnm_glass_furnace.xml) image mean and centre for both
/// transmission walks and tangent modes, and for the nested rough dielectric alone (`nx = 0.5`:
/// ωp = ωg, which delegates to the nested BSDF exactly); 16384 spp, seed 7, all threads.
pub fn glass_furnace_means() {
    let mut runs: Vec<(&str, &str, &str)> = Vec::new();
    for tangent in ["same", "mirror"] {
        for walk in ["two_sided", "exit_on_refraction"] {
            runs.push((tangent, walk, "0.85"));
        }
    }
    runs.push(("same", "two_sided", "0.5"));
    for (tangent, walk, nx) in runs {
        let r = render_scene(
            &test_scene("mnm_glass_furnace.xml"),
            &[("tangent", tangent), ("walk", walk), ("nx", nx)],
            16384,
            7,
            0,
            |_| {},
        );
        let (m, se) = image_mean(&r);
        println!(
            "nx {nx} tangent {tangent} walk {walk}: image mean {m:.4} ± {se:.4}, centre {:.4}, invalid {}",
            centre_mean(&r),
            r.stats.invalid_samples
        );
    }
}
