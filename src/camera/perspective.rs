//! The perspective camera (Mitsuba 3 `perspective` sensor): field of view and its axis, `to_world`,
//! near/far clip planes. Its projection (film position → direction on the z = 1 plane) is shared
//! with the thin lens camera ([`super::thinlens`]).
//!
//! Conventions (checked numerically against Mitsuba 3.9.1, see the tests): in camera-local space
//! the camera looks along +z, +y is up and +x points to the LEFT of the image, because Mitsuba's
//! look-at builds its columns as (left, up, dir). Film positions are continuous pixel coordinates of
//! the full film: (0,0) is the top-left corner, (width, height) the bottom-right one. A crop window
//! only restricts which positions the renderer asks for; it does not change the mapping.

use crate::error::{Error, Result};
use crate::geometry::Ray;
use crate::lane::vec::V3;
use crate::lane::Lane;
use crate::math::{Mat4, Vec2, Vec3};
use crate::scene::xml::props::Props;

/// Which film axis the `fov` parameter refers to (Mitsuba's `fov_axis`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FovAxis {
    X,
    Y,
    Diagonal,
    Smaller,
    Larger,
}

impl FovAxis {
    /// Parses Mitsuba's names (`x`, `y`, `diagonal`, `smaller`, `larger`; case-insensitive).
    pub fn parse(s: &str) -> Option<FovAxis> {
        match s.to_ascii_lowercase().as_str() {
            "x" => Some(FovAxis::X),
            "y" => Some(FovAxis::Y),
            "diagonal" => Some(FovAxis::Diagonal),
            "smaller" => Some(FovAxis::Smaller),
            "larger" => Some(FovAxis::Larger),
            _ => None,
        }
    }
}

/// The field of view of a Mitsuba perspective-type sensor (`perspective`, `thinlens`;
/// `sensor.cpp`'s `parse_fov`): either `fov` in degrees along `fov_axis` (default `x`), or a
/// 35 mm-equivalent `focal_length` such as `"50mm"` (the default), which sets the diagonal field
/// of view of a 36 × 24 mm frame. Giving both is an error, as in Mitsuba.
pub(crate) fn fov_from_props(p: &Props<'_>) -> Result<(f32, FovAxis)> {
    match (p.float_opt("fov")?, p.string_opt("focal_length")?) {
        (Some(_), Some(_)) => Err(Error::scene(
            p.loc(),
            "give either fov or focal_length, not both",
        )),
        (Some(f), None) => {
            let axis_s = p.string("fov_axis", "x")?;
            let axis = FovAxis::parse(&axis_s).ok_or_else(|| {
                Error::scene(
                    p.loc(),
                    format!("fov_axis '{axis_s}' must be one of x, y, diagonal, smaller, larger"),
                )
            })?;
            Ok((f, axis))
        }
        (None, fl) => {
            let s = fl.unwrap_or_else(|| "50mm".to_string());
            let mm: f32 = s
                .trim()
                .trim_end_matches("mm")
                .trim()
                .parse()
                .map_err(|_| {
                    Error::scene(p.loc(), format!("focal_length '{s}' must look like '50mm'"))
                })?;
            if !(mm > 0.0 && mm.is_finite()) {
                return Err(Error::scene(p.loc(), "focal_length must be positive"));
            }
            let diag = (36.0f32 * 36.0 + 24.0 * 24.0).sqrt();
            Ok((
                2.0 * (diag / (2.0 * mm)).atan().to_degrees(),
                FovAxis::Diagonal,
            ))
        }
    }
}

/// tan of half the horizontal field of view for `fov_deg` along `axis` on an image of
/// width / height `aspect` (Mitsuba's sensor.cpp `parse_fov`, in f64). Shared by the
/// perspective-type sensors and the `projector` light.
pub(crate) fn tan_half_x_fov(fov_deg: f32, axis: FovAxis, aspect: f64) -> f64 {
    let t = (0.5 * (fov_deg as f64).to_radians()).tan();
    let axis = match axis {
        FovAxis::Smaller if aspect > 1.0 => FovAxis::Y,
        FovAxis::Smaller => FovAxis::X,
        FovAxis::Larger if aspect > 1.0 => FovAxis::X,
        FovAxis::Larger => FovAxis::Y,
        a => a,
    };
    match axis {
        FovAxis::Y => t * aspect,
        FovAxis::Diagonal => t * aspect / (1.0 + aspect * aspect).sqrt(),
        _ => t,
    }
}

/// A pinhole perspective camera.
#[derive(Clone, Debug)]
pub struct Perspective {
    to_world: Mat4,
    to_local: Mat4,
    /// tan of half the horizontal field of view.
    tan_half_x: f32,
    /// Film width / height.
    aspect: f32,
    near_clip: f32,
    far_clip: f32,
    film_w: f32,
    film_h: f32,
    /// Ray generation's per-axis scales: x = (1 − 2u)·tan, y = (1 − 2v)·tan / aspect, with
    /// u = film x / width (reciprocals precomputed; camera rays are a hot path).
    scale_x: f32,
    scale_y: f32,
    /// tan of half the vertical field of view (tan_half_x / aspect).
    tan_half_y: f32,
}

impl Perspective {
    /// Mitsuba 3 `perspective`: the camera looks along +z of `to_world`'s local space, +y up, local
    /// +x is LEFT in the image (Mitsuba's look-at builds columns (left, up, dir)). `film_size` is the
    /// full film (width, height), not the crop.
    ///
    /// Like Mitsuba, rejects a field of view outside (0, 180) degrees, `near_clip <= 0`,
    /// `far_clip <= near_clip` and a `to_world` with scale factors (a mirror such as
    /// `<scale x="-1"/>` is no scale and is accepted). Errors are [`Error::Usage`] without a
    /// location; the caller adds the XML position.
    pub fn new(
        to_world: Mat4,
        fov_deg: f32,
        fov_axis: FovAxis,
        near_clip: f32,
        far_clip: f32,
        film_size: (u32, u32),
    ) -> Result<Perspective> {
        Perspective::projective(
            "perspective",
            to_world,
            fov_deg,
            fov_axis,
            (near_clip, far_clip),
            film_size,
        )
    }

    /// The checks and projection of [`Perspective::new`] for the sensor `name` (`perspective`,
    /// `thinlens`: both are Mitsuba `ProjectiveCamera`s with the same field-of-view rules).
    pub(super) fn projective(
        name: &str,
        to_world: Mat4,
        fov_deg: f32,
        fov_axis: FovAxis,
        (near_clip, far_clip): (f32, f32),
        film_size: (u32, u32),
    ) -> Result<Perspective> {
        let (w, h) = film_size;
        if w == 0 || h == 0 {
            return Err(Error::Usage(format!(
                "{name}: film size must be positive, got {w}x{h}"
            )));
        }
        if !(fov_deg.is_finite() && fov_deg > 0.0 && fov_deg < 180.0) {
            return Err(Error::Usage(format!(
                "{name}: fov must be in (0, 180) degrees, got {fov_deg}"
            )));
        }
        if !(near_clip.is_finite() && near_clip > 0.0) {
            return Err(Error::Usage(format!(
                "{name}: near_clip must be greater than zero, got {near_clip}"
            )));
        }
        if !(far_clip.is_finite() && far_clip > near_clip) {
            return Err(Error::Usage(format!(
                "{name}: far_clip ({far_clip}) must be greater than near_clip ({near_clip})"
            )));
        }
        if !to_world.is_finite() {
            return Err(Error::Usage(format!(
                "{name}: to_world contains non-finite values"
            )));
        }
        // Mitsuba (perspective.cpp) refuses scale factors in the camera transform; the columns
        // of the linear part must be unit length. Rotations and mirrors pass.
        for (i, c) in [to_world.x_axis, to_world.y_axis, to_world.z_axis]
            .iter()
            .enumerate()
        {
            let n2 = c.truncate().length_squared();
            if (n2 - 1.0).abs() > 1e-3 {
                return Err(Error::Usage(format!(
                    "{name}: scale factors in the camera to_world are not allowed \
                     (column {i} has length {})",
                    n2.sqrt()
                )));
            }
        }
        let det = to_world.determinant();
        if !det.is_finite() || det.abs() < 1e-6 {
            return Err(Error::Usage(format!("{name}: to_world is not invertible")));
        }
        let to_local = to_world.inverse();

        let aspect = w as f64 / h as f64;
        let tan_half_x = tan_half_x_fov(fov_deg, fov_axis, aspect);
        let x_fov = 2.0 * tan_half_x.atan().to_degrees();
        if !(x_fov > 0.0 && x_fov < 180.0) {
            return Err(Error::Usage(format!(
                "{name}: the horizontal field of view must be in (0, 180) degrees, got {x_fov}"
            )));
        }
        Ok(Perspective {
            to_world,
            to_local,
            tan_half_x: tan_half_x as f32,
            aspect: aspect as f32,
            near_clip,
            far_clip,
            film_w: w as f32,
            film_h: h as f32,
            scale_x: (2.0 * tan_half_x / w as f64) as f32,
            scale_y: (2.0 * tan_half_x / aspect / h as f64) as f32,
            tan_half_y: (tan_half_x / aspect) as f32,
        })
    }

    /// Horizontal field of view in degrees (after resolving `fov_axis`).
    pub fn x_fov_deg(&self) -> f32 {
        2.0 * self.tan_half_x.atan().to_degrees()
    }

    /// The camera-to-world transform.
    pub fn to_world(&self) -> &Mat4 {
        &self.to_world
    }

    /// The world-to-camera transform (the inverse of [`Perspective::to_world`]).
    pub(super) fn to_local(&self) -> &Mat4 {
        &self.to_local
    }

    /// The near and far clip distances.
    pub fn clip(&self) -> (f32, f32) {
        (self.near_clip, self.far_clip)
    }

    /// Camera position in world space.
    pub fn position(&self) -> Vec3 {
        self.to_world.w_axis.truncate()
    }

    /// The camera-local, not normalised direction through a film position, with z = 1.
    #[inline]
    pub(super) fn local_dir(&self, film_pos: Vec2) -> Vec3 {
        // Normalised film coordinates u, v in [0,1]²; Mitsuba's perspective_projection maps them
        // to the z = 1 plane as x = (1 - 2u)·tan, y = (1 - 2v)·tan / aspect.
        Vec3::new(
            self.tan_half_x - film_pos.x * self.scale_x,
            self.tan_half_y - film_pos.y * self.scale_y,
            1.0,
        )
    }

    /// `film_pos` in continuous pixel coordinates of the full film: (0,0) top-left corner, (w,h)
    /// bottom-right. Returns a ray with a unit direction and its origin at the camera; `tmin` and
    /// `tmax` span exactly the near..far clip planes as Mitsuba does (clip distances divided by the
    /// z of the unit local direction; Mitsuba moves the origin to the near plane instead).
    pub fn generate_ray(&self, film_pos: Vec2) -> Ray {
        let l = self.local_dir(film_pos);
        // z of the unit local direction is 1/|l|.
        let inv_z = l.length();
        let d = self.to_world.transform_vector3(l).normalize();
        Ray {
            o: self.position(),
            d,
            tmin: self.near_clip * inv_z,
            tmax: self.far_clip * inv_z,
        }
    }

    /// [`Self::generate_ray`] for `L::WIDTH` film positions (`x`, `y`) at once (the stream
    /// renderer's camera rays, 8 samples at a time): the unit direction, `tmin` and `tmax`; the
    /// origin is [`Self::position`]. The same operations in the same order as the scalar code
    /// (glam's `transform_vector3` is `(x_axis·x + y_axis·y) + z_axis·z`, its `normalize`
    /// `v · (1/|v|)`), so every lane equals it bit for bit (tested below).
    #[inline(always)]
    pub(crate) fn ray_lanes<L: Lane>(&self, x: L, y: L) -> (V3<L>, L, L) {
        let k = |c: f32| x.splat(c);
        let l = V3::new(
            k(self.tan_half_x) - x * k(self.scale_x),
            k(self.tan_half_y) - y * k(self.scale_y),
            k(1.0),
        );
        let inv_z = l.length();
        let col = |v: glam::Vec4| V3::splat(x, v.x, v.y, v.z);
        let m = &self.to_world;
        let w = col(m.x_axis).scale(l.x) + col(m.y_axis).scale(l.y) + col(m.z_axis).scale(l.z);
        (
            w.normalize(),
            k(self.near_clip) * inv_z,
            k(self.far_clip) * inv_z,
        )
    }

    /// The film position (full-film continuous pixel coordinates) that a world direction leaving
    /// the camera lands on, or `None` if it points backwards or outside the film.
    pub fn film_position(&self, dir_world: Vec3) -> Option<Vec2> {
        let d = self.to_local.transform_vector3(dir_world);
        if !d.is_finite() || d.z <= 0.0 {
            return None;
        }
        let x = d.x / d.z;
        let y = d.y / d.z;
        let u = 0.5 - 0.5 * x / self.tan_half_x;
        let v = 0.5 - 0.5 * y * self.aspect / self.tan_half_x;
        let p = Vec2::new(u * self.film_w, v * self.film_h);
        if p.x >= 0.0 && p.x <= self.film_w && p.y >= 0.0 && p.y <= self.film_h {
            Some(p)
        } else {
            None
        }
    }
}

/// The sensor's side of a connection from a scene point (light tracing): where on the film the
/// point appears and the importance it receives (Mitsuba 3's `Sensor::sample_direction`).
#[derive(Clone, Copy, Debug)]
pub struct SensorSample {
    /// Full-film continuous pixel position the point projects to (inside the crop window).
    pub film_pos: Vec2,
    /// The lens point (the camera position for a pinhole), world space.
    pub p: Vec3,
    /// Unit direction from the scene point toward `p`, and the distance.
    pub d: Vec3,
    pub dist: f32,
    /// Importance times the geometry term of the lens side, already divided by the lens
    /// sample's density: `W / dist²` with W = 1 / (A · cos³θ) (Mitsuba's `importance`), A the
    /// crop window's area on the plane at unit distance. The scene point's cosine is the
    /// caller's (in its BSDF value).
    pub weight: f32,
}

impl Perspective {
    /// The film position of the camera-local point `l` projected through the pinhole (its
    /// plane z = 1 coordinates x/z, y/z), as the inverse of [`Perspective::local_dir`].
    #[inline]
    pub(super) fn film_of_local(&self, l: Vec3) -> Vec2 {
        let x = l.x / l.z;
        let y = l.y / l.z;
        Vec2::new(
            (0.5 - 0.5 * x / self.tan_half_x) * self.film_w,
            (0.5 - 0.5 * y / self.tan_half_y) * self.film_h,
        )
    }

    /// 1 / A: the reciprocal area, on the plane z = 1, of the crop window `crop` (full-film
    /// pixels x0, y0, w, h): Mitsuba's `m_normalization` for the sensor's image rectangle.
    #[inline]
    pub(super) fn importance_normalization(&self, crop: (u32, u32, u32, u32)) -> f32 {
        let a = (2.0 * self.tan_half_x)
            * (2.0 * self.tan_half_y)
            * (crop.2 as f32 / self.film_w)
            * (crop.3 as f32 / self.film_h);
        1.0 / a
    }

    /// True when the full-film position lies in the crop window (edges included, as Mitsuba's
    /// test `0 ≤ uv ≤ 1` of the crop's screen coordinates).
    #[inline]
    pub(super) fn in_crop(pos: Vec2, crop: (u32, u32, u32, u32)) -> bool {
        let (x0, y0, w, h) = (crop.0 as f32, crop.1 as f32, crop.2 as f32, crop.3 as f32);
        pos.x >= x0 && pos.x <= x0 + w && pos.y >= y0 && pos.y <= y0 + h
    }

    /// The world point `p_world`'s connection to the pinhole (Mitsuba 3 `perspective`'s
    /// `sample_direction` and `importance`): `None` outside the near..far range (measured along
    /// the local z axis, as Mitsuba does) or outside the crop window.
    pub fn sample_direction(
        &self,
        p_world: Vec3,
        crop: (u32, u32, u32, u32),
    ) -> Option<SensorSample> {
        let l = self.to_local.transform_point3(p_world);
        if !(l.z >= self.near_clip && l.z <= self.far_clip) {
            return None;
        }
        let film_pos = self.film_of_local(l);
        if !Self::in_crop(film_pos, crop) {
            return None;
        }
        let dist = l.length();
        let ct = l.z / dist;
        let weight = self.importance_normalization(crop) / (ct * ct * ct * dist * dist);
        let p = self.position();
        let d = (p - p_world) / dist;
        (weight.is_finite() && weight > 0.0).then_some(SensorSample {
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
pub(super) mod tests {
    use super::*;

    /// Mitsuba's look-at transform (shared by the other cameras' tests).
    pub(crate) fn look_at(origin: Vec3, target: Vec3, up: Vec3) -> Mat4 {
        // Mitsuba's look_at: columns (left, new_up, dir, origin).
        let dir = (target - origin).normalize();
        let left = up.normalize().cross(dir).normalize();
        let new_up = dir.cross(left);
        Mat4::from_cols(
            left.extend(0.0),
            new_up.extend(0.0),
            dir.extend(0.0),
            origin.extend(1.0),
        )
    }

    fn check(cam: &Perspective, w: u32, h: u32, uv: (f32, f32), expect: [f32; 3]) {
        let ray = cam.generate_ray(Vec2::new(uv.0 * w as f32, uv.1 * h as f32));
        let e = Vec3::from_array(expect);
        assert!(
            (ray.d - e).abs().max_element() < 1e-5,
            "uv {uv:?}: got {:?}, Mitsuba {e:?}",
            ray.d
        );
        // The inverse map lands where we started (film edges may round to just outside).
        if uv.0 > 0.0 && uv.0 < 1.0 && uv.1 > 0.0 && uv.1 < 1.0 {
            let p = cam.film_position(ray.d).expect("inside the film");
            assert!((p - Vec2::new(uv.0 * w as f32, uv.1 * h as f32)).length() < 1e-3);
        }
    }

    /// Directions from Mitsuba 3.9.1 (`scalar_rgb`, `sensor.sample_ray(0, 0.5, (u, v), (0.5, 0.5))`)
    /// for the normalised film positions (0.5,0.5), (0,0), (1,0.25), (0.1,0.9).
    const UVS: [(f32, f32); 4] = [(0.5, 0.5), (0.0, 0.0), (1.0, 0.25), (0.1, 0.9)];

    fn check_case(axis: FovAxis, fov: f32, w: u32, h: u32, to_world: Mat4, dirs: [[f32; 3]; 4]) {
        let cam = Perspective::new(to_world, fov, axis, 0.01, 10000.0, (w, h)).unwrap();
        for (uv, d) in UVS.iter().zip(dirs) {
            check(&cam, w, h, *uv, d);
        }
    }

    #[test]
    fn matches_mitsuba_fov_axes() {
        let id = Mat4::IDENTITY;
        check_case(
            FovAxis::X,
            40.0,
            64,
            48,
            id,
            [
                [0.0, 0.0, 1.0],
                [0.3312942087650299, 0.24847064912319183, 0.9102233648300171],
                [-0.3392412066459656, 0.12721547484397888, 0.932057797908783],
                [0.27361607551574707, -0.2052120566368103, 0.9396926164627075],
            ],
        );
        check_case(
            FovAxis::Y,
            40.0,
            64,
            48,
            id,
            [
                [0.0, 0.0, 1.0],
                [0.4149197041988373, 0.31118980050086975, 0.8549869060516357],
                [
                    -0.43086108565330505,
                    0.16157297790050507,
                    0.8878361582756042,
                ],
                [0.34927821159362793, -0.2619585692882538, 0.8996568918228149],
            ],
        );
        check_case(
            FovAxis::Smaller,
            50.0,
            64,
            48,
            id,
            [
                [0.0, 0.0, 1.0],
                [0.4909169375896454, 0.36818769574165344, 0.7895811200141907],
                [-0.517953097820282, 0.19423246383666992, 0.8330656886100769],
                [0.4224070608615875, -0.3168051838874817, 0.849238932132721],
            ],
        );
        check_case(
            FovAxis::Larger,
            50.0,
            48,
            64,
            id,
            [
                [0.0, 0.0, 1.0],
                [0.3021490275859833, 0.40286538004875183, 0.8639475703239441],
                [
                    -0.32240813970565796,
                    0.21493884921073914,
                    0.9218754172325134,
                ],
                [0.2535710036754608, -0.3380945324897766, 0.9063078165054321],
            ],
        );
        check_case(
            FovAxis::Diagonal,
            60.0,
            64,
            48,
            id,
            [
                [0.0, 0.0, 1.0],
                [0.3999999761581421, 0.29999998211860657, 0.866025447845459],
                [
                    -0.41422414779663086,
                    0.15533411502838135,
                    0.8968219757080078,
                ],
                [0.3354511260986328, -0.25158828496932983, 0.9078413248062134],
            ],
        );
    }

    #[test]
    fn matches_mitsuba_look_at_and_mirror() {
        let o = Vec3::new(1.0, 2.0, 3.0);
        let t = Vec3::new(-2.0, 0.5, 1.0);
        check_case(
            FovAxis::X,
            35.0,
            30,
            20,
            look_at(o, t, Vec3::new(0.3, 1.0, 0.2)),
            [
                [
                    -0.7682212591171265,
                    -0.38411059975624084,
                    -0.5121474862098694,
                ],
                [-0.9447406530380249, -0.177705317735672, -0.275473952293396],
                [
                    -0.5949180722236633,
                    -0.27242177724838257,
                    -0.756213366985321,
                ],
                [
                    -0.8176485300064087,
                    -0.5161725282669067,
                    -0.2549835741519928,
                ],
            ],
        );
        // <scale x="-1"/> applied after the look-at (world-space mirror).
        let mirror = Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
        let la = look_at(o, t, Vec3::Y);
        check_case(
            FovAxis::X,
            45.0,
            32,
            24,
            mirror * la,
            [
                [
                    0.7682213187217712,
                    -0.38411059975624084,
                    -0.5121474266052246,
                ],
                [
                    0.9744076132774353,
                    -0.08638913184404373,
                    -0.20752498507499695,
                ],
                [0.5378241539001465, -0.2201194316148758, -0.8138136267662048],
                [
                    0.8061804175376892,
                    -0.5668679475784302,
                    -0.16951096057891846,
                ],
            ],
        );
        // The mirror before the look-at flips the image horizontally (camera-space mirror).
        check_case(
            FovAxis::X,
            45.0,
            32,
            24,
            la * mirror,
            [
                [
                    -0.7682212591171265,
                    -0.38411059975624084,
                    -0.5121475458145142,
                ],
                [
                    -0.5663337111473083,
                    -0.08638913184404373,
                    -0.819635808467865,
                ],
                [
                    -0.9580680727958679,
                    -0.2201194316148758,
                    -0.18344779312610626,
                ],
                [
                    -0.4665410816669464,
                    -0.5668679475784302,
                    -0.6789699792861938,
                ],
            ],
        );
    }

    #[test]
    fn crop_window_uses_full_film_coordinates() {
        // Mitsuba, 8x8 film, fov 40, crop offset (2,4) size (4,2): the crop's top-left corner
        // (normalised crop position (0,0)) gives the same ray as full-film position (2,4).
        let cam =
            Perspective::new(Mat4::IDENTITY, 40.0, FovAxis::X, 0.01, 10000.0, (8, 8)).unwrap();
        let d = cam.generate_ray(Vec2::new(2.0, 4.0)).d;
        let e = Vec3::new(0.17904441058635712, 0.0, 0.9838410019874573);
        assert!((d - e).abs().max_element() < 1e-5, "{d:?}");
    }

    #[test]
    fn clip_range_matches_mitsuba() {
        // Mitsuba: maxt = far/z - near/z (origin moved to the near plane), for fov 40 x, 64x48.
        let cam =
            Perspective::new(Mat4::IDENTITY, 40.0, FovAxis::X, 0.01, 10000.0, (64, 48)).unwrap();
        let r = cam.generate_ray(Vec2::new(0.0, 0.0));
        assert!((r.tmin - 0.01 / 0.9102233648300171).abs() < 1e-7);
        assert!(((r.tmax - r.tmin) - 10986.302734375).abs() < 2e-3);
        assert!((r.d.length() - 1.0).abs() < 1e-6);
    }

    #[test]
    fn rejects_bad_parameters() {
        let id = Mat4::IDENTITY;
        let p = |m: Mat4, fov: f32, n: f32, f: f32| {
            Perspective::new(m, fov, FovAxis::X, n, f, (8, 8)).is_err()
        };
        assert!(p(id, 0.0, 0.01, 10.0));
        assert!(p(id, 180.0, 0.01, 10.0));
        assert!(p(id, f32::NAN, 0.01, 10.0));
        assert!(p(id, 40.0, 0.0, 10.0));
        assert!(p(id, 40.0, 5.0, 1.0));
        assert!(p(id, 40.0, 0.01, f32::INFINITY));
        assert!(p(Mat4::from_scale(Vec3::splat(2.0)), 40.0, 0.01, 10.0));
        let mut nan = id;
        nan.w_axis.x = f32::NAN;
        assert!(p(nan, 40.0, 0.01, 10.0));
        assert!(Perspective::new(id, 40.0, FovAxis::X, 0.01, 10.0, (0, 8)).is_err());
        assert!(!p(
            Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)),
            40.0,
            0.01,
            10.0
        ));
        // fov_axis y can push the horizontal fov past 180 degrees on a wide film.
        assert!(Perspective::new(id, 170.0, FovAxis::Y, 0.01, 10.0, (100, 10)).is_ok());
        assert_eq!(FovAxis::parse("Diagonal"), Some(FovAxis::Diagonal));
        assert_eq!(FovAxis::parse("z"), None);
    }

    #[test]
    fn film_position_rejects_outside_and_behind() {
        let cam =
            Perspective::new(Mat4::IDENTITY, 40.0, FovAxis::X, 0.01, 100.0, (64, 48)).unwrap();
        assert!(cam.film_position(Vec3::new(0.0, 0.0, -1.0)).is_none());
        assert!(cam.film_position(Vec3::new(5.0, 0.0, 1.0)).is_none());
        let c = cam.film_position(Vec3::Z).unwrap();
        assert!((c - Vec2::new(32.0, 24.0)).length() < 1e-4);
    }

    /// The lane form of ray generation equals `generate_ray` bit for bit, at width 1 and in
    /// every lane of width 8: random cameras (field of view, axis, aspect, look-at, a mirror)
    /// and random film positions, the film's edges and outside it included.
    #[test]
    fn lane_rays_equal_the_scalar_rays() {
        let mut r = crate::math::Pcg32::new(3, 11);
        let mut f = |a: f32, b: f32| a + (b - a) * r.next_f32();
        let same = |a: f32, b: f32| a.to_bits() == b.to_bits();
        let mut checked = 0;
        for c in 0..200 {
            let (w, h) = (1 + (f(0.0, 900.0) as u32), 1 + (f(0.0, 700.0) as u32));
            let o = Vec3::new(f(-5.0, 5.0), f(-5.0, 5.0), f(-5.0, 5.0));
            let t = Vec3::new(f(-5.0, 5.0), f(-5.0, 5.0), f(-5.0, 5.0));
            let mut m = look_at(o, t, Vec3::new(f(-0.3, 0.3), 1.0, f(-0.3, 0.3)));
            if c % 4 == 0 {
                m *= Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0));
            }
            let axis = [FovAxis::X, FovAxis::Y, FovAxis::Smaller, FovAxis::Larger][c % 4];
            let cam = Perspective::new(m, f(1.0, 170.0), axis, f(1e-3, 1.0), f(10.0, 1e5), (w, h))
                .unwrap();
            let pos: Vec<Vec2> = (0..64)
                .map(|k| match k {
                    0 => Vec2::ZERO,
                    1 => Vec2::new(w as f32, h as f32),
                    2 => Vec2::new(-3.0, h as f32 + 7.5),
                    _ => Vec2::new(f(0.0, w as f32), f(0.0, h as f32)),
                })
                .collect();
            for p in &pos {
                let s = cam.generate_ray(*p);
                let (d, t0, t1) = cam.ray_lanes(p.x, p.y);
                assert!(
                    same(d.x, s.d.x) && same(d.y, s.d.y) && same(d.z, s.d.z),
                    "{p}: {d:?} vs {}",
                    s.d
                );
                assert!(same(t0, s.tmin) && same(t1, s.tmax), "{p}");
                assert_eq!(cam.position(), s.o);
                checked += 1;
            }
            #[cfg(target_arch = "x86_64")]
            if let Some(avx) = crate::lane::Avx2::detect() {
                for p in pos.chunks_exact(8) {
                    let (d, t0, t1) = avx.run(|| {
                        let x = avx.load(&std::array::from_fn(|k| p[k].x));
                        let y = avx.load(&std::array::from_fn(|k| p[k].y));
                        cam.ray_lanes(x, y)
                    });
                    for (k, p) in p.iter().enumerate() {
                        let s = cam.generate_ray(*p);
                        assert!(
                            same(d.x.lane(k), s.d.x)
                                && same(d.y.lane(k), s.d.y)
                                && same(d.z.lane(k), s.d.z)
                                && same(t0.lane(k), s.tmin)
                                && same(t1.lane(k), s.tmax),
                            "{p} in lane {k}"
                        );
                    }
                }
            }
        }
        assert_eq!(checked, 200 * 64);
    }
}
