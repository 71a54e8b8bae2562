//! The command line's `-D KEY=VALUE` parsing, and the value substituted into a scene that
//! uses it in every kind of attribute.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

const SCENE: &str = r#"<scene version="3.0.0">
    <default name="k" value="1"/>
    <integrator type="path"><integer name="max_depth" value="$k"/></integrator>
    <sensor type="perspective"><float name="fov" value="$k"/>
        <film type="hdrfilm"><integer name="width" value="$k"/><integer name="height" value="4"/></film>
    </sensor>
    <shape type="sphere"><bsdf type="$k"/><float name="radius" value="$k"/></shape>
    <emitter type="constant"><rgb name="radiance" value="$k"/></emitter>
</scene>"#;

fuzz_target!(|data: &[u8]| {
    let Ok(s) = std::str::from_utf8(data) else {
        return;
    };
    let Ok((key, value)) = groove::cli::parse_define(s) else {
        return;
    };
    let defines = [(key, value)];
    let path = std::path::Path::new("/nonexistent/fuzz.xml");
    let budget = common::budget();
    if let Ok(doc) = groove::scene::xml::parse::load_str_within(SCENE, path, &defines, &budget) {
        let mode = groove::load::options::NormalMapping::AsWritten;
        let _ = groove::load::instantiate_within(&doc, path, mode, &budget);
    }
});
