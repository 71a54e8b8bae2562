//! Writing rendered images: OpenEXR (float32 RGB plus string metadata) and PNG (8-bit sRGB).
//!
//! Every write is atomic: the image goes to a temporary file next to the target
//! (`.NAME.tmp-<pid>`), is flushed to disk, and is then renamed over the target. On any failure
//! the temporary file is removed and an existing target stays untouched.

pub mod clash;
mod exr;
mod header_order;
pub mod part;
pub(crate) use exr::guarded as exr_guarded;
pub(crate) mod png;

use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::budget::{bytes_of, Budget};
use crate::error::{Error, Result};
use crate::film::Image;

/// Key/value pairs stored in the image header (EXR string attributes), e.g. `groove.spp`,
/// `groove.seed`, `groove.render_time_s`, `groove.scene`, `groove.version`. Strings are
/// stored as UTF-8 bytes. [`read_exr`] returns them sorted by key.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Metadata(pub Vec<(String, String)>);

impl Metadata {
    /// The value stored under `key`, if any.
    pub fn get(&self, key: &str) -> Option<&str> {
        self.0
            .iter()
            .find(|(k, _)| k == key)
            .map(|(_, v)| v.as_str())
    }
}

/// Writes `img` to `path`, choosing the format by extension (case-insensitive): `.exr` (float32
/// RGB with `meta` as string attributes) or `.png` (8-bit sRGB, clamped; `meta` is not stored).
/// Any other extension is an [`Error::Usage`] naming it.
pub fn write_image(path: &Path, img: &Image, meta: &Metadata) -> Result<()> {
    let format = check_extension(path)?;
    if img.data.len() != img.width as usize * img.height as usize {
        return Err(Error::file(
            path,
            format!(
                "image data holds {} pixels, expected {}x{}",
                img.data.len(),
                img.width,
                img.height
            ),
        ));
    }
    match format {
        Format::Exr => write_exr_atomic(path, |w| exr::write(w, img, meta)),
        Format::Png => write_atomic(path, |w| png::write(w, img)),
    }
}

/// Like [`write_image`], with extra named channels (the integrator's AOVs, one value per pixel
/// each). An EXR stores them beside R, G, B in one layer, named as given (Mitsuba's names, e.g.
/// `dd.T`, `m2_nested.X`); a PNG holds the RGB image only, so for `.png` the channels are
/// dropped and `Ok(false)` says so. With no extra channels this is [`write_image`].
pub fn write_image_channels(
    path: &Path,
    img: &Image,
    extra: &[(String, Vec<f32>)],
    meta: &Metadata,
) -> Result<bool> {
    if extra.is_empty() {
        return write_image(path, img, meta).map(|_| true);
    }
    match check_extension(path)? {
        Format::Png => write_image(path, img, meta).map(|_| false),
        Format::Exr => {
            if img.data.len() != img.width as usize * img.height as usize {
                return Err(Error::file(path, "image data does not match its size"));
            }
            write_exr_atomic(path, |w| exr::write_channels(w, img, extra, meta, None))?;
            Ok(true)
        }
    }
}

/// Where an image lies in a larger frame (a crop of a film): the frame's size and the image's
/// top-left pixel in it. An EXR stores them as its display and data windows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Window {
    pub full: (u32, u32),
    pub offset: (u32, u32),
}

/// [`write_image_channels`] of an image that is the `window` of a larger frame: an EXR gets
/// the frame as display window and the image as data window (viewers place it); a PNG holds
/// the image alone. With `None` this is [`write_image_channels`].
pub fn write_image_window(
    path: &Path,
    img: &Image,
    extra: &[(String, Vec<f32>)],
    meta: &Metadata,
    window: Option<Window>,
) -> Result<bool> {
    let Some(win) = window else {
        return write_image_channels(path, img, extra, meta);
    };
    match check_extension(path)? {
        Format::Png => write_image(path, img, meta).map(|_| extra.is_empty()),
        Format::Exr => {
            if img.data.len() != img.width as usize * img.height as usize {
                return Err(Error::file(path, "image data does not match its size"));
            }
            write_exr_atomic(path, |w| {
                exr::write_channels(w, img, extra, meta, Some(win))
            })?;
            Ok(true)
        }
    }
}

/// Writes 8-bit RGB pixels (row-major, top row first) as a PNG, atomically.
pub fn write_png_rgb8(path: &Path, width: u32, height: u32, rgb: &[u8]) -> Result<()> {
    use image::{codecs::png::PngEncoder, ExtendedColorType, ImageEncoder};
    write_atomic(path, |w| {
        PngEncoder::new(w)
            .write_image(rgb, width, height, ExtendedColorType::Rgb8)
            .map_err(|e| format!("cannot encode PNG: {e}"))
    })
}

/// The image formats groove writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    Exr,
    Png,
}

/// The format `path` names by its extension (case-insensitive), checked before a render starts;
/// any other extension is an [`Error::Usage`] naming it.
pub fn check_extension(path: &Path) -> Result<Format> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("exr") => Ok(Format::Exr),
        Some("png") => Ok(Format::Png),
        other => Err(Error::Usage(format!(
            "{}: unsupported output format {} (use .exr or .png)",
            path.display(),
            match other {
                Some(e) => format!("'.{e}'"),
                None => "(no extension)".to_string(),
            }
        ))),
    }
}

/// Reads an RGB EXR (f16, f32 or u32 channels named R, G, B, e.g. Mitsuba's output) and its
/// string attributes.
pub fn read_exr(path: &Path) -> Result<(Image, Metadata)> {
    exr::read(path)
}

/// Named image channels, one f32 per pixel each, row-major.
pub type Channels = Vec<(String, Vec<f32>)>;

/// Every channel of an EXR's first layer by name (sorted), as f32, with its width and height:
/// how tests and tools read the AOV channels that [`write_image_channels`] writes.
pub fn read_exr_channels(path: &Path) -> Result<(u32, u32, Channels)> {
    exr::read_channels(path)
}

/// [`read_exr`] of a regular file whose image (from its header, before any pixel is read),
/// with `extra` more bytes per pixel kept by the caller, fits `budget`; the pixels and the
/// extra stay reserved.
pub fn read_exr_within(path: &Path, budget: &Budget, extra: u64) -> Result<(Image, Metadata)> {
    let (f, _) = crate::inputs::open_regular(path)?;
    let (w, h, nch) = exr_size(std::io::BufReader::new(f)).map_err(|m| Error::file(path, m))?;
    let what = format!("EXR image {w}×{h} ({})", path.display());
    budget
        .check(bytes_of(&[w, h, 12 + 4 * nch + extra]), &what)
        .and_then(|_| budget.reserve(bytes_of(&[w, h, 12 + extra]), &what))
        .map_err(|m| Error::file(path, m))?;
    exr::read(path)
}

/// The width, height and channel count of an OpenEXR file's largest layer, read from its
/// headers only (no pixel data is touched, nothing large is allocated).
pub fn exr_size(r: impl std::io::Read) -> std::result::Result<(u64, u64, u64), String> {
    let meta = ::exr::meta::MetaData::read_from_buffered(r, false)
        .map_err(|e| format!("cannot read the EXR header: {e}"))?;
    meta.headers
        .iter()
        .map(|h| {
            (
                h.layer_size.width() as u64,
                h.layer_size.height() as u64,
                h.channels.list.len() as u64,
            )
        })
        .max_by_key(|&(w, h, c)| bytes_of(&[w, h, c]))
        .ok_or_else(|| "the EXR file has no header".to_string())
}

/// The temporary file used while writing `path`.
fn temp_path(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

/// [`write_atomic`] of an EXR: `encode` writes it, then its header's attributes are sorted by
/// name ([`header_order`]), so one image with one metadata is one file, byte for byte.
pub(crate) fn write_exr_atomic(
    path: &Path,
    encode: impl FnOnce(&mut BufWriter<File>) -> std::result::Result<(), String>,
) -> Result<()> {
    write_atomic(path, |w| {
        encode(w)?;
        header_order::sort_written(w)
    })
}

/// Runs `encode` into a temporary file beside `path`, syncs it and renames it over `path`.
/// The encoder's errors are plain messages; they are reported against `path`.
/// Write a file through a temporary sibling and a rename, so a failure never leaves a partial
/// file or touches an existing good one.
pub fn write_atomic(
    path: &Path,
    encode: impl FnOnce(&mut BufWriter<File>) -> std::result::Result<(), String>,
) -> Result<()> {
    if path.file_name().is_none() {
        return Err(Error::file(path, "output path has no file name"));
    }
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    };
    if !dir.is_dir() {
        return Err(Error::file(
            &dir,
            "output directory does not exist (create it first)",
        ));
    }
    if path.is_dir() {
        return Err(Error::file(path, "output path is a directory"));
    }
    let tmp = temp_path(path);
    let result = (|| -> Result<()> {
        // Readable too: an EXR's header is reordered in place after its encoding.
        let file = fs::OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(true)
            .open(&tmp)
            .map_err(|e| Error::io(&tmp, e))?;
        let mut w = BufWriter::new(file);
        encode(&mut w).map_err(|m| Error::file(path, m))?;
        w.flush().map_err(|e| Error::io(&tmp, e))?;
        let file = w
            .into_inner()
            .map_err(|e| Error::io(&tmp, e.into_error()))?;
        file.sync_all().map_err(|e| Error::io(&tmp, e))?;
        drop(file);
        fs::rename(&tmp, path).map_err(|e| Error::io(path, e))?;
        Ok(())
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    } else if let Ok(d) = File::open(&dir) {
        // Make the rename itself durable; best effort (not supported everywhere).
        let _ = d.sync_all();
    }
    result
}
