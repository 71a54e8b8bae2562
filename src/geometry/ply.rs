//! Stanford PLY loader: `ascii`, `binary_little_endian` and `binary_big_endian`.
//!
//! Reads the `vertex` element (`x y z`, optional `nx ny nz`, uv from `u v`, `texture_u texture_v`
//! or `s t`, stored unflipped as Mitsuba does) and the `face` element (`vertex_indices` or
//! `vertex_index`, any count and index types; polygons are fan-triangulated). Other properties
//! of the vertex and face elements become mesh attributes by Mitsuba's rules (see
//! [`super::ply_attributes`]; [`parse_ply_attributed`]); other elements are read and discarded,
//! so files with materials or edges load too.

use super::attributes::{Attribute, Per};
use super::mesh::TriMesh;
use super::ply_attributes::{self, ValueKind};
use crate::budget::{bytes_of, Budget};
use crate::error::{Error, Result};
use glam::{Vec2, Vec3};
use std::path::Path;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Ty {
    fn parse(s: &str) -> Option<Ty> {
        Some(match s {
            "char" | "int8" => Ty::I8,
            "uchar" | "uint8" => Ty::U8,
            "short" | "int16" => Ty::I16,
            "ushort" | "uint16" => Ty::U16,
            "int" | "int32" => Ty::I32,
            "uint" | "uint32" => Ty::U32,
            "float" | "float32" => Ty::F32,
            "double" | "float64" => Ty::F64,
            _ => return None,
        })
    }
    /// How Mitsuba converts a value of this type into a mesh attribute.
    fn value_kind(self) -> ValueKind {
        match self {
            Ty::F32 | Ty::F64 => ValueKind::Float,
            Ty::U8 => ValueKind::U8,
            Ty::I8 => ValueKind::Int {
                max: i8::MAX as f64,
            },
            Ty::I16 => ValueKind::Int {
                max: i16::MAX as f64,
            },
            Ty::U16 => ValueKind::Int {
                max: u16::MAX as f64,
            },
            Ty::I32 => ValueKind::Int {
                max: i32::MAX as f64,
            },
            Ty::U32 => ValueKind::Int {
                max: u32::MAX as f64,
            },
        }
    }

    fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::F64 => 8,
        }
    }
}

#[derive(Debug)]
struct Property {
    name: String,
    /// `Some(count type)` for a list property.
    list: Option<Ty>,
    ty: Ty,
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Property>,
}

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Le,
    Be,
}

/// A cursor over the body that yields numbers as f64 (exact for every PLY integer type).
struct Body<'a> {
    data: &'a [u8],
    pos: usize,
    format: Format,
}

impl Body<'_> {
    /// Where the cursor is, for errors: the line in an ASCII body, the byte offset in a binary one.
    fn position(&self) -> String {
        let pos = self.pos.min(self.data.len());
        match self.format {
            Format::Ascii => {
                let line = self.data[..pos].iter().filter(|&&b| b == b'\n').count() + 1;
                format!("line {line}")
            }
            Format::Le | Format::Be => format!("byte offset {pos}"),
        }
    }

    /// The next value of type `ty` (the type only sets the width of binary data: ASCII tokens
    /// are read as numbers whatever the declared type).
    fn read(&mut self, ty: Ty) -> std::result::Result<f64, String> {
        match self.format {
            Format::Ascii => self.read_ascii(),
            Format::Le | Format::Be => self.read_binary(ty),
        }
    }

    /// One whitespace-separated token.
    fn read_ascii(&mut self) -> std::result::Result<f64, String> {
        while self.pos < self.data.len() && self.data[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        let start = self.pos;
        while self.pos < self.data.len() && !self.data[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        if start == self.pos {
            return Err("unexpected end of file".into());
        }
        let tok = std::str::from_utf8(&self.data[start..self.pos]).unwrap_or("?");
        tok.parse::<f64>()
            .map_err(|_| format!("`{tok}` is not a number"))
    }

    /// `ty.size()` bytes in the file's byte order.
    fn read_binary(&mut self, ty: Ty) -> std::result::Result<f64, String> {
        let n = ty.size();
        let Some(bytes) = self.data.get(self.pos..self.pos + n) else {
            return Err("unexpected end of file (truncated binary data)".into());
        };
        self.pos += n;
        let mut b = [0u8; 8];
        b[..n].copy_from_slice(bytes);
        if self.format == Format::Be {
            b[..n].reverse();
        }
        Ok(match ty {
            Ty::I8 => b[0] as i8 as f64,
            Ty::U8 => b[0] as f64,
            Ty::I16 => i16::from_le_bytes([b[0], b[1]]) as f64,
            Ty::U16 => u16::from_le_bytes([b[0], b[1]]) as f64,
            Ty::I32 => i32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Ty::U32 => u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Ty::F32 => f32::from_le_bytes([b[0], b[1], b[2], b[3]]) as f64,
            Ty::F64 => f64::from_le_bytes(b),
        })
    }

    /// Reads and discards one property's value(s).
    fn skip(&mut self, p: &Property) -> std::result::Result<(), String> {
        let n = match p.list {
            Some(ct) => self.read(ct)? as usize,
            None => 1,
        };
        for _ in 0..n {
            self.read(p.ty)?;
        }
        Ok(())
    }
}

/// The parsed header: the body's format, its elements in file order, and where the body starts.
struct Header {
    format: Format,
    elements: Vec<Element>,
    body_start: usize,
}

/// The header line that starts at `*pos` (trimmed), advancing `*pos` past its `\n`.
fn header_line(data: &[u8], pos: &mut usize) -> Option<String> {
    if *pos >= data.len() {
        return None;
    }
    let end = data[*pos..]
        .iter()
        .position(|&c| c == b'\n')
        .map_or(data.len(), |e| *pos + e);
    let l = String::from_utf8_lossy(&data[*pos..end]).trim().to_string();
    *pos = (end + 1).min(data.len());
    Some(l)
}

/// Parses the header: ASCII lines from the `ply` magic up to and including `end_header`.
fn parse_header(data: &[u8]) -> std::result::Result<Header, String> {
    let mut pos = 0usize;
    if header_line(data, &mut pos).as_deref() != Some("ply") {
        return Err("not a PLY file (missing `ply` magic)".into());
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    let mut line_no = 1;
    loop {
        line_no += 1;
        let line = header_line(data, &mut pos).ok_or("unexpected end of file in the header")?;
        let herr = |m: &str| format!("header line {line_no}: {m}: `{line}`");
        let t: Vec<&str> = line.split_ascii_whitespace().collect();
        match t.first().copied() {
            Some("end_header") => break,
            Some("format") => {
                format = Some(match t.get(1).copied() {
                    Some("ascii") => Format::Ascii,
                    Some("binary_little_endian") => Format::Le,
                    Some("binary_big_endian") => Format::Be,
                    _ => return Err(herr("unknown format")),
                })
            }
            Some("element") => {
                let (Some(name), Some(count)) = (t.get(1), t.get(2).and_then(|c| c.parse().ok()))
                else {
                    return Err(herr("bad element"));
                };
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    props: vec![],
                });
            }
            Some("property") => {
                let el = elements
                    .last_mut()
                    .ok_or_else(|| herr("property before element"))?;
                el.props.push(parse_property(&t).map_err(herr)?);
            }
            Some("comment") | Some("obj_info") | None => {}
            Some(_) => return Err(herr("unknown header keyword")),
        }
    }
    Ok(Header {
        format: format.ok_or("header has no `format` line")?,
        elements,
        body_start: pos,
    })
}

/// A `property TYPE NAME` or `property list COUNT_TYPE TYPE NAME` line, split into words.
fn parse_property(t: &[&str]) -> std::result::Result<Property, &'static str> {
    if t.get(1) == Some(&"list") {
        match (
            t.get(2).and_then(|s| Ty::parse(s)),
            t.get(3).and_then(|s| Ty::parse(s)),
            t.get(4),
        ) {
            (Some(c), Some(ty), Some(n)) => Ok(Property {
                name: n.to_string(),
                list: Some(c),
                ty,
            }),
            _ => Err("bad list property"),
        }
    } else {
        match (t.get(1).and_then(|s| Ty::parse(s)), t.get(2)) {
            (Some(ty), Some(n)) => Ok(Property {
                name: n.to_string(),
                list: None,
                ty,
            }),
            _ => Err("bad property"),
        }
    }
}

/// The fewest bytes one record of `el` can take in the body: binary values (a list at least its
/// count), or ASCII tokens of one character and a separator each.
fn min_record_bytes(el: &Element, format: Format) -> u64 {
    el.props
        .iter()
        .map(|p| match (format, p.list) {
            (Format::Ascii, _) => 2,
            (_, Some(ct)) => ct.size() as u64,
            (_, None) => p.ty.size() as u64,
        })
        .sum()
}

/// Refuses header counts the file cannot hold (a 100-byte file declaring 10^12 vertices) and
/// meshes over the memory budget, before reading the body: the arrays then never grow past
/// what was checked. Faces count as one triangle each here (a polygon adds more as it is read,
/// bounded by the bytes of its list, and the loaded mesh is reserved in full by the loader).
fn check_counts(header: &Header, data: &[u8], budget: &Budget) -> std::result::Result<(), String> {
    let len = data.len();
    let mut left = (len - header.body_start.min(len)) as u64;
    // The last ASCII token needs no separator after it.
    if header.format == Format::Ascii {
        left += 1;
    }
    let (mut verts, mut faces, mut vert_bytes, mut face_bytes) = (0u64, 0u64, 12u64, 12u64);
    for el in &header.elements {
        let need = bytes_of(&[el.count as u64, min_record_bytes(el, header.format)]);
        if need > left {
            let start = Body {
                data,
                pos: header.body_start,
                format: header.format,
            };
            return Err(format!(
                "{} (element `{}`: the header declares {} records of at least {} bytes, but at \
                 most {left} bytes of the body are left for them)",
                start.position(),
                el.name,
                el.count,
                min_record_bytes(el, header.format)
            ));
        }
        left -= need;
        // Every scalar property is kept as one f32: positions, normals and uvs, and the others
        // as mesh attributes (`ply_attributes`).
        let scalars = el.props.iter().filter(|p| p.list.is_none()).count() as u64;
        match el.name.as_str() {
            "vertex" => {
                verts = el.count as u64;
                vert_bytes = (4 * scalars).max(12);
            }
            "face" => {
                faces = el.count as u64;
                face_bytes = 12 + 4 * scalars;
            }
            _ => {}
        }
    }
    let keep = bytes_of(&[verts, vert_bytes]).saturating_add(bytes_of(&[faces, face_bytes]));
    budget.check(keep, &format!("mesh of {verts} vertices and {faces} faces"))
}

/// The mesh being read, element by element.
#[derive(Default)]
struct MeshData {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    uvs: Vec<Vec2>,
    indices: Vec<[u32; 3]>,
    /// Whether the (last) vertex element has `nx ny nz`, resp. a uv pair.
    have_n: bool,
    have_uv: bool,
    have_faces: bool,
    /// Extra vertex and face properties as Mitsuba's mesh attributes, and the warnings Mitsuba
    /// gives about the properties it skips.
    attributes: Vec<Attribute>,
    warnings: Vec<String>,
}

/// The attributes `groups` of an element (see [`ply_attributes::group`]), empty, with the value
/// conversion of each of their properties.
fn new_attributes(
    el: &Element,
    per: Per,
    groups: Vec<ply_attributes::Group>,
    props: &[usize],
) -> Vec<(Attribute, Vec<(usize, ValueKind)>)> {
    groups
        .into_iter()
        .map(|g| {
            let fields = g
                .fields
                .iter()
                .map(|&f| (props[f], el.props[props[f]].ty.value_kind()))
                .collect();
            let a = Attribute {
                name: g.name,
                per,
                dim: g.fields.len(),
                data: Vec::new(),
            };
            (a, fields)
        })
        .collect()
}

/// The extra properties of element `el` (its non-list properties `props`, named `names`) that
/// become attributes `kind`… (`vertex_` / `face_`), with Mitsuba's warnings added to `mesh`.
fn element_attributes(
    mesh: &mut MeshData,
    el: &Element,
    kind: &str,
    per: Per,
    names: &[&str],
    props: &[usize],
    reserved: &[&str],
) -> Vec<(Attribute, Vec<(usize, ValueKind)>)> {
    let is_float: Vec<bool> = props
        .iter()
        .map(|&k| el.props[k].ty.value_kind() == ValueKind::Float)
        .collect();
    let (groups, warnings) = ply_attributes::group(kind, names, &is_float, reserved);
    mesh.warnings.extend(warnings);
    new_attributes(el, per, groups, props)
}

/// `element NAME i: message`, the position of a body error.
fn at(el: &Element, i: usize, m: String) -> String {
    format!("element `{}` {i}: {m}", el.name)
}

/// Reads the `vertex` element: positions, and normals and uvs when it has them.
fn read_vertices(
    body: &mut Body,
    el: &Element,
    mesh: &mut MeshData,
) -> std::result::Result<(), String> {
    let find = |name: &str| {
        el.props
            .iter()
            .position(|p| p.list.is_none() && p.name == name)
    };
    let (Some(ix), Some(iy), Some(iz)) = (find("x"), find("y"), find("z")) else {
        return Err("vertex element lacks x, y or z".into());
    };
    let nrm = match (find("nx"), find("ny"), find("nz")) {
        (Some(a), Some(b), Some(c)) => Some((a, b, c)),
        _ => None,
    };
    let uvp = [("u", "v"), ("texture_u", "texture_v"), ("s", "t")]
        .iter()
        .find_map(|(a, b)| Some((find(a)?, find(b)?)));
    mesh.have_n = nrm.is_some();
    mesh.have_uv = uvp.is_some();
    // Mitsuba's attribute names see the uv pair renamed to `u v`.
    let props: Vec<usize> = (0..el.props.len())
        .filter(|&k| el.props[k].list.is_none())
        .collect();
    let names: Vec<&str> = props
        .iter()
        .map(|&k| match uvp {
            Some((a, _)) if a == k => "u",
            Some((_, b)) if b == k => "v",
            _ => el.props[k].name.as_str(),
        })
        .collect();
    let reserved = ["x", "y", "z", "nx", "ny", "nz", "u", "v"];
    let mut attrs = element_attributes(mesh, el, "vertex_", Per::Vertex, &names, &props, &reserved);
    let mut vals = vec![0.0f64; el.props.len()];
    for i in 0..el.count {
        for (k, p) in el.props.iter().enumerate() {
            if p.list.is_some() {
                body.skip(p).map_err(|m| at(el, i, m))?;
            } else {
                vals[k] = body.read(p.ty).map_err(|m| at(el, i, m))?;
            }
        }
        let v3 = |a: usize, b: usize, c: usize| {
            Vec3::new(vals[a] as f32, vals[b] as f32, vals[c] as f32)
        };
        mesh.positions.push(v3(ix, iy, iz));
        if let Some((a, b, c)) = nrm {
            mesh.normals.push(v3(a, b, c).normalize_or_zero());
        }
        if let Some((a, b)) = uvp {
            mesh.uvs.push(Vec2::new(vals[a] as f32, vals[b] as f32));
        }
        for (a, fields) in &mut attrs {
            a.data
                .extend(fields.iter().map(|&(k, conv)| conv.convert(vals[k])));
        }
    }
    mesh.attributes.extend(attrs.into_iter().map(|(a, _)| a));
    Ok(())
}

/// Reads the `face` element: each `vertex_indices` polygon, fan-triangulated.
fn read_faces(
    body: &mut Body,
    el: &Element,
    mesh: &mut MeshData,
) -> std::result::Result<(), String> {
    let li = el
        .props
        .iter()
        .position(|p| p.list.is_some() && (p.name == "vertex_indices" || p.name == "vertex_index"))
        .ok_or("face element lacks a vertex_indices list")?;
    mesh.have_faces = true;
    let props: Vec<usize> = (0..el.props.len())
        .filter(|&k| el.props[k].list.is_none())
        .collect();
    let names: Vec<&str> = props.iter().map(|&k| el.props[k].name.as_str()).collect();
    let mut attrs = element_attributes(mesh, el, "face_", Per::Face, &names, &props, &[]);
    let mut vals = vec![0.0f64; el.props.len()];
    let mut poly: Vec<u32> = Vec::new();
    for i in 0..el.count {
        let first = mesh.indices.len();
        for (k, p) in el.props.iter().enumerate() {
            match p.list {
                Some(ct) if k == li => {
                    let n = body.read(ct).map_err(|m| at(el, i, m))?;
                    poly.clear();
                    for _ in 0..n as usize {
                        let v = body.read(p.ty).map_err(|m| at(el, i, m))?;
                        if !(v >= 0.0 && v < u32::MAX as f64) || v.fract() != 0.0 {
                            return Err(at(el, i, format!("bad vertex index {v}")));
                        }
                        poly.push(v as u32);
                    }
                    if poly.len() < 3 {
                        return Err(at(el, i, format!("face with {} vertices", poly.len())));
                    }
                    for j in 1..poly.len() - 1 {
                        mesh.indices.push([poly[0], poly[j], poly[j + 1]]);
                    }
                }
                None => vals[k] = body.read(p.ty).map_err(|m| at(el, i, m))?,
                _ => body.skip(p).map_err(|m| at(el, i, m))?,
            }
        }
        // A polygon's face attributes hold for each triangle it was split into.
        for _ in first..mesh.indices.len() {
            for (a, fields) in &mut attrs {
                a.data
                    .extend(fields.iter().map(|&(k, conv)| conv.convert(vals[k])));
            }
        }
    }
    mesh.attributes.extend(attrs.into_iter().map(|(a, _)| a));
    Ok(())
}

/// Reads and discards an element groove does not use (colours, materials, edges...).
fn skip_element(body: &mut Body, el: &Element) -> std::result::Result<(), String> {
    if el.props.is_empty() {
        // Records without properties take no bytes (and a count of 10^18 must not loop).
        return Ok(());
    }
    for i in 0..el.count {
        for p in &el.props {
            body.skip(p).map_err(|m| at(el, i, m))?;
        }
    }
    Ok(())
}

/// Loads a PLY file into an untransformed [`TriMesh`].
pub fn load_ply(path: &Path) -> Result<TriMesh> {
    load_ply_within(path, &Budget::default())
}

/// [`load_ply`] of a regular file whose size fits `budget`.
pub fn load_ply_within(path: &Path, budget: &Budget) -> Result<TriMesh> {
    let data = crate::inputs::read_regular(path, budget)?;
    parse_ply_within(&data, budget).map_err(|m| Error::file(path, m))
}

/// Parses PLY bytes under the default [`Budget`]; errors are plain messages (the caller adds
/// the file name).
pub fn parse_ply(data: &[u8]) -> std::result::Result<TriMesh, String> {
    parse_ply_within(data, &Budget::default())
}

/// [`parse_ply`] whose header counts are checked before any array grows: each element's records
/// must fit in the bytes after the header, and the mesh they declare must fit `budget`.
pub fn parse_ply_within(data: &[u8], budget: &Budget) -> std::result::Result<TriMesh, String> {
    parse_ply_attributed_within(data, budget).map(|p| p.mesh)
}

/// A PLY mesh with its extra properties as Mitsuba's mesh attributes.
#[derive(Clone, Debug)]
pub struct PlyMesh {
    pub mesh: TriMesh,
    /// `vertex_…` attributes (a value set per vertex) and `face_…` ones (per triangle).
    pub attributes: Vec<Attribute>,
    /// What Mitsuba warns about: skipped properties, integer colours.
    pub warnings: Vec<String>,
}

/// [`load_ply_within`] keeping the extra properties as mesh attributes.
pub fn load_ply_attributed_within(path: &Path, budget: &Budget) -> Result<PlyMesh> {
    let data = crate::inputs::read_regular(path, budget)?;
    parse_ply_attributed_within(&data, budget).map_err(|m| Error::file(path, m))
}

/// [`parse_ply`] keeping the extra properties as mesh attributes.
pub fn parse_ply_attributed(data: &[u8]) -> std::result::Result<PlyMesh, String> {
    parse_ply_attributed_within(data, &Budget::default())
}

/// [`parse_ply_within`] keeping the extra properties as mesh attributes.
pub fn parse_ply_attributed_within(
    data: &[u8],
    budget: &Budget,
) -> std::result::Result<PlyMesh, String> {
    let header = parse_header(data)?;
    check_counts(&header, data, budget)?;
    let mut body = Body {
        data,
        pos: header.body_start,
        format: header.format,
    };
    let mut mesh = MeshData::default();
    for el in &header.elements {
        let read = match el.name.as_str() {
            "vertex" => read_vertices(&mut body, el, &mut mesh),
            "face" => read_faces(&mut body, el, &mut mesh),
            _ => skip_element(&mut body, el),
        };
        read.map_err(|m| format!("{} ({m})", body.position()))?;
    }
    if !mesh.have_faces {
        return Err("no face element".into());
    }
    let (nv, nf) = (mesh.positions.len(), mesh.indices.len());
    for (i, a) in mesh.attributes.iter().enumerate() {
        if mesh.attributes[..i].iter().any(|b| b.name == a.name) {
            // Mitsuba's `add_attribute` refuses a second attribute of one name.
            return Err(format!("attribute {} already exists", a.name));
        }
        let count = match a.per {
            Per::Vertex => nv,
            Per::Face => nf,
        };
        if a.data.len() != count * a.dim {
            return Err(format!(
                "attribute {} has {} values for {count} elements of {}",
                a.name,
                a.data.len(),
                a.dim
            ));
        }
    }
    let tri = TriMesh {
        positions: mesh.positions,
        normals: mesh.have_n.then_some(mesh.normals),
        uvs: mesh.have_uv.then_some(mesh.uvs),
        indices: mesh.indices,
    };
    tri.validate()?;
    Ok(PlyMesh {
        mesh: tri,
        attributes: mesh.attributes,
        warnings: mesh.warnings,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ascii_quad_with_extra_element_and_properties() {
        let s = "ply\nformat ascii 1.0\ncomment hi\nelement vertex 4\nproperty float x\n\
                 property float y\nproperty float z\nproperty uchar red\nproperty float s\nproperty float t\n\
                 element face 1\nproperty list uchar int vertex_index\nproperty int flags\n\
                 element edge 1\nproperty int a\nproperty int b\nend_header\n\
                 0 0 0 255 0 0\n1 0 0 0 1 0\n1 1 0 0 1 1\n0 1 0 0 0 1\n4 0 1 2 3 7\n0 1\n";
        let m = parse_ply(s.as_bytes()).unwrap();
        assert_eq!(m.indices, vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.uvs.unwrap()[2], Vec2::new(1.0, 1.0));
        assert!(m.normals.is_none());
    }

    #[test]
    fn index_out_of_range_and_garbage() {
        let s = "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
                 property float z\nelement face 1\nproperty list uchar uint vertex_indices\nend_header\n\
                 0 0 0\n1 0 0\n0 1 0\n3 0 1 3\n";
        assert!(parse_ply(s.as_bytes()).unwrap_err().contains("index 3"));
        assert!(parse_ply(b"plx\n").is_err());
    }
}
