//! `mask`, `null`, `bumpmap` and the bitmap gradient against Mitsuba 3.9.1 point evaluations
//! (tests/data/perturb_points.json, written by tests/refs/perturb_points.py from Mitsuba's own
//! `eval`, `pdf`, `sample` and `eval_1_grad` in `scalar_rgb`); module `models`: the base models
//! against tests/data/mitsuba_bsdf_points.json (tests/refs/bsdf_points.py).

#[path = "mitsuba_models.rs"]
mod models;

use std::path::{Path, PathBuf};

use glam::{Vec2, Vec3};
use groove::bsdf::{
    named_conductor, BsdfArena, BsdfContext, BsdfNode, Diffuse, Lobes, Mask,
    MicrofacetDistribution, MicrofacetType, RoughConductor,
};
use groove::geometry::SurfaceInteraction;
use groove::load::instantiate;
use groove::material::{MaterialNode, Materials};
use groove::math::Frame;
use groove::sampler::Sampler;
use groove::scene::xml::parse::load_str;
use groove::texture::Texture;
use serde_json::Value;

fn data() -> Value {
    let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/perturb_points.json");
    let v: Value = serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap();
    assert_eq!(v["mitsuba"], "3.9.1");
    v
}

fn v3(v: &Value) -> Vec3 {
    let a: Vec<f32> = v
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap() as f32)
        .collect();
    Vec3::new(a[0], a[1], a[2])
}

fn f(v: &Value) -> f32 {
    v.as_f64().unwrap() as f32
}

fn textures_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/textures")
}

/// A texture given as XML, resolved in tests/data/textures.
fn load_texture(xml: &str) -> Texture {
    let path = textures_dir().join("scene.xml");
    let scene = format!(
        "<scene version=\"3.0.0\"><sensor type=\"perspective\"><film type=\"hdrfilm\"><integer name=\"width\" value=\"2\"/><integer name=\"height\" value=\"2\"/></film></sensor>{xml}</scene>"
    );
    let doc = load_str(&scene, &path, &[]).unwrap();
    instantiate(&doc, &path).unwrap().scene.materials().textures[0].clone()
}

/// The nested BSDFs of the generator: diffuse (0.2, 0.5, 0.8) and rough gold (GGX 0.2).
fn nested(name: &str) -> BsdfNode {
    match name {
        "diffuse" => BsdfNode::Diffuse(Diffuse {
            reflectance: Vec3::new(0.2, 0.5, 0.8),
        }),
        "roughconductor" => {
            let (eta, k) = named_conductor("Au").unwrap();
            BsdfNode::RoughConductor(RoughConductor {
                distribution: MicrofacetDistribution::new(MicrofacetType::Ggx, 0.2, true),
                eta,
                k,
                specular_reflectance: Vec3::ONE,
            })
        }
        n => panic!("unknown nested {n}"),
    }
}

/// |a − b| relative to max(|b|, floor), per channel.
fn rel(a: Vec3, b: Vec3, floor: f32) -> f32 {
    ((a - b).abs() / b.abs().max(Vec3::splat(floor))).max_element()
}

#[test]
fn bitmap_gradient_matches_mitsuba_eval_1_grad() {
    let d = data();
    let (mut n, mut worst) = (0, 0.0f32);
    for case in d["grad"].as_array().unwrap() {
        let xml = case["xml"].as_str().unwrap();
        let tex = load_texture(xml);
        for p in case["points"].as_array().unwrap() {
            let a: Vec<f32> = p
                .as_array()
                .unwrap()
                .iter()
                .map(|x| x.as_f64().unwrap() as f32)
                .collect();
            let (uv, want) = (Vec2::new(a[0], a[1]), Vec2::new(a[2], a[3]));
            let got = tex.eval_1_grad(uv);
            let err = (got - want).abs().max_element() / want.abs().max_element().max(1.0);
            worst = worst.max(err);
            n += 1;
            assert!(err < 1e-4, "{xml} uv {uv}: groove {got}, Mitsuba {want}");
        }
    }
    assert!(n >= 60);
    eprintln!("{n} gradient points, worst relative difference {worst:.2e}");
}

#[test]
fn mask_and_null_match_mitsuba() {
    let d = data();
    let ctx = BsdfContext::default();
    let mut s = Sampler::from_seed(3, 0);
    let (mut n, mut worst) = (0, 0.0f32);
    for case in d["mask"].as_array().unwrap() {
        let opacity = f(&case["opacity"]);
        let mut arena = BsdfArena::new();
        let child = arena.push(nested(case["nested"].as_str().unwrap()));
        let root = arena.push(BsdfNode::Mask(Mask {
            nested: child,
            opacity,
        }));
        let b = arena.bsdf(root);
        assert_eq!(b.lobes() & Lobes::NULL, Lobes::NULL);
        for p in case["points"].as_array().unwrap() {
            let (wi, wo) = (v3(&p["wi"]), v3(&p["wo"]));
            let (e, pdf) = (b.eval(&ctx, wi, wo, &mut s), b.pdf(&ctx, wi, wo));
            let (re, rp) = (v3(&p["eval"]), f(&p["pdf"]));
            let err = rel(e, re, 1e-3).max((pdf - rp).abs() / rp.max(1e-3));
            worst = worst.max(err);
            n += 1;
            assert!(
                err < 1e-4,
                "mask {case:?}: wi {wi} wo {wo}: eval {e} vs {re}, pdf {pdf} vs {rp}"
            );
        }
        // Mitsuba's samples: the pass-through has weight 1 and wo = −wi; a nested sample keeps
        // the nested weight f/p, which is groove's eval/pdf (the opacity cancels).
        for p in case["samples"].as_array().unwrap() {
            let (wi, wo, w) = (v3(&p["wi"]), v3(&p["wo"]), v3(&p["weight"]));
            if p["null"].as_bool().unwrap() {
                assert_eq!(wo, -wi);
                assert_eq!(w, Vec3::ONE);
                assert!((f(&p["pdf"]) - (1.0 - opacity)).abs() < 1e-6);
            } else if w.max_element() > 0.0 {
                let ours = b.eval(&ctx, wi, wo, &mut s) / b.pdf(&ctx, wi, wo);
                assert!(
                    rel(ours, w, 1e-3) < 1e-3,
                    "nested sample wo {wo}: {ours} vs {w}"
                );
            }
        }
        // groove's own samples: pass-through with probability 1 − opacity.
        let wi = v3(&case["points"][0]["wi"]);
        let trials = 20_000;
        let mut nulls = 0;
        for _ in 0..trials {
            // A nested sample may fail (a microfacet direction below the horizon).
            let Some(bs) = b.sample(&ctx, wi, &mut s) else {
                continue;
            };
            if bs.lobe == Lobes::NULL {
                assert_eq!((bs.wo, bs.weight, bs.eta), (-wi, Vec3::ONE, 1.0));
                nulls += 1;
            }
        }
        let frac = nulls as f64 / trials as f64;
        let sd = ((1.0 - opacity as f64) * opacity as f64 / trials as f64).sqrt();
        assert!(
            (frac - (1.0 - opacity as f64)).abs() < 5.0 * sd,
            "null fraction {frac}"
        );
    }
    // `null`: flags Null, eval 0, sample straight through with weight 1.
    let nl = &d["null"];
    assert!(nl["flags_null"].as_bool().unwrap());
    let mut arena = BsdfArena::new();
    let root = arena.push(BsdfNode::Null);
    let b = arena.bsdf(root);
    let wi = v3(&nl["wi"]);
    assert_eq!(b.lobes(), Lobes::NULL);
    assert_eq!(b.eval(&ctx, wi, Vec3::Z, &mut s), v3(&nl["eval"]));
    let bs = b.sample(&ctx, wi, &mut s).unwrap();
    assert_eq!(bs.wo, v3(&nl["wo"]));
    assert_eq!(bs.weight, v3(&nl["weight"]));
    assert_eq!(bs.lobe, Lobes::NULL);
    eprintln!("{n} mask points, worst relative difference {worst:.2e}");
}

#[test]
fn bumpmap_matches_mitsuba_pointwise() {
    let d = data();
    let ctx = BsdfContext::default();
    let mut s = Sampler::from_seed(5, 0);
    let (mut n, mut nonzero, mut worst) = (0, 0, 0.0f32);
    for case in d["bumpmap"].as_array().unwrap() {
        let g = &case["geometry"];
        let mut m = Materials::default();
        let height = m.add_texture(load_texture(case["texture_xml"].as_str().unwrap()));
        let inner = match nested(case["nested"].as_str().unwrap()) {
            BsdfNode::Diffuse(d) => {
                let t = m.add_texture(Texture::Constant(d.reflectance));
                m.add_node(MaterialNode::Diffuse { reflectance: t })
            }
            other => m.add_node(MaterialNode::Leaf {
                template: Box::new(other),
                slots: Vec::new(),
            }),
        };
        let root_mat = m.add_node(MaterialNode::BumpMap {
            nested: inner,
            height,
            scale: f(&case["scale"]),
            flip_invalid_normals: case["flip_invalid_normals"].as_bool().unwrap(),
            use_shadowing_function: case["use_shadowing_function"].as_bool().unwrap(),
        });
        let sh = Frame {
            s: v3(&g["s"]),
            t: v3(&g["t"]),
            n: v3(&g["sh_n"]),
        };
        for p in case["points"].as_array().unwrap() {
            let uv = v3(&{
                let mut a = p["uv"].clone();
                a.as_array_mut().unwrap().push(Value::from(0.0));
                a
            });
            let si = SurfaceInteraction {
                p: Vec3::ZERO,
                t: 1.0,
                ng: v3(&g["n"]),
                sh,
                uv: Vec2::new(uv.x, uv.y),
                dpdu: v3(&g["dp_du"]),
                dpdv: v3(&g["dp_dv"]),
                shape: 0,
                prim: 0,
                wi: sh.to_world(v3(&p["wi"])),
            };
            let mut arena = BsdfArena::new();
            let root = m.build(root_mat, &si, &mut arena);
            let b = arena.bsdf(root);
            let (wi, wo) = (v3(&p["wi"]), v3(&p["wo"]));
            let (e, pdf) = (b.eval(&ctx, wi, wo, &mut s), b.pdf(&ctx, wi, wo));
            let (re, rp) = (v3(&p["eval"]), f(&p["pdf"]));
            let err = rel(e, re, 1e-2).max((pdf - rp).abs() / rp.max(1e-2));
            worst = worst.max(err);
            n += 1;
            nonzero += usize::from(re.max_element() > 0.0);
            assert!(
                err < 2e-4,
                "bumpmap {} scale {}: uv {uv} wi {wi} wo {wo}: eval {e} vs {re}, pdf {pdf} vs {rp}",
                case["nested"],
                case["scale"]
            );
        }
    }
    assert!(n >= 250 && nonzero >= 60, "{n} points, {nonzero} non-zero");
    eprintln!("{n} bumpmap points ({nonzero} non-zero), worst relative difference {worst:.2e}");
}

/// Mitsuba 3.9.1's checkerboard swaps its colours in `eval_1` (the scalar used for opacity,
/// blend weights and roughness) relative to `eval`; groove follows.
#[test]
fn checkerboard_eval_1_swaps_colours_like_mitsuba() {
    let d = data();
    let c = &d["checkerboard_eval_1"];
    let tex = load_texture(c["xml"].as_str().unwrap());
    let mut swapped = 0;
    for p in c["points"].as_array().unwrap() {
        let a: Vec<f32> = p
            .as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap() as f32)
            .collect();
        let uv = Vec2::new(a[0], a[1]);
        assert!(
            (tex.eval_1(uv) - a[2]).abs() < 1e-6,
            "eval_1 at {uv}: {} vs {}",
            tex.eval_1(uv),
            a[2]
        );
        assert!((tex.eval(uv).x - a[3]).abs() < 1e-6, "eval at {uv}");
        swapped += usize::from(a[2] != a[3]);
    }
    assert_eq!(swapped, c["points"].as_array().unwrap().len());
}
