//! Participating media (Mitsuba 3's `<medium>` plugins) and their phase functions.
//!
//! - [`homogeneous`]: constant extinction and albedo, sampled analytically;
//! - [`phase`]: `isotropic`, `hg`, `blendphase`;
//! - [`MediumInterface`]: which medium lies on each side of a shape (Mitsuba's `interior` /
//!   `exterior`), chosen by the sign of dot(ray direction, geometric normal).

pub mod homogeneous;
pub mod phase;

pub use homogeneous::Homogeneous;
pub use phase::Phase;

use glam::Vec3;

/// Index of a medium in `Scene::media`.
pub type MediumId = u32;

/// The media on both sides of a shape's surface: `interior` behind the geometric normal,
/// `exterior` in front of it (Mitsuba 3's `Shape::interior_medium` / `exterior_medium`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MediumInterface {
    pub interior: Option<MediumId>,
    pub exterior: Option<MediumId>,
}

impl MediumInterface {
    /// Whether crossing this surface changes the medium (Mitsuba's `is_medium_transition`:
    /// either side is set).
    #[inline]
    pub fn is_transition(&self) -> bool {
        self.interior.is_some() || self.exterior.is_some()
    }

    /// The medium a ray leaving the surface in direction `d` enters (Mitsuba's
    /// `SurfaceInteraction::target_medium`): the exterior when `d` points along the geometric
    /// normal `ng`, the interior otherwise.
    #[inline]
    pub fn target(&self, ng: Vec3, d: Vec3) -> Option<MediumId> {
        if ng.dot(d) > 0.0 {
            self.exterior
        } else {
            self.interior
        }
    }
}

/// A participating medium.
#[derive(Clone, Debug)]
pub enum Medium {
    Homogeneous(Homogeneous),
}

impl Medium {
    /// The medium's phase function.
    #[inline]
    pub fn phase(&self) -> &Phase {
        match self {
            Medium::Homogeneous(m) => &m.phase,
        }
    }

    /// Whether scattering events in the medium sample emitters (Mitsuba's `sample_emitters`).
    #[inline]
    pub fn sample_emitters(&self) -> bool {
        match self {
            Medium::Homogeneous(m) => m.sample_emitters,
        }
    }
}
