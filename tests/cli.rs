//! The `groove render` command as a user meets it: exit codes, error messages with
//! FILE:LINE:COL, batch behaviour, output naming and atomic writes; module `doc_links`: the
//! links of README.md and docs/ resolve inside the repository; module `bench`: `groove bench` on
//! two tiny scenes and its JSON schema; module `split`: split renders
//! (`--crop`, `--tile`, `--samples`, `--time-limit`) merged by `groove merge`, bit for bit; module `slurm` (as root only: a
//! private Slurm): the Slurm recipe end to end; module `renderer`: `--renderer scalar|stream`; module `simd_calls`: no SIMD intrinsic called out of line in the release binary; module `node_loss` (ignored, slow): a node lost
//! under a `--requeue` task.

#[path = "cli/bench.rs"]
mod bench;
#[path = "cli/doc_links.rs"]
mod doc_links;
#[path = "cli/hostile.rs"]
mod hostile;
#[path = "cli/node_loss.rs"]
mod node_loss;
#[path = "cli/renderer.rs"]
mod renderer;
#[path = "common/scratch.rs"]
#[allow(dead_code)]
mod scratch;
#[path = "cli/simd_calls.rs"]
mod simd_calls;
#[path = "cli/slurm.rs"]
mod slurm;
#[path = "cli/split.rs"]
mod split;

use assert_cmd::Command;
use std::fs;
use std::path::{Path, PathBuf};

fn groove() -> Command {
    Command::cargo_bin("groove").expect("binary")
}

fn tmpdir(name: &str) -> crate::scratch::Scratch {
    crate::scratch::Scratch::new(&format!("groove-cli-{}-{name}", std::process::id()))
}

/// A tiny valid scene: a diffuse rectangle under a constant environment.
const TINY: &str = r#"<scene version="3.0.0">
    <default name="spp" value="4"/>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0,0,4" target="0,0,0" up="0,1,0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm"><integer name="width" value="8"/><integer name="height" value="6"/></film>
    </sensor>
    <shape type="rectangle"><bsdf type="diffuse"/></shape>
    <emitter type="constant"/>
</scene>
"#;

fn write(dir: &Path, name: &str, text: &str) -> PathBuf {
    let p = dir.join(name);
    fs::write(&p, text).unwrap();
    p
}

fn stderr_of(out: &std::process::Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// Runs a failing render and returns stderr; asserts a clean failure (no panic).
fn fails(args: &[&str], cwd: &Path) -> String {
    let out = groove().current_dir(cwd).args(args).output().unwrap();
    let err = stderr_of(&out);
    assert!(
        !out.status.success(),
        "expected failure, got success; stderr: {err}"
    );
    assert!(!err.contains("panicked"), "must not panic: {err}");
    err
}

#[test]
fn renders_to_default_name_with_metadata_and_summary() {
    let d = tmpdir("default");
    write(&d, "tiny.xml", TINY);
    let out = groove()
        .current_dir(&d)
        .args(["render", "tiny.xml", "--seed", "3", "-q"])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr_of(&out));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("Msamples/s") && stdout.contains("Mrays/s"),
        "{stdout}"
    );
    let (img, meta) = groove::output::read_exr(&d.join("tiny.exr")).unwrap();
    assert_eq!((img.width, img.height), (8, 6));
    assert_eq!(meta.get("groove.spp"), Some("4"));
    assert_eq!(meta.get("groove.seed"), Some("3"));
    assert!(meta.get("groove.render_time_s").is_some());
    assert!(meta.get("groove.version").is_some());
    assert!(meta.get("groove.scene").unwrap().ends_with("tiny.xml"));
}

#[test]
fn png_output_and_spp_override() {
    let d = tmpdir("png");
    write(&d, "tiny.xml", TINY);
    groove()
        .current_dir(&d)
        .args([
            "render", "tiny.xml", "-o", "out.png", "--spp", "2", "-t", "1",
        ])
        .assert()
        .success();
    let img = image::open(d.join("out.png")).unwrap();
    assert_eq!((img.width(), img.height()), (8, 6));
}

#[test]
fn malformed_xml_reports_file_line_column() {
    let d = tmpdir("malformed");
    write(
        &d,
        "bad.xml",
        "<scene version=\"3.0.0\">\n  <shape type=\"sphere\">\n</scene>\n",
    );
    let err = fails(&["render", "bad.xml"], &d);
    assert!(err.starts_with("error: "), "{err}");
    assert!(
        err.contains("bad.xml:3:"),
        "line of the mismatched tag: {err}"
    );
}

#[test]
fn unknown_plugin_and_unreferenced_property_name_their_place() {
    let d = tmpdir("unknown");
    let s = TINY.replace(r#"<bsdf type="diffuse"/>"#, r#"<bsdf type="velvet"/>"#);
    write(&d, "a.xml", &s);
    let err = fails(&["render", "a.xml"], &d);
    assert!(err.contains("a.xml:9:") && err.contains("velvet"), "{err}");

    let s = TINY.replace(
        r#"<bsdf type="diffuse"/>"#,
        r#"<bsdf type="diffuse"><float name="extEta" value="1.5"/></bsdf>"#,
    );
    write(&d, "b.xml", &s);
    let err = fails(&["render", "b.xml"], &d);
    assert!(err.contains("b.xml:9:") && err.contains("extEta"), "{err}");
    assert!(err.contains("version"), "hint at the 0.6 dialect: {err}");
}

#[test]
fn missing_mesh_and_broken_mesh_are_clear_errors() {
    let d = tmpdir("mesh");
    let s = TINY.replace(
        r#"<shape type="rectangle"><bsdf type="diffuse"/></shape>"#,
        r#"<shape type="obj"><string name="filename" value="nothere.obj"/></shape>"#,
    );
    write(&d, "a.xml", &s);
    let err = fails(&["render", "a.xml"], &d);
    assert!(
        err.contains("a.xml:9:") && err.contains("nothere.obj"),
        "{err}"
    );

    write(&d, "nan.obj", "v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n");
    let s = TINY.replace(
        r#"<shape type="rectangle"><bsdf type="diffuse"/></shape>"#,
        r#"<shape type="obj"><string name="filename" value="nan.obj"/></shape>"#,
    );
    write(&d, "b.xml", &s);
    let err = fails(&["render", "b.xml"], &d);
    assert!(err.contains("nan.obj"), "{err}");
}

#[test]
fn unused_define_is_an_error() {
    let d = tmpdir("define");
    write(&d, "tiny.xml", TINY);
    let err = fails(&["render", "tiny.xml", "-D", "sp=4"], &d);
    assert!(err.contains("sp"), "{err}");
    groove()
        .current_dir(&d)
        .args(["render", "tiny.xml", "-D", "spp=1", "-q"])
        .assert()
        .success();
}

#[test]
fn batch_renders_the_good_scenes_and_fails_at_the_end() {
    let d = tmpdir("batch");
    write(&d, "one.xml", TINY);
    write(&d, "two.xml", "<scene version=\"3.0.0\"><oops/></scene>");
    write(&d, "three.xml", TINY);
    let out = groove()
        .current_dir(&d)
        .args([
            "render",
            "one.xml",
            "two.xml",
            "three.xml",
            "-o",
            "outdir",
            "-q",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = stderr_of(&out);
    assert!(err.contains("two.xml:1:"), "{err}");
    assert!(d.join("outdir/one.exr").is_file());
    assert!(d.join("outdir/three.exr").is_file());
    assert!(!d.join("outdir/two.exr").exists());
}

#[test]
fn a_failed_render_leaves_an_existing_image_untouched_and_no_temp_files() {
    let d = tmpdir("atomic");
    write(&d, "tiny.xml", TINY);
    groove()
        .current_dir(&d)
        .args(["render", "tiny.xml", "-o", "good.exr", "-q"])
        .assert()
        .success();
    let before = fs::read(d.join("good.exr")).unwrap();
    write(&d, "bad.xml", &TINY.replace("rectangle", "torus"));
    fails(&["render", "bad.xml", "-o", "good.exr"], &d);
    assert_eq!(fs::read(d.join("good.exr")).unwrap(), before);
    // An output in a directory that does not exist: error, nothing left behind.
    let err = fails(&["render", "tiny.xml", "-o", "nodir/x.exr"], &d);
    assert!(err.contains("nodir"), "{err}");
    let leftovers: Vec<_> = fs::read_dir(&d)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

#[test]
fn unsupported_output_format_fails_before_rendering() {
    let d = tmpdir("ext");
    write(&d, "tiny.xml", TINY);
    let err = fails(&["render", "tiny.xml", "-o", "x.jpg"], &d);
    assert!(err.contains(".jpg") || err.contains("jpg"), "{err}");
}

/// Start `groove render` on a scene that takes minutes, send `signal` once it runs, and return
/// (exit status, stderr, seconds from the signal to the exit). The process is killed by its
/// PID if it does not stop within 30 s.
fn interrupt_render(
    dir: &Path,
    out: &Path,
    signal: &str,
) -> (std::process::ExitStatus, String, f64) {
    use std::process::Stdio;
    let scene = write(
        dir,
        "slow.xml",
        &TINY.replace("width\" value=\"8", "width\" value=\"256"),
    );
    let mut child = std::process::Command::new(assert_cmd::cargo::cargo_bin("groove"))
        .args(["render", "-q", "-t", "2", "--spp", "4000000"])
        .arg(&scene)
        .arg("-o")
        .arg(out)
        .stderr(Stdio::piped())
        .stdout(Stdio::null())
        .spawn()
        .expect("spawn groove");
    std::thread::sleep(std::time::Duration::from_millis(1500));
    assert!(
        child.try_wait().unwrap().is_none(),
        "the render ended before the signal"
    );
    let sent = std::time::Instant::now();
    let kill = std::process::Command::new("kill")
        .args([signal, &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if sent.elapsed().as_secs() > 30 {
            let _ = child.kill();
            panic!("groove did not stop within 30 s of {signal}");
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    };
    let mut err = String::new();
    use std::io::Read;
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    (status, err, sent.elapsed().as_secs_f64())
}

/// Ctrl-C (SIGINT) and SIGTERM stop a render within seconds with 130 / 143, write nothing,
/// leave an existing output untouched and no temporary file behind.
#[test]
fn sigint_and_sigterm_stop_the_render_and_write_nothing() {
    for (signal, code) in [("-INT", 130), ("-TERM", 143)] {
        let dir = tmpdir(&format!("signal{code}"));
        let out = dir.join("out.exr");
        fs::write(&out, b"a good image").unwrap();
        let (status, err, secs) = interrupt_render(&dir, &out, signal);
        assert_eq!(
            status.code(),
            Some(code),
            "{signal}: {status:?}, stderr: {err}"
        );
        assert!(
            err.contains("interrupted") && err.contains("not written"),
            "{err}"
        );
        assert!(secs < 10.0, "{signal}: took {secs:.1} s to stop");
        assert_eq!(fs::read(&out).unwrap(), b"a good image");
        let names: Vec<_> = fs::read_dir(&dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        let mut expected = vec!["out.exr".to_string(), "slow.xml".to_string()];
        let mut names_sorted = names.clone();
        names_sorted.sort();
        expected.sort();
        assert_eq!(names_sorted, expected, "{signal}: files left: {names:?}");
    }
}
