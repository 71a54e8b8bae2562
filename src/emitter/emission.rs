//! Emission sampling for light tracing (`ptracer`): a ray leaving an emitter with the weight
//! `Le · cos / (pdf_position · pdf_direction)`, and, for the emitters a camera can see, a point
//! on them (area lights) or a direction (environments) to connect to the sensor directly.
//!
//! The strategies are chosen for being unbiased and cheap, not to reproduce Mitsuba 3's random
//! numbers (an image's expectation is the same, its noise is not):
//! - `area`: a point by area (the shape's `sample_position`), a cosine-weighted direction about
//!   its emitting normal (Mitsuba's `area::sample_ray` does the same).
//! - `point`, `projector`: a uniform direction on the sphere, weighted by the radiant intensity
//!   the light's own next-event routine reports for it (intensity = value · distance²).
//! - `spot`: a uniform direction in its cone when its transform is rigid (the cone is then the
//!   same in world space), else uniform on the sphere.
//! - `directional`, `constant`, `envmap`: a direction (the light's own, uniform, or the
//!   environment's importance sampling), then a point on the disk of the scene's bounding
//!   sphere's radius R facing it, R beyond the centre: weight `Le · πR² / pdf(direction)`
//!   (every ray that can reach the scene crosses that disk).

use super::{DirectSample, Emitter};
use crate::geometry::ray::offset_origin;
use crate::geometry::{Ray, Shape};
use crate::math::{warp, Frame, PI};
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3};

/// A ray leaving an emitter and what it carries: `Le · cos / pdf` (the emitter's selection
/// probability not included).
#[derive(Clone, Copy, Debug)]
pub struct EmissionRay {
    pub ray: Ray,
    pub weight: Spectrum,
}

/// A point of an emitter the camera may see directly, for the connection of a light path of
/// length zero (Mitsuba's `sample_visible_emitters`).
#[derive(Clone, Copy, Debug)]
pub enum VisiblePoint {
    /// A point on an area light: position, emitting (shading) normal `n` (unit; the side
    /// test, as `AreaLight::eval`), geometric normal `ng` (unit; the area-to-solid-angle
    /// cosine), `Le / pdf_area`.
    Surface {
        p: Vec3,
        n: Vec3,
        ng: Vec3,
        weight: Spectrum,
    },
    /// A direction toward an environment (unit, from the scene toward the light) and
    /// `Le / pdf_solid_angle`.
    Environment { d: Vec3, weight: Spectrum },
}

impl Emitter {
    /// A ray leaving this emitter from position sample `u_pos` and direction sample `u_dir`;
    /// `bsphere` is the scene's bounding sphere (centre, radius). `None` when the sample carries
    /// nothing.
    pub fn sample_ray(
        &self,
        shapes: &[Shape],
        bsphere: (Vec3, f32),
        u_pos: Vec2,
        u_dir: Vec2,
    ) -> Option<EmissionRay> {
        let (ray, weight) = match self {
            Emitter::Area(a) => {
                let shape = &shapes[a.shape as usize];
                let ps = shape.sample_position(u_pos);
                if !(ps.pdf.is_finite() && ps.pdf > 0.0) {
                    return None;
                }
                // A cosine-weighted direction about the emitting (shading) normal, weighted
                // Le · cos / (pdf_area · cos/π) = Le · π / pdf_area: the flux `Le·cos θ_s dA dω`
                // of the shading normal, the convention of the path integrator's next-event
                // estimation (as Mitsuba's, it converts the area density to solid angle with the
                // sampled point's shading normal), so that the two integrators agree on what a
                // smooth-normal mesh light illuminates.
                let local = warp::square_to_cosine_hemisphere(u_dir);
                let d = Frame::from_normal(ps.n).to_world(local);
                let w = a.radiance.eval(ps.uv) * (PI / ps.pdf);
                (Ray::new(offset_origin(ps.p, ps.ng, d), d), w)
            }
            Emitter::Point(p) => {
                let d = warp::square_to_uniform_sphere(u_dir);
                (Ray::new(p.position, d), p.intensity * (4.0 * PI))
            }
            Emitter::Spot(s) => {
                let (d, pdf) = s.sample_emission_direction(u_dir);
                let i = intensity_toward(self, s.position, d)?;
                (Ray::new(s.position, d), i / pdf)
            }
            Emitter::Projector(p) => {
                let d = warp::square_to_uniform_sphere(u_dir);
                let i = intensity_toward(self, p.position(), d)?;
                (Ray::new(p.position(), d), i * (4.0 * PI))
            }
            Emitter::Directional(l) => {
                far_disk_ray(bsphere, -l.direction, 1.0, l.irradiance, u_pos)?
            }
            Emitter::Constant(c) => {
                let d = warp::square_to_uniform_sphere(u_dir);
                far_disk_ray(bsphere, d, warp::uniform_sphere_pdf(), c.radiance, u_pos)?
            }
            Emitter::EnvMap(m) => {
                let ds = m.sample_direct(bsphere.0, u_dir)?;
                far_disk_ray(bsphere, ds.d, ds.pdf, ds.value, u_pos)?
            }
        };
        if weight == Spectrum::ZERO || !crate::spectrum::is_finite(weight) {
            return None;
        }
        Some(EmissionRay { ray, weight })
    }

    /// A point (area lights) or direction (environments, sampled from `ref_p`, the sensor's
    /// position) a camera may see; `None` for delta lights, which no camera sees.
    pub fn sample_visible(&self, shapes: &[Shape], ref_p: Vec3, u: Vec2) -> Option<VisiblePoint> {
        match self {
            Emitter::Area(a) => {
                let ps = shapes[a.shape as usize].sample_position(u);
                if !(ps.pdf.is_finite() && ps.pdf > 0.0) {
                    return None;
                }
                Some(VisiblePoint::Surface {
                    p: ps.p,
                    n: ps.n,
                    ng: ps.ng,
                    weight: a.radiance.eval(ps.uv) / ps.pdf,
                })
            }
            Emitter::Constant(_) | Emitter::EnvMap(_) => {
                let ds = self.sample_direct(shapes, ref_p, u)?;
                if !(ds.pdf.is_finite() && ds.pdf > 0.0) || ds.value == Spectrum::ZERO {
                    return None;
                }
                Some(VisiblePoint::Environment {
                    d: ds.d,
                    weight: ds.value / ds.pdf,
                })
            }
            Emitter::Point(_)
            | Emitter::Spot(_)
            | Emitter::Projector(_)
            | Emitter::Directional(_) => None,
        }
    }
}

/// Radiant intensity of a point-like light at `position` in the world direction `d` (unit):
/// its next-event value seen from a point along `d`, times the squared distance (the value is
/// intensity / distance²). The distance is scaled to the position's magnitude so that the
/// direction survives rounding.
fn intensity_toward(e: &Emitter, position: Vec3, d: Vec3) -> Option<Spectrum> {
    let s = position.abs().max_element().max(1.0);
    let ds: DirectSample = e.sample_direct(&[], position + d * s, Vec2::ZERO)?;
    // The sample must be of the direction asked for (ds.d points back toward the light).
    if ds.d.dot(-d) < 0.999 {
        return None;
    }
    Some(ds.value * (ds.dist * ds.dist))
}

/// A ray from the disk of radius R facing direction `toward` (unit, from the scene to the
/// light), R beyond the bounding sphere's centre, travelling along `-toward`; weight
/// `value · πR² / pdf`.
fn far_disk_ray(
    (centre, radius): (Vec3, f32),
    toward: Vec3,
    pdf: f32,
    value: Spectrum,
    u: Vec2,
) -> Option<(Ray, Spectrum)> {
    if !(pdf.is_finite() && pdf > 0.0) {
        return None;
    }
    let r = if radius.is_finite() && radius > 0.0 {
        radius
    } else {
        1.0
    };
    let frame = Frame::from_normal(toward);
    let disk = warp::square_to_disk_concentric(u) * r;
    let o = centre + toward * r + frame.s * disk.x + frame.t * disk.y;
    Some((Ray::new(o, -toward), value * (PI * r * r / pdf)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emitter::area::AreaLight;
    use crate::geometry::mesh::TriMesh;
    use crate::texture::Texture;

    /// A unit-radiance right triangle in z = 0 (geometric normal +z, area 1/2) whose vertex
    /// normals all lean `alpha` toward +x: a smooth-normal mesh light whose shading and
    /// geometric normals disagree everywhere.
    fn tilted_triangle_light(alpha: f32) -> (Vec<Shape>, Emitter) {
        let ns = Vec3::new(alpha.sin(), 0.0, alpha.cos());
        let mesh = TriMesh {
            positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y],
            normals: Some(vec![ns; 3]),
            uvs: None,
            indices: vec![[0, 1, 2]],
        };
        let shape = Shape::from_mesh(mesh, false, false).expect("mesh");
        let light = Emitter::Area(AreaLight {
            shape: 0,
            radiance: Texture::Constant(Spectrum::ONE),
        });
        (vec![shape], light)
    }

    /// The point a camera may see carries the geometric normal of its triangle next to the
    /// shading normal (the side test), so the connection's cosine is the area element's.
    #[test]
    fn visible_points_of_a_smooth_normal_mesh_light_carry_the_face_normal() {
        let (shapes, light) = tilted_triangle_light(60f32.to_radians());
        let Some(VisiblePoint::Surface { n, ng, .. }) =
            light.sample_visible(&shapes, Vec3::new(0.2, 0.2, 3.0), Vec2::new(0.4, 0.7))
        else {
            panic!("no visible point");
        };
        assert!((ng - Vec3::Z).length() < 1e-6, "ng = {ng}");
        assert!((n.dot(Vec3::Z) - 0.5).abs() < 1e-5, "n = {n}");
    }
}
