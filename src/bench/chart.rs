//! Pictures of a benchmark: the bar chart of render time per mode (with the ratio to classic over
//! each bar) and, per scene, an image grid of every mode's reference render with its difference
//! from classic normal mapping. Drawn with `plotters` into an RGB buffer, written as PNG.

use super::{BenchReport, ModeSummary};
use crate::error::{Error, Result};
use crate::film::Image;
use crate::output::png::srgb_u8;
use crate::output::write_png_rgb8;
use plotters::prelude::*;
use plotters::style::FontStyle;
use std::path::Path;
use std::sync::OnceLock;

/// TrueType fonts tried for labels (Debian's `fonts-dejavu-core` first); `GROOVE_FONT`
/// overrides.
const FONT_PATHS: [&str; 4] = [
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/truetype/liberation/LiberationSans-Regular.ttf",
    "/usr/share/fonts/truetype/freefont/FreeSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
];

/// Register a font with plotters once per process.
fn ensure_font() -> Result<()> {
    static FONT: OnceLock<std::result::Result<(), String>> = OnceLock::new();
    FONT.get_or_init(|| {
        let candidates: Vec<String> = std::env::var("GROOVE_FONT")
            .into_iter()
            .chain(FONT_PATHS.iter().map(|s| s.to_string()))
            .collect();
        for p in &candidates {
            if let Ok(bytes) = std::fs::read(p) {
                let bytes: &'static [u8] = Box::leak(bytes.into_boxed_slice());
                if plotters::style::register_font("sans-serif", FontStyle::Normal, bytes).is_ok() {
                    return Ok(());
                }
            }
        }
        Err(format!(
            "drawing needs a TrueType font: install Debian's fonts-dejavu-core or set GROOVE_FONT=FILE.ttf (tried {})",
            candidates.join(", ")
        ))
    })
    .clone()
    .map_err(Error::Usage)
}

fn draw_err<E: std::fmt::Debug>(path: &Path) -> impl Fn(E) -> Error + '_ {
    move |e| Error::file(path, format!("cannot draw: {e:?}"))
}

/// Colour of the mode's bars.
fn mode_colour(mode: &str) -> RGBColor {
    match mode {
        "classic" => RGBColor(120, 120, 120),
        "explicit" => RGBColor(230, 159, 0),
        "walk-mirror" => RGBColor(0, 114, 178),
        "walk-same" => RGBColor(86, 180, 233),
        "vgroove" => RGBColor(0, 158, 115),
        "ugroove" => RGBColor(204, 121, 167),
        _ => RGBColor(90, 90, 160),
    }
}

/// Bar chart: one panel per scene, median render time per mode, ratio to classic on each bar.
pub fn write_bar_chart(path: &Path, r: &BenchReport) -> Result<()> {
    ensure_font()?;
    let mut scenes: Vec<&str> = Vec::new();
    for m in &r.summaries {
        if !scenes.contains(&m.scene.as_str()) {
            scenes.push(&m.scene);
        }
    }
    if scenes.is_empty() {
        return Err(Error::Usage("no mode was rendered: nothing to plot".into()));
    }
    let (w, panel_h) = (900u32, 300u32);
    let h = 50 + panel_h * scenes.len() as u32;
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err(path))?;
        let (title, body) = root.split_vertically(50);
        title
            .draw(&Text::new(
                format!(
                    "groove bench: median render time per normal-mapping mode ({} spp, {} threads)",
                    r.spp, r.threads
                ),
                (15, 15),
                ("sans-serif", 20).into_font(),
            ))
            .map_err(draw_err(path))?;
        let panels = body.split_evenly((scenes.len(), 1));
        for (panel, scene) in panels.iter().zip(&scenes) {
            let modes: Vec<&ModeSummary> =
                r.summaries.iter().filter(|m| m.scene == *scene).collect();
            let tmax = modes
                .iter()
                .filter(|m| m.median_seconds.is_finite())
                .map(|m| m.median_seconds)
                .fold(0.0f64, f64::max)
                .max(1e-6);
            let n = modes.len() as f64;
            let mut chart = ChartBuilder::on(panel)
                .caption(*scene, ("sans-serif", 18))
                .margin(8)
                .x_label_area_size(if r.renderers.len() > 1 { 44 } else { 28 })
                .y_label_area_size(60)
                .build_cartesian_2d(-0.5f64..n - 0.5, 0.0f64..tmax * 1.25)
                .map_err(draw_err(path))?;
            chart
                .configure_mesh()
                .disable_x_mesh()
                .disable_x_axis()
                .y_desc("seconds")
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(draw_err(path))?;
            for (i, m) in modes.iter().enumerate() {
                let x = i as f64;
                // The mode, and under it the render loop when the bench timed several.
                let mut labels = vec![m.mode.clone()];
                if r.renderers.len() > 1 {
                    labels.push(m.renderer.clone());
                }
                for (row, label) in labels.into_iter().enumerate() {
                    chart
                        .draw_series(std::iter::once(
                            EmptyElement::at((x - 0.3, -tmax * 0.02))
                                + Text::new(
                                    label,
                                    (0, 15 * row as i32),
                                    ("sans-serif", 13).into_font(),
                                ),
                        ))
                        .map_err(draw_err(path))?;
                }
                if !m.median_seconds.is_finite() {
                    chart
                        .draw_series(std::iter::once(Text::new(
                            "skipped",
                            (x - 0.25, tmax * 0.1),
                            ("sans-serif", 13).into_font().color(&RED),
                        )))
                        .map_err(draw_err(path))?;
                    continue;
                }
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [(x - 0.35, 0.0), (x + 0.35, m.median_seconds)],
                        mode_colour(&m.mode).filled(),
                    )))
                    .map_err(draw_err(path))?;
                let label = match m.ratio_to_classic {
                    Some(q) => format!("{:.2} s  {q:.2}×", m.median_seconds),
                    None => format!("{:.2} s", m.median_seconds),
                };
                chart
                    .draw_series(std::iter::once(Text::new(
                        label,
                        (x - 0.33, m.median_seconds + tmax * 0.1),
                        ("sans-serif", 13).into_font(),
                    )))
                    .map_err(draw_err(path))?;
            }
        }
        root.present().map_err(draw_err(path))?;
    }
    write_png_rgb8(path, w, h, &buf)
}

/// Per scene: `DIR/SCENE.MODE.png` for every mode's reference and `DIR/SCENE.grid.png`: the
/// references in a row, under them each mode's difference from classic (red: brighter than
/// classic, blue: darker; full colour at a difference equal to the classic image's mean).
pub fn write_image_grid(dir: &Path, scene: &str, refs: &[(String, &Image)]) -> Result<()> {
    ensure_font()?;
    std::fs::create_dir_all(dir).map_err(|e| Error::io(dir, e))?;
    for (mode, img) in refs {
        crate::output::write_image(
            &dir.join(format!("{scene}.{mode}.png")),
            img,
            &Default::default(),
        )?;
    }
    let (iw, ih) = (refs[0].1.width, refs[0].1.height);
    let classic = refs.iter().find(|(m, _)| m == "classic").map(|(_, i)| *i);
    let label_h = 24u32;
    let rows = if classic.is_some() { 2 } else { 1 };
    let (w, h) = (iw * refs.len() as u32, rows * (ih + label_h));
    let mut buf = vec![255u8; (w * h * 3) as usize];
    let put = |buf: &mut [u8], x: u32, y: u32, rgb: [u8; 3]| {
        let i = ((y * w + x) * 3) as usize;
        buf[i..i + 3].copy_from_slice(&rgb);
    };
    let scale = classic.map(|c| {
        let m = c.mean();
        1.0 / ((m[0] + m[1] + m[2]) / 3.0).max(1e-6) as f32
    });
    for (col, (_, img)) in refs.iter().enumerate() {
        let x0 = col as u32 * iw;
        for y in 0..ih.min(img.height) {
            for x in 0..iw.min(img.width) {
                let p = img.get(x, y);
                put(&mut buf, x0 + x, label_h + y, p.map(srgb_u8));
                if let (Some(c), Some(k)) = (classic, scale) {
                    let q = c.get(x, y);
                    let d = ((p[0] - q[0]) + (p[1] - q[1]) + (p[2] - q[2])) / 3.0 * k;
                    let rgb = [srgb_u8(d.max(0.0)), 0, srgb_u8((-d).max(0.0))];
                    put(&mut buf, x0 + x, 2 * label_h + ih + y, rgb);
                }
            }
        }
    }
    let path = dir.join(format!("{scene}.grid.png"));
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        for (col, (mode, _)) in refs.iter().enumerate() {
            let x = (col as u32 * iw + 6) as i32;
            root.draw(&Text::new(
                mode.clone(),
                (x, 4),
                ("sans-serif", 16).into_font(),
            ))
            .map_err(draw_err(&path))?;
            if classic.is_some() {
                root.draw(&Text::new(
                    format!("{mode} − classic"),
                    (x, (label_h + ih + 4) as i32),
                    ("sans-serif", 16).into_font(),
                ))
                .map_err(draw_err(&path))?;
            }
        }
        root.present().map_err(draw_err(&path))?;
    }
    write_png_rgb8(&path, w, h, &buf)
}
