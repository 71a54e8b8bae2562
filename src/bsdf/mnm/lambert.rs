//! Exact closed forms of the full random walk ([`super::walk`]) when the nested BSDF is
//! Lambertian (`diffuse`, also as the front of a `twosided`): a Lambertian vertex forgets its
//! incidence, so the walk is a finite Markov chain over the facets (issue 17 item 1; derivations
//! in `shared/spec/mnm_fast.md` §2.2, re-derived below). Eval is deterministic and consumes no
//! random numbers; sampling is exact (weight = eval/pdf).
//!
//! - **Sawtooth, mirror wall.** Every p-vertex sends light out with the density
//!   cosθp·z(ωo)/π whatever its incidence (direct exit G1(ωo)⟨ωo,ωp⟩/π plus the exit through the
//!   wall, (1 − G1(Rωo))⟨Rωo,ωp⟩ = sinθp⟨ωo,ωt⟩; their sum is cosθp Σ(ωo) G1(ωo)/π), and every
//!   entry reaches p. So the return probability is 1 − cosθp and the walk is exactly Lambertian,
//!   f = ρ_eff/π with ρ_eff = ρ cosθp / (1 − ρ(1 − cosθp)) per channel. Sampled by a cosine lobe
//!   about ωg (weight ρ_eff).
//! - **Facet chains** (sawtooth with `tangent = same`, V-groove, U-groove): with e_j the escape
//!   probability and Q_jk the transfer probability of a cosine-distributed ray leaving facet j,
//!   and N = (I − ρQ)⁻¹ (expected visits), f·z(ωo) = (1/π) G1(ωo) Σ_k w_k(ωi) ⟨ωo,m_k⟩⁺ with
//!   w_k(ωi) = ρ Σ_j λ_j(ωi) N_jk. Reciprocal because A_j Q_jk = A_k Q_kj (closure gives
//!   Σ(ω) − z(ω) = Σ(−ω), which makes the Smith transfer symmetric). Sampled by choosing facet k
//!   with probability ∝ luminance(w_k)·e_k (the energy its lobe sends out), then a cosine lobe
//!   about m_k; pdf = Σ_k π_k ⟨ωo,m_k⟩⁺/π; a direction below the macro surface is a failed
//!   sample.
//!
//! e_j and Q_jk: every facet normal lies in the plane of ωg and ωp, so the integrands depend on a
//! direction only through its projection on that plane; integrating the other coordinate out
//! (on the sphere, dA = dφ dy about the plane's normal) turns ∫⟨d,m⟩⁺/π·g dd into the flatland
//! integral ½∫ ⟨u,m⟩⁺ g(u) dφ over unit vectors u of the plane. There:
//! - sawtooth: e_p = (1 − sinθp + cosθp)/2, e_t = (1 − sinθp + cotθp(1 − cosθp))/2 (the spec's
//!   forms, re-derived; G1 = 1 where both facets face u);
//! - V-groove: e = cosθp on both facets;
//! - U-groove: e_j from the primitive of (a·u)(z·u)/(b·u) on each interval where the set of
//!   facets facing u is fixed ([`escape_2d`]; a logarithm appears, a few hundred ns per hit);
//! - Q from e by the reciprocity above and the row sums Σ_k Q_jk = 1 − e_j (a facet does not
//!   see itself): two facets Q_12 = 1 − e_1; three facets A_j Q_jk = (A_j q_j + A_k q_k − A_l q_l)/2
//!   with q = 1 − e. Tested against 3-D quadrature of the definitions (unit tests below).
//!
//! The walk stops after `max_order` vertices and the closed forms sum all orders: they are used
//! only when the energy the truncation drops is at most [`TRUNCATION_TOL`] (always at the
//! default 256 for ρ ≤ 1 and θp ≤ 85°), and otherwise the walk runs. `lambert_closed_form =
//! false` (XML, [`super::MicrofacetNormalMap::with_lambert_closed_form`]) keeps the walk, for the
//! tests that compare the two.

// Small matrices over facets: the index loops mirror the formulas (N_jk, Q_jk).
#![allow(clippy::needless_range_loop)]

use super::facets::{Microgeometry, Microsurface, MAX_FACETS};
use super::MicrofacetNormalMap;
use crate::math::{warp, INV_PI};
use crate::sampler::Sampler;
use crate::spectrum::{luminance, max_component, Spectrum};
use glam::{Vec2, Vec3};

/// Largest energy (albedo units) the walk's `max_order` truncation may drop for the closed form
/// to stand in for it.
pub const TRUNCATION_TOL: f32 = 1e-3;

/// The closed form of one shading point (plain values, built with the BSDF per hit).
#[derive(Clone, Copy, Debug)]
pub enum LambertForm {
    /// Mirror sawtooth: f = ρ_eff / π.
    Uniform { rho_eff: Spectrum },
    /// Facet chain: `w[j][k]` = ρ N_jk, `e` the escape probabilities.
    Chain {
        n: usize,
        w: [[Spectrum; MAX_FACETS]; MAX_FACETS],
        e: [f32; MAX_FACETS],
    },
}

/// Escape probabilities e_j and transfer probabilities Q_jk of cosine-distributed rays leaving
/// each facet (geometry only; see the module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FacetChain {
    pub n: usize,
    pub e: [f32; MAX_FACETS],
    pub q: [[f32; MAX_FACETS]; MAX_FACETS],
}

impl FacetChain {
    /// The chain of `surface` (built by `geometry` from `wp`, not flat, all facets Lambertian).
    pub fn new(geometry: Microgeometry, wp: Vec3, surface: &Microsurface) -> FacetChain {
        let n = surface.len();
        // In f64, and as q = 1 − e directly: at small tilts q is small and 1 − e would lose it
        // (reciprocity A_j Q_jk = A_k Q_kj then breaks by ~1e-7/sinθp).
        let c = wp.z as f64;
        let s = (1.0 - c * c).max(0.0).sqrt();
        let mut r = [0.0f64; MAX_FACETS];
        match geometry {
            Microgeometry::Sawtooth if n == 2 => {
                // 1 − cosθp = sin²θp / (1 + cosθp); cotθp (1 − cosθp) = cosθp sinθp / (1 + cosθp).
                r[0] = 0.5 * (s + s * s / (1.0 + c));
                r[1] = 0.5 * (1.0 + s - c * s / (1.0 + c));
            }
            Microgeometry::VGroove if n == 2 => {
                r[0] = s * s / (1.0 + c);
                r[1] = r[0];
            }
            _ => {
                let e2 = escape_2d(surface, wp);
                for k in 0..n {
                    r[k] = (1.0 - e2[k]).max(0.0);
                }
            }
        }
        let e: [f32; MAX_FACETS] =
            std::array::from_fn(|k| if k < n { (1.0 - r[k]) as f32 } else { 0.0 });
        let mut q = [[0.0; MAX_FACETS]; MAX_FACETS];
        let a: [f64; MAX_FACETS] =
            std::array::from_fn(|k| surface.area_vector(k).as_dvec3().length());
        match n {
            2 => {
                q[0][1] = r[0] as f32;
                q[1][0] = r[1] as f32;
            }
            3 => {
                for j in 0..3 {
                    for k in 0..3 {
                        if j != k {
                            let l = 3 - j - k;
                            let aq = 0.5 * (a[j] * r[j] + a[k] * r[k] - a[l] * r[l]);
                            q[j][k] = (aq / a[j]).max(0.0) as f32;
                        }
                    }
                }
            }
            _ => {}
        }
        FacetChain { n, e, q }
    }
}

impl LambertForm {
    /// The closed form of `m` over a Lambertian of albedo `rho`, or `None` when the walk must
    /// run: not the random walk (or `compensated`, which approximates it), no named microgeometry, closed form switched off, ρ not finite
    /// and non-negative, or the walk's truncation at `max_order` dropping more than
    /// [`TRUNCATION_TOL`].
    pub fn new(m: &MicrofacetNormalMap, rho: Spectrum) -> Option<LambertForm> {
        let geometry = m.geometry?;
        let full_walk = matches!(
            m.evaluation,
            super::Evaluation::RandomWalk
                | super::Evaluation::Compensated
                | super::Evaluation::Auto
        );
        if !full_walk || m.degenerate || !m.lambert_closed_form {
            return None;
        }
        if !(rho.min_element() >= 0.0 && rho.is_finite()) {
            return None;
        }
        let rmax = max_component(rho);
        let order = m.max_order as i32;
        if m.mirror_wall {
            let c = m.wp.z;
            let q = 1.0 - c;
            // Paths with n p-vertices have at most 2n + 1 vertices (entry and exit through the
            // wall): all of them are complete for n ≤ (max_order − 1)/2.
            let complete = (order - 1) / 2;
            if !tail_is_small(rmax, q, complete) {
                return None;
            }
            return Some(LambertForm::Uniform {
                rho_eff: rho * c / (Spectrum::ONE - rho * q),
            });
        }
        let chain = FacetChain::new(geometry, m.wp, &m.surface);
        let qmax = (0..chain.n)
            .map(|k| chain.q[k].iter().sum::<f32>())
            .fold(0.0, f32::max);
        if chain.n < 2 || !tail_is_small(rmax, qmax, order) {
            return None;
        }
        let w = visits(&chain, rho);
        Some(LambertForm::Chain {
            n: chain.n,
            w,
            e: chain.e,
        })
    }

    /// The per-facet weights w_k(ωi) = Σ_j λ_j(ωi) W_jk and the sampling probabilities π_k.
    #[inline]
    fn weights(
        n: usize,
        w: &[[Spectrum; MAX_FACETS]; MAX_FACETS],
        e: &[f32; MAX_FACETS],
        surf: &Microsurface,
        wi: Vec3,
    ) -> ([Spectrum; MAX_FACETS], [f32; MAX_FACETS]) {
        let l = surf.lambdas(wi);
        let mut wk = [Spectrum::ZERO; MAX_FACETS];
        for (j, &lj) in l.iter().enumerate().take(n) {
            if lj > 0.0 {
                for k in 0..n {
                    wk[k] += lj * w[j][k];
                }
            }
        }
        let mut pk = [0.0; MAX_FACETS];
        let mut total = 0.0;
        for k in 0..n {
            pk[k] = luminance(wk[k]).max(0.0) * e[k];
            total += pk[k];
        }
        if total > 0.0 {
            for p in pk.iter_mut().take(n) {
                *p /= total;
            }
        }
        (wk, pk)
    }

    /// f·z(ωo) (ωi, ωo above the macro surface).
    #[inline]
    pub fn eval(&self, m: &MicrofacetNormalMap, wi: Vec3, wo: Vec3) -> Spectrum {
        match self {
            LambertForm::Uniform { rho_eff } => *rho_eff * (wo.z * INV_PI),
            LambertForm::Chain { n, w, e } => {
                let (wk, _) = Self::weights(*n, w, e, &m.surface, wi);
                chain_f(*n, &wk, &m.surface, wo)
            }
        }
    }

    /// Density of [`Self::sample`].
    #[inline]
    pub fn pdf(&self, m: &MicrofacetNormalMap, wi: Vec3, wo: Vec3) -> f32 {
        match self {
            LambertForm::Uniform { .. } => wo.z * INV_PI,
            LambertForm::Chain { n, w, e } => {
                let (_, pk) = Self::weights(*n, w, e, &m.surface, wi);
                chain_pdf(*n, &pk, &m.surface, wo)
            }
        }
    }

    /// (f·z(ωo), pdf) in one pass.
    #[inline]
    pub fn eval_pdf(&self, m: &MicrofacetNormalMap, wi: Vec3, wo: Vec3) -> (Spectrum, f32) {
        match self {
            LambertForm::Uniform { rho_eff } => (*rho_eff * (wo.z * INV_PI), wo.z * INV_PI),
            LambertForm::Chain { n, w, e } => {
                let (wk, pk) = Self::weights(*n, w, e, &m.surface, wi);
                (
                    chain_f(*n, &wk, &m.surface, wo),
                    chain_pdf(*n, &pk, &m.surface, wo),
                )
            }
        }
    }

    /// Exact sample: (ωo, weight = eval/pdf, pdf).
    #[inline]
    pub fn sample(
        &self,
        m: &MicrofacetNormalMap,
        wi: Vec3,
        s: &mut Sampler,
    ) -> Option<(Vec3, Spectrum, f32)> {
        match self {
            LambertForm::Uniform { rho_eff } => {
                let wo = warp::square_to_cosine_hemisphere(s.next_2d());
                let pdf = wo.z * INV_PI;
                (pdf > 0.0).then_some((wo, *rho_eff, pdf))
            }
            LambertForm::Chain { n, w, e } => {
                let (wk, pk) = Self::weights(*n, w, e, &m.surface, wi);
                let u = s.next_1d();
                let uv: Vec2 = s.next_2d();
                let mut k = usize::MAX;
                let mut acc = 0.0;
                for (j, &p) in pk.iter().enumerate().take(*n) {
                    if p > 0.0 {
                        k = j;
                        acc += p;
                        if u < acc {
                            break;
                        }
                    }
                }
                if k == usize::MAX {
                    return None;
                }
                let wo = m.frames[k].to_world(warp::square_to_cosine_hemisphere(uv));
                if wo.z <= 0.0 {
                    return None;
                }
                let pdf = chain_pdf(*n, &pk, &m.surface, wo);
                if pdf.is_nan() || pdf <= 0.0 {
                    return None;
                }
                Some((wo, chain_f(*n, &wk, &m.surface, wo) / pdf, pdf))
            }
        }
    }
}

#[inline]
fn chain_f(n: usize, wk: &[Spectrum; MAX_FACETS], surf: &Microsurface, wo: Vec3) -> Spectrum {
    let g1 = surf.g1(wo);
    if g1 <= 0.0 {
        return Spectrum::ZERO;
    }
    let mut f = Spectrum::ZERO;
    for k in 0..n {
        let c = wo.dot(surf.normal(k));
        if c > 0.0 {
            f += c * wk[k];
        }
    }
    f * (g1 * INV_PI)
}

#[inline]
fn chain_pdf(n: usize, pk: &[f32; MAX_FACETS], surf: &Microsurface, wo: Vec3) -> f32 {
    if wo.z <= 0.0 {
        return 0.0;
    }
    let mut p = 0.0;
    for k in 0..n {
        p += pk[k] * wo.dot(surf.normal(k)).max(0.0);
    }
    p * INV_PI
}

/// Σ_{n > complete} ρ^n q^(n−1) ≤ [`TRUNCATION_TOL`]: the energy of the paths with more than
/// `complete` Lambertian vertices, which the truncated walk may drop.
fn tail_is_small(rho: f32, q: f32, complete: i32) -> bool {
    let rq = rho * q;
    if rq.is_nan() || rq >= 1.0 || complete < 1 {
        return false;
    }
    rho.powi(complete + 1) * q.powi(complete) / (1.0 - rq) <= TRUNCATION_TOL
}

/// W = ρ (I − ρQ)⁻¹ per channel (entries are spectra), by the adjugate.
fn visits(c: &FacetChain, rho: Spectrum) -> [[Spectrum; MAX_FACETS]; MAX_FACETS] {
    let one = Spectrum::ONE;
    let mut w = [[Spectrum::ZERO; MAX_FACETS]; MAX_FACETS];
    // M = I − ρQ.
    let mm = |j: usize, k: usize| {
        if j == k {
            one
        } else {
            -rho * c.q[j][k]
        }
    };
    match c.n {
        2 => {
            let det = one - rho * rho * (c.q[0][1] * c.q[1][0]);
            let inv = rho / det;
            w[0][0] = inv;
            w[1][1] = inv;
            w[0][1] = inv * rho * c.q[0][1];
            w[1][0] = inv * rho * c.q[1][0];
        }
        3 => {
            let cof = |j: usize, k: usize| {
                let (r0, r1) = ((j + 1) % 3, (j + 2) % 3);
                let (c0, c1) = ((k + 1) % 3, (k + 2) % 3);
                mm(r0, c0) * mm(r1, c1) - mm(r0, c1) * mm(r1, c0)
            };
            let det = mm(0, 0) * cof(0, 0) + mm(0, 1) * cof(0, 1) + mm(0, 2) * cof(0, 2);
            let scale = rho / det;
            for (j, row) in w.iter_mut().enumerate() {
                for (k, x) in row.iter_mut().enumerate() {
                    // (M⁻¹)_jk = cofactor_kj / det.
                    *x = cof(k, j) * scale;
                }
            }
        }
        _ => {}
    }
    w
}

/// Escape probability of a cosine-distributed ray leaving each facet, in flatland (module doc):
/// e_j = ½ ∫₀^π ⟨u,m_j⟩⁺ u_z / Σ(u) dφ, integrated exactly on each interval where the facets
/// facing u do not change (there Σ(u) = b·u). In f64: cancellations at small tilts.
pub fn escape_2d(surface: &Microsurface, wp: Vec3) -> [f64; MAX_FACETS] {
    let n = surface.len();
    let h = Vec3::new(wp.x, wp.y, 0.0).normalize_or_zero();
    let to2 = |v: Vec3| [v.dot(h) as f64, v.z as f64];
    let v2: [[f64; 2]; MAX_FACETS] = std::array::from_fn(|k| {
        if k < n {
            to2(surface.area_vector(k))
        } else {
            [0.0; 2]
        }
    });
    // Breakpoints: 0, π, and where u ⊥ v_k.
    let mut cuts = [0.0f64; MAX_FACETS + 2];
    let mut nc = 0;
    cuts[nc] = 0.0;
    nc += 1;
    cuts[nc] = std::f64::consts::PI;
    nc += 1;
    for v in v2.iter().take(n) {
        // u ⊥ v_k: u ∝ (v_z, −v_x) in (x, z), taken modulo π.
        let a = (-v[0]).atan2(v[1]).rem_euclid(std::f64::consts::PI);
        if a > 0.0 && a < std::f64::consts::PI {
            cuts[nc] = a;
            nc += 1;
        }
    }
    let cuts = &mut cuts[..nc];
    cuts.sort_by(|a, b| a.total_cmp(b));
    let mut e = [0.0f64; MAX_FACETS];
    for w in cuts.windows(2) {
        let (p0, p1) = (w[0], w[1]);
        if p1 - p0 < 1e-12 {
            continue;
        }
        let mid = 0.5 * (p0 + p1);
        let um = [mid.cos(), mid.sin()];
        let dot = |a: &[f64; 2], u: &[f64; 2]| a[0] * u[0] + a[1] * u[1];
        let mut b = [0.0f64; 2];
        for v in v2.iter().take(n) {
            if dot(v, &um) > 0.0 {
                b[0] += v[0];
                b[1] += v[1];
            }
        }
        let bl = (b[0] * b[0] + b[1] * b[1]).sqrt();
        if bl <= 0.0 {
            continue;
        }
        let bh = [b[0] / bl, b[1] / bl];
        let bp = [-bh[1], bh[0]];
        let u0 = [p0.cos(), p0.sin()];
        let u1 = [p1.cos(), p1.sin()];
        for (j, ej) in e.iter_mut().enumerate().take(n) {
            let vl = (v2[j][0] * v2[j][0] + v2[j][1] * v2[j][1]).sqrt();
            let a = [v2[j][0] / vl, v2[j][1] / vl];
            if dot(&a, &um) <= 0.0 {
                continue;
            }
            // ∫ (a·u)(z·u)/(b·u) dφ with ψ = φ − β: cosψ = b̂·u, sinψ = b̂⊥·u.
            let (ap, aq) = (dot(&a, &bh), dot(&a, &bp));
            let (zp, zq) = (bh[1], bp[1]);
            let prim = |u: &[f64; 2]| {
                let (cp, sp) = (dot(&bh, u), dot(&bp, u));
                (ap * zp - aq * zq) * sp - (ap * zq + aq * zp) * cp
                    + aq * zq * ((1.0 + sp) / cp).ln()
            };
            *ej += 0.5 * (prim(&u1) - prim(&u0)) / bl;
        }
    }
    e
}

#[cfg(test)]
mod tests {
    use super::*;

    fn wp_of(theta_deg: f32, phi_deg: f32) -> Vec3 {
        let (t, p) = (theta_deg.to_radians(), phi_deg.to_radians());
        Vec3::new(t.sin() * p.cos(), t.sin() * p.sin(), t.cos())
    }

    /// e_j and Q_jk by 3-D midpoint quadrature of their definitions (cosine-distributed rays
    /// leaving facet j in its own frame: escape with G1, else hit facet k ∝ a_k(−d)).
    fn quadrature(surf: &Microsurface) -> ([f64; 3], [[f64; 3]; 3]) {
        let (nt, np) = (1024, 2048);
        let mut e = [0.0; 3];
        let mut q = [[0.0; 3]; 3];
        for j in 0..surf.len() {
            let fr = crate::math::Frame::from_normal(surf.normal(j));
            for it in 0..nt {
                // Cosine-weighted in the facet frame: r = sqrt(u), uniform in u = sin²θ.
                let u = (it as f64 + 0.5) / nt as f64;
                let (st, ct) = (u.sqrt(), (1.0 - u).sqrt());
                for ip in 0..np {
                    let ph = (ip as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
                    let l = Vec3::new((st * ph.cos()) as f32, (st * ph.sin()) as f32, ct as f32);
                    let d = fr.to_world(l);
                    let w = 1.0 / (nt * np) as f64;
                    let g = surf.g1(d) as f64;
                    e[j] += w * g;
                    let lam = surf.lambdas(-d);
                    for k in 0..surf.len() {
                        q[j][k] += w * (1.0 - g) * lam[k] as f64;
                    }
                }
            }
        }
        (e, q)
    }

    #[test]
    fn chains_match_quadrature_of_their_definitions() {
        let geoms = [
            Microgeometry::Sawtooth,
            Microgeometry::VGroove,
            Microgeometry::UGroove { fill: 0.5 },
            Microgeometry::UGroove { fill: 0.2 },
            Microgeometry::UGroove { fill: 0.9 },
        ];
        for g in geoms {
            for tp in [3.0f32, 20.0, 45.0, 70.0, 85.0] {
                let wp = wp_of(tp, 37.0);
                let surf = Microsurface::new(g, wp);
                let c = FacetChain::new(g, wp, &surf);
                let (e, q) = quadrature(&surf);
                for j in 0..c.n {
                    assert!(
                        (c.e[j] as f64 - e[j]).abs() < 2e-4,
                        "{g:?} θp {tp}: e{j} {} vs quadrature {}",
                        c.e[j],
                        e[j]
                    );
                    for k in 0..c.n {
                        assert!(
                            (c.q[j][k] as f64 - q[j][k]).abs() < 2e-4,
                            "{g:?} θp {tp}: Q{j}{k} {} vs quadrature {}",
                            c.q[j][k],
                            q[j][k]
                        );
                    }
                }
            }
        }
    }

    /// The generic flatland integral reproduces the sawtooth's and V-groove's closed forms.
    #[test]
    fn flatland_escape_matches_the_closed_forms() {
        for tp in [0.5f32, 10.0, 30.0, 60.0, 85.0] {
            for g in [Microgeometry::Sawtooth, Microgeometry::VGroove] {
                let wp = wp_of(tp, 200.0);
                let surf = Microsurface::new(g, wp);
                let c = FacetChain::new(g, wp, &surf);
                let e2 = escape_2d(&surf, wp);
                for k in 0..2 {
                    assert!(
                        (c.e[k] as f64 - e2[k]).abs() < 1e-5,
                        "{g:?} θp {tp}: {} vs {}",
                        c.e[k],
                        e2[k]
                    );
                }
            }
        }
    }

    /// Reciprocity of the transfer (A_j Q_jk = A_k Q_kj) for the two-facet closed forms, and
    /// (I − ρQ) W = ρ I.
    #[test]
    fn transfer_is_reciprocal_and_visits_invert() {
        for tp in [5.0f32, 40.0, 80.0] {
            for g in [
                Microgeometry::Sawtooth,
                Microgeometry::VGroove,
                Microgeometry::UGroove { fill: 0.4 },
            ] {
                let wp = wp_of(tp, 0.0);
                let surf = Microsurface::new(g, wp);
                let c = FacetChain::new(g, wp, &surf);
                for j in 0..c.n {
                    for k in 0..c.n {
                        let aj = surf.area_vector(j).length();
                        let ak = surf.area_vector(k).length();
                        assert!((aj * c.q[j][k] - ak * c.q[k][j]).abs() < 1e-5);
                    }
                }
                let rho = Vec3::new(0.3, 0.8, 1.0);
                let w = visits(&c, rho);
                for j in 0..c.n {
                    for k in 0..c.n {
                        let mut s = w[j][k];
                        for l in 0..c.n {
                            s -= rho * c.q[j][l] * w[l][k];
                        }
                        let want = if j == k { rho } else { Vec3::ZERO };
                        assert!((s - want).abs().max_element() < 1e-5, "{g:?} {tp} {j}{k}");
                    }
                }
            }
        }
    }
}
