//! A microfacet normal map's microsurface and frames as the reflection walk's readers see them
//! (issue 18, forty-second session): [`MapView`], implemented by the map itself and by
//! [`MapRef`], a lane's map or its [`ColMap`] (lane k of the stream kernel's build columns
//! without a map).
//!
//! The stream kernel builds the maps of 8 hits from columns (`MnmSettings::lanes_at`, then
//! `map_lane_into` per lane: ~340 instructions a sample on `metal_plastic` in walk-same). A
//! lane whose every query goes through the masked walks (the reflection walk over a shared
//! `roughconductor` or `roughplastic` leaf: its light-sample terms, `walk_pdf_lanes`; its
//! eval and sample walks, `compensated::lanes`; the sample's density, `walk_density_lanes`)
//! needs only what this trait gives: the microsurface (λ, G1, the wall's normal), the
//! carrying facets' frames, the wall flag, `max_order` and the MIS weight c. [`ColMap`] takes
//! them from the columns by the same functions the map's build uses (`Microsurface::of_lane`,
//! `Microsurface::frame_of_lane`, [`super::mis_weight`]), so every number is the map's bit for
//! bit (`tests`), and `PdfTerms` and the walks stay one code over both.

use super::facet_bsdf::reflect_across;
use super::facets::{FacetCols, Microgeometry, Microsurface, MAX_FACETS};
use super::{mis_weight, MicrofacetNormalMap, Tangent};
use crate::math::Frame;
use glam::Vec3;

/// A map's microsurface and frames, what the reflection walk's terms, walks and densities
/// read of it.
pub(crate) trait MapView {
    /// The facets (area vectors, normals): λ, G1, the mirror wall's normal.
    fn surface(&self) -> &Microsurface;
    /// Facet `k`'s frame (a facet that carries the nested BSDF).
    fn frame(&self, k: usize) -> Frame;
    /// Facet 1 is the sawtooth's mirror wall.
    fn mirror_wall(&self) -> bool;
    /// The walk's longest path, in vertices (at least 1).
    fn max_order(&self) -> u32;
    /// Decision 3's cosine-lobe weight c of the walk's MIS density.
    fn mis_c(&self) -> f32;
    /// `w` reflected by the mirror wall (facet 1).
    #[inline(always)]
    fn reflect_wall(&self, w: Vec3) -> Vec3 {
        reflect_across(w, self.surface().normal(1))
    }
}

impl MapView for MicrofacetNormalMap {
    #[inline(always)]
    fn surface(&self) -> &Microsurface {
        &self.surface
    }
    #[inline(always)]
    fn frame(&self, k: usize) -> Frame {
        self.frames[k]
    }
    #[inline(always)]
    fn mirror_wall(&self) -> bool {
        self.mirror_wall
    }
    #[inline(always)]
    fn max_order(&self) -> u32 {
        self.max_order
    }
    #[inline(always)]
    fn mis_c(&self) -> f32 {
        MicrofacetNormalMap::mis_c(self)
    }
}

/// Lane `k` of a chunk's build columns standing for its map (`MnmSettings::map_lane_into`'s
/// map of the random walk, not flat): its microsurface copied out of the columns as the map's
/// build copies it, its frames read from them on demand, the wall flag, `max_order` and c as
/// `MicrofacetNormalMap::of_lane` sets them.
#[derive(Clone, Copy)]
pub(crate) struct ColMap<'c> {
    surface: Microsurface,
    from: [u8; MAX_FACETS],
    facets: &'c FacetCols<8>,
    k: usize,
    mirror_wall: bool,
    max_order: u32,
    mis_c: f32,
}

impl<'c> ColMap<'c> {
    /// Lane `k` of `facets` with perturbed normal `wp` (the columns' own, clamped), for the
    /// random walk over `geometry` and `tangent` with `max_order`: the numbers of
    /// `MicrofacetNormalMap::of_lane` of the same lane (its `assemble`).
    #[inline(always)]
    pub(crate) fn of_lane(
        facets: &'c FacetCols<8>,
        k: usize,
        wp: Vec3,
        geometry: Microgeometry,
        tangent: Tangent,
        max_order: u32,
    ) -> Self {
        let (surface, from) = Microsurface::of_lane(facets, k);
        ColMap {
            mirror_wall: geometry == Microgeometry::Sawtooth
                && tangent == Tangent::Mirror
                && surface.len() == 2,
            surface,
            from,
            facets,
            k,
            max_order: max_order.max(1),
            mis_c: mis_weight(wp),
        }
    }
}

impl ColMap<'_> {
    /// Facet `k`'s frame, from the columns (`Microsurface::frame_of_lane`, as the map's
    /// build takes it).
    #[inline(always)]
    fn frame(&self, k: usize) -> Frame {
        self.surface
            .frame_of_lane(self.facets, &self.from, self.k, k)
    }
}

/// A lane's map or its view of the columns: what the stream kernel's walks keep per lane,
/// and the one [`MapView`] of a view (its fields read here: one source for both kinds of
/// lane, no accessors repeated for the view).
#[derive(Clone, Copy)]
pub(crate) enum MapRef<'a> {
    Map(&'a MicrofacetNormalMap),
    Cols(&'a ColMap<'a>),
}

impl MapView for MapRef<'_> {
    #[inline(always)]
    fn surface(&self) -> &Microsurface {
        match self {
            MapRef::Map(m) => MapView::surface(*m),
            MapRef::Cols(c) => &c.surface,
        }
    }
    #[inline(always)]
    fn frame(&self, k: usize) -> Frame {
        match self {
            MapRef::Map(m) => MapView::frame(*m, k),
            MapRef::Cols(c) => c.frame(k),
        }
    }
    #[inline(always)]
    fn mirror_wall(&self) -> bool {
        match self {
            MapRef::Map(m) => MapView::mirror_wall(*m),
            MapRef::Cols(c) => c.mirror_wall,
        }
    }
    #[inline(always)]
    fn max_order(&self) -> u32 {
        match self {
            MapRef::Map(m) => MapView::max_order(*m),
            MapRef::Cols(c) => c.max_order,
        }
    }
    #[inline(always)]
    fn mis_c(&self) -> f32 {
        match self {
            MapRef::Map(m) => MapView::mis_c(*m),
            MapRef::Cols(c) => c.mis_c,
        }
    }
}

impl<'a> MapRef<'a> {
    /// The map itself, for the scalar code that reads the whole map (`walk::eval`, the
    /// nested densities of `PdfTerms::total`); `None` for a view (every query of such a lane
    /// goes through the masked walks).
    #[inline(always)]
    pub(crate) fn map(self) -> Option<&'a MicrofacetNormalMap> {
        match self {
            MapRef::Map(m) => Some(m),
            MapRef::Cols(_) => None,
        }
    }
}

/// Whether view `v` holds map `m`'s numbers bit for bit: the microsurface (facet count, area
/// vectors, normals), the carrying facets' frames, the wall flag, `max_order` and c (the
/// walk tests' check of every view they hand the walks).
#[cfg(test)]
pub(crate) fn view_is_map(v: &impl MapView, m: &MicrofacetNormalMap) -> bool {
    let same = |a: Vec3, b: Vec3| a.to_array().map(f32::to_bits) == b.to_array().map(f32::to_bits);
    let (s, t) = (v.surface(), &m.surface);
    let mut ok = s.len() == t.len()
        && v.mirror_wall() == m.mirror_wall
        && v.max_order() == m.max_order
        && v.mis_c().to_bits() == MicrofacetNormalMap::mis_c(m).to_bits();
    for j in 0..t.len().min(MAX_FACETS) {
        ok &= same(s.area_vector(j), t.area_vector(j)) && same(s.normal(j), t.normal(j));
    }
    let carrying = if m.mirror_wall { 1 } else { t.len() };
    for j in 0..carrying.min(MAX_FACETS) {
        let (a, b) = (v.frame(j), m.frames[j]);
        ok &= same(a.s, b.s) && same(a.t, b.t) && same(a.n, b.n);
    }
    // What the terms compute from them: λ and G1 toward directions above, grazing and below,
    // and the wall's reflection.
    for w in [
        Vec3::Z,
        Vec3::new(0.6, 0.0, 0.8),
        Vec3::new(-0.3, 0.5, 0.81),
        Vec3::new(0.7, -0.7, 0.14),
        Vec3::new(-0.9, -0.2, 0.02),
        Vec3::new(0.1, 0.2, -0.97),
    ] {
        ok &= s.lambdas(w).map(f32::to_bits) == t.lambdas(w).map(f32::to_bits)
            && s.g1(w).to_bits() == t.g1(w).to_bits();
        if m.mirror_wall {
            ok &= same(v.reflect_wall(w), MapView::reflect_wall(m, w));
        }
    }
    ok
}
