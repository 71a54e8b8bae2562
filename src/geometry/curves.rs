//! Mitsuba 3's curve shapes `linearcurve` and `bsplinecurve` (`src/shapes/linearcurve.cpp`,
//! `bsplinecurve.cpp` in mitsuba-renderer/mitsuba3 3.9.1): many hollow tubes of varying radius
//! along polylines (round linear: cones joined and capped by spheres) or uniform cubic
//! B-splines (open ends, no caps), read from a text file and intersected by Embree's native
//! round curves (`accel::embree`, which also culls hits from inside a curve, as Mitsuba does).
//!
//! | parameter | type | default | meaning |
//! |---|---|---|---|
//! | `filename` | string | (required) | the curve file (below) |
//! | `to_world` | transform | identity | maps the control points' positions; their radii are *not* scaled (as Mitsuba) |
//! | `silhouette_sampling_weight` | float | 1 | read and ignored: it weighs Mitsuba's silhouette sampling for differentiable rendering, which groove does not do |
//!
//! `flip_normals` is no parameter of these shapes (Mitsuba 3.9.1 rejects it as unreferenced), and
//! neither can carry an area emitter: Mitsuba has no position sampling on curves (its
//! `sample_position` is not implemented), so the loader refuses one with a located error.
//!
//! The file: one control point per line, `x y z radius` (four numbers separated by blanks); an
//! empty (or blank) line ends a curve. A linear curve needs at least 2 control points and has
//! n − 1 segments, a B-spline curve at least 4 and has n − 3 segments; segment k of a curve
//! starting at control point f starts at control point f + k (Embree's index buffer). Lines of
//! 1024 characters or more, a fifth number on a line, non-finite numbers, a negative radius,
//! a too-short curve and a file without any control point are errors naming the file, line and
//! column. (Mitsuba also stops at the long line, the non-finite values and the short curve; it
//! ignores what follows the fourth number, and passes a negative radius on to Embree.)
//!
//! The surface at a hit (the ray point, not reprojected, as Mitsuba) is in [`super::curve_surface`].

use crate::budget::{gb, Budget};
use crate::error::{Error, Result, SourceLoc};
use crate::scene::xml::props::Props;
use glam::{Mat4, Vec3};
use std::io::{BufRead, BufReader, Read};
use std::path::{Path, PathBuf};

/// The basis of a curve shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CurveBasis {
    /// `linearcurve`: straight segments between consecutive control points.
    Linear,
    /// `bsplinecurve`: uniform cubic B-spline segments over 4 consecutive control points.
    BSpline,
}

impl CurveBasis {
    /// Control points per segment (2 or 4), which is also the fewest a curve may have.
    pub fn points_per_segment(self) -> usize {
        match self {
            CurveBasis::Linear => 2,
            CurveBasis::BSpline => 4,
        }
    }

    /// What the error messages call these curves.
    fn noun(self) -> &'static str {
        match self {
            CurveBasis::Linear => "linear curves",
            CurveBasis::BSpline => "B-spline curves",
        }
    }

    /// The plugin name.
    pub fn plugin(self) -> &'static str {
        match self {
            CurveBasis::Linear => "linearcurve",
            CurveBasis::BSpline => "bsplinecurve",
        }
    }
}

/// The curves of one shape, in world space.
#[derive(Clone, Debug)]
pub struct Curves {
    pub basis: CurveBasis,
    /// Control points: world-space position (x, y, z) and radius.
    pub points: Vec<[f32; 4]>,
    /// The first control point of each segment, in file order; a hit's primitive index.
    pub segments: Vec<u32>,
}

/// Mitsuba's line buffer is 1025 bytes and refuses a line of 1024 characters or more.
const MAX_LINE: usize = 1023;

/// Bytes held per control point, for the memory budget: ours (16, plus 4 per segment index)
/// and Embree's copies of both buffers, plus an estimate of Embree's curve BVH (≈ 64 per
/// segment: leaf references and nodes).
const BYTES_PER_POINT: u64 = 16 + 4 + 16 + 4 + 64;

impl Curves {
    /// Axis-aligned world bounds: each control point ± its radius (Mitsuba's `bbox`, which
    /// contains the B-spline's convex hull).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.points.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), c| {
                let (p, r) = (Vec3::new(c[0], c[1], c[2]), c[3]);
                (lo.min(p - r), hi.max(p + r))
            },
        )
    }

    /// The control points of segment `prim` (2 or 4).
    #[inline]
    pub fn segment(&self, prim: u32) -> &[[f32; 4]] {
        let first = self.segments[prim as usize] as usize;
        &self.points[first..first + self.basis.points_per_segment()]
    }
}

/// The shape of a `linearcurve` / `bsplinecurve` element: its own parameters (`filename`,
/// `silhouette_sampling_weight`); the loader reads `to_world` and passes it in, with `resolve`
/// (the scene's file lookup) and the memory budget. Errors are located at the element, with
/// the curve file's own line and column in the message.
pub fn from_props(
    p: &Props<'_>,
    basis: CurveBasis,
    to_world: &Mat4,
    resolve: impl Fn(&str) -> Result<PathBuf>,
    budget: &Budget,
) -> Result<super::Shape> {
    let name = p.string_opt("filename")?.ok_or_else(|| {
        Error::scene(
            p.loc(),
            format!("shape '{}' needs a 'filename'", basis.plugin()),
        )
    })?;
    p.float("silhouette_sampling_weight", 1.0)?;
    let file = resolve(&name)?;
    let curves = load_curves_within(&file, basis, to_world, budget)
        .map_err(|e| Error::scene(p.loc(), format!("cannot load curves '{name}': {e}")))?;
    Ok(super::Shape::curves(curves))
}

/// Loads a curve file (a regular file) with positions mapped by `to_world`, its memory checked
/// against and then reserved in `budget` as it grows.
pub fn load_curves_within(
    path: &Path,
    basis: CurveBasis,
    to_world: &Mat4,
    budget: &Budget,
) -> Result<Curves> {
    let (f, _) = crate::inputs::open_regular(path)?;
    parse_curves(f, path, basis, to_world, budget)
}

/// Parses a curve file streamed from `input`; `path` names it in errors (`path:line:col`).
pub fn parse_curves(
    input: impl Read,
    path: &Path,
    basis: CurveBasis,
    to_world: &Mat4,
    budget: &Budget,
) -> Result<Curves> {
    let mut reader = BufReader::new(input);
    let mut points: Vec<[f32; 4]> = Vec::new();
    let mut segments: Vec<u32> = Vec::new();
    // The current curve: its first control point and the line it starts on.
    let mut curve: Option<(usize, u32)> = None;
    let mut line = Vec::with_capacity(128);
    let mut line_no = 0u32;
    let at = |line: u32, col: usize| SourceLoc::new(path, line, col as u32 + 1);
    let finish = |curve: Option<(usize, u32)>, points: &Vec<[f32; 4]>, segments: &mut Vec<u32>| {
        let Some((first, start)) = curve else {
            return Ok(());
        };
        let n = points.len() - first;
        let need = basis.points_per_segment();
        if n < need {
            return Err(Error::scene(
                &at(start, 0),
                format!(
                    "{} need at least {need} control points; the one starting here has {n}",
                    basis.noun()
                ),
            ));
        }
        grow(segments, n - need + 1, 4, budget, path)?;
        // Indices fit in u32: the point count is checked as points are added.
        segments.extend((first..=points.len() - need).map(|i| i as u32));
        Ok(())
    };
    loop {
        line.clear();
        let n = reader
            .by_ref()
            .take(MAX_LINE as u64 + 2)
            .read_until(b'\n', &mut line)
            .map_err(|e| Error::io(path, e))?;
        if n == 0 {
            break;
        }
        line_no = line_no.saturating_add(1);
        if line.last() == Some(&b'\n') {
            line.pop();
        }
        if line.len() > MAX_LINE {
            return Err(Error::scene(
                &at(line_no, 0),
                format!("line longer than {MAX_LINE} characters (Mitsuba's limit)"),
            ));
        }
        let mut toks = line
            .split(|b| b.is_ascii_whitespace())
            .scan(0usize, |col, t| {
                let c = *col;
                *col += t.len() + 1;
                Some((c, t))
            })
            .filter(|(_, t)| !t.is_empty());
        let Some(first_tok) = toks.next() else {
            finish(curve.take(), &points, &mut segments)?;
            continue;
        };
        let mut xs = [0.0f32; 4];
        let mut tok = Some(first_tok);
        for (k, x) in xs.iter_mut().enumerate() {
            let Some((col, t)) = tok else {
                return Err(Error::scene(
                    &at(line_no, line.len()),
                    format!("a control point needs 4 numbers (x y z radius), got {k}"),
                ));
            };
            let text = String::from_utf8_lossy(t);
            *x = text
                .parse::<f32>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    Error::scene(
                        &at(line_no, col),
                        format!("`{text}` is not a finite number"),
                    )
                })?;
            tok = toks.next();
        }
        if let Some((col, t)) = tok {
            return Err(Error::scene(
                &at(line_no, col),
                format!(
                    "unexpected `{}` after the 4 numbers of a control point",
                    String::from_utf8_lossy(t)
                ),
            ));
        }
        let p = to_world.transform_point3(Vec3::new(xs[0], xs[1], xs[2]));
        if !p.is_finite() {
            return Err(Error::scene(
                &at(line_no, 0),
                format!("the control point is not finite after to_world ({p})"),
            ));
        }
        if xs[3] < 0.0 {
            return Err(Error::scene(
                &at(line_no, 0),
                format!("negative radius {}", xs[3]),
            ));
        }
        if points.len() >= u32::MAX as usize {
            return Err(Error::scene(
                &at(line_no, 0),
                "more than 2^32 − 1 control points",
            ));
        }
        if curve.is_none() {
            curve = Some((points.len(), line_no));
        }
        grow(&mut points, 1, 16, budget, path)?;
        points.push([p.x, p.y, p.z, xs[3]]);
    }
    finish(curve.take(), &points, &mut segments)?;
    if points.is_empty() {
        return Err(Error::file(
            path,
            "no control points: the curve file is empty",
        ));
    }
    points.shrink_to_fit();
    segments.shrink_to_fit();
    let bytes = points.len() as u64 * BYTES_PER_POINT;
    budget
        .reserve(
            bytes,
            &format!(
                "{} curves ({} control points, {} segments)",
                basis.plugin(),
                points.len(),
                segments.len()
            ),
        )
        .map_err(|m| Error::file(path, m))?;
    Ok(Curves {
        basis,
        points,
        segments,
    })
}

/// Makes room for `more` items of `item_bytes` in `v`, doubling its capacity; the doubled
/// size (in the final structures' terms, [`BYTES_PER_POINT`] per control point) is checked
/// against the budget before allocating.
fn grow<T>(
    v: &mut Vec<T>,
    more: usize,
    item_bytes: u64,
    budget: &Budget,
    path: &Path,
) -> Result<()> {
    let need = v.len().saturating_add(more);
    if need <= v.capacity() {
        return Ok(());
    }
    let cap = need.max(v.capacity().saturating_mul(2)).max(256);
    let bytes = (cap as u64).saturating_mul(item_bytes.max(BYTES_PER_POINT));
    budget
        .check(
            bytes,
            &format!("curves of {} ({})", path.display(), gb(bytes)),
        )
        .map_err(|m| Error::file(path, m))?;
    v.reserve_exact(cap - v.len());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str, basis: CurveBasis) -> Result<Curves> {
        parse_curves(
            text.as_bytes(),
            Path::new("c.txt"),
            basis,
            &Mat4::IDENTITY,
            &Budget::new(1 << 30),
        )
    }

    fn err(text: &str, basis: CurveBasis) -> String {
        parse(text, basis).unwrap_err().to_string()
    }

    #[test]
    fn curves_are_split_by_blank_lines_into_segments() {
        let c = parse(
            "\n-1.0 0.1 0.1 0.5\n 1.0 1.4 1.2 0.5\n  \t\r\n\n-1 5 2.2 1\r\n-2.3 4 2.3 2\n4 1 2.2 5\n4 0 2.3 6",
            CurveBasis::Linear,
        )
        .unwrap();
        assert_eq!(c.points.len(), 6);
        assert_eq!(c.segments, vec![0, 2, 3, 4]);
        assert_eq!(c.points[5], [4.0, 0.0, 2.3, 6.0]);
        assert_eq!(c.segment(1), &c.points[2..4]);
        let b = parse(
            "0 0 0 1\n1 0 0 1\n2 0 0 1\n3 0 0 1\n\n0 1 0 1\n1 1 0 1\n2 1 0 1\n3 1 0 1\n4 1 0 1\n5 1 0 1\n",
            CurveBasis::BSpline,
        )
        .unwrap();
        assert_eq!(b.segments, vec![0, 4, 5, 6]);
        assert_eq!(b.segment(3).len(), 4);
        let (lo, hi) = b.bounds();
        assert_eq!(
            (lo, hi),
            (Vec3::new(-1.0, -1.0, -1.0), Vec3::new(6.0, 2.0, 1.0))
        );
    }

    #[test]
    fn positions_follow_to_world_but_radii_do_not() {
        let m =
            Mat4::from_translation(Vec3::new(1.0, 0.0, 0.0)) * Mat4::from_scale(Vec3::splat(2.0));
        let c = parse_curves(
            "0 0 1 0.5\n1 1 1 0.25\n".as_bytes(),
            Path::new("c.txt"),
            CurveBasis::Linear,
            &m,
            &Budget::new(1 << 30),
        )
        .unwrap();
        assert_eq!(c.points, vec![[1.0, 0.0, 2.0, 0.5], [3.0, 2.0, 2.0, 0.25]]);
    }

    #[test]
    fn malformed_lines_name_file_line_and_column() {
        use CurveBasis::*;
        let e = err("0 0 0 1\n1 x 0 1\n", Linear);
        assert!(e.starts_with("c.txt:2:3:") && e.contains("`x`"), "{e}");
        let e = err("0 0 0 1\n1 0 0\n", Linear);
        assert!(e.starts_with("c.txt:2:6:") && e.contains("got 3"), "{e}");
        let e = err("0 0 0 1\n1 0 0 1 7\n", Linear);
        assert!(e.starts_with("c.txt:2:9:") && e.contains("`7`"), "{e}");
        let e = err("0 0 0 1\n1 0 inf 1\n", Linear);
        assert!(e.starts_with("c.txt:2:5:"), "{e}");
        let e = err("0 0 0 1\n1 0 0 NaN\n", Linear);
        assert!(e.starts_with("c.txt:2:7:"), "{e}");
        let e = err("0 0 0 1\n1 0 0 -0.5\n", Linear);
        assert!(
            e.starts_with("c.txt:2:1:") && e.contains("negative radius"),
            "{e}"
        );
        // A curve too short for its basis is reported at its first line.
        let e = err("0 0 0 1\n1 0 0 1\n\n\n2 0 0 1\n", Linear);
        assert!(
            e.starts_with("c.txt:5:1:") && e.contains("at least 2") && e.contains("has 1"),
            "{e}"
        );
        let e = err("0 0 0 1\n1 0 0 1\n2 0 0 1\n", BSpline);
        assert!(
            e.starts_with("c.txt:1:1:") && e.contains("at least 4"),
            "{e}"
        );
        let e = err("", Linear);
        assert!(e.starts_with("c.txt:") && e.contains("empty"), "{e}");
        let e = err("\n \n\t\n", BSpline);
        assert!(e.contains("empty"), "{e}");
        // Mitsuba's line limit: 1023 characters pass, 1024 do not.
        let ok = format!("0 0 0 1\n1 0 0 1{}\n", " ".repeat(1023 - 7));
        assert!(parse(&ok, Linear).is_ok());
        let long = format!("0 0 0 1\n1 0 0 1{}\n", " ".repeat(1024 - 7));
        let e = err(&long, Linear);
        assert!(
            e.starts_with("c.txt:2:1:") && e.contains("longer than 1023"),
            "{e}"
        );
        // Not UTF-8: a located error, no panic.
        let e = parse_curves(
            &b"0 0 0 1\n1 \xff 0 1\n"[..],
            Path::new("c.txt"),
            Linear,
            &Mat4::IDENTITY,
            &Budget::new(1 << 30),
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("c.txt:2:3:"), "{e}");
    }

    #[test]
    fn hostile_inputs_are_refused_by_the_budget_or_the_line_limit() {
        // A gigabyte without a newline: refused after reading one line's worth.
        let endless = std::io::repeat(b'1').take(1 << 30);
        let e = parse_curves(
            endless,
            Path::new("c.txt"),
            CurveBasis::Linear,
            &Mat4::IDENTITY,
            &Budget::new(1 << 30),
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("longer than 1023"), "{e}");
        // A million control points against a 1 MB budget: refused while growing, not after.
        let many = "0 0 0 1\n".repeat(1 << 20);
        let e = parse_curves(
            many.as_bytes(),
            Path::new("c.txt"),
            CurveBasis::Linear,
            &Mat4::IDENTITY,
            &Budget::new(1 << 20),
        )
        .unwrap_err()
        .to_string();
        assert!(e.starts_with("c.txt:") && e.contains("memory limit"), "{e}");
    }
}
