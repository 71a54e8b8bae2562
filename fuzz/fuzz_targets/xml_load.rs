//! The XML loader end to end (parse, includes, substitution, instantiation with Embree):
//! the input is split at the first NUL byte into the scene file and a file it may include
//! as `inc.xml` (both written to a scratch folder).
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    common::let_groove_catch_decoder_panics();
    let dir = common::scratch();
    let (main, inc) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    let scene = dir.join("scene.xml");
    std::fs::write(&scene, main).unwrap();
    std::fs::write(dir.join("inc.xml"), inc).unwrap();
    let opts = groove::load::options::LoadOptions {
        budget: common::budget(),
        ..Default::default()
    };
    let _ = groove::load::load_scene(&scene, &opts);
});
