//! The XML constructor of `microfacet_normalmap` (and of the `normalmap` that
//! `--normal-mapping microfacet|explicit|walk-...` turns into one); the decisions page of
//! `mnm.md` gives the reasons for each default.
//!
//! # XML parameters
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `normalmap` | texture | required | the normal map, ωp = 2·rgb − 1 in the shading frame |
//! | (nested) | one `<bsdf>` | required | the BSDF on every facet (a non-delta lobe; a transmitting one needs the random walk) |
//! | `microgeometry` | string | `sawtooth` | `sawtooth`, `vgroove` or `ugroove` ([`Microgeometry`]) |
//! | `groove_fill` | float | 0.5 | the flat share of a `ugroove`, in (0, 1] (`ugroove` only) |
//! | `tangent` | string | `same` (random walk), `mirror` (explicit forms, compensated, auto) | the sawtooth's wall: a perfect mirror or the nested BSDF (`sawtooth` only); the default is [`DEFAULT_WALK_TANGENT`] for every nested kind |
//! | `evaluation` | string | `random_walk` | `random_walk`, `explicit` (the paper's closed form, Variant M), `explicit4` (the complete first order: Variant M plus t→p→t→o; the explicit forms are sawtooth only) `compensated` (the complete first order plus a rank-1 remainder tabulated from the walk at load, any microgeometry; needs a nested BSDF `ms_nested.rs` can tabulate) or `auto` (per shading point compensated where its misplaced energy against the walk, measured at load, is small, the walk where it is large, blended between: `misplaced.rs`; the random walk over a nested BSDF without a table) |
//! | `lambert_closed_form` | boolean | true | over a `diffuse` (or twosided diffuse) nested BSDF, `random_walk` uses the walk's exact closed forms (`lambert.rs`); false runs the walk itself |
//! | `max_order` | integer | 256 | longest random walk, in scattering events |
//! | `max_theta` | float | 85 | largest tilt of the perturbed normal, degrees, in (0, 90) |
//! | `transmission_walk` | string | `two_sided` | over a transmitting BSDF: `two_sided` (§9.3) or `exit_on_refraction` (§9.4) |

use super::facets::{MaxTilt, Microgeometry};
use super::{ms_nested, Evaluation, Tangent, TransmissionWalk};

use crate::bsdf::normalmap::load::parts;
use crate::error::{Error, Result, SourceLoc};
use crate::load::bsdfs::BsdfCtx;
use crate::load::check;
use crate::load::options::MnmMode;
use crate::material::{MatId, MaterialNode, MnmSettings};
use crate::scene::xml::props::Props;

/// `microfacet_normalmap`; `forced` (from `--normal-mapping`) replaces the written
/// microgeometry, tangent and evaluation.
pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>, forced: Option<MnmMode>) -> Result<MaterialNode> {
    let (nested, nested_loc, normalmap) = parts(cx, "microfacet_normalmap")?;
    let p = cx.props();
    let geometry = microgeometry(p)?;
    let evaluation = match p.string("evaluation", "random_walk")?.as_str() {
        "random_walk" => Evaluation::RandomWalk,
        "explicit" => Evaluation::Explicit,
        "explicit4" => Evaluation::ExplicitComplete,
        "compensated" => Evaluation::Compensated,
        "auto" => Evaluation::Auto,
        other => {
            return Err(Error::scene(
                p.loc(),
                format!("evaluation '{other}' must be 'random_walk', 'explicit', 'explicit4', 'compensated' or 'auto'"),
            ))
        }
    };
    let tangent = tangent(p, geometry, evaluation)?;
    let (geometry, tangent, evaluation) = match forced {
        Some(f) => (f.geometry, f.tangent, f.evaluation),
        None => (geometry, tangent, evaluation),
    };
    if geometry != Microgeometry::Sawtooth && evaluation.is_explicit() {
        return Err(Error::scene(
            p.loc(),
            "microgeometries other than 'sawtooth' need evaluation = random_walk",
        ));
    }
    let max_order = p.int("max_order", 256)?;
    check(
        p.loc(),
        (1..=1 << 20).contains(&max_order),
        "max_order must be >= 1",
    )?;
    let max_theta = p.float("max_theta", 85.0)?;
    check(
        p.loc(),
        max_theta > 0.0 && max_theta < 90.0,
        "max_theta must be in (0, 90) degrees",
    )?;
    let walk = p.string("transmission_walk", "two_sided")?;
    let transmission_walk = match walk.as_str() {
        "two_sided" => TransmissionWalk::TwoSided,
        "exit_on_refraction" => TransmissionWalk::ExitOnRefraction,
        _ => {
            return Err(Error::scene(
                p.loc(),
                "transmission_walk must be 'two_sided' or 'exit_on_refraction'",
            ))
        }
    };
    let lambert_closed_form = p.bool("lambert_closed_form", true)?;
    let mut settings = MnmSettings {
        geometry,
        tangent,
        evaluation,
        max_order: max_order as u32,
        max_theta: MaxTilt::new(max_theta.to_radians()),
        transmission_walk,
        lambert_closed_form,
        ms_table: None,
    };
    compensate(cx, nested, &mut settings, forced.is_some())?;
    check_nested(cx, nested, nested_loc, settings.evaluation)?;
    Ok(MaterialNode::MicrofacetNormalMap {
        nested,
        normalmap,
        settings,
    })
}

/// `evaluation = compensated` or `auto`: obtain the nested BSDF's remainder table
/// ([`ms_nested`]; for `auto` with its misplaced-energy table). A nested BSDF without one is an
/// error when the file asks for `compensated`, falls back to the random walk (with a warning)
/// when `--normal-mapping compensated` does, and is the random walk under `auto` (which picks
/// the walk wherever the compensated model is not known to be close; no warning).
fn compensate(
    cx: &mut BsdfCtx<'_, '_>,
    nested: MatId,
    settings: &mut MnmSettings,
    forced: bool,
) -> Result<()> {
    let auto = settings.evaluation == Evaluation::Auto;
    if settings.evaluation != Evaluation::Compensated && !auto {
        return Ok(());
    }
    let why = if cx.lobes(nested).has_transmission() {
        Err("it transmits (the compensated model is reflection only)".to_string())
    } else if auto {
        ms_nested::auto_table_for(
            cx.materials(),
            nested,
            settings.geometry,
            settings.tangent,
            settings.max_order,
            settings.max_theta.radians(),
            settings.lambert_closed_form,
        )
    } else {
        ms_nested::table_for(
            cx.materials(),
            nested,
            settings.geometry,
            settings.tangent,
            settings.max_order,
            settings.max_theta.radians(),
        )
    };
    if auto && why.is_err() {
        settings.evaluation = Evaluation::RandomWalk;
        return Ok(());
    }
    match why {
        Ok(got) => {
            if let Some(w) = got.warning {
                cx.warn(w);
            }
            settings.ms_table = Some(got.table);
            Ok(())
        }
        Err(why) if forced => {
            cx.warn(format!(
                "{}: evaluation = compensated needs a table of the nested BSDF, and {why}: this normal map uses the random walk",
                cx.props().loc()
            ));
            settings.evaluation = Evaluation::RandomWalk;
            Ok(())
        }
        Err(why) => Err(Error::scene(
            cx.props().loc(),
            format!("evaluation = compensated needs a table of the nested BSDF, and {why}; use evaluation = random_walk"),
        )),
    }
}

/// A `normalmap` converted to a `microfacet_normalmap` of model `mode` with the other
/// parameters at their defaults; its own flags are read (and checked) but have no effect.
pub(crate) fn from_normalmap(cx: &mut BsdfCtx<'_, '_>, mode: MnmMode) -> Result<MaterialNode> {
    let (nested, nested_loc, normalmap) = parts(cx, "normalmap")?;
    let _ = cx.props().bool("flip_invalid_normals", true)?;
    let _ = cx.props().bool("use_shadowing_function", true)?;
    let mut settings = MnmSettings {
        geometry: mode.geometry,
        tangent: mode.tangent,
        evaluation: mode.evaluation,
        max_order: 256,
        max_theta: MaxTilt::new(85f32.to_radians()),
        transmission_walk: TransmissionWalk::TwoSided,
        lambert_closed_form: true,
        ms_table: None,
    };
    compensate(cx, nested, &mut settings, true)?;
    check_nested(cx, nested, nested_loc, settings.evaluation)?;
    Ok(MaterialNode::MicrofacetNormalMap {
        nested,
        normalmap,
        settings,
    })
}

/// `microgeometry` (with `groove_fill` for `ugroove`).
fn microgeometry(p: &Props) -> Result<Microgeometry> {
    let geometry = match p.string("microgeometry", "sawtooth")?.as_str() {
        "sawtooth" => Microgeometry::Sawtooth,
        "vgroove" => Microgeometry::VGroove,
        "ugroove" => {
            let s = p.float("groove_fill", 0.5)?;
            check(
                p.loc(),
                s > 0.0 && s <= 1.0,
                "groove_fill must be in (0, 1]",
            )?;
            Microgeometry::UGroove { fill: s }
        }
        other => {
            return Err(Error::scene(
                p.loc(),
                format!("microgeometry '{other}' must be sawtooth, vgroove or ugroove"),
            ))
        }
    };
    if !matches!(geometry, Microgeometry::UGroove { .. }) && p.has("groove_fill") {
        return Err(Error::scene(
            p.loc(),
            "groove_fill belongs to microgeometry 'ugroove'",
        ));
    }
    Ok(geometry)
}

/// The sawtooth's wall when `tangent` is absent and the random walk evaluates: the nested BSDF,
/// for every nested kind. Measured in `docs/mnm.md`, "Normal maps on diffuse materials": a
/// mirror wall makes texels tilted toward and away from a light look alike (exactly so over
/// `diffuse`, where the mirror walk is Lambertian; over rough conductor, plastic and dielectric
/// wherever the light reaches the wall, like the symmetric V-groove), so the normal map loses
/// its relief; a same-material wall keeps it. `--normal-mapping microfacet` uses it too.
pub(crate) const DEFAULT_WALK_TANGENT: Tangent = Tangent::Same;

/// `tangent`, which only the sawtooth takes. Absent: [`DEFAULT_WALK_TANGENT`] under the
/// random walk; `mirror` under the explicit forms, whose paths are the mirror wall's (the
/// paper's Variant M and its complete first order). The grooves' walls are the same material.
fn tangent(p: &Props, geometry: Microgeometry, evaluation: Evaluation) -> Result<Tangent> {
    if !p.has("tangent") {
        return Ok(match geometry {
            // `compensated` (and `auto`, which blends it with the walk on the same microsurface)
            // builds on explicit4's mirror-wall first order, as its forced mode does.
            Microgeometry::Sawtooth
                if evaluation.is_explicit()
                    || matches!(evaluation, Evaluation::Compensated | Evaluation::Auto) =>
            {
                Tangent::Mirror
            }
            Microgeometry::Sawtooth => DEFAULT_WALK_TANGENT,
            _ => Tangent::Same,
        });
    }
    if geometry != Microgeometry::Sawtooth {
        return Err(Error::scene(
            p.loc(),
            "'tangent' belongs to the sawtooth microgeometry only",
        ));
    }
    match p.string("tangent", "mirror")?.as_str() {
        "mirror" => Ok(Tangent::Mirror),
        "same" => Ok(Tangent::Same),
        other => Err(Error::scene(
            p.loc(),
            format!("tangent '{other}' must be 'mirror' or 'same'"),
        )),
    }
}

/// What a `microfacet_normalmap` (written, or converted by `--normal-mapping`) accepts as
/// nested BSDF: a non-delta lobe; over a transmitting BSDF only the random walk.
fn check_nested(
    cx: &BsdfCtx<'_, '_>,
    nested: MatId,
    nested_loc: &SourceLoc,
    evaluation: Evaluation,
) -> Result<()> {
    let lobes = cx.lobes(nested);
    if lobes.has_transmission() && evaluation != Evaluation::RandomWalk {
        return Err(Error::scene(cx.props().loc(), "microfacet_normalmap over a transmitting BSDF needs evaluation = random_walk (the closed forms are reflection only)"));
    }
    if !lobes.is_smooth() {
        return Err(Error::scene(nested_loc, "microfacet_normalmap needs a nested BSDF with a non-delta lobe (e.g. diffuse, roughconductor, roughplastic): with only delta lobes its evaluation is zero almost everywhere"));
    }
    Ok(())
}
