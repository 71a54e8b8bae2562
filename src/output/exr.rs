//! OpenEXR input and output through the `exr` crate.

use std::io::{Seek, Write};
use std::path::Path;

use exr::meta::attribute::{AttributeValue, Text};
use exr::prelude::{
    read as exr_read, Encoding, Image as ExrImage, Layer, LayerAttributes, ReadChannels,
    ReadLayers, SpecificChannels, Vec2 as ExrVec2, WritableImage,
};

use super::Metadata;
use crate::error::{Error, Result};
use crate::film::Image;

/// Encodes `img` as a scan-line, ZIP-compressed float32 RGB EXR with `meta` as string attributes.
pub(super) fn write<W: Write + Seek>(w: W, img: &Image, meta: &Metadata) -> Result<(), String> {
    if img.width == 0 || img.height == 0 {
        return Err("cannot write an empty image as EXR".into());
    }
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

/// Reads the first layer with R, G and B channels, converting samples to f32, plus all text
/// attributes of the image and the layer (decoded as UTF-8, sorted by key: the header's order is
/// not kept by the exr crate).
pub(super) fn read(path: &Path) -> Result<(Image, Metadata)> {
    let image = exr_read()
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
        .from_file(path)
        .map_err(|e| match e {
            exr::error::Error::Io(io) => Error::io(path, io),
            other => Error::file(path, format!("cannot read EXR: {other}")),
        })?;
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
