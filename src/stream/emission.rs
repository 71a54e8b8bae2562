//! The emission stage of the stream renderer in lanes: what each active path's ray sees (an
//! escaped ray, the constant environment lights; a hit on an area light, its radiance), weighted
//! by MIS against the light's density, added to the path's radiance 8 paths at a time; and which
//! paths go on to the shading stage.
//!
//! The arithmetic is [`PathState::add_emission`]'s, operation for operation, written once over
//! [`Lane`] (width 1 is checked against the scalar functions below, width 8 by
//! `tests/render/stream.rs`): the power heuristic (Veach 1997, eq. 9.13, β = 2) of the previous
//! vertex's BSDF density against the light's, `Shape::pdf_direction`'s area-measure density
//! `dist² / (|cos| · area)` times the light selection's pmf, and `result += throughput · Le · w`.
//! What it does not cover goes lane by lane through [`PathState::add_emission`] itself: misses
//! when an environment light is not `constant` (an `envmap` looks its texels up per ray), and
//! hits on area lights with textured radiance or on spheres (whose density is a cone's from
//! outside).

use crate::emitter::Emitter;
use crate::geometry::shapes::ShapeKind;
use crate::integrator::path::PrevMis;
use crate::lane::vec::V3;
use crate::lane::Lane;
use crate::scene::Scene;
use crate::spectrum::Spectrum;
use crate::stream::kernels::mis::power_heuristic;
use crate::texture::Texture;
use glam::Vec3;

#[cfg(doc)]
use crate::integrator::path::PathState;

/// What a ray that hits a shape sees of its emission.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Seen {
    /// Nothing: the shape emits nothing (or zero radiance).
    Dark,
    /// An area light of constant `radiance` on a shape of `area` that is not a sphere, picked
    /// by the light sampler with probability `pmf`: in lanes.
    Area { radiance: Vec3, area: f32, pmf: f32 },
    /// Anything else: [`PathState::add_emission`], lane by lane.
    Scalar,
}

/// The scene's emission as the stage sees it, decided once at load.
#[derive(Clone, Debug)]
pub(crate) struct Lights {
    /// Per shape.
    pub shapes: Vec<Seen>,
    /// The environment lights in `Scene::env_emission`'s order when every one is `constant`:
    /// (radiance, light density = `pdf_direct_env · pmf`), those of zero radiance left out;
    /// `None` when one is not (escaped rays then go lane by lane).
    pub env: Option<Vec<(Vec3, f32)>>,
}

impl Lights {
    pub(crate) fn new(scene: &Scene) -> Lights {
        let shapes = (0..scene.shapes.len())
            .map(|s| {
                let Some(e) = scene.shape_emitter[s] else {
                    return Seen::Dark;
                };
                match &scene.emitters[e as usize] {
                    Emitter::Area(a) => match a.radiance {
                        Texture::Constant(le)
                            if !matches!(
                                scene.shapes[a.shape as usize].kind,
                                ShapeKind::Sphere { .. }
                            ) =>
                        {
                            // `add_emission` adds nothing when the radiance is zero.
                            if le == Spectrum::ZERO {
                                Seen::Dark
                            } else {
                                Seen::Area {
                                    radiance: le,
                                    area: scene.shapes[a.shape as usize].area(),
                                    pmf: scene.light_sampler.pmf(e as usize),
                                }
                            }
                        }
                        _ => Seen::Scalar,
                    },
                    // Only area lights have surface emission (`Emitter::eval_surface`).
                    _ => Seen::Dark,
                }
            })
            .collect();
        let env = scene
            .env_emitters
            .iter()
            .map(|&e| match &scene.emitters[e as usize] {
                Emitter::Constant(c) => Some((
                    c.radiance,
                    c.pdf_direct(Vec3::Z) * scene.light_sampler.pmf(e as usize),
                )),
                _ => None,
            })
            .collect::<Option<Vec<_>>>()
            .map(|v| {
                v.into_iter()
                    .filter(|(le, _)| *le != Spectrum::ZERO)
                    .collect()
            });
        Lights { shapes, env }
    }
}

/// The previous vertices of `L::WIDTH` paths as the MIS weight sees them ([`PrevMis`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Prev<L: Lane> {
    pub p: V3<L>,
    pub pdf: L,
    pub mis: L::Mask,
    pub zero: L::Mask,
}

/// The MIS weight of emission whose light density is `light_pdf` (`path::emission_weight`).
#[inline(always)]
pub(crate) fn weight<L: Lane>(prev: &Prev<L>, light_pdf: L) -> L {
    let k = |c: f32| light_pdf.splat(c);
    L::select(
        prev.mis,
        power_heuristic(prev.pdf, light_pdf),
        L::select(prev.zero, k(0.0), k(1.0)),
    )
}

/// `Shape::pdf_direction` for a shape that is not a sphere: the density of the point `p`
/// (shading normal `n`) seen from `ref_p` by area sampling of a shape of `area`, in solid angle
/// (0 where not finite).
#[inline(always)]
pub(crate) fn area_pdf<L: Lane>(p: V3<L>, n: V3<L>, ref_p: V3<L>, area: L) -> L {
    let v = p - ref_p;
    let dist2 = v.length_squared();
    let cos = v.div_by(dist2.sqrt()).dot(n).abs();
    let pdf = dist2 / (cos * area);
    L::select(pdf.is_finite(), pdf, pdf.splat(0.0))
}

/// `AreaLight::eval`'s side test: the point emits toward `wi` unless `n · wi ≤ 0` (a NaN
/// product emits, as in the scalar test).
#[inline(always)]
pub(crate) fn front<L: Lane>(n: V3<L>, wi: V3<L>) -> L::Mask {
    let d = n.dot(wi);
    !d.le(d.splat(0.0))
}

/// `result += throughput · le · w`, as glam computes it (component products, then the scale).
#[inline(always)]
pub(crate) fn add<L: Lane>(result: V3<L>, throughput: V3<L>, le: V3<L>, w: L) -> V3<L> {
    result + (throughput * le).scale(w)
}

/// Emission seen by `L::WIDTH` paths with radiance `result`, throughput `throughput` and
/// previous vertices `prev`: the constant environment lights `env` where `miss`, the area light
/// of constant radiance `le`, `area` and pmf `pmf` at the point `p` (shading normal `n`,
/// toward the previous vertex `wi`) where `on_area`. Returns the new radiance.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(crate) fn seen<L: Lane>(
    mut result: V3<L>,
    throughput: V3<L>,
    prev: &Prev<L>,
    env: &[(Vec3, f32)],
    miss: L::Mask,
    on_area: L::Mask,
    area: (V3<L>, L, L),
    hit: (V3<L>, V3<L>, V3<L>),
) -> V3<L> {
    let like = prev.pdf;
    for &(le, light_pdf) in env {
        let w = weight(prev, like.splat(light_pdf));
        let le = V3::splat(like, le.x, le.y, le.z);
        result = V3::select(miss, add(result, throughput, le, w), result);
    }
    let (le, a, pmf) = area;
    let (p, n, wi) = hit;
    let on = on_area & front(n, wi);
    let w = weight(prev, area_pdf(p, n, prev.p, a) * pmf);
    V3::select(on, add(result, throughput, le, w), result)
}

#[cfg(target_arch = "x86_64")]
pub(crate) mod x8 {
    use super::*;
    use crate::integrator::PathSettings;
    use crate::lane::Avx2;
    use crate::stream::batch::{cols, Batch};
    use crate::stream::kernels::light::x8::Cols3;

    /// Row field `f` (three floats) of path `i`, into lane `k` of `c`.
    #[inline(always)]
    fn row3(c: &mut Cols3, k: usize, flat: &[f32], i: usize, f: usize) {
        let r = &flat[i * cols::ROW + f..i * cols::ROW + f + 3];
        (c.0[0][k], c.0[1][k], c.0[2][k]) = (r[0], r[1], r[2]);
    }

    /// The emission stage over `batch.active`, 8 paths at a time: adds what each ray sees to
    /// its path, marks every active path not alive, and lists in `batch.scatter` (ascending) the
    /// paths that scatter at their hit (depth + 1 < max_depth), with their material. Returns the
    /// paths whose emission went through the lanes. Call inside [`Avx2::run`].
    #[inline(always)]
    pub(crate) fn stage(
        avx: Avx2,
        scene: &Scene,
        cfg: &PathSettings,
        lights: &Lights,
        batch: &mut Batch,
    ) -> u64 {
        let limit = crate::integrator::depth_limit(cfg.max_depth);
        let env = lights.env.as_deref();
        let env_lights = env.unwrap_or(&[]);
        let mut in_lanes = 0;
        batch.scatter.clear();
        let Batch {
            active,
            state,
            hit,
            surf,
            alive,
            material,
            scatter,
            ray,
            ..
        } = batch;
        let flat = &surf.flat()[..];
        for chunk in active.chunks(8) {
            let mut lanes = [false; 8];
            let mut miss = [false; 8];
            let mut on_area = [false; 8];
            let mut scalar = [false; 8];
            let mut le: Cols3 = Cols3::default();
            let mut area = [0.0f32; 8];
            let mut pmf = [0.0f32; 8];
            for (k, &i) in chunk.iter().enumerate() {
                let i = i as usize;
                alive[i] = false;
                let st = &state[i];
                let show = st.depth > 0 || !cfg.hide_emitters;
                if hit[i].is_some() {
                    let shape = flat[i * cols::ROW + cols::SHAPE].to_bits() as usize;
                    if show {
                        match lights.shapes[shape] {
                            Seen::Dark => {}
                            Seen::Area {
                                radiance,
                                area: a,
                                pmf: q,
                            } => {
                                on_area[k] = true;
                                lanes[k] = true;
                                le.set(k, radiance);
                                (area[k], pmf[k]) = (a, q);
                            }
                            Seen::Scalar => scalar[k] = true,
                        }
                    }
                    // Mitsuba: continue only while depth + 1 < max_depth.
                    if st.depth.saturating_add(1) < limit {
                        material[i] = scene.shape_material[shape];
                        scatter.push(i as u32);
                    }
                } else if show {
                    match env {
                        Some(e) if !e.is_empty() => {
                            miss[k] = true;
                            lanes[k] = true;
                        }
                        Some(_) => {}
                        None => scalar[k] = true,
                    }
                }
            }
            if lanes.contains(&true) {
                let mut t: Cols3 = Cols3::default();
                let mut r: Cols3 = Cols3::default();
                let mut pp: Cols3 = Cols3::default();
                let mut pdf = [0.0f32; 8];
                let mut mis = [false; 8];
                let mut zero = [false; 8];
                let mut p: Cols3 = Cols3::default();
                let mut n: Cols3 = Cols3::default();
                let mut wi: Cols3 = Cols3::default();
                for (k, &i) in chunk.iter().enumerate() {
                    if !lanes[k] {
                        continue;
                    }
                    let i = i as usize;
                    let st = &state[i];
                    t.set(k, st.throughput);
                    r.set(k, st.result);
                    let pm: PrevMis = st.prev_mis(cfg);
                    pp.set(k, pm.p);
                    (pdf[k], mis[k], zero[k]) = (pm.pdf, pm.mis, pm.zero);
                    if on_area[k] {
                        row3(&mut p, k, flat, i, cols::P);
                        row3(&mut n, k, flat, i, cols::N);
                        row3(&mut wi, k, flat, i, cols::WI);
                    }
                }
                let prev = Prev {
                    p: pp.load(avx),
                    pdf: avx.load(&pdf),
                    mis: avx.mask(&mis),
                    zero: avx.mask(&zero),
                };
                let out = seen(
                    r.load(avx),
                    t.load(avx),
                    &prev,
                    env_lights,
                    avx.mask(&miss),
                    avx.mask(&on_area),
                    (le.load(avx), avx.load(&area), avx.load(&pmf)),
                    (p.load(avx), n.load(avx), wi.load(avx)),
                );
                let (x, y, z) = (out.x.to_array(), out.y.to_array(), out.z.to_array());
                for (k, &i) in chunk.iter().enumerate() {
                    if lanes[k] {
                        state[i as usize].result = Vec3::new(x[k], y[k], z[k]);
                        in_lanes += 1;
                    }
                }
            }
            if scalar.contains(&true) {
                for (k, &i) in chunk.iter().enumerate() {
                    if scalar[k] {
                        let i = i as usize;
                        let si = hit[i].map(|_| surf.get(i));
                        state[i].add_emission(cfg, scene, &ray[i], si.as_ref());
                    }
                }
            }
        }
        in_lanes
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Shape;
    use crate::math::mis::power_heuristic as scalar_ph;
    use crate::math::Pcg32;
    use glam::{Mat4, Vec2};

    fn same(a: f32, b: f32) -> bool {
        a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
    }

    fn same3(a: V3<f32>, b: Vec3) -> bool {
        same(a.x, b.x) && same(a.y, b.y) && same(a.z, b.z)
    }

    /// The scalar MIS weight of `path::emission_weight` from a `PrevMis`.
    fn scalar_weight(pm: &PrevMis, light_pdf: f32) -> f32 {
        if pm.mis {
            scalar_ph(pm.pdf, light_pdf)
        } else if pm.zero {
            0.0
        } else {
            1.0
        }
    }

    /// Width 1 (and width 8 in lane 5) of the area-light pieces equals the scalar code bit for
    /// bit: `AreaLight::eval`'s side test and `Shape::pdf_direction` on random rectangles and
    /// triangle-free shapes seen from random points (grazing, behind and at the point included),
    /// the weight and `result += throughput · le · w` under every MIS case.
    #[test]
    fn lane_emission_equals_the_scalar_code() {
        use crate::emitter::area::AreaLight;
        use crate::geometry::SurfaceInteraction;
        use crate::math::Frame;
        let mut r = Pcg32::new(17, 3);
        let mut f = |a: f32, b: f32| a + (b - a) * r.next_f32();
        let mut checked = 0;
        for i in 0..6000 {
            let axis = Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(0.1, 1.0)).normalize();
            let (scale, turn) = (Vec3::new(f(0.1, 3.0), f(0.1, 3.0), 1.0), f(-3.0, 3.0));
            let at = Vec3::new(f(-2.0, 2.0), f(-2.0, 2.0), f(-2.0, 2.0));
            let m = Mat4::from_translation(at)
                * Mat4::from_quat(glam::Quat::from_axis_angle(axis, turn))
                * Mat4::from_scale(scale);
            let shape = Shape::rectangle_with_normals(&m, None, i % 3 == 0);
            let le = Vec3::new(f(0.0, 9.0), f(0.0, 9.0), f(0.0, 9.0));
            let light = AreaLight {
                shape: 0,
                radiance: Texture::Constant(le),
            };
            let n = Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), f(-1.0, 1.0)).normalize();
            let p = m.transform_point3(Vec3::new(f(-1.0, 1.0), f(-1.0, 1.0), 0.0));
            let refp = match i % 7 {
                0 => p,
                1 => p + n * 1e-30,
                _ => Vec3::new(f(-4.0, 4.0), f(-4.0, 4.0), f(-4.0, 4.0)),
            };
            let wi = match i % 11 {
                0 => Vec3::new(n.y, -n.x, 0.0),
                _ => (refp - p).normalize_or(Vec3::Z),
            };
            let si = SurfaceInteraction {
                p,
                t: 1.0,
                ng: n,
                sh: Frame::from_normal(n),
                uv: Vec2::new(f(0.0, 1.0), f(0.0, 1.0)),
                dpdu: Vec3::X,
                dpdv: Vec3::Y,
                shape: 0,
                prim: 0,
                wi,
            };
            let shapes = [shape];
            let pm = PrevMis {
                p: refp,
                pdf: [0.0, f(0.0, 5.0), f32::INFINITY, 1e30][i % 4],
                mis: i % 5 != 0,
                zero: i % 5 == 0 && i % 2 == 0,
            };
            let pmf = f(0.1, 1.0);
            let t = Vec3::new(f(0.0, 2.0), f(0.0, 2.0), f(0.0, 2.0));
            let r0 = Vec3::new(f(0.0, 2.0), f(0.0, 2.0), f(0.0, 2.0));
            // The scalar code (`add_emission`'s area branch).
            let sle = light.eval(&si);
            let mut expect = r0;
            if sle != Spectrum::ZERO {
                let w = scalar_weight(&pm, light.pdf_direct(&shapes, refp, &si) * pmf);
                expect += t * sle * w;
            }
            let prev = Prev {
                p: pm.p.into(),
                pdf: pm.pdf,
                mis: pm.mis,
                zero: pm.zero,
            };
            let area = shapes[0].area();
            let got = seen::<f32>(
                r0.into(),
                t.into(),
                &prev,
                &[],
                false,
                true,
                (le.into(), area, pmf),
                (p.into(), si.sh.n.into(), wi.into()),
            );
            assert!(same3(got, expect), "{i}: {got:?} vs {expect}");
            #[cfg(target_arch = "x86_64")]
            if let Some(avx) = crate::lane::Avx2::detect() {
                let v = |v: Vec3| V3::splat(avx.splat(0.0), v.x, v.y, v.z);
                let m = |b: bool| avx.mask(&[b; 8]);
                let got = avx.run(|| {
                    let prev = Prev {
                        p: v(pm.p),
                        pdf: avx.splat(pm.pdf),
                        mis: m(pm.mis),
                        zero: m(pm.zero),
                    };
                    seen(
                        v(r0),
                        v(t),
                        &prev,
                        &[],
                        m(false),
                        m(true),
                        (v(le), avx.splat(area), avx.splat(pmf)),
                        (v(p), v(si.sh.n), v(wi)),
                    )
                });
                let g = V3::new(got.x.lane(5), got.y.lane(5), got.z.lane(5));
                assert!(same3(g, expect), "{i} at width 8");
            }
            // A constant environment light seen by an escaped ray.
            let lpdf = crate::math::warp::uniform_sphere_pdf() * pmf;
            let expect = r0 + t * le * scalar_weight(&pm, lpdf);
            let got = seen::<f32>(
                r0.into(),
                t.into(),
                &prev,
                &[(le, lpdf)],
                true,
                false,
                (le.into(), 1.0, 1.0),
                (p.into(), n.into(), wi.into()),
            );
            assert!(same3(got, expect), "{i} (environment)");
            checked += (sle != Spectrum::ZERO) as usize;
        }
        assert!(checked > 1500, "{checked}");
    }
}
