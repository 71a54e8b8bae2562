//! The scene file's intermediate representation: elements ([`Node`]) and attributes ([`Attr`])
//! that remember where they were written, the loaded [`Document`], the element vocabulary
//! ([`PLUGIN_TAGS`], [`PROPERTY_TAGS`]) and the index of ids that `<ref>` resolves against
//! ([`Ids`]). Produced by [`super::parse`]; read by [`super::props`] and the loader.

use std::cell::RefCell;
use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::error::{Error, Result, SourceLoc};

/// One XML element after substitution (and, for old files, after the version upgrade).
#[derive(Clone, Debug, PartialEq)]
pub struct Node {
    /// Element name: "scene", "bsdf", "shape", "float", "rgb", "transform", "ref", ...
    pub tag: String,
    /// Attributes after `$`-substitution, in document order.
    pub attrs: Vec<Attr>,
    pub children: Vec<Node>,
    /// The file the element came from (an included file for spliced elements) and the 1-based
    /// line and column of its `<`.
    pub loc: SourceLoc,
}

/// One attribute; `loc` is the position of the attribute's name.
#[derive(Clone, Debug, PartialEq)]
pub struct Attr {
    pub name: String,
    pub value: String,
    pub loc: SourceLoc,
}

impl Node {
    /// The value of attribute `name`, if present.
    pub fn attr(&self, name: &str) -> Option<&str> {
        self.attrs
            .iter()
            .find(|a| a.name == name)
            .map(|a| a.value.as_str())
    }

    /// Where attribute `name` is written; the element's own location when it is absent.
    pub fn attr_loc(&self, name: &str) -> &SourceLoc {
        self.attrs
            .iter()
            .find(|a| a.name == name)
            .map(|a| &a.loc)
            .unwrap_or(&self.loc)
    }

    /// Sets (or adds) an attribute; a new attribute gets the element's location.
    pub fn set_attr(&mut self, name: &str, value: impl Into<String>) {
        let value = value.into();
        if let Some(a) = self.attrs.iter_mut().find(|a| a.name == name) {
            a.value = value;
        } else {
            self.attrs.push(Attr {
                name: name.to_string(),
                value,
                loc: self.loc.clone(),
            });
        }
    }

    /// A short description for messages: `<bsdf type="dielectric">`, `<float name="x">`.
    pub fn describe(&self) -> String {
        match (self.attr("type"), self.attr("name")) {
            (Some(t), _) => format!("<{} type=\"{}\">", self.tag, t),
            (None, Some(n)) => format!("<{} name=\"{}\">", self.tag, n),
            _ => format!("<{}>", self.tag),
        }
    }
}

/// A loaded scene: the `<scene>` root with includes inlined, defaults/paths consumed.
#[derive(Clone, Debug)]
pub struct Document {
    pub root: Node,
    /// The main file's `version` attribute.
    pub version: (u32, u32, u32),
    /// Resource search folders: the main file's folder first, then `<path>` entries in order.
    pub search_paths: Vec<PathBuf>,
    /// Non-fatal remarks with their locations (`FILE:LINE:COL: message`).
    pub warnings: Vec<String>,
    /// The main file was older than 2.0 and has been upgraded to Mitsuba 3 names (later stages
    /// use this for 0.6 semantics, e.g. of the classic `normalmap`).
    pub upgraded_from_v0: bool,
    /// The scene file and every file it includes.
    pub files: Vec<PathBuf>,
    /// Every resource file [`Document::resolve_file`] has found (meshes, images), in order:
    /// with [`Document::files`], what a render of the document reads.
    pub read: RefCell<Vec<PathBuf>>,
}

impl Document {
    /// Resolves a resource file name: an absolute path must exist; a relative one is looked up
    /// in the search paths in order. A missing file, or one that is not a regular file (a
    /// directory, a FIFO, a device), is an error at `loc` naming the file. The file is
    /// recorded in [`Document::read`].
    pub fn resolve_file(&self, name: &str, loc: &SourceLoc) -> Result<PathBuf> {
        let found = |p: PathBuf| -> Result<PathBuf> {
            crate::inputs::check_regular(&p).map_err(|e| Error::scene(loc, e.to_string()))?;
            self.read.borrow_mut().push(p.clone());
            Ok(p)
        };
        let p = Path::new(name);
        if p.is_absolute() {
            if p.exists() {
                return found(p.to_path_buf());
            }
            return Err(Error::scene(loc, format!("file '{name}' not found")));
        }
        for dir in &self.search_paths {
            let cand = dir.join(p);
            if cand.exists() {
                return found(cand);
            }
        }
        let searched: Vec<String> = self
            .search_paths
            .iter()
            .map(|d| d.display().to_string())
            .collect();
        Err(Error::scene(
            loc,
            format!(
                "file '{name}' not found (searched: {})",
                searched.join(", ")
            ),
        ))
    }
}

/// Plugin (object) element names.
pub const PLUGIN_TAGS: &[&str] = &[
    "bsdf",
    "shape",
    "emitter",
    "texture",
    "sensor",
    "film",
    "sampler",
    "rfilter",
    "integrator",
    "medium",
    "phase",
    "volume",
];

/// Property element names (values of a plugin).
pub const PROPERTY_TAGS: &[&str] = &[
    "float",
    "integer",
    "boolean",
    "string",
    "rgb",
    "spectrum",
    "point",
    "vector",
    "transform",
];

/// Every element of a document that has an `id` (`<ref>`s themselves excluded), for resolving
/// `<ref id>` (ids are unique: the parser checks it).
#[derive(Debug, Default)]
pub struct Ids<'d> {
    map: HashMap<&'d str, &'d Node>,
}

impl<'d> Ids<'d> {
    /// Indexes the descendants of `root`.
    pub fn new(root: &'d Node) -> Ids<'d> {
        fn walk<'d>(n: &'d Node, map: &mut HashMap<&'d str, &'d Node>) {
            for c in &n.children {
                if c.tag != "ref" {
                    if let Some(id) = c.attr("id") {
                        map.insert(id, c);
                    }
                }
                walk(c, map);
            }
        }
        let mut map = HashMap::new();
        walk(root, &mut map);
        Ids { map }
    }

    /// The element named `id`.
    pub fn get(&self, id: &str) -> Option<&'d Node> {
        self.map.get(id).copied()
    }

    /// The tag of an object child, looking through a `<ref>` to its target ("ref" when the id is
    /// unknown).
    pub fn kind<'n>(&self, c: &'n Node) -> &'n str
    where
        'd: 'n,
    {
        if c.tag != "ref" {
            return c.tag.as_str();
        }
        c.attr("id")
            .and_then(|id| self.get(id))
            .map_or("ref", |t| t.tag.as_str())
    }

    /// Follows a `<ref id>` to its target, which must be a `<expect>`; any other element is
    /// returned as it is. An unknown id or a target of another kind is an error at the `<ref>`.
    pub fn resolve(&self, n: &'d Node, expect: &str) -> Result<&'d Node> {
        if n.tag != "ref" {
            return Ok(n);
        }
        let id = n
            .attr("id")
            .ok_or_else(|| Error::scene(&n.loc, "<ref> needs an id"))?;
        let target = self.get(id).ok_or_else(|| {
            Error::scene(n.attr_loc("id"), format!("reference to unknown id '{id}'"))
        })?;
        if target.tag != expect {
            return Err(Error::scene(
                &n.loc,
                format!(
                    "id '{id}' is a <{}>, but a <{expect}> is expected here",
                    target.tag
                ),
            ));
        }
        Ok(target)
    }
}
