//! Mitsuba 3's `orthographic` sensor (`src/sensors/orthographic.cpp`): parallel rays along the
//! camera's +z from a planar film.
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | `to_world` | transform | identity | camera to world; may scale (that sizes the film) |
//! | `near_clip`, `far_clip` | float | 0.01, 10⁴ | rays start on the plane z = near_clip and run for far_clip − near_clip |
//! | `focus_distance` | float | far_clip | read (every projective camera has it) and ignored |
//! | `shutter_open`, `shutter_close` | float | 0, 0 | read; groove renders the instant `shutter_open` |
//!
//! The film covers x ∈ [−1, 1] and y ∈ [−1/aspect, 1/aspect] of the camera's XY plane (aspect =
//! width / height; Mitsuba's `orthographic_projection`), film u = 0 at x = +1 (local +x is left in
//! the image) and v = 0 at y = +1/aspect; `to_world` maps that rectangle into the world. A ray
//! starts at to_world · (x, y, near_clip), goes along normalize(to_world · (0,0,1)) and ends after
//! far_clip − near_clip (measured along the unit direction, as Mitsuba's `maxt`).

use crate::error::{Error, Result};
use crate::geometry::Ray;
use crate::math::{Mat4, Vec2, Vec3};
use crate::scene::xml::props::Props;

/// An orthographic camera.
#[derive(Clone, Debug)]
pub struct Orthographic {
    /// World-space origin of the ray through film position (0, 0): to_world · (1, 1/aspect, near).
    origin0: Vec3,
    /// World-space change of the origin per pixel along film x and film y.
    step_x: Vec3,
    step_y: Vec3,
    /// Unit world direction of every ray.
    dir: Vec3,
    /// far_clip − near_clip.
    max_t: f32,
}

impl Orthographic {
    /// The camera for a film of `film_size` (full film, not the crop). Rejects a non-finite
    /// `to_world` or one that maps the viewing direction to zero, and clip planes outside
    /// 0 < near < far (Mitsuba's `ProjectiveCamera` rule). Errors are [`Error::Usage`] without a
    /// location; [`Orthographic::from_props`] adds it.
    pub fn new(
        to_world: Mat4,
        near_clip: f32,
        far_clip: f32,
        film_size: (u32, u32),
    ) -> Result<Orthographic> {
        let (w, h) = film_size;
        if w == 0 || h == 0 {
            return Err(Error::Usage(format!(
                "orthographic: film size must be positive, got {w}x{h}"
            )));
        }
        if !(near_clip.is_finite() && near_clip > 0.0) {
            return Err(Error::Usage(format!(
                "orthographic: near_clip must be greater than zero, got {near_clip}"
            )));
        }
        if !(far_clip.is_finite() && far_clip > near_clip) {
            return Err(Error::Usage(format!(
                "orthographic: far_clip ({far_clip}) must be greater than near_clip ({near_clip})"
            )));
        }
        if !to_world.is_finite() {
            return Err(Error::Usage(
                "orthographic: to_world contains non-finite values".into(),
            ));
        }
        let dir = to_world
            .transform_vector3(Vec3::Z)
            .try_normalize()
            .ok_or_else(|| {
                Error::Usage(
                    "orthographic: to_world maps the viewing direction (+z) to zero".into(),
                )
            })?;
        let aspect = w as f64 / h as f64;
        // x = 1 − 2·px/w and y = (1 − 2·py/h)/aspect = 1/aspect − 2·py/w.
        let step = -(2.0 / w as f64) as f32;
        Ok(Orthographic {
            origin0: to_world.transform_point3(Vec3::new(1.0, (1.0 / aspect) as f32, near_clip)),
            step_x: to_world.transform_vector3(Vec3::new(step, 0.0, 0.0)),
            step_y: to_world.transform_vector3(Vec3::new(0.0, step, 0.0)),
            dir,
            max_t: far_clip - near_clip,
        })
    }

    /// The `orthographic` sensor element's camera parameters (the loader handles its film and
    /// sampler); errors name the element's position.
    pub fn from_props(p: &Props<'_>, film_size: (u32, u32)) -> Result<Orthographic> {
        let to_world = p.transform("to_world")?;
        let (near, far) = super::clip_from_props(p)?;
        // Mitsuba's ProjectiveCamera reads it for every projective sensor; unused here.
        let _ = p.float("focus_distance", far)?;
        super::shutter_from_props(p)?;
        Orthographic::new(to_world, near, far, film_size)
            .map_err(|e| Error::scene(p.loc(), e.to_string()))
    }

    /// The ray through `film_pos` (full-film continuous pixel coordinates): origin on the near
    /// plane, unit direction, `tmin` 0 and `tmax` far_clip − near_clip.
    #[inline]
    pub fn generate_ray(&self, film_pos: Vec2) -> Ray {
        Ray {
            o: self.origin0 + self.step_x * film_pos.x + self.step_y * film_pos.y,
            d: self.dir,
            tmin: 0.0,
            tmax: self.max_t,
        }
    }
}

#[cfg(test)]
// Mitsuba's values are quoted as Python printed them.
#[allow(clippy::excessive_precision)]
mod tests {
    use super::*;
    use crate::camera::perspective::tests::look_at;

    /// Origins from Mitsuba 3.9.1 (`scalar_rgb`, `sensor.sample_ray(0, 0.5, (u, v), (0.5, 0.5))`)
    /// for `to_world` = look_at((1,2,3), (−2,0.5,1), (0.3,1,0.2)) · scale(2, 3, 1), a 30×20 film,
    /// near_clip 0.5 and far_clip 40, at the normalised film positions below.
    #[test]
    fn matches_mitsuba() {
        let la = look_at(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(-2.0, 0.5, 1.0),
            Vec3::new(0.3, 1.0, 0.2),
        );
        let m = la * Mat4::from_scale(Vec3::new(2.0, 3.0, 1.0));
        let cam = Orthographic::new(m, 0.5, 40.0, (30, 20)).unwrap();
        let cases: [((f32, f32), [f32; 3]); 4] = MITSUBA_ORTHO;
        let d = Vec3::from_array(MITSUBA_ORTHO_DIR);
        for ((u, v), o) in cases {
            let r = cam.generate_ray(Vec2::new(u * 30.0, v * 20.0));
            let o = Vec3::from_array(o);
            assert!(
                (r.o - o).abs().max_element() < 2e-5,
                "{u},{v}: {:?} vs {o:?}",
                r.o
            );
            assert!((r.d - d).abs().max_element() < 1e-6);
            assert!((r.tmax - 39.5).abs() < 1e-5 && r.tmin == 0.0);
        }
    }

    const MITSUBA_ORTHO_DIR: [f32; 3] =
        [-0.768221378326416, -0.384110689163208, -0.5121475458145142];
    const MITSUBA_ORTHO: [((f32, f32), [f32; 3]); 4] = [
        (
            (0.5, 0.5),
            [0.6158891320228577, 1.807944893836975, 2.743926525115967],
        ),
        (
            (0.0, 0.0),
            [-1.1327095031738281, 3.6545186042785645, 3.9818947315216064],
        ),
        (
            (1.0, 0.25),
            [1.4056899547576904, 2.731231927871704, 0.8667598962783813],
        ),
        (
            (0.1, 0.9),
            [0.23972797393798828, 0.3306862413883209, 4.416111946105957],
        ),
    ];

    /// All rays are parallel, and the film's corners land on the scaled [−1,1] × [−1/a, 1/a]
    /// rectangle of the near plane.
    #[test]
    fn parallel_rays_and_extent() {
        let m = Mat4::from_translation(Vec3::new(0.5, -1.0, 2.0))
            * Mat4::from_rotation_y(0.3)
            * Mat4::from_scale(Vec3::new(4.0, 4.0, 2.0));
        let cam = Orthographic::new(m, 0.25, 10.0, (64, 32)).unwrap();
        let local = |p: Vec3| m.inverse().transform_point3(p);
        let d0 = cam.generate_ray(Vec2::ZERO).d;
        assert!((d0.length() - 1.0).abs() < 1e-6);
        assert!((d0 - m.transform_vector3(Vec3::Z).normalize()).length() < 1e-6);
        for (p, e) in [
            (Vec2::new(0.0, 0.0), Vec3::new(1.0, 0.5, 0.25)),
            (Vec2::new(64.0, 0.0), Vec3::new(-1.0, 0.5, 0.25)),
            (Vec2::new(0.0, 32.0), Vec3::new(1.0, -0.5, 0.25)),
            (Vec2::new(64.0, 32.0), Vec3::new(-1.0, -0.5, 0.25)),
            (Vec2::new(32.0, 16.0), Vec3::new(0.0, 0.0, 0.25)),
            (Vec2::new(16.0, 24.0), Vec3::new(0.5, -0.25, 0.25)),
        ] {
            let r = cam.generate_ray(p);
            assert!((local(r.o) - e).length() < 1e-5, "{p}: {}", local(r.o));
            assert_eq!(r.d, d0);
            // tmax is measured along the unit world direction: far − near.
            assert!((r.tmax - 9.75).abs() < 1e-6);
        }
    }

    #[test]
    fn rejects_bad_parameters() {
        let id = Mat4::IDENTITY;
        assert!(Orthographic::new(id, 0.0, 1.0, (8, 8)).is_err());
        assert!(Orthographic::new(id, 1.0, 1.0, (8, 8)).is_err());
        assert!(Orthographic::new(id, 0.1, f32::INFINITY, (8, 8)).is_err());
        assert!(Orthographic::new(id, 0.1, 1.0, (8, 0)).is_err());
        assert!(
            Orthographic::new(Mat4::from_scale(Vec3::new(1.0, 1.0, 0.0)), 0.1, 1.0, (8, 8))
                .is_err()
        );
        let mut nan = id;
        nan.w_axis.y = f32::NAN;
        assert!(Orthographic::new(nan, 0.1, 1.0, (8, 8)).is_err());
        assert!(Orthographic::new(Mat4::from_scale(Vec3::splat(3.0)), 0.1, 1.0, (8, 8)).is_ok());
    }
}
