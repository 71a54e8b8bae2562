//! The misplaced-energy table M(θp) of `evaluation = auto` (issue 17 item 5; design
//! `shared/spec/mnm_fast.md` §4.4, re-derived; the measured tables are in `docs/mnm.md`).
//!
//! **Definition.** Fix a nested BSDF, microsurface and tilt θp, and an incident ωi. Cut the ωo
//! hemisphere into [`CELLS_U`] × [`CELLS_PHI`] cells uniform in u = cos²θ and φ (each holds
//! 1/128 of the projected solid angle, since (1/π) z dω = du dφ/2π). Let W(c) be the energy the
//! walk reflects into cell c and C(c) the compensated model's. Both models share the first
//! order exactly (explicit4's four paths, or single scattering, equal to the walk's one-vertex
//! paths per cell: `tests/bsdf/mnm_first_order.rs`), so only the paths with ≥ 2 non-delta
//! vertices are compared: Δ(c) = C(c) − W(c) of the remainders. The misplaced energy at ωi is
//!
//!   m(ωi) = max(Σ_c Δ⁺(c), Σ_c Δ⁻(c)) = ½ (Σ_c |Δ(c)| + |Σ_c Δ(c)|),
//!
//! the least energy that must be moved, added or removed to turn the compensated lobe into the
//! walk's (energy misplaced by x counts x; an albedo off by δ counts δ). M(θp) = Σ_i m(ωi) /
//! Σ_i E_walk(ωi) over [`WI`] incident directions stratified in (u, φ): the share of the walk's
//! reflected energy (all orders) that the compensated model puts elsewhere under uniform
//! illumination. Per colour channel; the table keeps the largest. Why this metric: it is in
//! units of the quantity the threshold speaks of (a share of the albedo), it counts both
//! misplacement and gain/loss, it needs no query direction at run time (a function of θp only),
//! and it is zero exactly when the two lobes agree cell by cell.
//!
//! **Estimate.** W(c) from N walks of groove's own walk (`walk::sample_counted`, the table's
//! `max_order`); C(c) by 3 × 3-point quadrature of the rank-1 remainder per cell (deterministic).
//! The walk's noise biases Σ|Δ| upward by E Σ|n(c)|; it is removed with a split-half estimate:
//! with a, b the two halves' histograms, ½ Σ|a − b| has the expectation of Σ|n(c)| when the
//! noise is Gaussian (a − b has twice the standard deviation of the full estimate's noise, and
//! E|X| = σ√(2/π)). The same correction is applied to |ΣΔ|; the result is clamped at 0. The
//! correction is exact when |Δ(c)| ≫ σ(c) or |Δ(c)| ≪ σ(c) and underestimates in between by at
//! most the noise floor, which is reported ([`Misplaced::floor`]).
//!
//! **Points.** θp at the table's nodes and the midpoints between them (where the table's θp
//! interpolation errs most), [`N_POINTS`] in all; θp = 0 is exact (the nested BSDF itself).
//! Between points M is interpolated linearly in θp (by cos θp within a point interval).
//!
//! **Blend.** β(M) = clamp((`HI` − M)/(`HI` − `LO`), 0, 1) with [`LO`] = 2 %, [`HI`] = 4 %: the
//! compensated model where M ≤ 2 %, the walk where M ≥ 4 %, the mixture β f_comp + (1 − β) f_walk
//! in between (eval: one model picked with probability β, an unbiased estimate of the mixture;
//! pdf: the mixture's), so a texel's BSDF changes continuously with θp. The mixture's own misplaced energy
//! is β M ≤ 2 % everywhere (β M = (HI − M) M/(HI − LO) is largest at M = LO).

use super::ms_table::{MsTable, N_THETA};
use super::walk;
use crate::bsdf::{Bsdf, BsdfContext, TransportMode};
use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use glam::{DVec3, Vec3};
use rayon::prelude::*;

/// Cells in u = cos²θ of the ωo histogram.
pub const CELLS_U: usize = 8;
/// Cells in φ (over [0, 2π)) of the ωo histogram.
pub const CELLS_PHI: usize = 16;
const CELLS: usize = CELLS_U * CELLS_PHI;
/// Incident directions per θp point (4 strata in u × 2 in φ ∈ [0, π], jittered; the
/// microsurface is mirror-symmetric about the plane of ωg and ωp).
pub const WI: usize = 8;
/// Walks per incident direction.
pub const WALKS: u32 = 8192;
/// θp points: the table's nodes and the midpoints between them.
pub const N_POINTS: usize = 2 * (N_THETA - 1) + 1;
/// Below this M the compensated model alone evaluates.
pub const LO: f32 = 0.02;
/// Above this M the walk alone evaluates.
pub const HI: f32 = 0.04;
/// Version of the measurement (part of the cache key).
pub const VERSION: u32 = 1;

/// M(θp) of one table (module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct Misplaced {
    /// cos θp of the points (decreasing; point 0 is θp = 0).
    cos: [f32; N_POINTS],
    /// M at the points.
    pub m: [f32; N_POINTS],
    /// The largest m(ωi)/E_walk(ωi) over the incident directions of each point.
    pub worst: [f32; N_POINTS],
    /// The subtracted noise floor, relative like M.
    pub floor: [f32; N_POINTS],
    /// Seconds the measurement took (0 when read from disk or exact).
    pub build_seconds: f32,
}

/// θp of point q (radians).
pub fn theta_point(q: usize, max_theta: f32) -> f32 {
    max_theta * q as f32 / (N_POINTS - 1) as f32
}

/// β of a misplaced energy M (module doc).
#[inline]
pub fn blend(m: f32) -> f32 {
    ((HI - m) / (HI - LO)).clamp(0.0, 1.0)
}

impl Misplaced {
    fn with(max_theta: f32, m: [f32; N_POINTS]) -> Misplaced {
        Misplaced {
            cos: std::array::from_fn(|q| theta_point(q, max_theta).cos()),
            m,
            worst: m,
            floor: [0.0; N_POINTS],
            build_seconds: 0.0,
        }
    }

    /// M = 0 everywhere: for a table the model reproduces exactly (the mirror sawtooth over a
    /// Lambertian, where the remainder is the constant rank-1 cos θp q/(1 − q) lobe of §2.2).
    pub fn exact(max_theta: f32) -> Misplaced {
        Misplaced::with(max_theta, [0.0; N_POINTS])
    }

    /// M at a shading point of cos θp = `cos_tp`, linear in cos θp between the points.
    pub fn at(&self, cos_tp: f32) -> f32 {
        let mut q = 0;
        while q + 2 < N_POINTS && cos_tp < self.cos[q + 1] {
            q += 1;
        }
        let (c0, c1) = (self.cos[q], self.cos[q + 1]);
        let t = ((c0 - cos_tp) / (c0 - c1)).clamp(0.0, 1.0);
        (1.0 - t) * self.m[q] + t * self.m[q + 1]
    }

    /// Measure M for `table` against the walk over `nested` (node `nested_index` of its arena),
    /// `walks` walks per incident direction, fixed seeds, rayon over (θp point, ωi).
    pub fn measure(nested: &Bsdf, nested_index: u32, table: &MsTable, walks: u32) -> Misplaced {
        let t0 = std::time::Instant::now();
        let spec = table.spec;
        let tasks: Vec<(usize, usize)> = (1..N_POINTS)
            .flat_map(|q| (0..WI).map(move |i| (q, i)))
            .collect();
        let per: Vec<(usize, PerWi)> = tasks
            .into_par_iter()
            .map(|(q, i)| {
                let tp = theta_point(q, spec.max_theta);
                let wp = Vec3::new(tp.sin(), 0.0, tp.cos());
                let stream = (q * WI + i) as u64;
                (q, per_wi(nested, nested_index, table, wp, stream, i, walks))
            })
            .collect();
        let mut out = Misplaced::with(spec.max_theta, [0.0; N_POINTS]);
        let mut num = [DVec3::ZERO; N_POINTS];
        let mut den = [DVec3::ZERO; N_POINTS];
        let mut fl = [DVec3::ZERO; N_POINTS];
        for (q, r) in per {
            num[q] += r.misplaced;
            den[q] += r.albedo;
            fl[q] += r.floor;
            let worst = max_ratio(r.misplaced, r.albedo);
            out.worst[q] = out.worst[q].max(worst);
        }
        for q in 1..N_POINTS {
            out.m[q] = max_ratio(num[q], den[q]);
            out.floor[q] = max_ratio(fl[q], den[q]);
        }
        out.build_seconds = t0.elapsed().as_secs_f32();
        out
    }

    /// M, the worst ωi and the noise floor at one tilt `theta_p` (radians) from `walks` walks
    /// per incident direction and stream `seed` (checks between the points: an independent
    /// estimate of what [`Self::at`] interpolates).
    pub fn measure_at(
        nested: &Bsdf,
        nested_index: u32,
        table: &MsTable,
        theta_p: f32,
        walks: u32,
        seed: u64,
    ) -> (f32, f32, f32) {
        let wp = Vec3::new(theta_p.sin(), 0.0, theta_p.cos());
        let per: Vec<PerWi> = (0..WI)
            .into_par_iter()
            .map(|i| {
                let stream = (seed << 8) | i as u64;
                per_wi(nested, nested_index, table, wp, stream, i, walks)
            })
            .collect();
        let (mut num, mut den, mut fl, mut worst) = (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, 0f32);
        for r in &per {
            num += r.misplaced;
            den += r.albedo;
            fl += r.floor;
            worst = worst.max(max_ratio(r.misplaced, r.albedo));
        }
        (max_ratio(num, den), worst, max_ratio(fl, den))
    }

    /// Bytes for the disk cache: the key, then cos, m, worst, floor (little-endian f32).
    pub fn to_bytes(&self, key: &str) -> Vec<u8> {
        let mut out = Vec::with_capacity(MAGIC.len() + 4 + key.len() + 16 * N_POINTS);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&(key.len() as u32).to_le_bytes());
        out.extend_from_slice(key.as_bytes());
        for a in [&self.cos, &self.m, &self.worst, &self.floor] {
            for x in a {
                out.extend_from_slice(&x.to_le_bytes());
            }
        }
        out
    }

    /// Read back [`Self::to_bytes`] of exactly `key` (anything else is `None`).
    pub fn from_bytes(bytes: &[u8], key: &str) -> Option<Misplaced> {
        let head = MAGIC.len() + 4 + key.len();
        if bytes.len() != head + 16 * N_POINTS || !bytes.starts_with(MAGIC) {
            return None;
        }
        let len = u32::from_le_bytes(bytes[MAGIC.len()..MAGIC.len() + 4].try_into().ok()?);
        if len as usize != key.len() || &bytes[MAGIC.len() + 4..head] != key.as_bytes() {
            return None;
        }
        let f: Vec<f32> = bytes[head..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
            .collect();
        if !f.iter().all(|x| x.is_finite()) {
            return None;
        }
        let arr = |k: usize| -> [f32; N_POINTS] { std::array::from_fn(|q| f[k * N_POINTS + q]) };
        Some(Misplaced {
            cos: arr(0),
            m: arr(1),
            worst: arr(2),
            floor: arr(3),
            build_seconds: 0.0,
        })
    }
}

const MAGIC: &[u8] = b"groove-ms-misplaced\n";

/// The largest channel of a / b (0 where b = 0).
fn max_ratio(a: DVec3, b: DVec3) -> f32 {
    let r = |x: f64, y: f64| if y > 0.0 { x / y } else { 0.0 };
    r(a.x, b.x).max(r(a.y, b.y)).max(r(a.z, b.z)) as f32
}

/// One incident direction: the corrected misplaced energy, the walk's albedo, the floor.
struct PerWi {
    misplaced: DVec3,
    albedo: DVec3,
    floor: DVec3,
}

/// The ωo cell of a direction (z > 0).
#[inline]
fn cell_of(w: Vec3) -> usize {
    let u = (w.z * w.z).clamp(0.0, 1.0);
    let iu = ((u * CELLS_U as f32) as usize).min(CELLS_U - 1);
    let mut phi = w.y.atan2(w.x);
    if phi < 0.0 {
        phi += std::f32::consts::TAU;
    }
    let ip = ((phi / std::f32::consts::TAU * CELLS_PHI as f32) as usize).min(CELLS_PHI - 1);
    iu * CELLS_PHI + ip
}

/// The direction at (u, φ).
fn direction(u: f32, phi: f32) -> Vec3 {
    let z = u.clamp(1e-4, 1.0).sqrt();
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// m(ωi) for incident direction stratum i at tilt ωp = `wp` (module doc), random numbers from
/// `stream`.
fn per_wi(
    nested: &Bsdf,
    nested_index: u32,
    table: &MsTable,
    wp: Vec3,
    stream: u64,
    i: usize,
    walks: u32,
) -> PerWi {
    let spec = table.spec;
    let ctx = BsdfContext {
        mode: TransportMode::Radiance,
    };
    let mut s = Sampler::from_seed(0x6d6d_6973 ^ VERSION as u64, stream);
    let j = s.next_2d();
    let u = ((i % 4) as f32 + j.x) / 4.0;
    let phi = ((i / 4) as f32 + j.y) / 2.0 * std::f32::consts::PI;
    let wi = direction(u, phi);
    // The compensated remainder per cell, white (c = 1: a per-bounce table's largest remainder;
    // a baked table's own colours).
    let cell = table.cell(wp);
    let k = table.coefficients(&cell, Spectrum::ONE);
    let ei = MsTable::remainder(&table.lookup(&cell, wi), &k).as_dvec3();
    let ebar = table.mean_remainder(&cell, &k).as_dvec3();
    let scale = DVec3::select(ebar.cmpgt(DVec3::ZERO), ei / ebar, DVec3::ZERO);
    let mut comp = [DVec3::ZERO; CELLS];
    for (c, v) in comp.iter_mut().enumerate() {
        let (iu, ip) = (c / CELLS_PHI, c % CELLS_PHI);
        let mut acc = DVec3::ZERO;
        for a in 0..3 {
            for b in 0..3 {
                let u = (iu as f32 + (a as f32 + 0.5) / 3.0) / CELLS_U as f32;
                let phi =
                    (ip as f32 + (b as f32 + 0.5) / 3.0) / CELLS_PHI as f32 * std::f32::consts::TAU;
                let wo = direction(u, phi);
                acc += MsTable::remainder(&table.lookup(&cell, wo), &k).as_dvec3();
            }
        }
        // ∫_cell E_ms(ωo) du dφ/2π: the cell's measure is 1/CELLS.
        *v = scale * acc / (9.0 * CELLS as f64);
    }
    // The walk's remainder per cell, in two halves.
    let m = spec.walk(nested_index, wp);
    let mut half = [[DVec3::ZERO; CELLS]; 2];
    let mut albedo = DVec3::ZERO;
    for n in 0..walks {
        if let Some(r) = walk::sample_counted(&m, nested, &ctx, wi, &mut s) {
            let w = r.weight.as_dvec3();
            albedo += w;
            if r.nested_vertices >= 2 && r.wo.z > 0.0 {
                half[(n & 1) as usize][cell_of(r.wo)] += w;
            }
        }
    }
    let inv = 1.0 / walks as f64;
    let (mut l1, mut sum, mut split, mut split_sum) =
        (DVec3::ZERO, DVec3::ZERO, DVec3::ZERO, DVec3::ZERO);
    for c in 0..CELLS {
        let (a, b) = (half[0][c] * 2.0 * inv, half[1][c] * 2.0 * inv);
        let d = comp[c] - (a + b) * 0.5;
        l1 += d.abs();
        sum += d;
        split += (a - b).abs() * 0.5;
        split_sum += (a - b) * 0.5;
    }
    let floor = (split + split_sum.abs()) * 0.5;
    PerWi {
        misplaced: ((l1 + sum.abs()) * 0.5 - floor).max(DVec3::ZERO),
        albedo: albedo * inv,
        floor,
    }
}
