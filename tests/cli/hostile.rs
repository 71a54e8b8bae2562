//! Hostile and careless input (issue 15), one test per class: every case must exit non-zero
//! with a clear message at the right place, by itself (no signal), within a time limit and
//! under an address-space limit (`prlimit --as`), leaving the inputs and other outputs as they
//! were and no temporary file behind.

use super::{tmpdir, write, TINY};
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Address space granted to each hostile run: far below what any of the cases would allocate
/// without its check (tens to hundreds of GB), far above what groove needs for a tiny scene.
const AS_LIMIT: &str = "--as=3221225472";
/// Wall-clock limit of each hostile run.
const TIME_LIMIT: Duration = Duration::from_secs(30);

/// Every file under `dir` with its contents.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut out = Vec::new();
    let mut todo = vec![dir.to_path_buf()];
    while let Some(d) = todo.pop() {
        for e in fs::read_dir(&d).unwrap() {
            let e = e.unwrap();
            let t = e.file_type().unwrap();
            if t.is_dir() {
                todo.push(e.path());
            } else if t.is_file() {
                out.push((e.path(), fs::read(e.path()).unwrap()));
            } else {
                out.push((e.path(), b"<special>".to_vec()));
            }
        }
    }
    out.sort();
    out
}

/// Runs `groove ARGS` in `dir` under the address-space and time limits and returns stderr,
/// asserting: a non-zero exit code (not a signal), no panic, every message in `expect` present,
/// and `dir` unchanged (no file written, replaced or left behind).
fn refused(dir: &Path, args: &[&str], expect: &[&str]) -> String {
    let before = snapshot(dir);
    let mut child = Command::new("prlimit")
        .arg(AS_LIMIT)
        .arg("--")
        .arg(assert_cmd::cargo::cargo_bin("groove"))
        .args(args)
        .current_dir(dir)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("prlimit");
    let t0 = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if t0.elapsed() > TIME_LIMIT {
            let _ = child.kill();
            let _ = child.wait();
            panic!("{args:?}: still running after {TIME_LIMIT:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    let mut err = String::new();
    use std::io::Read;
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert!(
        matches!(status.code(), Some(c) if c != 0),
        "{args:?}: expected an error exit, got {status:?}; stderr: {err}"
    );
    assert!(!err.contains("panicked"), "{args:?}: panicked: {err}");
    for e in expect {
        assert!(err.contains(e), "{args:?}: expected {e:?} in: {err}");
    }
    assert_eq!(
        snapshot(dir),
        before,
        "{args:?}: the directory changed; stderr: {err}"
    );
    err
}

/// TINY with `extra` added before `</scene>`.
fn tiny_with(extra: &str) -> String {
    TINY.replace("</scene>", &format!("{extra}\n</scene>"))
}

/// The 1-based line and column where the last `needle` starts in `text`.
fn line_col(text: &str, needle: &str) -> String {
    let i = text.rfind(needle).expect("needle");
    let line = text[..i].matches('\n').count() + 1;
    let col = text[..i].rsplit('\n').next().unwrap().chars().count() + 1;
    format!("{line}:{col}")
}

#[test]
fn ref_cycles_are_circular_references_at_the_ref() {
    let d = tmpdir("hostile-cycle");
    // An unused twosided that refers to itself.
    let text = tiny_with(r#"<bsdf type="twosided" id="me"><ref id="me"/></bsdf>"#);
    write(&d, "self.xml", &text);
    let at = line_col(&text, r#"id="me"/>"#);
    refused(
        &d,
        &["render", "-q", "self.xml", "-o", "o.exr"],
        &[&format!("self.xml:{at}: circular reference: bsdf 'me'")],
    );
    // Two blendbsdfs referring to each other through a shape.
    let text = tiny_with(
        r#"<bsdf type="blendbsdf" id="a"><float name="weight" value="0.5"/><ref id="b"/><bsdf type="diffuse"/></bsdf>
<bsdf type="blendbsdf" id="b"><float name="weight" value="0.5"/><bsdf type="diffuse"/><ref id="a"/></bsdf>"#,
    );
    write(&d, "pair.xml", &text);
    let at = line_col(&text, r#"id="a"/>"#);
    refused(
        &d,
        &["render", "-q", "pair.xml", "-o", "o.exr"],
        &[
            &format!("pair.xml:{at}: circular reference: bsdf 'a'"),
            "'a' -> 'b'",
        ],
    );
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    let d = tmpdir("hostile-nest");
    for (tag, open, leaf) in [
        (
            "twosided",
            r#"<bsdf type="twosided">"#,
            r#"<bsdf type="diffuse"/>"#,
        ),
        (
            "blendbsdf",
            r#"<bsdf type="blendbsdf"><float name="weight" value="0.5"/><bsdf type="diffuse"/>"#,
            r#"<bsdf type="diffuse"/>"#,
        ),
    ] {
        let n = 5000;
        let text = tiny_with(&format!("{}{leaf}{}", open.repeat(n), "</bsdf>".repeat(n)));
        write(&d, &format!("{tag}.xml"), &text);
        refused(
            &d,
            &["render", "-q", &format!("{tag}.xml"), "-o", "o.exr"],
            &[&format!("{tag}.xml:"), "elements nest more than 128 deep"],
        );
    }
    // Flat in the file, deep through <ref>s: the loader's own limit.
    let mut chain = String::new();
    for i in 0..300 {
        chain += &format!(
            "<bsdf type=\"twosided\" id=\"b{i}\"><ref id=\"b{}\"/></bsdf>\n",
            i + 1
        );
    }
    chain += "<bsdf type=\"diffuse\" id=\"b300\"/>";
    write(&d, "chain.xml", &tiny_with(&chain));
    refused(
        &d,
        &["render", "-q", "chain.xml", "-o", "o.exr"],
        &["chain.xml:", "BSDFs nest more than 64 deep"],
    );
}

/// A minimal scan-line OpenEXR header (RGB half channels, no compression) claiming a
/// `w`×`h` data window, followed by `tail` bytes of nothing (no offset table, no pixels).
fn exr_header(w: i32, h: i32, tail: usize) -> Vec<u8> {
    fn attr(out: &mut Vec<u8>, name: &str, ty: &str, value: &[u8]) {
        out.extend_from_slice(name.as_bytes());
        out.push(0);
        out.extend_from_slice(ty.as_bytes());
        out.push(0);
        out.extend_from_slice(&(value.len() as i32).to_le_bytes());
        out.extend_from_slice(value);
    }
    let mut v = vec![0x76, 0x2f, 0x31, 0x01, 2, 0, 0, 0];
    let mut ch = Vec::new();
    for c in ["B", "G", "R"] {
        ch.extend_from_slice(c.as_bytes());
        ch.push(0);
        ch.extend_from_slice(&1i32.to_le_bytes()); // HALF
        ch.extend_from_slice(&[0, 0, 0, 0]);
        ch.extend_from_slice(&1i32.to_le_bytes());
        ch.extend_from_slice(&1i32.to_le_bytes());
    }
    ch.push(0);
    attr(&mut v, "channels", "chlist", &ch);
    attr(&mut v, "compression", "compression", &[0]);
    let mut b = Vec::new();
    for x in [0, 0, w - 1, h - 1] {
        b.extend_from_slice(&x.to_le_bytes());
    }
    attr(&mut v, "dataWindow", "box2i", &b);
    attr(&mut v, "displayWindow", "box2i", &b);
    attr(&mut v, "lineOrder", "lineOrder", &[0]);
    attr(&mut v, "pixelAspectRatio", "float", &1f32.to_le_bytes());
    attr(&mut v, "screenWindowCenter", "v2f", &[0; 8]);
    attr(&mut v, "screenWindowWidth", "float", &1f32.to_le_bytes());
    v.push(0);
    v.resize(v.len() + tail, 0);
    v
}

/// A PNG claiming a `w`×`h` RGB image: signature, IHDR, an empty IDAT and IEND.
fn png_header(w: u32, h: u32) -> Vec<u8> {
    let mut v = vec![0x89, b'P', b'N', b'G', 0x0d, 0x0a, 0x1a, 0x0a];
    let mut ihdr = Vec::new();
    ihdr.extend_from_slice(&w.to_be_bytes());
    ihdr.extend_from_slice(&h.to_be_bytes());
    ihdr.extend_from_slice(&[8, 2, 0, 0, 0]);
    for (ty, data) in [(&b"IHDR"[..], &ihdr[..]), (b"IDAT", &[]), (b"IEND", &[])] {
        v.extend_from_slice(&(data.len() as u32).to_be_bytes());
        let mut chunk = ty.to_vec();
        chunk.extend_from_slice(data);
        v.extend_from_slice(&chunk);
        let mut crc = flate2::Crc::new();
        crc.update(&chunk);
        v.extend_from_slice(&crc.sum().to_be_bytes());
    }
    v
}

#[test]
fn huge_image_headers_are_refused_before_allocating() {
    let d = tmpdir("hostile-images");
    fs::write(d.join("huge.exr"), exr_header(100_000, 100_000, 64)).unwrap();
    fs::write(d.join("huge.png"), png_header(100_000, 100_000)).unwrap();
    for (name, tex) in [("exr", "huge.exr"), ("png", "huge.png")] {
        let text = tiny_with(&format!(
            r#"<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="{tex}"/></texture></bsdf></shape>"#
        ));
        write(&d, &format!("tex_{name}.xml"), &text);
        let at = line_col(&text, "<texture");
        refused(
            &d,
            &["render", "-q", &format!("tex_{name}.xml"), "-o", "o.exr"],
            &[
                &format!("tex_{name}.xml:{at}: cannot load bitmap texture '{tex}'"),
                "image 100000×100000 needs ~",
                "raise it with --max-memory",
            ],
        );
    }
    let text = TINY.replace(
        r#"<emitter type="constant"/>"#,
        r#"<emitter type="envmap"><string name="filename" value="huge.exr"/></emitter>"#,
    );
    write(&d, "env.xml", &text);
    let at = line_col(&text, r#"<emitter type="envmap""#);
    refused(
        &d,
        &["render", "-q", "env.xml", "-o", "o.exr"],
        &[
            &format!("env.xml:{at}: cannot read envmap 'huge.exr'"),
            "EXR image 100000×100000",
            "needs ~",
        ],
    );
    // A header attribute claiming 2 GB (a mutated header): the EXR reader must not trust it.
    let mut big_attr = exr_header(4, 4, 0);
    big_attr.pop();
    big_attr.extend_from_slice(b"comments\0string\0");
    big_attr.extend_from_slice(&0x7fff_ffffi32.to_le_bytes());
    big_attr.extend_from_slice(b"abc\0");
    fs::write(d.join("attr.exr"), big_attr).unwrap();
    write(&d, "attr.xml", &text.replace("huge.exr", "attr.exr"));
    refused(
        &d,
        &["render", "-q", "attr.xml", "-o", "o.exr"],
        &[
            "attr.xml:",
            "cannot read envmap 'attr.exr'",
            "cannot read the EXR header",
        ],
    );
    // A modest image over a lowered limit: the limit is the user's.
    fs::write(d.join("mid.exr"), exr_header(4096, 4096, 64)).unwrap();
    write(&d, "mid.xml", &text.replace("huge.exr", "mid.exr"));
    refused(
        &d,
        &[
            "render",
            "-q",
            "mid.xml",
            "-o",
            "o.exr",
            "--max-memory",
            "0.1",
        ],
        &["EXR image 4096×4096", "over the 102.4 MB memory limit"],
    );
}

#[test]
fn huge_films_and_thread_counts_are_refused() {
    let d = tmpdir("hostile-film");
    let text = TINY.replace(
        r#"<integer name="width" value="8"/><integer name="height" value="6"/>"#,
        r#"<integer name="width" value="30000"/><integer name="height" value="30000"/>"#,
    );
    write(&d, "film.xml", &text);
    let at = line_col(&text, "<film");
    refused(
        &d,
        &["render", "-q", "film.xml", "-o", "o.exr"],
        &[
            &format!("film.xml:{at}: film 30000×30000 needs ~"),
            "raise it with --max-memory",
        ],
    );
    write(&d, "tiny.xml", TINY);
    refused(
        &d,
        &["render", "-q", "tiny.xml", "-o", "o.exr", "-t", "100000"],
        &["100000 worker threads asked for; at most"],
    );
    refused(
        &d,
        &[
            "render",
            "-q",
            "tiny.xml",
            "-o",
            "o.exr",
            "--max-memory",
            "0",
        ],
        &["--max-memory", "positive number of GB"],
    );
}

#[test]
fn includes_are_parsed_once_and_expansion_is_budgeted() {
    let d = tmpdir("hostile-include");
    // Each level includes the next twice, with 400 kB of padding: re-parsing every include
    // would parse 2^14 × 400 kB = 6.5 GB of XML; parsing each file once parses 6 MB.
    let pad = format!("<!-- {} -->", "x".repeat(400_000));
    for k in 0..14 {
        write(
            &d,
            &format!("lvl{k}.xml"),
            &format!(
                "<scene version=\"3.0.0\">{pad}<include filename=\"lvl{}.xml\"/><include filename=\"lvl{}.xml\"/></scene>",
                k + 1,
                k + 1
            ),
        );
    }
    write(
        &d,
        "lvl14.xml",
        "<scene version=\"3.0.0\"><bsdf type=\"diffuse\"/></scene>",
    );
    let scene = write(
        &d,
        "wide.xml",
        &tiny_with(r#"<include filename="lvl0.xml"/>"#),
    );
    let t0 = Instant::now();
    let doc = groove::scene::xml::parse::load_file(&scene, &[]).unwrap();
    let secs = t0.elapsed().as_secs_f64();
    assert_eq!(
        doc.root.children.iter().filter(|c| c.tag == "bsdf").count(),
        1 << 14
    );
    assert_eq!(doc.files.len(), 16, "{:?}", doc.files);
    // Re-parsing would cost ~0.5 ms per include, 8 s in all; parsing once takes ~50 ms.
    assert!(secs < 3.0, "2^14 includes took {secs:.1} s");

    // Twice per level, 30 levels deep: 2^30 elements. The budget stops it.
    for k in 0..30 {
        write(
            &d,
            &format!("exp{k}.xml"),
            &format!(
                "<scene version=\"3.0.0\"><include filename=\"exp{}.xml\"/><include filename=\"exp{}.xml\"/></scene>",
                k + 1,
                k + 1
            ),
        );
    }
    write(
        &d,
        "exp30.xml",
        "<scene version=\"3.0.0\"><bsdf type=\"diffuse\"/></scene>",
    );
    write(
        &d,
        "exp.xml",
        &tiny_with(r#"<include filename="exp0.xml"/>"#),
    );
    refused(
        &d,
        &[
            "render",
            "-q",
            "exp.xml",
            "-o",
            "o.exr",
            "--max-memory",
            "0.25",
        ],
        &[
            "the scene's XML (",
            "elements with includes spliced in) needs ~",
        ],
    );
    // Under the default memory limit the element cap stops it, at once: the include is counted
    // on the parsed files before anything is spliced (expanding 8 M elements first took 17 s).
    let t0 = std::time::Instant::now();
    refused(
        &d,
        &["render", "-q", "exp.xml", "-o", "o.exr"],
        &["the scene expands to more than 8000000 XML elements"],
    );
    let secs = t0.elapsed().as_secs_f64();
    assert!(secs < 5.0, "the element cap took {secs:.1} s");
    // A cycle.
    write(
        &d,
        "c1.xml",
        "<scene version=\"3.0.0\">\n<include filename=\"c2.xml\"/></scene>",
    );
    write(
        &d,
        "c2.xml",
        "<scene version=\"3.0.0\">\n<include filename=\"c1.xml\"/></scene>",
    );
    write(&d, "cyc.xml", &tiny_with(r#"<include filename="c1.xml"/>"#));
    refused(
        &d,
        &["render", "-q", "cyc.xml", "-o", "o.exr"],
        &["c2.xml:2:10: include cycle: './c1.xml' is already being included"],
    );
}

#[cfg(unix)]
#[test]
fn only_regular_files_are_read() {
    let d = tmpdir("hostile-special");
    let fifo = d.join("pipe.xml");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    fs::create_dir(d.join("dir.obj")).unwrap();
    refused(
        &d,
        &["render", "-q", "pipe.xml", "-o", "o.exr"],
        &["pipe.xml: is a FIFO (named pipe); only regular files are read"],
    );
    for (what, name, expect) in [
        ("include", "pipe.xml", "is a FIFO"),
        ("include", "/dev/zero", "is a character device"),
        ("obj", "/dev/zero", "is a character device"),
        ("obj", "dir.obj", "is a directory"),
        ("ply", "pipe.xml", "is a FIFO"),
        ("texture", "/dev/zero", "is a character device"),
    ] {
        let elem = match what {
            "include" => format!(r#"<include filename="{name}"/>"#),
            "texture" => format!(
                r#"<shape type="sphere"><bsdf type="diffuse"><texture type="bitmap" name="reflectance"><string name="filename" value="{name}"/></texture></bsdf></shape>"#
            ),
            t => format!(r#"<shape type="{t}"><string name="filename" value="{name}"/></shape>"#),
        };
        let text = tiny_with(&elem);
        write(&d, "s.xml", &text);
        let tag = if what == "include" {
            "<include"
        } else if what == "texture" {
            "<texture"
        } else {
            "<shape"
        };
        let at = line_col(&text, tag);
        let err = refused(&d, &["render", "-q", "s.xml", "-o", "o.exr"], &[expect]);
        assert!(
            err.contains(&format!("s.xml:{}", at.split(':').next().unwrap())),
            "{what} {name}: {err}"
        );
    }
}

#[test]
fn outputs_never_overwrite_inputs_or_each_other() {
    let d = tmpdir("hostile-outputs");
    fs::create_dir_all(d.join("a")).unwrap();
    fs::create_dir_all(d.join("b")).unwrap();
    write(&d, "a/x.xml", TINY);
    write(&d, "b/x.xml", TINY);
    refused(
        &d,
        &["render", "-q", "a/x.xml", "b/x.xml", "-o", "out"],
        &["a/x.xml and b/x.xml would both be written to out/x.exr; nothing was rendered"],
    );
    // The same scene twice is the same clash.
    refused(
        &d,
        &["render", "-q", "a/x.xml", "a/./x.xml", "-o", "out2"],
        &["would both be written to"],
    );
    // -o naming the scene file itself (a scene saved under an image name).
    write(&d, "scene.png", TINY);
    refused(
        &d,
        &["render", "-q", "scene.png", "-o", "scene.png"],
        &["output scene.png is the scene file scene.png"],
    );
    // -o naming an asset: the envmap, an included file, a texture, through another spelling.
    let env = d.join("sky.exr");
    let mut sky = groove::film::Image::new(4, 2);
    sky.data.iter_mut().for_each(|p| *p = [1.0; 3]);
    groove::output::write_image(&env, &sky, &groove::output::Metadata::default()).unwrap();
    write(
        &d,
        "env.xml",
        &TINY.replace(
            r#"<emitter type="constant"/>"#,
            r#"<emitter type="envmap"><string name="filename" value="sky.exr"/></emitter>"#,
        ),
    );
    refused(
        &d,
        &["render", "-q", "env.xml", "-o", "./sky.exr"],
        &[
            "output ./sky.exr would overwrite",
            "sky.exr, an input of the render",
        ],
    );
    write(
        &d,
        "part.png",
        "<scene version=\"3.0.0\"><shape type=\"sphere\"/></scene>",
    );
    write(
        &d,
        "inc.xml",
        &tiny_with(r#"<include filename="part.png"/>"#),
    );
    refused(
        &d,
        &["render", "-q", "inc.xml", "-o", "part.png"],
        &["would overwrite", "part.png, an input of the render"],
    );
    // In a batch: the second scene's output would replace the first scene's envmap. The
    // first renders, the second is refused before rendering, the envmap stays.
    fs::create_dir_all(d.join("out3")).unwrap();
    fs::copy(&env, d.join("out3/second.exr")).unwrap();
    write(
        &d,
        "first.xml",
        &TINY.replace(
            r#"<emitter type="constant"/>"#,
            r#"<emitter type="envmap"><string name="filename" value="out3/second.exr"/></emitter>"#,
        ),
    );
    write(&d, "second.xml", TINY);
    let before = fs::read(d.join("out3/second.exr")).unwrap();
    let out = Command::new(assert_cmd::cargo::cargo_bin("groove"))
        .current_dir(&d)
        .args(["render", "-q", "first.xml", "second.xml", "-o", "out3"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains(
            "output out3/second.exr would overwrite ./out3/second.exr, an input of the render"
        ),
        "{err}"
    );
    assert_eq!(fs::read(d.join("out3/second.exr")).unwrap(), before);
    assert!(d.join("out3/first.exr").is_file());
    let names: Vec<_> = fs::read_dir(d.join("out3"))
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
}

#[test]
fn loader_errors_are_located_twice() {
    let d = tmpdir("hostile-located");
    // Invalid UTF-8: line and column of the bad byte.
    fs::write(
        d.join("bad8.xml"),
        b"<scene version=\"3.0.0\">\n  <bsdf type=\"diff\xffuse\"/>\n</scene>\n",
    )
    .unwrap();
    refused(
        &d,
        &["render", "-q", "bad8.xml", "-o", "o.exr"],
        &["bad8.xml:2:19: invalid UTF-8 (byte 0xFF at byte offset 42)"],
    );
    // UTF-16 without a byte-order mark, and UTF-16 with one but an unpaired surrogate.
    let utf16: Vec<u8> = TINY.encode_utf16().flat_map(|u| u.to_le_bytes()).collect();
    fs::write(d.join("nobom.xml"), &utf16).unwrap();
    refused(
        &d,
        &["render", "-q", "nobom.xml", "-o", "o.exr"],
        &[
            "nobom.xml:1:2: NUL character",
            "UTF-16 without a byte-order mark",
        ],
    );
    let mut bad16 = vec![0xFF, 0xFE];
    bad16.extend(
        "<scene version=\"3.0.0\">\n <"
            .encode_utf16()
            .flat_map(|u| u.to_le_bytes()),
    );
    bad16.extend_from_slice(&0xD800u16.to_le_bytes());
    fs::write(d.join("bad16.xml"), &bad16).unwrap();
    refused(
        &d,
        &["render", "-q", "bad16.xml", "-o", "o.exr"],
        &["bad16.xml:2:3: invalid UTF-16 (unpaired surrogate 0xD800 at byte offset 54)"],
    );
    // Mesh errors: the <shape> that asked for the file, then the file's own line or offset.
    write(&d, "bad.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 x\n");
    write(
        &d,
        "bad.ply",
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 nope 0\n3 0 1 2\n",
    );
    let mut bin = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nend_header\n".to_vec();
    bin.extend_from_slice(&[0u8; 20]);
    fs::write(d.join("short.ply"), &bin).unwrap();
    for (t, file, inner) in [
        ("obj", "bad.obj", "bad.obj:4:"),
        (
            "ply",
            "bad.ply",
            "line 12 (element `vertex` 2: `nope` is not a number)",
        ),
        ("ply", "short.ply", "byte offset"),
    ] {
        let text = tiny_with(&format!(
            r#"<shape type="{t}"><string name="filename" value="{file}"/></shape>"#
        ));
        write(&d, "mesh.xml", &text);
        let at = line_col(&text, &format!(r#"<shape type="{t}""#));
        refused(
            &d,
            &["render", "-q", "mesh.xml", "-o", "o.exr"],
            &[&format!("mesh.xml:{at}: cannot load mesh '{file}'"), inner],
        );
    }
    // --spp 0 is an error, as sample_count=0 is.
    write(&d, "tiny.xml", TINY);
    refused(
        &d,
        &["render", "-q", "tiny.xml", "--spp", "0", "-o", "o.exr"],
        &["'--spp", "0 is not in 1.."],
    );
}
