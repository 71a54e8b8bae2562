//! Loading a Mitsuba XML scene file into an IR of [`Node`]s that remember where they came from.
//!
//! The pipeline per file: quick-xml events → raw tree (with exact line/column of every element and
//! attribute) → per-file version upgrade ([`super::upgrade`]) → tag/attribute validation →
//! `$param` substitution, `<default>`, `<include>` and `<path>` processing in document order (as
//! Mitsuba 3's parser does) → duplicate-id check → unused `-D` check.

use std::collections::HashMap;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::rc::Rc;

use quick_xml::events::Event;
use quick_xml::Reader;

use super::decode::decode_text;
use super::ir::{Attr, Document, Node, PLUGIN_TAGS};
use super::upgrade;
use crate::budget::Budget;
use crate::error::{Error, Result, SourceLoc};

/// Deepest element nesting accepted, in one file and after includes are spliced in. Real
/// scenes nest about ten deep; the limit keeps every recursive walk of the tree (validation,
/// substitution, the loader, `Drop`) far from the stack's end.
pub const MAX_DEPTH: usize = 128;
/// Longest chain of files including each other.
pub const MAX_INCLUDE_DEPTH: usize = 32;
/// What one element of the expanded tree costs in memory (the node, its attributes, their
/// strings and the file names of their locations), for the budget: ~150 bytes measured on
/// small elements (peak RSS over element count), with a margin for longer values.
const ELEMENT_BYTES: u64 = 256;
/// Most elements a scene may expand to with its includes spliced in, whatever the memory limit:
/// a hand-written or exported scene has well under a million; an include graph that repeats a
/// file at every level grows exponentially and is stopped here within seconds.
pub const MAX_ELEMENTS: u64 = 8_000_000;

/// Loads a scene file with the `-D key=value` definitions `defines` (a repeated key: the last
/// one wins), with the default memory budget.
pub fn load_file(path: &Path, defines: &[(String, String)]) -> Result<Document> {
    load_file_within(path, defines, &Budget::default())
}

/// [`load_file`] whose file reads and expanded tree are checked against `budget`.
pub fn load_file_within(
    path: &Path,
    defines: &[(String, String)],
    budget: &Budget,
) -> Result<Document> {
    let bytes = crate::inputs::read_regular(path, budget)?;
    let text = decode_text(&bytes, path)?;
    load_str_within(&text, path, defines, budget)
}

/// Loads a scene from a string as if it were the file `virtual_path`; includes and `<path>`
/// entries resolve relative to `virtual_path`'s folder.
pub fn load_str(text: &str, virtual_path: &Path, defines: &[(String, String)]) -> Result<Document> {
    load_str_within(text, virtual_path, defines, &Budget::default())
}

/// [`load_str`] whose includes and expanded tree are checked against `budget`.
pub fn load_str_within(
    text: &str,
    virtual_path: &Path,
    defines: &[(String, String)],
    budget: &Budget,
) -> Result<Document> {
    let raw = parse_tree(text, virtual_path)?;
    if raw.tag != "scene" {
        return Err(Error::scene(
            &raw.loc,
            format!("root element must be <scene>, found <{}>", raw.tag),
        ));
    }
    let version = match raw.attr("version") {
        Some(v) => parse_version(v, raw.attr_loc("version"))?,
        None => return Err(Error::scene(
            &raw.loc,
            "missing version attribute in root element <scene> (e.g. <scene version=\"3.0.0\">)",
        )),
    };
    let mut warnings = Vec::new();
    let mut raw = raw;
    let old = version < (2, 0, 0);
    if old {
        upgrade::upgrade_tree(&mut raw, &mut warnings);
    }
    validate(&raw, None)?;

    let dir = parent_dir(virtual_path);
    let mut ctx = Ctx {
        params: Vec::new(),
        include_stack: vec![canonical(virtual_path)],
        search_paths: vec![dir],
        warnings,
        parsed: HashMap::new(),
        counted: HashMap::new(),
        resolved: HashMap::new(),
        files: vec![virtual_path.to_path_buf()],
        elements: 1,
        budget: budget.clone(),
    };
    // A repeated -D key: the last one wins.
    for (k, v) in defines {
        if let Some(p) = ctx.params.iter_mut().find(|p| &p.name == k) {
            p.value = v.clone();
        } else {
            ctx.params.push(Param {
                name: k.clone(),
                value: v.clone(),
                used: false,
            });
        }
    }
    // Mitsuba substitutes longest names first so that `$spp_max` is not read as `$spp` + "_max".
    ctx.sort_params();
    substitute_attrs(&mut raw, &mut ctx.params)?;
    let children = std::mem::take(&mut raw.children);
    raw.children = process_children(children, &mut ctx, 1)?;
    budget
        .reserve(ctx.elements * ELEMENT_BYTES, "the scene's XML elements")
        .map_err(|m| Error::scene(&raw.loc, m))?;

    let mut ids: HashMap<String, SourceLoc> = HashMap::new();
    check_ids(&raw, &mut ids)?;
    super::transform::non_unit_rotations(&raw, &mut ctx.warnings);

    if let Some(p) = ctx.params.iter().find(|p| !p.used) {
        return Err(Error::scene(
            &raw.loc,
            format!("unused -D value '{}' (no <default> or $ use of it)", p.name),
        ));
    }

    Ok(Document {
        root: raw,
        version,
        search_paths: ctx.search_paths,
        warnings: ctx.warnings,
        upgraded_from_v0: old,
        files: ctx.files,
        read: Default::default(),
    })
}

// ---------------------------------------------------------------------------------------------
// Raw parsing

/// Byte offset → 1-based line and column (columns count characters).
struct LineIndex<'t> {
    text: &'t str,
    starts: Vec<usize>,
}

impl<'t> LineIndex<'t> {
    fn new(text: &'t str) -> Self {
        let mut starts = vec![0];
        starts.extend(
            text.bytes()
                .enumerate()
                .filter(|&(_, b)| b == b'\n')
                .map(|(i, _)| i + 1),
        );
        LineIndex { text, starts }
    }

    fn loc(&self, file: &Path, off: usize) -> SourceLoc {
        let off = off.min(self.text.len());
        let line = self.starts.partition_point(|&s| s <= off).max(1) - 1;
        let start = self.starts[line];
        let col = self
            .text
            .get(start..off)
            .map(|s| s.chars().count())
            .unwrap_or(off - start);
        SourceLoc::new(file, (line + 1) as u32, (col + 1) as u32)
    }
}

/// Parses one file's text into a raw element tree (no substitution, no upgrade).
pub(crate) fn parse_tree(text: &str, file: &Path) -> Result<Node> {
    // A UTF-8 byte-order mark (written by some Windows exporters) is not part of the document
    // (Mitsuba's pugixml skips it too). Columns on the first line count from after it.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let idx = LineIndex::new(text);
    let mut reader = Reader::from_str(text);
    reader.config_mut().trim_text(false);
    let mut stack: Vec<Node> = Vec::new();
    let mut root: Option<Node> = None;
    loop {
        let pos = reader.buffer_position() as usize;
        let ev = reader.read_event().map_err(|e| {
            Error::scene(
                &idx.loc(file, reader.error_position() as usize),
                format!("malformed XML: {e}"),
            )
        })?;
        match ev {
            Event::Start(ref e) | Event::Empty(ref e) => {
                let empty = matches!(ev, Event::Empty(_));
                let loc = idx.loc(file, pos);
                let tag = std::str::from_utf8(e.name().as_ref())
                    .map_err(|_| Error::scene(&loc, "element name is not valid UTF-8"))?
                    .to_string();
                let content_start = pos + 1;
                let content_end = content_start + e.len();
                let attrs = scan_attrs(
                    text,
                    content_start + tag.len(),
                    content_end.min(text.len()),
                    &idx,
                    file,
                    &tag,
                )?;
                let node = Node {
                    tag,
                    attrs,
                    children: Vec::new(),
                    loc,
                };
                if stack.len() >= MAX_DEPTH {
                    return Err(Error::scene(
                        &node.loc,
                        format!("elements nest more than {MAX_DEPTH} deep"),
                    ));
                }
                if empty {
                    attach(node, &mut stack, &mut root)?;
                } else {
                    stack.push(node);
                }
            }
            Event::End(_) => {
                // quick-xml checks that the end name matches.
                if let Some(node) = stack.pop() {
                    attach(node, &mut stack, &mut root)?;
                }
            }
            Event::Text(t) => {
                if !t.iter().all(|b| b.is_ascii_whitespace()) {
                    let lead = t.iter().take_while(|b| b.is_ascii_whitespace()).count();
                    return Err(Error::scene(
                        &idx.loc(file, pos + lead),
                        "unexpected text content (values go into attributes)",
                    ));
                }
            }
            Event::CData(_) => {
                return Err(Error::scene(
                    &idx.loc(file, pos),
                    "unexpected CDATA content",
                ));
            }
            Event::Comment(_) | Event::Decl(_) | Event::PI(_) | Event::DocType(_) => {}
            Event::Eof => break,
        }
    }
    if let Some(open) = stack.last() {
        return Err(Error::scene(
            &open.loc,
            format!("malformed XML: element <{}> is never closed", open.tag),
        ));
    }
    root.ok_or_else(|| Error::scene(&SourceLoc::new(file, 1, 1), "no root element"))
}

fn attach(node: Node, stack: &mut [Node], root: &mut Option<Node>) -> Result<()> {
    if let Some(parent) = stack.last_mut() {
        parent.children.push(node);
        Ok(())
    } else if root.is_some() {
        Err(Error::scene(
            &node.loc,
            format!("malformed XML: second root element <{}>", node.tag),
        ))
    } else {
        *root = Some(node);
        Ok(())
    }
}

/// Scans `name="value"` pairs in `text[start..end]`, recording each name's position.
fn scan_attrs(
    text: &str,
    mut i: usize,
    end: usize,
    idx: &LineIndex,
    file: &Path,
    tag: &str,
) -> Result<Vec<Attr>> {
    let b = text.as_bytes();
    let mut out: Vec<Attr> = Vec::new();
    let skip_ws = |i: &mut usize| {
        while *i < end && b[*i].is_ascii_whitespace() {
            *i += 1;
        }
    };
    loop {
        skip_ws(&mut i);
        if i >= end {
            break;
        }
        let ns = i;
        while i < end && !b[i].is_ascii_whitespace() && b[i] != b'=' {
            i += 1;
        }
        let name = &text[ns..i];
        let loc = idx.loc(file, ns);
        skip_ws(&mut i);
        if i >= end || b[i] != b'=' {
            return Err(Error::scene(
                &loc,
                format!("malformed XML: attribute '{name}' on <{tag}> has no value"),
            ));
        }
        i += 1;
        skip_ws(&mut i);
        if i >= end || (b[i] != b'"' && b[i] != b'\'') {
            return Err(Error::scene(
                &idx.loc(file, i),
                format!("malformed XML: value of attribute '{name}' must be quoted"),
            ));
        }
        let q = b[i];
        i += 1;
        let vs = i;
        while i < end && b[i] != q {
            i += 1;
        }
        if i >= end {
            return Err(Error::scene(
                &loc,
                format!("malformed XML: unterminated value of attribute '{name}'"),
            ));
        }
        let raw = &text[vs..i];
        i += 1;
        let value = quick_xml::escape::unescape(raw)
            .map_err(|e| Error::scene(&loc, format!("malformed XML in attribute '{name}': {e}")))?
            .into_owned();
        if let Some(prev) = out.iter().find(|a| a.name == name) {
            return Err(Error::scene(
                &loc,
                format!(
                    "malformed XML: duplicate attribute '{name}' on <{tag}> (first at {})",
                    prev.loc
                ),
            ));
        }
        out.push(Attr {
            name: name.to_string(),
            value,
            loc,
        });
    }
    Ok(out)
}

fn parse_version(v: &str, loc: &SourceLoc) -> Result<(u32, u32, u32)> {
    let parts: Vec<&str> = v.trim().split('.').collect();
    let bad = || Error::scene(loc, format!("could not parse version number '{v}'"));
    if parts.is_empty() || parts.len() > 3 {
        return Err(bad());
    }
    let mut n = [0u32; 3];
    for (k, p) in parts.iter().enumerate() {
        n[k] = p.trim().parse().map_err(|_| bad())?;
    }
    Ok((n[0], n[1], n[2]))
}

// ---------------------------------------------------------------------------------------------
// Validation

const TRANSFORM_OPS: &[&str] = &["translate", "rotate", "scale", "matrix", "lookat"];

fn allowed_attrs(tag: &str) -> Option<&'static [&'static str]> {
    Some(match tag {
        "scene" => &["version"],
        "float" | "integer" | "boolean" | "string" | "rgb" | "spectrum" => &["name", "value"],
        "point" | "vector" => &["name", "value", "x", "y", "z"],
        "translate" | "scale" => &["x", "y", "z", "value"],
        "rotate" => &["x", "y", "z", "angle", "value"],
        "matrix" => &["value"],
        "lookat" => &["origin", "target", "up"],
        "transform" => &["name"],
        "ref" => &["id", "name"],
        "include" => &["filename"],
        "default" => &["name", "value"],
        "path" => &["value"],
        t if PLUGIN_TAGS.contains(&t) => &["type", "id", "name"],
        _ => return None,
    })
}

fn required_attrs(tag: &str) -> &'static [&'static str] {
    match tag {
        "float" | "integer" | "boolean" | "string" | "rgb" | "spectrum" => &["name", "value"],
        "point" | "vector" | "transform" => &["name"],
        "matrix" | "path" => &["value"],
        "lookat" => &["origin", "target"],
        "ref" => &["id"],
        "include" => &["filename"],
        "default" => &["name", "value"],
        t if PLUGIN_TAGS.contains(&t) => &["type"],
        _ => &[],
    }
}

/// Checks tags, attributes and nesting of one file's (upgraded) raw tree.
fn validate(node: &Node, parent: Option<&str>) -> Result<()> {
    let tag = node.tag.as_str();
    let Some(allowed) = allowed_attrs(tag) else {
        let hint = if tag == "lookAt" {
            " (Mitsuba 3 spells it <lookat>; <lookAt> is only accepted in files with version < 2.0)"
        } else {
            ""
        };
        return Err(Error::scene(
            &node.loc,
            format!("unknown tag <{tag}>{hint}"),
        ));
    };
    for a in &node.attrs {
        if !allowed.contains(&a.name.as_str()) {
            // Mitsuba's spectrum plugins (`<spectrum type="blackbody">`, `regular`, ...) and
            // `.spd` files: say what groove takes instead.
            let hint = if tag == "spectrum" && (a.name == "type" || a.name == "filename") {
                " (spectrum plugins and spectrum files are not supported by groove: give \
                 wavelength:value pairs, one value, or an <rgb>)"
            } else {
                ""
            };
            return Err(Error::scene(
                &a.loc,
                format!("unknown attribute '{}' on <{tag}>{hint}", a.name),
            ));
        }
    }
    for r in required_attrs(tag) {
        if node.attr(r).is_none() {
            return Err(Error::scene(
                &node.loc,
                format!("<{tag}> needs a '{r}' attribute"),
            ));
        }
    }
    let is_op = TRANSFORM_OPS.contains(&tag);
    match parent {
        None if tag != "scene" => {
            return Err(Error::scene(&node.loc, "root element must be <scene>"))
        }
        Some(_) if tag == "scene" => {
            return Err(Error::scene(
                &node.loc,
                "<scene> can only be the root element",
            ))
        }
        Some("transform") if !is_op => {
            return Err(Error::scene(
                &node.loc,
                format!("<transform> can only contain transform operations, not <{tag}>"),
            ))
        }
        Some(p) if is_op && p != "transform" => {
            return Err(Error::scene(
                &node.loc,
                format!("<{tag}> can only occur inside a <transform>"),
            ))
        }
        Some(p) if p != "transform" && !PLUGIN_TAGS.contains(&p) && p != "scene" => {
            return Err(Error::scene(
                &node.loc,
                format!("<{tag}> cannot occur inside <{p}>"),
            ))
        }
        _ => {}
    }
    if matches!(tag, "path") && parent != Some("scene") {
        return Err(Error::scene(
            &node.loc,
            "<path> can only be a child of the root <scene>",
        ));
    }
    for c in &node.children {
        validate(c, Some(tag))?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// Parameters, includes, paths

struct Param {
    name: String,
    value: String,
    used: bool,
}

struct Ctx {
    params: Vec<Param>,
    include_stack: Vec<PathBuf>,
    search_paths: Vec<PathBuf>,
    warnings: Vec<String>,
    /// Every included file, parsed, upgraded and validated once (by canonical path): a file
    /// included many times is spliced again without being read again.
    parsed: HashMap<OsString, Rc<Vec<Node>>>,
    /// [`file_elements`] of each included file (by canonical path and the number of search
    /// folders known, which decides how its own includes resolve).
    counted: HashMap<(OsString, usize), Option<u64>>,
    /// Include lookups done: (including folder, file name, search paths known) → (path found,
    /// canonical path).
    resolved: HashMap<(OsString, String, usize), (PathBuf, PathBuf)>,
    /// The scene file and every file it includes, in order of first use.
    files: Vec<PathBuf>,
    /// Elements of the expanded tree so far (checked against the budget as they grow).
    elements: u64,
    budget: Budget,
}

impl Ctx {
    fn sort_params(&mut self) {
        self.params
            .sort_by(|a, b| b.name.len().cmp(&a.name.len()).then(a.name.cmp(&b.name)));
    }
}

/// Replaces `$name` in every attribute value of `node` (not its children), marking the
/// parameters used. `params` is sorted longest name first. Any `$` left over is an undefined
/// parameter (Mitsuba 3: "undefined parameter(s) in string").
fn substitute_attrs(node: &mut Node, params: &mut [Param]) -> Result<()> {
    for a in &mut node.attrs {
        if !a.value.contains('$') {
            continue;
        }
        let mut v = a.value.clone();
        for p in params.iter_mut() {
            let pat = format!("${}", p.name);
            if v.contains(&pat) {
                v = v.replace(&pat, &p.value);
                p.used = true;
            }
        }
        if let Some(pos) = v.find('$') {
            let ident: String = v[pos + 1..]
                .chars()
                .take_while(|c| c.is_alphanumeric() || *c == '_')
                .collect();
            return Err(Error::scene(
                &a.loc,
                format!(
                    "undefined parameter '${ident}' in attribute '{}' (define it with <default name=\"{ident}\" value=\"...\"/> or -D {ident}=...)",
                    a.name
                ),
            ));
        }
        a.value = v;
    }
    Ok(())
}

/// Processes the children of an element at nesting `depth` (the root's children are at 1).
fn process_children(children: Vec<Node>, ctx: &mut Ctx, depth: usize) -> Result<Vec<Node>> {
    let mut out = Vec::with_capacity(children.len());
    for mut child in children {
        if depth >= MAX_DEPTH {
            return Err(Error::scene(
                &child.loc,
                format!("elements nest more than {MAX_DEPTH} deep (with includes spliced in)"),
            ));
        }
        ctx.elements += 1;
        if ctx.elements > MAX_ELEMENTS {
            return Err(Error::scene(&child.loc, too_many_elements()));
        }
        if ctx.elements.is_multiple_of(4096) {
            ctx.budget
                .check(
                    ctx.elements * ELEMENT_BYTES,
                    &format!(
                        "the scene's XML ({} elements with includes spliced in)",
                        ctx.elements
                    ),
                )
                .map_err(|m| Error::scene(&child.loc, m))?;
        }
        substitute_attrs(&mut child, &mut ctx.params)?;
        match child.tag.as_str() {
            "default" => {
                let name = child.attr("name").unwrap_or_default().to_string();
                let value = child.attr("value").unwrap_or_default().to_string();
                if name.is_empty() || name.contains(',') || name.contains('$') {
                    return Err(Error::scene(
                        child.attr_loc("name"),
                        format!("invalid parameter name '{name}' in <default>"),
                    ));
                }
                if let Some(p) = ctx.params.iter_mut().find(|p| p.name == name) {
                    // A -D value overrides the default; it counts as used.
                    p.used = true;
                } else {
                    ctx.params.push(Param {
                        name,
                        value,
                        used: true,
                    });
                    ctx.sort_params();
                }
            }
            "path" => {
                let value = child.attr("value").unwrap_or_default();
                let base = parent_dir(&child.loc.file);
                let p = Path::new(value);
                // As Mitsuba 3.9.1 (`parser.cpp`, `<path>`): relative to the folder of the file
                // that holds the `<path>` first, else through the search folders known so far
                // (the main scene's folder, earlier `<path>`s): an included file's
                // `<path value="../../common"/>` may be meant from the main scene's folder.
                let dir = if p.is_absolute() {
                    p.to_path_buf()
                } else {
                    let own = base.join(p);
                    if own.is_dir() {
                        own
                    } else {
                        ctx.search_paths
                            .iter()
                            .map(|d| d.join(p))
                            .find(|d| d.is_dir())
                            .unwrap_or(own)
                    }
                };
                if !dir.is_dir() {
                    return Err(Error::scene(
                        child.attr_loc("value"),
                        format!("<path>: folder '{}' not found", dir.display()),
                    ));
                }
                ctx.search_paths.push(dir);
            }
            "include" => {
                let spliced = include(&child, ctx, depth)?;
                out.extend(spliced);
            }
            _ => {
                let grand = std::mem::take(&mut child.children);
                child.children = process_children(grand, ctx, depth + 1)?;
                out.push(child);
            }
        }
    }
    Ok(out)
}

/// Loads an `<include filename>` at nesting `depth` and returns the nodes to splice in its
/// place. Each file is read and parsed once per load ([`Ctx::parsed`]).
fn include(node: &Node, ctx: &mut Ctx, depth: usize) -> Result<Vec<Node>> {
    let name = node.attr("filename").unwrap_or_default();
    let loc = node.attr_loc("filename");
    let (path, canon) = resolve(node, ctx)?;
    // Compared as strings: `PathBuf`'s `==` and `Hash` walk components and are slow.
    if ctx
        .include_stack
        .iter()
        .any(|p| p.as_os_str() == canon.as_os_str())
    {
        return Err(Error::scene(
            loc,
            format!(
                "include cycle: '{}' is already being included",
                path.display()
            ),
        ));
    }
    if ctx.include_stack.len() >= MAX_INCLUDE_DEPTH {
        return Err(Error::scene(
            loc,
            format!("includes nest more than {MAX_INCLUDE_DEPTH} files deep"),
        ));
    }
    let nodes = parsed_nodes(&path, &canon, ctx).map_err(|e| match e {
        // Name the include that asked for the file.
        Error::Scene { .. } => e,
        other => Error::scene(loc, format!("cannot include '{name}': {other}")),
    })?;
    // What the include will add, counted on the parsed files before anything is spliced: an
    // include graph that doubles at every level is refused here at once, not after building
    // millions of elements.
    let mut stack = vec![canon.clone()];
    if let Some(n) = file_elements(&canon, &nodes, ctx, &mut stack, depth) {
        let total = ctx.elements.saturating_add(n);
        // Whichever limit the element-by-element expansion would reach first: the memory
        // budget (checked up to the element cap) or the cap.
        let what = format!("the scene's XML ({total} elements with includes spliced in)");
        let bytes = |k: u64| k.saturating_mul(ELEMENT_BYTES);
        if ctx
            .budget
            .check(bytes(total.min(MAX_ELEMENTS + 1)), &what)
            .is_err()
        {
            if let Err(m) = ctx.budget.check(bytes(total), &what) {
                return Err(Error::scene(&node.loc, m));
            }
        }
        if total > MAX_ELEMENTS {
            return Err(Error::scene(&node.loc, too_many_elements()));
        }
    }
    ctx.include_stack.push(canon);
    let res = process_children((*nodes).clone(), ctx, depth);
    ctx.include_stack.pop();
    res
}

/// The error of a scene over [`MAX_ELEMENTS`].
fn too_many_elements() -> String {
    format!(
        "the scene expands to more than {MAX_ELEMENTS} XML elements with its includes spliced in \
         (does an include graph repeat a file at every level?)"
    )
}

/// The file an `<include>` names, as found (relative to the including file's folder, then the
/// search folders) and canonical.
fn resolve(node: &Node, ctx: &mut Ctx) -> Result<(PathBuf, PathBuf)> {
    let name = node.attr("filename").unwrap_or_default();
    let base = parent_dir(&node.loc.file);
    // The same include resolves the same way while no <path> is added: looked up once.
    let key = (
        base.as_os_str().to_os_string(),
        name.to_string(),
        ctx.search_paths.len(),
    );
    if let Some(r) = ctx.resolved.get(&key) {
        return Ok(r.clone());
    }
    let p = Path::new(name);
    let mut candidates = vec![if p.is_absolute() {
        p.to_path_buf()
    } else {
        base.join(p)
    }];
    if !p.is_absolute() {
        candidates.extend(ctx.search_paths.iter().map(|d| d.join(p)));
    }
    let Some(path) = candidates.into_iter().find(|c| c.exists()) else {
        return Err(Error::scene(
            node.attr_loc("filename"),
            format!("included file '{name}' not found"),
        ));
    };
    let canon = canonical(&path);
    ctx.resolved.insert(key, (path.clone(), canon.clone()));
    Ok((path, canon))
}

/// The nodes an included file adds, parsed on first use and kept ([`Ctx::parsed`]).
fn parsed_nodes(path: &Path, canon: &Path, ctx: &mut Ctx) -> Result<Rc<Vec<Node>>> {
    if let Some(nodes) = ctx.parsed.get(canon.as_os_str()) {
        return Ok(nodes.clone());
    }
    let nodes = Rc::new(parse_include(path, ctx)?);
    ctx.files.push(path.to_path_buf());
    ctx.parsed
        .insert(canon.as_os_str().to_os_string(), nodes.clone());
    Ok(nodes)
}

/// How many elements splicing the file `canon` (its parsed `nodes`) adds to the expanded tree,
/// counted as [`process_children`] counts them, from the parsed files alone (memoised in
/// [`Ctx::counted`]). `None` where only the expansion itself can tell: an include whose file
/// name holds a `$`, a `<path>` (later includes may resolve differently), an include that does
/// not resolve or parse (the expansion reports it where it stands), a cycle, or nesting past the
/// limits. `stack` holds the files being counted; `depth` the nesting of `nodes`.
fn file_elements(
    canon: &Path,
    nodes: &[Node],
    ctx: &mut Ctx,
    stack: &mut Vec<PathBuf>,
    depth: usize,
) -> Option<u64> {
    let key = (canon.as_os_str().to_os_string(), ctx.search_paths.len());
    if let Some(&n) = ctx.counted.get(&key) {
        return n;
    }
    let n = count_elements(nodes, ctx, stack, depth);
    ctx.counted.insert(key, n);
    n
}

/// [`file_elements`] of a list of sibling nodes at nesting `depth`.
fn count_elements(
    nodes: &[Node],
    ctx: &mut Ctx,
    stack: &mut Vec<PathBuf>,
    depth: usize,
) -> Option<u64> {
    if depth >= MAX_DEPTH {
        return None;
    }
    let mut n = 0u64;
    for node in nodes {
        n = n.saturating_add(1);
        let inner = match node.tag.as_str() {
            "path" => return None,
            "default" => 0,
            "include" => {
                if node.attr("filename").unwrap_or_default().contains('$')
                    || stack.len() >= MAX_INCLUDE_DEPTH
                {
                    return None;
                }
                let (path, canon) = resolve(node, ctx).ok()?;
                if stack.iter().any(|p| p.as_os_str() == canon.as_os_str()) {
                    return None;
                }
                let inner = parsed_nodes(&path, &canon, ctx).ok()?;
                stack.push(canon.clone());
                let k = file_elements(&canon, &inner, ctx, stack, depth);
                stack.pop();
                k?
            }
            _ => count_elements(&node.children, ctx, stack, depth + 1)?,
        };
        n = n.saturating_add(inner);
    }
    Some(n)
}

/// Reads, parses, upgrades and validates an included file; returns the nodes it adds.
fn parse_include(path: &Path, ctx: &mut Ctx) -> Result<Vec<Node>> {
    let bytes = crate::inputs::read_regular(path, &ctx.budget)?;
    let text = decode_text(&bytes, path)?;
    let mut raw = parse_tree(&text, path)?;
    Ok(if raw.tag == "scene" {
        if let Some(v) = raw.attr("version") {
            // Each file is upgraded according to its own version.
            let version = parse_version(v, raw.attr_loc("version"))?;
            if version < (2, 0, 0) {
                upgrade::upgrade_tree(&mut raw, &mut ctx.warnings);
            }
        }
        validate(&raw, None)?;
        raw.children
    } else {
        // A file holding a single object: validate it as a child of the scene.
        validate(&raw, Some("scene"))?;
        vec![raw]
    })
}

/// Every plugin `id` must be unique across the scene (including included files).
fn check_ids(node: &Node, ids: &mut HashMap<String, SourceLoc>) -> Result<()> {
    if PLUGIN_TAGS.contains(&node.tag.as_str()) {
        if let Some(id) = node.attr("id") {
            let loc = node.attr_loc("id");
            if let Some(first) = ids.get(id) {
                return Err(Error::scene(
                    loc,
                    format!("duplicate id '{id}' (first defined at {first})"),
                ));
            }
            ids.insert(id.to_string(), loc.clone());
        }
    }
    for c in &node.children {
        check_ids(c, ids)?;
    }
    Ok(())
}

fn parent_dir(p: &Path) -> PathBuf {
    match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

fn canonical(p: &Path) -> PathBuf {
    std::fs::canonicalize(p).unwrap_or_else(|_| p.to_path_buf())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load(text: &str) -> Result<Document> {
        load_str(text, Path::new("/virtual/t.xml"), &[])
    }

    #[test]
    fn line_and_column_of_elements_and_attributes() {
        let doc = load("<?xml version=\"1.0\"?>\n<scene version='3.0.0'>\n  <bsdf  type=\"diffuse\" id='a'/>\n</scene>\n").unwrap();
        let b = &doc.root.children[0];
        assert_eq!((b.loc.line, b.loc.col), (3, 3));
        assert_eq!((b.attr_loc("id").line, b.attr_loc("id").col), (3, 25));
        assert_eq!(b.attr("id"), Some("a"));
        assert_eq!(doc.version, (3, 0, 0));
    }

    #[test]
    fn entities_are_unescaped() {
        let doc = load("<scene version=\"3.0.0\"><bsdf type=\"a&amp;b\"/></scene>").unwrap();
        assert_eq!(doc.root.children[0].attr("type"), Some("a&b"));
    }

    #[test]
    fn text_content_is_an_error() {
        let e = load("<scene version=\"3.0.0\">\n hello</scene>").unwrap_err();
        assert!(e.to_string().contains("t.xml:2:2:"), "{e}");
    }
}
