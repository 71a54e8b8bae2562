//! A test's scratch folder under the system's temporary directory, removed when the test is done.

use std::path::{Path, PathBuf};

/// A fresh folder `NAME` under the temporary directory (emptied first if a crashed run left it).
/// It derefs to its [`Path`] and is removed on drop, except while the thread panics, so that a
/// failing test leaves its files behind to look at. Without this every test run left its scenes
/// and images in `/tmp` (about 90 MB a run).
pub struct Scratch(PathBuf);

impl Scratch {
    /// Creates `temp_dir()/name`; `name` should hold the process id so that concurrent runs differ.
    pub fn new(name: &str) -> Scratch {
        let dir = std::env::temp_dir().join(name);
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap_or_else(|e| panic!("{}: {e}", dir.display()));
        Scratch(dir)
    }
}

impl std::ops::Deref for Scratch {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.0
    }
}

impl AsRef<Path> for Scratch {
    fn as_ref(&self) -> &Path {
        &self.0
    }
}

impl Drop for Scratch {
    fn drop(&mut self) {
        if !std::thread::panicking() {
            let _ = std::fs::remove_dir_all(&self.0);
        }
    }
}

/// A file in a [`Scratch`] folder of its own: derefs to the file's path; the folder goes with it.
pub struct ScratchFile {
    path: PathBuf,
    _dir: Scratch,
}

impl ScratchFile {
    /// `dir/file` (not created: the caller writes it).
    pub fn new(dir: Scratch, file: &str) -> ScratchFile {
        ScratchFile {
            path: dir.join(file),
            _dir: dir,
        }
    }
}

impl std::ops::Deref for ScratchFile {
    type Target = Path;
    fn deref(&self) -> &Path {
        &self.path
    }
}

impl AsRef<Path> for ScratchFile {
    fn as_ref(&self) -> &Path {
        &self.path
    }
}
