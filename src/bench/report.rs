//! The benchmark's outputs: JSON (everything, machine-readable) and a Markdown summary.

use super::{BenchReport, ModeSummary};
use crate::error::{Error, Result};
use crate::output::write_atomic;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::Path;

/// Write the whole report as pretty JSON.
pub fn write_json(path: &Path, r: &BenchReport) -> Result<()> {
    let text = serde_json::to_string_pretty(r)
        .map_err(|e| Error::file(path, format!("cannot encode JSON: {e}")))?;
    write_text(path, &text)
}

/// Write `text` to `path` atomically.
pub fn write_text(path: &Path, text: &str) -> Result<()> {
    write_atomic(path, |w| {
        w.write_all(text.as_bytes()).map_err(|e| e.to_string())
    })
}

fn f(x: f64, digits: usize) -> String {
    if x.is_finite() {
        format!("{x:.digits$}")
    } else {
        "–".into()
    }
}

fn opt(x: Option<f64>, digits: usize) -> String {
    x.map_or("–".into(), |v| f(v, digits))
}

/// The Markdown summary: one table per scene, the Embree ceiling, the Mitsuba peer, and the
/// performance targets of the benchmark issue with their measured values.
pub fn markdown(r: &BenchReport, command: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# groove bench\n");
    let _ = writeln!(
        s,
        "groove {}, renderer {}, {} threads, CPU: {}, {} spp, {} repeats (min and median of the repeats).\n",
        r.groove_version,
        r.renderers.join(", "),
        r.threads,
        if r.cpu.is_empty() { "unknown" } else { &r.cpu },
        r.spp,
        r.repeat
    );
    if !command.is_empty() {
        let _ = writeln!(s, "Command: `{command}`\n");
    }
    let mut scenes: Vec<&str> = r.summaries.iter().map(|m| m.scene.as_str()).collect();
    for c in &r.ceilings {
        scenes.push(&c.scene);
    }
    scenes.dedup();
    let mut seen = std::collections::HashSet::new();
    for scene in scenes.into_iter().filter(|x| seen.insert(*x)) {
        let _ = writeln!(s, "## `{scene}`\n");
        let modes: Vec<&ModeSummary> = r.summaries.iter().filter(|m| m.scene == scene).collect();
        if let Some(rec) = r.records.iter().find(|x| x.scene == scene) {
            let _ = writeln!(s, "{}×{} pixels, {} spp.\n", rec.width, rec.height, rec.spp);
        }
        if !modes.is_empty() {
            let _ = writeln!(s, "| mode | renderer | min s | median s | × classic | Msamples/s | Mrays/s | of Embree ceiling | rays/sample | time/ray × classic | mean walk length | equal-time spp | RMSE | rel. RMSE | efficiency × classic |");
            let _ = writeln!(
                s,
                "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
            );
            let classic_eff = modes
                .iter()
                .find(|m| m.mode == "classic")
                .and_then(|m| m.equal_time.as_ref().map(|e| e.efficiency));
            for m in &modes {
                if m.status != "ok" {
                    let _ = writeln!(
                        s,
                        "| {} | {} | skipped: {} |||||||||||||",
                        m.mode,
                        m.renderer,
                        m.reason.as_deref().unwrap_or("").replace('|', "/")
                    );
                    continue;
                }
                let e = m.equal_time.as_ref();
                let _ = writeln!(
                    s,
                    "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} |",
                    m.mode,
                    m.renderer,
                    f(m.min_seconds, 3),
                    f(m.median_seconds, 3),
                    opt(m.ratio_to_classic, 3),
                    f(m.samples_per_second / 1e6, 3),
                    f(m.rays_per_second / 1e6, 2),
                    m.fraction_of_ceiling
                        .map_or("–".into(), |x| format!("{:.0} %", 100.0 * x)),
                    f(m.rays_per_sample, 2),
                    opt(m.ray_cost_to_classic, 2),
                    opt(m.mean_walk_length, 2),
                    e.map_or("–".into(), |e| e.spp.to_string()),
                    opt(e.map(|e| e.rmse), 4),
                    e.map_or("–".into(), |e| format!("{:.2} %", 100.0 * e.rel_rmse)),
                    opt(e.and_then(|e| classic_eff.map(|c| e.efficiency / c)), 2),
                );
            }
            if let Some(e) = modes.iter().find_map(|m| m.equal_time.as_ref()) {
                let _ = writeln!(
                    s,
                    "\nEqual time: each mode renders with the spp that fits the classic median time; RMSE against a {}-spp reference of the same mode; efficiency = 1/(MSE·time).",
                    e.ref_spp
                );
            }
        }
        if let Some(c) = r.ceilings.iter().find(|c| c.scene == scene) {
            let _ = writeln!(
                s,
                "\nEmbree ceiling: {} rays of a classic render ({:.0} % shadow rays, {} distinct) traced again without shading in {:.3} s: **{:.2} Mrays/s**.",
                c.rays,
                100.0 * c.shadow_fraction,
                c.recorded,
                c.seconds,
                c.rays_per_second / 1e6
            );
            let _ = writeln!(
                s,
                "The same rays in 8-wide packets (rtcIntersect8/rtcOccluded8, consecutive rays of one kind): **{:.2} Mrays/s** ({:.2}× single). Camera rays alone ({}): {:.2} Mrays/s one by one, **{:.2} Mrays/s** as coherent packets of 8 samples of a pixel ({:.2}×).",
                c.packet_rays_per_second / 1e6,
                c.packet_rays_per_second / c.rays_per_second,
                c.camera_rays,
                c.camera_single_rays_per_second / 1e6,
                c.camera_packet_rays_per_second / 1e6,
                c.camera_packet_rays_per_second / c.camera_single_rays_per_second
            );
            if let Some(a) = &c.tier_a {
                let _ = writeln!(
                    s,
                    "Tier A ({} analytic primitives by brute force): single rays **{:.2} Mrays/s** ({:.2}× Embree single), packets {:.2} Mrays/s ({:.2}× Embree packets), camera packets {:.2} Mrays/s.",
                    a.primitives,
                    a.single_rays_per_second / 1e6,
                    a.single_rays_per_second / c.rays_per_second,
                    a.packet_rays_per_second / 1e6,
                    a.packet_rays_per_second / c.packet_rays_per_second,
                    a.camera_packet_rays_per_second / 1e6
                );
                // Net of the replay loop: the time the intersections themselves take.
                let net = |t: f64| (t - c.floor_seconds).max(f64::MIN_POSITIVE);
                let _ = writeln!(
                    s,
                    "Net of the replay loop alone ({:.3} s for the same rays with a trivial test): tier A single rays {:.2}× Embree single.",
                    c.floor_seconds,
                    net(c.seconds) / net(a.single_seconds)
                );
            }
            if !c.lanes.is_empty() {
                let _ = writeln!(
                    s,
                    "\nPackets of 8 samples of a pixel, kept until their longest path ends (no compaction):\n\n| depth | packets | lanes alive | distinct materials |\n|---|---|---|---|"
                );
                for l in &c.lanes {
                    let _ = writeln!(
                        s,
                        "| {} | {} | {:.1} % | {:.2} |",
                        l.depth,
                        l.packets,
                        100.0 * l.active_fraction,
                        l.distinct_materials
                    );
                }
            }
        }
        let peers: Vec<_> = r.peers.iter().filter(|p| p.scene == scene).collect();
        if !peers.is_empty() {
            // One ratio column per render loop that rendered classic.
            let classic: Vec<&ModeSummary> = modes
                .iter()
                .filter(|m| m.mode == "classic" && m.status == "ok")
                .copied()
                .collect();
            let heads: String = classic
                .iter()
                .map(|m| format!(" groove classic {} / Mitsuba |", m.renderer))
                .collect();
            let _ = writeln!(
                s,
                "\n| Mitsuba 3 variant | min s | median s | first render s |{heads}"
            );
            let _ = writeln!(s, "|---|---|---|---|{}", "---|".repeat(classic.len()));
            for p in peers {
                match p.median_seconds {
                    Some(med) => {
                        let ratios: String = classic
                            .iter()
                            .map(|c| format!(" {} |", f(c.median_seconds / med, 2)))
                            .collect();
                        let _ = writeln!(
                            s,
                            "| {} | {} | {} | {} |{ratios}",
                            p.variant,
                            opt(p.min_seconds, 3),
                            f(med, 3),
                            opt(p.warmup_seconds, 3),
                        );
                    }
                    None => {
                        let _ = writeln!(
                            s,
                            "| {} | skipped: {} |||{}",
                            p.variant,
                            p.reason.as_deref().unwrap_or("").replace('|', "/"),
                            "|".repeat(classic.len())
                        );
                    }
                }
            }
        }
        let _ = writeln!(s);
    }
    targets(&mut s, r);
    if let Some(n) = &r.peer_note {
        let _ = writeln!(s, "{n}\n");
    }
    s
}

/// The benchmark issue's performance targets, each with its measured value: the walk and
/// explicit ratios and the ray-rate fraction on the metal/plastic scene(s) (names containing
/// "metal"), the Mitsuba ratios on every scene Mitsuba rendered. Each row also shows a bound that
/// this architecture cannot beat (see the note printed under the table).
fn targets(s: &mut String, r: &BenchReport) {
    // (target, scene, measured, met, bound)
    let mut rows: Vec<(String, String, f64, bool, Option<f64>)> = Vec::new();
    let find = |scene: &str, mode: &str| {
        r.summaries
            .iter()
            .find(|m| m.scene == scene && m.mode == mode && m.status == "ok")
    };
    let mut scenes: Vec<&str> = r.summaries.iter().map(|m| m.scene.as_str()).collect();
    scenes.dedup();
    for scene in scenes {
        let classic = find(scene, "classic");
        if scene.contains("metal") {
            for (mode, limit) in [("walk-mirror", 1.10), ("explicit", 1.05)] {
                if let Some(m) = find(scene, mode) {
                    if let Some(q) = m.ratio_to_classic {
                        // The ratio if every ray of this mode cost what a classic ray costs.
                        let bound = classic.map(|c| m.rays_per_sample / c.rays_per_sample);
                        rows.push((
                            format!("{mode} time ≤ {limit:.2}× classic"),
                            scene.into(),
                            q,
                            q <= limit,
                            bound,
                        ));
                    }
                }
            }
            if let Some(x) = classic.and_then(|m| m.fraction_of_ceiling) {
                rows.push((
                    "classic rays/s ≥ 0.50 × Embree ceiling".into(),
                    scene.into(),
                    x,
                    x >= 0.5,
                    None,
                ));
            }
        }
        let classics = r
            .summaries
            .iter()
            .filter(|m| m.scene == scene && m.mode == "classic" && m.status == "ok");
        for c in classics {
            let ceiling = r.ceilings.iter().find(|x| x.scene == scene);
            for (variant, limit) in [("scalar_rgb", 0.6), ("llvm_ad_rgb", 1.0)] {
                if let Some(t) = r
                    .peers
                    .iter()
                    .find(|p| p.scene == scene && p.variant == variant)
                    .and_then(|p| p.median_seconds)
                {
                    let q = c.median_seconds / t;
                    rows.push((
                        format!(
                            "groove classic ({}) time ≤ {limit:.1}× Mitsuba {variant}",
                            c.renderer
                        ),
                        scene.into(),
                        q,
                        q <= limit,
                        // Tracing the render's rays one by one, with no shading at all.
                        ceiling.map(|x| x.seconds / t),
                    ));
                }
            }
        }
    }
    if rows.is_empty() {
        return;
    }
    let _ = writeln!(s, "## Performance targets\n");
    let _ = writeln!(s, "| target | scene | measured | met | bound |");
    let _ = writeln!(s, "|---|---|---|---|---|");
    for (t, scene, v, ok, bound) in rows {
        let _ = writeln!(
            s,
            "| {t} | {scene} | {v:.2} | {} | {} |",
            if ok { "yes" } else { "no" },
            opt(bound, 2)
        );
    }
    let _ = writeln!(
        s,
        "\nBound: for the microfacet modes, the ratio of rays per sample (the time ratio if a \
         microfacet ray cost no more than a classic one; their extra rays carry the energy that \
         classic normal mapping loses). For the Mitsuba ratios, the Embree ceiling's time over \
         Mitsuba's: the ratio groove would reach if shading cost nothing, since groove traces one \
         ray per `rtcIntersect1`/`rtcOccluded1` call.\n"
    );
}
