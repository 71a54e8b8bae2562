//! Participating media (Mitsuba 3's `<medium>` plugins) and their phase functions.
//!
//! - [`homogeneous`]: constant extinction, sampled analytically; a constant albedo or one from a
//!   [`volume`] looked up at the scattering point;
//! - [`heterogeneous`]: extinction and albedo from [`volume`]s (`constvolume`, `gridvolume`),
//!   delta tracking and ratio tracking against one majorant;
//! - [`phase`]: `isotropic`, `hg`, `blendphase`;
//! - [`MediumInterface`]: which medium lies on each side of a shape (Mitsuba's `interior` /
//!   `exterior`), chosen by the sign of dot(ray direction, geometric normal).

pub mod heterogeneous;
pub mod homogeneous;
pub mod phase;
pub mod volume;

pub use heterogeneous::Heterogeneous;
pub use homogeneous::{FreeFlight, Homogeneous};
pub use phase::Phase;

use crate::sampler::Sampler;
use crate::spectrum::Spectrum;

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

/// A medium's coefficients at a point (Mitsuba's `get_scattering_coefficients`): extinction
/// σt, scattering σs = α·σt and the null-collision coefficient σn = majorant − σt.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coefficients {
    pub sigma_t: Spectrum,
    pub sigma_s: Spectrum,
    pub sigma_n: Spectrum,
}

/// A participating medium.
///
/// The tracking interface, for any volumetric integrator (all distances along a ray o + t·d with
/// unit `d`):
/// - [`Medium::majorant`], [`Medium::coefficients`], [`Medium::clip`]: the pieces of Mitsuba's
///   `get_majorant`, `get_scattering_coefficients`, `intersect_aabb`;
/// - [`Medium::sample_interaction`]: one tentative collision (Mitsuba's `sample_interaction`),
///   for an integrator that runs its own tracking loop (none does today: both `volpath` and
///   `volpathmis` call the heterogeneous medium's `delta_track` / `ratio_track`);
/// - [`Medium::sample_free_flight`]: a whole free flight as `volpath` samples it (closed form
///   when homogeneous, delta tracking when not);
/// - [`Medium::transmittance`]: a shadow segment's transmittance (closed form, or ratio
///   tracking).
#[derive(Clone, Debug)]
pub enum Medium {
    Homogeneous(Homogeneous),
    Heterogeneous(Box<Heterogeneous>),
}

impl Medium {
    /// The medium's phase function.
    #[inline]
    pub fn phase(&self) -> &Phase {
        match self {
            Medium::Homogeneous(m) => &m.phase,
            Medium::Heterogeneous(m) => &m.phase,
        }
    }

    /// Whether scattering events in the medium sample emitters (Mitsuba's `sample_emitters`).
    #[inline]
    pub fn sample_emitters(&self) -> bool {
        match self {
            Medium::Homogeneous(m) => m.sample_emitters,
            Medium::Heterogeneous(m) => m.sample_emitters,
        }
    }

    /// Mitsuba's `is_homogeneous`.
    #[inline]
    pub fn is_homogeneous(&self) -> bool {
        matches!(self, Medium::Homogeneous(_))
    }

    /// Mitsuba's `has_spectral_extinction`.
    #[inline]
    pub fn has_spectral_extinction(&self) -> bool {
        match self {
            Medium::Homogeneous(m) => m.spectral_extinction,
            Medium::Heterogeneous(m) => m.spectral_extinction,
        }
    }

    /// The majorant used for distance sampling: σt itself when homogeneous, the global
    /// `scale`·max(σt) in every channel when heterogeneous.
    #[inline]
    pub fn majorant(&self) -> Spectrum {
        match self {
            Medium::Homogeneous(m) => m.sigma_t,
            Medium::Heterogeneous(m) => Spectrum::splat(m.majorant),
        }
    }

    /// σt, σs, σn at world point `p` (σn = 0 when homogeneous; σs reads a homogeneous
    /// medium's albedo volume at `p` when it has one).
    #[inline]
    pub fn coefficients(&self, p: Vec3) -> Coefficients {
        match self {
            Medium::Homogeneous(m) => Coefficients {
                sigma_t: m.sigma_t,
                sigma_s: m.sigma_s_at(p),
                sigma_n: Spectrum::ZERO,
            },
            Medium::Heterogeneous(m) => m.coefficients(p),
        }
    }

    /// The interval [t0, t1] of t ∈ [0, t_max] where the medium exists along the ray (all of
    /// it when homogeneous; the σt volume's world box when heterogeneous), `None` if empty.
    #[inline]
    pub fn clip(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, f32)> {
        match self {
            Medium::Homogeneous(_) => Some((0.0, t_max)),
            Medium::Heterogeneous(m) => m.clip(o, d, t_max),
        }
    }

    /// One tentative collision at t > `t_from`, sampled from `u` with the majorant of channel
    /// `channel` (Mitsuba's `sample_interaction` on the ray restarted at `t_from`): its distance
    /// and coefficients, or `None` when it falls beyond `t_max` or outside the medium. The
    /// free-flight density of the step is majorant·exp(−majorant·(t − t0)), t0 = where the medium
    /// starts after `t_from`.
    pub fn sample_interaction(
        &self,
        o: Vec3,
        d: Vec3,
        t_from: f32,
        t_max: f32,
        channel: usize,
        u: f32,
    ) -> Option<(f32, Coefficients)> {
        match self {
            Medium::Homogeneous(m) => {
                let s = m.sigma_t[channel];
                let t = t_from - (1.0 - u).ln() / s;
                (s > 0.0 && t < t_max).then(|| (t, self.coefficients(o + d * t)))
            }
            Medium::Heterogeneous(m) => m.sample_interaction(o, d, t_from, t_max, u),
        }
    }

    /// A free flight along the ray up to `t_max` (the next surface, or ∞), as `volpath` samples
    /// it: homogeneous media draw one number (channel `channel`'s exponential), heterogeneous
    /// ones delta-track (see [`heterogeneous`]).
    #[inline]
    pub fn sample_free_flight(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        channel: usize,
        sampler: &mut Sampler,
    ) -> FreeFlight {
        match self {
            Medium::Homogeneous(m) => m.sample_free_flight(o, d, t_max, channel, sampler.next_1d()),
            Medium::Heterogeneous(m) => m.sample_free_flight(o, d, t_max, sampler),
        }
    }

    /// Transmittance of a shadow ray over [0, `t_max`] for a path sampling distances in
    /// `channel`: exp(−σt·t_max) when homogeneous (draws nothing; grey in `channel` without
    /// spectral extinction, as Mitsuba), a ratio-tracking estimate when heterogeneous.
    #[inline]
    pub fn transmittance(
        &self,
        o: Vec3,
        d: Vec3,
        t_max: f32,
        channel: usize,
        sampler: &mut Sampler,
    ) -> Spectrum {
        match self {
            Medium::Homogeneous(m) => m.shadow_transmittance(t_max, channel),
            Medium::Heterogeneous(m) => m.transmittance(o, d, t_max, sampler),
        }
    }
}
