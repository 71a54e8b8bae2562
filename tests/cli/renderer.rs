//! `--renderer auto|scalar|stream`: the two render loops write the same image, the stream renderer
//! refuses integrators other than `path` with a clear error, `auto` (the default) runs the stream
//! renderer where it can and the scalar one elsewhere and says which ran, an unknown loop is
//! refused before anything renders, and `groove bench --renderer scalar,stream` records both.

use assert_cmd::Command;
use std::fs;
use std::path::Path;

fn groove() -> Command {
    Command::cargo_bin("groove").expect("binary")
}

fn tmpdir(name: &str) -> crate::scratch::Scratch {
    crate::scratch::Scratch::new(&format!("groove-renderer-{}-{name}", std::process::id()))
}

/// A small scene with the given integrator: a diffuse sphere on a rectangle, an area light.
fn scene(integrator: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <integrator type="{integrator}"/>
    <sensor type="perspective">
        <transform name="to_world"><lookat origin="0,1,5" target="0,0,0" up="0,1,0"/></transform>
        <sampler type="independent"><integer name="sample_count" value="4"/></sampler>
        <film type="hdrfilm"><integer name="width" value="24"/><integer name="height" value="16"/></film>
    </sensor>
    <shape type="sphere"><bsdf type="diffuse"/></shape>
    <shape type="rectangle"><transform name="to_world"><scale value="4"/><rotate x="1" angle="-90"/><translate y="-1"/></transform></shape>
    <shape type="rectangle"><transform name="to_world"><rotate x="1" angle="90"/><translate y="3"/></transform>
        <emitter type="area"><rgb name="radiance" value="8"/></emitter></shape>
</scene>
"#
    )
}

#[test]
fn scalar_and_stream_write_the_same_image() {
    let d = tmpdir("same");
    fs::write(d.join("s.xml"), scene("path")).unwrap();
    for r in ["scalar", "stream"] {
        let out = groove()
            .current_dir(&d)
            .args(["render", "s.xml", "-q", "-t", "3", "--renderer", r])
            .args(["-o", &format!("{r}.png")])
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let (a, b) = (
        fs::read(d.join("scalar.png")).unwrap(),
        fs::read(d.join("stream.png")).unwrap(),
    );
    assert!(a == b, "the stream renderer wrote another image");
}

#[test]
fn the_stream_renderer_refuses_the_volpath_integrator() {
    let d = tmpdir("volpath");
    fs::write(d.join("d.xml"), scene("volpath")).unwrap();
    let out = groove()
        .current_dir(&d)
        .args(["render", "d.xml", "-q", "--renderer", "stream"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "rendered: {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(
        err.contains("path and direct integrators only") && err.contains("volpath"),
        "{err}"
    );
    assert!(!d.join("d.exr").exists());
    let out = groove()
        .current_dir(&d)
        .args(["render", "d.xml", "-q", "--renderer", "wide"])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(
        err.contains("expected one of auto, scalar, stream"),
        "{err}"
    );
}

/// A scene with a medium-free `volpath` integrator: one the stream renderer does not run.
const OTHER: &str = "volpath";

/// `groove ARGS` in `d`, which must succeed; its stdout.
fn run_ok(d: &Path, args: &[&str]) -> String {
    let out = groove().current_dir(d).args(args).output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "groove {args:?}: {err}");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn read_json(p: &Path) -> serde_json::Value {
    serde_json::from_slice(&fs::read(p).unwrap()).unwrap()
}

/// The string `key` of every element of the array `v[list]`.
fn strings<'a>(v: &'a serde_json::Value, list: &str, key: &str) -> Vec<&'a str> {
    let a = v[list]
        .as_array()
        .unwrap_or_else(|| panic!("no {list}: {v}"));
    a.iter().map(|r| r[key].as_str().unwrap()).collect()
}

#[test]
fn auto_is_the_default_and_says_which_renderer_ran() {
    let d = tmpdir("auto");
    fs::write(d.join("p.xml"), scene("path")).unwrap();
    fs::write(d.join("v.xml"), scene(OTHER)).unwrap();
    let both = ["render", "p.xml", "v.xml", "-q", "-t", "2", "-o", "out"];
    // Default and explicit `auto`: the stream on `path`, the scalar renderer on the other.
    for extra in [&[][..], &["--renderer", "auto"][..]] {
        let stdout = run_ok(&d, &[&both[..], extra, &["--json", "r.json"]].concat());
        let v = read_json(&d.join("r.json"));
        assert_eq!(
            strings(&v, "renders", "renderer"),
            ["stream", "scalar"],
            "{v}"
        );
        assert!(stdout.contains("2 threads, stream renderer"), "{stdout}");
        assert!(stdout.contains("2 threads, scalar renderer"), "{stdout}");
    }
    // `auto` writes the image `scalar` writes, bit for bit.
    run_ok(
        &d,
        &[
            "render",
            "p.xml",
            "-q",
            "-t",
            "3",
            "--renderer",
            "scalar",
            "-o",
            "s.png",
        ],
    );
    run_ok(&d, &["render", "p.xml", "-q", "-t", "1", "-o", "a.png"]);
    assert!(
        fs::read(d.join("s.png")).unwrap() == fs::read(d.join("a.png")).unwrap(),
        "auto wrote another image"
    );
}

#[test]
fn bench_times_both_renderers() {
    let d = tmpdir("bench");
    fs::write(d.join("p.xml"), scene("path")).unwrap();
    run_ok(
        &d,
        &[
            "bench",
            "p.xml",
            "--renderer",
            "scalar,stream",
            "--modes",
            "classic",
            "--spp",
            "1",
            "--repeat",
            "2",
            "-t",
            "2",
            "--peer",
            "off",
            "--no-ceiling",
            "--ref-spp",
            "0",
            "-q",
            "--json",
            "b.json",
            "--md",
            "b.md",
            "--plot",
            "b.png",
        ],
    );
    let v = read_json(&d.join("b.json"));
    assert_eq!(v["renderers"], serde_json::json!(["scalar", "stream"]));
    // Both renderers' records, interleaved, and the stream's with its lane fractions.
    assert_eq!(
        strings(&v, "records", "renderer"),
        ["scalar", "stream", "scalar", "stream"]
    );
    let recs = v["records"].as_array().unwrap();
    for (i, r) in recs.iter().enumerate() {
        assert_eq!(r["repeat"], i / 2, "{r}");
        assert_eq!(r["samples"], 24 * 16);
        assert_eq!(
            r["active_lanes"].is_null(),
            r["renderer"] == "scalar",
            "{r}"
        );
    }
    // The two renderers trace the same rays (the same paths, bit for bit).
    assert_eq!(recs[0]["rays"], recs[1]["rays"]);
    assert_eq!(strings(&v, "summaries", "renderer"), ["scalar", "stream"]);
    for s in v["summaries"].as_array().unwrap() {
        assert_eq!(s["status"], "ok");
        assert_eq!(s["ratio_to_classic"], 1.0, "{s}");
    }
    let md = fs::read_to_string(d.join("b.md")).unwrap();
    assert!(
        md.contains("| classic | scalar |") && md.contains("| classic | stream |"),
        "{md}"
    );
    assert!(md.contains("renderer scalar, stream"), "{md}");
}
