//! Split renders (`--crop`, `--tile`, `--samples`, `--time-limit`) merged by `groove merge`
//! equal the single render bit for bit; merge refuses parts that do not fit together and then
//! writes nothing; the batch niceties (`--json`, SIGUSR1, SIGINT).

use super::{groove, stderr_of, tmpdir, write};
use std::path::Path;

/// An odd-sized film (37×29: tiles never align with the 32-pixel blocks) with the filter and
/// sampler as parameters; a sphere and a diffuse floor lit by an environment and a point light.
const SCENE: &str = r#"<scene version="3.0.0">
    <default name="filter" value="gaussian"/>
    <default name="sampler" value="independent"/>
    <default name="spp" value="6"/>
    <sensor type="perspective">
        <float name="fov" value="40"/>
        <transform name="to_world"><lookat origin="0,1,4" target="0,0,0" up="0,1,0"/></transform>
        <sampler type="$sampler"><integer name="sample_count" value="$spp"/></sampler>
        <film type="hdrfilm"><integer name="width" value="37"/><integer name="height" value="29"/>
            <rfilter type="$filter"/></film>
    </sensor>
    <shape type="sphere"><float name="radius" value="0.7"/><bsdf type="roughconductor"/></shape>
    <shape type="rectangle">
        <transform name="to_world"><rotate x="1" angle="-90"/><scale value="3"/><translate y="-0.7"/></transform>
        <bsdf type="diffuse"/>
    </shape>
    <emitter type="constant"><rgb name="radiance" value="0.4"/></emitter>
    <emitter type="point"><point name="position" x="1" y="2" z="1"/><rgb name="intensity" value="6"/></emitter>
</scene>
"#;

/// Runs groove in `dir` and asserts success.
fn ok(dir: &Path, args: &[&str]) {
    let out = groove().current_dir(dir).args(args).output().unwrap();
    assert!(out.status.success(), "{args:?}: {}", stderr_of(&out));
}

/// Runs groove in `dir`, asserts a clean failure and returns stderr.
fn refused(dir: &Path, args: &[&str]) -> String {
    let out = groove().current_dir(dir).args(args).output().unwrap();
    let err = stderr_of(&out);
    assert!(!out.status.success(), "{args:?} should fail");
    assert!(!err.contains("panicked"), "{err}");
    err
}

/// Every channel of an EXR, as bits.
fn bits(p: &Path) -> (u32, u32, Vec<(String, Vec<u32>)>) {
    let (w, h, ch) = groove::output::read_exr_channels(p).unwrap();
    let ch = ch
        .into_iter()
        .map(|(n, v)| (n, v.iter().map(|x| x.to_bits()).collect()))
        .collect();
    (w, h, ch)
}

fn assert_same_bits(a: &Path, b: &Path) {
    let (x, y) = (bits(a), bits(b));
    assert_eq!(
        (x.0, x.1),
        (y.0, y.1),
        "{} vs {}: size",
        a.display(),
        b.display()
    );
    assert_eq!(x.2.len(), y.2.len());
    for ((na, va), (nb, vb)) in x.2.iter().zip(&y.2) {
        assert_eq!(na, nb);
        let diff = va.iter().zip(vb).filter(|(p, q)| p != q).count();
        assert_eq!(
            diff,
            0,
            "{} vs {}: channel {na} differs in {diff} pixels",
            a.display(),
            b.display()
        );
    }
}

fn setup(name: &str) -> crate::scratch::Scratch {
    let d = tmpdir(name);
    write(&d, "s.xml", SCENE);
    d
}

/// Leftover temporary files of atomic writes in `d`.
fn temp_files(d: &Path) -> Vec<String> {
    std::fs::read_dir(d)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".tmp-"))
        .collect()
}

#[test]
fn crop_tiles_merge_to_the_full_render_for_every_filter() {
    let d = setup("split-crops");
    for filter in ["box", "tent", "gaussian"] {
        let f = format!("filter={filter}");
        let full = format!("full-{filter}.exr");
        ok(
            &d,
            &["render", "s.xml", "-q", "-t", "2", "-D", &f, "-o", &full],
        );
        // Crops cut at odd places, not on block edges.
        let crops = ["0,0,13,11", "13,0,24,11", "0,11,20,18", "20,11,17,18"];
        let mut parts = Vec::new();
        for (k, c) in crops.iter().enumerate() {
            let p = format!("c{k}-{filter}.exr");
            ok(
                &d,
                &[
                    "render", "s.xml", "-q", "-t", "1", "-D", &f, "--crop", c, "-o", &p,
                ],
            );
            parts.push(p);
        }
        let merged = format!("merged-{filter}.exr");
        let mut args = vec!["merge", "-q", merged.as_str()];
        args.extend(parts.iter().map(|s| s.as_str()));
        ok(&d, &args);
        assert_same_bits(&d.join(&merged), &d.join(&full));
        // --tile: strips of 29 rows in 4 (7, 7, 7, 8 rows).
        let mut tiles = Vec::new();
        for i in 0..4 {
            let p = format!("t{i}-{filter}.exr");
            let t = format!("{i}/4");
            ok(
                &d,
                &[
                    "render", "s.xml", "-q", "-t", "3", "-D", &f, "--tile", &t, "-o", &p,
                ],
            );
            tiles.push(p);
        }
        let merged = format!("tiles-{filter}.exr");
        let mut args = vec!["merge", "-q", merged.as_str()];
        args.extend(tiles.iter().rev().map(|s| s.as_str()));
        ok(&d, &args);
        assert_same_bits(&d.join(&merged), &d.join(&full));
    }
}

#[test]
fn sample_ranges_and_a_crop_by_range_grid_merge_to_the_full_render() {
    let d = setup("split-samples");
    for (sampler, spp, cut) in [("independent", "6", 2), ("stratified", "9", 4)] {
        let defs = [format!("sampler={sampler}"), format!("spp={spp}")];
        let full = format!("full-{sampler}.exr");
        let base = ["render", "s.xml", "-q", "-D", &defs[0], "-D", &defs[1]];
        let run = |extra: &[&str]| {
            let mut a: Vec<&str> = base.to_vec();
            a.extend(extra);
            ok(&d, &a);
        };
        run(&["-t", "1", "-o", &full]);
        let a = format!("0..{cut}");
        let b = format!("{cut}..{spp}");
        run(&["--samples", &a, "-o", "a.exr"]);
        run(&["--samples", &b, "-o", "b.exr"]);
        ok(&d, &["merge", "-q", "ab.exr", "b.exr", "a.exr"]);
        assert_same_bits(&d.join("ab.exr"), &d.join(&full));
        // The same parts merged again, named in the other order: the same file, byte for byte
        // (the header's attributes are written sorted by name).
        ok(&d, &["merge", "-q", "ba.exr", "a.exr", "b.exr"]);
        let bytes = |n: &str| std::fs::read(d.join(n)).unwrap();
        assert!(bytes("ab.exr") == bytes("ba.exr"), "two merges differ");
        // 2 crops × 3 sample ranges.
        let ranges = ["0..1".to_string(), format!("1..{cut}"), b.clone()];
        let mut parts = Vec::new();
        for (i, c) in ["0,0,37,14", "0,14,37,15"].iter().enumerate() {
            for (j, r) in ranges.iter().enumerate() {
                let p = format!("g{i}{j}.exr");
                run(&["--crop", c, "--samples", r, "-o", &p]);
                parts.push(p);
            }
        }
        let mut args = vec!["merge", "-q", "grid.exr"];
        args.extend(parts.iter().map(|s| s.as_str()));
        ok(&d, &args);
        assert_same_bits(&d.join("grid.exr"), &d.join(&full));
    }
}

#[test]
fn same_bits_at_1_2_3_threads_and_any_block_size() {
    let d = setup("split-threads");
    let scene = d.join("s.xml");
    let load = groove::load::options::LoadOptions {
        defines: vec![("filter".into(), "gaussian".into())],
        ..Default::default()
    };
    let loaded = groove::load::load_scene(&scene, &load).unwrap();
    let mut first: Option<groove::film::Image> = None;
    for (threads, block) in [(1, 32), (2, 16), (3, 7), (2, 5)] {
        let opts = groove::render::RenderOptions {
            threads,
            block_size: block,
            ..Default::default()
        };
        let img = groove::render::render(&loaded.scene, &loaded.settings, &opts)
            .unwrap()
            .film
            .develop();
        let b: Vec<u32> = img.data.iter().flatten().map(|x| x.to_bits()).collect();
        match &first {
            None => first = Some(img),
            Some(f) => {
                let a: Vec<u32> = f.data.iter().flatten().map(|x| x.to_bits()).collect();
                assert_eq!(a, b, "{threads} threads, blocks of {block}");
            }
        }
    }
}

#[test]
fn merge_refuses_parts_that_do_not_fit_and_writes_nothing() {
    let d = setup("split-refuse");
    let r = |args: &[&str]| {
        let mut a = vec!["render", "s.xml", "-q"];
        a.extend(args);
        ok(&d, &a);
    };
    r(&["--samples", "0..3", "-o", "a.exr"]);
    r(&["--samples", "3..6", "-o", "b.exr"]);
    r(&["--samples", "2..6", "-o", "b2.exr"]);
    r(&["--samples", "3..6", "--seed", "9", "-o", "seed.exr"]);
    r(&["--samples", "3..6", "-D", "filter=tent", "-o", "tent.exr"]);
    r(&["--samples", "3..6", "--spp", "8", "-o", "spp.exr"]);
    r(&["--crop", "0,0,37,10", "-o", "top.exr"]);
    r(&["--crop", "0,20,37,9", "-o", "bottom.exr"]);
    r(&["-o", "plain.exr"]);
    write(&d, "other.xml", &SCENE.replace("0.7", "0.6"));
    ok(
        &d,
        &[
            "render",
            "other.xml",
            "-q",
            "--samples",
            "3..6",
            "-o",
            "other.exr",
        ],
    );
    let cases: [(&[&str], &str); 9] = [
        (&["a.exr", "b2.exr"], "both render samples 2..3"),
        (&["a.exr", "seed.exr"], "groove.seed: 0 vs 9"),
        (&["a.exr", "tent.exr"], "groove.defines"),
        (&["a.exr", "spp.exr"], "groove.sample_count: 6 vs 8"),
        (&["a.exr", "other.exr"], "groove.scene_hash"),
        (
            &["a.exr"],
            "samples 3..6 of pixels x 0..37, y 0..29 are in no part",
        ),
        (
            &["top.exr", "bottom.exr"],
            "samples 0..6 of pixels x 0..37, y 10..20 are in no part",
        ),
        (&["a.exr", "plain.exr"], "not a groove part"),
        (&["a.exr", "b.exr", "a.exr"], "given twice"),
    ];
    for (parts, msg) in cases {
        let mut args = vec!["merge", "out.exr"];
        args.extend(parts);
        let err = refused(&d, &args);
        assert!(err.contains(msg), "{parts:?}: expected '{msg}' in: {err}");
        assert!(
            err.contains("nothing was written") || msg == "not a groove part",
            "{err}"
        );
        assert!(!d.join("out.exr").exists(), "{parts:?} wrote an output");
    }
    let err = refused(&d, &["merge", "a.exr", "a.exr", "b.exr"]);
    assert!(err.contains("input"), "{err}");
    assert!(temp_files(&d).is_empty(), "{:?}", temp_files(&d));
    // --allow-missing merges what there is and names the gap.
    let out = groove()
        .current_dir(&d)
        .args([
            "merge",
            "--allow-missing",
            "gap.png",
            "top.exr",
            "bottom.exr",
        ])
        .output()
        .unwrap();
    assert!(out.status.success(), "{}", stderr_of(&out));
    assert!(stderr_of(&out).contains("y 10..20 are in no part"));
    assert!(d.join("gap.png").exists());
    // A part must be an EXR.
    let err = refused(
        &d,
        &["render", "s.xml", "-q", "--tile", "0/2", "-o", "p.png"],
    );
    assert!(err.contains("a part"), "{err}");
    let err = refused(
        &d,
        &["render", "s.xml", "-q", "--crop", "30,0,8,5", "-o", "p.exr"],
    );
    assert!(err.contains("does not lie inside"), "{err}");
    let err = refused(
        &d,
        &["render", "s.xml", "-q", "--samples", "3..7", "-o", "p.exr"],
    );
    assert!(err.contains("beyond the 6 samples"), "{err}");
}

#[test]
fn a_part_says_what_it_is() {
    let d = setup("split-meta");
    ok(
        &d,
        &[
            "render",
            "s.xml",
            "-q",
            "--crop",
            "3,4,10,7",
            "--samples",
            "1..5",
            "-D",
            "spp=6",
            "-o",
            "p.exr",
        ],
    );
    let (w, h, chans) = groove::output::read_exr_channels(&d.join("p.exr")).unwrap();
    assert_eq!((w, h), (10, 7));
    let names: Vec<&str> = chans.iter().map(|c| c.0.as_str()).collect();
    for n in ["R", "G", "B", "W", "sum.R.0", "sum.W.3", "sum.flags"] {
        assert!(names.contains(&n), "{n} not in {names:?}");
    }
    let part = groove::output::part::read_part(&d.join("p.exr"), &Default::default()).unwrap();
    assert_eq!(part.film, (37, 29));
    assert_eq!(part.crop, (3, 4, 10, 7));
    assert_eq!(part.samples, (1, 5));
    assert_eq!(part.meta.get("groove.sample_count"), Some("6"));
    assert_eq!(part.meta.get("groove.defines"), Some(r#"[["spp","6"]]"#));
    assert_eq!(part.meta.get("groove.version"), Some(groove::VERSION));
    assert_eq!(part.meta.get("groove.scene_hash").map(str::len), Some(16));
}

#[test]
fn a_time_limited_part_continues_and_merges_to_the_full_render() {
    let d = setup("split-time");
    ok(&d, &["render", "s.xml", "-q", "-o", "full.exr"]);
    // A zero time limit stops after the first pass: one sample per pixel.
    ok(
        &d,
        &[
            "render",
            "s.xml",
            "-q",
            "--part",
            "--time-limit",
            "0",
            "--json",
            "r.json",
            "-o",
            "first.exr",
        ],
    );
    let part = groove::output::part::read_part(&d.join("first.exr"), &Default::default()).unwrap();
    assert_eq!(part.samples, (0, 1));
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("r.json")).unwrap()).unwrap();
    let r = &j["renders"][0];
    assert_eq!(r["samples"], serde_json::json!([0, 1]));
    assert_eq!(r["stopped_early"], true);
    assert!(r["rays"].as_u64().unwrap() > 0);
    assert!(r["render_seconds"].as_f64().is_some());
    assert_eq!(r["output"], "first.exr");
    assert!(r["warnings"][0].as_str().unwrap().contains("time limit"));
    assert_eq!(j["summary"]["rendered"], 1);
    ok(
        &d,
        &[
            "render",
            "s.xml",
            "-q",
            "--samples",
            "1..6",
            "-o",
            "rest.exr",
        ],
    );
    ok(&d, &["merge", "-q", "m.exr", "first.exr", "rest.exr"]);
    assert_same_bits(&d.join("m.exr"), &d.join("full.exr"));
}

#[test]
fn json_records_every_scene_of_a_batch() {
    let d = setup("split-json");
    write(
        &d,
        "bad.xml",
        "<scene version=\"3.0.0\"><shape type=\"nope\"/></scene>",
    );
    let out = groove()
        .current_dir(&d)
        .args([
            "render",
            "s.xml",
            "bad.xml",
            "-q",
            "-o",
            "out",
            "--json",
            "batch.json",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let j: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("batch.json")).unwrap()).unwrap();
    assert_eq!(j["summary"]["scenes"], 2);
    assert_eq!(j["summary"]["failed"], 1);
    assert_eq!(j["renders"][0]["spp"], 6);
    assert!(j["renders"][1]["error"]
        .as_str()
        .unwrap()
        .contains("bad.xml"));
}

#[cfg(unix)]
#[test]
fn sigusr1_writes_the_current_image_and_sigint_stops_cleanly() {
    let d = setup("split-signals");
    let mut child = std::process::Command::new(assert_cmd::cargo::cargo_bin("groove"))
        .current_dir(&d)
        .args([
            "render",
            "s.xml",
            "-q",
            "-t",
            "1",
            "-D",
            "spp=100000",
            "-o",
            "snap.exr",
        ])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let pid = child.id().to_string();
    let kill = |sig: &str| {
        let st = std::process::Command::new("kill")
            .args([sig, &pid])
            .status()
            .unwrap();
        assert!(st.success());
    };
    // Wait (bounded) until the process catches SIGUSR1 (its default action would kill it):
    // bit 9 of SigCgt in /proc/PID/status.
    let t0 = std::time::Instant::now();
    let catches_usr1 = || {
        std::fs::read_to_string(format!("/proc/{pid}/status"))
            .ok()
            .and_then(|s| {
                let l = s.lines().find(|l| l.starts_with("SigCgt:"))?;
                u64::from_str_radix(l[7..].trim(), 16).ok()
            })
            .is_some_and(|m| m & (1 << 9) != 0)
    };
    while !catches_usr1() {
        assert!(t0.elapsed().as_secs() < 60, "SIGUSR1 not caught after 60 s");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    // Ask for a snapshot until one appears.
    while !d.join("snap.exr").exists() {
        assert!(t0.elapsed().as_secs() < 60, "no snapshot after 60 s");
        std::thread::sleep(std::time::Duration::from_millis(300));
        kill("-USR1");
    }
    let (img, meta) = groove::output::read_exr(&d.join("snap.exr")).unwrap();
    assert_eq!((img.width, img.height), (37, 29));
    assert_eq!(meta.get("groove.snapshot"), Some("1"));
    assert!(child.try_wait().unwrap().is_none(), "the render went on");
    kill("-INT");
    let t1 = std::time::Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        assert!(
            t1.elapsed().as_secs() < 60,
            "SIGINT did not stop the render"
        );
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    assert_eq!(status.code(), Some(130));
    assert!(temp_files(&d).is_empty(), "{:?}", temp_files(&d));
}

#[test]
fn parts_carry_the_extra_channels_exactly() {
    let d = tmpdir("split-aov");
    let aov = SCENE.replace(
        "    <sensor",
        r#"    <integrator type="aov">
        <string name="aovs" value="dd.y:depth,nn:sh_normal"/>
        <integrator type="path" name="img"/>
    </integrator>
    <sensor"#,
    );
    write(&d, "s.xml", &aov);
    ok(&d, &["render", "s.xml", "-q", "-o", "full.exr"]);
    ok(
        &d,
        &[
            "render",
            "s.xml",
            "-q",
            "--tile",
            "0/2",
            "--samples",
            "0..4",
            "-o",
            "a.exr",
        ],
    );
    ok(
        &d,
        &[
            "render",
            "s.xml",
            "-q",
            "--tile",
            "0/2",
            "--samples",
            "4..6",
            "-o",
            "b.exr",
        ],
    );
    ok(
        &d,
        &["render", "s.xml", "-q", "--tile", "1/2", "-o", "c.exr"],
    );
    ok(&d, &["merge", "-q", "m.exr", "a.exr", "b.exr", "c.exr"]);
    let (_, _, chans) = groove::output::read_exr_channels(&d.join("m.exr")).unwrap();
    assert!(
        chans.iter().any(|c| c.0 == "dd.y.T"),
        "{:?}",
        chans.iter().map(|c| &c.0).collect::<Vec<_>>()
    );
    assert_same_bits(&d.join("m.exr"), &d.join("full.exr"));
}
