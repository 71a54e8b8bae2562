//! Which nested BSDFs `evaluation = compensated` can tabulate, and the table of one material
//! (built at load, [`super::ms_cache`] keeps it).
//!
//! - `diffuse` (also the front of a `twosided`), any reflectance (constant or textured): the
//!   exact closed-form table ([`MsTable::lambert`]), colour per bounce. (With
//!   `lambert_closed_form = true`, the default, the walk's closed forms evaluate it instead and
//!   the table only stands by.)
//! - `roughconductor` whose only texture is `specular_reflectance`: walked with that colour at 1,
//!   applied per bounce at the hit.
//! - Otherwise every parameter must be constant and the BSDF built from `diffuse`,
//!   `roughconductor`, `roughplastic` (isotropic roughness), `twosided` and `blendbsdf`: walked
//!   with its colours baked in.
//!
//! Anything else (textured roughness or plastic colours, anisotropy, delta lobes, transmission,
//! other plugins) has no table: the caller reports why.
//!
//! `evaluation = auto` also needs the table's misplaced energy M(θp) against the walk
//! ([`super::misplaced`], [`auto_table_for`]): measured once per table (cached with it, in memory
//! and on disk), except where it is known to be 0 (a Lambertian nested BSDF under the mirror
//! sawtooth, whose table is exact) or unused (a Lambertian with the closed forms on: they stand
//! in for both models).

use super::facets::Microgeometry;
use super::misplaced::Misplaced;
use super::ms_cache::{self, Source};
use super::ms_table::{self, Colour, MsTable, TableSpec};
use super::Tangent;
use crate::bsdf::{BsdfArena, BsdfNode};
use crate::geometry::SurfaceInteraction;
use crate::material::{MatId, MaterialNode, Materials, Slot};
use crate::math::Frame;
use crate::texture::Texture;
use glam::{Vec2, Vec3};

/// A table obtained for a material, with how and what it cost.
pub struct Obtained {
    pub table: &'static MsTable,
    pub source: Source,
    /// A warning for the load (the disk cache could not be written).
    pub warning: Option<String>,
}

/// The table of `nested` under the given microsurface, or why there is none.
pub fn table_for(
    materials: &Materials,
    nested: MatId,
    geometry: Microgeometry,
    tangent: Tangent,
    max_order: u32,
    max_theta: f32,
) -> Result<Obtained, String> {
    obtain(
        materials, nested, geometry, tangent, max_order, max_theta, None,
    )
}

/// [`table_for`] with the table's misplaced-energy table M(θp) set (`evaluation = auto`).
/// `lambert_closed_form`: the material's switch (on, a Lambertian nested BSDF needs no M).
pub fn auto_table_for(
    materials: &Materials,
    nested: MatId,
    geometry: Microgeometry,
    tangent: Tangent,
    max_order: u32,
    max_theta: f32,
    lambert_closed_form: bool,
) -> Result<Obtained, String> {
    obtain(
        materials,
        nested,
        geometry,
        tangent,
        max_order,
        max_theta,
        Some(lambert_closed_form),
    )
}

/// Both of the above: `auto` = Some(the Lambert closed-form switch) measures M.
fn obtain(
    materials: &Materials,
    nested: MatId,
    geometry: Microgeometry,
    tangent: Tangent,
    max_order: u32,
    max_theta: f32,
    auto: Option<bool>,
) -> Result<Obtained, String> {
    let nodes = materials.nodes();
    let mut spec = TableSpec {
        geometry,
        tangent,
        max_order,
        max_theta,
        colour: Colour::PerBounce,
        walks: ms_table::WALKS_PER_NODE,
    };
    let head = format!(
        "v{} {}x{}x{} {:?} {:?} max_theta={:e}",
        ms_table::VERSION,
        ms_table::N_THETA,
        ms_table::N_Z,
        ms_table::N_PHI,
        geometry,
        tangent,
        max_theta
    );
    let lambertian = match &nodes[nested as usize] {
        MaterialNode::Diffuse { .. } => true,
        MaterialNode::TwoSided { front, .. } => {
            matches!(nodes[*front as usize], MaterialNode::Diffuse { .. })
        }
        _ => false,
    };
    if lambertian {
        let key = format!("{head} lambert");
        let (table, source, mut warning) =
            ms_cache::get_or_build(&key, spec, || MsTable::lambert(spec, key.clone()));
        let exact = geometry == Microgeometry::Sawtooth && tangent == Tangent::Mirror;
        match auto {
            Some(true) => {}
            Some(false) if exact => {
                let _ = table.misplaced.set(Misplaced::exact(max_theta));
            }
            Some(false) => {
                let mut arena = BsdfArena::new();
                let root = arena.push(BsdfNode::Diffuse(crate::bsdf::diffuse::Diffuse {
                    reflectance: Vec3::ONE,
                }));
                warning = warning.or(ms_cache::misplaced(table, &arena.bsdf(root), root));
            }
            None => {}
        }
        return Ok(Obtained {
            table,
            source,
            warning,
        });
    }
    let mut arena = BsdfArena::new();
    let root = match &nodes[nested as usize] {
        MaterialNode::Leaf { template, slots }
            if matches!(**template, BsdfNode::RoughConductor(_))
                && slots.iter().all(|(s, _)| *s == Slot::SpecularReflectance)
                && !slots.is_empty() =>
        {
            let mut t = **template;
            if let BsdfNode::RoughConductor(b) = &mut t {
                b.specular_reflectance = Vec3::ONE;
            }
            arena.push(t)
        }
        _ => {
            let mut textured = false;
            materials.texture_uses(nested, &mut |t, _| {
                textured |= !matches!(materials.textures[t as usize], Texture::Constant(_));
            });
            if textured {
                return Err("its parameters are textured (a table needs constant parameters; only a roughconductor's specular_reflectance or a diffuse reflectance may be textured)".into());
            }
            spec.colour = Colour::Baked;
            let si = SurfaceInteraction {
                p: Vec3::ZERO,
                t: 1.0,
                ng: Vec3::Z,
                sh: Frame::from_normal(Vec3::Z),
                uv: Vec2::ZERO,
                dpdu: Vec3::X,
                dpdv: Vec3::Y,
                shape: 0,
                prim: 0,
                wi: Vec3::Z,
            };
            materials.build_at(nested, &si, Vec2::ZERO, &mut arena)
        }
    };
    supported(&arena, root)?;
    let key = format!(
        "{head} max_order={max_order} walks={} colour={:?} nested={:?}",
        spec.walks, spec.colour, arena
    );
    let nested_bsdf = arena.bsdf(root);
    let (table, source, mut warning) = ms_cache::get_or_build(&key, spec, || {
        MsTable::from_walk(&nested_bsdf, root, spec, key.clone())
    });
    if auto.is_some() {
        warning = warning.or(ms_cache::misplaced(table, &nested_bsdf, root));
    }
    Ok(Obtained {
        table,
        source,
        warning,
    })
}

/// The nested BSDF (node `i` of `arena`) is one the tables can describe (module doc).
fn supported(arena: &BsdfArena, i: u32) -> Result<(), String> {
    let iso = |d: &crate::bsdf::MicrofacetDistribution| d.alpha_u == d.alpha_v;
    match arena.bsdf(i).node() {
        BsdfNode::Diffuse(_) => Ok(()),
        BsdfNode::RoughConductor(b) if iso(&b.distribution) => Ok(()),
        BsdfNode::RoughPlastic(b) if iso(&b.distribution) => Ok(()),
        BsdfNode::RoughConductor(_) | BsdfNode::RoughPlastic(_) => {
            Err("its roughness is anisotropic (the tables assume an isotropic nested BSDF)".into())
        }
        BsdfNode::TwoSided { front, .. } => supported(arena, *front),
        BsdfNode::Blend(b) => {
            supported(arena, b.bsdf0)?;
            supported(arena, b.bsdf1)
        }
        other => Err(format!(
            "a nested {} has no table (supported: diffuse, roughconductor, roughplastic, twosided and blendbsdf of those)",
            kind(other)
        )),
    }
}

fn kind(n: &BsdfNode) -> &'static str {
    match n {
        BsdfNode::Conductor(_) => "conductor",
        BsdfNode::Dielectric(_) => "dielectric",
        BsdfNode::ThinDielectric(_) => "thindielectric",
        BsdfNode::RoughDielectric(_) => "roughdielectric",
        BsdfNode::Plastic(_) => "plastic",
        BsdfNode::MicrofacetNormalMap { .. } => "microfacet_normalmap",
        BsdfNode::NormalMap(_) => "normalmap or bumpmap",
        BsdfNode::Null => "null",
        BsdfNode::Mask(_) => "mask",
        BsdfNode::Principled { .. } => "principled",
        BsdfNode::PrincipledThin { .. } => "principledthin",
        BsdfNode::Hair(_) => "hair",
        _ => "BSDF of this kind",
    }
}
