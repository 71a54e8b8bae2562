//! Hostile input inside the loader (issue 15): the nesting limits keep the recursive loader
//! within a small stack, and cycles are found wherever they are.

use groove::load::MAX_NESTING;
use groove::scene::xml::parse::load_str;
use std::path::Path;

const HEAD: &str = r#"<scene version="3.0.0"><sensor type="perspective"/>"#;

/// A chain of `n` BSDFs, each a `twosided` referring to the next, the last a diffuse one.
fn ref_chain(n: usize) -> String {
    let mut s = HEAD.to_string();
    for i in 0..n - 1 {
        s += &format!(
            "<bsdf type=\"twosided\" id=\"b{i}\"><ref id=\"b{}\"/></bsdf>\n",
            i + 1
        );
    }
    s + &format!("<bsdf type=\"diffuse\" id=\"b{}\"/></scene>", n - 1)
}

/// `n` `blendbsdf`s nested in the file itself.
fn nested_blend(n: usize) -> String {
    let open = r#"<bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse"/>"#;
    format!(
        "{HEAD}{}<bsdf type=\"diffuse\"/>{}</scene>",
        open.repeat(n - 1),
        "</bsdf>".repeat(n - 1)
    )
}

fn load(text: &str) -> Result<(), String> {
    let path = Path::new("/virtual/deep.xml");
    load_str(text, path, &[])
        .and_then(|doc| groove::load::instantiate(&doc, path))
        .map(|_| ())
        .map_err(|e| e.to_string())
}

/// The deepest nesting the loader accepts, through `<ref>`s or in the file, loads on a thread
/// with a 256 KB stack (an eighth of a rayon worker's, a 32nd of the main thread's): the limit
/// is far below what the stack holds. One more level is a clean error. (Measured with
/// `ulimit -s` on the binary: a 64-deep chain needs 112 KB of main-thread stack for the whole
/// render, a 1-deep one 108 KB.)
#[test]
fn deepest_accepted_nesting_fits_a_small_stack() {
    let run = |text: String| {
        std::thread::Builder::new()
            .stack_size(256 << 10)
            .spawn(move || load(&text))
            .unwrap()
            .join()
            .expect("no stack overflow")
    };
    run(ref_chain(MAX_NESTING)).expect("64 deep through refs");
    run(nested_blend(MAX_NESTING)).expect("64 deep in the file");
    let e = run(ref_chain(MAX_NESTING + 1)).unwrap_err();
    assert!(e.contains("BSDFs nest more than 64 deep"), "{e}");
    let e = run(nested_blend(MAX_NESTING + 1)).unwrap_err();
    assert!(e.contains("BSDFs nest more than 64 deep"), "{e}");
}

/// A cycle anywhere along a chain is found at the `<ref>` that closes it, and names the chain.
#[test]
fn cycles_are_found_at_the_closing_ref() {
    let text = ref_chain(10).replace(r#"<ref id="b9"/>"#, r#"<ref id="b3"/>"#);
    let e = load(&text).unwrap_err();
    assert!(
        e.contains("circular reference: bsdf 'b3' refers to itself ('b3' -> 'b4' -> 'b5' -> 'b6' -> 'b7' -> 'b8' -> 'b3')"),
        "{e}"
    );
    let line = text[..text.rfind(r#"<ref id="b3"/>"#).unwrap()]
        .matches('\n')
        .count()
        + 1;
    assert!(e.starts_with(&format!("/virtual/deep.xml:{line}:")), "{e}");
}

/// A PLY element with a huge count and no properties takes no bytes: skipped at once, not
/// looped over 10^15 times (found while reading the parser for issue 15).
#[test]
fn ply_elements_without_properties_are_skipped_at_once() {
    let ply = "ply\nformat ascii 1.0\nelement junk 1000000000000000\nelement vertex 3\n\
               property float x\nproperty float y\nproperty float z\nelement face 1\n\
               property list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n";
    let t0 = std::time::Instant::now();
    let m = groove::geometry::ply::parse_ply(ply.as_bytes()).expect("valid");
    assert_eq!(m.indices, vec![[0, 1, 2]]);
    assert!(t0.elapsed().as_secs_f64() < 1.0);
}

/// A binary PLY error names the byte offset, an ASCII one the line.
#[test]
fn ply_errors_name_the_position_in_the_file() {
    // One face whose list says 3 indices but has 2: the record's minimum (its count byte) fits,
    // the read fails where the data ends.
    let head = "ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
                property float y\nproperty float z\nelement face 1\n\
                property list uchar uchar vertex_indices\nend_header\n";
    let mut bin = head.as_bytes().to_vec();
    bin.extend_from_slice(&[0u8; 36]);
    bin.extend_from_slice(&[3, 0, 1]);
    let e = groove::geometry::ply::parse_ply(&bin).unwrap_err();
    assert!(
        e.starts_with(&format!(
            "byte offset {} (element `face` 0:",
            head.len() + 39
        )),
        "{e}"
    );
    let ascii = "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nproperty float y\n\
                 property float z\nend_header\n0 0    \n";
    let e = groove::geometry::ply::parse_ply(ascii.as_bytes()).unwrap_err();
    assert!(
        e.starts_with("line 9 (element `vertex` 0: unexpected end of file"),
        "{e}"
    );
}

/// Header counts the file cannot hold, or a declared mesh over the memory budget, are refused
/// from the header alone (no array grows first), naming the element and the sizes.
#[test]
fn ply_header_counts_are_checked_before_reading() {
    let head = |n: &str, fmt: &str| {
        format!(
            "ply\nformat {fmt} 1.0\nelement vertex {n}\nproperty float x\nproperty float y\n\
             property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n"
        )
    };
    let t0 = std::time::Instant::now();
    for fmt in ["binary_little_endian", "binary_big_endian", "ascii"] {
        let mut f = head("1000000000000", fmt).into_bytes();
        f.extend_from_slice(&[b'0'; 64]);
        let e = groove::geometry::ply::parse_ply(&f).unwrap_err();
        assert!(
            e.contains("element `vertex`: the header declares 1000000000000 records"),
            "{fmt}: {e}"
        );
    }
    // 10^7 vertices that the file does hold, under a 64 MB budget: 120 MB of positions.
    let mut f = head("10000000", "binary_little_endian").into_bytes();
    f.resize(f.len() + 120_000_000 + 13, 0);
    let e = groove::geometry::ply::parse_ply_within(&f, &groove::budget::Budget::new(64 << 20))
        .unwrap_err();
    assert!(
        e.starts_with("mesh of 10000000 vertices and 1 faces needs ~114.4 MB"),
        "{e}"
    );
    assert!(t0.elapsed().as_secs_f64() < 5.0);
}

/// The worker threads count against the render's memory budget (issue 15: "thread count"):
/// 64 threads at `THREAD_BYTES` each do not fit 128 MB beside a tiny film, and the error says so.
#[test]
fn worker_threads_count_against_the_budget() {
    use groove::render::{render, RenderOptions, THREAD_BYTES};
    let path = crate::common::test_scene("area_point.xml");
    let loaded = groove::load::load_scene(&path, &Default::default()).expect("load");
    let opts = |threads, mb: u64| RenderOptions {
        threads,
        spp: Some(1),
        budget: groove::budget::Budget::new(mb << 20),
        ..Default::default()
    };
    const _: () = assert!(64 * THREAD_BYTES > 128 << 20);
    let e = render(&loaded.scene, &loaded.settings, &opts(64, 128))
        .err()
        .expect("64 threads over 128 MB")
        .to_string();
    assert!(e.contains("with 64 worker threads needs ~"), "{e}");
    render(&loaded.scene, &loaded.settings, &opts(1, 128)).expect("1 thread fits");
}

/// Fuzzing finding (bitmap target, 2026-12-01): a corrupt B44-compressed EXR makes the `exr`
/// crate's decompressor subtract with overflow (a panic with overflow checks, garbage without).
/// As a texture and as an envmap image it must be a clear error naming the file, never a panic.
#[test]
fn corrupt_b44_exr_is_an_error() {
    let f = crate::common::repo_root().join("tests/data/hostile/exr_b44_overflow.exr");
    let budget = groove::budget::Budget::new(256 << 20);
    let opts = groove::texture::BitmapOptions::default();
    let e = match groove::texture::BitmapTexture::load_within(&f, &opts, &budget) {
        Ok(_) => panic!("a corrupt EXR loaded"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("exr_b44_overflow.exr"), "{e}");
    let _ = groove::output::read_exr_within(&f, &budget, 20);
}
