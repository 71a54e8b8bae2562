//! `bumpmap` (Mitsuba 3.9.1 semantics): a height texture perturbs the shading normal, and the
//! nested BSDF is evaluated in the perturbed frame exactly as for the classic `normalmap` — both
//! are Mitsuba's `PerturbedBSDF` (`flip_invalid_normals`, the Estevez et al. 2019 shadowing term,
//! side rejection; see [`super::normalmap`]), so a bump-mapped BSDF is a [`super::NormalMap`]
//! node whose normal comes from [`perturbed_normal`].
//!
//! The normal is Blinn's bump mapping ("Simulation of Wrinkled Surfaces", 1978) without the
//! derivative of the base normal, as Mitsuba does: with g = `scale` · ∇_uv h and the shading
//! normal n, the displaced tangents are ∂p/∂u′ = ∂p/∂u + n·(g_u − n·∂p/∂u) (likewise v), and the
//! perturbed normal is normalize(∂p/∂u′ × ∂p/∂v′), flipped to the geometric normal's side,
//! expressed in the shading frame. Only the height's variation matters, not its offset.
//!
//! # XML parameters (Mitsuba 3 names; defaults as groove and Mitsuba 3 read them)
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | (nested) | one `<texture>` (any name) | required | the height, a `bitmap` (the only texture with a gradient in Mitsuba 3) |
//! | (nested) | one `<bsdf>` | required | the bumped BSDF |
//! | `scale` | float | 1 | multiplier of the height |
//! | `flip_invalid_normals` | boolean | true (false in files upgraded from 0.6) | mirror a normal that faces away from the incident direction |
//! | `use_shadowing_function` | boolean | true (false in files upgraded from 0.6) | the Estevez et al. 2019 shadowing term |

use crate::geometry::SurfaceInteraction;
use glam::{Vec2, Vec3};

/// The bump-mapped normal in shading-frame coordinates at `si`, for the height gradient `grad`
/// (already multiplied by `scale`) with respect to uv. Degenerate geometry (zero tangents) gives
/// the unperturbed normal (0, 0, 1).
pub fn perturbed_normal(si: &SurfaceInteraction, grad: Vec2) -> Vec3 {
    let n = si.sh.n;
    let dpdu = si.dpdu + n * (grad.x - n.dot(si.dpdu));
    let dpdv = si.dpdv + n * (grad.y - n.dot(si.dpdv));
    let c = dpdu.cross(dpdv);
    let len2 = c.length_squared();
    if !(len2 > 0.0 && len2.is_finite()) {
        return Vec3::Z;
    }
    let mut pn = c / len2.sqrt();
    if si.ng.dot(pn) < 0.0 {
        pn = -pn;
    }
    si.sh.to_local(pn)
}

/// The XML constructor (see the parameter table above); the only part of this file that
/// sees the scene file.
pub(crate) mod load {
    use crate::error::{Error, Result};
    use crate::load::bsdfs::BsdfCtx;
    use crate::load::check;
    use crate::material::MaterialNode;
    use crate::texture::Texture;

    /// `bumpmap`.
    pub(crate) fn build(cx: &mut BsdfCtx<'_, '_>) -> Result<MaterialNode> {
        for c in cx.props().objects() {
            match cx.props().kind(c) {
                "bsdf" | "texture" => {}
                t => return Err(Error::scene(&c.loc, format!("<{t}> is not expected inside a bumpmap (a nested <bsdf> and a height <texture>)"))),
            }
        }
        let (nested, height) = (
            cx.props().one_child("bsdf")?,
            cx.props().one_child("texture")?,
        );
        // The height texture is checked first (a missing file is its own error at the <texture>).
        let height = match height {
            Some(c) => {
                let id = cx.texture(c)?;
                if !matches!(cx.texture_at(id), Texture::Bitmap(_)) {
                    return Err(Error::scene(&c.loc, "a bumpmap's height texture must be a 'bitmap' (Mitsuba 3 has no gradient for other textures)"));
                }
                Some(id)
            }
            None => None,
        };
        let nested = match nested {
            Some(c) => cx.bsdf(c)?,
            None => {
                return Err(Error::scene(
                    cx.props().loc(),
                    "bumpmap needs a nested <bsdf>",
                ))
            }
        };
        let p = cx.props();
        let height = height
            .ok_or_else(|| Error::scene(p.loc(), "bumpmap needs a nested height <texture>"))?;
        let scale = p.float("scale", 1.0)?;
        check(p.loc(), scale.is_finite(), "bumpmap scale must be finite")?;
        let default = !cx.upgraded_from_v0();
        Ok(MaterialNode::BumpMap {
            nested,
            height,
            scale,
            flip_invalid_normals: p.bool("flip_invalid_normals", default)?,
            use_shadowing_function: p.bool("use_shadowing_function", default)?,
        })
    }
}
