//! Bitmap textures: PNG, JPEG and OpenEXR decoding (recognised by content), written to a
//! scratch file and loaded as a `bitmap` texture would be; then the EXR reader of envmaps.
#![no_main]
use libfuzzer_sys::fuzz_target;

#[path = "common.rs"]
mod common;

fuzz_target!(|data: &[u8]| {
    common::let_groove_catch_decoder_panics();
    let path = common::scratch().join("image.bin");
    std::fs::write(&path, data).unwrap();
    let opts = groove::texture::BitmapOptions::default();
    let _ = groove::texture::BitmapTexture::load_within(&path, &opts, &common::budget());
    if data.starts_with(&[0x76, 0x2f, 0x31, 0x01]) {
        let _ = groove::output::read_exr_within(&path, &common::budget(), 20);
    }
});
