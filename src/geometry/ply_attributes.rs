//! Which extra PLY properties become mesh attributes, and how their values are converted: Mitsuba
//! 3.9.1's rules (`src/shapes/ply.h`, `find_other_fields`; checked with `mi.traverse` on PLY
//! files of every property type).
//!
//! Grouping, per element (`vertex` → `vertex_…`, `face` → `face_…`):
//! - `r g b` (or `red green blue`, then also `alpha`) → `<kind>color`, 3 values (4 with `a` /
//!   `alpha`), in r, g, b, a order wherever they sit;
//! - other properties named `<prefix>_<p>`, consecutive with one prefix and postfixes following
//!   one of the sequences `x y z w`, `r g b a`, `0 1 2 3`, `1 2 3 4`, give `<kind><prefix>`
//!   (`<kind><prefix>_color` for `r g b`) with 1 or 3 values; other counts, unknown postfixes,
//!   names without `_` and repeated prefixes are skipped with Mitsuba's warnings. The state
//!   machine below is Mitsuba's, quirks included (after an invalid sequence or a repeated prefix
//!   it also skips the property that follows the skipped run).
//! - Reserved, never attributes: `x y z nx ny nz u v` and the uv pairs renamed to `u v`
//!   (vertices), the index list (faces), and `r g b a`.
//!
//! Values: floating-point properties as they are; 8-bit unsigned ones (`uchar`) as their integer
//! value, not divided by 255 (what Mitsuba 3.9.1 does, with a warning that colours are expected
//! in [0, 1]); every other integer type normalised to [−1, 1] (v / max of the type) and then
//! decoded with the sRGB curve (Mitsuba marks integer PLY fields `Normalized | Gamma`).

use crate::texture::bitmap::srgb_to_linear;

/// A property's value type, as far as the conversion cares.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ValueKind {
    Float,
    /// Unsigned 8 bits.
    U8,
    /// Another integer type, with the largest value of the type.
    Int {
        max: f64,
    },
}

impl ValueKind {
    /// A raw property value to what Mitsuba stores.
    #[inline]
    pub fn convert(self, v: f64) -> f32 {
        match self {
            ValueKind::Float | ValueKind::U8 => v as f32,
            ValueKind::Int { max } => {
                let n = v / max;
                // The sRGB curve; negative values take its linear part, as Mitsuba's does.
                if n <= 0.04045 {
                    (n / 12.92) as f32
                } else {
                    srgb_to_linear(n) as f32
                }
            }
        }
    }
}

/// One attribute: its full name and the properties (indices into the element's list) holding
/// its values, in order.
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    pub name: String,
    pub fields: Vec<usize>,
}

/// `kind` is `"vertex_"` or `"face_"`; `names` the element's non-list properties (after the
/// uv renaming of the vertex element), `reserved` the names that are never attributes, and
/// `is_float` says which properties are floating-point (for Mitsuba's warnings). Returns the
/// attributes and the warnings Mitsuba would log.
pub fn group(
    kind: &str,
    names: &[&str],
    is_float: &[bool],
    reserved: &[&str],
) -> (Vec<Group>, Vec<String>) {
    let mut names: Vec<String> = names.iter().map(|s| s.to_string()).collect();
    let mut groups = Vec::new();
    let mut warnings = Vec::new();
    let has = |names: &[String], n: &str| names.iter().any(|x| x == n);
    let pos = |names: &[String], n: &str| names.iter().position(|x| x == n);
    // The colour.
    if !(has(&names, "r") && has(&names, "g") && has(&names, "b"))
        && has(&names, "red")
        && has(&names, "green")
        && has(&names, "blue")
    {
        for (from, to) in [("red", "r"), ("green", "g"), ("blue", "b"), ("alpha", "a")] {
            if let Some(i) = pos(&names, from) {
                names[i] = to.to_string();
            }
        }
    }
    if let (Some(r), Some(g), Some(b)) = (pos(&names, "r"), pos(&names, "g"), pos(&names, "b")) {
        let mut fields = vec![r, g, b];
        if let Some(a) = pos(&names, "a") {
            fields.push(a);
        }
        if !is_float[r] {
            warnings.push(format!(
                "mesh attribute \"{kind}color\" has integer fields: color attributes are expected to be in the [0, 1] range"
            ));
        }
        groups.push(Group {
            name: format!("{kind}color"),
            fields,
        });
    }
    let reserved: Vec<&str> = reserved
        .iter()
        .copied()
        .chain(["r", "g", "b", "a"])
        .collect();

    // Postfix sequences by level (rows) and category (columns): x y z w, r g b a, 0 1 2 3, 1 2 3 4.
    const POSTFIXES: [&[u8; 4]; 4] = [b"xr01", b"yg12", b"zb23", b"wa34"];
    let n = names.len();
    let mut encountered: Vec<String> = Vec::new();
    let mut prefix = String::new();
    let mut category = 0usize;
    let mut level = 0usize;
    let mut reading = false;
    let mut current_float = true;
    let mut current: Vec<usize> = Vec::new();

    // Mitsuba's `flush_attribute`.
    let flush = |prefix: &mut String,
                 level: &mut usize,
                 reading: &mut bool,
                 current: &mut Vec<usize>,
                 category: usize,
                 current_float: bool,
                 encountered: &mut Vec<String>,
                 groups: &mut Vec<Group>,
                 warnings: &mut Vec<String>| {
        if *level != 1 && *level != 3 {
            warnings.push(format!(
                "attribute must have either 1 or 3 fields (had {level}): attribute \"{kind}{prefix}\" ignored"
            ));
        } else {
            if !current_float && *level == 3 {
                warnings.push(format!(
                    "attribute \"{kind}{prefix}\" has integer fields: color attributes are expected to be in the [0, 1] range"
                ));
            }
            let suffix = if category == 1 { "_color" } else { "" };
            groups.push(Group {
                name: format!("{kind}{prefix}{suffix}"),
                fields: std::mem::take(current),
            });
            encountered.push(prefix.clone());
        }
        prefix.clear();
        *level = 0;
        *reading = false;
        current.clear();
    };

    let mut i = 0usize;
    while i < n {
        let name = names[i].clone();
        if reserved.contains(&name.as_str()) {
            i += 1;
            continue;
        }
        current_float = is_float[i];
        let Some(us) = name.rfind('_') else {
            warnings.push(format!(
                "attributes without postfix are not handled for now: attribute \"{name}\" ignored"
            ));
            if reading {
                flush(
                    &mut prefix,
                    &mut level,
                    &mut reading,
                    &mut current,
                    category,
                    current_float,
                    &mut encountered,
                    &mut groups,
                    &mut warnings,
                );
            }
            i += 1;
            continue;
        };
        let postfix = &name[us + 1..];
        if postfix.len() != 1 {
            warnings.push(format!(
                "attribute postfix can only be one letter long: attribute \"{name}\" ignored"
            ));
            if reading {
                flush(
                    &mut prefix,
                    &mut level,
                    &mut reading,
                    &mut current,
                    category,
                    current_float,
                    &mut encountered,
                    &mut groups,
                    &mut warnings,
                );
            }
            i += 1;
            continue;
        }
        let this_prefix = name[..us].to_string();
        if reading && this_prefix != prefix {
            flush(
                &mut prefix,
                &mut level,
                &mut reading,
                &mut current,
                category,
                current_float,
                &mut encountered,
                &mut groups,
                &mut warnings,
            );
        }
        if !reading && encountered.contains(&this_prefix) {
            warnings.push(format!(
                "attribute prefix has already been encountered: attribute \"{name}\" ignored"
            ));
            while i < n && names[i].starts_with(&this_prefix) {
                i += 1;
            }
            if i == n {
                break;
            }
            i += 1;
            continue;
        }
        let ch = postfix.as_bytes()[0];
        if !reading {
            let Some(c) = POSTFIXES[0].iter().position(|&p| p == ch) else {
                warnings.push(format!(
                    "attribute can't start with postfix '{}': attribute \"{name}\" ignored",
                    ch as char
                ));
                i += 1;
                continue;
            };
            reading = true;
            category = c;
            prefix = this_prefix.clone();
            current.push(i);
        } else if POSTFIXES.get(level).map(|row| row[category]) != Some(ch) {
            warnings.push(format!(
                "attribute postfix sequence is invalid: attribute \"{kind}{prefix}\" ignored"
            ));
            prefix.clear();
            level = 0;
            reading = false;
            current.clear();
            while i < n && names[i].starts_with(&this_prefix) {
                i += 1;
            }
            if i == n {
                break;
            }
        } else {
            current.push(i);
        }
        level += 1;
        i += 1;
    }
    if reading {
        flush(
            &mut prefix,
            &mut level,
            &mut reading,
            &mut current,
            category,
            current_float,
            &mut encountered,
            &mut groups,
            &mut warnings,
        );
    }
    (groups, warnings)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(g: &[Group]) -> Vec<(&str, Vec<usize>)> {
        g.iter()
            .map(|g| (g.name.as_str(), g.fields.clone()))
            .collect()
    }

    #[test]
    fn mitsuba_groups_colours_and_prefixed_properties() {
        // What Mitsuba 3.9.1 made of these vertex properties (mi.traverse of the loaded PLY).
        let props = [
            "x", "y", "z", "red", "green", "blue", "alpha", "foo_x", "foo_y", "foo_z", "q_0",
        ];
        let float = [
            true, true, true, false, false, false, false, true, true, true, false,
        ];
        let (g, w) = group(
            "vertex_",
            &props,
            &float,
            &["x", "y", "z", "nx", "ny", "nz", "u", "v"],
        );
        assert_eq!(
            names(&g),
            [
                ("vertex_color", vec![3, 4, 5, 6]),
                ("vertex_foo", vec![7, 8, 9]),
                ("vertex_q", vec![10]),
            ]
        );
        assert!(w.iter().any(|w| w.contains("vertex_color")));
        // Face properties w_r w_g w_b: a colour-category attribute.
        let (g, _) = group("face_", &["w_r", "w_g", "w_b"], &[true; 3], &[]);
        assert_eq!(names(&g), [("face_w_color", vec![0, 1, 2])]);
        // Two fields, a bad start, no underscore: ignored with warnings.
        let (g, w) = group(
            "vertex_",
            &["k_x", "k_y", "m_q", "plain", "c_1"],
            &[true; 5],
            &[],
        );
        assert_eq!(names(&g), [("vertex_c", vec![4])]);
        assert_eq!(w.len(), 3, "{w:?}");
    }

    #[test]
    fn integer_values_follow_mitsuba() {
        // uchar stays as is; other integers are normalised and sRGB-decoded (values from
        // Mitsuba 3.9.1: ushort 1000 → 0.00118104, char −128 → −0.0780088, char 7 → 0.0044122).
        assert_eq!(ValueKind::U8.convert(255.0), 255.0);
        let us = ValueKind::Int { max: 65535.0 };
        assert!((us.convert(1000.0) - 0.00118104).abs() < 1e-8);
        assert_eq!(us.convert(65535.0), 1.0);
        let c = ValueKind::Int { max: 127.0 };
        assert!((c.convert(-128.0) + 0.0780088).abs() < 1e-7);
        assert!((c.convert(7.0) - 0.0044122).abs() < 1e-7);
        assert_eq!(ValueKind::Float.convert(0.5), 0.5);
    }
}
