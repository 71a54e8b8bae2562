//! The Wavefront OBJ parser, then the shape built from its mesh.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let text = String::from_utf8_lossy(data);
    if let Ok(mesh) = groove::geometry::obj::parse_obj(&text, std::path::Path::new("f.obj")) {
        let _ = groove::geometry::Shape::from_mesh(mesh, false, false);
    }
});
