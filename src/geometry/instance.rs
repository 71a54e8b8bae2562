//! Mitsuba 3's `instance` shape (`src/shapes/instance.cpp`): a `shapegroup` (its loader is
//! `load/shapegroup.rs`) placed in the world by `to_world`. The group's shapes are stored and
//! built into an acceleration structure once; every instance traces them through its transform
//! (an Embree instance, `accel/embree.rs`).
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | (nested object) | `shapegroup` (nested, or a `<ref>` to one) | required | the group to place; exactly one, and nothing else |
//! | `to_world` | transform | identity | group space to world: any invertible affine map (non-uniform scale, shear and mirroring included) |
//!
//! Each member keeps its own BSDF (an instance cannot change it, as in Mitsuba). The surface seen
//! through an instance is the member's, computed in group space from the ray mapped by the inverse
//! of `to_world` (whose direction is not renormalised, so the ray parameter `t` is the world one),
//! then mapped back as Mitsuba 3.9.1's `Instance::compute_surface_interaction` does: the point by
//! `to_world`, the geometric and shading normals by its inverse transpose (renormalised), dp/du
//! and dp/dv by `to_world`. The shading frame is then rebuilt around the mapped shading normal
//! from the mapped dp/du, which is what a shape transformed and loaded directly gets. (Mitsuba
//! 3.9.1 rebuilds it from the *unmapped* dp/du, a slip its later versions fixed; the two differ
//! only in the tangent's direction, which only anisotropic BSDFs see.) A mirroring `to_world`
//! keeps each normal on the side the member's own normal was: the inverse transpose preserves it,
//! as in Mitsuba (a mesh mirrored by its own `to_world` instead follows its winding).
//!
//! After a `<rotate>` with a non-unit axis in the instance's `to_world`, Mitsuba's stored inverse
//! transpose is not the true one (`scene/xml/transform.rs`), and its instance uses it twice:
//! normals are mapped by it, and the member's interaction is computed for the ray mapped by its
//! transpose (`Transform::inverse()`), while Embree traces the true transform. groove does the
//! same ([`Instance::with_mitsuba_inverse`]): for mesh members only the normals change (their
//! points come from the barycentrics); analytic members are evaluated at the point of that ray.
//!
//! `scene_index` is the instance's number in Mitsuba's `scene.shapes()` (the `aov` integrator's
//! `shape_index` of every hit through it), set by the loader.

use super::interaction::SurfaceInteraction;
use super::Ray;
use crate::math::Frame;
use glam::{Mat3, Mat4, Vec3};

/// One placement of a shape group.
#[derive(Clone, Debug)]
pub struct Instance {
    /// Index of the group (in the scene's list of groups).
    group: u32,
    to_world: Mat4,
    to_object: Mat4,
    /// The inverse transpose of `to_world`'s linear part, which maps normals.
    normal: Mat3,
    /// Mitsuba 3.9.1's number of the instance in `scene.shapes()`, from 1 (0 until set).
    pub scene_index: u32,
}

impl Instance {
    /// Group `group` under `to_world`; an error (the reason) when `to_world` is not finite or
    /// not invertible.
    pub fn new(group: u32, to_world: &Mat4) -> Result<Instance, String> {
        Instance::with_mitsuba_inverse(group, to_world, None)
    }

    /// [`Instance::new`] with Mitsuba's stored inverse transpose `inverse_transpose` when it
    /// differs from the true one (after a `<rotate>` with a non-unit axis): normals follow it,
    /// and rays are taken to group space by its transpose (see the module docs).
    pub fn with_mitsuba_inverse(
        group: u32,
        to_world: &Mat4,
        inverse_transpose: Option<&Mat4>,
    ) -> Result<Instance, String> {
        let linear = Mat3::from_mat4(*to_world);
        let det = linear.determinant();
        let to_object = to_world.inverse();
        let affine = to_world.row(3) == glam::Vec4::W;
        let invertible = det.is_finite() && det != 0.0 && to_object.is_finite();
        if !(to_world.is_finite() && affine && invertible) {
            return Err(format!(
                "the instance's to_world is not an invertible affine map (determinant {det})"
            ));
        }
        let (to_object, normal) = match inverse_transpose {
            Some(it) if it.is_finite() => (it.transpose(), Mat3::from_mat4(*it)),
            _ => (to_object, linear.inverse().transpose()),
        };
        Ok(Instance {
            group,
            to_world: *to_world,
            to_object,
            normal,
            scene_index: 0,
        })
    }

    /// Index of the placed group.
    pub fn group(&self) -> u32 {
        self.group
    }

    /// Group space to world.
    pub fn to_world(&self) -> &Mat4 {
        &self.to_world
    }

    /// `ray` in group space: same `tmin`/`tmax`, direction mapped but not renormalised, so a
    /// point at parameter `t` is the image of the world point at `t`.
    #[inline]
    pub fn object_ray(&self, ray: &Ray) -> Ray {
        Ray {
            o: self.to_object.transform_point3(ray.o),
            d: self.to_object.transform_vector3(ray.d),
            tmin: ray.tmin,
            tmax: ray.tmax,
        }
    }

    /// A member's interaction `local`, computed for [`Instance::object_ray`] of the world ray
    /// `ray`, mapped to world space (see the module docs).
    #[inline]
    pub fn interaction(&self, local: SurfaceInteraction, ray: &Ray) -> SurfaceInteraction {
        let normal = |n: Vec3| (self.normal * n).try_normalize().unwrap_or(n);
        let dpdu = self.to_world.transform_vector3(local.dpdu);
        SurfaceInteraction {
            p: self.to_world.transform_point3(local.p),
            ng: normal(local.ng),
            sh: Frame::from_normal_tangent(normal(local.sh.n), dpdu),
            dpdu,
            dpdv: self.to_world.transform_vector3(local.dpdv),
            wi: -ray.d,
            ..local
        }
    }

    /// What the lane form of [`Instance::interaction`] needs
    /// ([`super::surface_lanes::instance`]): `to_world` and the normal matrix.
    pub(crate) fn lanes(&self) -> (Mat4, Mat3) {
        (self.to_world, self.normal)
    }

    /// World bounds of the group bounds (`lo`, `hi`) under `to_world`: the box around the eight
    /// mapped corners (empty bounds stay empty).
    pub fn bounds(&self, (lo, hi): (Vec3, Vec3)) -> (Vec3, Vec3) {
        if !(lo.cmple(hi).all()) {
            return (lo, hi);
        }
        (0..8).fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(a, b), k| {
                let c = Vec3::new(
                    if k & 1 == 0 { lo.x } else { hi.x },
                    if k & 2 == 0 { lo.y } else { hi.y },
                    if k & 4 == 0 { lo.z } else { hi.z },
                );
                let w = self.to_world.transform_point3(c);
                (a.min(w), b.max(w))
            },
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn degenerate_transforms_are_refused() {
        assert!(Instance::new(0, &Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0))).is_err());
        assert!(Instance::new(0, &Mat4::from_scale(Vec3::splat(f32::NAN))).is_err());
        let mut projective = Mat4::IDENTITY;
        projective.x_axis.w = 0.5;
        assert!(Instance::new(0, &projective).is_err());
        assert!(Instance::new(0, &Mat4::from_scale(Vec3::new(-1.0, 2.0, 0.5))).is_ok());
    }

    #[test]
    fn bounds_hold_the_mapped_corners() {
        let m = Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0))
            * Mat4::from_rotation_z(std::f32::consts::FRAC_PI_4)
            * Mat4::from_scale(Vec3::new(2.0, 1.0, 1.0));
        let i = Instance::new(0, &m).unwrap();
        let (lo, hi) = i.bounds((Vec3::splat(-1.0), Vec3::splat(1.0)));
        let s = 3.0 / 2f32.sqrt();
        assert!((lo - Vec3::new(1.0 - s, 2.0 - s, 2.0)).abs().max_element() < 1e-5);
        assert!((hi - Vec3::new(1.0 + s, 2.0 + s, 4.0)).abs().max_element() < 1e-5);
        let empty = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        assert_eq!(i.bounds(empty), empty);
    }
}
