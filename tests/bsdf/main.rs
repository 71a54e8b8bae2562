//! BSDF tests: the statistical harness (chi-square of sample vs pdf, weight == eval/pdf, furnace,
//! reciprocity), pointwise agreement with Mitsuba 3.9.1, the wrappers, and the microfacet normal
//! map's oracles. One test crate (one link) for the theme; each module is one former test file.

#[path = "../common/mod.rs"]
mod common;

mod adjoint;
mod grazing;
mod hair;
mod harness;
mod mitsuba_wrappers;
mod mnm_auto;
mod mnm_auto_load;
mod mnm_compensated;
mod mnm_compensated_load;
mod mnm_exit_on_refraction;
mod mnm_first_order;
mod mnm_harness;
mod mnm_lambert;
mod mnm_microgeometry;
mod mnm_oracles;
mod mnm_perf_fused;
mod mnm_transmission;
mod principled_points;
mod principled_stats;
mod wrappers;
