//! The emitters without a surface sampled in lanes: `point`, `spot` (its texture's uv here, the
//! lookup in `light::x8::Gather::finish`), `directional`,
//! `constant` and `envmap`, each the operations of its scalar `sample_direct`
//! (`src/emitter/*.rs`) in the same order, so every lane equals it bit for bit (the unit test
//! below at width 1, `tests/render/stream.rs` at width 8). Branches of the scalar code become
//! masks; an environment map's table walk and texel lookups stay lane by lane (they branch on
//! data), its trigonometry (the direction of the sampled (u, v), and back to (u, v) for the
//! density and radiance, as the scalar `sample_direct` recomputes them) runs in lanes; the way
//! back to (u, v) ([`env_uv`]) also serves the emission stage's escaped rays
//! (`stream::emission`).

use crate::lane::math as lm;
use crate::lane::vec::{V2, V3};
use crate::lane::{warp, Lane};
use crate::math::PI;

/// A light sample with no surface normal, as `emitter::DirectSample` (`ok`: the scalar
/// `sample_direct` returns it; its `value` may still be zero, which `nee::sample_emitter`
/// drops).
#[derive(Clone, Copy, Debug)]
pub(crate) struct FreePoint<L: Lane> {
    pub ok: L::Mask,
    pub d: V3<L>,
    pub dist: L,
    pub p: V3<L>,
    pub pdf: L,
    pub value: V3<L>,
}

/// glam's `Mat3 * Vec3` (columns `c`): `c0·v.x`, plus `c1·v.y`, plus `c2·v.z`, left to right.
#[inline(always)]
pub(crate) fn mat3_mul<L: Lane>(c: &[V3<L>; 3], v: V3<L>) -> V3<L> {
    (c[0].scale(v.x) + c[1].scale(v.y)) + c[2].scale(v.z)
}

/// `f32::clamp`: `lo` below `lo`, `hi` above `hi` (NaN stays NaN; −0 stays −0 at `lo` = 0).
#[inline(always)]
fn clamp<L: Lane>(x: L, lo: f32, hi: f32) -> L {
    let (lo, hi) = (x.splat(lo), x.splat(hi));
    L::select(x.gt(hi), hi, L::select(x.lt(lo), lo, x))
}

/// glam's `normalize_or_zero`: `v · (1/|v|)` where that reciprocal is finite and positive, else 0.
#[inline(always)]
fn normalize_or_zero<L: Lane>(v: V3<L>) -> V3<L> {
    let rcp = v.x.splat(1.0) / v.length();
    let ok = rcp.is_finite() & rcp.gt(v.x.splat(0.0));
    let z = v.x.splat(0.0);
    V3::select(ok, v.scale(rcp), V3::new(z, z, z))
}

/// The point and distance toward a point light at `pos` seen from `ref_p`, shared by `point`
/// and `spot`: `v = pos − ref_p`, `|v|²` (refused when NaN or ≤ 0), `|v|`, `v / |v|`.
#[inline(always)]
fn toward<L: Lane>(pos: V3<L>, ref_p: V3<L>) -> (L::Mask, V3<L>, L, L) {
    let v = pos - ref_p;
    let dist2 = v.length_squared();
    let ok = !(dist2.is_nan() | dist2.le(dist2.splat(0.0)));
    let dist = dist2.sqrt();
    (ok, v.div_by(dist), dist, dist2)
}

/// `PointLight::sample_direct`: intensity / dist², density 1 (a delta light).
#[inline(always)]
pub(crate) fn sample_point<L: Lane>(pos: V3<L>, intensity: V3<L>, ref_p: V3<L>) -> FreePoint<L> {
    let (ok, d, dist, dist2) = toward(pos, ref_p);
    FreePoint {
        ok,
        d,
        dist,
        p: pos,
        pdf: dist.splat(1.0),
        value: intensity.div_by(dist2),
    }
}

/// A spot light per lane: position, the columns of its world-to-light matrix, intensity, and its
/// cone (cosines and angles of cutoff and beam width); a texture multiplies [`sample_spot`]'s
/// value afterwards, at [`spot_uv`] (`light::x8::Gather::finish`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Spot<L: Lane> {
    pub pos: V3<L>,
    pub to_local: [V3<L>; 3],
    pub intensity: V3<L>,
    pub cos_cutoff: L,
    pub cos_beam: L,
    pub cutoff: L,
    pub beam_width: L,
}

/// `SpotLight::sample_direct` up to its texture: the falloff (`SpotLight::falloff`: 0 outside
/// the cutoff, 1 inside the beam, linear in the angle between) of the direction in the light's
/// frame, times intensity / dist².
#[inline(always)]
pub(crate) fn sample_spot<L: Lane>(s: &Spot<L>, ref_p: V3<L>) -> FreePoint<L> {
    let k = |c: f32| ref_p.x.splat(c);
    let (ok, d, dist, dist2) = toward(s.pos, ref_p);
    let local = mat3_mul(&s.to_local, -d);
    let c = normalize_or_zero(local).z;
    let theta = lm::acos(clamp(c, -1.0, 1.0));
    let ramp = clamp((s.cutoff - theta) / (s.cutoff - s.beam_width), 0.0, 1.0);
    let fall = L::select(
        c.le(s.cos_cutoff),
        k(0.0),
        L::select(c.ge(s.cos_beam), k(1.0), ramp),
    );
    FreePoint {
        ok: ok & !fall.le(k(0.0)),
        d,
        dist,
        p: s.pos,
        pdf: k(1.0),
        value: s.intensity.scale(fall / dist2),
    }
}

/// The texture coordinates of a spot light's texture toward the light sample `d` (the
/// direction from the reference point to the light), as `SpotLight::sample_direct` computes them:
/// `local = to_local · −d`, `k = 0.5 / (local.z · tan cutoff)`, `uv = 0.5 + (local.x, local.y)·k`
/// (Mitsuba 3's `spot` `direction_to_uv`).
#[inline(always)]
pub(crate) fn spot_uv<L: Lane>(to_local: &[V3<L>; 3], d: V3<L>, uv_factor: L) -> V2<L> {
    let local = mat3_mul(to_local, -d);
    let half = uv_factor.splat(0.5);
    let k = half / (local.z * uv_factor);
    V2::new(half + local.x * k, half + local.y * k)
}

/// `DirectionalLight::sample_direct`: the direction `d` (minus the direction of travel) at an
/// infinite distance, its point `ref_p + d`.
#[inline(always)]
pub(crate) fn sample_directional<L: Lane>(
    d: V3<L>,
    irradiance: V3<L>,
    ref_p: V3<L>,
) -> FreePoint<L> {
    let k = |c: f32| ref_p.x.splat(c);
    FreePoint {
        ok: k(0.0).eq(k(0.0)),
        d,
        dist: k(f32::INFINITY),
        p: ref_p + d,
        pdf: k(1.0),
        value: irradiance,
    }
}

/// `ConstantLight::sample_direct`: a uniform direction on the sphere.
#[inline(always)]
pub(crate) fn sample_constant<L: Lane>(radiance: V3<L>, u: V2<L>) -> FreePoint<L> {
    let k = |c: f32| u.x.splat(c);
    let d = warp::square_to_uniform_sphere(u);
    FreePoint {
        ok: k(0.0).eq(k(0.0)),
        d,
        dist: k(f32::INFINITY),
        p: d,
        pdf: warp::uniform_sphere_pdf(u.x),
        value: radiance,
    }
}

/// An environment map's frames per lane and the texture-space point its table walk picked
/// (`EnvMapLight::sample_uv`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Env<L: Lane> {
    pub to_world: [V3<L>; 3],
    pub to_local: [V3<L>; 3],
    /// `EnvMapLight::half_texel`.
    pub half_texel: L,
    pub uv: V2<L>,
}

/// The trigonometric part of `EnvMapLight::sample_direct`: the world direction `d` of the
/// sampled (u, v), then, as `pdf_direct` and `eval` recompute them from `d`, its (u, v) again
/// (`uv`, where the texels are looked up), `sin θ` and the patch-space point `patch` (where the
/// table's density is looked up). `ok`: the tests that pass so far (the sampled sin θ, a
/// non-zero local direction, the recomputed sin θ); [`env_pdf`] adds the density's.
#[derive(Clone, Copy, Debug)]
pub(crate) struct EnvDir<L: Lane> {
    pub ok: L::Mask,
    pub d: V3<L>,
    pub uv: V2<L>,
    pub patch: V2<L>,
    pub sin_theta: L,
}

/// `EnvMapLight::local_of_uv` then `(to_world · local).normalize()`, and
/// `EnvMapLight::uv_of_local` of `to_local · d`, as `sample_direct` / `pdf_direct` / `eval`.
#[inline(always)]
pub(crate) fn env_direction<L: Lane>(e: &Env<L>) -> EnvDir<L> {
    let k = |c: f32| e.uv.x.splat(c);
    let ok = !lm::sin(k(PI) * e.uv.y).le(k(0.0));
    let (sp, cp) = lm::sincos(k(2.0 * PI) * e.uv.x);
    let (st, ct) = lm::sincos(k(PI) * e.uv.y);
    let local = V3::new(st * sp, ct, -st * cp);
    let d = mat3_mul(&e.to_world, local).normalize();
    let q = env_uv(&e.to_local, e.half_texel, d);
    EnvDir {
        ok: ok & q.seen & q.sin_ok,
        d,
        uv: q.uv,
        patch: q.patch,
        sin_theta: q.sin_theta,
    }
}

/// Where an environment map looks up the world direction `d` (the direction of an escaped ray,
/// or a sampled one), as `EnvMapLight::eval` and `pdf_direct` compute it: the local direction
/// `normalize_or_zero(to_local · d)`, its (u, v) (`EnvMapLight::uv_of_local`), sin θ and the
/// patch-space point of the table's density.
#[derive(Clone, Copy, Debug)]
pub(crate) struct EnvUv<L: Lane> {
    /// The local direction is not zero (where it is, `eval` is 0 and `pdf_direct` 0).
    pub seen: L::Mask,
    pub uv: V2<L>,
    pub patch: V2<L>,
    pub sin_theta: L,
    /// sin θ is neither NaN nor ≤ 0 (where it is, `pdf_direct` is 0).
    pub sin_ok: L::Mask,
}

/// [`EnvUv`] of the world direction `d` under the map frame `to_local` (columns), with
/// `EnvMapLight::half_texel` `half_texel`.
#[inline(always)]
pub(crate) fn env_uv<L: Lane>(to_local: &[V3<L>; 3], half_texel: L, d: V3<L>) -> EnvUv<L> {
    let k = |c: f32| d.x.splat(c);
    let l = normalize_or_zero(mat3_mul(to_local, d));
    let zero = l.x.eq(k(0.0)) & l.y.eq(k(0.0)) & l.z.eq(k(0.0));
    let u = lm::atan2(l.x, -l.z) * k(0.5 / PI);
    let u = L::select(u.lt(k(0.0)), u + k(1.0), u);
    let u = L::select(u.ge(k(1.0)), k(0.0), u);
    let v = lm::acos(clamp(l.y, -1.0, 1.0)) / k(PI);
    let sin_theta = lm::sin(k(PI) * v);
    let sin_ok = !(sin_theta.is_nan() | sin_theta.le(k(0.0)));
    let px = u - half_texel;
    let px = L::select(px.lt(k(0.0)), px + k(1.0), px);
    EnvUv {
        seen: !zero,
        uv: V2::new(u, v),
        patch: V2::new(px, v),
        sin_theta,
        sin_ok,
    }
}

/// The end of `EnvMapLight::pdf_direct`: the table's density `patch_pdf` at the patch point
/// to solid angle, and `sample_direct`'s test of it (finite and positive).
#[inline(always)]
pub(crate) fn env_pdf<L: Lane>(patch_pdf: L, sin_theta: L) -> (L, L::Mask) {
    let k = |c: f32| sin_theta.splat(c);
    let pdf = patch_pdf / (k(2.0 * PI * PI) * sin_theta);
    (pdf, pdf.is_finite() & pdf.gt(k(0.0)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::emitter::constant::ConstantLight;
    use crate::emitter::directional::DirectionalLight;
    use crate::emitter::envmap::EnvMapLight;
    use crate::emitter::point::PointLight;
    use crate::emitter::spot::SpotLight;
    use crate::emitter::DirectSample;
    use crate::math::Pcg32;
    use crate::stream::kernels::light::tests::{same, same3};
    use glam::{Mat3, Vec2, Vec3};

    /// The lane sample equals the scalar one where the scalar accepts it, and is refused where
    /// the scalar refuses it.
    fn check(q: &FreePoint<f32>, ds: Option<DirectSample>, what: &str) -> bool {
        assert_eq!(q.ok, ds.is_some(), "{what}");
        let Some(ds) = ds else { return false };
        assert!(
            same3(q.d, ds.d)
                && same(q.dist, ds.dist)
                && same3(q.p, ds.p)
                && same(q.pdf, ds.pdf)
                && same3(q.value, ds.value),
            "{what}: {q:?} vs {ds:?}"
        );
        true
    }

    fn cols(m: Mat3) -> [V3<f32>; 3] {
        [m.x_axis.into(), m.y_axis.into(), m.z_axis.into()]
    }

    /// Width 1 of the lane samplers equals the scalar `sample_direct` of `point`, `spot`,
    /// `directional`, `constant` and `envmap` bit for bit on random lights seen from random
    /// points (spot: random cones and non-rigid frames, inside, in the falloff and outside;
    /// envmap: a random map under a random rotation), accepted or not.
    #[test]
    fn lane_free_emitters_equal_the_scalar_sampling() {
        let mut r = Pcg32::new(5, 9);
        let mut f = |a: f32, b: f32| a + (b - a) * r.next_f32();
        let mut accepted = [0usize; 5];
        let (w, h) = (13, 7);
        let px: Vec<[f32; 3]> = (0..w * h)
            .map(|i| {
                let x = (i * 7919 % 101) as f32 / 50.0;
                [x, 0.5 * x + 0.1, if i % 5 == 0 { 0.0 } else { 1.0 }]
            })
            .collect();
        for i in 0..4000 {
            let refp = Vec3::new(f(-3.0, 3.0), f(-3.0, 3.0), f(-3.0, 3.0));
            let u = Vec2::new(f(0.0, 1.0), f(0.0, 1.0));
            let pos = Vec3::new(f(-2.0, 2.0), f(-2.0, 2.0), f(-2.0, 2.0));
            let pos = if i % 97 == 0 { refp } else { pos };
            let le = Vec3::new(f(0.0, 4.0), f(0.0, 4.0), f(0.0, 4.0));
            let pl = PointLight {
                position: pos,
                intensity: le,
            };
            let q = sample_point(pos.into(), le.into(), refp.into());
            accepted[0] += check(&q, pl.sample_direct(refp), "point") as usize;

            let rot = glam::Quat::from_euler(
                glam::EulerRot::XYZ,
                f(-3.0, 3.0),
                f(-3.0, 3.0),
                f(-3.0, 3.0),
            );
            let scale = if i % 2 == 0 {
                Vec3::ONE
            } else {
                Vec3::new(f(0.5, 2.0), f(0.5, 2.0), f(0.5, 2.0))
            };
            let to_local = Mat3::from_quat(rot) * Mat3::from_diagonal(scale);
            let cutoff = f(0.05, 3.1);
            let beam = cutoff * f(0.0, 1.0);
            let sl = SpotLight::new(pos, to_local, le, None, cutoff, beam);
            let q = sample_spot(
                &Spot {
                    pos: pos.into(),
                    to_local: cols(to_local),
                    intensity: le.into(),
                    cos_cutoff: sl.cos_cutoff,
                    cos_beam: sl.cos_beam,
                    cutoff: sl.cutoff,
                    beam_width: sl.beam_width,
                },
                refp.into(),
            );
            accepted[1] += check(&q, sl.sample_direct(refp), "spot") as usize;

            let dir = (pos - Vec3::splat(0.1)).normalize_or(Vec3::Z);
            let dl = DirectionalLight {
                direction: dir,
                irradiance: le,
            };
            let q = sample_directional((-dir).into(), le.into(), refp.into());
            accepted[2] += check(&q, dl.sample_direct(refp), "directional") as usize;

            let cl = ConstantLight { radiance: le };
            let q = sample_constant(le.into(), u.into());
            accepted[3] += check(&q, cl.sample_direct(u), "constant") as usize;

            let to_world = Mat3::from_quat(rot);
            let em = EnvMapLight::new(w, h, &px, f(0.5, 2.0), to_world).unwrap();
            let ds = em.sample_direct(refp, u);
            let Some(uv) = em.sample_uv(u) else {
                assert!(ds.is_none());
                continue;
            };
            let (tw, tl) = em.frames();
            let e = env_direction(&Env {
                to_world: cols(tw),
                to_local: cols(tl),
                half_texel: em.half_texel(),
                uv: uv.into(),
            });
            let (pdf, pdf_ok) = env_pdf(em.patch_pdf(e.patch.into()), e.sin_theta);
            let q = FreePoint {
                ok: e.ok && pdf_ok,
                d: e.d,
                dist: f32::INFINITY,
                p: (refp + Vec3::from(e.d)).into(),
                pdf,
                value: em.lookup(e.uv.into()).into(),
            };
            accepted[4] += check(&q, ds, "envmap") as usize;
        }
        // Most of the random cases are accepted (the spot's about half: inside its cone).
        assert!(accepted.iter().all(|&n| n > 1000), "{accepted:?}");
    }
}
