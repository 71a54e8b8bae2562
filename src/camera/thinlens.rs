//! Mitsuba 3's `thinlens` sensor (`src/sensors/thinlens.cpp`): a perspective camera whose rays
//! leave a disk-shaped aperture and meet on the plane of focus, which gives depth of field.
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | `aperture_radius` | float | (required) | lens radius in camera-local units; 0 is replaced by 2⁻²⁴ (Mitsuba warns and does the same) |
//! | `focus_distance` | float | far_clip | distance along the local z axis of the plane in focus; must be positive |
//! | `fov`, `fov_axis` / `focal_length` | | `50mm` | as `perspective` |
//! | `to_world` | transform | identity | camera to world; no scale factors (a mirror passes) |
//! | `near_clip`, `far_clip` | float | 0.01, 10⁴ | clip planes, measured along the local z axis |
//! | `shutter_open`, `shutter_close` | float | 0, 0 | read; groove renders the instant `shutter_open` |
//!
//! Ray through film position p with lens sample ξ: the pinhole direction of p is scaled to the
//! point f on the plane z = focus_distance, the lens point is a = r · concentric_disk(ξ) on z = 0,
//! and the ray goes from a toward f. With the origin at a, `tmin`..`tmax` = near_clip/d_z ..
//! far_clip/d_z for the unit local direction d (Mitsuba moves the origin to the near plane
//! instead; the segment is the same).

use super::perspective::{fov_from_props, FovAxis, Perspective};
use crate::error::{Error, Result};
use crate::geometry::Ray;
use crate::math::{warp, Mat4, Vec2, Vec3};
use crate::scene::xml::props::Props;

/// The radius Mitsuba substitutes for `aperture_radius = 0` (`dr::Epsilon<float>`).
const MIN_APERTURE: f32 = 1.0 / 16_777_216.0;

/// A thin lens camera.
#[derive(Clone, Debug)]
pub struct ThinLens {
    /// The film-to-direction projection, transform and clip planes (shared with `perspective`).
    pinhole: Perspective,
    aperture_radius: f32,
    focus_distance: f32,
}

impl ThinLens {
    /// A thin lens with the field of view, transform and clip rules of
    /// [`Perspective::new`], plus the lens: `aperture_radius` must be finite (0 becomes 2⁻²⁴),
    /// `focus_distance` finite and positive. Errors are [`Error::Usage`] without a location.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        to_world: Mat4,
        fov_deg: f32,
        fov_axis: FovAxis,
        near_clip: f32,
        far_clip: f32,
        aperture_radius: f32,
        focus_distance: f32,
        film_size: (u32, u32),
    ) -> Result<ThinLens> {
        let pinhole = Perspective::projective(
            "thinlens",
            to_world,
            fov_deg,
            fov_axis,
            (near_clip, far_clip),
            film_size,
        )?;
        if !aperture_radius.is_finite() {
            return Err(Error::Usage(format!(
                "thinlens: aperture_radius must be finite, got {aperture_radius}"
            )));
        }
        if !(focus_distance.is_finite() && focus_distance > 0.0) {
            return Err(Error::Usage(format!(
                "thinlens: focus_distance must be positive, got {focus_distance}"
            )));
        }
        // A negative radius mirrors the disk: the same lens (Mitsuba accepts it too).
        let aperture_radius = if aperture_radius == 0.0 {
            MIN_APERTURE
        } else {
            aperture_radius
        };
        Ok(ThinLens {
            pinhole,
            aperture_radius,
            focus_distance,
        })
    }

    /// The `thinlens` sensor element's camera parameters (the loader handles its film and
    /// sampler); errors name the element's position.
    pub fn from_props(p: &Props<'_>, film_size: (u32, u32)) -> Result<ThinLens> {
        let to_world = p.transform("to_world")?;
        let (fov, axis) = fov_from_props(p)?;
        let (near, far) = super::clip_from_props(p)?;
        let aperture = p.float_opt("aperture_radius")?.ok_or_else(|| {
            Error::scene(
                p.loc(),
                "thinlens needs an 'aperture_radius' (the lens radius)",
            )
        })?;
        let focus = p.float("focus_distance", far)?;
        super::shutter_from_props(p)?;
        ThinLens::new(to_world, fov, axis, near, far, aperture, focus, film_size)
            .map_err(|e| Error::scene(p.loc(), e.to_string()))
    }

    /// The lens radius in use (2⁻²⁴ for a given 0).
    pub fn aperture_radius(&self) -> f32 {
        self.aperture_radius
    }

    /// The ray through `film_pos` (full-film continuous pixel coordinates) and the lens point
    /// that `aperture` ∈ [0,1)² maps to (Shirley–Chiu concentric disk, as Mitsuba).
    #[inline]
    pub fn generate_ray(&self, film_pos: Vec2, aperture: Vec2) -> Ray {
        // The pinhole direction has z = 1, so scaling it by the focus distance lands on the
        // plane of focus.
        let focus_p = self.pinhole.local_dir(film_pos) * self.focus_distance;
        let a = warp::square_to_disk_concentric(aperture) * self.aperture_radius;
        let lens_p = Vec3::new(a.x, a.y, 0.0);
        let d = (focus_p - lens_p).normalize();
        let inv_z = 1.0 / d.z;
        let m = self.pinhole.to_world();
        let (near, far) = self.pinhole.clip();
        Ray {
            o: m.transform_point3(lens_p),
            d: m.transform_vector3(d).normalize(),
            tmin: near * inv_z,
            tmax: far * inv_z,
        }
    }
}

impl ThinLens {
    /// The lens centre in world space.
    pub fn position(&self) -> Vec3 {
        self.pinhole.position()
    }

    /// The world point `p_world`'s connection to the lens point that `aperture` ∈ [0,1)² maps
    /// to (Mitsuba 3 `thinlens`'s `sample_direction`): the direction from the lens point to the
    /// scene point meets the plane of focus at a point whose pinhole projection is the film
    /// position; the weight is 1 / (A · cos³θ · dist²) with A the crop window's area on the
    /// plane z = 1 (the lens density cancels against the lens area of the importance).
    /// `None` outside the near..far range (local z) or outside the crop window.
    pub fn sample_direction(
        &self,
        p_world: Vec3,
        aperture: Vec2,
        crop: (u32, u32, u32, u32),
    ) -> Option<super::perspective::SensorSample> {
        let m = self.pinhole.to_world();
        let l = self.pinhole.to_local().transform_point3(p_world);
        let (near, far) = self.pinhole.clip();
        if !(l.z >= near && l.z <= far) {
            return None;
        }
        let a = warp::square_to_disk_concentric(aperture) * self.aperture_radius;
        let lens_p = Vec3::new(a.x, a.y, 0.0);
        let v = l - lens_p;
        let dist = v.length();
        let local_d = v / dist;
        let ct = local_d.z;
        if !crate::bsdf::is_positive(ct) {
            return None;
        }
        let focus_p = lens_p + local_d * (self.focus_distance / ct);
        let film_pos = self.pinhole.film_of_local(focus_p);
        if !Perspective::in_crop(film_pos, crop) {
            return None;
        }
        let weight = self.pinhole.importance_normalization(crop) / (ct * ct * ct * dist * dist);
        let p = m.transform_point3(lens_p);
        let d = (p - p_world) / dist;
        (weight.is_finite() && weight > 0.0).then_some(super::perspective::SensorSample {
            film_pos,
            p,
            d,
            dist,
            weight,
        })
    }
}

#[cfg(test)]
// Mitsuba's values are quoted as Python printed them.
#[allow(clippy::excessive_precision)]
mod tests {
    use super::*;
    use crate::camera::perspective::tests::look_at;

    fn la() -> Mat4 {
        look_at(
            Vec3::new(1.0, 2.0, 3.0),
            Vec3::new(-2.0, 0.5, 1.0),
            Vec3::new(0.3, 1.0, 0.2),
        )
    }

    /// Mitsuba 3.9.1 (`scalar_rgb`): `sensor.sample_ray(0, 0.5, uv, aperture)` of a thinlens with
    /// fov 35 (x), aperture_radius 0.2, focus_distance 4, near_clip 0.1, far_clip 50, 30×20 film,
    /// to_world = look_at((1,2,3), (−2,0.5,1), (0.3,1,0.2)): (aperture, uv, ray.o, ray.d, maxt),
    /// where Mitsuba's origin is already moved to the near plane.
    /// (aperture sample, film uv, ray.o, ray.d, maxt).
    type Row = ((f32, f32), (f32, f32), [f32; 3], [f32; 3], f32);
    const MITSUBA: [Row; 8] = [
        (
            (0.5, 0.5),
            (0.5, 0.5),
            [0.9231778383255005, 1.961588978767395, 2.9487853050231934],
            [
                -0.7682213187217712,
                -0.38411059975624084,
                -0.5121474862098694,
            ],
            49.900001525878906,
        ),
        (
            (0.5, 0.5),
            (0.0, 0.0),
            [0.8989703059196472, 1.9809963703155518, 2.970541000366211],
            [
                -0.9447407126426697,
                -0.1777053028345108,
                -0.2754739820957184,
            ],
            53.362606048583984,
        ),
        (
            (0.1, 0.8),
            (0.5, 0.5),
            [0.9674282670021057, 2.041609048843384, 2.822394371032715],
            [
                -0.7789446711540222,
                -0.4043053090572357,
                -0.4793562591075897,
            ],
            49.939903259277344,
        ),
        (
            (0.1, 0.8),
            (0.0, 0.0),
            [0.9432206749916077, 2.06101655960083, 2.8441500663757324],
            [
                -0.949871838092804,
                -0.19576281309127808,
                -0.24376292526721954,
            ],
            53.67040252685547,
        ),
        (
            (0.1, 0.8),
            (1.0, 0.25),
            [0.9815589189529419, 2.0513129234313965, 2.7939205169677734],
            [
                -0.6123510599136353,
                -0.2951049506664276,
                -0.7334434390068054,
            ],
            52.01138687133789,
        ),
        (
            (0.9, 0.3),
            (0.5, 0.5),
            [0.8623112440109253, 1.9064699411392212, 3.0814242362976074],
            [
                -0.7520131468772888,
                -0.3696819245815277,
                -0.5457211136817932,
            ],
            49.939903259277344,
        ),
        (
            (0.9, 0.3),
            (1.0, 0.25),
            [0.8764418959617615, 1.9161736965179443, 3.052950382232666],
            [
                -0.5728991031646729,
                -0.25579142570495605,
                -0.778689444065094,
            ],
            53.24544143676758,
        ),
        (
            (0.9, 0.3),
            (0.1, 0.9),
            [0.8536939024925232, 1.890944004058838, 3.105994701385498],
            [-0.810996413230896, -0.507834255695343, -0.2904980182647705],
            51.6099853515625,
        ),
    ];

    #[test]
    fn matches_mitsuba() {
        let cam = ThinLens::new(la(), 35.0, FovAxis::X, 0.1, 50.0, 0.2, 4.0, (30, 20)).unwrap();
        for (ap, uv, o, d, maxt) in MITSUBA {
            let r = cam.generate_ray(Vec2::new(uv.0 * 30.0, uv.1 * 20.0), Vec2::new(ap.0, ap.1));
            let (o, d) = (Vec3::from_array(o), Vec3::from_array(d));
            assert!(
                (r.d - d).abs().max_element() < 1e-5,
                "{ap:?} {uv:?}: {:?} vs {d:?}",
                r.d
            );
            let start = r.at(r.tmin);
            assert!(
                (start - o).abs().max_element() < 1e-5,
                "{ap:?} {uv:?}: {start:?} vs {o:?}"
            );
            assert!(((r.tmax - r.tmin) - maxt).abs() < 1e-3 * maxt.max(1.0));
        }
        // focal_length 28mm, aperture 0 (→ 2⁻²⁴), identity, 30×20, uv (0.1, 0.9), lens (0.3, 0.3).
        let (fov, axis) = (
            2.0 * (43.266615f32 / 56.0).atan().to_degrees(),
            FovAxis::Diagonal,
        );
        let cam = ThinLens::new(Mat4::IDENTITY, fov, axis, 0.01, 1e4, 0.0, 1e4, (30, 20)).unwrap();
        assert_eq!(cam.aperture_radius(), MIN_APERTURE);
        let r = cam.generate_ray(Vec2::new(3.0, 18.0), Vec2::new(0.3, 0.3));
        let d = Vec3::new(0.43746572732925415, -0.2916437089443207, 0.8506277799606323);
        assert!((r.d - d).abs().max_element() < 1e-5, "{:?}", r.d);
        let o = Vec3::new(
            0.005142840091139078,
            -0.003428586758673191,
            0.009999998845160007,
        );
        assert!((r.at(r.tmin) - o).abs().max_element() < 1e-6);
    }

    /// Every ray through one film position, whatever its lens point, passes through the same
    /// point of the plane of focus; rays of different lens points diverge elsewhere.
    #[test]
    fn rays_converge_on_the_focus_plane() {
        let m = la();
        let cam = ThinLens::new(m, 40.0, FovAxis::Y, 0.01, 100.0, 0.3, 2.5, (40, 30)).unwrap();
        let to_local = m.inverse();
        for film in [
            Vec2::new(20.0, 15.0),
            Vec2::new(3.5, 27.25),
            Vec2::new(39.0, 1.0),
        ] {
            let mut focus = None;
            let mut spread = 0.0f32;
            for ap in [
                (0.5, 0.5),
                (0.05, 0.1),
                (0.95, 0.4),
                (0.3, 0.99),
                (0.7, 0.02),
            ] {
                let r = cam.generate_ray(film, Vec2::new(ap.0, ap.1));
                let (o, d) = (
                    to_local.transform_point3(r.o),
                    to_local.transform_vector3(r.d),
                );
                assert!(o.z.abs() < 1e-6 && o.truncate().length() <= 0.3 + 1e-6);
                let f = o + d * ((2.5 - o.z) / d.z);
                let g = o + d * ((7.0 - o.z) / d.z);
                match focus {
                    None => focus = Some((f, g)),
                    Some((f0, g0)) => {
                        assert!((f - f0).length() < 2e-5, "{film}: {f} vs {f0}");
                        spread = spread.max((g - g0).length());
                    }
                }
            }
            assert!(
                spread > 0.1,
                "rays should diverge away from the focus plane"
            );
        }
    }

    /// With the aperture at its centre (or of zero radius), a thin lens is the pinhole camera:
    /// the same directions and clip range.
    #[test]
    fn zero_aperture_equals_perspective() {
        let m = la();
        let pin = Perspective::new(m, 50.0, FovAxis::Smaller, 0.05, 80.0, (32, 24)).unwrap();
        let lens0 =
            ThinLens::new(m, 50.0, FovAxis::Smaller, 0.05, 80.0, 0.0, 3.0, (32, 24)).unwrap();
        let lens =
            ThinLens::new(m, 50.0, FovAxis::Smaller, 0.05, 80.0, 0.5, 3.0, (32, 24)).unwrap();
        for film in [
            Vec2::new(16.0, 12.0),
            Vec2::new(0.0, 0.0),
            Vec2::new(31.5, 7.25),
        ] {
            let p = pin.generate_ray(film);
            for (cam, ap) in [(&lens0, Vec2::new(0.9, 0.1)), (&lens, Vec2::splat(0.5))] {
                let r = cam.generate_ray(film, ap);
                assert!((r.d - p.d).length() < 1e-6, "{film}: {} vs {}", r.d, p.d);
                assert!((r.o - p.o).length() < 1e-6);
                assert!((r.tmin - p.tmin).abs() < 1e-6 && (r.tmax - p.tmax).abs() < 1e-2);
            }
        }
    }

    #[test]
    fn rejects_bad_parameters() {
        let id = Mat4::IDENTITY;
        let t = |ap: f32, focus: f32, m: Mat4| {
            ThinLens::new(m, 40.0, FovAxis::X, 0.01, 100.0, ap, focus, (8, 8)).is_err()
        };
        assert!(t(f32::NAN, 1.0, id));
        assert!(t(0.1, 0.0, id));
        assert!(t(0.1, -1.0, id));
        assert!(t(0.1, f32::INFINITY, id));
        assert!(t(0.1, 1.0, Mat4::from_scale(Vec3::splat(2.0))));
        assert!(!t(-0.1, 1.0, id));
        let err = ThinLens::new(id, 190.0, FovAxis::X, 0.01, 100.0, 0.1, 1.0, (8, 8));
        assert!(err.unwrap_err().to_string().contains("thinlens"));
    }
}
