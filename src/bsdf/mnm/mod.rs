//! Microfacet-based normal mapping (Schüssler, Heitz, Hanika, Dachsbacher 2017) and its
//! extensions (transmission, other microgeometries). See `../shared/spec/mnm.md`.
//!
//! Built so far: the microgeometries (facet areas, projected areas, λ, G1) in [`facets`].
//! The BSDF itself (explicit and random-walk evaluation) is the next step.

pub mod facets;
