//! `--renderer scalar|stream`: the two render loops write the same image, the stream renderer
//! refuses integrators other than `path` with a clear error, and an unknown loop is refused
//! before anything renders.

use assert_cmd::Command;
use std::fs;
use std::path::PathBuf;

fn groove() -> Command {
    Command::cargo_bin("groove").expect("binary")
}

fn tmpdir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("groove-renderer-{}-{name}", std::process::id()));
    let _ = fs::remove_dir_all(&d);
    fs::create_dir_all(&d).unwrap();
    d
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
    assert!(err.contains("expected one of scalar, stream"), "{err}");
}
