//! Reading input files (scenes, includes, meshes, images): only regular files are opened, so a
//! FIFO cannot block the load, a directory is not "not found" and `/dev/zero` is not read until
//! memory runs out; the size is known before reading and checked against the [`Budget`].

use std::fs::{File, Metadata};
use std::io::Read;
use std::path::Path;

use crate::budget::{gb, Budget};
use crate::error::{Error, Result};

/// What kind of file `m` describes, for messages about files that are not regular.
fn kind(m: &Metadata) -> &'static str {
    let t = m.file_type();
    if t.is_dir() {
        return "a directory";
    }
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if t.is_fifo() {
            return "a FIFO (named pipe)";
        }
        if t.is_char_device() {
            return "a character device";
        }
        if t.is_block_device() {
            return "a block device";
        }
        if t.is_socket() {
            return "a socket";
        }
    }
    "not a regular file"
}

/// Checks that `path` (symbolic links followed) is a regular file; returns its size. The
/// metadata is read without opening the file, so a FIFO never blocks.
pub fn check_regular(path: &Path) -> Result<u64> {
    let m = std::fs::metadata(path).map_err(|e| Error::io(path, e))?;
    if !m.is_file() {
        return Err(Error::file(
            path,
            format!(
                "is {}; only regular files are read as scenes, meshes and images",
                kind(&m)
            ),
        ));
    }
    Ok(m.len())
}

/// Opens a regular file (see [`check_regular`]); returns it with its size.
pub fn open_regular(path: &Path) -> Result<(File, u64)> {
    let len = check_regular(path)?;
    let f = File::open(path).map_err(|e| Error::io(path, e))?;
    // The path may have been swapped between the two calls: check what was opened.
    let m = f.metadata().map_err(|e| Error::io(path, e))?;
    if !m.is_file() {
        return Err(Error::file(path, format!("is {}", kind(&m))));
    }
    Ok((f, len))
}

/// Reads a whole regular file whose size fits the budget (checked, not reserved: the bytes
/// are parsed and dropped). Reads at most the size the metadata gave.
pub fn read_regular(path: &Path, budget: &Budget) -> Result<Vec<u8>> {
    let (f, len) = open_regular(path)?;
    budget
        .check(len, &format!("reading {} ({})", path.display(), gb(len)))
        .map_err(|m| Error::file(path, m))?;
    let mut buf = Vec::with_capacity(len as usize);
    f.take(len)
        .read_to_end(&mut buf)
        .map_err(|e| Error::io(path, e))?;
    Ok(buf)
}
