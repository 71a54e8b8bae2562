//! groove: a physically based renderer for Mitsuba-style XML scenes.
//!
//! # Conventions (used by every module)
//! - Units: scene units as given in the XML; angles in degrees in XML, radians in code.
//! - Colour is linear sRGB/Rec.709 RGB ([`Spectrum`] is a `glam::Vec3`).
//! - Directions point *away* from the surface. `wi` points toward the previous path vertex (the
//!   camera side when tracing radiance), `wo` is the sampled direction / toward the light. This is
//!   Mitsuba's naming, the reverse of pbrt's.
//! - BSDFs work in a local frame whose `z` is the shading normal. `eval` returns `f · |cos θo|`,
//!   `pdf` is a solid-angle density, `sample` returns `weight = f · |cos θo| / pdf`.
//! - Frames are right-handed orthonormal bases `(s, t, n)`; `to_local(v) = (v·s, v·t, v·n)`.
//! - Random numbers: every path draws from its own deterministic stream keyed by
//!   (seed, pixel, sample index), so a render is bit-identical for any thread count.
//!
//! The library serves the `groove` binary, its tests and benches. Its documentation is written
//! for the people who work on it and links private items freely: build it with
//! `cargo doc --no-deps --document-private-items`.
#![allow(rustdoc::private_intra_doc_links)]

pub mod accel;
pub mod bench;
pub mod bsdf;
pub mod budget;
pub mod camera;
pub mod cancel;
pub mod cli;
pub mod emitter;
pub mod error;
pub mod film;
pub mod geometry;
pub mod inputs;
pub mod integrator;
pub mod lane;
pub mod load;
pub mod material;
pub mod math;
pub mod medium;
pub mod merge;
pub mod output;
pub mod render;
pub mod sampler;
pub mod scene;
pub mod spectrum;
pub mod stream;
pub mod texture;

pub use error::{Error, Result, SourceLoc};
pub use spectrum::Spectrum;

/// The crate version, written into image metadata.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
