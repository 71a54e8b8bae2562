//! Embree's round curves as groove builds them (`embree::curve_geometry`): hit distances,
//! normals and uvs against closed forms, and the culling of hits from inside a curve.

use super::Accel;
use crate::geometry::curves::{CurveBasis, Curves};
use crate::geometry::{Ray, Shape};
use glam::Vec3;

fn accel_of(basis: CurveBasis, points: Vec<[f32; 4]>, segments: Vec<u32>) -> (Accel, Shape) {
    let shape = Shape::curves(Curves {
        basis,
        points,
        segments,
    });
    let accel = Accel::build(std::slice::from_ref(&shape)).unwrap();
    (accel, shape)
}

fn ray(o: Vec3, d: Vec3) -> Ray {
    Ray::new(o, d.normalize())
}

#[test]
fn a_straight_linear_segment_is_hit_at_its_radius_with_the_radial_normal() {
    // One segment along +x from (-2,0,0) to (2,0,0), radius 0.25.
    let r = 0.25;
    let (accel, shape) = accel_of(
        CurveBasis::Linear,
        vec![[-2.0, 0.0, 0.0, r], [2.0, 0.0, 0.0, r]],
        vec![0],
    );
    for (o, d, t, n) in [
        // Straight down onto the top: t = 3 − r, normal +y.
        (Vec3::new(0.3, 3.0, 0.0), -Vec3::Y, 3.0 - r, Vec3::Y),
        // From +z at an offset h from the axis: t = 5 − √(r² − h²), normal (0, h, √(r² − h²))/r.
        (
            Vec3::new(-0.7, 0.15, 5.0),
            -Vec3::Z,
            5.0 - (r * r - 0.15f32 * 0.15).sqrt(),
            Vec3::new(0.0, 0.15, (r * r - 0.15f32 * 0.15).sqrt()) / r,
        ),
    ] {
        let ry = ray(o, d);
        let hit = accel.intersect(&ry).expect("hit");
        assert!((hit.t - t).abs() < 1e-4, "t {} vs {t}", hit.t);
        let si = shape.interaction(0, &ry, &hit);
        assert!((si.ng - n).length() < 1e-3, "n {} vs {n}", si.ng);
        assert!((si.sh.n - n).length() < 1e-3);
        // v is the fraction along the one segment.
        assert!((si.uv.y - (o.x + 2.0) / 4.0).abs() < 1e-3, "uv {}", si.uv);
        assert!(accel.occluded(&ry));
    }
    // Missing by more than the radius.
    assert!(accel
        .intersect(&ray(Vec3::new(0.0, 0.26, 5.0), -Vec3::Z))
        .is_none());
    // The end is capped by a sphere (Embree's round linear curve): hit nearly along the axis
    // (a ray exactly parallel to the axis misses in Embree 3.13.5), at u = 1.
    let ry = ray(Vec3::new(5.0, 0.003, 0.0), Vec3::new(-1.0, -0.001, 0.0));
    let hit = accel.intersect(&ry).expect("cap hit");
    assert!((hit.t - (3.0 - r)).abs() < 1e-3, "cap t {}", hit.t);
    assert_eq!(hit.u, 1.0);
    let si = shape.interaction(0, &ry, &hit);
    assert!((si.ng - Vec3::X).length() < 1e-3, "cap n {}", si.ng);
}

#[test]
fn curves_are_not_hit_from_inside_as_in_mitsuba() {
    // Mitsuba's Embree culls curve backfaces: a ray starting on the axis sees nothing, in both
    // queries; a second curve behind is still found through the first one's inside.
    let (accel, _) = accel_of(
        CurveBasis::Linear,
        vec![
            [-2.0, 0.0, 0.0, 0.5],
            [2.0, 0.0, 0.0, 0.5],
            [-2.0, 0.0, -3.0, 0.5],
            [2.0, 0.0, -3.0, 0.5],
        ],
        vec![0, 2],
    );
    let up = ray(Vec3::ZERO, Vec3::Y);
    assert!(accel.intersect(&up).is_none());
    assert!(!accel.occluded(&up));
    let back = ray(Vec3::ZERO, -Vec3::Z);
    let hit = accel.intersect(&back).expect("the second curve");
    assert_eq!(hit.prim, 1);
    assert!((hit.t - 2.5).abs() < 1e-4, "t {}", hit.t);
}

#[test]
fn a_straight_bspline_tube_is_hit_at_its_radius() {
    // Collinear, evenly spaced control points: the centre line is the segment from x = 1 to
    // x = 2 (the B-spline starts at (p0 + 4 p1 + p2)/6), the radius constant; no end caps.
    let r = 0.3;
    let (accel, shape) = accel_of(
        CurveBasis::BSpline,
        (0..4).map(|i| [i as f32, 0.0, 0.0, r]).collect(),
        vec![0],
    );
    let ry = ray(Vec3::new(1.25, 0.0, 4.0), -Vec3::Z);
    let hit = accel.intersect(&ry).expect("hit");
    assert!((hit.t - (4.0 - r)).abs() < 1e-3, "t {}", hit.t);
    let si = shape.interaction(0, &ry, &hit);
    assert!((si.ng - Vec3::Z).length() < 1e-3, "n {}", si.ng);
    assert!((si.uv.y - 0.25).abs() < 2e-3, "v {}", si.uv.y);
    // dp/du runs around the tube (2π r long), dp/dv along it (1 long), the frame follows dp/du.
    assert!((si.dpdu.length() - 2.0 * std::f32::consts::PI * r).abs() < 1e-3);
    assert!((si.dpdv - Vec3::X).length() < 1e-3, "dpdv {}", si.dpdv);
    assert!((si.sh.s - si.dpdu.normalize()).length() < 1e-4);
    // Open ends: along the axis from outside, nothing.
    assert!(accel
        .intersect(&ray(Vec3::new(5.0, 0.0, 0.0), -Vec3::X))
        .is_none());
    // Beyond the centre line's end (x > 2) the tube is not there.
    assert!(accel
        .intersect(&ray(Vec3::new(2.2, 0.0, 4.0), -Vec3::Z))
        .is_none());
}

#[test]
fn a_tapered_linear_segment_gets_the_cone_normal() {
    // A cone from radius 0.5 at x = −1 to 0.1 at x = 1: Embree's curve parameter makes
    // p − c(v) the true normal (Mitsuba's linearcurve relies on it).
    let (accel, shape) = accel_of(
        CurveBasis::Linear,
        vec![[-1.0, 0.0, 0.0, 0.5], [1.0, 0.0, 0.0, 0.1]],
        vec![0],
    );
    let ry = ray(Vec3::new(0.0, 0.0, 3.0), -Vec3::Z);
    let hit = accel.intersect(&ry).expect("hit");
    let si = shape.interaction(0, &ry, &hit);
    // The tube is the envelope of spheres of radius r(s) = 0.3 − 0.2 s centred at (s, 0, 0):
    // a cone of half-angle sin α = 0.2 touching the sphere at s where s + r(s) sin α = 0, i.e.
    // s = −0.0625, r = 0.3125; there the normal is (sin α, 0, cos α).
    let cos_a = (0.96f32).sqrt();
    let n = Vec3::new(0.2, 0.0, cos_a);
    assert!((si.ng - n).length() < 1e-3, "n {} vs {n}", si.ng);
    assert!((hit.t - (3.0 - 0.3125 * cos_a)).abs() < 1e-4, "t {}", hit.t);
    assert!(
        (si.uv.y - (1.0 - 0.0625) / 2.0).abs() < 1e-3,
        "v {}",
        si.uv.y
    );
}
