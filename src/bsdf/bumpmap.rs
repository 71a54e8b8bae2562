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
