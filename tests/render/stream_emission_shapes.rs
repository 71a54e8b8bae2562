//! The stream renderer's emission stage in lanes for environment maps and sphere lights
//! (issue 18, twelfth session, h5): the scalar image bit for bit at 1, 2, 3 and 7 threads under
//! every MIS strategy, hidden emitters and short paths, with the lane counters showing that the
//! escaped rays under an envmap and the hits on sphere lights went through the lanes (a silent
//! fallback to `PathState::add_emission` cannot pass).

use super::stream::{assert_identical, load, scene};
use crate::common::test_scene;
use groove::integrator::{IntegratorDesc, PathSettings, Strategy};

type Edit = (&'static str, fn(&mut PathSettings));

const EDITS: [Edit; 5] = [
    ("as written", |_| {}),
    ("light only", |p| p.strategy = Strategy::LightOnly),
    ("bsdf only", |p| p.strategy = Strategy::BsdfOnly),
    ("hidden emitters", |p| p.hide_emitters = true),
    ("max_depth 2", |p| p.max_depth = 2),
];

/// Each scene under each edit: the stream image equals the scalar one; returns the summed
/// counters (escaped rays under an envmap in lanes, sphere-light hits in lanes).
fn check(path: &std::path::Path) -> (u64, u64) {
    let label = path.display().to_string();
    let (mut env, mut sphere) = (0, 0);
    for (what, edit) in EDITS {
        let mut l = load(path, "as_written");
        let IntegratorDesc::Path(mut p) = l.settings.integrator else {
            unreachable!("a path scene")
        };
        edit(&mut p);
        l.settings.integrator = IntegratorDesc::Path(p);
        let lanes = assert_identical(&l, &format!("{label}, {what}"), 2);
        assert!(
            lanes.emission_env_lanes + lanes.emission_sphere_lanes <= lanes.emission_lanes,
            "{label}, {what}: {lanes:?}"
        );
        env += lanes.emission_env_lanes;
        sphere += lanes.emission_sphere_lanes;
    }
    (env, sphere)
}

/// Escaped rays under an environment map (alone, beside a point light, beside an area light,
/// and before a constant environment) see it in lanes, the scalar image bit for bit.
#[test]
fn stream_equals_scalar_with_envmap_emission_in_lanes() {
    for name in [
        "stream_emitters_env.xml",
        "light_envmap.xml",
        "light_envmap_area.xml",
        "stream_envmap_spheres.xml",
    ] {
        let (env, _) = check(&test_scene(name));
        assert!(env > 0, "{name}: no escaped ray under the envmap in lanes");
    }
}

/// Hits on sphere lights (seen from outside their cone threshold and, after a bounce off a
/// nearby surface, from close by; flipped normals) are weighted in lanes with the cone
/// density, the scalar image bit for bit.
#[test]
fn stream_equals_scalar_with_sphere_light_emission_in_lanes() {
    for name in ["stream_lights.xml", "stream_envmap_spheres.xml"] {
        let (_, sphere) = check(&test_scene(name));
        assert!(sphere > 0, "{name}: no sphere-light hit in lanes");
    }
    // The bench scenes' emission (rectangles, a constant environment) is unchanged.
    let l = load(&scene("scenes/bench/metal_plastic.xml"), "classic");
    let lanes = assert_identical(&l, "metal_plastic", 2);
    assert_eq!(lanes.emission_env_lanes, 0);
}

/// Hits on cylinders are reconstructed 8-wide (`surface_lanes::cylinder`, with the crate's
/// `atan2` in both renderers): the scalar image bit for bit on a scene of cylinders only (so
/// any hit in lanes is a cylinder's) and on the Mitsuba-reference scenes with cylinders.
#[test]
fn stream_equals_scalar_with_cylinders_gathered_in_lanes() {
    let l = load(&test_scene("stream_cylinders.xml"), "as_written");
    let lanes = assert_identical(&l, "stream_cylinders", 2);
    assert!(
        lanes.surface_lanes > 0,
        "no cylinder hit in lanes: {lanes:?}"
    );
    for name in ["shape_cylinder.xml", "cylinder_quirks.xml"] {
        let l = load(&test_scene(name), "as_written");
        let lanes = assert_identical(&l, name, 2);
        assert!(lanes.surface_lanes > 0, "{name}: {lanes:?}");
    }
}
