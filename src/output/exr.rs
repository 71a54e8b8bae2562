//! OpenEXR input and output through the `exr` crate.

use std::io::{Seek, Write};
use std::path::Path;

use exr::meta::attribute::{AttributeValue, IntegerBounds, Text};
use exr::prelude::{
    read as exr_read, AnyChannel, AnyChannels, Encoding, FlatSamples, Image as ExrImage,
    ImageAttributes, Layer, LayerAttributes, ReadChannels, ReadLayers, SmallVec, SpecificChannels,
    Vec2 as ExrVec2, WritableImage,
};

use super::Metadata;
use crate::error::{Error, Result};
use crate::film::Image;

/// Runs an `exr` crate decode so that a panic inside it (the crate has integer-overflow bugs on
/// corrupt compressed blocks: fuzzing found one in its B44 decompressor, `tests/scene/hostile.rs`)
/// becomes an error instead of taking the process down. Callers decode with `non_parallel()`: a
/// panic in one of the crate's own decoder threads would abort the process before this sees it.
pub(crate) fn guarded<T>(decode: impl FnOnce() -> T) -> std::result::Result<T, String> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(decode)).map_err(|p| {
        let why = p
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        format!("cannot read EXR: corrupt data (the decoder failed: {why})")
    })
}

/// A failed read of the EXR at `path` as groove's error: I/O errors as such, the rest named as
/// unreadable EXR data.
fn read_error(path: &Path, e: exr::error::Error) -> Error {
    match e {
        exr::error::Error::Io(io) => Error::io(path, io),
        other => Error::file(path, format!("cannot read EXR: {other}")),
    }
}

/// The string attributes of `meta` for an EXR header.
pub(super) fn attributes(meta: &Metadata) -> Result<LayerAttributes, String> {
    let mut attrs = LayerAttributes::default();
    for (k, v) in &meta.0 {
        // Names are NUL-terminated in the header; values are length-prefixed. Both are stored
        // as UTF-8 bytes (the exr crate's `Text` is a byte string).
        if k.is_empty() || k.contains('\0') {
            return Err(format!("metadata key {k:?} cannot be stored in EXR"));
        }
        attrs.other.insert(
            Text::from_slice_unchecked(k.as_bytes()),
            AttributeValue::Text(Text::from_slice_unchecked(v.as_bytes())),
        );
    }
    Ok(attrs)
}

/// Encodes `img` as a scan-line, ZIP-compressed float32 RGB EXR with `meta` as string attributes.
pub(super) fn write<W: Write + Seek>(w: W, img: &Image, meta: &Metadata) -> Result<(), String> {
    if img.width == 0 || img.height == 0 {
        return Err("cannot write an empty image as EXR".into());
    }
    let attrs = attributes(meta)?;
    let width = img.width as usize;
    let channels = SpecificChannels::rgb(|p: ExrVec2<usize>| {
        let px = img.data[p.y() * width + p.x()];
        (px[0], px[1], px[2])
    });
    let layer = Layer::new(
        (width, img.height as usize),
        attrs,
        Encoding::SMALL_LOSSLESS,
        channels,
    );
    ExrImage::from_layer(layer)
        .write()
        .to_buffered(w)
        .map_err(|e| format!("cannot encode EXR: {e}"))
}

/// Encodes `img` as R, G, B plus the named `extra` channels (one f32 per pixel each, e.g.
/// `depth.T`), float32, in one layer as Mitsuba's `hdrfilm` writes AOVs (the file stores the
/// channels sorted by name, as OpenEXR requires).
pub(super) fn write_channels<W: Write + Seek>(
    w: W,
    img: &Image,
    extra: &[(String, Vec<f32>)],
    meta: &Metadata,
    window: Option<super::Window>,
) -> Result<(), String> {
    if img.width == 0 || img.height == 0 {
        return Err("cannot write an empty image as EXR".into());
    }
    let n = img.width as usize * img.height as usize;
    let mut list: SmallVec<[AnyChannel<FlatSamples>; 4]> = SmallVec::new();
    for (c, name) in ["R", "G", "B"].iter().enumerate() {
        let v: Vec<f32> = img.data.iter().map(|p| p[c]).collect();
        list.push(AnyChannel::new(*name, FlatSamples::F32(v)));
    }
    for (name, v) in extra {
        if v.len() != n {
            return Err(format!(
                "channel {name:?} holds {} values, expected {n}",
                v.len()
            ));
        }
        if name.is_empty() || name.contains('\0') || ["R", "G", "B"].contains(&name.as_str()) {
            return Err(format!("channel name {name:?} cannot be stored in EXR"));
        }
        list.push(AnyChannel::new(name.as_str(), FlatSamples::F32(v.clone())));
    }
    let mut names: Vec<&Text> = list.iter().map(|c| &c.name).collect();
    names.sort();
    if names.windows(2).any(|p| p[0] == p[1]) {
        return Err("two channels have the same name".into());
    }
    let mut attrs = attributes(meta)?;
    let display = match window {
        Some(win) => {
            let fits = win.offset.0 as u64 + img.width as u64 <= win.full.0 as u64
                && win.offset.1 as u64 + img.height as u64 <= win.full.1 as u64;
            if !fits {
                return Err("the image does not fit its display window".into());
            }
            attrs.layer_position = ExrVec2(win.offset.0 as i32, win.offset.1 as i32);
            IntegerBounds::new((0, 0), (win.full.0 as usize, win.full.1 as usize))
        }
        None => IntegerBounds::new((0, 0), (img.width as usize, img.height as usize)),
    };
    let layer = Layer::new(
        (img.width as usize, img.height as usize),
        attrs,
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(list),
    );
    ExrImage::new(ImageAttributes::new(display), layer)
        .write()
        .to_buffered(w)
        .map_err(|e| format!("cannot encode EXR: {e}"))
}

/// The first layer of the EXR at `path` with every channel and attribute, decoded on this
/// thread under [`guarded`].
pub(crate) type FirstLayer = ExrImage<Layer<AnyChannels<FlatSamples>>>;

/// Reads [`FirstLayer`] of the EXR at `path` (a corrupt file is an error, never a panic).
pub(crate) fn read_first_layer(path: &Path) -> Result<FirstLayer> {
    guarded(|| {
        exr_read()
            .no_deep_data()
            .largest_resolution_level()
            .all_channels()
            .first_valid_layer()
            .all_attributes()
            .non_parallel()
            .from_file(path)
    })
    .map_err(|m| Error::file(path, m))?
    .map_err(|e| read_error(path, e))
}

/// Every channel of the first layer of the EXR at `path`, as f32, by name (sorted), with the
/// layer's size.
pub(super) fn read_channels(path: &Path) -> Result<(u32, u32, super::Channels)> {
    let image = read_first_layer(path)?;
    let size = image.layer_data.size;
    let chans = image
        .layer_data
        .channel_data
        .list
        .iter()
        .map(|c| {
            let v: Vec<f32> = c.sample_data.values_as_f32().collect();
            (String::from_utf8_lossy(c.name.as_slice()).into_owned(), v)
        })
        .collect();
    Ok((size.width() as u32, size.height() as u32, chans))
}

/// Reads the first layer with R, G and B channels, converting samples to f32, plus all text
/// attributes of the image and the layer (decoded as UTF-8, sorted by key: the header's order is
/// not kept by the exr crate).
pub(super) fn read(path: &Path) -> Result<(Image, Metadata)> {
    let image = guarded(|| {
        exr_read()
            .no_deep_data()
            .largest_resolution_level()
            .rgb_channels(
                |res, _| Image::new(res.width() as u32, res.height() as u32),
                |img: &mut Image, p, (r, g, b): (f32, f32, f32)| {
                    let w = img.width as usize;
                    img.data[p.y() * w + p.x()] = [r, g, b];
                },
            )
            .first_valid_layer()
            .all_attributes()
            .non_parallel()
            .from_file(path)
    })
    .map_err(|m| Error::file(path, m))?
    .map_err(|e| read_error(path, e))?;
    let mut meta = Vec::new();
    let others = image
        .attributes
        .other
        .iter()
        .chain(image.layer_data.attributes.other.iter());
    for (k, v) in others {
        if let AttributeValue::Text(t) = v {
            meta.push((
                String::from_utf8_lossy(k.as_slice()).into_owned(),
                String::from_utf8_lossy(t.as_slice()).into_owned(),
            ));
        }
    }
    meta.sort();
    Ok((image.layer_data.channel_data.pixels, Metadata(meta)))
}

#[cfg(test)]
mod tests {
    use super::guarded;

    #[test]
    fn a_decoder_panic_becomes_an_error() {
        assert_eq!(guarded(|| 3), Ok(3));
        let e = guarded(|| -> u32 { panic!("attempt to subtract with overflow") }).unwrap_err();
        assert!(
            e.contains("corrupt data") && e.contains("subtract with overflow"),
            "{e}"
        );
    }
}
