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

    let mut scan = Scan {
        kind,
        groups,
        warnings,
        encountered: Vec::new(),
        prefix: String::new(),
        category: 0,
        level: 0,
        reading: false,
        current_float: true,
        current: Vec::new(),
    };
    let n = names.len();
    let mut i = 0usize;
    // Mitsuba's loop over the fields; `i += 1; continue` is its `continue`.
    while i < n {
        let name = names[i].as_str();
        if reserved.contains(&name) {
            i += 1;
            continue;
        }
        // Set before the flushes below, as in Mitsuba (whose warning about integer fields then
        // looks at the field that ends an attribute).
        scan.current_float = is_float[i];
        let Some(us) = name.rfind('_') else {
            scan.warn(format!(
                "attributes without postfix are not handled for now: attribute \"{name}\" ignored"
            ));
            if scan.reading {
                scan.flush();
            }
            i += 1;
            continue;
        };
        let postfix = &name[us + 1..];
        if postfix.len() != 1 {
            scan.warn(format!(
                "attribute postfix can only be one letter long: attribute \"{name}\" ignored"
            ));
            if scan.reading {
                scan.flush();
            }
            i += 1;
            continue;
        }
        let prefix = &name[..us];
        if scan.reading && prefix != scan.prefix {
            scan.flush();
        }
        if !scan.reading && scan.encountered.iter().any(|e| e == prefix) {
            scan.warn(format!(
                "attribute prefix has already been encountered: attribute \"{name}\" ignored"
            ));
            let prefix = prefix.to_string();
            while i < n && names[i].starts_with(&prefix) {
                i += 1;
            }
            if i == n {
                break;
            }
            i += 1;
            continue;
        }
        let ch = postfix.as_bytes()[0];
        if !scan.reading {
            let Some(c) = POSTFIXES[0].iter().position(|&p| p == ch) else {
                scan.warn(format!(
                    "attribute can't start with postfix '{}': attribute \"{name}\" ignored",
                    ch as char
                ));
                i += 1;
                continue;
            };
            scan.reading = true;
            scan.category = c;
            scan.prefix = prefix.to_string();
            scan.current.push(i);
        } else if POSTFIXES.get(scan.level).map(|row| row[scan.category]) != Some(ch) {
            let w = format!(
                "attribute postfix sequence is invalid: attribute \"{}{}\" ignored",
                scan.kind, scan.prefix
            );
            scan.warn(w);
            scan.reset();
            let prefix = prefix.to_string();
            while i < n && names[i].starts_with(&prefix) {
                i += 1;
            }
            if i == n {
                break;
            }
            // Mitsuba falls through here: the level counts on and the next field is skipped.
        } else {
            scan.current.push(i);
        }
        scan.level += 1;
        i += 1;
    }
    if scan.reading {
        scan.flush();
    }
    (scan.groups, scan.warnings)
}

/// Postfix sequences by level (rows) and category (columns): x y z w, r g b a, 0 1 2 3, 1 2 3 4.
const POSTFIXES: [&[u8; 4]; 4] = [b"xr01", b"yg12", b"zb23", b"wa34"];

/// The state of Mitsuba's scan over an element's fields.
struct Scan<'k> {
    /// `vertex_` or `face_`.
    kind: &'k str,
    groups: Vec<Group>,
    warnings: Vec<String>,
    /// Prefixes that made an attribute.
    encountered: Vec<String>,
    /// The attribute being read: its prefix, postfix category, fields so far (`level`) and their
    /// indices; `current_float` is the type of the field last looked at.
    prefix: String,
    category: usize,
    level: usize,
    reading: bool,
    current_float: bool,
    current: Vec<usize>,
}

impl Scan<'_> {
    fn warn(&mut self, w: String) {
        self.warnings.push(w);
    }

    /// Mitsuba's `ignore_attribute`: forget the attribute being read.
    fn reset(&mut self) {
        self.prefix.clear();
        self.category = 0;
        self.level = 0;
        self.reading = false;
        self.current.clear();
    }

    /// Mitsuba's `flush_attribute`: keep the attribute being read if it has 1 or 3 fields.
    fn flush(&mut self) {
        let (kind, prefix, level) = (self.kind, self.prefix.clone(), self.level);
        if level != 1 && level != 3 {
            self.warn(format!(
                "attribute must have either 1 or 3 fields (had {level}): attribute \"{kind}{prefix}\" ignored"
            ));
        } else {
            if !self.current_float && level == 3 {
                self.warn(format!(
                    "attribute \"{kind}{prefix}\" has integer fields: color attributes are expected to be in the [0, 1] range"
                ));
            }
            let suffix = if self.category == 1 { "_color" } else { "" };
            let fields = std::mem::take(&mut self.current);
            self.groups.push(Group {
                name: format!("{kind}{prefix}{suffix}"),
                fields,
            });
            self.encountered.push(prefix);
        }
        self.reset();
    }
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
