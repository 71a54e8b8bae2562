//! The stream renderer's `direct` integrator through more of the kernels (issue 18, twelfth
//! session, h6): the compensated microfacet normal map's kernel under `direct`.

use super::stream::{as_direct, assert_identical, load, scene};

/// `metal_plastic` and `strong` with `--normal-mapping compensated` under `direct` (one light
/// and one BSDF sample per hit, the kernels' vertex; with `hide_emitters`; BSDF samples only)
/// give the scalar image at 1, 2, 3 and 7 threads, and the compensated kernel shaded (its
/// counter is only counted where the kernel ran, so a fallback to the 1-lane code fails). With
/// 3 emitter samples the kernels stand aside.
#[test]
fn the_compensated_kernel_runs_under_direct() {
    for name in ["metal_plastic", "strong"] {
        let base = || load(&scene(&format!("scenes/bench/{name}.xml")), "compensated");
        for (label, es, bs, hide) in [("1, 1", 1, 1, false), ("1, 1, hidden", 1, 1, true)] {
            let l = as_direct(base(), es, bs, hide);
            let lanes = assert_identical(&l, &format!("{name} compensated direct ({label})"), 3);
            assert!(
                lanes.mnm_lanes > 0 && lanes.mnm_lanes <= lanes.kernel_lanes,
                "{name} ({label}): {lanes:?}"
            );
        }
        let l = as_direct(base(), 3, 1, false);
        let lanes = assert_identical(&l, &format!("{name} compensated direct (3, 1)"), 2);
        assert_eq!(lanes.mnm_lanes, 0, "{name} (3, 1): {lanes:?}");
    }
}

/// The same kernel over the random walk and the closed form (issue 18, thirty-ninth session:
/// `walk-same`, `walk-mirror` and `explicit` on metal_plastic, their BSDF evaluated and sampled
/// lane by lane inside the kernel) under `direct` with one light and one BSDF sample per hit:
/// the scalar image at 1, 2, 3 and 7 threads, and the kernel shaded.
#[test]
fn the_mnm_kernel_runs_the_walks_under_direct() {
    for mode in ["walk-same", "walk-mirror", "explicit"] {
        let l = as_direct(
            load(&scene("scenes/bench/metal_plastic.xml"), mode),
            1,
            1,
            false,
        );
        let lanes = assert_identical(&l, &format!("metal_plastic {mode} direct (1, 1)"), 3);
        assert!(
            lanes.mnm_lanes > 0 && lanes.mnm_lanes <= lanes.kernel_lanes,
            "{mode}: {lanes:?}"
        );
    }
}
