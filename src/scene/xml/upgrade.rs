//! Upgrading the old scene dialect (version < 2.0, Mitsuba 0.4–0.6) to Mitsuba 3 names, the way
//! Mitsuba 3's `upgrade_tree` (src/core/parser.cpp) does, plus two leniencies of groove's:
//! `<lookAt>` is renamed with a warning, and a lone `uoffset`/`uscale` is not dropped.

use super::ir::{Attr, Node};

/// Mitsuba 3's camelCase → snake_case rule for property names: wherever a lowercase letter is
/// followed by an uppercase one, insert `_` and lowercase the following run of uppercase letters
/// (`intIOR` → `int_ior`, `toWorld` → `to_world`, `alphaU` → `alpha_u`). The scan skips the
/// character after such a run, exactly like Mitsuba's loop (so `aBcD` → `a_bcD`).
pub fn camel_to_snake(name: &str) -> String {
    let mut s: Vec<char> = name.chars().collect();
    let mut i = 0;
    while i + 1 < s.len() {
        if s[i].is_ascii_lowercase() && s[i + 1].is_ascii_uppercase() {
            s.insert(i + 1, '_');
            i += 2;
            while i < s.len() && s[i].is_ascii_uppercase() {
                s[i] = s[i].to_ascii_lowercase();
                i += 1;
            }
        }
        i += 1;
    }
    s.into_iter().collect()
}

/// For a property name that looks like a Mitsuba 0.6 camelCase name, the text of a hint to add
/// to an "unreferenced property" error: `(a Mitsuba 0.6 name? set <scene version="0.6.0"> or use
/// 'ext_eta')`. `None` for names that the upgrade would leave unchanged.
pub fn camel_case_hint(name: &str) -> Option<String> {
    let snake = camel_to_snake(name);
    (snake != name)
        .then(|| format!("(a Mitsuba 0.6 name? set <scene version=\"0.6.0\"> or use '{snake}')"))
}

/// Upgrades one file's raw tree in place (the file's `version` is < 2.0). Warnings carry
/// locations (`FILE:LINE:COL: message`).
pub fn upgrade_tree(node: &mut Node, warnings: &mut Vec<String>) {
    if node.tag != "default" {
        if let Some(a) = node.attrs.iter_mut().find(|a| a.name == "name") {
            a.value = camel_to_snake(&a.value);
        }
    }
    if node.tag == "lookAt" {
        warnings.push(format!(
            "{}: <lookAt> renamed to <lookat> (Mitsuba 3 itself does not accept <lookAt>)",
            node.loc
        ));
        node.tag = "lookat".to_string();
    }
    // Mitsuba 3 renames identifiers with a leading underscore (reserved for internal ids).
    if let Some(a) = node.attrs.iter_mut().find(|a| a.name == "id") {
        if a.value.starts_with('_') {
            let new_id = format!("ID{}__UPGR", a.value);
            warnings.push(format!(
                "{}: changing identifier '{}' to '{}'",
                a.loc, a.value, new_id
            ));
            a.value = new_id;
        }
    }
    for c in &mut node.children {
        upgrade_tree(c, warnings);
    }
    // `diffuse` renamed its `diffuseReflectance` (already snake_cased by now).
    if node.tag == "bsdf" && node.attr("type") == Some("diffuse") {
        for c in &mut node.children {
            if let Some(a) = c.attrs.iter_mut().find(|a| a.name == "name") {
                if a.value == "diffuse_reflectance" {
                    a.value = "reflectance".to_string();
                }
            }
        }
    }
    upgrade_uv_transform(node);
}

/// `uoffset`, `voffset`, `uscale`, `vscale` floats → `<transform name="to_uv">` holding a
/// `<translate>` and then a `<scale>` (Mitsuba 3's order: to_uv = scale · translate). Unlike
/// Mitsuba 3.9.1, which only emits the translate when *both* offsets are non-zero (and the scale
/// when both scales differ from 1), a lone offset or scale is kept. Values stay text so that
/// `$params` and number errors are handled later, at the original locations.
fn upgrade_uv_transform(node: &mut Node) {
    const NAMES: [&str; 4] = ["uoffset", "voffset", "uscale", "vscale"];
    let is_uv = |c: &Node| c.tag == "float" && c.attr("name").is_some_and(|n| NAMES.contains(&n));
    if !node.children.iter().any(is_uv) {
        return;
    }
    let mut found: [Option<(String, Attr)>; 4] = Default::default();
    let mut first_loc = None;
    node.children.retain(|c| {
        if !is_uv(c) {
            return true;
        }
        let name = c.attr("name").unwrap_or_default();
        let k = NAMES.iter().position(|n| *n == name).unwrap_or(0);
        let loc = c.attr_loc("value").clone();
        first_loc.get_or_insert_with(|| c.loc.clone());
        found[k] = Some((
            c.attr("value").unwrap_or_default().to_string(),
            Attr {
                name: String::new(),
                value: String::new(),
                loc,
            },
        ));
        false
    });
    let loc = first_loc.unwrap_or_else(|| node.loc.clone());
    let op = |tag: &str, x: &Option<(String, Attr)>, y: &Option<(String, Attr)>| {
        let mut attrs = Vec::new();
        for (axis, v) in [("x", x), ("y", y)] {
            if let Some((value, a)) = v {
                attrs.push(Attr {
                    name: axis.to_string(),
                    value: value.clone(),
                    loc: a.loc.clone(),
                });
            }
        }
        Node {
            tag: tag.to_string(),
            attrs,
            children: Vec::new(),
            loc: loc.clone(),
        }
    };
    let mut ops = Vec::new();
    if found[0].is_some() || found[1].is_some() {
        ops.push(op("translate", &found[0], &found[1]));
    }
    if found[2].is_some() || found[3].is_some() {
        ops.push(op("scale", &found[2], &found[3]));
    }
    node.children.push(Node {
        tag: "transform".to_string(),
        attrs: vec![Attr {
            name: "name".to_string(),
            value: "to_uv".to_string(),
            loc: loc.clone(),
        }],
        children: ops,
        loc,
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn camel_case_follows_mitsuba() {
        for (a, b) in [
            ("intIOR", "int_ior"),
            ("extIOR", "ext_ior"),
            ("toWorld", "to_world"),
            ("alphaU", "alpha_u"),
            ("sampleCount", "sample_count"),
            ("maxDepth", "max_depth"),
            ("fovAxis", "fov_axis"),
            ("pixelFormat", "pixel_format"),
            ("specularReflectance", "specular_reflectance"),
            ("diffuseReflectance", "diffuse_reflectance"),
            ("rrDepth", "rr_depth"),
            ("width", "width"),
            ("to_world", "to_world"),
            ("aBcD", "a_bcD"),
        ] {
            assert_eq!(camel_to_snake(a), b, "{a}");
        }
    }

    #[test]
    fn hint_only_for_camel_case() {
        assert!(camel_case_hint("extEta").unwrap().contains("'ext_eta'"));
        assert!(camel_case_hint("ext_eta").is_none());
    }
}
