//! `groove bench` as a user runs it: on two tiny benchmark scenes at 1 spp it writes JSON with
//! the documented schema (one record per scene × mode × repeat), Markdown and a PNG chart, skips
//! a mode that cannot apply with its reason, and rejects bad arguments before rendering.

use assert_cmd::Command;
use serde_json::Value;
use std::fs;
use std::path::{Path, PathBuf};

fn groove() -> Command {
    Command::cargo_bin("groove").expect("binary")
}

fn tmpdir(name: &str) -> crate::scratch::Scratch {
    crate::scratch::Scratch::new(&format!("groove-bench-{}-{name}", std::process::id()))
}

fn scene(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes/bench")
        .join(name)
}

use groove::bench::MODES;

fn num(v: &Value, k: &str) -> f64 {
    v[k].as_f64()
        .unwrap_or_else(|| panic!("'{k}' is not a number in {v}"))
}

#[test]
fn bench_writes_json_markdown_and_chart_with_the_documented_schema() {
    let d = tmpdir("schema");
    let (json, md, png, imgs) = (
        d.join("b.json"),
        d.join("b.md"),
        d.join("b.png"),
        d.join("images"),
    );
    let out = groove()
        .arg("bench")
        .arg(scene("metal_plastic.xml"))
        .arg(scene("glass.xml"))
        .args([
            "-D",
            "res=24",
            "-D",
            "height=16",
            "--spp",
            "1",
            "--repeat",
            "2",
        ])
        .args(["--ref-spp", "2", "--peer", "off", "-t", "2", "-q"])
        .arg("--ref-dir")
        .arg(d.join("refs"))
        .arg("--json")
        .arg(&json)
        .arg("--md")
        .arg(&md)
        .arg("--plot")
        .arg(&png)
        .arg("--images")
        .arg(&imgs)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "bench failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: Value = serde_json::from_slice(&fs::read(&json).unwrap()).unwrap();
    assert_eq!(v["spp"], 1);
    assert_eq!(v["repeat"], 2);
    assert_eq!(v["threads"], 2);
    assert!(v["groove_version"].is_string() && v["cpu"].is_string());

    // Records: every scene × applicable mode × repeat; explicit cannot apply over glass.
    let records = v["records"].as_array().unwrap();
    assert_eq!(records.len(), (6 + 5) * 2, "records: {records:?}");
    for r in records {
        for k in [
            "seconds",
            "samples_per_second",
            "rays_per_second",
            "samples",
            "rays",
            "camera_rays",
            "bounce_rays",
            "shadow_rays",
        ] {
            assert!(num(r, k) > 0.0, "{k} in {r}");
        }
        assert_eq!(r["samples"], 24 * 16);
        assert_eq!(r["camera_rays"], 24 * 16);
        assert_eq!(
            num(r, "rays"),
            num(r, "camera_rays") + num(r, "bounce_rays") + num(r, "shadow_rays")
        );
        assert_eq!(
            (r["width"].as_u64(), r["height"].as_u64()),
            (Some(24), Some(16))
        );
        let mode = r["mode"].as_str().unwrap();
        assert!(MODES.contains(&mode));
        // Walk lengths exist exactly for the random-walk modes (≥ 1 vertex per walk).
        match mode {
            "classic" | "explicit" => assert!(r["mean_walk_length"].is_null(), "{r}"),
            _ => assert!(num(r, "mean_walk_length") >= 1.0, "{r}"),
        }
        assert!(r["repeat"].as_u64().unwrap() < 2);
    }

    // Summaries: one per scene × mode, ratios against classic, the skipped mode with its reason.
    let sums = v["summaries"].as_array().unwrap();
    assert_eq!(sums.len(), 12);
    for s in sums {
        let skipped = s["scene"] == "glass" && s["mode"] == "explicit";
        if skipped {
            assert_eq!(s["status"], "skipped");
            assert!(s["reason"].as_str().unwrap().contains("random_walk"), "{s}");
            continue;
        }
        assert_eq!(s["status"], "ok", "{s}");
        assert!(num(s, "min_seconds") <= num(s, "median_seconds"));
        assert!(num(s, "ratio_to_classic") > 0.0);
        assert!(num(s, "fraction_of_ceiling") > 0.0);
        let e = &s["equal_time"];
        assert_eq!(e["ref_spp"], 2);
        assert!(num(e, "spp") >= 1.0 && num(e, "rmse") >= 0.0 && num(e, "seconds") > 0.0);
        if s["mode"] == "classic" {
            assert_eq!(num(s, "ratio_to_classic"), 1.0);
        }
    }
    let ceilings = v["ceilings"].as_array().unwrap();
    assert_eq!(ceilings.len(), 2);
    for c in ceilings {
        assert!(num(c, "rays_per_second") > 0.0 && num(c, "rays") > 0.0);
        // Below the cap every traced ray is recorded: the render's counters count exactly the
        // rays it traces (a path ended by Russian roulette traces no further ray).
        assert_eq!(c["rays"], c["recorded"], "{c}");
    }
    assert!(v["peers"].as_array().unwrap().is_empty());
    assert!(v["peer_note"].as_str().unwrap().contains("not requested"));

    let md_text = fs::read_to_string(&md).unwrap();
    assert!(md_text.contains("## `metal_plastic`") && md_text.contains("| walk-mirror |"));
    assert!(md_text.contains("Embree ceiling"));
    let png_bytes = fs::read(&png).unwrap();
    assert_eq!(&png_bytes[1..4], b"PNG");
    for f in [
        "metal_plastic.grid.png",
        "glass.grid.png",
        "glass.vgroove.png",
    ] {
        assert!(imgs.join(f).is_file(), "{f} missing");
    }
}

#[test]
fn bench_rejects_bad_arguments_before_rendering() {
    let d = tmpdir("bad");
    let json = d.join("b.json");
    let out = groove()
        .args(["bench", "--modes", "classic,sparkle", "--peer", "off"])
        .arg("--json")
        .arg(&json)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown mode 'sparkle'"));

    let out = groove()
        .args(["bench", "--peer", "off", "--json"])
        .arg(d.join("b.txt"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("expected a .json file"));

    let missing = d.join("nope.xml");
    let out = groove()
        .arg("bench")
        .arg(&missing)
        .args(["--peer", "off", "--spp", "1", "--repeat", "1"])
        .arg("--json")
        .arg(&json)
        .arg("--md")
        .arg(d.join("b.md"))
        .arg("--plot")
        .arg(d.join("b.png"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("nope.xml"));
    assert!(!json.exists(), "no output after a failed bench");
}
