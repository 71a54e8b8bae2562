//! Mitsuba's `serialized` mesh reader (zlib streams, dictionary), meshes 0 and 1.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    for index in 0..2 {
        let r = std::io::Cursor::new(data);
        let _ = groove::geometry::serialized::read_serialized_within(
            r,
            index,
            true,
            "f",
            &common::budget(),
        );
    }
});
