//! Mitsuba's binary grid-volume file (`.vol`, read by `VolumeGrid::read` in
//! `src/render/volumegrid.cpp`), all little-endian:
//!
//! | bytes | content |
//! |---|---|
//! | 3 | `VOL` |
//! | 1 | version, 3 |
//! | 4 | data type (i32), 1 = float32 (the only one Mitsuba 3.9.1 reads) |
//! | 12 | size x, y, z (i32 each) |
//! | 4 | channels (i32) |
//! | 24 | bounding box min x, y, z, max x, y, z (f32; `gridvolume`'s `use_grid_bbox`, not used by `sdfgrid`) |
//! | 4·x·y·z·channels | values (f32), channel fastest, then x, then y, then z |
//!
//! One reader for both users: the `sdfgrid` shape (`crate::geometry::sdfgrid`) and the
//! `gridvolume` of heterogeneous media (`crate::medium::volume`), each checking what it needs of
//! the channel count and the values.
//!
//! The sizes are checked against the file's length and the memory budget before the values
//! are read; every error names the offset it was found at.

use crate::budget::Budget;
use std::io::Read;
use std::path::Path;

/// The size of the header in bytes.
const HEADER: u64 = 48;

/// A grid read from a `.vol` file.
#[derive(Clone, Debug)]
pub struct VolGrid {
    /// Size along x, y, z.
    pub size: [u32; 3],
    pub channels: u32,
    /// The bounding box stored in the header: min x, y, z, then max x, y, z.
    pub bbox: [f32; 6],
    /// Values, channel fastest, then x, y, z.
    pub data: Vec<f32>,
}

/// Reads `path` as a `.vol` file, reserving its values' memory in `budget` first.
pub fn read_vol(path: &Path, budget: &Budget) -> Result<VolGrid, String> {
    let file = std::fs::File::open(path).map_err(|e| format!("cannot open: {e}"))?;
    let len = file
        .metadata()
        .map_err(|e| format!("cannot stat: {e}"))?
        .len();
    let mut r = std::io::BufReader::new(file);
    let mut head = [0u8; HEADER as usize];
    r.read_exact(&mut head).map_err(|_| {
        format!("truncated header: the file has {len} bytes, a volume header has {HEADER}")
    })?;
    if &head[0..3] != b"VOL" {
        return Err("offset 0: not a Mitsuba volume file (no 'VOL' magic)".into());
    }
    if head[3] != 3 {
        return Err(format!(
            "offset 3: version {} (only version 3 is supported, as in Mitsuba)",
            head[3]
        ));
    }
    let int = |at: usize| i32::from_le_bytes([head[at], head[at + 1], head[at + 2], head[at + 3]]);
    let kind = int(4);
    if kind != 1 {
        return Err(format!(
            "offset 4: data type {kind} (only 1, float32, is supported, as in Mitsuba)"
        ));
    }
    let mut size = [0u32; 3];
    for (k, s) in size.iter_mut().enumerate() {
        let v = int(8 + 4 * k);
        *s = u32::try_from(v)
            .ok()
            .filter(|&v| v > 0)
            .ok_or_else(|| format!("offset {}: size {v} must be positive", 8 + 4 * k))?;
    }
    let channels = int(20);
    let channels = u32::try_from(channels)
        .ok()
        .filter(|&c| c > 0)
        .ok_or_else(|| format!("offset 20: channel count {channels} must be positive"))?;
    let count = size
        .iter()
        .map(|&s| u64::from(s))
        .product::<u64>()
        .saturating_mul(u64::from(channels));
    let bytes = count.saturating_mul(4);
    if HEADER.saturating_add(bytes) != len {
        return Err(format!(
            "offset {HEADER}: {}x{}x{} voxels of {channels} channel(s) need {bytes} bytes of \
             values, the file has {}",
            size[0],
            size[1],
            size[2],
            len.saturating_sub(HEADER)
        ));
    }
    let mut bbox = [0f32; 6];
    for (k, b) in bbox.iter_mut().enumerate() {
        let at = 24 + 4 * k;
        *b = f32::from_le_bytes([head[at], head[at + 1], head[at + 2], head[at + 3]]);
    }
    budget.reserve(
        bytes,
        &format!("volume grid {}x{}x{}x{channels}", size[0], size[1], size[2]),
    )?;
    let n = usize::try_from(count).map_err(|_| "grid too large for this machine".to_string())?;
    let mut data = Vec::with_capacity(n);
    let mut buf = [0u8; 4096];
    while data.len() < n {
        let want = ((n - data.len()) * 4).min(buf.len());
        r.read_exact(&mut buf[..want]).map_err(|e| {
            format!(
                "offset {}: cannot read the values: {e}",
                HEADER + 4 * data.len() as u64
            )
        })?;
        data.extend(
            buf[..want]
                .chunks_exact(4)
                .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]])),
        );
    }
    Ok(VolGrid {
        size,
        channels,
        bbox,
        data,
    })
}
