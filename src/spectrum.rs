//! Colour: linear Rec.709 RGB. Conversion of `wavelength:value` spectra to RGB lives here.

pub type Spectrum = glam::Vec3;

/// Luminance (Rec.709 weights) of a linear RGB value.
#[inline]
pub fn luminance(c: Spectrum) -> f32 {
    0.212671 * c.x + 0.715160 * c.y + 0.072169 * c.z
}

/// Largest component.
#[inline]
pub fn max_component(c: Spectrum) -> f32 {
    c.x.max(c.y).max(c.z)
}

/// True when every component is finite.
#[inline]
pub fn is_finite(c: Spectrum) -> bool {
    c.x.is_finite() && c.y.is_finite() && c.z.is_finite()
}
