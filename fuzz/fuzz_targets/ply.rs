//! The PLY parser (ASCII and binary), then the shape built from its mesh.
#![no_main]
use libfuzzer_sys::fuzz_target;

mod common;

fuzz_target!(|data: &[u8]| {
    if let Ok(mesh) = groove::geometry::ply::parse_ply_within(data, &common::budget()) {
        let _ = groove::geometry::Shape::from_mesh(mesh, false, false);
    }
});
