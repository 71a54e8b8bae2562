//! Partial outputs of a split render (`groove render --crop/--tile/--samples`), merged by
//! `groove merge`: one OpenEXR file per part that says what it is.
//!
//! Layout of a part (scan lines, ZIP, one layer):
//! - display window: the full film; data window: the part's crop window;
//! - `R`, `G`, `B` (f32): the developed pixels, so that any viewer shows the part, and `W` (f32):
//!   the summed filter weight Σw, rounded;
//! - the exact sums of every pixel ([`crate::film::RawPixel`]: Σw·v and Σw·v² per colour, Σw,
//!   Σw², integers times 2⁻⁶⁴ in 128 bits) as four `u32` channels each, least significant
//!   first: `sum.<q>.0` … `sum.<q>.3` for q in `R G B R2 G2 B2 W W2`, and `sum.flags` (the
//!   non-finite flags). Extra channels (AOVs) are stored developed under their own names and
//!   exactly as `sum.aov<c>.1.<limb>` (Σw·a) and `sum.aov<c>.2.<limb>` (Σw·a²). Because the sums
//!   are exact integers, parts of disjoint sample ranges add to the bits of the full render;
//! - string attributes ([`PART_KEYS`]): `groove.part` (the format, "1"), `groove.version`,
//!   `groove.scene_hash` (FNV-1a 64 of the contents of the scene and every file it read),
//!   `groove.defines` (the `-D` parameters, JSON), `groove.normal_mapping`, `groove.seed`,
//!   `groove.sample_count` (samples per pixel of the full render), `groove.samples` (the range
//!   `A..B` rendered), `groove.crop` (`X,Y,W,H`), `groove.film` (`WxH`), `groove.filter`,
//!   `groove.aovs` (the extra channels' names, JSON).

use std::io::Read;
use std::path::{Path, PathBuf};

use exr::meta::attribute::{AttributeValue, IntegerBounds, Text};
use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Image as ExrImage, ImageAttributes, Layer,
    SmallVec, Vec2 as ExrVec2, WritableImage,
};

use super::{write_exr_atomic, Metadata};
use crate::budget::{bytes_of, Budget};
use crate::error::{Error, Result};
use crate::film::{Film, RawPixel};

/// Value of `groove.part`: the layout of this file.
pub const PART_FORMAT: &str = "1";

/// Attributes that two parts must share to be merged (besides the film size).
pub const MATCH_KEYS: [&str; 9] = [
    "groove.version",
    "groove.scene_hash",
    "groove.defines",
    "groove.normal_mapping",
    "groove.seed",
    "groove.sample_count",
    "groove.film",
    "groove.filter",
    "groove.aovs",
];

/// Every attribute a part must carry.
pub const PART_KEYS: [&str; 12] = [
    "groove.part",
    "groove.version",
    "groove.scene_hash",
    "groove.defines",
    "groove.normal_mapping",
    "groove.seed",
    "groove.sample_count",
    "groove.film",
    "groove.filter",
    "groove.aovs",
    "groove.samples",
    "groove.crop",
];

/// Names of the eight exact sums of a pixel, in [`RawPixel::sums`] order.
const SUM_NAMES: [&str; 8] = ["R", "G", "B", "R2", "G2", "B2", "W", "W2"];

/// A part read back: where it lies, what it holds, and its exact sums.
#[derive(Clone, Debug)]
pub struct Part {
    pub path: PathBuf,
    /// Full film size (the display window).
    pub film: (u32, u32),
    /// The crop window (the data window): x, y, width, height.
    pub crop: (u32, u32, u32, u32),
    /// Sample indices [a, b).
    pub samples: (u32, u32),
    pub meta: Metadata,
    /// Names of the extra channels.
    pub aovs: Vec<String>,
    /// Exact sums per crop pixel, row-major.
    pub pixels: Vec<RawPixel>,
    /// Exact extra-channel sums, `aovs.len()` per pixel.
    pub extra: Vec<[i128; 2]>,
}

/// FNV-1a (64 bit) of the contents of `files`, in order, each followed by its length: a
/// fingerprint telling parts of different scenes (or of edited inputs) apart, whatever the
/// folder they were rendered from. Duplicates in `files` count once.
pub fn scene_hash(files: &[PathBuf]) -> Result<String> {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    let mut seen: Vec<&PathBuf> = Vec::new();
    let mut buf = vec![0u8; 1 << 16];
    for f in files {
        if seen.contains(&f) {
            continue;
        }
        seen.push(f);
        let mut file = std::fs::File::open(f).map_err(|e| Error::io(f, e))?;
        let mut len = 0u64;
        loop {
            let n = file.read(&mut buf).map_err(|e| Error::io(f, e))?;
            if n == 0 {
                break;
            }
            len += n as u64;
            for &b in &buf[..n] {
                h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
            }
        }
        for b in len.to_le_bytes() {
            h = (h ^ b as u64).wrapping_mul(0x0100_0000_01b3);
        }
    }
    Ok(format!("{h:016x}"))
}

/// The four u32 limbs of `x`, least significant first.
fn limbs(x: i128) -> [u32; 4] {
    let u = x as u128;
    [0, 1, 2, 3].map(|k| (u >> (32 * k)) as u32)
}

/// The i128 of four u32 limbs, least significant first.
fn from_limbs(l: [u32; 4]) -> i128 {
    l.iter()
        .enumerate()
        .fold(0u128, |a, (k, &v)| a | (v as u128) << (32 * k)) as i128
}

/// Writes `film` (its crop window, of a `film.desc()` full film) as a part at `path`
/// (atomically, like every output); `meta` must hold [`PART_KEYS`] except `groove.part`,
/// `groove.crop` and `groove.film`, which are written from the film.
pub fn write_part(path: &Path, film: &Film, aovs: &[String], meta: &Metadata) -> Result<()> {
    let (x, y, w, h) = film.crop_rect();
    if w == 0 || h == 0 {
        return Err(Error::file(path, "the part's crop window is empty"));
    }
    if !film.has_second_moments() {
        return Err(Error::file(
            path,
            "a part carries every exact sum, but this film was rendered without its second moments",
        ));
    }
    let desc = film.desc();
    let n = w as usize * h as usize;
    let nch = film.channel_count().min(aovs.len());
    let img = film.develop();
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let v: Vec<f32> = img.data.iter().map(|p| p[c]).collect();
        list.push(AnyChannel::new(*name, FlatSamples::F32(v)));
    }
    let raw: Vec<RawPixel> = (0..n).map(|i| film.raw_pixel(i)).collect();
    let wsum: Vec<f32> = raw
        .iter()
        .map(|p| crate::film::sum::to_f64(p.sums[6]) as f32)
        .collect();
    list.push(AnyChannel::new("W", FlatSamples::F32(wsum)));
    let mut push_limbs = |name: &str, vals: &dyn Fn(usize) -> i128| {
        let mut l: [Vec<u32>; 4] = Default::default();
        for i in 0..n {
            for (k, v) in limbs(vals(i)).into_iter().enumerate() {
                l[k].push(v);
            }
        }
        for (k, v) in l.into_iter().enumerate() {
            list.push(AnyChannel::new(
                format!("sum.{name}.{k}").as_str(),
                FlatSamples::U32(v),
            ));
        }
    };
    for (q, name) in SUM_NAMES.iter().enumerate() {
        push_limbs(name, &|i| raw[i].sums[q]);
    }
    for c in 0..nch {
        push_limbs(&format!("aov{c}.1"), &|i| film.raw_extra(i, c)[0]);
        push_limbs(&format!("aov{c}.2"), &|i| film.raw_extra(i, c)[1]);
    }
    let flags: Vec<u32> = raw.iter().map(|p| p.bad as u32).collect();
    list.push(AnyChannel::new("sum.flags", FlatSamples::U32(flags)));
    for (c, name) in aovs.iter().take(nch).enumerate() {
        if name.is_empty() || name.contains('\0') || name.starts_with("sum.") || name == "W" {
            return Err(Error::file(
                path,
                format!("channel name {name:?} cannot be stored in a part"),
            ));
        }
        list.push(AnyChannel::new(
            name.as_str(),
            FlatSamples::F32(film.develop_channel(c)),
        ));
    }
    let mut all = meta.clone();
    all.0.retain(|(k, _)| {
        !matches!(
            k.as_str(),
            "groove.part" | "groove.crop" | "groove.film" | "groove.filter"
        )
    });
    all.0.push(("groove.part".into(), PART_FORMAT.into()));
    all.0
        .push(("groove.crop".into(), format!("{x},{y},{w},{h}")));
    all.0.push((
        "groove.film".into(),
        format!("{}x{}", desc.width, desc.height),
    ));
    all.0
        .push(("groove.filter".into(), format!("{:?}", desc.filter)));
    for k in PART_KEYS {
        if all.get(k).is_none() {
            return Err(Error::file(path, format!("part metadata lacks {k}")));
        }
    }
    let mut attrs = super::exr::attributes(&all).map_err(|m| Error::file(path, m))?;
    attrs.layer_position = ExrVec2(x as i32, y as i32);
    let mut names: Vec<&Text> = list.iter().map(|c| &c.name).collect();
    names.sort();
    if names.windows(2).any(|p| p[0] == p[1]) {
        return Err(Error::file(
            path,
            "two channels of the part have the same name",
        ));
    }
    let layer = Layer::new(
        (w as usize, h as usize),
        attrs,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    let display = IntegerBounds::new((0, 0), (desc.width as usize, desc.height as usize));
    let image = ExrImage::new(ImageAttributes::new(display), layer);
    write_exr_atomic(path, |wr| {
        image
            .write()
            .to_buffered(wr)
            .map_err(|e| format!("cannot encode EXR: {e}"))
    })
}

/// Parses `A..B`.
pub fn parse_range(s: &str) -> Option<(u32, u32)> {
    let (a, b) = s.split_once("..")?;
    Some((a.trim().parse().ok()?, b.trim().parse().ok()?))
}

/// Parses `X,Y,W,H`.
pub fn parse_rect(s: &str) -> Option<(u32, u32, u32, u32)> {
    let v: Vec<u32> = s
        .split(',')
        .map(|t| t.trim().parse().ok())
        .collect::<Option<_>>()?;
    match v[..] {
        [x, y, w, h] => Some((x, y, w, h)),
        _ => None,
    }
}

/// Reads a part written by [`write_part`], its pixels checked against `budget` (with what the
/// merge keeps per pixel) from the header before they are read.
pub fn read_part(path: &Path, budget: &Budget) -> Result<Part> {
    let (f, _) = crate::inputs::open_regular(path)?;
    let (w, h, nch) =
        super::exr_size(std::io::BufReader::new(f)).map_err(|m| Error::file(path, m))?;
    budget
        .check(
            bytes_of(&[w, h, 8 * nch + 2 * crate::film::PIXEL_BYTES]),
            &format!("part {w}×{h} ({})", path.display()),
        )
        .map_err(|m| Error::file(path, m))?;
    let image = super::exr::read_first_layer(path)?;
    let mut meta = Vec::new();
    for (k, v) in image
        .attributes
        .other
        .iter()
        .chain(image.layer_data.attributes.other.iter())
    {
        if let AttributeValue::Text(t) = v {
            meta.push((
                String::from_utf8_lossy(k.as_slice()).into_owned(),
                String::from_utf8_lossy(t.as_slice()).into_owned(),
            ));
        }
    }
    meta.sort();
    let meta = Metadata(meta);
    let not_part = |why: String| {
        Error::file(
            path,
            format!("not a groove part ({why}); parts are written by groove render --crop, --tile, --samples or --part"),
        )
    };
    match meta.get("groove.part") {
        Some(PART_FORMAT) => {}
        Some(v) => {
            return Err(not_part(format!(
                "part format {v:?}, this groove reads {PART_FORMAT:?}"
            )))
        }
        None => return Err(not_part("no groove.part attribute".into())),
    }
    for k in PART_KEYS {
        if meta.get(k).is_none() {
            return Err(not_part(format!("no {k} attribute")));
        }
    }
    let get = |k: &str| meta.get(k).unwrap_or_default();
    let crop = parse_rect(get("groove.crop"))
        .ok_or_else(|| not_part(format!("groove.crop {:?}", get("groove.crop"))))?;
    let samples = parse_range(get("groove.samples"))
        .filter(|(a, b)| a < b)
        .ok_or_else(|| not_part(format!("groove.samples {:?}", get("groove.samples"))))?;
    let film = get("groove.film")
        .split_once('x')
        .and_then(|(a, b)| Some((a.parse::<u32>().ok()?, b.parse::<u32>().ok()?)))
        .ok_or_else(|| not_part(format!("groove.film {:?}", get("groove.film"))))?;
    let aovs: Vec<String> = serde_json::from_str(get("groove.aovs"))
        .map_err(|e| not_part(format!("groove.aovs: {e}")))?;
    let disp = image.attributes.display_window;
    let layer = &image.layer_data;
    let pos = layer.attributes.layer_position;
    let size = layer.size;
    let windows_agree = disp.position == ExrVec2(0, 0)
        && disp.size == ExrVec2(film.0 as usize, film.1 as usize)
        && pos == ExrVec2(crop.0 as i32, crop.1 as i32)
        && size == ExrVec2(crop.2 as usize, crop.3 as usize)
        && crop.0.checked_add(crop.2).is_some_and(|e| e <= film.0)
        && crop.1.checked_add(crop.3).is_some_and(|e| e <= film.1);
    if !windows_agree {
        return Err(not_part(format!(
            "its windows (display {:?}+{:?}, data {:?}+{:?}) disagree with groove.crop and groove.film",
            disp.position, disp.size, pos, size
        )));
    }
    let n = crop.2 as usize * crop.3 as usize;
    let channel = |name: &str| -> Result<&Vec<u32>> {
        let c = layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name.as_slice() == name.as_bytes())
            .ok_or_else(|| not_part(format!("no channel {name}")))?;
        match &c.sample_data {
            FlatSamples::U32(v) if v.len() == n => Ok(v),
            _ => Err(not_part(format!("channel {name} is not {n} u32 values"))),
        }
    };
    let read_sums = |name: &str| -> Result<Vec<i128>> {
        let l: Vec<&Vec<u32>> = (0..4)
            .map(|k| channel(&format!("sum.{name}.{k}")))
            .collect::<Result<_>>()?;
        Ok((0..n)
            .map(|i| from_limbs([l[0][i], l[1][i], l[2][i], l[3][i]]))
            .collect())
    };
    let mut pixels = vec![RawPixel::default(); n];
    // Second moments and weights are sums of non-negative addends; the film's saturating
    // addition (`film::sum::add_unsigned`) relies on that.
    let negative = |name: &str| not_part(format!("channel sum.{name} holds a negative sum"));
    for (q, name) in SUM_NAMES.iter().enumerate() {
        for (p, v) in pixels.iter_mut().zip(read_sums(name)?) {
            if q >= 3 && v < 0 {
                return Err(negative(name));
            }
            p.sums[q] = v;
        }
    }
    for (p, &f) in pixels.iter_mut().zip(channel("sum.flags")?) {
        p.bad = (f & 0x1ff) as u16;
    }
    let na = aovs.len();
    let mut extra = vec![[0i128; 2]; n * na];
    for c in 0..na {
        let first = read_sums(&format!("aov{c}.1"))?;
        let second = read_sums(&format!("aov{c}.2"))?;
        for (i, (a, b)) in first.into_iter().zip(second).enumerate() {
            if b < 0 {
                return Err(negative(&format!("aov{c}.2")));
            }
            extra[i * na + c] = [a, b];
        }
    }
    Ok(Part {
        path: path.to_path_buf(),
        film,
        crop,
        samples,
        meta,
        aovs,
        pixels,
        extra,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limbs_round_trip() {
        for x in [0i128, 1, -1, i128::MAX, i128::MIN, 1 << 64, -(3 << 90) + 17] {
            assert_eq!(from_limbs(limbs(x)), x);
        }
        assert_eq!(parse_range("3..17"), Some((3, 17)));
        assert_eq!(parse_range("3-17"), None);
        assert_eq!(parse_rect("1,2,3,4"), Some((1, 2, 3, 4)));
        assert_eq!(parse_rect("1,2,3"), None);
    }
}
