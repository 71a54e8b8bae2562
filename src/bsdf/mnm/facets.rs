//! Microgeometries for microfacet-based normal mapping (Schüssler et al. 2017; spec `mnm.md`
//! §2 and §10.1): a few planar facets per shading point whose area-weighted normals sum to the
//! geometric normal ωg = +z (the closure identity), so the microsurface is a valid heightfield.
//!
//! Each facet k is stored as its *area vector* `v_k = A_k · m_k` (area per unit macro area times
//! unit normal). Then the projected area toward ω is `a_k(ω) = ⟨ω, v_k⟩`, closure reads
//! `Σ v_k = ωg`, and no formula divides by cos θp or sin θp (the robust form of §2.4).

use glam::Vec3;

/// Most facets any microgeometry here uses.
pub const MAX_FACETS: usize = 3;

/// Which microgeometry to build from the perturbed normal ωp.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Microgeometry {
    /// The paper's sawtooth: perturbed facet ωp plus a vertical "tangent" wall ωt.
    Sawtooth,
    /// Symmetric V-groove: ωp and its mirror image (−x, −y, z), each of area 1/(2 cos θp).
    VGroove,
    /// Three facets: ωp, a flat bottom ωg and the tangent wall; `fill` s ∈ (0, 1] (§10.3):
    /// A_p = s / cos θp, A_t = s · tan θp, A_n = 1 − s. s = 1 is the sawtooth.
    UGroove { fill: f32 },
}

/// The facets at one shading point, in the macro (shading) frame where ωg = +z.
#[derive(Clone, Copy, Debug)]
pub struct Microsurface {
    /// Area vectors A_k · m_k.
    v: [Vec3; MAX_FACETS],
    /// Unit normals m_k.
    m: [Vec3; MAX_FACETS],
    n: usize,
}

impl Microsurface {
    /// Build the facets for the perturbed normal `wp` (unit, `wp.z > 0`; callers clamp it).
    /// Facets of zero area (e.g. the wall when ωp = ωg) are left out.
    pub fn new(geometry: Microgeometry, wp: Vec3) -> Microsurface {
        let inv_cos = 1.0 / wp.z;
        // ωt_u = ωg (ωg·ωp) − ωp: horizontal, length sin θp, pointing away from ωp's lean.
        let wt_u = Vec3::new(-wp.x, -wp.y, 0.0);
        let mut s = Microsurface {
            v: [Vec3::ZERO; MAX_FACETS],
            m: [Vec3::ZERO; MAX_FACETS],
            n: 0,
        };
        match geometry {
            Microgeometry::Sawtooth => {
                s.push(wp * inv_cos);
                s.push(wt_u * inv_cos);
            }
            Microgeometry::VGroove => {
                let mirror = Vec3::new(-wp.x, -wp.y, wp.z);
                s.push(wp * (0.5 * inv_cos));
                s.push(mirror * (0.5 * inv_cos));
            }
            Microgeometry::UGroove { fill } => {
                s.push(wp * (fill * inv_cos));
                s.push(Vec3::new(0.0, 0.0, 1.0 - fill));
                s.push(wt_u * (fill * inv_cos));
            }
        }
        s
    }

    /// A microsurface from explicit area vectors (experiments and tests, e.g. a deliberately
    /// broken closure). At most [`MAX_FACETS`] are used; zero vectors are skipped.
    pub fn from_area_vectors(vs: &[Vec3]) -> Microsurface {
        let mut s = Microsurface {
            v: [Vec3::ZERO; MAX_FACETS],
            m: [Vec3::ZERO; MAX_FACETS],
            n: 0,
        };
        for &v in vs.iter().take(MAX_FACETS) {
            s.push(v);
        }
        s
    }

    /// |Σ_k A_k m_k − ωg|: zero for a valid microsurface (the closure identity).
    pub fn closure_error(&self) -> f32 {
        ((0..self.n).map(|k| self.v[k]).sum::<Vec3>() - Vec3::Z).length()
    }

    fn push(&mut self, v: Vec3) {
        let len = v.length();
        if len > 1e-7 {
            self.v[self.n] = v;
            self.m[self.n] = v / len;
            self.n += 1;
        }
    }

    /// Number of facets.
    #[inline]
    pub fn len(&self) -> usize {
        self.n
    }

    #[inline]
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// Unit normal of facet `k`.
    #[inline]
    pub fn normal(&self, k: usize) -> Vec3 {
        self.m[k]
    }

    /// Area vector A_k · m_k of facet `k`.
    #[inline]
    pub fn area_vector(&self, k: usize) -> Vec3 {
        self.v[k]
    }

    /// Projected area of facet `k` toward ω: a_k(ω) = A_k ⟨ω, m_k⟩.
    #[inline]
    pub fn proj_area(&self, k: usize, w: Vec3) -> f32 {
        w.dot(self.v[k]).max(0.0)
    }

    /// Σ_k a_k(ω): the microsurface's projected area toward ω (≥ z(ω) by closure).
    #[inline]
    pub fn sigma(&self, w: Vec3) -> f32 {
        (0..self.n).map(|k| self.proj_area(k, w)).sum()
    }

    /// Smith masking of the macro surface seen from ω: G1(ω) = χ(z)·min(1, z / Σ(ω)).
    #[inline]
    pub fn g1(&self, w: Vec3) -> f32 {
        if w.z <= 0.0 {
            return 0.0;
        }
        // One pass over the facets gives both the test below and Σ(ω) (each ⟨ω, v_k⟩ once; the
        // sum is [`sigma`](Self::sigma)'s, bit for bit: negative terms add nothing).
        let mut s = 0.0;
        let mut all_face = true;
        for k in 0..self.n {
            let a = w.dot(self.v[k]);
            if a >= 0.0 {
                s += a;
            } else {
                all_face = false;
            }
        }
        // Every facet faces ω: nothing can block it. Closure makes Σ = z exactly then; testing
        // it directly keeps rounding (z/Σ = 0.9999999) from inventing blocked rays.
        if all_face {
            return 1.0;
        }
        if s <= 0.0 {
            return 1.0;
        }
        (w.z / s).min(1.0)
    }

    /// λ_k(ω) for every facet with Σ(ω) computed once (entries past [`len`](Self::len) are 0);
    /// each entry equals [`lambda`](Self::lambda)`(k, ω)` bit for bit.
    #[inline]
    pub fn lambdas(&self, w: Vec3) -> [f32; MAX_FACETS] {
        let mut l = [0.0; MAX_FACETS];
        let s = self.sigma(w);
        if s > 0.0 {
            for (k, lk) in l.iter_mut().enumerate().take(self.n) {
                *lk = self.proj_area(k, w) / s;
            }
        }
        l
    }

    /// Probability that a ray arriving from ω (pointing away, above the surface) first hits
    /// facet k: λ_k(ω) = a_k(ω) / Σ(ω).
    #[inline]
    pub fn lambda(&self, k: usize, w: Vec3) -> f32 {
        let s = self.sigma(w);
        if s > 0.0 {
            self.proj_area(k, w) / s
        } else {
            0.0
        }
    }

    /// Choose the facet hit by a ray arriving from ω (∝ a_k(ω)) with `u ∈ [0,1)`; returns the
    /// facet and its probability. `None` when no facet faces ω.
    #[inline]
    pub fn pick(&self, w: Vec3, u: f32) -> Option<(usize, f32)> {
        let s = self.sigma(w);
        if s <= 0.0 {
            return None;
        }
        let target = u * s;
        let mut acc = 0.0;
        let mut last = None;
        for k in 0..self.n {
            let a = self.proj_area(k, w);
            if a <= 0.0 {
                continue;
            }
            acc += a;
            last = Some((k, a / s));
            if target < acc {
                return last;
            }
        }
        last
    }
}

/// The perturbed normal used by microfacet normal mapping: `n` (from the normal map, in the
/// shading frame) normalised, with its tilt clamped to `max_theta` (radians) and a normal below
/// the horizon clamped as well (decisions page: `max_theta`, default 85°). [`MaxTilt::clamp`]
/// with the cosine and sine of `max_theta` computed here.
pub fn clamp_perturbed_normal(n: Vec3, max_theta: f32) -> Vec3 {
    MaxTilt::new(max_theta).clamp(n)
}

/// The largest tilt `max_theta` of the perturbed normal (radians) with its cosine and sine
/// computed once (a material's setting: the per-hit clamp, [`Self::clamp`], then makes no
/// `cos`/`sin` call).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MaxTilt {
    radians: f32,
    cos: f32,
    sin: f32,
}

impl MaxTilt {
    pub fn new(radians: f32) -> Self {
        MaxTilt {
            radians,
            cos: radians.cos(),
            sin: radians.sin(),
        }
    }

    /// The tilt in radians.
    #[inline]
    pub fn radians(&self) -> f32 {
        self.radians
    }

    /// [`clamp_perturbed_normal`] of `n` for this tilt, bit for bit.
    #[inline]
    pub fn clamp(&self, n: Vec3) -> Vec3 {
        let Some(n) = n.try_normalize() else {
            return Vec3::Z;
        };
        let cos_min = self.cos;
        if n.z >= cos_min {
            return n;
        }
        let h = Vec3::new(n.x, n.y, 0.0);
        match h.try_normalize() {
            Some(h) => h * self.sin + Vec3::Z * cos_min,
            None => Vec3::Z, // straight down: no meaningful tilt direction
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::warp::square_to_uniform_sphere;
    use crate::math::Pcg32;
    use glam::Vec2;

    fn random_wp(r: &mut Pcg32, max_theta_deg: f32) -> Vec3 {
        let theta = r.next_f32() * max_theta_deg.to_radians();
        let phi = r.next_f32() * std::f32::consts::TAU;
        Vec3::new(
            theta.sin() * phi.cos(),
            theta.sin() * phi.sin(),
            theta.cos(),
        )
    }

    fn geometries() -> [Microgeometry; 5] {
        [
            Microgeometry::Sawtooth,
            Microgeometry::VGroove,
            Microgeometry::UGroove { fill: 0.25 },
            Microgeometry::UGroove { fill: 0.5 },
            Microgeometry::UGroove { fill: 1.0 },
        ]
    }

    /// Oracle 1 (closure): Σ A_k (ω·m_k) = z(ω) for every ω; λ sums to 1; 0 ≤ G1 ≤ 1; G1 = 1
    /// when every facet faces ω; no NaN for θp up to 85°.
    #[test]
    fn closure_lambda_and_masking_bounds() {
        let mut r = Pcg32::new(1, 1);
        for g in geometries() {
            for _ in 0..2000 {
                let wp = random_wp(&mut r, 85.0);
                let s = Microsurface::new(g, wp);
                let sum: Vec3 = (0..s.len()).map(|k| s.area_vector(k)).sum();
                assert!((sum - Vec3::Z).length() < 1e-4, "{g:?} {wp} {sum}");
                let w = square_to_uniform_sphere(Vec2::new(r.next_f32(), r.next_f32()));
                let signed: f32 = (0..s.len()).map(|k| w.dot(s.area_vector(k))).sum();
                assert!((signed - w.z).abs() < 1e-4);
                let g1 = s.g1(w);
                assert!(g1.is_finite() && (0.0..=1.0).contains(&g1));
                if w.z > 0.0 {
                    let l: f32 = (0..s.len()).map(|k| s.lambda(k, w)).sum();
                    assert!((l - 1.0).abs() < 1e-5);
                    assert!(s.sigma(w) >= w.z * (1.0 - 1e-5));
                    if (0..s.len()).all(|k| w.dot(s.normal(k)) > 0.0) {
                        assert!((g1 - 1.0).abs() < 1e-4, "{g:?} all facets face ω: G1 {g1}");
                    }
                } else {
                    assert_eq!(g1, 0.0);
                }
            }
        }
    }

    /// The sawtooth's masking equals the reference form min(1, z·cosθp/(⟨ω,ωp⟩ + ⟨ω,ωt⟩ sinθp)).
    #[test]
    fn sawtooth_masking_matches_the_reference_form() {
        let mut r = Pcg32::new(2, 1);
        for _ in 0..2000 {
            let wp = random_wp(&mut r, 80.0);
            let s = Microsurface::new(Microgeometry::Sawtooth, wp);
            let w = square_to_uniform_sphere(Vec2::new(r.next_f32(), r.next_f32()));
            if w.z <= 0.0 || wp.z > 0.9999 {
                continue;
            }
            let sin_p = (1.0 - wp.z * wp.z).sqrt();
            let wt = Vec3::new(-wp.x, -wp.y, 0.0) / sin_p;
            let denom = w.dot(wp).max(0.0) + w.dot(wt).max(0.0) * sin_p;
            let reference = (w.z * wp.z / denom).min(1.0);
            assert!(
                (s.g1(w) - reference).abs() < 1e-4,
                "{} vs {reference}",
                s.g1(w)
            );
        }
    }

    /// V-groove, in-plane directions: Torrance–Sparrow masking min(1, 2 cosθp cosθω / (ω·m)) for
    /// the facet facing away (§10.2).
    #[test]
    fn vgroove_matches_torrance_sparrow_in_plane() {
        let tp = 40f32.to_radians();
        let wp = Vec3::new(tp.sin(), 0.0, tp.cos());
        let s = Microsurface::new(Microgeometry::VGroove, wp);
        for deg in [-80.0f32, -60.0, -30.0, 0.0, 20.0, 55.0, 75.0] {
            let t = deg.to_radians();
            let w = Vec3::new(t.sin(), 0.0, t.cos());
            let ts = (0..2)
                .map(|k| {
                    let m = s.normal(k);
                    if w.dot(m) > 0.0 {
                        (2.0 * m.z * w.z / w.dot(m)).min(1.0)
                    } else {
                        1.0
                    }
                })
                .fold(1.0f32, f32::min);
            assert!((s.g1(w) - ts).abs() < 1e-5, "θ {deg}: {} vs {ts}", s.g1(w));
        }
    }

    #[test]
    fn flat_normal_leaves_a_single_flat_facet() {
        for g in geometries() {
            let s = Microsurface::new(g, Vec3::Z);
            let sum: Vec3 = (0..s.len()).map(|k| s.area_vector(k)).sum();
            assert!((sum - Vec3::Z).length() < 1e-6);
            assert!((0..s.len()).all(|k| (s.normal(k) - Vec3::Z).length() < 1e-6));
            assert_eq!(s.g1(Vec3::new(0.6, 0.0, 0.8)), 1.0);
        }
    }

    #[test]
    fn pick_follows_projected_areas() {
        let wp = Vec3::new(0.5, 0.2, 0.8).normalize();
        let s = Microsurface::new(Microgeometry::UGroove { fill: 0.5 }, wp);
        let w = Vec3::new(-0.3, 0.1, 0.9).normalize();
        let n = 30_000;
        let mut counts = [0usize; MAX_FACETS];
        for i in 0..n {
            let (k, p) = s.pick(w, (i as f32 + 0.5) / n as f32).unwrap();
            assert!((p - s.lambda(k, w)).abs() < 1e-6);
            counts[k] += 1;
        }
        for (k, &c) in counts.iter().enumerate().take(s.len()) {
            assert!((c as f32 / n as f32 - s.lambda(k, w)).abs() < 1e-3);
        }
    }

    #[test]
    fn perturbed_normal_clamp() {
        let mt = 85f32.to_radians();
        let n = clamp_perturbed_normal(Vec3::new(1.0, 0.0, 0.01), mt);
        assert!((n.z - mt.cos()).abs() < 1e-5 && (n.length() - 1.0).abs() < 1e-5);
        let below = clamp_perturbed_normal(Vec3::new(0.0, 1.0, -0.5), mt);
        assert!((below.z - mt.cos()).abs() < 1e-5 && below.y > 0.0);
        let ok = Vec3::new(0.3, 0.0, 0.9).normalize();
        assert_eq!(clamp_perturbed_normal(ok, mt), ok);
        assert_eq!(clamp_perturbed_normal(Vec3::ZERO, mt), Vec3::Z);
    }
}
