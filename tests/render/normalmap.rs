//! Classic `normalmap` at render level against Mitsuba 3.9.1 references (both flag settings), and
//! the `--normal-mapping classic|microfacet` switch (decision 6) through `load_scene` and the CLI.

use crate::common;

use common::{compare, load_reference, read_exr_rgb, render_scene, repo_root, test_scene};
use groove::load::load_scene;
use groove::load::options::{LoadOptions, NormalMapping};
use groove::material::MaterialNode;
use std::path::Path;

const PLAIN: [(&str, &str); 2] = [("flip", "false"), ("shadow", "false")];

#[test]
fn normalmap_with_mitsuba_defaults_matches_mitsuba() {
    let r = render_scene(&test_scene("nmap_plane.xml"), &[], 512, 31, 0, |_| {});
    let (m, v) = load_reference("nmap_plane");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("nmap_plane: {}", c.report());
    c.assert_consistent("nmap_plane.xml, 512 spp");
}

#[test]
fn plain_normalmap_matches_mitsuba_and_differs_from_the_default() {
    let r = render_scene(&test_scene("nmap_plane.xml"), &PLAIN, 512, 32, 0, |_| {});
    let (m, v) = load_reference("nmap_plane_plain");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("nmap_plane_plain: {}", c.report());
    c.assert_consistent("nmap_plane.xml flip=shadow=false, 512 spp");
    // Sensitivity: the flags change the image by more than the test's noise.
    let (m, v) = load_reference("nmap_plane");
    let c = compare(&r.mean, &r.var, &m, &v, 4);
    eprintln!("plain vs default reference: {}", c.report());
    assert!(!c.is_consistent(), "the flags made no visible difference");
}

fn load(path: &Path, mode: NormalMapping, defines: &[(&str, &str)]) -> Vec<MaterialNode> {
    let opts = LoadOptions {
        defines: defines
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
        normal_mapping: mode,
        ..Default::default()
    };
    load_scene(path, &opts)
        .expect("scene")
        .scene
        .materials()
        .nodes()
        .to_vec()
}

fn classic_flags(nodes: &[MaterialNode]) -> Vec<(bool, bool)> {
    nodes
        .iter()
        .filter_map(|n| match n {
            MaterialNode::NormalMap {
                flip_invalid_normals,
                use_shadowing_function,
                ..
            } => Some((*flip_invalid_normals, *use_shadowing_function)),
            _ => None,
        })
        .collect()
}

fn microfacet_count(nodes: &[MaterialNode]) -> usize {
    nodes
        .iter()
        .filter(|n| matches!(n, MaterialNode::MicrofacetNormalMap { .. }))
        .count()
}

#[test]
fn normal_mapping_switch_converts_at_load() {
    let nmap = test_scene("nmap_plane.xml");
    // As written: two classic normal maps with Mitsuba's defaults.
    let n = load(&nmap, NormalMapping::AsWritten, &[]);
    assert_eq!(classic_flags(&n), vec![(true, true); 2]);
    assert_eq!(microfacet_count(&n), 0);
    // Classic: the plain model whatever the file says.
    let n = load(&nmap, NormalMapping::Classic, &[]);
    assert_eq!(classic_flags(&n), vec![(false, false); 2]);
    // Microfacet: every normalmap becomes a microfacet_normalmap (same texture and nested BSDF).
    let n = load(&nmap, NormalMapping::Microfacet, &[]);
    assert!(classic_flags(&n).is_empty());
    assert_eq!(microfacet_count(&n), 2);
    match n
        .iter()
        .find(|n| matches!(n, MaterialNode::MicrofacetNormalMap { .. }))
    {
        Some(MaterialNode::MicrofacetNormalMap {
            nested, settings, ..
        }) => {
            assert!(matches!(n[*nested as usize], MaterialNode::Diffuse { .. }));
            assert_eq!(settings.max_order, 256);
            assert!((settings.max_theta.radians() - 85f32.to_radians()).abs() < 1e-6);
        }
        _ => unreachable!(),
    }
    // A microfacet_normalmap scene under `classic`: the plain normalmap over the same nested BSDF.
    let mnm = test_scene("mnm_furnace.xml");
    let n = load(&mnm, NormalMapping::AsWritten, &[]);
    assert_eq!(microfacet_count(&n), 1);
    let n = load(&mnm, NormalMapping::Classic, &[]);
    assert_eq!(microfacet_count(&n), 0);
    assert_eq!(classic_flags(&n), vec![(false, false)]);
    assert_eq!(
        microfacet_count(&load(&mnm, NormalMapping::Microfacet, &[])),
        1
    );
}

#[test]
fn documents_upgraded_from_0_6_get_the_plain_normalmap() {
    let dir = crate::common::Scratch::new(&format!("groove-nmap-{}", std::process::id()));
    let tex = repo_root().join("tests/data/textures/nmap_bumps.exr");
    let scene = |version: &str| {
        format!(
            r#"<scene version="{version}">
    <sensor type="perspective">
        <film type="hdrfilm">
            <integer name="width" value="8"/>
            <integer name="height" value="8"/>
        </film>
    </sensor>
    <shape type="sphere">
        <bsdf type="normalmap">
            <texture type="bitmap" name="normalmap">
                <string name="filename" value="{}"/>
                <boolean name="raw" value="true"/>
            </texture>
            <bsdf type="diffuse"/>
        </bsdf>
    </shape>
</scene>"#,
            tex.display()
        )
    };
    for (version, flags) in [("0.6.0", (false, false)), ("3.0.0", (true, true))] {
        let path = dir.join(format!("v{version}.xml"));
        std::fs::write(&path, scene(version)).unwrap();
        let n = load(&path, NormalMapping::AsWritten, &[]);
        assert_eq!(classic_flags(&n), vec![flags], "version {version}");
    }
}

/// `groove ARGS`; a render on the render tests' loop ([`crate::common::renderer`]).
fn groove(args: &[&str]) -> std::process::Output {
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_groove"));
    cmd.args(args);
    if args.first() == Some(&"render") {
        cmd.args(["--renderer", crate::common::renderer().name()]);
    }
    cmd.output().expect("run groove")
}

#[test]
fn cli_normal_mapping_flag() {
    let dir = crate::common::Scratch::new(&format!("groove-nmap-cli-{}", std::process::id()));
    let scene = test_scene("nmap_plane.xml");
    let scene = scene.to_str().unwrap();
    let out = |name: &str| dir.join(name).to_str().unwrap().to_string();
    let common = ["--spp", "16", "--seed", "7", "-t", "1", "-q"];
    let run = |extra: &[&str], o: &str| {
        let mut args = vec!["render", scene, "-o", o];
        args.extend_from_slice(&common);
        args.extend_from_slice(extra);
        let r = groove(&args);
        assert!(
            r.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&r.stderr)
        );
        read_exr_rgb(Path::new(o))
    };
    // `classic` renders exactly the file with both flags switched off.
    let classic = run(&["--normal-mapping", "classic"], &out("classic.exr"));
    let plain = run(
        &["-D", "flip=false", "-D", "shadow=false"],
        &out("plain.exr"),
    );
    assert_eq!(classic.data, plain.data);
    let default = run(&[], &out("default.exr"));
    assert_ne!(classic.data, default.data);
    let micro = run(&["--normal-mapping", "microfacet"], &out("micro.exr"));
    assert_ne!(micro.data, default.data);
    assert!(micro.data.iter().all(|p| p.iter().all(|c| c.is_finite())));
    // A bad value is a usage error naming the choices.
    let r = groove(&["render", scene, "--normal-mapping", "bumpy"]);
    assert!(!r.status.success());
    let err = String::from_utf8_lossy(&r.stderr);
    assert!(
        err.contains("classic") && err.contains("microfacet"),
        "{err}"
    );
}
