//! Typed access to a plugin element's properties, with Mitsuba 3's rule that every property
//! given in the file must be used: [`Props::finish`] reports the first one nobody queried.

use std::cell::{Cell, RefCell};

use glam::{Mat4, Vec3};

pub use super::transform::transform_of;
use super::transform::{transform_full, Transform};

use super::ir::{Ids, Node, PLUGIN_TAGS, PROPERTY_TAGS};
use super::upgrade::camel_case_hint;
use crate::error::{Error, Result, SourceLoc};
use crate::spectrum::{spectrum_list_to_rgb, Spectrum, SpectrumUse};

/// The properties of one plugin element (`<bsdf>`, `<shape>`, ...).
pub struct Props<'a> {
    node: &'a Node,
    /// Property children (`<float>`, `<rgb>`, `<transform>`, ...), in document order.
    props: Vec<&'a Node>,
    used: Vec<Cell<bool>>,
    /// The document's ids, to see through `<ref>`s ([`Props::kind`]); `None`: a `<ref>` is
    /// of kind "ref".
    ids: Option<&'a Ids<'a>>,
    /// Non-fatal remarks (`FILE:LINE:COL: message`), e.g. a clamped out-of-gamut spectrum.
    warnings: RefCell<Vec<String>>,
}

/// Object children: nested plugins and references.
fn is_object_tag(tag: &str) -> bool {
    tag == "ref" || PLUGIN_TAGS.contains(&tag)
}

impl<'a> Props<'a> {
    /// Collects the property children of `node`. Two properties (or a property and a named
    /// object) with the same name are an error at the second one.
    pub fn new(node: &'a Node) -> Result<Props<'a>> {
        Self::build(node, None)
    }

    /// [`Props::new`] that sees through `<ref>`s to their targets with `ids`.
    pub fn with_ids(node: &'a Node, ids: &'a Ids<'a>) -> Result<Props<'a>> {
        Self::build(node, Some(ids))
    }

    fn build(node: &'a Node, ids: Option<&'a Ids<'a>>) -> Result<Props<'a>> {
        let mut props: Vec<&'a Node> = Vec::new();
        let mut names: Vec<(&'a str, &'a SourceLoc)> = Vec::new();
        for c in &node.children {
            let is_prop = PROPERTY_TAGS.contains(&c.tag.as_str());
            if !is_prop && !is_object_tag(&c.tag) {
                return Err(Error::scene(
                    &c.loc,
                    format!("<{}> cannot occur inside {}", c.tag, node.describe()),
                ));
            }
            let name = c.attr("name");
            if is_prop && name.is_none() {
                return Err(Error::scene(
                    &c.loc,
                    format!("<{}> needs a 'name' attribute", c.tag),
                ));
            }
            if let Some(name) = name {
                if let Some((_, first)) = names.iter().find(|(n, _)| *n == name) {
                    return Err(Error::scene(
                        c.attr_loc("name"),
                        format!(
                            "duplicate property '{name}' in {} (first at {first})",
                            node.describe()
                        ),
                    ));
                }
                names.push((name, c.attr_loc("name")));
            }
            if is_prop {
                props.push(c);
            }
        }
        let used = props.iter().map(|_| Cell::new(false)).collect();
        Ok(Props {
            node,
            props,
            used,
            ids,
            warnings: RefCell::new(Vec::new()),
        })
    }

    /// The `type` attribute ("" for `<scene>`).
    pub fn plugin_type(&self) -> &'a str {
        self.node.attr("type").unwrap_or("")
    }
    pub fn id(&self) -> Option<&'a str> {
        self.node.attr("id")
    }
    pub fn loc(&self) -> &'a SourceLoc {
        &self.node.loc
    }
    pub fn tag(&self) -> &'a str {
        &self.node.tag
    }
    pub fn node(&self) -> &'a Node {
        self.node
    }

    /// Takes the warnings collected so far (Mitsuba logs these; groove reports them).
    pub fn take_warnings(&self) -> Vec<String> {
        std::mem::take(&mut *self.warnings.borrow_mut())
    }

    /// Finds a property by name and marks it used.
    fn get(&self, name: &str) -> Option<&'a Node> {
        let i = self
            .props
            .iter()
            .position(|p| p.attr("name") == Some(name))?;
        self.used[i].set(true);
        Some(self.props[i])
    }

    fn wrong_type(&self, p: &Node, want: &str) -> Error {
        Error::scene(
            &p.loc,
            format!(
                "property '{}' of {} is a <{}>, expected {want}",
                p.attr("name").unwrap_or_default(),
                self.node.describe(),
                p.tag
            ),
        )
    }

    /// Does a property or named object `name` exist? Does not mark it used.
    pub fn has(&self, name: &str) -> bool {
        self.node
            .children
            .iter()
            .any(|c| c.attr("name") == Some(name))
    }

    /// A `<float>` or `<integer>` (Mitsuba accepts an integer where a float is expected).
    pub fn float(&self, name: &str, default: f32) -> Result<f32> {
        Ok(self.float_opt(name)?.unwrap_or(default))
    }

    pub fn float_opt(&self, name: &str) -> Result<Option<f32>> {
        let Some(p) = self.get(name) else {
            return Ok(None);
        };
        match p.tag.as_str() {
            "float" | "integer" => {
                let v = parse_f32(value_of(p)?, p.attr_loc("value"))?;
                Ok(Some(v))
            }
            _ => Err(self.wrong_type(p, "<float>")),
        }
    }

    /// An `<integer>` only: "1.5" is an error.
    pub fn int(&self, name: &str, default: i64) -> Result<i64> {
        Ok(self.int_opt(name)?.unwrap_or(default))
    }

    pub fn int_opt(&self, name: &str) -> Result<Option<i64>> {
        let Some(p) = self.get(name) else {
            return Ok(None);
        };
        if p.tag != "integer" {
            return Err(self.wrong_type(p, "<integer>"));
        }
        let text = value_of(p)?;
        text.trim().parse::<i64>().map(Some).map_err(|_| {
            Error::scene(
                p.attr_loc("value"),
                format!("could not parse integer value '{text}'"),
            )
        })
    }

    /// A `<boolean>`: "true" or "false", case-insensitive (Mitsuba 3.9.1 rejects "1"/"0").
    pub fn bool(&self, name: &str, default: bool) -> Result<bool> {
        let Some(p) = self.get(name) else {
            return Ok(default);
        };
        if p.tag != "boolean" {
            return Err(self.wrong_type(p, "<boolean>"));
        }
        let text = value_of(p)?;
        match text.trim().to_ascii_lowercase().as_str() {
            "true" => Ok(true),
            "false" => Ok(false),
            _ => Err(Error::scene(
                p.attr_loc("value"),
                format!("could not parse boolean value '{text}' -- must be 'true' or 'false'"),
            )),
        }
    }

    pub fn string(&self, name: &str, default: &str) -> Result<String> {
        Ok(self
            .string_opt(name)?
            .unwrap_or_else(|| default.to_string()))
    }

    pub fn string_opt(&self, name: &str) -> Result<Option<String>> {
        let Some(p) = self.get(name) else {
            return Ok(None);
        };
        if p.tag != "string" {
            return Err(self.wrong_type(p, "<string>"));
        }
        Ok(Some(value_of(p)?.to_string()))
    }

    /// A `<point>` or `<vector>`: `value="x, y, z"` (or one number for all three), or `x=`, `y=`,
    /// `z=` with missing components 0.
    pub fn point(&self, name: &str, default: Vec3) -> Result<Vec3> {
        Ok(self.point_opt(name)?.unwrap_or(default))
    }

    pub fn point_opt(&self, name: &str) -> Result<Option<Vec3>> {
        let Some(p) = self.get(name) else {
            return Ok(None);
        };
        if p.tag != "point" && p.tag != "vector" {
            return Err(self.wrong_type(p, "<point> or <vector>"));
        }
        Ok(Some(xyz_of(p, 0.0)?))
    }

    /// Same as [`Props::point`]; both tags are accepted for both.
    pub fn vector(&self, name: &str, default: Vec3) -> Result<Vec3> {
        self.point(name, default)
    }

    /// A `<transform>`; identity when absent.
    pub fn transform(&self, name: &str) -> Result<Mat4> {
        Ok(self.transform_opt(name)?.unwrap_or(Mat4::IDENTITY))
    }

    pub fn transform_opt(&self, name: &str) -> Result<Option<Mat4>> {
        Ok(self.transform_full_opt(name)?.map(|t| t.matrix))
    }

    /// A `<transform>` with Mitsuba's inverse transpose (which differs from the true one after a
    /// `<rotate>` with a non-unit axis, see [`super::transform`]); identity when absent.
    pub fn transform_full(&self, name: &str) -> Result<Transform> {
        Ok(self
            .transform_full_opt(name)?
            .unwrap_or(Transform::IDENTITY))
    }

    pub fn transform_full_opt(&self, name: &str) -> Result<Option<Transform>> {
        let Some(p) = self.get(name) else {
            return Ok(None);
        };
        if p.tag != "transform" {
            return Err(self.wrong_type(p, "<transform>"));
        }
        transform_full(p).map(Some)
    }

    /// A colour for a reflectance-like parameter (see [`Props::color_with`]).
    pub fn color(&self, name: &str, default: Spectrum) -> Result<Spectrum> {
        self.color_with(name, default, SpectrumUse::Reflectance)
    }

    pub fn color_opt(&self, name: &str) -> Result<Option<Spectrum>> {
        self.color_opt_with(name, SpectrumUse::Reflectance)
    }

    /// A colour: `<rgb>` (one or three numbers), `<spectrum>` (a constant, or `λ:value` pairs
    /// converted as Mitsuba 3 does for `use_`), or `<float>`/`<integer>` (grey). As in Mitsuba 3,
    /// an `<rgb>` reflectance outside [0, 1] is an error, while a tabulated reflectance spectrum
    /// is clamped to [0, 1].
    pub fn color_with(&self, name: &str, default: Spectrum, use_: SpectrumUse) -> Result<Spectrum> {
        Ok(self.color_opt_with(name, use_)?.unwrap_or(default))
    }

    pub fn color_opt_with(&self, name: &str, use_: SpectrumUse) -> Result<Option<Spectrum>> {
        let Some(p) = self.get(name) else {
            return Ok(None);
        };
        let loc = p.attr_loc("value");
        let text = match p.tag.as_str() {
            "rgb" | "spectrum" | "float" | "integer" => value_of(p)?,
            _ => return Err(self.wrong_type(p, "<rgb> or <spectrum>")),
        };
        match p.tag.as_str() {
            "float" | "integer" => Ok(Some(Spectrum::splat(parse_f32(text, loc)?))),
            "rgb" => {
                let v = parse_list(text, loc)?;
                let c = match v.as_slice() {
                    [g] => Spectrum::splat(*g),
                    [r, g, b] => Spectrum::new(*r, *g, *b),
                    _ => {
                        return Err(Error::scene(
                            loc,
                            format!("<rgb> needs one or three values, got '{text}'"),
                        ))
                    }
                };
                // Mitsuba 3's reflectance texture (`SRGBReflectanceSpectrum`) refuses values
                // outside [0, 1]; unbounded parameters and emitters take any value.
                if use_ == SpectrumUse::Reflectance
                    && (c.min_element() < 0.0 || c.max_element() > 1.0)
                {
                    return Err(Error::scene(
                        loc,
                        format!(
                            "invalid RGB reflectance value '{text}' for '{name}': must be in the range [0, 1]"
                        ),
                    ));
                }
                Ok(Some(c))
            }
            _ => {
                let (c, clamped_from) = spectrum_of(text, loc, use_)?;
                if let Some(orig) = clamped_from {
                    self.warnings.borrow_mut().push(format!(
                        "{loc}: spectrum '{name}' clamped from out-of-gamut RGB {orig} to {c} (as Mitsuba 3 does)"
                    ));
                }
                Ok(Some(c))
            }
        }
    }

    /// All object children (nested plugins and `<ref>`s), in document order. Objects are not
    /// properties: using them is the caller's business.
    pub fn objects(&self) -> impl Iterator<Item = &'a Node> {
        self.node.children.iter().filter(|c| is_object_tag(&c.tag))
    }

    /// The tag of object child `c`, looking through a `<ref>` to its target ("ref" when the id
    /// is unknown, or when these props were made without ids).
    pub fn kind<'n>(&self, c: &'n Node) -> &'n str
    where
        'a: 'n,
    {
        match self.ids {
            Some(ids) => ids.kind(c),
            None => c.tag.as_str(),
        }
    }

    /// The object child of kind `tag` (a nested `<tag>` or a `<ref>` to one, see
    /// [`Props::kind`]), or `None` when there is none. A second one is an error at it: "mask
    /// takes exactly one nested BSDF" inside a `<bsdf>` (whose nested objects of one kind are
    /// each required), "a shape takes only one emitter" elsewhere. Checking that the child
    /// exists, and that no child of another kind is there, is the caller's business.
    pub fn one_child(&self, tag: &str) -> Result<Option<&'a Node>> {
        let mut found = self.objects().filter(|c| self.kind(c) == tag);
        let first = found.next();
        if let Some(second) = found.next() {
            let noun = match tag {
                "bsdf" => "BSDF".to_string(),
                "texture" => "<texture>".to_string(),
                t => t.to_string(),
            };
            let msg = if self.tag() == "bsdf" {
                format!("{} takes exactly one nested {noun}", self.plugin_type())
            } else {
                format!("a {} takes only one {noun}", self.tag())
            };
            return Err(Error::scene(&second.loc, msg));
        }
        Ok(first)
    }

    /// Raw access to the property or named object `name` (marks a property used).
    pub fn property_node(&self, name: &str) -> Option<&'a Node> {
        self.get(name).or_else(|| {
            self.node
                .children
                .iter()
                .find(|c| is_object_tag(&c.tag) && c.attr("name") == Some(name))
        })
    }

    /// Marks property `name` used without reading it.
    pub fn mark_used(&self, name: &str) {
        let _ = self.get(name);
    }

    /// Errors at the first property nobody queried, like Mitsuba 3's "unreferenced property".
    pub fn finish(self) -> Result<()> {
        for (p, used) in self.props.iter().zip(&self.used) {
            if used.get() {
                continue;
            }
            let name = p.attr("name").unwrap_or_default();
            let mut msg = format!("unreferenced property '{name}' in {}", self.node.describe());
            if let Some(hint) = camel_case_hint(name) {
                msg.push(' ');
                msg.push_str(&hint);
            }
            return Err(Error::scene(p.attr_loc("name"), msg));
        }
        Ok(())
    }
}

fn value_of(p: &Node) -> Result<&str> {
    p.attr("value")
        .ok_or_else(|| Error::scene(&p.loc, format!("<{}> needs a 'value' attribute", p.tag)))
}

/// Parses one finite number; errors name the text.
pub fn parse_f32(text: &str, loc: &SourceLoc) -> Result<f32> {
    let t = text.trim();
    match t.parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(Error::scene(loc, format!("number '{t}' is not finite"))),
        Err(_) => Err(Error::scene(
            loc,
            format!("could not parse floating point value '{t}'"),
        )),
    }
}

/// Numbers separated by commas and/or whitespace.
pub fn parse_list(text: &str, loc: &SourceLoc) -> Result<Vec<f32>> {
    text.split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .map(|t| parse_f32(t, loc))
        .collect()
}

fn parse_f64(text: &str, loc: &SourceLoc) -> Result<f64> {
    let t = text.trim();
    match t.parse::<f64>() {
        Ok(v) if v.is_finite() => Ok(v),
        _ => Err(Error::scene(
            loc,
            format!("could not parse number '{t}' in spectrum"),
        )),
    }
}

/// `<spectrum value>`: one number is a constant (grey); otherwise `λ:value` pairs. Also returns
/// the unclamped value when the conversion had to clamp.
fn spectrum_of(
    text: &str,
    loc: &SourceLoc,
    use_: SpectrumUse,
) -> Result<(Spectrum, Option<Spectrum>)> {
    let tokens: Vec<&str> = text
        .split(|c: char| c == ',' || c.is_whitespace())
        .filter(|t| !t.is_empty())
        .collect();
    if tokens.len() == 1 && !tokens[0].contains(':') {
        return Ok((Spectrum::splat(parse_f32(tokens[0], loc)?), None));
    }
    let mut wl = Vec::with_capacity(tokens.len());
    let mut vals = Vec::with_capacity(tokens.len());
    for t in &tokens {
        let Some((w, v)) = t.split_once(':') else {
            return Err(Error::scene(
                loc,
                format!("invalid spectrum entry '{t}' (expected wavelength:value pairs)"),
            ));
        };
        wl.push(parse_f64(w, loc)?);
        vals.push(parse_f64(v, loc)?);
    }
    spectrum_list_to_rgb(&wl, &vals, use_)
        .map(|c| (c.rgb, c.clamped.then_some(c.unclamped)))
        .map_err(|m| Error::scene(loc, format!("invalid spectrum: {m}")))
}

/// `value="x, y, z"` (or a single number for all three) or `x`, `y`, `z` attributes with
/// missing ones = `missing`.
pub(super) fn xyz_of(p: &Node, missing: f32) -> Result<Vec3> {
    if let Some(v) = p.attr("value") {
        if ["x", "y", "z"].iter().any(|a| p.attr(a).is_some()) {
            return Err(Error::scene(
                p.attr_loc("value"),
                format!("<{}>: give either 'value' or 'x'/'y'/'z', not both", p.tag),
            ));
        }
        let loc = p.attr_loc("value");
        let n = parse_list(v, loc)?;
        return match n.as_slice() {
            [a] => Ok(Vec3::splat(*a)),
            [x, y, z] => Ok(Vec3::new(*x, *y, *z)),
            _ => Err(Error::scene(
                loc,
                format!("<{}>: expected one or three values, got '{v}'", p.tag),
            )),
        };
    }
    let mut out = [missing; 3];
    for (k, a) in ["x", "y", "z"].iter().enumerate() {
        if let Some(v) = p.attr(a) {
            out[k] = parse_f32(v, p.attr_loc(a))?;
        }
    }
    Ok(Vec3::from(out))
}

pub(super) fn vec3_attr(p: &Node, name: &str) -> Result<Vec3> {
    let loc = p.attr_loc(name);
    let text = p.attr(name).unwrap_or_default();
    let n = parse_list(text, loc)?;
    match n.as_slice() {
        [x, y, z] => Ok(Vec3::new(*x, *y, *z)),
        _ => Err(Error::scene(
            loc,
            format!("'{name}' needs exactly three values, got '{text}'"),
        )),
    }
}
