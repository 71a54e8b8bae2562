//! Width 1 against groove's scalar code: bit for bit where both use the same operations
//! (vectors, frames, Fresnel, the microfacet distributions, PCG32, the sine-free warps), within
//! a few ulps where the lane code replaces libm by its polynomials (sine warps).

use crate::harness::{count, mixed, same, uniform};
use glam::{Vec2, Vec3};
use groove::bsdf::fresnel::{fresnel_conductor_1, fresnel_dielectric};
use groove::bsdf::{MicrofacetDistribution, MicrofacetType};
use groove::lane::frame::Frame;
use groove::lane::microfacet::Microfacet;
use groove::lane::pcg::Pcg;
use groove::lane::vec::{V2, V3};
use groove::lane::{fresnel, warp};
use groove::math::{warp as mwarp, Frame as MFrame, Pcg32};

fn n() -> usize {
    crate::harness::count_composite().max(10_000)
}
fn any(r: &mut Pcg32) -> f32 {
    mixed(r, &|r| uniform(r, -2.0, 2.0))
}
fn unit_vec(r: &mut Pcg32) -> Vec3 {
    Vec3::new(
        uniform(r, -1.0, 1.0),
        uniform(r, -1.0, 1.0),
        uniform(r, -1.0, 1.0),
    )
    .normalize_or(Vec3::Z)
}
fn eq3(name: &str, a: V3<f32>, b: Vec3, input: impl std::fmt::Debug) {
    assert!(
        same(a.x, b.x) && same(a.y, b.y) && same(a.z, b.z),
        "{name}: lane {a:?} != groove {b:?} for {input:?}"
    );
}

#[test]
fn vectors_and_frames_equal_glam_and_math_frame() {
    let mut r = Pcg32::new(21, 1);
    for i in 0..n() {
        let a = Vec3::new(any(&mut r), any(&mut r), any(&mut r));
        let b = Vec3::new(any(&mut r), any(&mut r), any(&mut r));
        let (la, lb) = (V3::from(a), V3::from(b));
        assert!(same(la.dot(lb), a.dot(b)));
        eq3("cross", la.cross(lb), a.cross(b), (a, b));
        eq3("normalize", la.normalize(), a.normalize(), a);
        let nrm = if i % 8 == 0 { a } else { unit_vec(&mut r) };
        let (f, g) = (Frame::from_normal(V3::from(nrm)), MFrame::from_normal(nrm));
        eq3("frame s", f.s, g.s, nrm);
        eq3("frame t", f.t, g.t, nrm);
        eq3("to_local", f.to_local(lb), g.to_local(b), (nrm, b));
        eq3("to_world", f.to_world(lb), g.to_world(b), (nrm, b));
        let (f, g) = (
            Frame::from_normal_tangent(V3::from(nrm), lb),
            MFrame::from_normal_tangent(nrm, b),
        );
        eq3("tangent frame s", f.s, g.s, (nrm, b));
        eq3("tangent frame t", f.t, g.t, (nrm, b));
    }
}

#[test]
fn fresnel_equals_bsdf_fresnel() {
    let mut r = Pcg32::new(22, 1);
    for _ in 0..n() {
        let c = mixed(&mut r, &|r| uniform(r, -1.0, 1.0));
        let (eta, k) = (
            mixed(&mut r, &|r| uniform(r, 0.2, 3.0)),
            mixed(&mut r, &|r| uniform(r, 0.0, 5.0)),
        );
        let (a, b) = (fresnel::dielectric(c, eta), fresnel_dielectric(c, eta));
        let ok = same(a.r, b.r)
            && same(a.cos_theta_t, b.cos_theta_t)
            && same(a.eta_it, b.eta_it)
            && same(a.eta_ti, b.eta_ti);
        assert!(ok, "dielectric({c:e}, {eta:e}): {a:?} vs {b:?}");
        let (a, b) = (
            fresnel::conductor_1(c, eta, k),
            fresnel_conductor_1(c, eta, k),
        );
        assert!(
            same(a, b),
            "conductor({c:e}, {eta:e}, {k:e}): {a:e} vs {b:e}"
        );
    }
}

/// `bsdf::microfacet` is the lane kernel at width 1 (D, Λ, G1, pdf and every sampler, Mitsuba's
/// map of `roughplastic`'s tables included): the same bits through the glam wrappers.
#[test]
fn microfacet_equals_bsdf_microfacet() {
    let mut r = Pcg32::new(23, 1);
    for kind in [MicrofacetType::Ggx, MicrofacetType::Beckmann] {
        for _ in 0..n() {
            let (au, av) = (uniform(&mut r, 0.0, 1.0), uniform(&mut r, 0.0, 1.0));
            let vis = r.next_u32() & 1 == 0;
            let d = MicrofacetDistribution::anisotropic(kind, au, av, vis);
            let l = Microfacet::new(kind, au, av, vis);
            let mut wi = unit_vec(&mut r);
            wi.z = wi.z.abs();
            let m = unit_vec(&mut r);
            let (lwi, lm) = (V3::from(wi), V3::from(m));
            let ctx = (kind, au, av, vis, wi, m);
            assert!(same(l.lambda(lwi), d.lambda(wi)), "lambda {ctx:?}");
            assert!(same(l.smith_g1(lwi, lm), d.smith_g1(wi, m)), "g1 {ctx:?}");
            assert!(same(l.eval(lm), d.eval(m)), "eval {ctx:?}");
            assert!(same(l.pdf(lwi, lm), d.pdf(wi, m)), "pdf {ctx:?}");
            let u = Vec2::new(r.next_f32(), r.next_f32());
            let lu = V2::from(u);
            eq3(
                "sample_normal",
                l.sample_normal(lwi, lu),
                d.sample_normal(wi, u),
                (ctx, u),
            );
            eq3(
                "sample_normal_mitsuba_map",
                l.sample_normal_mitsuba_map(lwi, lu),
                d.sample_normal_mitsuba_map(wi, u),
                (ctx, u),
            );
        }
    }
}

/// Heitz 2018's concentric map (Mitsuba's, for `roughplastic`'s tables) and the spherical caps
/// map the same square to the same density, differently: the two samplers must not agree
/// pointwise (else the tables would not need their own), but both give visible normals whose
/// pdf integrates to 1 (checked in `tests/bsdf`); here, the concentric one's normals are
/// unit, upper-hemisphere and visible from `wi`.
#[test]
fn ggx_concentric_map_gives_visible_unit_normals() {
    let mut r = Pcg32::new(26, 1);
    let mut differ = 0;
    for _ in 0..n() {
        let (au, av) = (uniform(&mut r, 0.01, 1.0), uniform(&mut r, 0.01, 1.0));
        let l = Microfacet::new(MicrofacetType::Ggx, au, av, true);
        let mut wi = unit_vec(&mut r);
        wi.z = wi.z.abs().max(1e-3);
        let wi = wi.normalize();
        let u = V2::new(r.next_f32(), r.next_f32());
        let m = Vec3::from(l.sample_visible_ggx_concentric(V3::from(wi), u));
        let c = Vec3::from(l.sample_visible_ggx(V3::from(wi), u));
        assert!((m.length() - 1.0).abs() <= 1e-5, "{m:?}");
        assert!(
            m.z >= 0.0 && m.dot(wi) >= -1e-5,
            "{m:?} not visible from {wi:?}"
        );
        differ += ((m - c).length() > 1e-3) as usize;
    }
    assert!(
        differ > n() / 2,
        "the two maps agree on {} of {}",
        n() - differ,
        n()
    );
}

#[test]
fn warps_match_math_warp() {
    let mut r = Pcg32::new(24, 1);
    for _ in 0..n() {
        let u = Vec2::new(r.next_f32(), r.next_f32());
        let lu = V2::from(u);
        let t = warp::square_to_uniform_triangle(lu);
        let mt = mwarp::square_to_uniform_triangle(u);
        assert!(same(t.x, mt.x) && same(t.y, mt.y), "triangle {u:?}");
        let cm = uniform(&mut r, -1.0, 1.0);
        assert!(same(
            warp::uniform_cone_pdf(cm),
            mwarp::uniform_cone_pdf(cm)
        ));
        let pairs = [
            (
                warp::square_to_cosine_hemisphere(lu),
                mwarp::square_to_cosine_hemisphere(u),
            ),
            (
                warp::square_to_uniform_sphere(lu),
                mwarp::square_to_uniform_sphere(u),
            ),
            (
                warp::square_to_uniform_cone(lu, cm),
                mwarp::square_to_uniform_cone(u, cm),
            ),
        ];
        for (i, (a, b)) in pairs.into_iter().enumerate() {
            // z = √(1 − x² − y²) amplifies an ulp of x, y near the rim: compare z².
            let (a, dz2) = (Vec3::from(a), (a.z * a.z - b.z * b.z).abs());
            let close = (a.truncate() - b.truncate()).length() <= 1e-6 && dz2 <= 1e-6;
            assert!(close, "warp {i} {u:?}: {a:?} vs {b:?}");
        }
        let d = warp::square_to_disk_concentric(lu);
        let md = mwarp::square_to_disk_concentric(u);
        assert!((Vec2::new(d.x, d.y) - md).length() <= 1e-6, "disk {u:?}");
    }
}

#[test]
fn pcg_equals_math_rng() {
    let mut r = Pcg32::new(25, 1);
    for _ in 0..(count() / 1000).max(100) {
        let seed = (r.next_u32() as u64) << 32 | r.next_u32() as u64;
        let stream = (r.next_u32() as u64) << 32 | r.next_u32() as u64;
        let mut a = Pcg::<f32>::new(seed, stream);
        let mut b = Pcg32::new(seed, stream);
        for _ in 0..100 {
            assert_eq!(a.next_u32() as u32, b.next_u32());
            assert_eq!(a.next_f32().to_bits(), b.next_f32().to_bits());
        }
    }
}
