//! `groove merge OUT PARTS...`: the parts of a split render ([`crate::output::part`]) added
//! into one image. Parts of disjoint sample ranges add; parts of disjoint crops stitch; both
//! exactly (the sums are integers), so a complete merge equals the single render bit for bit.
//!
//! Refused, with nothing written: parts of different renders (any of
//! [`part::MATCH_KEYS`] or the film size differ: another scene or edited input, other `-D`
//! parameters, seed, samples per pixel, filter, channels or groove version), two parts that
//! render the same samples of a pixel (overlap), and, unless `allow_missing`, pixels whose
//! samples `0..N` are not all covered (gaps). With `allow_missing` the gaps are reported
//! ([`Merged::missing`]) and the pixels hold what the parts have; nothing is filled in.

use std::path::{Path, PathBuf};

use crate::budget::Budget;
use crate::error::{Error, Result};
use crate::film::{Film, FilmDesc, Filter, Image};
use crate::output::part::{self, Part};
use crate::output::Metadata;

/// The result of a merge, ready to be written.
pub struct Merged {
    /// The film of the merged window (the bounding box of the parts' crops).
    pub film: Film,
    /// Names of the extra channels.
    pub aovs: Vec<String>,
    /// Full film size.
    pub full: (u32, u32),
    /// Attributes for the output (those the parts share, and what was merged).
    pub meta: Metadata,
    /// What is missing (only with `allow_missing`; else a gap is an error), one line each.
    pub missing: Vec<String>,
}

impl Merged {
    /// The developed image and extra channels.
    pub fn develop(&self) -> (Image, Vec<(String, Vec<f32>)>) {
        let extra = self
            .aovs
            .iter()
            .enumerate()
            .map(|(c, n)| (n.clone(), self.film.develop_channel(c)))
            .collect();
        (self.film.develop(), extra)
    }
}

/// Reads and checks `parts` and adds them (see the module's documentation).
pub fn merge(parts: &[PathBuf], allow_missing: bool, budget: &Budget) -> Result<Merged> {
    if parts.is_empty() {
        return Err(Error::Usage("no parts to merge".into()));
    }
    let mut read: Vec<Part> = Vec::with_capacity(parts.len());
    for p in parts {
        if let Some(q) = read
            .iter()
            .find(|q| crate::output::clash::same_file(&q.path, p))
        {
            return Err(Error::Usage(format!(
                "{} is given twice ({} is the same file); nothing was written",
                p.display(),
                q.path.display()
            )));
        }
        let part = part::read_part(p, budget)?;
        check_same_render(&read, &part)?;
        read.push(part);
    }
    let first = &read[0];
    let n_total: u32 = first
        .meta
        .get("groove.sample_count")
        .and_then(|s| s.parse().ok())
        .filter(|&n| n > 0)
        .ok_or_else(|| Error::file(&first.path, "groove.sample_count is not a positive integer"))?;
    // The merged window: the bounding box of the crops.
    let x0 = read.iter().map(|p| p.crop.0).min().unwrap_or(0);
    let y0 = read.iter().map(|p| p.crop.1).min().unwrap_or(0);
    let x1 = read.iter().map(|p| p.crop.0 + p.crop.2).max().unwrap_or(0);
    let y1 = read.iter().map(|p| p.crop.1 + p.crop.3).max().unwrap_or(0);
    let missing = coverage(&read, n_total, (x0, y0, x1, y1))?;
    if !missing.is_empty() && !allow_missing {
        return Err(Error::Usage(format!(
            "the parts do not cover every sample of every pixel; nothing was written \
             (--allow-missing merges what there is):\n  {}",
            missing.join("\n  ")
        )));
    }
    let (w, h) = (x1 - x0, y1 - y0);
    let desc = FilmDesc {
        width: first.film.0,
        height: first.film.1,
        crop_offset: (x0, y0),
        crop_size: (w, h),
        // Developing does not use the filter; the parts' own is in the metadata.
        filter: Filter::default(),
        // The parts carry them (and a merged film may be asked for its variance).
        second_moments: true,
    };
    budget
        .check(
            (w as u64 * h as u64).saturating_mul(crate::film::PIXEL_BYTES + 24),
            &format!("merged film {w}×{h}"),
        )
        .map_err(Error::Usage)?;
    let na = first.aovs.len();
    let mut film = Film::with_channels(desc, na);
    for p in &read {
        let (px, py, pw, ph) = p.crop;
        for j in 0..ph {
            for i in 0..pw {
                let src = (j * pw + i) as usize;
                let dst = ((py - y0 + j) * w + (px - x0 + i)) as usize;
                film.add_raw(dst, &p.pixels[src], &p.extra[src * na..(src + 1) * na]);
            }
        }
    }
    let mut meta: Vec<(String, String)> = part::MATCH_KEYS
        .iter()
        .filter_map(|k| first.meta.get(k).map(|v| (k.to_string(), v.to_string())))
        .collect();
    meta.push(("groove.parts".into(), read.len().to_string()));
    meta.push(("groove.crop".into(), format!("{x0},{y0},{w},{h}")));
    let mut ranges: Vec<(u32, u32)> = read.iter().map(|p| p.samples).collect();
    ranges.sort_unstable();
    ranges.dedup();
    if missing.is_empty() {
        meta.push(("groove.samples".into(), format!("0..{n_total}")));
        meta.push(("groove.spp".into(), n_total.to_string()));
    } else {
        meta.push(("groove.missing".into(), missing.join("; ")));
    }
    Ok(Merged {
        film,
        aovs: first.aovs.clone(),
        full: first.film,
        meta: Metadata(meta),
        missing,
    })
}

/// Errs when `p` is not a part of the same render as the parts read before it.
fn check_same_render(read: &[Part], p: &Part) -> Result<()> {
    let Some(first) = read.first() else {
        return Ok(());
    };
    for k in part::MATCH_KEYS {
        let (a, b) = (first.meta.get(k), p.meta.get(k));
        if a != b {
            return Err(Error::Usage(format!(
                "{} and {} are parts of different renders ({k}: {} vs {}); nothing was written",
                first.path.display(),
                p.path.display(),
                a.unwrap_or("(none)"),
                b.unwrap_or("(none)")
            )));
        }
    }
    Ok(())
}

/// Checks that no two parts render the same sample of a pixel (an error naming both) and
/// lists the samples of the window `(x0, y0, x1, y1)` that no part renders. The window is cut
/// into the cells of the crops' edges; within a cell every pixel is covered by the same parts.
fn coverage(parts: &[Part], n: u32, (x0, y0, x1, y1): (u32, u32, u32, u32)) -> Result<Vec<String>> {
    let mut xs: Vec<u32> = parts
        .iter()
        .flat_map(|p| [p.crop.0, p.crop.0 + p.crop.2])
        .collect();
    let mut ys: Vec<u32> = parts
        .iter()
        .flat_map(|p| [p.crop.1, p.crop.1 + p.crop.3])
        .collect();
    xs.extend([x0, x1]);
    ys.extend([y0, y1]);
    xs.sort_unstable();
    xs.dedup();
    ys.sort_unstable();
    ys.dedup();
    let mut missing = Vec::new();
    for yw in ys.windows(2) {
        for xw in xs.windows(2) {
            let (cx0, cx1, cy0, cy1) = (xw[0], xw[1], yw[0], yw[1]);
            let mut cover: Vec<&Part> = parts
                .iter()
                .filter(|p| {
                    p.crop.0 <= cx0
                        && cx1 <= p.crop.0 + p.crop.2
                        && p.crop.1 <= cy0
                        && cy1 <= p.crop.1 + p.crop.3
                })
                .collect();
            cover.sort_by_key(|p| p.samples);
            let cell = format!("pixels x {cx0}..{cx1}, y {cy0}..{cy1}");
            let mut next = 0u32;
            for (k, p) in cover.iter().enumerate() {
                let (a, b) = p.samples;
                if k > 0 && a < next {
                    let q = cover[..k]
                        .iter()
                        .find(|q| q.samples.1 > a)
                        .unwrap_or(&cover[k - 1]);
                    return Err(Error::Usage(format!(
                        "{} (samples {}..{}) and {} (samples {}..{}) both render samples {}..{} of {cell}; nothing was written",
                        q.path.display(),
                        q.samples.0,
                        q.samples.1,
                        p.path.display(),
                        a,
                        b,
                        a,
                        next.min(b)
                    )));
                }
                if b > n {
                    return Err(Error::file(
                        &p.path,
                        format!("samples {a}..{b} go beyond the render's {n} samples per pixel"),
                    ));
                }
                if a > next {
                    missing.push(format!("samples {next}..{a} of {cell} are in no part"));
                }
                next = next.max(b);
            }
            if next < n {
                missing.push(format!("samples {next}..{n} of {cell} are in no part"));
            }
        }
    }
    Ok(missing)
}

/// Where the merged image lies in the full frame (for the output's windows); `None` when it is
/// the full frame.
pub fn window(m: &Merged) -> Option<crate::output::Window> {
    let (x, y, w, h) = m.film.crop_rect();
    ((x, y, w, h) != (0, 0, m.full.0, m.full.1)).then_some(crate::output::Window {
        full: m.full,
        offset: (x, y),
    })
}

/// Errs when `out` is one of `parts` (the merge would destroy its input).
pub fn check_output(out: &Path, parts: &[PathBuf]) -> Result<()> {
    crate::output::clash::check_not_input(out, parts).map_err(Error::Usage)
}
