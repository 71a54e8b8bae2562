//! The microfacet normal map's per-hit build in place (`BsdfArena::push_microfacet_normal_map_with`
//! with `MnmSettings::map_into`, what the scalar renderer's `Materials::build_at` and the stream
//! kernel's `build_shared` use): an arena slot left by earlier hits, overwritten in place, gives
//! the BSDF that pushing the built map (`map_at`, `with_incident`) into a fresh arena gives, bit
//! for bit in eval, pdf and sample.

use glam::Vec3;
use groove::bsdf::microfacet::{MicrofacetDistribution, MicrofacetType};
use groove::bsdf::mnm::facets::{MaxTilt, Microgeometry};
use groove::bsdf::mnm::ms_table::{Colour, MsTable, TableSpec, WALKS_PER_NODE};
use groove::bsdf::mnm::{Evaluation, Tangent, TransmissionWalk};
use groove::bsdf::roughconductor::RoughConductor;
use groove::bsdf::{BsdfArena, BsdfContext, BsdfNode, Diffuse};
use groove::material::MnmSettings;
use groove::math::Pcg32;
use groove::sampler::Sampler;

fn bits(v: Vec3) -> [u32; 3] {
    v.to_array().map(f32::to_bits)
}

/// An exact Lambert table (instant) for `geometry`, `tangent`.
fn table(geometry: Microgeometry, tangent: Tangent, colour: Colour) -> &'static MsTable {
    let spec = TableSpec {
        geometry,
        tangent,
        max_order: 256,
        max_theta: 85f32.to_radians(),
        colour,
        walks: WALKS_PER_NODE,
    };
    Box::leak(Box::new(MsTable::lambert(spec, "unit".into())))
}

/// Random settings: every microgeometry, the evaluations that keep different state (the
/// compensated table and its ωi cache, `auto`'s blend, the walk's MIS weight, the Lambert
/// closed form over a diffuse nested BSDF).
fn settings(rng: &mut Pcg32) -> MnmSettings {
    let (geometry, tangent) = match rng.next_u32() % 3 {
        0 => (Microgeometry::Sawtooth, Tangent::Mirror),
        1 => (Microgeometry::VGroove, Tangent::Same),
        _ => (Microgeometry::UGroove { fill: 0.6 }, Tangent::Same),
    };
    let evaluation = match rng.next_u32() % 4 {
        0 | 1 => Evaluation::Compensated,
        2 => Evaluation::RandomWalk,
        _ => Evaluation::ExplicitComplete,
    };
    let colour = if rng.next_f32() < 0.5 {
        Colour::Baked
    } else {
        Colour::PerBounce
    };
    MnmSettings {
        geometry,
        tangent,
        evaluation,
        max_order: 1 + rng.next_u32() % 300,
        max_theta: MaxTilt::new(85f32.to_radians()),
        transmission_walk: TransmissionWalk::TwoSided,
        lambert_closed_form: rng.next_f32() < 0.7,
        ms_table: (rng.next_f32() < 0.9).then(|| table(geometry, tangent, colour)),
    }
}

fn direction(rng: &mut Pcg32) -> Vec3 {
    let z = 2.0 * rng.next_f32() - 1.0;
    let phi = std::f32::consts::TAU * rng.next_f32();
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

fn push_nested(arena: &mut BsdfArena, diffuse: bool) -> u32 {
    if diffuse {
        arena.push(BsdfNode::Diffuse(Diffuse {
            reflectance: Vec3::new(0.7, 0.4, 0.2),
        }))
    } else {
        arena.push(BsdfNode::RoughConductor(RoughConductor {
            distribution: MicrofacetDistribution::new(MicrofacetType::Ggx, 0.2, true),
            eta: Vec3::new(0.2, 0.4, 1.4),
            k: Vec3::new(3.6, 2.4, 1.8),
            specular_reflectance: Vec3::ONE,
        }))
    }
}

#[test]
fn normal_maps_built_in_place_equal_the_pushed_ones() {
    let mut rng = Pcg32::new(12, 2);
    let ctx = BsdfContext::default();
    let mut reused = BsdfArena::new();
    let (mut checked, mut sampled) = (0, 0);
    for hit in 0..600 {
        // The reused arena's slots hold earlier hits' maps (other settings, other nested BSDFs).
        reused.clear();
        let mut fresh = BsdfArena::new();
        let maps = 1 + (hit % 4);
        for _ in 0..maps {
            let diffuse = rng.next_f32() < 0.4;
            let s = settings(&mut rng);
            let rgb = Vec3::new(rng.next_f32(), rng.next_f32(), 0.5 + 0.5 * rng.next_f32());
            let wi = direction(&mut rng);
            let cache = rng.next_f32() < 0.8;
            let nr = push_nested(&mut reused, diffuse);
            let r = reused.push_microfacet_normal_map_with(nr, |m| {
                s.map_into(m, nr, rgb);
                if cache {
                    m.set_incident(wi);
                }
            });
            let nf = push_nested(&mut fresh, diffuse);
            let m = s.map_at(nf, rgb);
            let f = fresh.push_microfacet_normal_map(if cache { m.with_incident(wi) } else { m });
            assert_eq!(r, f, "hit {hit}");
            for _ in 0..4 {
                let wo = direction(&mut rng);
                let seed = rng.next_u32() as u64;
                let (mut s1, mut s2) = (Sampler::from_seed(seed, 1), Sampler::from_seed(seed, 1));
                let (fa, pa) = reused.bsdf(r).eval_pdf(&ctx, wi, wo, &mut s1);
                let (fb, pb) = fresh.bsdf(f).eval_pdf(&ctx, wi, wo, &mut s2);
                let at = format!("hit {hit}: {s:?} {rgb} {wi} {wo}");
                assert_eq!((bits(fa), pa.to_bits()), (bits(fb), pb.to_bits()), "{at}");
                let a = reused.bsdf(r).sample(&ctx, wi, &mut s1);
                let b = fresh.bsdf(f).sample(&ctx, wi, &mut s2);
                match (a, b) {
                    (None, None) => {}
                    (Some(a), Some(b)) => {
                        assert_eq!(bits(a.wo), bits(b.wo), "{at}");
                        assert_eq!(a.pdf.to_bits(), b.pdf.to_bits(), "{at}");
                        assert_eq!(bits(a.weight), bits(b.weight), "{at}");
                        sampled += 1;
                    }
                    (a, b) => panic!("{at}: {a:?} vs {b:?}"),
                }
                assert_eq!(s1.next_1d().to_bits(), s2.next_1d().to_bits(), "{at}");
                checked += usize::from(wi.z > 0.0 && wo.z > 0.0);
            }
        }
    }
    // 600 hits of 2.5 maps × 4 queries, a quarter with both directions above the surface.
    assert!(
        checked > 1200 && sampled > 1500,
        "{checked} evaluated, {sampled} sampled"
    );
}
