//! The stream renderer's batch set-up at 8 and more samples per pixel: a chunk of 8 paths is
//! then 8 samples of one pixel (one stream key, `sampler::for_samples_x8`, and no per-path
//! stepping in `Batch::fill`), or, at 12 spp, a chunk straddles two pixels. The image equals
//! the scalar renderer's bit for bit (`tests/render/stream.rs` renders at 3 and 4 spp, where
//! every chunk spans several pixels).

use super::stream::{assert_identical, load, scene};

#[test]
fn stream_equals_scalar_at_8_and_12_spp() {
    let l = load(&scene("scenes/bench/metal_plastic.xml"), "classic");
    for spp in [8, 12] {
        let lanes = assert_identical(&l, &format!("metal_plastic at {spp} spp"), spp);
        assert!(
            lanes.conductor_lanes > 0,
            "{spp} spp: the kernels never ran"
        );
    }
}
