//! The gather stage's chunks of triangle hits (issue 18, session 16): direct hits on a mesh wait
//! in a one-mesh chunk (slot `geom % 8`) and are gathered by vector gathers from that mesh, or,
//! when their slot holds another mesh's hits, in the mixed chunk gathered lane by lane
//! (`src/stream/kernels/surface.rs`, `MeshChunks`). Either way the rows hold the scalar
//! interaction's bits.

use super::stream::{assert_identical, load};
use crate::common::test_scene;

/// Eleven meshes (three pairs sharing a slot; with and without normals and uvs, flipped, face
/// normals) give the scalar image at 1, 2, 3 and 7 threads, with hits reconstructed in lanes.
#[test]
fn stream_equals_scalar_with_one_mesh_and_mixed_chunks() {
    let path = test_scene("stream_mesh_chunks.xml");
    let l = load(&path, "as_written");
    let lanes = assert_identical(&l, "stream_mesh_chunks.xml", 3);
    assert!(
        lanes.surface_lanes > 0,
        "no surface reconstructed in lanes: {lanes:?}"
    );
}
