//! Wavefront OBJ loader (the subset scenes use: `v`, `vt`, `vn`, `f`).
//!
//! Mitsuba 3 semantics: texture `v` is flipped (v → 1 − v); each distinct
//! (position, texcoord, normal) triple becomes one vertex; polygons are fan-triangulated;
//! groups, objects, materials and smoothing groups are ignored. Errors name `file:line:col`.

use super::mesh::TriMesh;
use crate::budget::Budget;
use crate::error::{Error, Result, SourceLoc};
use glam::{Vec2, Vec3};
use std::collections::HashMap;
use std::path::Path;

/// One face corner: indices into the v / vt / vn lists (0-based, resolved), `None` if absent.
type Key = (u32, Option<u32>, Option<u32>);

/// Loads an OBJ file into an untransformed [`TriMesh`]. Normals are present only when every
/// face corner names one (otherwise the caller computes smooth normals, as Mitsuba does).
pub fn load_obj(path: &Path) -> Result<TriMesh> {
    load_obj_within(path, &Budget::default())
}

/// [`load_obj`] of a regular file whose size fits `budget`.
pub fn load_obj_within(path: &Path, budget: &Budget) -> Result<TriMesh> {
    let text = crate::inputs::read_regular(path, budget)?;
    let text = String::from_utf8_lossy(&text);
    parse_obj(&text, path)
}

/// Parses OBJ text; `path` is used in error messages only.
pub fn parse_obj(text: &str, path: &Path) -> Result<TriMesh> {
    let mut v: Vec<Vec3> = Vec::new();
    let mut vt: Vec<Vec2> = Vec::new();
    let mut vn: Vec<Vec3> = Vec::new();
    let mut map: HashMap<Key, u32> = HashMap::new();
    let mut keys: Vec<Key> = Vec::new();
    let mut indices: Vec<[u32; 3]> = Vec::new();
    let mut corner: Vec<u32> = Vec::with_capacity(8);

    for (line_no, raw) in text.lines().enumerate() {
        let line_no = line_no as u32 + 1;
        let line = raw.split('#').next().unwrap_or("");
        let mut toks = tokens(line);
        let Some((_, head)) = toks.next() else {
            continue;
        };
        let err = |col: usize, msg: String| {
            Error::scene(&SourceLoc::new(path, line_no, col as u32 + 1), msg)
        };
        match head {
            "v" | "vn" | "vt" => {
                let want = if head == "vt" { 2 } else { 3 };
                let mut xs = [0.0f32; 3];
                for (k, x) in xs.iter_mut().enumerate().take(want) {
                    let (col, tok) = toks.next().ok_or_else(|| {
                        err(
                            line.len(),
                            format!("`{head}` needs {want} numbers, got {k}"),
                        )
                    })?;
                    *x = tok
                        .parse::<f32>()
                        .ok()
                        .filter(|x| x.is_finite())
                        .ok_or_else(|| err(col, format!("`{tok}` is not a finite number")))?;
                }
                match head {
                    "v" => v.push(Vec3::from_array(xs)),
                    "vn" => vn.push(Vec3::from_array(xs).normalize_or_zero()),
                    // Mitsuba flips v so that images are addressed from their top row.
                    _ => vt.push(Vec2::new(xs[0], 1.0 - xs[1])),
                }
            }
            "f" => {
                corner.clear();
                for (col, tok) in toks {
                    let mut parts = tok.split('/');
                    let resolve = |s: Option<&str>, n: usize, what: &str| -> Result<Option<u32>> {
                        let s = match s {
                            None | Some("") => return Ok(None),
                            Some(s) => s,
                        };
                        let i: i64 = s
                            .parse()
                            .map_err(|_| err(col, format!("bad {what} index `{s}` in `{tok}`")))?;
                        // 1-based; negative counts back from the last element defined so far.
                        let r = if i > 0 { i - 1 } else { n as i64 + i };
                        if i == 0 || r < 0 || r >= n as i64 {
                            return Err(err(
                                col,
                                format!("{what} index {i} out of range (have {n})"),
                            ));
                        }
                        Ok(Some(r as u32))
                    };
                    let pi = resolve(parts.next(), v.len(), "vertex")?
                        .ok_or_else(|| err(col, format!("face corner `{tok}` has no vertex")))?;
                    let ti = resolve(parts.next(), vt.len(), "texture")?;
                    let ni = resolve(parts.next(), vn.len(), "normal")?;
                    let key = (pi, ti, ni);
                    let idx = *map.entry(key).or_insert_with(|| {
                        keys.push(key);
                        keys.len() as u32 - 1
                    });
                    corner.push(idx);
                }
                if corner.len() < 3 {
                    return Err(err(0, format!("face with {} vertices", corner.len())));
                }
                for k in 1..corner.len() - 1 {
                    indices.push([corner[0], corner[k], corner[k + 1]]);
                }
            }
            _ => {} // o, g, s, usemtl, mtllib, l, p, ...: ignored as Mitsuba does
        }
    }

    let positions = keys.iter().map(|k| v[k.0 as usize]).collect();
    let uvs = keys.iter().any(|k| k.1.is_some()).then(|| {
        keys.iter()
            .map(|k| k.1.map_or(Vec2::ZERO, |i| vt[i as usize]))
            .collect()
    });
    let normals = (!keys.is_empty() && keys.iter().all(|k| k.2.is_some()))
        .then(|| keys.iter().map(|k| vn[k.2.unwrap() as usize]).collect());
    let mesh = TriMesh {
        positions,
        normals,
        uvs,
        indices,
    };
    mesh.validate().map_err(|m| Error::file(path, m))?;
    Ok(mesh)
}

/// Whitespace-separated tokens with their byte column.
fn tokens(line: &str) -> impl Iterator<Item = (usize, &str)> {
    line.split_ascii_whitespace()
        .map(move |t| (t.as_ptr() as usize - line.as_ptr() as usize, t))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<TriMesh> {
        parse_obj(s, Path::new("t.obj"))
    }

    #[test]
    fn quad_with_flipped_uvs_and_normals() {
        let m = parse(
            "# c\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0.25\nvn 0 0 2\n\
             g x\nusemtl m\nf 1/1/1 2/2/1 3/2/1 4/1/1\n",
        )
        .unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.uvs.as_ref().unwrap()[1], Vec2::new(1.0, 0.75));
        assert_eq!(m.normals.as_ref().unwrap()[0], Vec3::Z);
    }

    #[test]
    fn negative_and_normal_only_indices_dedup() {
        let m =
            parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf -3//-1 -2//1 -1//1\nf 1//1 2//1 3//1\n")
                .unwrap();
        assert_eq!(m.positions.len(), 3);
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 1, 2]]);
        assert!(m.uvs.is_none() && m.normals.is_some());
    }

    #[test]
    fn errors_name_file_line_and_column() {
        let e = parse("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n")
            .unwrap_err()
            .to_string();
        assert!(e.starts_with("t.obj:4:7:"), "{e}");
        let e = parse("v 0 0 0\nv 1 x 0\n").unwrap_err().to_string();
        assert!(e.starts_with("t.obj:2:5:") && e.contains("`x`"), "{e}");
        let e = parse("v 0 0 0\nv 1 nan 0\n").unwrap_err().to_string();
        assert!(e.starts_with("t.obj:2:5:"), "{e}");
        assert!(parse("v 0 0 0\n").is_err(), "no faces");
    }
}
