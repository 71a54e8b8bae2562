//! Render tests: groove's images against Mitsuba 3.9.1 references (`tests/refs/`) by per-tile
//! z-tests, and the comparison's own self-check. One test crate for the theme.

#[path = "../common/mod.rs"]
mod common;

mod aov;
mod curves;
mod cylinder_quirks;
mod film_moments;
mod foundation;
mod instances;
mod lights;
mod materials;
mod media;
mod media_albedo;
mod mnm;
mod mnm_default_tangent;
mod normalmap;
mod parity;
mod ptracer;
mod ptracer_agree;
mod ptracer_sweep;
mod refs_selfcheck;
mod robustness;
mod sdfgrid;
mod stream;
mod stream_blend;
mod stream_emission_shapes;
mod stream_light;
mod stream_mesh_chunks;
mod stream_mnm_build;
mod stream_mnm_direct;
mod stream_spp;
mod stream_width;
mod textures;
mod transform_quirks;
mod volpathmis;
mod wrappers;
