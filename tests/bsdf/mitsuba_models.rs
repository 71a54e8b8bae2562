//! Pointwise agreement of the base models with Mitsuba 3.9.1 (`scalar_rgb`): every model is
//! evaluated on the (wi, wo) pairs of `tests/data/mitsuba_bsdf_points.json`, written by
//! `tests/refs/bsdf_points.py` from Mitsuba's own `eval`, `pdf` and (delta models) `sample`.
//!
//! The numbers in the file are the shortest decimals that round-trip through f32; reading them as
//! f64 and rounding to f32 gives the very f32 Mitsuba returned (checked once for every value of the
//! file when it moved here from a Rust table: none is a double-rounding case).

use std::collections::BTreeMap;
use std::path::Path;

use glam::{Vec2, Vec3};
use groove::bsdf::{
    named_conductor, BsdfArena, BsdfContext, BsdfNode, Conductor, Dielectric, Diffuse,
    MicrofacetDistribution, MicrofacetType, Plastic, RoughConductor, RoughDielectric, RoughPlastic,
    ThinDielectric, TransportMode,
};
use groove::sampler::Sampler;
use groove::Spectrum;
use serde_json::Value;

/// Number of `eval`/`pdf` and `sample` points the generator writes: a truncated or partly
/// regenerated file must not pass with fewer points.
const EVAL_POINTS: usize = 3456;
const SAMPLE_POINTS: usize = 376;

/// One parameter set of the generator.
#[derive(Debug)]
struct Key {
    dist: u8,
    alpha_u: f32,
    alpha_v: f32,
    sample_visible: bool,
    material: String,
    int_ior: f32,
    ext_ior: f32,
    reflectance: [f32; 3],
    nonlinear: bool,
}

/// One `eval`/`pdf` reference point: `mode` 0 radiance / 1 importance.
struct Row {
    model: String,
    key: usize,
    mode: u8,
    wi: [f32; 3],
    wo: [f32; 3],
    eval: [f32; 3],
    pdf: f32,
}

/// One `sample` reference point.
struct SRow {
    model: String,
    key: usize,
    mode: u8,
    wi: [f32; 3],
    u1: f32,
    u2: [f32; 2],
    wo: [f32; 3],
    weight: [f32; 3],
    pdf: f32,
    eta: f32,
    delta: bool,
}

struct Points {
    keys: Vec<Key>,
    rows: Vec<Row>,
    srows: Vec<SRow>,
}

fn num(v: &Value) -> f32 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}")) as f32
}

fn int(v: &Value) -> usize {
    v.as_u64().unwrap_or_else(|| panic!("not an integer: {v}")) as usize
}

fn boolean(v: &Value) -> bool {
    v.as_bool().unwrap_or_else(|| panic!("not a boolean: {v}"))
}

fn text(v: &Value) -> String {
    v.as_str()
        .unwrap_or_else(|| panic!("not a string: {v}"))
        .to_string()
}

fn arr<const N: usize>(v: &Value) -> [f32; N] {
    let a = v.as_array().unwrap_or_else(|| panic!("not an array: {v}"));
    assert_eq!(a.len(), N, "expected {N} numbers: {v}");
    std::array::from_fn(|i| num(&a[i]))
}

/// The rows of section `name`, after checking its column list is the one this reader expects.
fn section<'a>(doc: &'a Value, name: &str, columns: &[&str]) -> &'a [Value] {
    let got: Vec<&str> = doc[format!("{name}_columns")]
        .as_array()
        .unwrap_or_else(|| panic!("no {name}_columns"))
        .iter()
        .map(|c| c.as_str().unwrap())
        .collect();
    assert_eq!(got, columns, "{name} columns");
    let rows = doc[name].as_array().unwrap_or_else(|| panic!("no {name}"));
    for r in rows {
        assert_eq!(r.as_array().map(Vec::len), Some(columns.len()), "{r}");
    }
    rows
}

fn points() -> Points {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/mitsuba_bsdf_points.json");
    let doc: Value = serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    assert_eq!(doc["mitsuba"], "3.9.1");
    assert_eq!(doc["variant"], "scalar_rgb");
    let keys: Vec<Key> = doc["keys"]
        .as_array()
        .expect("keys")
        .iter()
        .map(|k| Key {
            dist: int(&k["dist"]) as u8,
            alpha_u: num(&k["alpha_u"]),
            alpha_v: num(&k["alpha_v"]),
            sample_visible: boolean(&k["sample_visible"]),
            material: text(&k["material"]),
            int_ior: num(&k["int_ior"]),
            ext_ior: num(&k["ext_ior"]),
            reflectance: arr(&k["reflectance"]),
            nonlinear: boolean(&k["nonlinear"]),
        })
        .collect();
    let eval_columns = ["model", "key", "mode", "wi", "wo", "eval", "pdf"];
    let rows: Vec<Row> = section(&doc, "eval", &eval_columns)
        .iter()
        .map(|r| Row {
            model: text(&r[0]),
            key: int(&r[1]),
            mode: int(&r[2]) as u8,
            wi: arr(&r[3]),
            wo: arr(&r[4]),
            eval: arr(&r[5]),
            pdf: num(&r[6]),
        })
        .collect();
    let sample_columns = [
        "model", "key", "mode", "wi", "u1", "u2", "wo", "weight", "pdf", "eta", "delta",
    ];
    let srows: Vec<SRow> = section(&doc, "sample", &sample_columns)
        .iter()
        .map(|r| SRow {
            model: text(&r[0]),
            key: int(&r[1]),
            mode: int(&r[2]) as u8,
            wi: arr(&r[3]),
            u1: num(&r[4]),
            u2: arr(&r[5]),
            wo: arr(&r[6]),
            weight: arr(&r[7]),
            pdf: num(&r[8]),
            eta: num(&r[9]),
            delta: boolean(&r[10]),
        })
        .collect();
    for k in rows
        .iter()
        .map(|r| r.key)
        .chain(srows.iter().map(|r| r.key))
    {
        assert!(k < keys.len(), "key index {k} out of range");
    }
    assert_eq!(rows.len(), EVAL_POINTS, "eval points in the data file");
    assert_eq!(srows.len(), SAMPLE_POINTS, "sample points in the data file");
    Points { keys, rows, srows }
}

fn node(model: &str, k: &Key) -> BsdfNode {
    let kind = if k.dist == 0 {
        MicrofacetType::Beckmann
    } else {
        MicrofacetType::Ggx
    };
    let distr = MicrofacetDistribution::anisotropic(kind, k.alpha_u, k.alpha_v, k.sample_visible);
    let refl = Spectrum::from_array(k.reflectance);
    match model {
        "roughconductor" => {
            let (eta, kk) = named_conductor(&k.material).expect("material");
            BsdfNode::RoughConductor(RoughConductor {
                distribution: distr,
                eta,
                k: kk,
                specular_reflectance: Spectrum::ONE,
            })
        }
        "conductor" => {
            let (eta, kk) = named_conductor(&k.material).expect("material");
            BsdfNode::Conductor(Conductor {
                eta,
                k: kk,
                specular_reflectance: Spectrum::ONE,
            })
        }
        "roughdielectric" => BsdfNode::RoughDielectric(RoughDielectric::new(
            distr,
            k.int_ior,
            k.ext_ior,
            Spectrum::ONE,
            Spectrum::ONE,
        )),
        "dielectric" => BsdfNode::Dielectric(Dielectric::new(
            k.int_ior,
            k.ext_ior,
            Spectrum::ONE,
            Spectrum::ONE,
        )),
        "thindielectric" => BsdfNode::ThinDielectric(ThinDielectric::new(
            k.int_ior,
            k.ext_ior,
            Spectrum::ONE,
            Spectrum::ONE,
        )),
        "plastic" => BsdfNode::Plastic(Plastic::new(
            refl,
            Spectrum::ONE,
            k.int_ior,
            k.ext_ior,
            k.nonlinear,
        )),
        "roughplastic" => BsdfNode::RoughPlastic(RoughPlastic::new(
            kind,
            k.alpha_u,
            k.sample_visible,
            refl,
            Spectrum::ONE,
            k.int_ior,
            k.ext_ior,
            k.nonlinear,
        )),
        _ => panic!("unknown model {model}"),
    }
}

fn ctx(mode: u8) -> BsdfContext {
    BsdfContext {
        mode: if mode == 0 {
            TransportMode::Radiance
        } else {
            TransportMode::Importance
        },
    }
}

/// Relative error with an absolute floor (values below `floor` compare absolutely).
fn rel_err(a: f32, b: f32, floor: f32) -> f32 {
    (a - b).abs() / b.abs().max(floor)
}

/// Refraction through a rough dielectric (wi and wo on opposite sides).
fn is_rough_refraction(r: &Row) -> bool {
    r.model == "roughdielectric" && r.wi[2] * r.wo[2] < 0.0
}

/// Tolerance: 1e-4 relative. Refraction through a rough dielectric builds its half vector from
/// wi + η wo, which nearly cancels for some pairs; the f32 rounding of that sum differs between the
/// two implementations by a few 1e-5, amplified up to ~3e-4 in the far tails of D: 5e-4 there.
fn tolerance(r: &Row) -> f32 {
    if is_rough_refraction(r) {
        5e-4
    } else {
        1e-4
    }
}

#[test]
fn eval_and_pdf_match_mitsuba() {
    let Points { keys, rows, .. } = points();
    let mut arena = BsdfArena::new();
    let mut sampler = Sampler::from_seed(1, 1);
    let mut failures = Vec::new();
    let mut max_err: f32 = 0.0;
    let mut per_model = BTreeMap::new();
    for r in &rows {
        let key = &keys[r.key];
        arena.clear();
        let root = arena.push(node(&r.model, key));
        let b = arena.bsdf(root);
        let c = ctx(r.mode);
        let (wi, wo) = (Vec3::from_array(r.wi), Vec3::from_array(r.wo));
        let e = b.eval(&c, wi, wo, &mut sampler);
        let p = b.pdf(&c, wi, wo);
        let scale = r.eval.iter().fold(0.0f32, |m, v| m.max(v.abs())).max(1e-3);
        let mut err = rel_err(p, r.pdf, 1e-3);
        for i in 0..3 {
            err = err.max(rel_err(e[i], r.eval[i], scale * 1e-3));
        }
        max_err = max_err.max(err);
        let label = if is_rough_refraction(r) {
            "roughdielectric (refraction)"
        } else {
            r.model.as_str()
        };
        let m = per_model.entry(label).or_insert(0.0f32);
        *m = m.max(err);
        if err > tolerance(r) {
            failures.push(format!(
                "{} {key:?} mode {} wi {:?} wo {:?}: eval {e:?} vs mitsuba {:?}, pdf {p} vs {} (err {err:.2e})",
                r.model, r.mode, r.wi, r.wo, r.eval, r.pdf
            ));
        }
    }
    eprintln!(
        "{} points, max relative error {max_err:.3e}; per model {per_model:?}",
        rows.len()
    );
    assert!(
        failures.is_empty(),
        "{} of {} points differ:\n{}",
        failures.len(),
        rows.len(),
        failures.join("\n")
    );
}

#[test]
fn delta_samples_match_mitsuba() {
    let Points { keys, srows, .. } = points();
    let mut failures = Vec::new();
    let mut max_err: f32 = 0.0;
    for r in &srows {
        let key = &keys[r.key];
        let n = node(&r.model, key);
        let c = ctx(r.mode);
        let wi = Vec3::from_array(r.wi);
        // Mitsuba's (u1, u2) go straight to the model's own sample function.
        let s = match &n {
            BsdfNode::Conductor(m) => m.sample(wi),
            BsdfNode::Dielectric(m) => m.sample(c.mode, wi, r.u1),
            BsdfNode::ThinDielectric(m) => m.sample(wi, r.u1),
            BsdfNode::Plastic(m) => m.sample(wi, r.u1, Vec2::from_array(r.u2)),
            _ => unreachable!("sample references exist for the delta models only"),
        };
        let Some(s) = s else {
            if r.weight.iter().any(|w| *w != 0.0) {
                failures.push(format!(
                    "{} {key:?} wi {:?}: no sample, mitsuba {:?}",
                    r.model, r.wi, r.weight
                ));
            }
            continue;
        };
        let mut err = (s.wo - Vec3::from_array(r.wo)).length();
        for i in 0..3 {
            err = err.max(rel_err(s.weight[i], r.weight[i], 1e-3));
        }
        err = err.max(rel_err(s.eta, r.eta, 1.0));
        if !r.delta {
            err = err.max(rel_err(s.pdf, r.pdf, 1e-3));
        }
        max_err = max_err.max(err);
        if err > 1e-4 {
            failures.push(format!(
                "{} {key:?} mode {} wi {:?} u1 {}: wo {:?} w {:?} eta {} vs mitsuba wo {:?} w {:?} eta {} (err {err:.2e})",
                r.model, r.mode, r.wi, r.u1, s.wo, s.weight, s.eta, r.wo, r.weight, r.eta
            ));
        }
    }
    eprintln!("{} samples, max relative error {max_err:.3e}", srows.len());
    assert!(
        failures.is_empty(),
        "{} of {} samples differ:\n{}",
        failures.len(),
        srows.len(),
        failures.join("\n")
    );
}

/// Every model with Mitsuba's default parameters (`tests/refs/bsdf_points.py defaults`): checks
/// the `Default` impls (Beckmann, α 0.1, visible sampling, bk7/air, polypropylene, ρ 0.5, "none").
#[test]
fn defaults_match_mitsuba() {
    /// (model, wi, wo, eval (grey), pdf)
    type DefaultRow = (&'static str, [f32; 3], [f32; 3], f32, f32);
    #[rustfmt::skip]
    const ROWS: &[DefaultRow] = &[
        ("plastic", [0.3, 0.2, 0.9327379], [-0.25, -0.2, 0.94736475], 0.15326163, 0.2789153),
        ("roughplastic", [0.3, 0.2, 0.9327379], [-0.25, -0.2, 0.94736475], 0.45741442, 0.8781233),
        ("roughconductor", [0.3, 0.2, 0.9327379], [-0.25, -0.2, 0.94736475], 7.96029, 7.96029),
        ("roughdielectric", [0.3, 0.2, 0.9327379], [-0.25, -0.2, 0.94736475], 0.32476208, 0.32476208),
        ("diffuse", [0.3, 0.2, 0.9327379], [-0.25, -0.2, 0.94736475], 0.15077777, 0.30155554),
        ("plastic", [0.3, 0.2, 0.9327379], [-0.2, -0.1, -0.9746794], 0.0, 0.0),
        ("roughplastic", [0.3, 0.2, 0.9327379], [-0.2, -0.1, -0.9746794], 0.0, 0.0),
        ("roughconductor", [0.3, 0.2, 0.9327379], [-0.2, -0.1, -0.9746794], 0.0, 0.0),
        ("roughdielectric", [0.3, 0.2, 0.9327379], [-0.2, -0.1, -0.9746794], 42.801945, 96.84227),
        ("diffuse", [0.3, 0.2, 0.9327379], [-0.2, -0.1, -0.9746794], 0.0, 0.0),
    ];
    let mut arena = BsdfArena::new();
    let mut sampler = Sampler::from_seed(1, 1);
    for &(model, wi, wo, e, p) in ROWS {
        let n = match model {
            "plastic" => BsdfNode::Plastic(Plastic::default()),
            "roughplastic" => BsdfNode::RoughPlastic(RoughPlastic::default()),
            "roughconductor" => BsdfNode::RoughConductor(RoughConductor::default()),
            "roughdielectric" => BsdfNode::RoughDielectric(RoughDielectric::default()),
            "diffuse" => BsdfNode::Diffuse(Diffuse {
                reflectance: Spectrum::splat(0.5),
            }),
            _ => unreachable!(),
        };
        arena.clear();
        let root = arena.push(n);
        let b = arena.bsdf(root);
        let (wi, wo) = (Vec3::from_array(wi), Vec3::from_array(wo));
        let c = BsdfContext::default();
        let ours = (b.eval(&c, wi, wo, &mut sampler).x, b.pdf(&c, wi, wo));
        assert!(
            rel_err(ours.0, e, 1e-3) < 1e-4 && rel_err(ours.1, p, 1e-3) < 1e-4,
            "{model}: {ours:?} vs mitsuba ({e}, {p})"
        );
    }
}
