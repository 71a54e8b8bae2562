//! Per-order energy tables of the microsurface random walk, for `evaluation = compensated`
//! ([`super::compensated`]; issue 17 item 4, design `shared/spec/mnm_fast.md` §4.3).
//!
//! For one nested BSDF, microgeometry and wall, `W_n(θp; ω)` is the energy (albedo share) of the
//! walks from ω that scatter exactly n times on facets carrying the nested BSDF (mirror-wall
//! reflections are not counted), with colour multiplier 1 where the colour is applied at run time
//! ([`Colour::PerBounce`]). Stored per node: W1 (used only to pick the sampling lobe), W2, W3 and
//! W≥4 per colour channel; per θp node the hemisphere means W̄n and a tail ratio r̄ = W̄≥5/W̄≥4.
//!
//! Axes (ωp leans toward +x; directions ω = (θ, φ) in the macro frame):
//! - θp: [`N_THETA`] nodes uniform on [0, `max_theta`]; **interpolated linearly in cos θp**, so
//!   the white-Lambert remainder 1 − cos θp is reproduced exactly between nodes. Node 0 (flat)
//!   has no remainder.
//! - z = cos θ: [`N_Z`] nodes uniform on [0, 1] (dense toward grazing in u); **interpolated
//!   linearly in u = z²**, because (1/π) z dω = du dφ/(2π).
//! - φ relative to ωp's azimuth, folded to [0, π] (the microsurface is mirror-symmetric about the
//!   plane of ωg and ωp; the nested BSDF must be isotropic): [`N_PHI`] nodes every 22.5°, so 90°
//!   (where ωi·ωt changes sign and the wall entry switches on) is a node; **interpolated linearly
//!   in cos φ** (no `acos` at run time).
//!
//! The interpolant is linear in the node values, so its hemisphere mean is an exact weighted sum
//! of them ([`axis_weights`]): with those means the rank-1 remainder integrates exactly to the
//! interpolated E_ms(ωi) (the albedo identity), whatever the interpolation error against the walk.
//!
//! Colour per order (Hill 2019's per-order factors; spec §2.5, re-derived): with a per-bounce
//! multiplier c the remainder is Σ_{n≥2} cⁿ W_n ≈ c² W2 + c³ W3 + c⁴ W≥4 (1 − r̄)/(1 − c r̄),
//! exact for n ≤ 3 and for a geometric tail (the mirror sawtooth over Lambert), and exact for
//! every c when the colour is baked into the table ([`Colour::Baked`], c = 1).
//!
//! Builds: from groove's own walk ([`super::walk::sample_counted`], [`WALKS_PER_NODE`] walks per
//! node, fixed seeds, the scene's `max_order`), or in closed form over a Lambertian nested BSDF
//! ([`MsTable::lambert`]: W_n = Σ_j λ_j(ω) [Q^{n−1} e]_j of the facet chain of `lambert.rs`; for the
//! mirror sawtooth cos θp (1 − cos θp)^{n−1}), where the walk would only add noise.

// Node and order indices: the loops mirror the formulas.
#![allow(clippy::needless_range_loop)]

use super::facets::Microgeometry;
use super::lambert::FacetChain;
use super::{lane_cols::Cols, walk, Evaluation, MicrofacetNormalMap, Tangent};
use crate::bsdf::{Bsdf, BsdfContext, TransportMode};
use crate::lane::vec::{V2, V3};
use crate::lane::{Lane, LaneI32, LaneLookup, ToArray};
use crate::sampler::Sampler;
use crate::spectrum::Spectrum;
use glam::{Vec2, Vec3, Vec3A};
use rayon::prelude::*;

/// θp nodes (node 0 is θp = 0).
pub const N_THETA: usize = 13;
/// z = cos θ nodes.
pub const N_Z: usize = 12;
/// Relative azimuth nodes on [0, π].
pub const N_PHI: usize = 9;
/// Per node: W1, W2, W3, W≥4.
pub const ORDERS: usize = 4;
/// Walks per node of a walk-built table: standard error ≈ 0.01 of the albedo per node
/// (measured in `docs/mnm.md`).
pub const WALKS_PER_NODE: u32 = 2048;
/// Smallest cos θ a node direction is simulated at (the z = 0 node).
const Z_MIN: f32 = 0.01;
/// Version of the table layout and build (part of the cache key).
pub const VERSION: u32 = 1;

/// Where the per-bounce colour comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Colour {
    /// The nested BSDF's colours are in the table (c = 1 at run time).
    Baked,
    /// Built with the nested BSDF's colour set to 1; c is the colour at the hit: `reflectance`
    /// of a `diffuse` (or a twosided's diffuse front), `specular_reflectance` of a
    /// `roughconductor` (both scale every bounce linearly).
    PerBounce,
}

/// What a table is built for (the cache key names all of it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TableSpec {
    pub geometry: Microgeometry,
    pub tangent: Tangent,
    pub max_order: u32,
    /// Largest θp (radians): the normal maps are clamped to it.
    pub max_theta: f32,
    pub colour: Colour,
    /// Walks per node (walk-built tables).
    pub walks: u32,
}

impl TableSpec {
    /// The walk the table is measured from, at the normal `wp`, over arena node `nested_index`
    /// (never the Lambert closed forms: the table must see the walk itself).
    pub fn walk(&self, nested_index: u32, wp: Vec3) -> MicrofacetNormalMap {
        MicrofacetNormalMap::new(
            nested_index,
            wp,
            self.geometry,
            self.tangent,
            Evaluation::RandomWalk,
            self.max_order,
        )
        .with_lambert_closed_form(false)
    }
}

/// A built table (see the module doc).
pub struct MsTable {
    /// What it was built from (verified when read from the disk cache).
    pub key: String,
    pub spec: TableSpec,
    /// cos θp of the θp nodes (decreasing).
    cos_theta: [f32; N_THETA],
    /// Node values, index [`node`].
    w: Vec<[Spectrum; ORDERS]>,
    /// Per node W2 + W3 + W≥4 (the remainder with the colour baked in, c = 1) and W1, apart
    /// (16-byte SIMD vectors: one multiply-add pair per node), each followed by [`PLANE`]
    /// zero nodes so that the window of a lookup at the last θp node stays inside.
    e: Vec<Vec3A>,
    e1: Vec<Vec3A>,
    /// The same node values as packed vectors (no padding) for the lane gathers of
    /// [`Self::lookup_baked_x8`] ([`interpolate_baked_lanes`]).
    e_nodes: Vec<Vec3>,
    e1_nodes: Vec<Vec3>,
    /// Per θp node: hemisphere means (1/π ∫ W z dω) of the interpolant.
    mean: [[Spectrum; ORDERS]; N_THETA],
    /// Per θp node: tail ratio r̄ per channel.
    tail: [Spectrum; N_THETA],
    /// Per θp node: the hemisphere mean of W2 + W3 + W≥4.
    mean_e: [Spectrum; N_THETA],
    /// Seconds the build took (0 for a table read from disk).
    pub build_seconds: f32,
    /// `evaluation = auto`: the misplaced-energy table M(θp) of this table against the walk
    /// ([`super::misplaced`]), set once at the first load that asks for it.
    pub misplaced: std::sync::OnceLock<super::misplaced::Misplaced>,
}

impl std::fmt::Debug for MsTable {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "MsTable({})", self.key)
    }
}

/// Nodes per θp node.
const PLANE: usize = N_Z * N_PHI;

#[inline]
fn node(j: usize, k: usize, l: usize) -> usize {
    (j * N_Z + k) * N_PHI + l
}

/// θp of node j.
fn theta_node(j: usize, max_theta: f32) -> f32 {
    max_theta * j as f32 / (N_THETA - 1) as f32
}

fn z_node(k: usize) -> f32 {
    k as f32 / (N_Z - 1) as f32
}

fn phi_node(l: usize) -> f32 {
    std::f32::consts::PI * l as f32 / (N_PHI - 1) as f32
}

/// cos φ of the φ nodes (decreasing), for the run-time search.
const fn cos_phi_nodes() -> [f32; N_PHI] {
    // cos(lπ/8), l = 0..8.
    [
        1.0,
        0.923_879_5,
        0.707_106_77,
        0.382_683_43,
        0.0,
        -0.382_683_43,
        -0.707_106_77,
        -0.923_879_5,
        -1.0,
    ]
}
const COS_PHI: [f32; N_PHI] = cos_phi_nodes();
const _: () = assert!(N_PHI == 9, "the φ cells' cosines are tables of 8");
/// cos φ of each φ cell's lower and upper node (cells 0 to 7), for [`coords`]' lookups (a
/// table of 8: `LaneLookup::lookup8`).
const COS_PHI_LO: [f32; 8] = {
    let mut t = [0.0; 8];
    let mut i = 0;
    while i < 8 {
        t[i] = COS_PHI[i];
        i += 1;
    }
    t
};
const COS_PHI_HI: [f32; 8] = {
    let mut t = [0.0; 8];
    let mut i = 0;
    while i < 8 {
        t[i] = COS_PHI[i + 1];
        i += 1;
    }
    t
};

/// The node direction (θ from z node k, φ node l) for ωp leaning toward +x.
fn node_direction(k: usize, l: usize) -> Vec3 {
    let z = z_node(k).max(Z_MIN);
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = phi_node(l);
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Weights w_u (over z nodes) and w_φ (over φ nodes) with which the hemisphere mean of the
/// interpolant is Σ_k Σ_l w_u\[k\] w_φ\[l\] V\[k\]\[l\]: trapezoid in u = z² (the interpolant is linear
/// in u), and the exact integral over φ of a function linear in cos φ on each cell, over π.
pub fn axis_weights() -> ([f64; N_Z], [f64; N_PHI]) {
    let mut wu = [0.0f64; N_Z];
    for k in 0..N_Z - 1 {
        let (a, b) = (z_node(k) as f64, z_node(k + 1) as f64);
        let h = b * b - a * a;
        wu[k] += h / 2.0;
        wu[k + 1] += h / 2.0;
    }
    let mut wp = [0.0f64; N_PHI];
    for l in 0..N_PHI - 1 {
        let (p0, p1) = (phi_node(l) as f64, phi_node(l + 1) as f64);
        let (x0, x1) = (p0.cos(), p1.cos());
        let h = p1 - p0;
        let s = p1.sin() - p0.sin();
        wp[l] += (s - x1 * h) / (x0 - x1) / std::f64::consts::PI;
        wp[l + 1] += (x0 * h - s) / (x0 - x1) / std::f64::consts::PI;
    }
    (wu, wp)
}

/// Where a shading point's ωp falls in a table: the θp cell and its weight (linear in cos θp),
/// and ωp's azimuth. Computed once per hit.
#[derive(Clone, Copy, Debug)]
pub struct ThetaCell {
    pub j: usize,
    pub t: f32,
    /// Unit vector of ωp's azimuth in the macro frame.
    pub axis: Vec2,
}

/// [`ThetaCell`]s of several shading points (lanes): [`MsTable::cells`].
#[derive(Clone, Copy, Debug)]
pub struct ThetaCells<L: Lane> {
    pub j: L::I32,
    pub t: L,
    pub axis: V2<L>,
}

impl<L: Lane> ThetaCells<L> {
    /// The cell of lane `i`.
    #[inline(always)]
    pub fn lane(&self, i: usize) -> ThetaCell {
        ThetaCell {
            j: self.j.lane(i) as usize,
            t: self.t.lane(i),
            axis: Vec2::new(self.axis.x.lane(i), self.axis.y.lane(i)),
        }
    }
}

impl<L: Lane> ThetaCells<L> {
    /// The lanes stored as arrays of `W` (the lane width): plain numbers, read per lane
    /// ([`CellCols::get`]) where the points are built one by one.
    #[inline(always)]
    pub fn cols<const W: usize>(&self) -> CellCols<W>
    where
        L: ToArray<f32, W>,
        L::I32: ToArray<i32, W>,
    {
        CellCols {
            j: self.j.to_array(),
            t: self.t.to_array(),
            axis: [self.axis.x.to_array(), self.axis.y.to_array()],
        }
    }
}

/// [`ThetaCells`] stored per lane ([`ThetaCells::cols`]).
#[derive(Clone, Copy, Debug)]
pub struct CellCols<const W: usize> {
    j: [i32; W],
    t: [f32; W],
    axis: [[f32; W]; 2],
}

impl<const W: usize> CellCols<W> {
    /// The cell of lane `i` ([`ThetaCells::lane`] of the stored lanes).
    #[inline(always)]
    pub fn get(&self, i: usize) -> ThetaCell {
        ThetaCell {
            j: self.j[i] as usize,
            t: self.t[i],
            axis: Vec2::new(self.axis[0][i], self.axis[1][i]),
        }
    }
}

/// Interpolated node values at one direction, for the two θp nodes of a cell.
#[derive(Clone, Copy, Debug)]
pub struct Lookup {
    pub w: [[Spectrum; ORDERS]; 2],
}

/// Where a direction falls in the (u = z², cos φ) grid of one θp plane: the lower z node `kz`,
/// the φ cell `l` (nodes `l`, `l + 1`) and the weights of the upper nodes in u and cos φ.
#[derive(Clone, Copy, Debug)]
pub struct Coords<L: Lane> {
    pub kz: L::I32,
    pub l: L::I32,
    pub tu: L,
    pub tx: L,
}

impl<L: Lane> Coords<L> {
    /// The bilinear weights of the nodes (kz, l), (kz, l + 1), (kz + 1, l), (kz + 1, l + 1).
    #[inline(always)]
    pub fn weights(&self) -> [L; 4] {
        let (tu, tx) = (self.tu, self.tx);
        let one = tu.splat(1.0);
        [
            (one - tu) * (one - tx),
            (one - tu) * tx,
            tu * (one - tx),
            tu * tx,
        ]
    }
}

/// Lane kernel (one source for 1 and 8 lanes, `crate::lane`) of a table lookup's arithmetic:
/// the z node and φ cell of direction `w` (z > 0) relative to ωp's azimuth `axis` (unit), and
/// the interpolation weights. Branch-free: the φ cell is the count of inner nodes whose cos φ
/// lies above x = cos φ (their cosines are chosen by selects, no table gather), the node
/// spacings are recomputed with the same operations the table's were built with, so width 1
/// gives the numbers of a scalar search bit for bit. Only the node gather is left per lane.
#[inline(always)]
pub fn coords<L: Lane>(axis: V2<L>, w: V3<L>) -> Coords<L> {
    let k = |c: f32| w.z.splat(c);
    let z = w.z.max(k(0.0)).min(k(1.0));
    let nz = k((N_Z - 1) as f32);
    let kz = (z * nz).trunc_i32();
    let kz = L::I32::select(
        kz.gt(kz.splat((N_Z - 2) as i32)),
        kz.splat((N_Z - 2) as i32),
        kz,
    );
    // u of nodes kz and kz + 1, as `z_node(k) * z_node(k)`.
    let z0 = kz.to_f32() / nz;
    let z1 = kz.add(kz.splat(1)).to_f32() / nz;
    let (u0, u1) = (z0 * z0, z1 * z1);
    let tu = ((z * z - u0) * (k(1.0) / (u1 - u0)))
        .max(k(0.0))
        .min(k(1.0));
    let r2 = w.x * w.x + w.y * w.y;
    let x = ((w.x * axis.x + w.y * axis.y) / r2.sqrt())
        .max(k(-1.0))
        .min(k(1.0));
    let x = L::select(r2.gt(k(1e-12)), x, k(1.0));
    // The cell l counts the inner nodes above x (a prefix: the cosines decrease), and its
    // nodes' cosines are looked up by l (`LaneLookup::lookup8`, one permute each: the same
    // values as a select per node).
    let mut l = kz.splat(0);
    for &c in &COS_PHI[1..N_PHI - 1] {
        l = L::I32::select(x.lt(k(c)), l.add(l.splat(1)), l);
    }
    let c0 = <L::I32 as LaneLookup<L>>::lookup8(&COS_PHI_LO, l);
    let c1 = <L::I32 as LaneLookup<L>>::lookup8(&COS_PHI_HI, l);
    let tx = ((c0 - x) * (k(1.0) / (c0 - c1))).max(k(0.0)).min(k(1.0));
    Coords { kz, l, tu, tx }
}

/// [`coords`] at width 1, written for one direction: the same operations in the same order
/// (so the same bits, `tests`), but the φ cell found by a search that stops at the first inner
/// node x is not below (the nodes' cosines decrease, so that count is the lane kernel's) instead
/// of seven selects over every node: the scalar renderer's lookups (two per compensated query)
/// spent ~100 instructions each in the width-1 lane kernel.
#[inline(always)]
fn coords_one(axis: Vec2, w: Vec3) -> Coords<f32> {
    // The lane kernel's `max` / `min` at width 1 (not `f32::max`, whose signed-zero result is
    // unspecified).
    let max = |a: f32, b: f32| if a > b { a } else { b };
    let min = |a: f32, b: f32| if a < b { a } else { b };
    let z = min(max(w.z, 0.0), 1.0);
    let nz = (N_Z - 1) as f32;
    // z ∈ [0, 1]: the truncation is in range.
    let kz = ((z * nz) as i32).min((N_Z - 2) as i32);
    let z0 = kz as f32 / nz;
    let z1 = (kz + 1) as f32 / nz;
    let (u0, u1) = (z0 * z0, z1 * z1);
    let tu = min(max((z * z - u0) * (1.0 / (u1 - u0)), 0.0), 1.0);
    let r2 = w.x * w.x + w.y * w.y;
    let x = min(max((w.x * axis.x + w.y * axis.y) / r2.sqrt(), -1.0), 1.0);
    // Not NaN after the clamp: every comparison below is ordered.
    let x = if r2 > 1e-12 { x } else { 1.0 };
    let mut l = 0;
    while l + 2 < N_PHI && x < COS_PHI[l + 1] {
        l += 1;
    }
    let (c0, c1) = (COS_PHI[l], COS_PHI[l + 1]);
    let tx = min(max((c0 - x) * (1.0 / (c0 - c1)), 0.0), 1.0);
    Coords {
        kz,
        l: l as i32,
        tu,
        tx,
    }
}

/// Up to 8 lookups of one table for [`MsTable::lookup_baked_x8`], by lane (structure of
/// arrays, filled in place by the callers): the cell's azimuth, plane (j · [`PLANE`]) and θp
/// weight, and the direction. Lanes without a lookup hold valid placeholders (+z in cell 0)
/// whose results are never read.
#[derive(Clone, Copy, Debug)]
pub struct Lookups8 {
    ax: [f32; 8],
    ay: [f32; 8],
    wx: [f32; 8],
    wy: [f32; 8],
    wz: [f32; 8],
    plane: [i32; 8],
    t: [f32; 8],
    /// Bit k: lane k has a lookup.
    used: u8,
}

impl Default for Lookups8 {
    fn default() -> Self {
        Self::new()
    }
}

impl Lookups8 {
    #[inline(always)]
    pub fn new() -> Self {
        Lookups8 {
            ax: [1.0; 8],
            ay: [0.0; 8],
            wx: [0.0; 8],
            wy: [0.0; 8],
            wz: [1.0; 8],
            plane: [0; 8],
            t: [0.0; 8],
            used: 0,
        }
    }

    /// Lane `k` looks up direction `w` (z > 0) in `cell`.
    #[inline(always)]
    pub fn push(&mut self, k: usize, cell: &ThetaCell, w: Vec3) {
        (self.ax[k], self.ay[k]) = (cell.axis.x, cell.axis.y);
        (self.wx[k], self.wy[k], self.wz[k]) = (w.x, w.y, w.z);
        (self.plane[k], self.t[k]) = ((cell.j * PLANE) as i32, cell.t);
        self.used |= 1 << k;
    }

    /// The lanes `on` (bit k: lane k) look up their direction (lane k of `w`, by component;
    /// z > 0) in their cells (lane k of `cells`): [`Self::push`] of each, from the columns as
    /// they are (`cells.get(k)`'s cell, its plane `j · PLANE` in the same wrapping integer
    /// product), the other lanes kept: a blend per column ([`Cols::blend`]; the select
    /// per lane written before compiled to a branch per lane and column). Call inside
    /// [`Cols::run`].
    #[inline(always)]
    pub(crate) fn push_lanes(
        &mut self,
        cols: Cols,
        on: u8,
        cells: &CellCols<8>,
        w: &[[f32; 8]; 3],
    ) {
        cols.blend(on, &mut self.ax, &cells.axis[0]);
        cols.blend(on, &mut self.ay, &cells.axis[1]);
        self.set_directions(cols, on, w);
        let plane: [i32; 8] =
            std::array::from_fn(|k| (cells.j[k] as usize).wrapping_mul(PLANE) as i32);
        cols.blend(on, &mut self.plane, &plane);
        cols.blend(on, &mut self.t, &cells.t);
        self.used |= on;
    }

    /// [`Self::set_direction`] of the lanes `on` (bit k: lane k; each with a lookup), from
    /// lane k of `w` (by component), the other lanes kept: a blend per column. Call inside
    /// [`Cols::run`].
    #[inline(always)]
    pub(crate) fn set_directions(&mut self, cols: Cols, on: u8, w: &[[f32; 8]; 3]) {
        cols.blend(on, &mut self.wx, &w[0]);
        cols.blend(on, &mut self.wy, &w[1]);
        cols.blend(on, &mut self.wz, &w[2]);
    }

    /// The lanes with a lookup, as bits (bit k: lane k).
    #[inline(always)]
    pub fn used(&self) -> u8 {
        self.used
    }

    /// Lane `k` (one with a lookup) looks up direction `w` (z > 0) instead, in the same cell:
    /// one query's lookups at ωo from the cells a chunk pushed once at ωi.
    #[inline(always)]
    pub fn set_direction(&mut self, k: usize, w: Vec3) {
        (self.wx[k], self.wy[k], self.wz[k]) = (w.x, w.y, w.z);
    }

    /// Whether lane `k` has a lookup.
    #[inline(always)]
    pub fn is_used(&self, k: usize) -> bool {
        self.used & (1 << k) != 0
    }

    /// Lane `k`'s cell and direction, as pushed.
    #[inline]
    pub fn get(&self, k: usize) -> Option<(ThetaCell, Vec3)> {
        self.is_used(k).then(|| {
            let cell = ThetaCell {
                j: self.plane[k] as usize / PLANE,
                t: self.t[k],
                axis: Vec2::new(self.ax[k], self.ay[k]),
            };
            (cell, Vec3::new(self.wx[k], self.wy[k], self.wz[k]))
        })
    }
}

/// The corner offsets of a lookup's window from its first node (kz, l) at the lower θp node:
/// (kz, l), (kz, l + 1), (kz + 1, l), (kz + 1, l + 1), in [`Coords::weights`]' order.
const CORNERS: [usize; 4] = [0, 1, N_PHI, N_PHI + 1];

/// Lane kernel (one source for 1 and 8 lanes, `crate::lane`) of [`MsTable::lookup_baked`]'s
/// interpolation: [W1, E_ms] at the coordinates `c` in the θp cell whose lower node's plane
/// starts at node `plane` (j · [`PLANE`]) with weight `t` of the upper node, from the node
/// values `e` (W2 + W3 + W≥4) and `e1` (W1) gathered per lane. The products and sums are those
/// of the scalar interpolation in its order (per channel: θp weight times bilinear weight,
/// times the node value, added to the running sum from 0), so each lane's result is the scalar
/// lookup's bit for bit. `with_first`: also W1 (else it stays 0).
#[inline(always)]
pub fn interpolate_baked_lanes<L: Lane>(
    e: &[Vec3],
    e1: &[Vec3],
    plane: L::I32,
    t: L,
    c: &Coords<L>,
    with_first: bool,
) -> [V3<L>; 2] {
    const { assert!(N_PHI == 9) };
    // node(j, kz, l) = j·PLANE + 9·kz + l.
    let i0 = plane.add(c.kz.shl::<3>()).add(c.kz).add(c.l);
    let wgt = c.weights();
    let zero = t.splat(0.0);
    let mut out = [V3::new(zero, zero, zero); 2];
    let acc = |o: &mut V3<L>, k: L, v: [L; 3]| {
        *o = V3::new(o.x + k * v[0], o.y + k * v[1], o.z + k * v[2]);
    };
    for h in 0..2 {
        let wt = if h == 0 { t.splat(1.0) - t } else { t };
        for (corner, &wc) in CORNERS.iter().zip(&wgt) {
            let i = i0.add(i0.splat((corner + h * PLANE) as i32));
            let k = wt * wc;
            acc(&mut out[1], k, L::gather3(e, i));
            if with_first {
                acc(&mut out[0], k, L::gather3(e1, i));
            }
        }
    }
    out
}

/// The 8 corner nodes of a θp cell from its first node, in [`interpolate_baked_lanes`]' order:
/// the lower θp node's [`CORNERS`], then the upper node's.
const WINDOW: [usize; 8] = [
    CORNERS[0],
    CORNERS[1],
    CORNERS[2],
    CORNERS[3],
    PLANE + CORNERS[0],
    PLANE + CORNERS[1],
    PLANE + CORNERS[2],
    PLANE + CORNERS[3],
];

/// [`interpolate_baked_lanes`] 8-wide with the corner nodes read by one window gather per
/// table ([`crate::lane::Avx2::gather3_window`]: one index clamp and scaling for the 8 corners
/// instead of one per corner); the products and sums are the lane kernel's, in its order. A
/// lane whose window lies inside the table (every lane with a cell: its upper θp node is a
/// plane of the table) reads the lane kernel's nodes, so its result is the same bit for bit
/// (`tests`).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn interpolate_baked_x8(
    avx: crate::lane::Avx2,
    e: &[Vec3],
    e1: &[Vec3],
    plane: crate::lane::I32x8,
    t: crate::lane::F32x8,
    c: &Coords<crate::lane::F32x8>,
    with_first: bool,
) -> [V3<crate::lane::F32x8>; 2] {
    const { assert!(N_PHI == 9) };
    // node(j, kz, l) = j·PLANE + 9·kz + l.
    let i0 = plane.add(c.kz.shl::<3>()).add(c.kz).add(c.l);
    let wgt = c.weights();
    let zero = t.splat(0.0);
    let mut out = [V3::new(zero, zero, zero); 2];
    let acc =
        |o: &mut V3<crate::lane::F32x8>, k: crate::lane::F32x8, v: [crate::lane::F32x8; 3]| {
            *o = V3::new(o.x + k * v[0], o.y + k * v[1], o.z + k * v[2]);
        };
    let ve = avx.gather3_window(e, i0, &WINDOW);
    let ve1 = if with_first {
        avx.gather3_window(e1, i0, &WINDOW)
    } else {
        ve
    };
    for h in 0..2 {
        let wt = if h == 0 { t.splat(1.0) - t } else { t };
        for (corner, &wc) in wgt.iter().enumerate() {
            let k = wt * wc;
            acc(&mut out[1], k, ve[4 * h + corner]);
            if with_first {
                acc(&mut out[0], k, ve1[4 * h + corner]);
            }
        }
    }
    out
}

impl MsTable {
    /// The θp cell of ωp = `wp` (not flat: `wp.xy` ≠ 0).
    pub fn cell(&self, wp: Vec3) -> ThetaCell {
        let c = wp.z;
        let mut j = 0;
        while j + 2 < N_THETA && c < self.cos_theta[j + 1] {
            j += 1;
        }
        let (c0, c1) = (self.cos_theta[j], self.cos_theta[j + 1]);
        let t = ((c0 - c) / (c0 - c1)).clamp(0.0, 1.0);
        let axis = Vec2::new(wp.x, wp.y).normalize_or(Vec2::X);
        ThetaCell { j, t, axis }
    }

    /// [`Self::cell`] per lane, bit for bit (the stream renderer's per-hit build, 8 points at
    /// once): the θp cells of the perturbed normals `wp` (not flat): the node j is the
    /// number of leading nodes 1, 2, …, N_THETA − 2 with cos θp below theirs (the search that
    /// stops at the first node it is not below: branch-free, the same j for any node order),
    /// the weight t = (c_j − cos θp) / (c_j − c_{j+1}) clamped to [0, 1] (NaN stays NaN, as
    /// `f32::clamp`), the azimuth as glam's `normalize_or(+x)` of `wp.xy`.
    #[inline(always)]
    pub fn cells<L: Lane>(&self, wp: V3<L>) -> ThetaCells<L> {
        let c = wp.z;
        let k = |x: f32| c.splat(x);
        let (zero, one) = (c.to_bits().splat(0), c.to_bits().splat(1));
        let mut below = c.lt(k(self.cos_theta[1]));
        let mut j = L::I32::select(below, one, zero);
        for &node in &self.cos_theta[2..N_THETA - 1] {
            below = below & c.lt(k(node));
            j = L::I32::select(below, j.add(one), j);
        }
        let (c0, c1) = (
            L::gather(&self.cos_theta, j),
            L::gather(&self.cos_theta, j.add(one)),
        );
        let t = (c0 - c) / (c0 - c1);
        let t = L::select(t.lt(k(0.0)), k(0.0), t);
        let t = L::select(t.gt(k(1.0)), k(1.0), t);
        let rcp = k(1.0) / (wp.x * wp.x + wp.y * wp.y).sqrt();
        let ok = rcp.is_finite() & rcp.gt(k(0.0));
        let axis = V2::new(
            L::select(ok, wp.x * rcp, k(1.0)),
            L::select(ok, wp.y * rcp, k(0.0)),
        );
        ThetaCells { j, t, axis }
    }

    /// The four nodes around direction `w` (z > 0) at θp node `cell.j` (those at `cell.j + 1`
    /// follow at the offset [`PLANE`]) and their bilinear weights (in u = z² and cos φ): the
    /// lane kernel [`coords`] at width 1.
    #[inline]
    fn corners(&self, cell: &ThetaCell, w: Vec3) -> ([usize; 4], [f32; 4]) {
        let c = coords_one(cell.axis, w);
        let i = node(cell.j, c.kz as usize, c.l as usize);
        ([i, i + 1, i + N_PHI, i + N_PHI + 1], c.weights())
    }

    /// Bilinear interpolation (in u = z² and cos φ) of the node values at direction `w` (z > 0),
    /// at the two θp nodes of `cell`.
    #[inline]
    pub fn lookup(&self, cell: &ThetaCell, w: Vec3) -> Lookup {
        let (idx, wgt) = self.corners(cell, w);
        let mut out = [[Spectrum::ZERO; ORDERS]; 2];
        for (h, o) in out.iter_mut().enumerate() {
            for c in 0..4 {
                let v = &self.w[idx[c] + h * PLANE];
                for n in 0..ORDERS {
                    o[n] += wgt[c] * v[n];
                }
            }
        }
        Lookup { w: out }
    }

    /// [W1, E_ms] at direction `w` with the colour baked in (c = 1: [`Colour::Baked`]),
    /// interpolated in θp too. `with_first`: also W1 (else it is 0).
    #[inline]
    pub fn lookup_baked(&self, cell: &ThetaCell, w: Vec3, with_first: bool) -> [Spectrum; 2] {
        let (idx, wgt) = self.corners(cell, w);
        self.interpolate_baked(cell, idx[0], wgt, with_first)
    }

    /// [`Self::lookup_baked`] of the 8 lanes of `q` (each a direction z > 0 in its own cell of
    /// this table; lanes without a lookup are left 0), all of it 8-wide under the [`Avx2`]
    /// token: the node coordinates and weights ([`coords`]), the corner nodes' gathers and the
    /// interpolation ([`interpolate_baked_lanes`]), one transpose to the lanes' rows. Bit for
    /// bit the scalar lookups (the lane rule of [`crate::lane`]; `tests`), which a CPU without
    /// AVX2 runs lane by lane. `with_first`: also W1 (the hit's ωi cache), else only E_ms (ωo).
    ///
    /// [`Avx2`]: crate::lane::Avx2
    #[inline]
    pub fn lookup_baked_x8(&self, q: &Lookups8, with_first: bool) -> [[Spectrum; 2]; 8] {
        let mut out = [[Spectrum::ZERO; 2]; 8];
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = crate::lane::Avx2::detect() {
            use crate::lane::F32x8;
            let rows = avx.run(
                #[inline(always)]
                || {
                    let [w1, e] = self.baked_lanes(avx, q, with_first);
                    let z = avx.splat(0.0);
                    F32x8::transpose8([w1.x, w1.y, w1.z, e.x, e.y, e.z, z, z]).map(|r| r.to_array())
                },
            );
            for (k, (o, r)) in out.iter_mut().zip(&rows).enumerate() {
                if q.is_used(k) {
                    *o = [Vec3::new(r[0], r[1], r[2]), Vec3::new(r[3], r[4], r[5])];
                }
            }
            return out;
        }
        for (k, o) in out.iter_mut().enumerate() {
            if let Some((cell, w)) = q.get(k) {
                *o = self.lookup_baked(&cell, w, with_first);
            }
        }
        out
    }

    /// E_ms (the baked W2 + W3 + W≥4, no W1) of [`Self::lookup_baked_x8`]'s lanes, left in
    /// registers for a caller already inside [`crate::lane::Avx2::run`] that goes on in lanes
    /// (the compensated chunk's remainders at ωo): the same coordinates and interpolation, so
    /// lane k (one with a lookup) is `lookup_baked(cell, w, false)[1]` bit for bit; the other
    /// lanes hold the placeholders' values.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub fn lookup_baked_e_lanes(
        &self,
        avx: crate::lane::Avx2,
        q: &Lookups8,
    ) -> V3<crate::lane::F32x8> {
        let [_, e] = self.baked_lanes(avx, q, false);
        e
    }

    /// W1 (when `with_first`; else zeros) and E_ms of the lanes of `q`, in registers: the
    /// coordinates and the interpolation that [`Self::lookup_baked_x8`] and
    /// [`Self::lookup_baked_e_lanes`] share (and the compensated chunk's state at ωi, which
    /// goes on in lanes). Lane k (one with a lookup) is `lookup_baked(cell, w, with_first)`
    /// bit for bit; the other lanes hold the placeholders' values. Call inside
    /// [`crate::lane::Avx2::run`].
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    pub(in crate::bsdf::mnm) fn baked_lanes(
        &self,
        avx: crate::lane::Avx2,
        q: &Lookups8,
        with_first: bool,
    ) -> [V3<crate::lane::F32x8>; 2] {
        let axis = V2::new(avx.load(&q.ax), avx.load(&q.ay));
        let d = V3::new(avx.load(&q.wx), avx.load(&q.wy), avx.load(&q.wz));
        let c = coords(axis, d);
        interpolate_baked_x8(
            avx,
            &self.e_nodes,
            &self.e1_nodes,
            avx.load_i32(&q.plane),
            avx.load(&q.t),
            &c,
            with_first,
        )
    }

    /// [`Self::lookup_baked`]'s interpolation from the first corner node `i0` and the bilinear
    /// weights.
    #[inline(always)]
    fn interpolate_baked(
        &self,
        cell: &ThetaCell,
        i0: usize,
        wgt: [f32; 4],
        with_first: bool,
    ) -> [Spectrum; 2] {
        let idx = [i0];
        // The two θp planes' corner nodes: one bounds check for all eight (the corner offsets
        // are constants inside the window).
        let win: &[Vec3A; 2 * PLANE] = self.e[idx[0]..idx[0] + 2 * PLANE]
            .try_into()
            .expect("window inside the table");
        // W1's window only when it is read (its bounds check is a branch the ωo lookups skip).
        let win1: &[Vec3A; 2 * PLANE] = if with_first {
            self.e1[idx[0]..idx[0] + 2 * PLANE]
                .try_into()
                .expect("window inside the table")
        } else {
            win
        };
        let mut out = [Vec3A::ZERO; 2];
        // Same products and sums in the same order as a per-component loop (Vec3A lanes are
        // the IEEE operations of Vec3's components): bit for bit the scalar interpolation.
        for h in 0..2 {
            let wt = if h == 0 { 1.0 - cell.t } else { cell.t };
            for c in 0..4 {
                let i = CORNERS[c] + h * PLANE;
                let k = wt * wgt[c];
                out[1] += k * win[i];
                if with_first {
                    out[0] += k * win1[i];
                }
            }
        }
        [Vec3::from(out[0]), Vec3::from(out[1])]
    }

    /// Ē_ms with the colour baked in (c = 1), interpolated in θp.
    #[inline]
    pub fn mean_baked(&self, cell: &ThetaCell) -> Spectrum {
        (1.0 - cell.t) * self.mean_e[cell.j] + cell.t * self.mean_e[cell.j + 1]
    }

    /// 1 / (π Ē_ms) of each lane's cell of `cells` with the colour baked in (the compensated
    /// point's `baked_norm`, `MsPlace::in_cell`: [`Self::mean_baked`], then per channel 1/x
    /// where x > 0, else 0, times 1/π), by channel: 8-wide under the [`crate::lane::Avx2`]
    /// token (the two θp nodes' Ē_ms gathered, the same products, sum and division in the same
    /// order: each lane the scalar value bit for bit, `tests`), else lane by lane. Every lane's
    /// cell must be a cell of this table (a lane of [`Self::cells`]). 8-wide when `cols` is.
    #[inline]
    pub(crate) fn baked_norms_x8(&self, cols: Cols, cells: &CellCols<8>) -> [[f32; 8]; 3] {
        let mut out = [[0.0f32; 8]; 3];
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = cols.avx() {
            use crate::lane::F32x8;
            avx.run(
                #[inline(always)]
                || {
                    let j = avx.load_i32(&cells.j);
                    let t = avx.load(&cells.t);
                    let (zero, one) = (avx.splat(0.0), avx.splat(1.0));
                    let m0 = F32x8::gather3(&self.mean_e, j);
                    let m1 = F32x8::gather3(&self.mean_e, j.add(j.splat(1)));
                    let inv_pi = avx.splat(crate::math::INV_PI);
                    for c in 0..3 {
                        let m = (one - t) * m0[c] + t * m1[c];
                        let inv = F32x8::select(m.gt(zero), one / m, zero);
                        (inv * inv_pi).store(&mut out[c]);
                    }
                },
            );
            return out;
        }
        for k in 0..8 {
            let m = self.mean_baked(&cells.get(k));
            let inv = |x: f32| if x > 0.0 { 1.0 / x } else { 0.0 };
            let n = Vec3::new(inv(m.x), inv(m.y), inv(m.z)) * crate::math::INV_PI;
            for c in 0..3 {
                out[c][k] = n[c];
            }
        }
        out
    }

    /// Per-order coefficients (c², c³, c⁴(1 − r̄)/(1 − c r̄)) at the two θp nodes of `cell`,
    /// each times its θp weight, for the colour `c`.
    #[inline]
    pub fn coefficients(&self, cell: &ThetaCell, c: Spectrum) -> [[Spectrum; 3]; 2] {
        let c2 = c * c;
        let c3 = c2 * c;
        let mut out = [[Spectrum::ZERO; 3]; 2];
        for (h, o) in out.iter_mut().enumerate() {
            let r = self.tail[cell.j + h];
            let wt = if h == 0 { 1.0 - cell.t } else { cell.t };
            let k = (Spectrum::ONE - r) / (Spectrum::ONE - c * r);
            *o = [wt * c2, wt * c3, wt * c3 * c * k];
        }
        out
    }

    /// The remainder energy E_ms from a lookup and [`Self::coefficients`].
    #[inline]
    pub fn remainder(l: &Lookup, k: &[[Spectrum; 3]; 2]) -> Spectrum {
        let mut e = Spectrum::ZERO;
        for h in 0..2 {
            e += k[h][0] * l.w[h][1] + k[h][1] * l.w[h][2] + k[h][2] * l.w[h][3];
        }
        e
    }

    /// The interpolated W1 (for the lobe choice; white).
    #[inline]
    pub fn first(l: &Lookup, cell: &ThetaCell) -> Spectrum {
        (1.0 - cell.t) * l.w[0][0] + cell.t * l.w[1][0]
    }

    /// Ē_ms: the hemisphere mean (1/π ∫ E_ms z dω) of the interpolated remainder, exact.
    #[inline]
    pub fn mean_remainder(&self, cell: &ThetaCell, k: &[[Spectrum; 3]; 2]) -> Spectrum {
        let mut e = Spectrum::ZERO;
        for h in 0..2 {
            let m = &self.mean[cell.j + h];
            e += k[h][0] * m[1] + k[h][1] * m[2] + k[h][2] * m[3];
        }
        e
    }

    /// A node value (tests, docs): W_n at θp node j, z node k, φ node l.
    pub fn node_value(&self, j: usize, k: usize, l: usize, order: usize) -> Spectrum {
        self.w[node(j, k, l)][order]
    }

    /// θp of node j (radians).
    pub fn theta_p(&self, j: usize) -> f32 {
        theta_node(j, self.spec.max_theta)
    }

    /// The node direction of z node k, φ node l (ωp leaning toward +x).
    pub fn direction(k: usize, l: usize) -> Vec3 {
        node_direction(k, l)
    }

    fn finish(
        key: String,
        spec: TableSpec,
        mut w: Vec<[Spectrum; ORDERS]>,
        beyond4: &[Spectrum],
        build_seconds: f32,
    ) -> MsTable {
        // No gain: table noise must not make the walk's total exceed 1.
        for v in w.iter_mut() {
            let total: Spectrum = v.iter().copied().sum();
            for ch in 0..3 {
                if total[ch] > 1.0 {
                    for n in v.iter_mut() {
                        n[ch] /= total[ch];
                    }
                }
            }
        }
        let (wu, wphi) = axis_weights();
        let mut mean = [[Spectrum::ZERO; ORDERS]; N_THETA];
        let mut tail = [Spectrum::ZERO; N_THETA];
        for j in 0..N_THETA {
            let mut m = [glam::DVec3::ZERO; ORDERS];
            let mut b5 = glam::DVec3::ZERO;
            for k in 0..N_Z {
                for l in 0..N_PHI {
                    let wgt = wu[k] * wphi[l];
                    let i = node(j, k, l);
                    for n in 0..ORDERS {
                        m[n] += wgt * w[i][n].as_dvec3();
                    }
                    b5 += wgt * beyond4[i].as_dvec3();
                }
            }
            mean[j] = m.map(|v| v.as_vec3());
            let r = b5 / m[3];
            tail[j] = Vec3::new(ratio(r.x, m[3].x), ratio(r.y, m[3].y), ratio(r.z, m[3].z));
        }
        Self::assemble(key, spec, w, mean, tail, build_seconds)
    }

    /// The table from its stored parts (the derived combined values computed here).
    fn assemble(
        key: String,
        spec: TableSpec,
        w: Vec<[Spectrum; ORDERS]>,
        mean: [[Spectrum; ORDERS]; N_THETA],
        tail: [Spectrum; N_THETA],
        build_seconds: f32,
    ) -> MsTable {
        let cos_theta = std::array::from_fn(|j| theta_node(j, spec.max_theta).cos());
        let pad = std::iter::repeat_n(Vec3A::ZERO, PLANE);
        let e = w
            .iter()
            .map(|v| Vec3A::from(v[1] + v[2] + v[3]))
            .chain(pad.clone())
            .collect();
        let e1 = w.iter().map(|v| Vec3A::from(v[0])).chain(pad).collect();
        let e_nodes = w.iter().map(|v| v[1] + v[2] + v[3]).collect();
        let e1_nodes = w.iter().map(|v| v[0]).collect();
        let mean_e = mean.map(|m| m[1] + m[2] + m[3]);
        MsTable {
            key,
            spec,
            cos_theta,
            w,
            e,
            e1,
            e_nodes,
            e1_nodes,
            tail,
            mean,
            mean_e,
            build_seconds,
            misplaced: std::sync::OnceLock::new(),
        }
    }

    /// The table of the walk over `nested` (in `nested`'s arena; reflection only, isotropic, no
    /// delta lobes — the caller checks), [`TableSpec::walks`] walks per node with fixed seeds.
    pub fn from_walk(nested: &Bsdf, nested_index: u32, spec: TableSpec, key: String) -> MsTable {
        let t0 = std::time::Instant::now();
        let ctx = BsdfContext {
            mode: TransportMode::Radiance,
        };
        let n = N_THETA * N_Z * N_PHI;
        let mut w = vec![[Spectrum::ZERO; ORDERS]; n];
        let mut beyond4 = vec![Spectrum::ZERO; n];
        // One task per (θp node ≥ 1, z node): 9 directions each.
        let rows: Vec<Row> = (1..N_THETA)
            .flat_map(|j| (0..N_Z).map(move |k| (j, k)))
            .collect::<Vec<_>>()
            .into_par_iter()
            .map(|(j, k)| {
                let tp = theta_node(j, spec.max_theta);
                let wp = Vec3::new(tp.sin(), 0.0, tp.cos());
                let m = spec.walk(nested_index, wp);
                let mut s = Sampler::from_seed(0x6d73_7462 ^ VERSION as u64, node(j, k, 0) as u64);
                // At z = 1 every azimuth is the same direction: walk once.
                let dirs = if k == N_Z - 1 { 1 } else { N_PHI };
                let mut row = Vec::with_capacity(N_PHI);
                for l in 0..dirs {
                    let wi = node_direction(k, l);
                    let mut acc = [glam::DVec3::ZERO; ORDERS + 1];
                    for _ in 0..spec.walks {
                        if let Some(r) = walk::sample_counted(&m, nested, &ctx, wi, &mut s) {
                            let b = (r.nested_vertices.max(1) as usize).min(ORDERS + 1) - 1;
                            acc[b] += r.weight.as_dvec3();
                        }
                    }
                    let inv = 1.0 / spec.walks as f64;
                    let v = [
                        (acc[0] * inv).as_vec3(),
                        (acc[1] * inv).as_vec3(),
                        (acc[2] * inv).as_vec3(),
                        ((acc[3] + acc[4]) * inv).as_vec3(),
                    ];
                    row.push((v, (acc[4] * inv).as_vec3()));
                }
                while row.len() < N_PHI {
                    row.push(row[0]);
                }
                (j, k, row)
            })
            .collect();
        for (j, k, row) in rows {
            for (l, (v, b)) in row.into_iter().enumerate() {
                w[node(j, k, l)] = v;
                beyond4[node(j, k, l)] = b;
            }
        }
        // θp = 0 (flat): no remainder; W1 (only the lobe choice) as at node 1.
        for k in 0..N_Z {
            for l in 0..N_PHI {
                w[node(0, k, l)] = [w[node(1, k, l)][0], Vec3::ZERO, Vec3::ZERO, Vec3::ZERO];
            }
        }
        Self::finish(key, spec, w, &beyond4, t0.elapsed().as_secs_f32())
    }

    /// The tests' exact Lambert table (instant to build): `max_order` 256, `max_theta` 85°,
    /// leaked so that maps can hold it as a `&'static` as the scene's tables are.
    #[cfg(test)]
    pub(crate) fn unit_lambert(
        geometry: Microgeometry,
        tangent: Tangent,
        colour: Colour,
    ) -> &'static MsTable {
        let spec = TableSpec {
            geometry,
            tangent,
            max_order: 256,
            max_theta: 85f32.to_radians(),
            colour,
            walks: WALKS_PER_NODE,
        };
        Box::leak(Box::new(MsTable::lambert(spec, "unit".into())))
    }

    /// The exact table over a white Lambertian nested BSDF (colour per bounce at run time):
    /// W_n(ω) = Σ_j λ_j(ω) [Q^{n−1} e]_j for the facet chain (`lambert.rs`), which for the
    /// mirror sawtooth (every path through p, return probability q = 1 − cos θp) is
    /// cos θp q^{n−1} for every ω. All orders (no `max_order` truncation).
    pub fn lambert(spec: TableSpec, key: String) -> MsTable {
        let t0 = std::time::Instant::now();
        let n = N_THETA * N_Z * N_PHI;
        let mut w = vec![[Spectrum::ZERO; ORDERS]; n];
        let mut beyond4 = vec![Spectrum::ZERO; n];
        for j in 0..N_THETA {
            let tp = theta_node(j, spec.max_theta);
            let wp = Vec3::new(tp.sin(), 0.0, tp.cos());
            let mirror =
                spec.geometry == Microgeometry::Sawtooth && spec.tangent == Tangent::Mirror;
            if j == 0 || mirror {
                let c = wp.z as f64;
                let q = if j == 0 { 0.0 } else { 1.0 - c };
                let v = [c, c * q, c * q * q, q * q * q].map(|x| Spectrum::splat(x as f32));
                for i in node(j, 0, 0)..node(j + 1, 0, 0) {
                    w[i] = v;
                    beyond4[i] = Spectrum::splat((q * q * q * q) as f32);
                }
                continue;
            }
            let surface = super::facets::Microsurface::new(spec.geometry, wp);
            let chain = FacetChain::new(spec.geometry, wp, &surface);
            let nf = chain.n;
            // v_n = Q^{n−1} e (n = 1..3), Q³·1 and Q⁴·1 (white: (I − Q)⁻¹ e = 1).
            let apply = |x: &[f64; 3]| -> [f64; 3] {
                let mut y = [0.0; 3];
                for (a, ya) in y.iter_mut().enumerate().take(nf) {
                    for (b, xb) in x.iter().enumerate().take(nf) {
                        *ya += chain.q[a][b] as f64 * xb;
                    }
                }
                y
            };
            let e: [f64; 3] = std::array::from_fn(|a| if a < nf { chain.e[a] as f64 } else { 0.0 });
            let v2 = apply(&e);
            let v3 = apply(&v2);
            let one: [f64; 3] = std::array::from_fn(|a| if a < nf { 1.0 } else { 0.0 });
            let q3 = apply(&apply(&apply(&one)));
            let q4 = apply(&q3);
            for k in 0..N_Z {
                for l in 0..N_PHI {
                    let lam = surface.lambdas(node_direction(k, l));
                    let dot = |v: &[f64; 3]| -> f32 {
                        (0..nf).map(|a| lam[a] as f64 * v[a]).sum::<f64>() as f32
                    };
                    let i = node(j, k, l);
                    w[i] = [dot(&e), dot(&v2), dot(&v3), dot(&q3)].map(Spectrum::splat);
                    beyond4[i] = Spectrum::splat(dot(&q4));
                }
            }
        }
        Self::finish(key, spec, w, &beyond4, t0.elapsed().as_secs_f32())
    }

    /// The table as bytes for the disk cache (little-endian f32, after a header with the key).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(64 + self.key.len() + self.w.len() * ORDERS * 12);
        out.extend_from_slice(MAGIC);
        out.extend_from_slice(&(self.key.len() as u32).to_le_bytes());
        out.extend_from_slice(self.key.as_bytes());
        let mut put = |v: Spectrum| {
            for x in v.to_array() {
                out.extend_from_slice(&x.to_le_bytes());
            }
        };
        for v in &self.w {
            for &s in v {
                put(s);
            }
        }
        for v in &self.mean {
            for &s in v {
                put(s);
            }
        }
        for &s in &self.tail {
            put(s);
        }
        out
    }

    /// A table read back from [`Self::to_bytes`], if `bytes` hold exactly the table of `key`
    /// (anything else — another key, a short or long file, non-finite values — is `None`).
    pub fn from_bytes(bytes: &[u8], key: &str, spec: TableSpec) -> Option<MsTable> {
        let floats = (N_THETA * N_Z * N_PHI * ORDERS + N_THETA * ORDERS + N_THETA) * 3;
        let head = MAGIC.len() + 4 + key.len();
        if bytes.len() != head + floats * 4 || !bytes.starts_with(MAGIC) {
            return None;
        }
        let len = u32::from_le_bytes(bytes[MAGIC.len()..MAGIC.len() + 4].try_into().ok()?);
        if len as usize != key.len() || &bytes[MAGIC.len() + 4..head] != key.as_bytes() {
            return None;
        }
        let mut f = bytes[head..]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]));
        let mut spectrum = || -> Option<Spectrum> {
            let v = Vec3::new(f.next()?, f.next()?, f.next()?);
            v.is_finite().then_some(v)
        };
        let mut w = Vec::with_capacity(N_THETA * N_Z * N_PHI);
        for _ in 0..N_THETA * N_Z * N_PHI {
            w.push([spectrum()?, spectrum()?, spectrum()?, spectrum()?]);
        }
        let mut mean = [[Spectrum::ZERO; ORDERS]; N_THETA];
        for m in mean.iter_mut() {
            *m = [spectrum()?, spectrum()?, spectrum()?, spectrum()?];
        }
        let mut tail = [Spectrum::ZERO; N_THETA];
        for t in tail.iter_mut() {
            *t = spectrum()?;
        }
        Some(Self::assemble(key.to_string(), spec, w, mean, tail, 0.0))
    }
}

const MAGIC: &[u8] = b"groove-ms-table\n";

/// One (θp node, z node) of a walk build: per φ node the values W1, W2, W3, W≥4 and W≥5.
type Row = (usize, usize, Vec<([Spectrum; ORDERS], Spectrum)>);

/// r̄ = W̄≥5/W̄≥4 in [0, 0.999] (0 where there is no energy beyond the third order).
fn ratio(r: f64, denom: f64) -> f32 {
    if denom > 0.0 && r.is_finite() {
        r.clamp(0.0, 0.999) as f32
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bsdf::lanes::testing::{direction, same3};
    use crate::math::{warp, Pcg32};

    /// A table with random node values, different per channel and order (the lookups' sums
    /// must keep every channel and node apart), assembled as a table read from the disk is.
    fn random_table(rng: &mut Pcg32) -> MsTable {
        let spec = TableSpec {
            geometry: Microgeometry::VGroove,
            tangent: Tangent::Same,
            max_order: 256,
            max_theta: 85f32.to_radians(),
            colour: Colour::Baked,
            walks: WALKS_PER_NODE,
        };
        let mut v = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let w = (0..N_THETA * PLANE).map(|_| [v(), v(), v(), v()]).collect();
        let mean = std::array::from_fn(|_| [v(), v(), v(), v()]);
        let tail = std::array::from_fn(|_| v());
        MsTable::assemble("random".into(), spec, w, mean, tail, 0.0)
    }

    /// The 8-wide lookups ([`MsTable::lookup_baked_x8`], with and without W1) and the lane
    /// kernel at width 1 ([`interpolate_baked_lanes`] after [`coords`]) equal the scalar
    /// [`MsTable::lookup_baked`] bit for bit, lane by lane: random ωp up to the table's largest
    /// θp (its last cell included), directions over the upper hemisphere with grazing, normal
    /// and node-exact ones mixed in, lanes without a cell left 0.
    #[test]
    fn lane_lookups_equal_the_scalar_ones() {
        let mut rng = Pcg32::new(14, 4);
        let table = random_table(&mut rng);
        let (mut looked, mut last_cell) = (0, 0);
        for round in 0..4000 {
            let mut cells = [None; 8];
            let mut w = [Vec3::Z; 8];
            let mut q = Lookups8::new();
            for k in 0..8 {
                if rng.next_f32() < 0.15 {
                    continue; // a lane without a cell
                }
                let cos_max = if round % 4 == 0 { 0.0872 } else { 0.0 };
                let wp = warp::square_to_uniform_cone(
                    [rng.next_f32(), rng.next_f32()].into(),
                    cos_max.max(85f32.to_radians().cos() * rng.next_f32()),
                );
                if wp.x == 0.0 && wp.y == 0.0 {
                    continue;
                }
                let c = table.cell(wp);
                last_cell += usize::from(c.j == N_THETA - 2);
                cells[k] = Some(c);
                let d = direction(&mut rng);
                w[k] = match rng.next_f32() {
                    x if x < 0.05 => MsTable::direction(rng.next_u32() as usize % N_Z, 3),
                    _ => Vec3::new(d.x, d.y, d.z.abs().max(1e-6)),
                };
                q.push(k, &c, w[k]);
            }
            for with_first in [true, false] {
                let got = table.lookup_baked_x8(&q, with_first);
                for k in 0..8 {
                    let want = match &cells[k] {
                        Some(c) => table.lookup_baked(c, w[k], with_first),
                        None => [Spectrum::ZERO; 2],
                    };
                    let at = format!("round {round} lane {k} {:?} {}", cells[k], w[k]);
                    assert!(same3(got[k][0], want[0]), "{at}: {:?} vs {want:?}", got[k]);
                    assert!(same3(got[k][1], want[1]), "{at}: {:?} vs {want:?}", got[k]);
                    let Some(c) = &cells[k] else { continue };
                    let co = coords::<f32>(V2::from(c.axis), V3::from(w[k]));
                    let one: [Vec3; 2] = interpolate_baked_lanes::<f32>(
                        &table.e_nodes,
                        &table.e1_nodes,
                        (c.j * PLANE) as i32,
                        c.t,
                        &co,
                        with_first,
                    )
                    .map(Vec3::from);
                    assert!(same3(one[0], want[0]) && same3(one[1], want[1]), "{at}");
                    looked += 1;
                }
            }
        }
        // 4000 rounds of ~6.8 cells, twice; the last θp cell reached by the steep quarter.
        assert!(
            looked > 50_000 && last_cell > 500,
            "{looked} lookups, {last_cell} in the last cell"
        );
    }

    /// The baked 1 / (π Ē_ms) of 8 cells at once ([`MsTable::baked_norms_x8`]) equals the
    /// scalar one (`MsPlace::in_cell`'s: [`MsTable::mean_baked`], 1/x where x > 0, else 0,
    /// times 1/π) bit for bit, lane by lane; and [`MsTable::lookup_baked_e_lanes`] equals
    /// `lookup_baked(…, false)[1]`. Random tables whose Ē_ms nodes hold edge values (±0,
    /// negative, subnormal, huge, ±∞, NaN) among random ones, every θp cell, weights t of 0 and
    /// 1 among random ones.
    #[test]
    fn baked_norms_and_e_lanes_equal_the_scalar_ones() {
        let mut rng = Pcg32::new(20, 2);
        let edges = [
            0.0,
            -0.0,
            -0.5,
            1e-40,
            -1e-40,
            3e38,
            1e-38,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
        ];
        let (mut compared, mut zero, mut odd) = (0, 0, 0);
        for round in 0..40 {
            let mut table = random_table(&mut rng);
            for m in table.mean_e.iter_mut() {
                for c in 0..3 {
                    if rng.next_f32() < 0.4 {
                        m[c] = edges[rng.next_u32() as usize % edges.len()];
                    }
                }
            }
            for _ in 0..200 {
                let mut cells = CellCols::<8> {
                    j: [0; 8],
                    t: [0.0; 8],
                    axis: [[1.0; 8], [0.0; 8]],
                };
                for k in 0..8 {
                    cells.j[k] = (rng.next_u32() as usize % (N_THETA - 1)) as i32;
                    cells.t[k] = match rng.next_f32() {
                        x if x < 0.1 => 0.0,
                        x if x < 0.2 => 1.0,
                        _ => rng.next_f32(),
                    };
                }
                let got = table.baked_norms_x8(Cols::detect(), &cells);
                for k in 0..8 {
                    let m = table.mean_baked(&cells.get(k));
                    let inv = |x: f32| if x > 0.0 { 1.0 / x } else { 0.0 };
                    let want = Vec3::new(inv(m.x), inv(m.y), inv(m.z)) * crate::math::INV_PI;
                    let g = Vec3::new(got[0][k], got[1][k], got[2][k]);
                    assert!(
                        same3(g, want),
                        "round {round} lane {k}: {g} vs {want} ({m})"
                    );
                    compared += 1;
                    zero += usize::from(want.min_element() == 0.0);
                    odd += usize::from(!m.is_finite() || m.min_element() <= 0.0);
                }
            }
            #[cfg(target_arch = "x86_64")]
            if let Some(avx) = crate::lane::Avx2::detect() {
                for _ in 0..100 {
                    let mut q = Lookups8::new();
                    let mut want = [None; 8];
                    for k in 0..8 {
                        if rng.next_f32() < 0.15 {
                            continue;
                        }
                        let wp = warp::square_to_uniform_cone(
                            [rng.next_f32(), rng.next_f32()].into(),
                            85f32.to_radians().cos(),
                        );
                        if wp.x == 0.0 && wp.y == 0.0 {
                            continue;
                        }
                        let c = table.cell(wp);
                        let d = direction(&mut rng);
                        let w = Vec3::new(d.x, d.y, d.z.abs().max(1e-6));
                        q.push(k, &c, w);
                        want[k] = Some(table.lookup_baked(&c, w, false)[1]);
                    }
                    let e = avx.run(|| {
                        let e = table.lookup_baked_e_lanes(avx, &q);
                        [e.x.to_array(), e.y.to_array(), e.z.to_array()]
                    });
                    for (k, w) in want.iter().enumerate() {
                        let Some(w) = w else { continue };
                        let g = Vec3::new(e[0][k], e[1][k], e[2][k]);
                        assert!(same3(g, *w), "round {round} lane {k}: {g} vs {w}");
                    }
                }
            }
        }
        assert!(
            compared == 64_000 && zero > 5_000 && odd > 5_000,
            "{compared} lanes, {zero} with a zero channel, {odd} with an edge Ē_ms"
        );
    }

    /// The scalar lookups' coordinates ([`coords_one`]) are the lane kernel's at width 1 bit
    /// for bit: random directions and azimuths, with directions on every φ node (x exactly a
    /// node's cosine, both signs), on every z node, straight up (r² = 0), grazing and below.
    #[test]
    fn one_direction_coordinates_equal_the_lane_kernels() {
        let mut rng = Pcg32::new(15, 3);
        let mut on_node = 0;
        for round in 0..200_000 {
            let a = rng.next_f32() * std::f32::consts::TAU;
            let axis = match round % 7 {
                0 => Vec2::X,
                _ => Vec2::new(a.cos(), a.sin()),
            };
            let d = direction(&mut rng);
            let w = match round % 5 {
                0 => MsTable::direction(
                    rng.next_u32() as usize % N_Z,
                    rng.next_u32() as usize % N_PHI,
                ),
                1 => Vec3::Z,
                2 => Vec3::new(d.x, d.y, d.z.abs() * 1e-3),
                3 => Vec3::new(d.x, d.y, -d.z.abs()),
                _ => Vec3::new(d.x, d.y, d.z.abs()),
            };
            // Node directions are for ωp along +x: there x is a node's cosine.
            on_node += usize::from(round % 5 == 0 && axis == Vec2::X);
            let one = coords_one(axis, w);
            let lane = coords::<f32>(V2::from(axis), V3::from(w));
            assert_eq!(
                (one.kz, one.l, one.tu.to_bits(), one.tx.to_bits()),
                (lane.kz, lane.l, lane.tu.to_bits(), lane.tx.to_bits()),
                "{axis} {w}"
            );
        }
        assert!(on_node > 4000, "{on_node}");
    }
}
