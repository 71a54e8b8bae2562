//! Measurements of microfacet normal mapping printed for the docs: experiments, not checks (the
//! acceptance tests live in `tests/`). Each prints one table on stdout, with fixed seeds, so a
//! rerun prints the numbers pasted into the docs:
//!
//! ```text
//! cargo run --release --example mnm_tables -- energy         # docs/mnm.md, energy table (spec §4.5)
//! cargo run --release --example mnm_tables -- microgeometry  # docs/microgeometry.md (spec §10)
//! cargo run --release --example mnm_tables -- nested-glass   # docs/mnm.md, nested glass albedo
//! cargo run --release --example mnm_tables -- glass-furnace  # docs/mnm.md, glass furnace means
//! ```
//!
//! The test helpers they need (directions, mean ± SE, in-process renders) are the integration
//! tests' own `tests/common`, shared by path rather than moved into the library.

#[path = "../../tests/common/mod.rs"]
mod common;
mod energy;
mod glass;
mod microgeometry;

/// (name, what it prints, the measurement).
const TABLES: [(&str, &str, fn()); 4] = [
    (
        "energy",
        "white-furnace energy table, spec §4.5 (docs/mnm.md)",
        energy::run,
    ),
    (
        "microgeometry",
        "microgeometry tables, spec §10 (docs/microgeometry.md)",
        microgeometry::run,
    ),
    (
        "nested-glass",
        "albedo of the glass furnace's nested GGX dielectric by angle (docs/mnm.md)",
        glass::nested_glass_albedo_by_angle,
    ),
    (
        "glass-furnace",
        "glass furnace image means per walk and tangent mode (docs/mnm.md)",
        glass::glass_furnace_means,
    ),
];

fn main() {
    let arg = std::env::args().nth(1);
    match TABLES.iter().find(|t| Some(t.0) == arg.as_deref()) {
        Some((_, _, run)) => run(),
        None => {
            eprintln!(
                "usage: cargo run --release --example mnm_tables -- TABLE\n\nTABLE is one of:"
            );
            for (name, what, _) in TABLES {
                eprintln!("  {name:<14} {what}");
            }
            std::process::exit(2);
        }
    }
}
