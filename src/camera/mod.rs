//! The scene's sensor: Mitsuba 3's `perspective`, `orthographic` and `thinlens` cameras, one file
//! each ([`perspective`], [`orthographic`], [`thinlens`]), behind one [`Camera`] the renderer
//! asks for rays.
//!
//! Conventions shared by all three (checked numerically against Mitsuba 3.9.1 in each file's
//! tests): camera-local space looks along +z, +y is up and +x points to the LEFT of the image
//! (Mitsuba's look-at builds its columns as (left, up, dir)); film positions are continuous pixel
//! coordinates of the full film, (0,0) the top-left corner and (width, height) the bottom-right
//! one, so a crop window only restricts which positions the renderer asks for.
//!
//! Stream use: the renderer draws one 2-D sample for the film position and, only for a camera
//! that [`Camera::needs_aperture_sample`] (the thin lens), a second one for the lens, right after
//! it, as Mitsuba's `SamplingIntegrator::sample` does. The pinhole and orthographic cameras draw
//! nothing, so their images do not depend on how the lens is sampled.

pub mod orthographic;
pub mod perspective;
pub mod thinlens;

pub use orthographic::Orthographic;
pub use perspective::{FovAxis, Perspective, SensorSample};
pub use thinlens::ThinLens;

use crate::error::{Error, Result};
use crate::geometry::Ray;
use crate::math::{Mat4, Vec2};
use crate::sampler::Sampler;
use crate::scene::xml::props::Props;

/// The scene's camera.
#[derive(Clone, Debug)]
pub enum Camera {
    Perspective(Perspective),
    Orthographic(Orthographic),
    ThinLens(ThinLens),
}

impl Camera {
    /// A pinhole `perspective` camera; see [`Perspective::new`].
    pub fn perspective(
        to_world: Mat4,
        fov_deg: f32,
        fov_axis: FovAxis,
        near_clip: f32,
        far_clip: f32,
        film_size: (u32, u32),
    ) -> Result<Camera> {
        Perspective::new(to_world, fov_deg, fov_axis, near_clip, far_clip, film_size)
            .map(Camera::Perspective)
    }

    /// Whether ray generation uses a lens sample (Mitsuba's `needs_aperture_sample`).
    #[inline]
    pub fn needs_aperture_sample(&self) -> bool {
        matches!(self, Camera::ThinLens(_))
    }

    /// The ray through `film_pos` (full-film continuous pixel coordinates) and, for a thin lens,
    /// through the lens point `aperture` ∈ [0,1)² maps to; the other cameras ignore `aperture`.
    /// Directions are unit length; `tmin`..`tmax` is the near..far clip range.
    #[inline]
    pub fn generate_ray(&self, film_pos: Vec2, aperture: Vec2) -> Ray {
        match self {
            Camera::Perspective(c) => c.generate_ray(film_pos),
            Camera::Orthographic(c) => c.generate_ray(film_pos),
            Camera::ThinLens(c) => c.generate_ray(film_pos, aperture),
        }
    }

    /// [`Camera::generate_ray`] with the lens sample drawn from the path's own stream, only when
    /// the camera needs one (so a pinhole camera's stream use is unchanged).
    #[inline]
    pub fn sample_ray(&self, film_pos: Vec2, sampler: &mut Sampler) -> Ray {
        let aperture = if self.needs_aperture_sample() {
            sampler.next_2d()
        } else {
            Vec2::splat(0.5)
        };
        self.generate_ray(film_pos, aperture)
    }
}

impl Camera {
    /// The pinhole or lens centre of a camera light tracing connects to (`None`: orthographic).
    pub fn light_tracing_origin(&self) -> Option<crate::math::Vec3> {
        match self {
            Camera::Perspective(c) => Some(c.position()),
            Camera::ThinLens(c) => Some(c.position()),
            Camera::Orthographic(_) => None,
        }
    }

    /// True when light tracing can connect to this sensor (Mitsuba 3.9.1 implements
    /// `sample_direction` for `perspective` and `thinlens`, not `orthographic`).
    pub fn supports_light_tracing(&self) -> bool {
        !matches!(self, Camera::Orthographic(_))
    }

    /// The connection of the world point `p` to the sensor for light tracing (see
    /// [`SensorSample`]), with `aperture` ∈ [0,1)² the lens sample (used by the thin lens only)
    /// and `crop` the crop window in full-film pixels (x0, y0, w, h). `None` when the point is
    /// not seen (behind, clipped, outside the crop) and for the orthographic camera.
    #[inline]
    pub fn sample_direction(
        &self,
        p: crate::math::Vec3,
        aperture: Vec2,
        crop: (u32, u32, u32, u32),
    ) -> Option<SensorSample> {
        match self {
            Camera::Perspective(c) => c.sample_direction(p, crop),
            Camera::ThinLens(c) => c.sample_direction(p, aperture, crop),
            Camera::Orthographic(_) => None,
        }
    }
}

/// The near/far clip planes of a Mitsuba `ProjectiveCamera` (defaults 0.01 and 10⁴;
/// `0 < near_clip < far_clip`, both finite).
pub(crate) fn clip_from_props(p: &Props<'_>) -> Result<(f32, f32)> {
    let near = p.float("near_clip", 1e-2)?;
    let far = p.float("far_clip", 1e4)?;
    if !(near.is_finite() && near > 0.0) {
        return Err(Error::scene(
            p.loc(),
            format!("near_clip must be greater than zero, got {near}"),
        ));
    }
    if !(far.is_finite() && far > near) {
        return Err(Error::scene(
            p.loc(),
            format!("far_clip ({far}) must be finite and greater than near_clip ({near})"),
        ));
    }
    Ok((near, far))
}

/// The shutter interval every Mitsuba sensor reads (`shutter_open`, `shutter_close`, both 0 by
/// default). groove renders the instant `shutter_open` (nothing in a scene moves); like Mitsuba
/// it rejects a shutter that closes before it opens.
pub(crate) fn shutter_from_props(p: &Props<'_>) -> Result<()> {
    let open = p.float("shutter_open", 0.0)?;
    let close = p.float("shutter_close", 0.0)?;
    if open.is_nan() || close.is_nan() || close < open {
        return Err(Error::scene(
            p.loc(),
            format!("shutter_close ({close}) must not be less than shutter_open ({open})"),
        ));
    }
    Ok(())
}
