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

/// A grid of `n` × `n` quads (2n² triangles) over [−2, 2]² as a binary PLY: a height field
/// (`wall` false: y = h(x, z), with its analytic normals, no uvs) or a wall behind it (`wall`
/// true: z = −1.5 + h(x, y)·0.5 over y ∈ [0, 4], with uvs, no normals).
fn grid_ply(path: &std::path::Path, n: usize, wall: bool) {
    let h = |a: f32, b: f32| {
        0.25 * (3.0 * a).sin() * (2.0 * b).cos() + 0.05 * (11.0 * a + 7.0 * b).sin()
    };
    let mut verts = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (a, b) = (
                -2.0 + 4.0 * i as f32 / n as f32,
                -2.0 + 4.0 * j as f32 / n as f32,
            );
            if wall {
                let (u, v) = (i as f32 / n as f32, j as f32 / n as f32);
                verts.push([a, b + 2.0, -1.5 + 0.5 * h(a, b), u, v, 0.0]);
            } else {
                let e = 1e-3;
                let (dx, dz) = (
                    (h(a + e, b) - h(a - e, b)) / (2.0 * e),
                    (h(a, b + e) - h(a, b - e)) / (2.0 * e),
                );
                let l = (dx * dx + 1.0 + dz * dz).sqrt();
                verts.push([a, h(a, b), b, -dx / l, 1.0 / l, -dz / l]);
            }
        }
    }
    let props = if wall {
        "property float x\nproperty float y\nproperty float z\nproperty float u\nproperty float v\n"
    } else {
        "property float x\nproperty float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n"
    };
    let mut out = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\n{props}element face {}\n\
         property list uchar int vertex_indices\nend_header\n",
        verts.len(),
        2 * n * n
    )
    .into_bytes();
    for v in &verts {
        for x in &v[..if wall { 5 } else { 6 }] {
            out.extend_from_slice(&x.to_le_bytes());
        }
    }
    for j in 0..n {
        for i in 0..n {
            let k = (j * (n + 1) + i) as i32;
            let m = k + n as i32 + 1;
            for t in [[k, m, k + 1], [k + 1, m, m + 1]] {
                out.push(3);
                for x in t {
                    out.extend_from_slice(&x.to_le_bytes());
                }
            }
        }
    }
    std::fs::write(path, out).unwrap();
}

/// Two meshes of 67,712 triangles each (above the size from which the gather stage pipelines a
/// mesh's chunks: index rows prefetched, then the vertices they name, the chunk reconstructed
/// two chunks later, `MeshChunks::enter`), one with normals and without uvs, one with uvs and
/// without normals, under a rectangle light and a dim sky: the stream image equals the scalar
/// one at 1, 2, 3 and 7 threads, so every row the pipeline writes (full chunks, the partial
/// chunks and the chunks still in flight at the stage's end) holds the scalar interaction.
#[test]
fn stream_equals_scalar_with_large_meshes_pipelined() {
    let dir = crate::common::Scratch::new(&format!("groove-chunks-{}", std::process::id()));
    grid_ply(&dir.join("field.ply"), 184, false);
    grid_ply(&dir.join("wall.ply"), 184, true);
    let xml = format!(
        r#"<scene version="3.0.0">
    <integrator type="path"><integer name="max_depth" value="5"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="50"/>
        <transform name="to_world"><lookat origin="0, 3, 5" target="0, 0.3, -0.5" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        <film type="hdrfilm">
            <integer name="width" value="48"/><integer name="height" value="40"/>
            <rfilter type="box"/>
        </film>
    </sensor>
    <shape type="ply">
        <string name="filename" value="{field}"/>
        <bsdf type="diffuse"><rgb name="reflectance" value="0.5, 0.45, 0.35"/></bsdf>
    </shape>
    <shape type="ply">
        <string name="filename" value="{wall}"/>
        <bsdf type="roughconductor"><string name="material" value="Cu"/><float name="alpha" value="0.3"/></bsdf>
    </shape>
    <shape type="rectangle">
        <transform name="to_world"><scale x="1.5" y="1"/><rotate x="1" angle="80"/><translate x="1" y="4" z="2"/></transform>
        <emitter type="area"><rgb name="radiance" value="8"/></emitter>
    </shape>
    <emitter type="constant"><rgb name="radiance" value="0.1, 0.12, 0.15"/></emitter>
</scene>
"#,
        field = dir.join("field.ply").display(),
        wall = dir.join("wall.ply").display(),
    );
    let path = dir.join("large_meshes.xml");
    std::fs::write(&path, xml).unwrap();
    let l = load(&path, "as_written");
    let lanes = assert_identical(&l, "large_meshes.xml", 4);
    assert!(
        lanes.surface_lanes > 0,
        "no surface reconstructed in lanes: {lanes:?}"
    );
}
