//! The compensated model at the 8 shading points of a stream chunk (issue 18, `docs/mnm.md`
//! "the compensated model in lanes"): each point keeps its own microsurface, entries and table
//! cell (scalar, per point, as [`super::eval_pdf`] and [`super::sample`] compute them), while
//! the first order's nested evaluations of all 8 points — up to 4 pairs each — are packed into
//! one batch of [`CHUNK`] pairs and evaluated in full 8-wide calls of the nested BSDF's lane
//! form (instead of one call per point with at most 4 of 8 lanes busy). A pair's values do not
//! depend on its neighbours in the batch (the lane rule of [`crate::lane`]), and the sums are
//! [`Collected::sum`], the scalar model's own code, so every point's result is the scalar
//! model's bit for bit (`tests`). The sampler runs with per-lane decisions (lobe choice, cosine
//! lobe, first-order entry, mirror wall), its nested samples of all 8 points in one 8-wide call
//! of the nested BSDF's lane form ([`sample`]); over the mirror sawtooth its random numbers
//! are drawn for the 8 points at once, as masked 8-wide PCG32 steps on their streams
//! ([`draws`]).
//!
//! The points' state at their ωi (the [`AtWi`] of each, its entries) is computed once per
//! chunk for both queries ([`Chunk`]): the baked table's lookups at ωi 8-wide, over the
//! mirror sawtooth the entries in lanes, else per point.
//!
//! Over the mirror sawtooth (every point of the call), the whole first order at ωo runs in
//! lanes, one lane per point ([`first`], instead of `Collected` and the batch): G1, the wall
//! exit, the four nested paths and their sums, from the points' facets, frames and entries
//! in the chunk's columns, in the scalar code's operations and order (bit for bit: `tests`
//! and `first`'s own).
//!
//! The stream kernel builds its points over the mirror sawtooth without their maps
//! ([`Chunk::of_facets`], [`Chunk::set_lanes`]): the build's facet and frame columns are the
//! chunk's as they are, each point keeps only its place in the table ([`MsPlace`]), and the
//! sampler's last step reads the point's microsurface from the columns (`first::Lane8`, the
//! map's numbers in the map's operations), so the answers are the scalar model's over the map
//! (`tests`).
//!
//! The points of one call must share their nested BSDF's parameters bit for bit (the batch
//! evaluates with the first point's): the stream kernel groups them so (a material whose
//! nested leaf has no textured parameter).

use super::super::facets::FacetCols;
pub(crate) use super::super::lane_cols::Cols;
use super::super::ms_table::{CellCols, Colour, Lookups8, MsTable};
use super::super::nested_batch::{Pairs, CHUNK};
#[cfg(target_arch = "x86_64")]
mod draws;
mod first;
mod sample;
#[cfg(target_arch = "x86_64")]
mod walk;
#[cfg(target_arch = "x86_64")]
pub(crate) use walk::{sample_walks_x8, BuiltFacets, WalkGroups, WalkSamples};
#[cfg(target_arch = "x86_64")]
mod walk_eval;
#[cfg(target_arch = "x86_64")]
pub(crate) use walk_eval::{eval_walks_x8, EvalQuery, FirstConnections};
#[cfg(target_arch = "x86_64")]
mod walk_eval_t;
#[cfg(target_arch = "x86_64")]
pub(crate) use walk_eval_t::{two_sided_evals_x8, TwoSidedEvals};

use super::{
    leave, pick_entry, sample_record_is_exact, AtIncident, AtWi, Collected, Entries, Known,
    MsPlace, Nested,
};
use crate::bsdf::mnm::MicrofacetNormalMap;
use crate::bsdf::{Bsdf, BsdfArena, BsdfContext, BsdfSample};
use crate::math::{warp, INV_PI};
#[cfg(test)]
use crate::sampler::Sampler;
use crate::sampler::{Draw, Samplers};
#[cfg(test)]
use crate::spectrum::Spectrum;
use glam::Vec3;

/// One shading point of the chunk: the compensated model alone
/// ([`crate::bsdf::mnm::compensated_alone`]) over a nested BSDF with a lane form, seen from
/// `wi` (shading frame): its map (`None` for a point over the mirror sawtooth built without
/// one, `Chunk::of_lanes`: its microsurface is in the chunk's columns) and its place in the
/// table (the map's `MsRef` without the ωi cache, which the chunk does not read).
#[derive(Clone, Copy)]
pub(crate) struct Point<'a> {
    m: Option<&'a MicrofacetNormalMap>,
    r: MsPlace,
    nested: Bsdf<'a>,
    wi: Vec3,
}

impl<'a> Point<'a> {
    /// `Some` when `eval_pdf` and `sample` of the root `b` run the compensated model alone and
    /// its nested BSDF has a lane form (`diffuse`, `roughconductor`, `roughplastic`).
    #[inline]
    pub(crate) fn of(b: Bsdf<'a>, wi: Vec3) -> Option<Self> {
        let (m, r, nested) = crate::bsdf::mnm::compensated_alone(b)?;
        if let Nested::Other(_) = Nested::of(&nested) {
            return None;
        }
        Some(Point {
            m: Some(m),
            r: r.place,
            nested,
            wi,
        })
    }

    /// The point's map (a point built with one: over another microgeometry than the mirror
    /// sawtooth every point is).
    #[inline(always)]
    fn map(&self) -> &'a MicrofacetNormalMap {
        self.m.expect("a point off the mirror sawtooth has its map")
    }
}

/// The chunk's points and what they compute once for their ωi, for both queries
/// ([`eval_pdf_x8_into`] toward the light points, [`sample_x8_cols`] for the next bounce): each point's
/// ωi state ([`AtWi`]) and entries, and over the mirror sawtooth the first order's per-point
/// inputs in columns ([`first::Points8`]). In place by lane (lane k's values are read only
/// where bit k of `above` is set).
pub(crate) struct Chunk<'a> {
    /// The points' rows, where a query reads them ([`Self::point`]): none for the points that
    /// [`Self::set_lanes`] placed in the baked lookups (their places are in `q`, `table` and
    /// `norm`, [`Self::place`]).
    pts: [Option<Point<'a>>; 8],
    /// Bit k: lane k has a point (with or without its row in `pts`).
    on: u8,
    /// The nested BSDF the points share (the first point's; `None` without a point).
    nested: Option<Bsdf<'a>>,
    /// Bit k: lane k has a point seen from above (ωi.z > 0).
    above: u8,
    /// The points' state at ωi and entries as rows (`None` until a point needs one: a chunk
    /// whose points are all in the shared baked lookups over the mirror sawtooth keeps both in
    /// columns and never makes them, which saved clearing ~1.4 KB of placeholders per chunk,
    /// a `memset` call; [`Self::at`], [`Self::entries`], [`rows`]).
    rows: Option<Rows>,
    /// Every point is over the mirror sawtooth (its first orders run in lanes, from `geo`).
    mirror: bool,
    geo: first::Points8,
    /// The lookups at ωi of the points with the shared baked table (`table`; the lanes of
    /// `q.used()`): each query's remainders at ωo look up in the same cells
    /// ([`remainders`], in lanes).
    q: Lookups8,
    table: Option<&'static MsTable>,
    /// Those points' E_ms(ωi) and 1 / (π Ē_ms) (their `AtWi`'s `ei` and `norm`), by channel.
    ei: [[f32; 8]; 3],
    norm: [[f32; 8]; 3],
    /// The points' lobe choice s(ωi) (their `AtWi`'s `select`) by lane, 0 in lanes without a
    /// point seen from above: the samples' densities in lanes ([`finish_samples`]).
    sel: [f32; 8],
    /// [`Self::set_lanes`] placed the points with the baked table in the lookups at ωi
    /// (`above`, `q`, `table`, `norm`, the entries' ωi): [`Self::prepare`] does not walk the
    /// points again.
    placed: bool,
    /// 8-wide or lane by lane (the CPU's answer, taken once per chunk): every query's and
    /// state's column code reads it instead of detecting AVX2 itself.
    cols: Cols,
}

impl<'a> Chunk<'a> {
    /// The chunk of the points `pts` (lanes without a point: `None`; see [`Point`]) before
    /// their state at ωi, which [`Self::prepare`] then computes in place: a plain struct
    /// literal, built in the caller's slot (built and returned as one value, the ~3 KB chunk
    /// was copied by a `memcpy` call per chunk). Its column code 8-wide or not as `cols` says
    /// (the stream kernel's AVX2 token, `Cols::of`).
    #[inline(always)]
    pub(crate) fn of(cols: Cols, pts: [Option<Point<'a>>; 8]) -> Self {
        let mut on = 0u8;
        for (k, pt) in pts.iter().enumerate() {
            on |= u8::from(pt.is_some()) << k;
        }
        Chunk {
            pts,
            on,
            nested: shared(&pts),
            above: 0,
            rows: None,
            mirror: all_mirror(&pts),
            geo: first::Points8::new(),
            q: Lookups8::new(),
            table: None,
            ei: [[0.0; 8]; 3],
            norm: [[0.0; 8]; 3],
            sel: [0.0; 8],
            placed: false,
            cols,
        }
    }

    /// The chunk of the stream kernel's points over the mirror sawtooth built without their
    /// maps (issue 18), from the build's columns `facets` (`MnmSettings::lanes_at`): the
    /// facets and frames go to the chunk's columns as they are
    /// ([`first::Points8::of_facets`]); then [`Self::set_lanes`] places the points and
    /// [`Self::prepare`] computes their state, as for [`Self::of`]. A struct literal, built in
    /// the caller's slot.
    #[inline(always)]
    pub(crate) fn of_facets(cols: Cols, facets: &FacetCols<8>) -> Self {
        Chunk {
            pts: [None; 8],
            on: 0,
            nested: None,
            above: 0,
            rows: None,
            mirror: true,
            geo: first::Points8::of_facets(facets),
            q: Lookups8::new(),
            table: None,
            ei: [[0.0; 8]; 3],
            norm: [[0.0; 8]; 3],
            sel: [0.0; 8],
            placed: false,
            cols,
        }
    }

    /// The points of a chunk from [`Self::of_facets`]: lane k (bit k of `lanes`) is the point
    /// that `MnmSettings::map_lane_into` would write from lane k of the build (its
    /// microsurface keeps both candidates, [`FacetCols::keeps`]; not flat; a compensated map
    /// alone, see [`Point`]) with θp cell `cells.get(k)` in `table`, over the shared nested BSDF
    /// `nested`, seen from ωi (lane k of `wi`, by component): its facets and frame are the
    /// map's, its table reference the map's (`MsPlace::in_cell`'s, its baked 1 / (π Ē_ms) for
    /// the 8 cells at once: [`MsTable::baked_norms_x8`]), so every query answers as over the
    /// map (`tests`).
    ///
    /// With the colours baked in, no `Point` row is built (eight ~80-byte rows per chunk that
    /// no query over the mirror sawtooth reads): the points seen from above go to the lookups
    /// at ωi and the entries' ωi from the columns as they are ([`Lookups8::push_lanes`],
    /// [`first::Points8::push_wi_lanes`]), their 1 / (π Ē_ms) is `norms` as it is, and a lane's
    /// place, where a CPU without AVX2 reads it, comes back from those ([`Self::place`]).
    /// With per-bounce colours the rows are built and [`Self::prepare`] walks them.
    #[inline(always)]
    pub(crate) fn set_lanes(
        &mut self,
        nested: Bsdf<'a>,
        table: &'static MsTable,
        cells: &CellCols<8>,
        lanes: u8,
        wi: &[[f32; 8]; 3],
    ) {
        self.on = lanes;
        self.nested = (lanes != 0).then_some(nested);
        if table.spec.colour != Colour::Baked {
            for (k, pt) in self.pts.iter_mut().enumerate() {
                if lanes & (1 << k) != 0 {
                    let r = MsPlace {
                        table,
                        cell: cells.get(k),
                        baked_norm: None,
                    };
                    *pt = Some(Point {
                        m: None,
                        r,
                        nested,
                        wi: Vec3::new(wi[0][k], wi[1][k], wi[2][k]),
                    });
                }
            }
            return;
        }
        // What [`Self::prepare`]'s walk over the points would do for them, from the columns
        // here (every point shares `table`, so each one seen from above looks up at ωi with
        // the others; its 1 / (π Ē_ms) is its lane of the norms, as in its `MsPlace`);
        // `prepare` then goes on from their state at ωi. (`prepare`'s test, z ≤ 0 skipped: a
        // NaN z is not.)
        let (q, geo) = (&mut self.q, &mut self.geo);
        let above = self.cols.run(
            #[inline(always)]
            |cols| {
                let above = cols.not_le_zero(&wi[2]) & lanes;
                q.push_lanes(cols, above, cells, wi);
                geo.push_wi_lanes(cols, above, wi);
                above
            },
        );
        self.norm = table.baked_norms_x8(self.cols, cells);
        self.above = above;
        self.table = Some(table);
        self.placed = true;
    }

    /// Lane `k` has a point (its queries go through the chunk).
    #[inline(always)]
    pub(crate) fn has(&self, k: usize) -> bool {
        self.on & (1 << k) != 0
    }

    /// The lanes with a point, as bits (bit k: lane k; [`Self::has`]).
    #[inline(always)]
    pub(crate) fn lanes(&self) -> u8 {
        self.on
    }

    /// [`Self::of`] and [`Self::prepare`] (the tests' chunks).
    #[cfg(test)]
    pub(crate) fn new(pts: [Option<Point<'a>>; 8]) -> Self {
        let mut c = Self::of(Cols::detect(), pts);
        c.prepare();
        c
    }

    /// The state of the points, as the scalar model computes it per query (bit for bit,
    /// `tests`), for the 8 points together: the table lookups at ωi of the points with a baked
    /// table in one [`MsTable::lookup_baked_x8`] with W1 (the first such point's table; a
    /// point with another table, or per-bounce colours, looks up alone), and over the mirror
    /// sawtooth the entries in lanes ([`first::Points8::entries`]), else per point. The maps'
    /// own ωi caches are not needed (nor read: the same numbers). Call once, on a chunk fresh
    /// from [`Self::of`].
    #[inline(always)]
    pub(crate) fn prepare(&mut self) {
        let mirror = self.mirror;
        let q = &mut self.q;
        let mut table: Option<&'static MsTable> = self.table;
        for k in 0..8 {
            if self.placed {
                break; // `set_lanes` placed the points (each in the shared baked lookups)
            }
            // The point read in place (a copy of the ~80-byte `Point` per lane cost more than
            // the reads it saved).
            let Some(pt) = &self.pts[k] else { continue };
            let wi = pt.wi;
            if wi.z <= 0.0 {
                continue;
            }
            let r = &pt.r;
            if r.baked_norm.is_some() && std::ptr::eq(*table.get_or_insert(r.table), r.table) {
                q.push(k, &r.cell, wi);
            } else {
                rows(&mut self.rows).at[k] = AtWi::new(r, &pt.nested, wi, None);
            }
            match (mirror, pt.m) {
                (true, Some(m)) => self.geo.push_point(k, m, wi),
                (true, None) => self.geo.push_wi(k, wi),
                (false, _) => rows(&mut self.rows).e[k] = Entries::new(pt.map(), wi),
            }
            self.above |= 1 << k;
        }
        if let Some(t) = table {
            self.baked_state(t);
        }
        self.table = table;
        for k in 0..8 {
            if self.above & (1 << k) != 0 && !self.q.is_used(k) {
                self.sel[k] = self.at(k).select;
            }
        }
        if mirror {
            self.geo.clear_unpushed();
        }
        // Over the mirror sawtooth the entries stay in the columns (no `Entries` row per
        // point: the sampler picks from the columns, `first::Points8::pick`).
        if mirror && self.above != 0 {
            self.geo.entries(self.cols);
        }
    }

    /// The state at ωi of the points of the lookups `q` (those with the shared baked table
    /// `t`), in columns: E_ms(ωi) (`ei`), 1 / (π Ē_ms) (`norm`, the points' own) and the lobe
    /// choice s(ωi) (`sel`), the numbers of `AtWi::baked` over `lookup_baked(.., true)` per
    /// point: 8-wide when the CPU has AVX2 and FMA ([`MsTable::baked_lanes`],
    /// [`selection_lanes`]; the queries then read the columns only), else per point (also
    /// kept in `at`, which the remainders then read). Lanes of `sel` and `ei` without a lookup
    /// hold any value until [`Self::prepare`] sets theirs.
    #[inline(always)]
    fn baked_state(&mut self, t: &'static MsTable) {
        // (After `set_lanes`, `norm` is written.)
        for k in 0..8 {
            if self.placed {
                break;
            }
            if let (Some(pt), true) = (&self.pts[k], self.q.is_used(k)) {
                let n = pt.r.baked_norm.expect("a point of the baked lookups");
                for (c, col) in self.norm.iter_mut().enumerate() {
                    col[k] = n[c];
                }
            }
        }
        #[cfg(target_arch = "x86_64")]
        if let Some(avx) = self.cols.avx() {
            let (q, ei, sel) = (&self.q, &mut self.ei, &mut self.sel);
            avx.run(
                #[inline(always)]
                || {
                    let [w1, e] = t.baked_lanes(avx, q, true);
                    e.x.store(&mut ei[0]);
                    e.y.store(&mut ei[1]);
                    e.z.store(&mut ei[2]);
                    selection_lanes(e, w1).store(sel);
                },
            );
            return;
        }
        let l = t.lookup_baked_x8(&self.q, true);
        for (k, &lk) in l.iter().enumerate() {
            if self.has(k) && self.q.is_used(k) {
                let at = AtWi::baked(&self.place(k), lk);
                for c in 0..3 {
                    self.ei[c][k] = at.ei[c];
                }
                self.sel[k] = at.select;
                rows(&mut self.rows).at[k] = at;
            }
        }
    }

    /// Lane `k`'s state at ωi as a row (the placeholder [`AtWi::UNUSED`] where none was made:
    /// a lane that [`Self::prepare`] left without one).
    #[inline(always)]
    fn at(&self, k: usize) -> &AtWi {
        self.rows.as_ref().map_or(&AtWi::UNUSED, |r| &r.at[k])
    }

    /// Lane `k`'s entries as a row (off the mirror sawtooth; [`Entries::EMPTY`] where none was
    /// made).
    #[inline(always)]
    fn entries(&self, k: usize) -> &Entries {
        self.rows.as_ref().map_or(&Entries::EMPTY, |r| &r.e[k])
    }

    /// Whether lane `k` has a point seen from above.
    #[inline(always)]
    fn is_above(&self, k: usize) -> bool {
        self.above & (1 << k) != 0
    }

    /// Lane `k`'s point as a row: a chunk off the mirror sawtooth (from [`Self::of`]: every
    /// point has its row), where the queries read its map.
    #[inline(always)]
    fn point(&self, k: usize) -> &Point<'a> {
        self.pts[k]
            .as_ref()
            .expect("a point off the mirror sawtooth has its row")
    }

    /// Lane `k`'s place in the table (a point's): its row's, or for a point that
    /// [`Self::set_lanes`] placed in the baked lookups without a row, the same place from the
    /// lookups' cell (`Lookups8::get`: the cell pushed, as `CellCols::get` gives it), the
    /// chunk's table and its lane of `norm`.
    #[inline(always)]
    fn place(&self, k: usize) -> MsPlace {
        match (&self.pts[k], self.q.get(k), self.table) {
            (Some(pt), _, _) => pt.r,
            (None, Some((cell, _)), Some(table)) => MsPlace {
                table,
                cell,
                baked_norm: Some(Vec3::new(self.norm[0][k], self.norm[1][k], self.norm[2][k])),
            },
            _ => unreachable!("a point without its row is in the baked lookups"),
        }
    }
}

/// The points' state at ωi ([`AtWi`]) and entries as rows, by lane: what [`Chunk::prepare`]
/// computes per point for a point outside the shared baked lookups (another table, per-bounce
/// colours, a CPU without AVX2) or off the mirror sawtooth. Lanes without a row hold the
/// placeholders.
struct Rows {
    at: [AtWi; 8],
    e: [Entries; 8],
}

/// The chunk's rows `r`, made (placeholders in every lane) on the first write.
#[inline(always)]
fn rows(r: &mut Option<Rows>) -> &mut Rows {
    r.get_or_insert_with(
        #[inline(always)]
        || Rows {
            at: [AtWi::UNUSED; 8],
            e: [Entries::EMPTY; 8],
        },
    )
}

/// What the points keep between the passes of one query, in place by lane (lane k's values are
/// read only where bit k of `live` is set; the others hold placeholders): fixed arrays written
/// once per point instead of per-point records moved through `Option`s (each such move of a
/// few hundred bytes was a `memcpy` call).
struct States {
    /// Bit k: lane k has a point whose first order is pending.
    live: u8,
    known: [Option<Known>; 8],
}

impl States {
    #[inline(always)]
    fn new() -> Self {
        States {
            live: 0,
            known: [None; 8],
        }
    }

    #[inline(always)]
    fn is_live(&self, k: usize) -> bool {
        self.live & (1 << k) != 0
    }
}

/// The first order's state off the mirror sawtooth: each point's `Collected` (in place by lane,
/// as [`States`]) and their nested pairs in one batch. Made only for such chunks: its ~1.2 KB
/// of placeholders were initialised (a `memcpy` call) for every query of every chunk, though a
/// mirror-sawtooth chunk reads none of them.
struct General {
    c: [Collected; 8],
    pairs: Pairs<CHUNK>,
}

impl General {
    #[inline(always)]
    fn new() -> Self {
        General {
            c: [Collected::UNUSED; 8],
            pairs: Pairs::<CHUNK>::new(),
        }
    }

    /// Lane `k`'s point `pt` (with its entries `e`) toward `wo`, with the drawn path's `known`
    /// term.
    #[inline(always)]
    fn push(&mut self, k: usize, pt: &Point, e: &Entries, wo: Vec3, known: Option<Known>) {
        self.c[k] = Collected::new(pt.map(), e, wo, known, &mut self.pairs);
    }
}

/// Each live point's rank-1 remainder at its ωo ([`AtWi::remainder`]), by channel, by lane
/// (`live`: bit k for lane k; the lanes that are not live hold any value), toward lane k of
/// `wo` (by component): the points with the chunk's shared baked table in lanes
/// ([`remainders_x8`]: their cells from [`Chunk::prepare`]'s lookups at ωi), each other point
/// (another table, per-bounce colours, a CPU without AVX2) alone.
fn remainders(live: u8, wo: &[[f32; 8]; 3], c: &Chunk) -> [[f32; 8]; 3] {
    let mut out = [[0.0f32; 8]; 3];
    let mut rest = live;
    #[cfg(target_arch = "x86_64")]
    if let (Some(t), Some(avx)) = (c.table, c.cols.avx()) {
        let lanes = live & c.q.used();
        if lanes != 0 {
            out = remainders_x8(avx, t, c, lanes, wo);
            rest &= !lanes;
        }
    }
    while rest != 0 {
        let k = rest.trailing_zeros() as usize;
        rest &= rest - 1;
        if c.has(k) {
            let w = Vec3::new(wo[0][k], wo[1][k], wo[2][k]);
            let r = c.at(k).remainder(&c.place(k), w);
            for (ch, o) in out.iter_mut().enumerate() {
                o[k] = r[ch];
            }
        }
    }
    out
}

/// [`AtWi::remainder`] of the points `lanes` (bit k: lane k; each a point of the chunk's
/// lookups at ωi in baked `table`, [`Chunk::prepare`]) toward lane k of `wo` (by component;
/// z > 0), 8-wide: E_ms(ωo) from the same cells ([`MsTable::lookup_baked_e_lanes`], each lane
/// the scalar `lookup_baked`; the directions blended in, [`Lookups8::set_directions`]), then
/// `remainder_from`'s products in its order per channel, ((E_ms(ωi) · E_ms(ωo)) · 1/(πĒ_ms)) ·
/// z(ωo), and 0 where E_ms(ωi) = 0 (the scalar code's early return, whose lookup it skips).
/// By channel, by lane; other lanes hold any value.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn remainders_x8(
    avx: crate::lane::Avx2,
    table: &'static MsTable,
    c: &Chunk,
    lanes: u8,
    wo: &[[f32; 8]; 3],
) -> [[f32; 8]; 3] {
    use crate::lane::Lane;
    avx.run(
        #[inline(always)]
        || {
            let mut q = c.q;
            q.set_directions(Cols::of(avx), lanes, wo);
            let eo = table.lookup_baked_e_lanes(avx, &q);
            let zero = avx.splat(0.0);
            let z = crate::lane::F32x8::select(
                avx.mask_bits(u32::from(lanes)),
                avx.load(&wo[2]),
                avx.splat(1.0),
            );
            let ei = [avx.load(&c.ei[0]), avx.load(&c.ei[1]), avx.load(&c.ei[2])];
            let none = ei[0].eq(zero) & ei[1].eq(zero) & ei[2].eq(zero);
            let mut out = [[0.0f32; 8]; 3];
            for (ch, e) in [eo.x, eo.y, eo.z].into_iter().enumerate() {
                let r = ei[ch] * e * avx.load(&c.norm[ch]) * z;
                crate::lane::F32x8::select(none, zero, r).store(&mut out[ch]);
            }
            out
        },
    )
}

/// [`MicrofacetNormalMap::with_incident`] of up to 8 points at once, in place: the microfacet
/// normal maps of `arena` at the nodes `roots[k]` (`u32::MAX`: no point), seen from `wi[k]` (the
/// per-hit build of the stream kernel, `docs/mnm.md` "the compensated build and sampler in
/// lanes"). The table lookups at ωi of the points with a baked table in one
/// [`MsTable::lookup_baked_x8`] with W1 (the node coordinates and weights 8-wide; the first such
/// point's table, a point with another table looks up alone), the entries per point. Bit for
/// bit the scalar cache (`tests`).
pub(crate) fn with_incident_x8(arena: &mut BsdfArena, roots: &[u32; 8], wi: &[Vec3; 8]) {
    // Pass 1: the lanes that get a cache (bit k of `wanted`) and the baked table's cells. The
    // table reference is read in place (a copy of the `MsRef` would copy its cache slot too).
    let mut q = Lookups8::new();
    let mut wanted = 0u8;
    let mut table: Option<&'static MsTable> = None;
    for (k, &root) in roots.iter().enumerate() {
        let Some(m) = arena.mnm_mut(root) else {
            continue;
        };
        let Some(r) = m.ms.as_ref().filter(|_| AtIncident::wanted(m, wi[k])) else {
            continue;
        };
        wanted |= 1 << k;
        if r.baked_norm.is_some() && std::ptr::eq(*table.get_or_insert(r.table), r.table) {
            q.push(k, &r.cell, wi[k]);
        }
    }
    let looked = table.map(|t| t.lookup_baked_x8(&q, true));
    // Pass 2: each wanted lane's cache, written into its map.
    for (k, &root) in roots.iter().enumerate() {
        if wanted & (1 << k) == 0 {
            continue;
        }
        let m = arena.mnm_mut(root).expect("a wanted lane's map");
        let at = match (looked.filter(|_| q.is_used(k)), &m.ms) {
            (Some(l), _) => AtIncident::from_lookup(m, wi[k], l[k]),
            (_, Some(r)) => AtIncident::new(m, r, wi[k]),
            (_, None) => unreachable!("a wanted lane has a table"),
        };
        if let Some(r) = &mut m.ms {
            r.at = Some(at);
        }
    }
}

/// [`with_incident_x8`] for the maps among `roots` that are no [`Point`] (the scalar model
/// answers their queries; a [`Chunk`] computes its points' ωi state itself). Whether a
/// non-degenerate map is a point depends on its material only (the nested BSDF's kind, the
/// closed forms, the blend), the same for every map of the stream kernel's chunk, and a
/// degenerate one wants no cache: when the first map is a point, none is built.
pub(crate) fn with_incident_alone_x8(arena: &mut BsdfArena, roots: &[u32; 8], wi: &[Vec3; 8]) {
    let Some(k0) = roots.iter().position(|&r| r != u32::MAX) else {
        return;
    };
    if Point::of(arena.bsdf(roots[k0]), wi[k0]).is_some() {
        return;
    }
    let mut alone = [u32::MAX; 8];
    for (k, &r) in roots.iter().enumerate() {
        if r != u32::MAX && Point::of(arena.bsdf(r), wi[k]).is_none() {
            alone[k] = r;
        }
    }
    with_incident_x8(arena, &alone, wi);
}

/// `compensated::selection` lane by lane in its operations and order: s(ωi) = Y(E_ms) /
/// (Y(W1) + Y(E_ms)) with Y the luminance (`spectrum::luminance`, its products and sums in
/// order, no fused multiply-add), each Y first raised to 0, and 0 where Y(E_ms) is not
/// positive. The x86 maximum gives 0 for NaN as `f32::max` does; where the two may differ
/// (the sign of a zero) the result does not: a zero Y(E_ms) gives 0, a zero Y(W1) adds nothing.
#[inline(always)]
fn selection_lanes<L: crate::lane::Lane>(
    ei: crate::lane::vec::V3<L>,
    first: crate::lane::vec::V3<L>,
) -> L {
    #[inline(always)]
    fn luminance<L: crate::lane::Lane>(c: crate::lane::vec::V3<L>) -> L {
        c.x.splat(0.212671) * c.x + c.x.splat(0.715160) * c.y + c.x.splat(0.072169) * c.z
    }
    let zero = ei.x.splat(0.0);
    let a = luminance(ei).max(zero);
    let b = luminance(first).max(zero);
    L::select(a.gt(zero), a / (a + b), zero)
}

/// Whether every point is over the mirror sawtooth (then their first orders run in lanes,
/// [`first::Mirror8`]).
#[inline(always)]
fn all_mirror(pts: &[Option<Point>; 8]) -> bool {
    let mut all = true;
    for pt in pts.iter().flatten() {
        all &= match pt.m {
            Some(m) => m.mirror_wall,
            None => true, // built over the mirror sawtooth (`Chunk::of_lanes`)
        };
    }
    all
}

/// The nested BSDF every pending point shares (the first one's).
fn shared<'a>(pts: &[Option<Point<'a>>; 8]) -> Option<Bsdf<'a>> {
    pts.iter().flatten().next().map(|p| p.nested)
}

/// `Bsdf::eval_pdf` of the root of each point of `c` in `lit` (bit k: lane k) toward its `wo`
/// (shading frame), as `mnm::eval_pdf` computes it: (0, 0) unless both directions are above
/// the surface. Other lanes are left (0, 0). The tests' view of [`eval_pdf_x8_into`].
#[cfg(test)]
pub(crate) fn eval_pdf_x8(
    ctx: &BsdfContext,
    c: &Chunk,
    lit: u8,
    wo: &[Vec3; 8],
) -> [(Spectrum, f32); 8] {
    let (mut f, mut p) = ([[0.0f32; 8]; 3], [0.0f32; 8]);
    let wo = [wo.map(|v| v.x), wo.map(|v| v.y), wo.map(|v| v.z)];
    eval_pdf_x8_into(ctx, c, lit, &wo, &mut f, &mut p);
    std::array::from_fn(|k| (Vec3::new(f[0][k], f[1][k], f[2][k]), p[k]))
}

/// `eval_pdf_x8` from and into the caller's columns: toward lane k of `wo` (by component),
/// lane k of `f` (by channel) and `p` gets lane k's value and density for each lane k of `lit`
/// ((0, 0) unless both directions are above the surface); other lanes are not written. The
/// stream kernel's form (no row of `(Spectrum, f32)` or `Vec3` per lane to copy from or into
/// its columns).
pub(crate) fn eval_pdf_x8_into(
    ctx: &BsdfContext,
    c: &Chunk,
    lit: u8,
    wo: &[[f32; 8]; 3],
    f: &mut [[f32; 8]; 3],
    p: &mut [f32; 8],
) {
    let _ = ctx; // the lane forms read no context
    let Some(nested) = c.nested else {
        let none = (first::FirstOrders::zero(), [[0.0; 8]; 3]);
        finish_evals(c, lit, 0, &none.0, &none.1, wo, f, p);
        return;
    };
    let kind = Nested::of(&nested);
    // Over the mirror sawtooth the first orders run in lanes ([`first`]) from the columns as
    // they are: the live lanes (lit, seen from above, ωo not below: the loop below's tests) as
    // one mask, the query's inputs by blends ([`first::Mirror8::sampled`] without a known term:
    // what [`first::Mirror8::push`] of each live lane without one gives).
    if c.mirror {
        let above = c.cols.run(
            #[inline(always)]
            |cols| cols.not_le_zero(&wo[2]),
        );
        let live = lit & c.above & above;
        if live == 0 {
            // No lane to evaluate (the chunk's lit lanes all seen from below or lit from
            // below; the tiles' neighbouring hits often are together): the lit lanes get
            // (0, 0) without the first orders' and the remainders' 8-wide work, whose lanes
            // `finish_evals` would not read.
            let none = (first::FirstOrders::zero(), [[0.0; 8]; 3]);
            finish_evals(c, lit, 0, &none.0, &none.1, wo, f, p);
            return;
        }
        let none = ([-1.0; 8], [0.0; 8], [[0.0; 8]; 3]);
        let lanes = first::Mirror8::sampled(c.cols, live, wo, 0, &none.0, &none.1, &none.2);
        let fo = lanes.eval(c.cols, &c.geo, kind);
        let rem = remainders(live, wo, c);
        finish_evals(c, lit, live, &fo, &rem, wo, f, p);
        return;
    }
    // Else each point's nested pairs go to one batch ([`General`], made only then).
    let mut general = General::new();
    let mut live = 0u8;
    for k in 0..8 {
        if !c.is_above(k) || lit & (1 << k) == 0 {
            continue;
        }
        let wo = Vec3::new(wo[0][k], wo[1][k], wo[2][k]);
        if wo.z <= 0.0 {
            continue;
        }
        general.push(k, c.point(k), c.entries(k), wo, None);
        live |= 1 << k;
    }
    let st = States {
        live,
        ..States::new()
    };
    let fo = first_orders(kind, c, &first::Mirror8::new(), Some(&general), &st, None);
    let rem = remainders(live, wo, c);
    finish_evals(c, lit, live, &fo, &rem, wo, f, p);
}

/// The last step of `mnm::eval_pdf` for the lanes `lit` of a light query (bit k: lane k) from
/// the first orders `fo` and remainders `rem` of its live lanes `live` (a subset), with the
/// lanes' lobe choice s(ωi) (`c.sel`) and directions `wo` (by component): a live lane's value
/// is f1·z(ωo) + f_ms per channel and its density (1 − s) p1 + (s z(ωo)) / π (the scalar
/// code's operations in its order, no fused multiply-add), a lit lane that is not live gets
/// (0, 0), the other lanes are kept. 8-wide when the chunk's columns are (`c.cols`: AVX2 and
/// FMA), else lane by lane (the same numbers; `tests`).
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn finish_evals(
    c: &Chunk,
    lit: u8,
    live: u8,
    fo: &first::FirstOrders,
    rem: &[[f32; 8]; 3],
    wo: &[[f32; 8]; 3],
    f: &mut [[f32; 8]; 3],
    p: &mut [f32; 8],
) {
    let sel = &c.sel;
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = c.cols.avx() {
        use crate::lane::{F32x8, Lane};
        avx.run(
            #[inline(always)]
            || {
                let (on, at) = (
                    avx.mask_bits(u32::from(live)),
                    avx.mask_bits(u32::from(lit)),
                );
                let zero = avx.splat(0.0);
                for ch in 0..3 {
                    let v = avx.load(&fo.f[ch]) + avx.load(&rem[ch]);
                    let kept = F32x8::select(at, zero, avx.load(&f[ch]));
                    F32x8::select(on, v, kept).store(&mut f[ch]);
                }
                let s = avx.load(sel);
                let pd = (avx.splat(1.0) - s) * avx.load(&fo.p)
                    + s * avx.load(&wo[2]) * avx.splat(INV_PI);
                let kept = F32x8::select(at, zero, avx.load(p));
                F32x8::select(on, pd, kept).store(p);
            },
        );
        return;
    }
    for k in 0..8 {
        if lit & (1 << k) == 0 {
            continue;
        }
        (f[0][k], f[1][k], f[2][k], p[k]) = (0.0, 0.0, 0.0, 0.0);
        if live & (1 << k) == 0 {
            continue;
        }
        let (fk, pk) = fo.get(k);
        let s = sel[k];
        let r = Vec3::new(rem[0][k], rem[1][k], rem[2][k]);
        let v = fk + r;
        (f[0][k], f[1][k], f[2][k]) = (v.x, v.y, v.z);
        p[k] = (1.0 - s) * pk + s * wo[2][k] * INV_PI;
    }
}

/// The first order (f1·z(ωo), p1) of each live point of `st`, by lane (the lanes that are not
/// live hold any finite value): over the mirror sawtooth from `lanes`
/// ([`first::Mirror8::eval`], its columns as they are), else from the points' `Collected` and
/// their nested pairs (`general`, `Collected::sum`), with the drawn paths' `known` terms
/// (sampling).
#[inline(always)]
fn first_orders(
    kind: Nested,
    c: &Chunk,
    lanes: &first::Mirror8,
    general: Option<&General>,
    st: &States,
    known: Option<&[Option<Known>; 8]>,
) -> first::FirstOrders {
    let Some(g) = general else {
        return lanes.eval(c.cols, &c.geo, kind);
    };
    let mut out = first::FirstOrders::zero();
    let ev = kind
        .lanes(&g.pairs)
        .expect("a point's nested BSDF has a lane form");
    for k in 0..8 {
        if st.is_live(k) {
            let kn = match known {
                Some(kn) => kn[k],
                None => None,
            };
            let fo = g.c[k].sum::<false, CHUNK>(c.entries(k), kn, &ev);
            out.set(k, fo.f, fo.p);
        }
    }
    out
}

/// `Bsdf::sample` of each point's root, as `mnm::sample` and `compensated::sample` compute it
/// (the same random numbers from each point's own sampler `samplers[ids[k]]`, in the same
/// order; the `ids` of one call are distinct), including `Bsdf::sample`'s rejection of
/// non-finite samples. Lanes without a point draw nothing and are left `None`.
///
/// In three passes over the lanes with per-lane decisions: (1) each point draws the lobe
/// choice, then either the cosine lobe's direction or the first order's entry
/// ([`super::pick_entry`], the scalar `draw`'s own step) and the nested BSDF's random numbers
/// ([`sample::Asks`]); (2) the nested samples of all points that asked, in one 8-wide call of
/// the nested BSDF's lane form ([`sample::Asks::answer`]); (3) each such point finishes `draw`
/// with its own sampler ([`super::leave`], the scalar `draw`'s last step: the facet frame, the
/// mirror wall's draw). Every point touches only its own sampler, so splitting its draws across the passes
/// keeps their order. The first orders at the sampled directions are then evaluated together
/// as in [`eval_pdf_x8`]. The tests' view of [`sample_x8_cols`].
#[cfg(test)]
pub(crate) fn sample_x8(
    ctx: &BsdfContext,
    c: &Chunk,
    samplers: &mut [Sampler],
    ids: &[u32; 8],
) -> [Option<BsdfSample>; 8] {
    // The streams as the stream renderer's columns, written back after.
    let mut cols = crate::sampler::Samplers::with_capacity(samplers.len());
    cols.extend_from(samplers);
    let s = sample_x8_cols(ctx, c, &mut cols, ids);
    for (i, s) in samplers.iter_mut().enumerate() {
        *s = cols.get(i);
    }
    std::array::from_fn(|k| s.get(k))
}

/// The chunk's BSDF samples ([`sample_x8_cols`]) by lane, in columns: bit k of `ok` says lane
/// k's sample is kept (its direction `wo` in the shading frame, density `pdf`, weight `w` by
/// channel; η = 1 and the lobe `lobe` of every point); other lanes hold any value.
pub(crate) struct Samples8 {
    pub(crate) ok: u8,
    pub(crate) wo: [[f32; 8]; 3],
    pub(crate) pdf: [f32; 8],
    pub(crate) w: [[f32; 8]; 3],
    pub(crate) lobe: crate::bsdf::Lobes,
}

impl Samples8 {
    /// No sample kept.
    #[inline(always)]
    fn none() -> Self {
        Samples8 {
            ok: 0,
            wo: [[0.0; 8]; 3],
            pdf: [0.0; 8],
            w: [[0.0; 8]; 3],
            lobe: crate::bsdf::Lobes::EMPTY,
        }
    }

    /// Lane `k`'s sample, as `Bsdf::sample` gives it.
    #[cfg(test)]
    pub(crate) fn get(&self, k: usize) -> Option<BsdfSample> {
        (self.ok & (1 << k) != 0).then(|| BsdfSample {
            wo: Vec3::new(self.wo[0][k], self.wo[1][k], self.wo[2][k]),
            pdf: self.pdf[k],
            weight: Vec3::new(self.w[0][k], self.w[1][k], self.w[2][k]),
            eta: 1.0,
            lobe: self.lobe,
        })
    }
}

/// `sample_x8` in columns (the stream kernel's form: no `Option<BsdfSample>` row per lane
/// to copy into its columns), each point drawing from stream `ids[k]` of the batch's columns
/// in place (`Samplers::stream`: the numbers its `Sampler` draws, strata included; no
/// `Sampler` copied out and back).
pub(crate) fn sample_x8_cols(
    ctx: &BsdfContext,
    c: &Chunk,
    samplers: &mut Samplers,
    ids: &[u32; 8],
) -> Samples8 {
    let _ = ctx; // the lane forms read no context
    let Some(nested) = c.nested else {
        return Samples8::none();
    };
    let kind = Nested::of(&nested);
    let exact = sample_record_is_exact(&nested);
    // Pass 1: the lobe choice, the cosine lobe, the entry and the nested sample's numbers
    // (each point's ωi state and entries from `c`; [`first_pass`]); `drawn`: the lanes with
    // an ωo (in the columns `wc`, by component); `entry`: the entry of a lane that asked for
    // a nested sample (off the mirror sawtooth).
    let mut st = States::new();
    let mut wc = [[0.0f32; 8]; 3];
    let mut entry = [usize::MAX; 8];
    let mut asks = sample::Asks::new();
    let p1 = first_pass(c, kind, samplers, ids, &mut asks, &mut wc, &mut entry);
    let mut drawn = p1.cosine;
    // Pass 2: the nested samples 8-wide.
    // Over the mirror sawtooth, the known terms of the lanes that took a nested sample in
    // columns: `from_nested` (bit k: lane k), each one's path 2 j + wall (`ks`), its nested
    // density and weight from `answered` (`known_term`'s inputs, its test and products done
    // for the 8 lanes below, [`first::Mirror8::sampled`]).
    let mut from_nested = 0u8;
    let mut ks = [0.0f32; 8];
    let mut answered = None;
    if !asks.is_empty() {
        // Answered in its slot (answered first and moved there after the passes, the value was
        // a `memcpy` call per chunk).
        let a = &*answered.insert(asks.answer(c.cols, kind));
        // Pass 3: the rest of `draw` per point (the facet frame and the mirror wall's draw),
        // for the lanes with an entry whose nested sample is kept (`Answered::get`'s test).
        let mut rest = p1.asked & a.ok();
        if c.mirror {
            // Over the mirror sawtooth `leave`'s numbers before its draw (the samples'
            // directions in the shading frame, G1 there, the mirror wall's reflection) for all
            // lanes at once, from the chunk's columns (the map's numbers); `leave_mirror`'s
            // draw ([`wall_pass`]: every entry is facet 0's): u where the number is below
            // G1(u), else R(u) through the wall (bit k of `wall`), blended into the columns
            // after; the known terms in columns.
            let l = c.geo.leave_dirs(c.cols, a.wo());
            let wall;
            (wall, ks) = wall_pass(c.cols, samplers, ids, rest, &l, p1.second);
            from_nested = rest;
            c.cols.run(
                #[inline(always)]
                |cols| l.blend_into(cols, from_nested, wall, &mut wc),
            );
        } else {
            while rest != 0 {
                let k = rest.trailing_zeros() as usize;
                rest &= rest - 1;
                let j = entry[k];
                let sampled = a.get(k).expect("a kept nested sample");
                let s = &mut samplers.stream(ids[k] as usize);
                let (wo, known) =
                    leave(c.point(k).map(), c.entries(k).k[j] as usize, j, sampled, s);
                (wc[0][k], wc[1][k], wc[2][k]) = (wo.x, wo.y, wo.z);
                st.known[k] = known;
                from_nested |= 1 << k;
            }
        }
        drawn |= from_nested;
    }
    // The live lanes: drawn, ωo not below the surface (the scalar `z <= 0` test, as a mask);
    // their ωo by component for the last step in lanes (others: 0).
    // (One region for the test and the blend.)
    let mut wo = [[0.0f32; 8]; 3];
    st.live = c.cols.run(
        #[inline(always)]
        |cols| {
            let live = drawn & cols.not_le_zero(&wc[2]);
            cols.blend3(live, &mut wo, &wc);
            live
        },
    );
    if st.live == 0 {
        return Samples8::none();
    }
    // The first orders at the sampled directions: in lanes over the mirror sawtooth, else
    // their nested pairs in one batch ([`General`], made only then).
    let mut general = (!c.mirror).then(General::new);
    if let Some(g) = &mut general {
        let mut rest = st.live;
        while rest != 0 {
            let k = rest.trailing_zeros() as usize;
            rest &= rest - 1;
            // (`Option::filter` by `exact`, written only where it changes the term: the
            // rewrite of every lane's ~40-byte record cost more than the test.)
            if !exact {
                st.known[k] = None;
            }
            let w = Vec3::new(wo[0][k], wo[1][k], wo[2][k]);
            g.push(k, c.point(k), c.entries(k), w, st.known[k]);
        }
    }
    // Over the mirror sawtooth the query's inputs from the columns (the known terms where
    // the sample record is exact: `Option::filter` by `exact`).
    let lanes = match (&general, &answered) {
        (None, Some(a)) => {
            let known = from_nested & st.live & if exact { u8::MAX } else { 0 };
            first::Mirror8::sampled(c.cols, st.live, &wo, known, &ks, a.pdf(), a.weight())
        }
        (None, None) => {
            let none = ([0.0; 8], [[0.0; 8]; 3]);
            first::Mirror8::sampled(c.cols, st.live, &wo, 0, &ks, &none.0, &none.1)
        }
        (Some(_), _) => first::Mirror8::new(),
    };
    let fo = first_orders(kind, c, &lanes, general.as_ref(), &st, Some(&st.known));
    let rem = remainders(st.live, &wo, c);
    let done = finish_samples(c.cols, st.live, &c.sel, &fo, &rem, &wo);
    // Every point's lobe is its nested BSDF's (the points share it); the kept lanes' ωo are
    // the live lanes' of `wo`.
    Samples8 {
        ok: done.ok,
        wo,
        pdf: done.pdf,
        w: done.w,
        lobe: super::super::explicit::lobe_of(nested.lobes()),
    }
}

/// What the sampler's pass 1 drew ([`first_pass`]), as lane bits (bit k: lane k): the lanes
/// that took the cosine lobe (their directions in the caller's columns), those that picked an
/// entry and asked for a nested sample, and among those the ones whose entry is slot 1 (over
/// the mirror sawtooth: the wall's after a direct one).
struct Drawn {
    cosine: u8,
    asked: u8,
    second: u8,
}

/// Pass 1 of [`sample_x8_cols`] for the points of `c` seen from above, each drawing from
/// stream `ids[k]`: the lobe choice (the cosine lobe where the number is below s(ωi): its
/// direction into `wc`), else the entry by weight and the nested sample's numbers (into
/// `asks`; the entry into `entry`, off the mirror sawtooth). Over the mirror sawtooth with
/// AVX2 the 8 points' draws in lanes ([`draws::first8`]), else point by point in the scalar
/// code (`Cols::LOOPS`: the tests' reference; the same numbers).
#[inline(always)]
fn first_pass(
    c: &Chunk,
    kind: Nested,
    samplers: &mut Samplers,
    ids: &[u32; 8],
    asks: &mut sample::Asks,
    wc: &mut [[f32; 8]; 3],
    entry: &mut [usize; 8],
) -> Drawn {
    #[cfg(target_arch = "x86_64")]
    if let (Some(avx), true) = (c.cols.avx(), c.mirror) {
        return draws::first8(avx, c, samplers, ids, sample::draws_u1(kind), asks, wc);
    }
    let mut d = Drawn {
        cosine: 0,
        asked: 0,
        second: 0,
    };
    let mut above = c.above;
    while above != 0 {
        let k = above.trailing_zeros() as usize;
        above &= above - 1;
        let s = &mut samplers.stream(ids[k] as usize);
        if s.next_1d() < c.sel[k] {
            let v = warp::square_to_cosine_hemisphere(s.next_2d());
            (wc[0][k], wc[1][k], wc[2][k]) = (v.x, v.y, v.z);
            d.cosine |= 1 << k;
            continue;
        }
        // `draw`'s entry by weight, then the nested sample from the entry's direction.
        // Over the mirror sawtooth from the chunk's entry columns (the same pick and
        // direction as `pick_entry` over the point's `Entries`).
        let u = s.next_1d();
        let (j, a) = if c.mirror {
            let Some(j) = c.geo.pick(k, u) else { continue };
            (j, c.geo.entry_dir(k, j))
        } else {
            let Some(j) = pick_entry(c.entries(k), u) else {
                continue;
            };
            (j, c.entries(k).a[j])
        };
        asks.push(kind, k, a, s);
        entry[k] = j;
        d.asked |= 1 << k;
        d.second |= u8::from(j == 1) << k;
    }
    d
}

/// Pass 3's draw over the mirror sawtooth (`leave_mirror`'s, every entry facet 0's): each
/// lane of `rest` (a kept nested sample) draws a number from stream `ids[k]` and leaves
/// through the wall where it is not below G1(u) (`l`). Returns the lanes through the wall and
/// each lane's path 2 j + wall (`second`: the lanes of entry 1). With AVX2 in lanes
/// ([`draws::wall8`]), else lane by lane (the same numbers).
#[inline(always)]
fn wall_pass(
    cols: Cols,
    samplers: &mut Samplers,
    ids: &[u32; 8],
    rest: u8,
    l: &first::Left,
    second: u8,
) -> (u8, [f32; 8]) {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = cols.avx() {
        return draws::wall8(avx, samplers, ids, rest, l.g_col(), second);
    }
    let (mut wall, mut ks) = (0u8, [0.0f32; 8]);
    let mut left = rest;
    while left != 0 {
        let k = left.trailing_zeros() as usize;
        left &= left - 1;
        let through = samplers.stream(ids[k] as usize).next_1d() < l.g(k);
        wall |= u8::from(!through) << k;
        ks[k] = (2 * usize::from(second & (1 << k) != 0) + usize::from(!through)) as f32;
    }
    (wall, ks)
}

/// [`finish_samples`]' results by lane: each sample's density and weight, and the lanes whose
/// sample is kept (bit k: lane k).
struct Finished {
    pdf: [f32; 8],
    w: [[f32; 8]; 3],
    ok: u8,
}

impl Finished {
    #[inline(always)]
    fn none() -> Self {
        Finished {
            pdf: [0.0; 8],
            w: [[0.0; 8]; 3],
            ok: 0,
        }
    }
}

/// The last step of `compensated::sample` and `Bsdf::sample` for the lanes `live` of a
/// chunk's samples (bit k: lane k), from the lanes' lobe choice s(ωi) `sel`, first orders
/// `fo`, remainders `rem` and directions `wo` in columns: [`finish`] 8-wide when the CPU has
/// AVX2 and FMA, else lane by lane in the scalar code ([`finish_samples_width1`]; the same
/// numbers, `tests`). Other lanes are not kept.
#[inline(always)]
fn finish_samples(
    cols: Cols,
    live: u8,
    sel: &[f32; 8],
    fo: &first::FirstOrders,
    rem: &[[f32; 8]; 3],
    wo: &[[f32; 8]; 3],
) -> Finished {
    #[cfg(target_arch = "x86_64")]
    if let Some(avx) = cols.avx() {
        return avx.run(
            #[inline(always)]
            || {
                use crate::lane::vec::V3;
                // A plain function, not a closure: a closure may be compiled out of the SIMD
                // function, and its loads become calls.
                #[inline(always)]
                fn l3(avx: crate::lane::Avx2, x: &[[f32; 8]; 3]) -> V3<crate::lane::F32x8> {
                    V3::new(avx.load(&x[0]), avx.load(&x[1]), avx.load(&x[2]))
                }
                let (pdf, w, ok) = finish(
                    l3(avx, &fo.f),
                    l3(avx, rem),
                    avx.load(&fo.p),
                    avx.load(sel),
                    l3(avx, wo),
                );
                let mut out = Finished::none();
                pdf.store(&mut out.pdf);
                w.x.store(&mut out.w[0]);
                w.y.store(&mut out.w[1]);
                w.z.store(&mut out.w[2]);
                out.ok = ok.bits() as u8 & live;
                out
            },
        );
    }
    finish_samples_width1(live, sel, fo, rem, wo)
}

/// [`finish_samples`] lane by lane in the scalar code (`compensated::sample`'s last lines,
/// then [`crate::bsdf::accept_sample`]): a CPU without AVX2, and the tests' reference.
#[inline(always)]
fn finish_samples_width1(
    live: u8,
    sel: &[f32; 8],
    fo: &first::FirstOrders,
    rem: &[[f32; 8]; 3],
    wo: &[[f32; 8]; 3],
) -> Finished {
    let mut out = Finished::none();
    for k in 0..8 {
        if live & (1 << k) == 0 {
            continue;
        }
        let (f, p) = fo.get(k);
        let r = Vec3::new(rem[0][k], rem[1][k], rem[2][k]);
        let wo = Vec3::new(wo[0][k], wo[1][k], wo[2][k]);
        let pdf = (1.0 - sel[k]) * p + sel[k] * wo.z * INV_PI;
        if !(pdf.is_finite() && pdf > 0.0) {
            continue;
        }
        let bs = BsdfSample {
            wo,
            pdf,
            weight: (f + r) / pdf,
            eta: 1.0,
            lobe: crate::bsdf::Lobes::EMPTY,
        };
        if let Some(bs) = crate::bsdf::accept_sample(bs) {
            out.pdf[k] = bs.pdf;
            (out.w[0][k], out.w[1][k], out.w[2][k]) = (bs.weight.x, bs.weight.y, bs.weight.z);
            out.ok |= 1 << k;
        }
    }
    out
}

/// A compensated sample's last step, lane by lane in the scalar code's operations and order
/// (`compensated::sample`, then `Bsdf::sample`'s [`crate::bsdf::accept_sample`]): the density
/// pdf = (1 − s) p1 + (s z(ωo)) / π, the weight (f1·z(ωo) + f_ms) / pdf per channel, and
/// whether the sample is kept: pdf finite and positive (`compensated::sample`'s test), ωo and
/// the weight finite (`accept_sample`'s; its pdf ≥ 0 follows from pdf > 0). No fused
/// multiply-add: each product and sum rounded as the scalar code rounds it.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn finish<L: crate::lane::Lane>(
    f: crate::lane::vec::V3<L>,
    rem: crate::lane::vec::V3<L>,
    p1: L,
    sel: L,
    wo: crate::lane::vec::V3<L>,
) -> (L, crate::lane::vec::V3<L>, L::Mask) {
    let pdf = (p1.splat(1.0) - sel) * p1 + sel * wo.z * p1.splat(INV_PI);
    let w = (f + rem).div_by(pdf);
    let ok = pdf.is_finite()
        & pdf.gt(p1.splat(0.0))
        & wo.x.is_finite()
        & wo.y.is_finite()
        & wo.z.is_finite()
        & w.x.is_finite()
        & w.y.is_finite()
        & w.z.is_finite();
    (pdf, w, ok)
}

#[cfg(test)]
mod tests {
    use super::super::super::facets::Microgeometry;
    use super::super::super::ms_table::{Colour, MsTable};
    use super::super::super::{Evaluation, Tangent};
    use super::*;
    use crate::bsdf::lanes::testing::{direction, same, same3};
    use crate::bsdf::BsdfArena;
    use crate::math::Pcg32;

    /// Edge values for the lane-vs-scalar tests: zeros of both signs, subnormals, one, huge
    /// values (whose products overflow), infinities and NaN.
    const EDGES: [f32; 12] = [
        0.0,
        -0.0,
        1e-40,
        -1e-40,
        f32::MIN_POSITIVE,
        1.0,
        1e30,
        -1e30,
        f32::MAX,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
    ];

    /// With probability `p` one of [`EDGES`], else uniform in [lo, hi).
    fn edge_or_uniform(rng: &mut Pcg32, p: f32, lo: f32, hi: f32) -> f32 {
        if rng.next_f32() < p {
            EDGES[rng.next_u32() as usize % EDGES.len()]
        } else {
            lo + (hi - lo) * rng.next_f32()
        }
    }

    /// The tests' compensated normal map over nested node `n` with table `t`.
    fn compensated_map(
        n: u32,
        wp: Vec3,
        geometry: Microgeometry,
        tangent: Tangent,
        t: &'static MsTable,
    ) -> MicrofacetNormalMap {
        MicrofacetNormalMap::new(n, wp, geometry, tangent, Evaluation::Compensated, 256)
            .with_ms_table(Some(t))
    }

    /// An exact Lambert table (instant) of the tests' settings.
    fn unit_table(geometry: Microgeometry, tangent: Tangent, colour: Colour) -> &'static MsTable {
        MsTable::unit_lambert(geometry, tangent, colour)
    }

    /// The ωi caches built 8 at a time in place ([`with_incident_x8`]) equal
    /// [`MicrofacetNormalMap::with_incident`]'s bit for bit, lane by lane: the mirror sawtooth,
    /// the V-groove and a U-groove, baked and per-bounce tables mixed in one chunk (two baked
    /// tables: the second looks up alone), random ωp (some flat: no cache), ωi over both
    /// hemispheres, empty lanes and a lane that is not a normal map.
    #[test]
    fn incident_caches_8_at_a_time_equal_the_scalar_ones() {
        let mut rng = Pcg32::new(18, 5);
        let mut arena = BsdfArena::new();
        let geometries = [
            (Microgeometry::Sawtooth, Tangent::Mirror),
            (Microgeometry::VGroove, Tangent::Same),
            (Microgeometry::UGroove { fill: 0.6 }, Tangent::Same),
        ];
        let tables: Vec<Vec<&'static MsTable>> = geometries
            .iter()
            .map(|&(geometry, tangent)| {
                [Colour::Baked, Colour::Baked, Colour::PerBounce]
                    .iter()
                    .map(|&colour| unit_table(geometry, tangent, colour))
                    .collect()
            })
            .collect();
        let (mut cached, mut baked) = (0, 0);
        for chunk in 0..3000 {
            let (geometry, tangent) = geometries[chunk % 3];
            arena.clear();
            let n = super::super::tests::push_reflectors(&mut arena)[chunk / 3 % 3];
            let mut roots = [u32::MAX; 8];
            let mut wi = [Vec3::Z; 8];
            let mut want: [Option<MicrofacetNormalMap>; 8] = [None; 8];
            for k in 0..8 {
                let u = rng.next_f32();
                if u < 0.1 {
                    continue; // an empty lane
                }
                if u < 0.15 {
                    roots[k] = n; // not a normal map
                    continue;
                }
                let wp = if rng.next_f32() < 0.05 {
                    Vec3::Z
                } else {
                    warp::square_to_uniform_cone(
                        [rng.next_f32(), rng.next_f32()].into(),
                        80f32.to_radians().cos(),
                    )
                };
                wi[k] = direction(&mut rng);
                // Mostly the first baked table, some the second and the per-bounce one.
                let t = tables[chunk % 3][match rng.next_f32() {
                    x if x < 0.8 => 0,
                    x if x < 0.9 => 1,
                    _ => 2,
                }];
                let m = compensated_map(n, wp, geometry, tangent, t);
                want[k] = Some(m.with_incident(wi[k]));
                roots[k] = arena.push_microfacet_normal_map(m);
            }
            with_incident_x8(&mut arena, &roots, &wi);
            for k in 0..8 {
                let Some(w) = want[k] else { continue };
                let got = arena.mnm_mut(roots[k]).expect("a normal map");
                let (w, g) = (w.ms.and_then(|r| r.at), got.ms.and_then(|r| r.at));
                // Debug prints each f32 as its shortest round-trip form: equal strings are
                // equal bits.
                assert_eq!(format!("{w:?}"), format!("{g:?}"), "chunk {chunk} lane {k}");
                cached += usize::from(w.is_some());
                baked += usize::from(w.is_some_and(|a| a.baked.is_some()));
            }
        }
        // 3000 chunks of ~6.8 maps, half of them seen from above.
        assert!(
            cached > 9000 && baked > 7000,
            "{cached} caches, {baked} baked"
        );
    }

    /// s(ωi) in lanes ([`selection_lanes`], 8-wide on this machine and at width 1) equals
    /// `compensated::selection` bit for bit: random E_ms and W1 (negative components too)
    /// mixed with ±0, subnormals, huge values, ±∞ and NaN.
    #[test]
    fn selection_in_lanes_equals_the_scalar_one() {
        use crate::lane::vec::V3;
        let mut rng = Pcg32::new(21, 5);
        let value = |rng: &mut Pcg32| edge_or_uniform(rng, 0.1, -0.5, 1.5);
        let (mut positive, mut zero) = (0, 0);
        for round in 0..20000 {
            let (mut e, mut w) = ([[0.0f32; 8]; 3], [[0.0f32; 8]; 3]);
            for k in 0..8 {
                for ch in 0..3 {
                    e[ch][k] = value(&mut rng);
                    w[ch][k] = value(&mut rng);
                }
            }
            let mut wide = None;
            #[cfg(target_arch = "x86_64")]
            if let Some(avx) = crate::lane::Avx2::detect() {
                wide = Some(avx.run(|| {
                    let l3 = |x: &[[f32; 8]; 3]| {
                        V3::new(avx.load(&x[0]), avx.load(&x[1]), avx.load(&x[2]))
                    };
                    let mut out = [0.0f32; 8];
                    selection_lanes(l3(&e), l3(&w)).store(&mut out);
                    out
                }));
            }
            for k in 0..8 {
                let ek = Vec3::new(e[0][k], e[1][k], e[2][k]);
                let wk = Vec3::new(w[0][k], w[1][k], w[2][k]);
                let want = super::super::selection(ek, wk);
                let one = selection_lanes::<f32>(ek.into(), wk.into());
                assert!(same(one, want), "{round} {k}: {one} vs {want}");
                if let Some(wide) = wide {
                    assert!(same(wide[k], want), "{round} {k}: {} vs {want}", wide[k]);
                }
                positive += usize::from(want > 0.0);
                zero += usize::from(want == 0.0);
            }
        }
        assert!(
            positive > 50000 && zero > 30000,
            "{positive} positive, {zero} zero"
        );
    }

    /// The samples' last step in lanes ([`finish_samples`], 8-wide on this machine and lane by
    /// lane at width 1) equals the scalar code's (`compensated::sample`'s density and weight,
    /// its test pdf finite and > 0, then `accept_sample`) bit for bit, lane by lane: kept or
    /// not alike, and where kept the same density and weight; lanes that are not live never
    /// kept. Random inputs mixed with ±0, subnormals, huge values, ±∞ and NaN in every input
    /// (first order, remainder, density p1, lobe choice, ωo).
    #[test]
    fn samples_last_step_in_lanes_equals_the_scalar_one() {
        let mut rng = Pcg32::new(21, 2);
        let value = |rng: &mut Pcg32, lo: f32, hi: f32| edge_or_uniform(rng, 0.08, lo, hi);
        let (mut kept, mut dropped) = (0, 0);
        for round in 0..20000 {
            let mut fo = first::FirstOrders::zero();
            let (mut rem, mut wo) = ([[0.0f32; 8]; 3], [[0.0f32; 8]; 3]);
            let mut sel = [0.0f32; 8];
            let live = rng.next_u32() as u8;
            for k in 0..8 {
                let f = Vec3::new(
                    value(&mut rng, 0.0, 2.0),
                    value(&mut rng, 0.0, 2.0),
                    value(&mut rng, 0.0, 2.0),
                );
                fo.set(k, f, value(&mut rng, 0.0, 4.0));
                for ch in 0..3 {
                    rem[ch][k] = value(&mut rng, 0.0, 0.5);
                    wo[ch][k] = value(&mut rng, -1.0, 1.0);
                }
                sel[k] = value(&mut rng, 0.0, 1.0);
            }
            let wide = finish_samples(Cols::detect(), live, &sel, &fo, &rem, &wo);
            let one = finish_samples_width1(live, &sel, &fo, &rem, &wo);
            for k in 0..8 {
                let at = format!("round {round} lane {k}");
                if live & (1 << k) == 0 {
                    assert_eq!((wide.ok | one.ok) & (1 << k), 0, "{at}");
                    continue;
                }
                // The scalar code's last step.
                let (f, p) = fo.get(k);
                let r = Vec3::new(rem[0][k], rem[1][k], rem[2][k]);
                let w = Vec3::new(wo[0][k], wo[1][k], wo[2][k]);
                let pdf = (1.0 - sel[k]) * p + sel[k] * w.z * INV_PI;
                let want = (pdf.is_finite() && pdf > 0.0)
                    .then(|| BsdfSample {
                        wo: w,
                        pdf,
                        weight: (f + r) / pdf,
                        eta: 1.0,
                        lobe: crate::bsdf::Lobes::GLOSSY_REFLECTION,
                    })
                    .and_then(crate::bsdf::accept_sample);
                for got in [&wide, &one] {
                    assert_eq!(got.ok & (1 << k) != 0, want.is_some(), "{at}");
                    if let Some(bs) = want {
                        let gw = Vec3::new(got.w[0][k], got.w[1][k], got.w[2][k]);
                        assert!(same(got.pdf[k], bs.pdf) && same3(gw, bs.weight), "{at}");
                    }
                }
                kept += usize::from(want.is_some());
                dropped += usize::from(want.is_none());
            }
        }
        // 20000 × 4 live lanes; ~27 % of them with a special value somewhere among 12 inputs.
        assert!(
            kept > 30000 && dropped > 15000,
            "{kept} kept, {dropped} dropped"
        );
    }

    /// The chunk's per-point state ([`Chunk::new`]: the baked tables' lookups at ωi 8-wide,
    /// the mirror sawtooth's entries in lanes) equals the scalar model's (`AtWi::new` without
    /// a cache, `Entries::new`) bit for bit, lane by lane: the mirror sawtooth and the
    /// V-groove, baked and per-bounce tables mixed in one chunk (two baked tables: the second
    /// looks up alone), rough conductors and a rough plastic, random ωp (some flat: no
    /// point), ωi over both hemispheres (and grazing: entries through the wall alone), maps
    /// with and without their ωi cache, empty lanes.
    #[test]
    fn chunk_state_equals_the_scalar_one() {
        let mut rng = Pcg32::new(16, 3);
        let mut arena = BsdfArena::new();
        let nested = super::super::tests::push_reflectors(&mut arena);
        let geometries = [
            (Microgeometry::Sawtooth, Tangent::Mirror),
            (Microgeometry::VGroove, Tangent::Same),
        ];
        let tables: Vec<Vec<&'static MsTable>> = geometries
            .iter()
            .map(|&(geometry, tangent)| {
                [Colour::Baked, Colour::Baked, Colour::PerBounce]
                    .iter()
                    .map(|&colour| unit_table(geometry, tangent, colour))
                    .collect()
            })
            .collect();
        let (mut compared, mut wall_only, mut both) = (0, 0, 0);
        for chunk in 0..2000 {
            let (geometry, tangent) = geometries[chunk % 2];
            let tables = &tables[chunk % 2];
            let n = nested[chunk / 2 % 3];
            let mut roots = [u32::MAX; 8];
            let mut wi = [Vec3::Z; 8];
            for k in 0..8 {
                if rng.next_f32() < 0.1 {
                    continue; // an empty lane
                }
                let wp = if rng.next_f32() < 0.05 {
                    Vec3::Z
                } else {
                    warp::square_to_uniform_cone(
                        [rng.next_f32(), rng.next_f32()].into(),
                        80f32.to_radians().cos(),
                    )
                };
                wi[k] = direction(&mut rng);
                if rng.next_f32() < 0.2 {
                    // Grazing: through the wall alone, or no entry.
                    wi[k] = Vec3::new(wi[k].x, wi[k].y, 0.02 * wi[k].z.abs()).normalize();
                }
                let t = tables[match rng.next_f32() {
                    x if x < 0.8 => 0,
                    x if x < 0.9 => 1,
                    _ => 2,
                }];
                let mut m = compensated_map(n, wp, geometry, tangent, t);
                if rng.next_f32() < 0.5 {
                    m = m.with_incident(wi[k]);
                }
                roots[k] = arena.push_microfacet_normal_map(m);
            }
            let mut pts = [None; 8];
            for k in 0..8 {
                if roots[k] != u32::MAX {
                    pts[k] = Point::of(arena.bsdf(roots[k]), wi[k]);
                }
            }
            let c = Chunk::new(pts);
            for (k, pt) in pts.iter().enumerate() {
                let above = pt.filter(|p| p.wi.z > 0.0);
                assert_eq!(c.is_above(k), above.is_some(), "chunk {chunk} lane {k}");
                let Some(pt) = above else { continue };
                let at = AtWi::new(&pt.r, &pt.nested, pt.wi, None);
                let e = Entries::new(pt.map(), pt.wi);
                // Debug prints each f32 as its shortest round-trip form: equal strings are
                // equal bits. The points of the baked lookups keep E_ms(ωi), 1 / (π Ē_ms)
                // and s(ωi) in columns, the others their `AtWi`; every point its s(ωi) in
                // `sel`.
                let (got, want) = if c.q.is_used(k) {
                    let col = |x: &[[f32; 8]; 3]| Vec3::new(x[0][k], x[1][k], x[2][k]);
                    assert!(at.k.is_none(), "chunk {chunk} lane {k}");
                    (
                        format!("{:?}", (col(&c.ei), col(&c.norm), c.sel[k])),
                        format!("{:?}", (at.ei, at.norm, at.select)),
                    )
                } else {
                    assert!(same(c.sel[k], at.select), "chunk {chunk} lane {k}");
                    (format!("{:?}", c.at(k)), format!("{at:?}"))
                };
                assert_eq!(got, want, "chunk {chunk} lane {k}");
                // Over the mirror sawtooth the entries stay in the columns.
                let got = match c.mirror {
                    true => c.geo.entries_of(k),
                    false => *c.entries(k),
                };
                assert_eq!(
                    format!("{got:?}"),
                    format!("{e:?}"),
                    "chunk {chunk} lane {k}"
                );
                compared += 1;
                if pt.map().mirror_wall {
                    wall_only += usize::from(e.len() == 1 && e.via_wall(0));
                    both += usize::from(e.len() == 2);
                }
            }
        }
        // 2000 chunks of ~7 points, ~40 % of them seen from above.
        assert!(
            compared > 4000 && wall_only > 20 && both > 500,
            "{compared} points, {wall_only} entered through the wall alone, {both} both ways"
        );
    }

    /// The chunk's eval and sample equal the scalar model's (`Bsdf::eval_pdf` / `Bsdf::sample`
    /// of the same roots, each lane with its own sampler) bit for bit, lane by lane, and leave
    /// each sampler where the scalar call leaves it: rough conductors (GGX with visible-normal
    /// sampling, Beckmann without) and a rough plastic, under the mirror sawtooth and the
    /// V-groove, tables with the colour per bounce and baked in, with and without the hit's
    /// ωi cache, random ωp, ωi and ωo (both hemispheres) and empty lanes.
    #[test]
    fn chunk_equals_the_scalar_model_lane_by_lane() {
        let ctx = BsdfContext::default();
        let mut rng = Pcg32::new(17, 3);
        let mut arena = BsdfArena::new();
        let nested = super::super::tests::push_reflectors(&mut arena);
        let (mut evals, mut samples, mut drawn, mut cached) = (0, 0, 0, 0);
        for (geometry, tangent) in [
            (Microgeometry::Sawtooth, Tangent::Mirror),
            (Microgeometry::VGroove, Tangent::Same),
        ] {
            for colour in [Colour::PerBounce, Colour::Baked] {
                let table = unit_table(geometry, tangent, colour);
                for &n in &nested {
                    for _ in 0..100 {
                        let mut roots = [u32::MAX; 8];
                        let mut wi = [Vec3::ZERO; 8];
                        let mut wo = [Vec3::ZERO; 8];
                        for k in 0..8 {
                            if rng.next_f32() < 0.1 {
                                continue; // an empty lane
                            }
                            let wp = warp::square_to_uniform_cone(
                                [rng.next_f32(), rng.next_f32()].into(),
                                75f32.to_radians().cos(),
                            );
                            wi[k] = direction(&mut rng);
                            wo[k] = direction(&mut rng);
                            let mut m = compensated_map(n, wp, geometry, tangent, table);
                            if rng.next_f32() < 0.7 {
                                m = m.with_incident(wi[k]);
                            }
                            roots[k] = arena.push_microfacet_normal_map(m);
                        }
                        let pts: [Option<Point>; 8] = std::array::from_fn(|k| {
                            (roots[k] != u32::MAX)
                                .then(|| Point::of(arena.bsdf(roots[k]), wi[k]))
                                .flatten()
                        });
                        let seeds: [u64; 8] = std::array::from_fn(|_| rng.next_u32() as u64);
                        // Eval toward wo.
                        let got = eval_pdf_x8(&ctx, &Chunk::new(pts), u8::MAX, &wo);
                        for k in 0..8 {
                            if pts[k].is_none() {
                                continue;
                            }
                            let mut s = Sampler::from_seed(seeds[k], 1);
                            let (f, p) = arena.bsdf(roots[k]).eval_pdf(&ctx, wi[k], wo[k], &mut s);
                            let at =
                                format!("{n} {geometry:?} {colour:?} {} {} {}", wi[k], wo[k], k);
                            assert!(
                                same3(got[k].0, f) && same(got[k].1, p),
                                "{at}: {got:?} vs {f} {p}"
                            );
                            evals += usize::from(wi[k].z > 0.0 && wo[k].z > 0.0);
                        }
                        // Samples, each lane from its own sampler.
                        let mut samplers: Vec<Sampler> =
                            seeds.iter().map(|&s| Sampler::from_seed(s, 2)).collect();
                        let ids: [u32; 8] = std::array::from_fn(|k| (7 - k) as u32);
                        let mut lane_pts = [None; 8];
                        for k in 0..8 {
                            lane_pts[7 - k] = pts[k];
                        }
                        let got = sample_x8(&ctx, &Chunk::new(lane_pts), &mut samplers, &ids);
                        for k in 0..8 {
                            let Some(_) = pts[k] else { continue };
                            let mut s = Sampler::from_seed(seeds[k], 2);
                            let want = arena.bsdf(roots[k]).sample(&ctx, wi[k], &mut s);
                            let at = format!("{n} {geometry:?} {colour:?} {}", wi[k]);
                            match (got[7 - k], want) {
                                (None, None) => {}
                                (Some(a), Some(b)) => {
                                    assert!(same3(a.wo, b.wo), "{at}");
                                    assert!(same(a.pdf, b.pdf), "{at}");
                                    assert!(same3(a.weight, b.weight), "{at}");
                                    assert_eq!((a.eta, a.lobe), (b.eta, b.lobe), "{at}");
                                    samples += 1;
                                }
                                (a, b) => panic!("{at}: {a:?} vs {b:?}"),
                            }
                            // The same random numbers consumed.
                            assert_eq!(
                                samplers[k].next_1d().to_bits(),
                                s.next_1d().to_bits(),
                                "{at}"
                            );
                        }
                        drawn += pts.iter().flatten().count();
                        cached += pts
                            .iter()
                            .flatten()
                            .filter(|p| {
                                let r = p.map().ms.as_ref().expect("a compensated map");
                                p.wi.z > 0.0 && r.at(p.wi).is_some()
                            })
                            .count();
                    }
                }
            }
        }
        // 12 × 100 chunks of ~7.2 points, a quarter with ωi and ωo above the surface.
        assert!(evals > 1800, "{evals} evaluations above the surface");
        assert!(samples > 2500, "{samples} samples");
        assert!(
            drawn > 8000 && cached > 2000,
            "{drawn} points, {cached} with the ωi cache"
        );
    }

    /// The chunk of points built without their maps (`Chunk::of_facets` and `set_lanes`: the
    /// stream kernel's build over the mirror sawtooth, from `MnmSettings::lanes_at`'s columns)
    /// answers eval and sample as the scalar model over the maps the scalar renderer builds
    /// (`MnmSettings::map_into`, with and without the ωi cache) bit for bit, lane by lane,
    /// and leaves each sampler where the scalar call leaves it; the lanes it takes
    /// (`MnmCols::two_facets_with_cell`) are exactly those whose map is the compensated model
    /// alone over the mirror sawtooth: rough conductors and a rough plastic, baked and
    /// per-bounce tables, random normal map values (beyond the tilt clamp, below the horizon,
    /// flat ones), ωi and ωo over both hemispheres, lanes left out (a failed side test);
    /// independent and stratified streams (some with a stratified 2-D draw pending), with the
    /// chunk's columns 8-wide and lane by lane (`Cols::LOOPS`).
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn chunk_of_the_build_lanes_equals_the_scalar_model() {
        use super::super::super::facets::MaxTilt;
        use super::super::super::TransmissionWalk;
        use crate::lane::vec::V3;
        use crate::lane::Avx2;
        use crate::material::MnmSettings;
        let Some(avx) = Avx2::detect() else { return };
        let ctx = BsdfContext::default();
        let mut rng = Pcg32::new(18, 9);
        let mut arena = BsdfArena::new();
        let nested = super::super::tests::push_reflectors(&mut arena);
        let (geometry, tangent) = (Microgeometry::Sawtooth, Tangent::Mirror);
        let (mut evals, mut samples, mut points, mut flat) = (0, 0, 0, 0);
        let mut strata = 0;
        // 8-wide (the sampler's draws in lanes) and lane by lane (`Cols::LOOPS`: the loops
        // that a CPU without AVX2 runs, `finish_evals`' among them).
        for (colour, cols) in [
            (Colour::Baked, Cols::detect()),
            (Colour::PerBounce, Cols::detect()),
            (Colour::Baked, Cols::LOOPS),
            (Colour::PerBounce, Cols::LOOPS),
        ] {
            let table = unit_table(geometry, tangent, colour);
            let settings = MnmSettings {
                geometry,
                tangent,
                evaluation: Evaluation::Compensated,
                max_order: 256,
                max_theta: MaxTilt::new(70f32.to_radians()),
                transmission_walk: TransmissionWalk::TwoSided,
                lambert_closed_form: true,
                ms_table: Some(table),
            };
            for &n in &nested {
                for round in 0..150 {
                    let mut rgb = [Vec3::ZERO; 8];
                    let (mut wi, mut wo) = ([Vec3::Z; 8], [Vec3::Z; 8]);
                    for k in 0..8 {
                        let z = rng.next_f32();
                        rgb[k] = if rng.next_f32() < 0.1 {
                            Vec3::new(0.5, 0.5, z) // flat
                        } else {
                            Vec3::new(rng.next_f32(), rng.next_f32(), z)
                        };
                        wi[k] = direction(&mut rng);
                        wo[k] = direction(&mut rng);
                    }
                    let lanes = avx.run(|| {
                        let col = |c: usize| avx.load(&rgb.map(|v| v[c]));
                        settings
                            .lanes_at(V3::new(col(0), col(1), col(2)))
                            .cols::<8>()
                    });
                    let mut roots = [u32::MAX; 8];
                    let mut mask = 0u8;
                    for k in 0..8 {
                        let mut m = MicrofacetNormalMap::placeholder();
                        settings.map_into(&mut m, n, rgb[k]);
                        if rng.next_f32() < 0.5 {
                            m = m.with_incident(wi[k]);
                        }
                        roots[k] = arena.push_microfacet_normal_map(m);
                        let alone = crate::bsdf::mnm::compensated_alone(arena.bsdf(roots[k]))
                            .is_some_and(|(m, _, _)| m.mirror_wall);
                        assert_eq!(lanes.two_facets_with_cell(k), alone, "{}", rgb[k]);
                        flat += usize::from(!alone);
                        if alone && rng.next_f32() < 0.9 {
                            mask |= 1 << k;
                        }
                    }
                    let chunk = || {
                        let mut c = Chunk::of_facets(cols, lanes.facets());
                        let cells = lanes.cells().expect("compensated, with a table");
                        let wi = [wi.map(|v| v.x), wi.map(|v| v.y), wi.map(|v| v.z)];
                        c.set_lanes(arena.bsdf(n), table, cells, mask, &wi);
                        c.prepare();
                        c
                    };
                    let seeds: [u64; 8] = std::array::from_fn(|_| rng.next_u32() as u64);
                    let got = eval_pdf_x8(&ctx, &chunk(), u8::MAX, &wo);
                    let ids: [u32; 8] = std::array::from_fn(|k| k as u32);
                    // Independent streams, or every other round stratified ones (with and
                    // without jitter), each lane with 0 to 2 of its stratified 2-D draws
                    // spent: plain and stratified streams in one chunk.
                    let fresh: Vec<Sampler> = (0..8)
                        .map(|k| match round % 4 {
                            0 | 2 => Sampler::from_seed(seeds[k], 2),
                            r => {
                                let desc = crate::sampler::SamplerDesc {
                                    kind: crate::sampler::SamplerKind::Stratified {
                                        jitter: r == 1,
                                    },
                                    sample_count: 16,
                                    seed: seeds[k],
                                };
                                let mut s = Sampler::for_sample(&desc, 7 + k as u64, k as u32);
                                for _ in 0..(k + round) % 3 {
                                    s.next_2d();
                                }
                                s
                            }
                        })
                        .collect();
                    let mut samplers = fresh.clone();
                    let sampled = sample_x8(&ctx, &chunk(), &mut samplers, &ids);
                    for k in 0..8 {
                        if mask & (1 << k) == 0 {
                            assert!(got[k] == (Spectrum::ZERO, 0.0) && sampled[k].is_none());
                            continue;
                        }
                        points += 1;
                        let b = arena.bsdf(roots[k]);
                        let at = format!("{n} {colour:?} {} {} {}", rgb[k], wi[k], wo[k]);
                        let mut s = Sampler::from_seed(seeds[k], 1);
                        let (f, p) = b.eval_pdf(&ctx, wi[k], wo[k], &mut s);
                        assert!(
                            same3(got[k].0, f) && same(got[k].1, p),
                            "{at}: {:?} vs {f} {p}",
                            got[k]
                        );
                        evals += usize::from(wi[k].z > 0.0 && wo[k].z > 0.0);
                        let mut s = fresh[k].clone();
                        strata += usize::from(s.plain_parts().is_none() && wi[k].z > 0.0);
                        match (sampled[k], b.sample(&ctx, wi[k], &mut s)) {
                            (None, None) => {}
                            (Some(a), Some(w)) => {
                                assert!(same3(a.wo, w.wo), "{at}");
                                assert!(same(a.pdf, w.pdf), "{at}");
                                assert!(same3(a.weight, w.weight), "{at}");
                                assert_eq!((a.eta, a.lobe), (w.eta, w.lobe), "{at}");
                                samples += 1;
                            }
                            (a, w) => panic!("{at}: {a:?} vs {w:?}"),
                        }
                        assert_eq!(
                            samplers[k].next_1d().to_bits(),
                            s.next_1d().to_bits(),
                            "{at}"
                        );
                    }
                }
            }
        }
        // 12 × 150 chunks of 8 lanes: ~10 % flat, ~86 % of the rest points, a quarter of
        // those with ωi and ωo above, half of them sampled; a third of the points of the
        // stratified rounds seen from above with a stratified 2-D draw pending.
        assert!(
            flat > 800 && points > 10000 && evals > 2000 && samples > 4000 && strata > 800,
            "{flat} flat, {points} points, {evals} evaluations, {samples} samples, \
             {strata} stratified"
        );
    }

    /// The light query in place ([`eval_pdf_x8_into`]) writes only its lit lanes, over the
    /// stream kernel's chunks of the mirror sawtooth (`Chunk::of_facets`, baked and per-bounce
    /// tables, 8-wide and lane by lane): a lane outside `lit` keeps its old bits (NaN payloads
    /// here), a lit lane seen or lit from below gets (0, 0), every other lit lane the scalar
    /// `eval_pdf` bit for bit. A third of the chunks are lit from below in every lane, where
    /// the query skips the first orders and remainders (`live == 0`): a skip that left the lit
    /// lanes unwritten, or one taken with a live lane, fails here.
    #[test]
    fn light_query_in_place_writes_only_the_lit_lanes() {
        use super::super::super::facets::MaxTilt;
        use super::super::super::TransmissionWalk;
        use crate::lane::vec::V3;
        use crate::lane::Avx2;
        use crate::material::MnmSettings;
        let Some(avx) = Avx2::detect() else { return };
        let ctx = BsdfContext::default();
        let mut rng = Pcg32::new(43, 4);
        let mut arena = BsdfArena::new();
        let nested = super::super::tests::push_reflectors(&mut arena);
        let (geometry, tangent) = (Microgeometry::Sawtooth, Tangent::Mirror);
        let (mut skipped, mut zeroed, mut evals, mut kept) = (0, 0, 0, 0);
        for (colour, cols) in [
            (Colour::Baked, Cols::detect()),
            (Colour::PerBounce, Cols::detect()),
            (Colour::Baked, Cols::LOOPS),
        ] {
            let table = unit_table(geometry, tangent, colour);
            let settings = MnmSettings {
                geometry,
                tangent,
                evaluation: Evaluation::Compensated,
                max_order: 256,
                max_theta: MaxTilt::new(70f32.to_radians()),
                transmission_walk: TransmissionWalk::TwoSided,
                lambert_closed_form: true,
                ms_table: Some(table),
            };
            for &n in &nested {
                for round in 0..120 {
                    let mut rgb = [Vec3::ZERO; 8];
                    let (mut wi, mut wo) = ([Vec3::Z; 8], [Vec3::Z; 8]);
                    for k in 0..8 {
                        rgb[k] = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
                        wi[k] = direction(&mut rng);
                        wo[k] = direction(&mut rng);
                        if round % 3 == 0 {
                            // Every lane lit from below (or at the horizon).
                            wo[k].z = -wo[k].z.abs() * f32::from(u8::from(k != 3));
                        }
                    }
                    let lanes = avx.run(|| {
                        let col = |c: usize| avx.load(&rgb.map(|v| v[c]));
                        settings
                            .lanes_at(V3::new(col(0), col(1), col(2)))
                            .cols::<8>()
                    });
                    let mut roots = [u32::MAX; 8];
                    let mut mask = 0u8;
                    for k in 0..8 {
                        let mut m = MicrofacetNormalMap::placeholder();
                        settings.map_into(&mut m, n, rgb[k]);
                        roots[k] = arena.push_microfacet_normal_map(m);
                        let alone = crate::bsdf::mnm::compensated_alone(arena.bsdf(roots[k]))
                            .is_some_and(|(m, _, _)| m.mirror_wall);
                        if alone && rng.next_f32() < 0.9 {
                            mask |= 1 << k;
                        }
                    }
                    let mut c = Chunk::of_facets(cols, lanes.facets());
                    let cells = lanes.cells().expect("compensated, with a table");
                    let wic = [wi.map(|v| v.x), wi.map(|v| v.y), wi.map(|v| v.z)];
                    c.set_lanes(arena.bsdf(n), table, cells, mask, &wic);
                    c.prepare();
                    let lit = (rng.next_u32() as u8) & mask;
                    let old = |k: usize, i: u32| f32::from_bits(0x7fc0_0000 | (k as u32) << 4 | i);
                    let mut f: [[f32; 8]; 3] =
                        std::array::from_fn(|i| std::array::from_fn(|k| old(k, i as u32)));
                    let mut p: [f32; 8] = std::array::from_fn(|k| old(k, 3));
                    let woc = [wo.map(|v| v.x), wo.map(|v| v.y), wo.map(|v| v.z)];
                    eval_pdf_x8_into(&ctx, &c, lit, &woc, &mut f, &mut p);
                    let live =
                        (0..8).filter(|&k| lit & (1 << k) != 0 && wi[k].z > 0.0 && wo[k].z > 0.0);
                    skipped += usize::from(lit != 0 && live.count() == 0);
                    for k in 0..8 {
                        let at =
                            format!("{n} {colour:?} {} {} {} lit {lit:#x}", rgb[k], wi[k], wo[k]);
                        let got = (Vec3::new(f[0][k], f[1][k], f[2][k]), p[k]);
                        if lit & (1 << k) == 0 {
                            let bits = [got.0.x, got.0.y, got.0.z, got.1].map(f32::to_bits);
                            let want = [0, 1, 2, 3].map(|i| old(k, i).to_bits());
                            assert_eq!(bits, want, "{at}: an unlit lane written");
                            kept += 1;
                            continue;
                        }
                        let mut s = Sampler::from_seed(1, 1);
                        let (fw, pw) = arena.bsdf(roots[k]).eval_pdf(&ctx, wi[k], wo[k], &mut s);
                        assert!(
                            same3(got.0, fw) && same(got.1, pw),
                            "{at}: {got:?} vs {fw} {pw}"
                        );
                        if wi[k].z > 0.0 && wo[k].z > 0.0 {
                            evals += 1;
                        } else {
                            assert!(got == (Spectrum::ZERO, 0.0), "{at}");
                            zeroed += 1;
                        }
                    }
                }
            }
        }
        assert!(
            skipped > 200 && zeroed > 2000 && evals > 400 && kept > 3000,
            "{skipped} skipped chunks, {zeroed} zeroed, {evals} evaluated, {kept} kept lanes"
        );
    }
}
