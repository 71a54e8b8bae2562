//! The stream renderer's 8-wide material kernels (issue 18): a run of at least 8 paths of one
//! material, after the stable sort, is shaded 8 at a time by code written once over
//! [`crate::lane::Lane`]. The drivers of `diffuse`, the wrapper chain and plastic (and the
//! helpers they share: [`draws`], [`light`]'s gather, [`surface`]'s prologue) are generic over
//! the chunk width `W` and its token ([`crate::lane::Wide`]), and run 16 wide on AVX-512 (their
//! modules keep the name `x8` from their first width; [`mnm`] is still 8-wide only). A material without a kernel, a run's tail (< 8 paths) and a machine
//! without AVX2 go through the 1-lane code lane by lane ([`crate::integrator::path::PathState::scatter`]),
//! never through something else.
//!
//! Bit-identity with the scalar renderer: a kernel computes exactly the operations of the
//! scalar code in the same order (the scalar BSDF, frame, warp and vector code is the `f32`
//! instantiation of the same `lane` functions; what the scalar renderer does with plain glam
//! arithmetic is mirrored here operation for operation and checked lane by lane in the unit
//! tests below and by `tests/render/stream.rs`). Random numbers follow each path's own stream in
//! the scalar renderer's order, drawn 8-wide from the chunk's gathered PCG32 states by the one
//! helper of all kernels ([`draws`]); the parts of a vertex that branch
//! on data (the sampling of emitters without a lane form, Russian roulette) run lane by lane
//! through the very functions the scalar renderer calls.
//!
//! - [`diffuse`]: `diffuse` with next-event estimation.
//! - [`conductor`]: `roughconductor` (with next-event estimation), `conductor`, constant
//!   `plastic`/`roughplastic` leaves, `diffuse` leaves (reflectance gathered per lane) and
//!   `dielectric`/`roughdielectric`/`thindielectric` leaves (refraction: the crossing's η goes
//!   to `PathState::advance`), bare or under `twosided` and classic `normalmap`, in lanes;
//!   [`vertex`]: their 8-wide driver.
//! - [`blend`]: `blendbsdf` (bare or under `twosided`) of two children the wrapper-chain
//!   driver has lane forms for, its weight constant or textured.
//! - [`plastic`]: bare `plastic` and `roughplastic` (textured reflectances gathered) with
//!   next-event estimation.
//! - [`mnm`]: the compensated microfacet normal map (its BSDF per lane through the scalar
//!   model; light points, MIS and shadow rays in lanes).
//! - [`light`]: the light selection and area lights on triangle meshes, rectangles and spheres
//!   sampled in lanes, and the one light-point gather of all kernels (`light::x8::Gather`);
//!   [`emitters`]: `point`, `spot`, `directional`, `constant` and `envmap` in lanes.
//! - [`draws`]: a vertex's random numbers for 8 paths, 8-wide.
//! - [`surface`]: the kernels' one surface load, 8-wide from the batch's columns.
//! - [`tail`]: the end of a vertex, per integrator (`path`: `PathState::advance`; `direct`:
//!   rays to trace), after a kernel's 8-wide samples.
//! - [`ray`]: robust ray origins in lanes.
//! - [`mis`]: the power heuristic in lanes.

pub(crate) mod blend;
pub(crate) mod conductor;
pub(crate) mod diffuse;
pub(crate) mod draws;
pub(crate) mod emitters;
pub(crate) mod light;
pub(crate) mod mis;
pub(crate) mod mnm;
pub(crate) mod plastic;
pub(crate) mod ray;
pub(crate) mod surface;
pub(crate) mod tail;
pub(crate) mod vertex;
