//! Textures: spatially varying colours looked up by uv (or, for `mesh_attribute`, by the hit's
//! mesh data: [`TexPoint`]). A material evaluates its textures at a hit and hands plain values
//! to the BSDFs (which never see uvs).
//!
//! Values are linear RGB and are not clamped: whatever the texture holds (e.g. an EXR reflectance
//! above 1) reaches the BSDF, as in Mitsuba 3.

pub mod bitmap;
pub mod float_image;
pub mod mesh_attribute;
mod pfm;
pub mod rawconstant;
mod rgbe;

use std::sync::Arc;

use crate::spectrum::{luminance, Spectrum};
use glam::{Mat3, Vec2, Vec3};

pub use bitmap::{BitmapOptions, BitmapTexture, FilterType, StorageFormat, WrapMode};
pub use mesh_attribute::{MeshAttributeTexture, MeshPoint};

/// Where a texture is looked up: the uv, and for `mesh_attribute` the hit mesh's data. A bare
/// `Vec2` converts into a lookup by uv alone.
#[derive(Clone, Copy, Debug)]
pub struct TexPoint<'a> {
    pub uv: Vec2,
    pub mesh: Option<MeshPoint<'a>>,
}

impl From<Vec2> for TexPoint<'_> {
    #[inline]
    fn from(uv: Vec2) -> Self {
        TexPoint { uv, mesh: None }
    }
}

/// What a texture lookup needs: a uv, and for `mesh_attribute` the hit mesh's data. Generic
/// lookups keep the common case (a bare `Vec2`, no mesh) exactly as cheap as a uv lookup: the
/// compiler sees that it has no mesh data and drops the mesh-attribute arm.
pub trait Lookup: Copy {
    fn uv(&self) -> Vec2;
    fn mesh(&self) -> Option<&MeshPoint<'_>>;
}

impl Lookup for Vec2 {
    #[inline(always)]
    fn uv(&self) -> Vec2 {
        *self
    }
    #[inline(always)]
    fn mesh(&self) -> Option<&MeshPoint<'_>> {
        None
    }
}

impl Lookup for TexPoint<'_> {
    #[inline(always)]
    fn uv(&self) -> Vec2 {
        self.uv
    }
    #[inline(always)]
    fn mesh(&self) -> Option<&MeshPoint<'_>> {
        self.mesh.as_ref()
    }
}

impl<'a> TexPoint<'a> {
    /// The lookup at hit `si` on `shape` (the shape `si.shape` names): with the mesh data when
    /// the shape has attributes.
    #[inline]
    pub fn on_shape(
        si: &crate::geometry::SurfaceInteraction,
        shape: &'a crate::geometry::Shape,
    ) -> TexPoint<'a> {
        let mesh = match &shape.kind {
            crate::geometry::ShapeKind::Mesh(m) if !shape.attributes().is_empty() => {
                Some(MeshPoint {
                    attributes: shape.attributes(),
                    mesh: m,
                    prim: si.prim,
                    p: si.p,
                })
            }
            _ => None,
        };
        TexPoint { uv: si.uv, mesh }
    }
}

#[derive(Clone, Debug)]
pub enum Texture {
    Constant(Spectrum),
    /// Mitsuba's `checkerboard`: with p = `to_uv`(uv) and f = p − ⌊p⌋ per component, `color0`
    /// where (f.x > 0.5) == (f.y > 0.5), else `color1` (so the quarter at uv (0, 0) is `color0`;
    /// checked against Mitsuba 3.9.1 in tests/scene/texture.rs).
    Checkerboard {
        color0: Spectrum,
        color1: Spectrum,
        to_uv: Mat3,
    },
    /// Mitsuba's `bitmap` (shared: cloning a texture does not copy its texels).
    Bitmap(Arc<BitmapTexture>),
    /// Mitsuba's `mesh_attribute`: a value the hit mesh carries.
    MeshAttribute(MeshAttributeTexture),
}

impl From<BitmapTexture> for Texture {
    fn from(b: BitmapTexture) -> Texture {
        Texture::Bitmap(Arc::new(b))
    }
}

impl Texture {
    /// The colour at `at` (a uv, or a [`TexPoint`]; linear RGB).
    #[inline]
    pub fn eval(&self, at: impl Lookup) -> Spectrum {
        let uv = at.uv();
        match self {
            Texture::Constant(c) => *c,
            Texture::Checkerboard {
                color0,
                color1,
                to_uv,
            } => {
                let p = to_uv.transform_point2(uv);
                // Mitsuba 3 checkerboard: the four quarters of the unit square, repeated.
                let fx = p.x - crate::math::floor(p.x);
                let fy = p.y - crate::math::floor(p.y);
                if (fx > 0.5) == (fy > 0.5) {
                    *color0
                } else {
                    *color1
                }
            }
            Texture::Bitmap(b) => b.eval(uv),
            Texture::MeshAttribute(m) => m.eval(at.mesh()),
        }
    }

    /// The stored RGB value at `uv` as a vector, for data textures (a normal map reads a
    /// `raw=true` bitmap and decodes `2·rgb − 1` itself). A grey bitmap gives (g, g, g).
    #[inline]
    pub fn eval_vec3(&self, at: impl Lookup) -> Vec3 {
        self.eval(at)
    }

    /// A scalar value at `uv` (roughness-like parameters), as Mitsuba's `eval_1`: a grey texture's
    /// value, otherwise the luminance of the colour.
    ///
    /// Mitsuba 3.9.1's `checkerboard` swaps its colours in `eval_1` (`color1` where `eval` gives
    /// `color0` and vice versa; checked with `mi.load_dict(...).eval_1` in
    /// tests/refs/perturb_points.py and the `mat_mask` reference), so a scalar checkerboard
    /// (opacity, weight, roughness) is the complement pattern of the same texture as a colour;
    /// groove follows Mitsuba.
    #[inline]
    pub fn eval_1(&self, at: impl Lookup) -> f32 {
        let uv = at.uv();
        let grey = match self {
            Texture::Bitmap(b) => b.is_grey(),
            _ => false,
        };
        let c = match self {
            Texture::Checkerboard {
                color0,
                color1,
                to_uv,
            } => Texture::Checkerboard {
                color0: *color1,
                color1: *color0,
                to_uv: *to_uv,
            }
            .eval(uv),
            _ => self.eval(at),
        };
        if grey || (c.x == c.y && c.y == c.z) {
            c.x
        } else {
            luminance(c)
        }
    }

    /// The gradient `(∂/∂u, ∂/∂v)` of [`Texture::eval_1`] at `uv` (what a `bumpmap` needs): a
    /// bitmap's as Mitsuba's `eval_1_grad`; 0 for constant textures and almost everywhere for
    /// the piecewise-constant checkerboard (Mitsuba 3.9.1 implements no gradient for
    /// `checkerboard`, so the scene loader rejects it in a bumpmap).
    pub fn eval_1_grad(&self, uv: Vec2) -> Vec2 {
        match self {
            Texture::Bitmap(b) => b.eval_1_grad(uv),
            Texture::Constant(_) | Texture::Checkerboard { .. } | Texture::MeshAttribute(_) => {
                Vec2::ZERO
            }
        }
    }

    /// Per-channel mean over the unit uv square (light power estimates). For a bitmap this is
    /// the mean texel, whose luminance is Mitsuba's `BitmapTexture::mean()`; for the checkerboard
    /// the average of its two colours. A `mesh_attribute` has none (0): its values belong to
    /// the meshes it is evaluated on, and the loader rejects the uses that need a mean.
    pub fn mean(&self) -> Spectrum {
        match self {
            Texture::Constant(c) => *c,
            Texture::Checkerboard { color0, color1, .. } => 0.5 * (*color0 + *color1),
            Texture::Bitmap(b) => b.mean(),
            Texture::MeshAttribute(_) => Spectrum::ZERO,
        }
    }

    /// Width and height in texels for a bitmap; `None` for constant and procedural textures.
    pub fn resolution(&self) -> Option<(u32, u32)> {
        match self {
            Texture::Bitmap(b) => Some(b.resolution()),
            _ => None,
        }
    }

    /// Does the value depend on uv?
    pub fn is_spatially_varying(&self) -> bool {
        !matches!(self, Texture::Constant(_))
    }

    /// The bitmap behind this texture, if it is one (texel access, e.g. for sampling).
    pub fn as_bitmap(&self) -> Option<&BitmapTexture> {
        match self {
            Texture::Bitmap(b) => Some(b),
            _ => None,
        }
    }
}
