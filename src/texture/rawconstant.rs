//! Mitsuba 3's `rawconstant` texture: a constant value that is used as given, without colour
//! conversion or range checks (`src/spectra/rawconstant.cpp`).
//!
//! # XML parameters
//!
//! | Parameter | Type | Default | Meaning |
//! | --- | --- | --- | --- |
//! | `value` | float or vector | required | the value: a `<float>` (the same in every channel) or a 3-D `<vector>` (or `<point>`) |
//!
//! It becomes a [`super::Texture::Constant`] (groove renders RGB, where a constant colour is
//! not converted either). A 3-D value has no scalar value in Mitsuba (`eval_1` throws), so the
//! loader rejects it where a scalar is read (roughness, weights, opacity).

use glam::Vec3;

/// A loaded `rawconstant`: its value in all channels, and whether it was a 3-D vector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RawConstant {
    pub value: Vec3,
    pub vector: bool,
}

/// What Mitsuba 3.9.1 says when a 3-D `rawconstant` is read as a scalar.
pub const NO_SCALAR: &str = "RawConstantTexture: eval_1() is not defined for 3D-valued textures.";

pub(crate) mod load {
    use super::RawConstant;
    use crate::error::{Error, Result};
    use crate::scene::xml::props::Props;
    use glam::Vec3;

    /// `rawconstant`.
    pub(crate) fn build(p: &Props<'_>) -> Result<RawConstant> {
        let Some(node) = p.property_node("value") else {
            return Err(Error::scene(
                p.loc(),
                "RawConstantTexture: missing required parameter \"value\" (1D `float` or 3D `vector` expected).",
            ));
        };
        let (value, vector) = match node.tag.as_str() {
            "float" => (Vec3::splat(p.float("value", 0.0)?), false),
            "vector" | "point" => (p.vector("value", Vec3::ZERO)?, true),
            _ => {
                return Err(Error::scene(
                    &node.loc,
                    "RawConstantTexture: parameter \"value\" has incorrect type, expected `float` or 3D `vector`.",
                ))
            }
        };
        if !value.is_finite() {
            return Err(Error::scene(
                &node.loc,
                "the 'value' of texture 'rawconstant' must be finite",
            ));
        }
        Ok(RawConstant { value, vector })
    }
}
