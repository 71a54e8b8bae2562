//! Outputs that would destroy data are refused before anything is rendered: an output that is
//! one of the render's inputs (the scene, an included file, a mesh, an image), and two scenes
//! of one batch that would write the same file (`a/x.xml b/x.xml -o out`: both `out/x.exr`).
//! The rule is to refuse, never to rename: a renamed output is as surprising as a lost one.

use std::path::{Path, PathBuf};

/// A key that is equal for two spellings of one output path: the canonical folder (when it
/// exists) joined with the file name.
pub fn output_key(path: &Path) -> PathBuf {
    let abs = match std::env::current_dir() {
        Ok(cwd) if path.is_relative() => cwd.join(path),
        _ => path.to_path_buf(),
    };
    if let Ok(c) = std::fs::canonicalize(&abs) {
        // The file exists (possibly as a symbolic link): its real path.
        return c;
    }
    match (abs.parent(), abs.file_name()) {
        (Some(dir), Some(name)) => std::fs::canonicalize(dir)
            .unwrap_or_else(|_| dir.to_path_buf())
            .join(name),
        _ => abs,
    }
}

/// Whether `a` and `b` name the same existing file (same device and inode on Unix, so hard
/// links count; the same canonical path elsewhere).
pub fn same_file(a: &Path, b: &Path) -> bool {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        if let (Ok(ma), Ok(mb)) = (std::fs::metadata(a), std::fs::metadata(b)) {
            return ma.dev() == mb.dev() && ma.ino() == mb.ino();
        }
        false
    }
    #[cfg(not(unix))]
    {
        matches!(
            (std::fs::canonicalize(a), std::fs::canonicalize(b)),
            (Ok(x), Ok(y)) if x == y
        )
    }
}

/// Checks a batch before it starts: no two scenes write the same output, and no output is one
/// of the batch's scene files. `jobs` pairs each scene with its output.
pub fn check_batch(jobs: &[(PathBuf, PathBuf)]) -> Result<(), String> {
    for (i, (scene, out)) in jobs.iter().enumerate() {
        let key = output_key(out);
        if let Some((first, _)) = jobs[..i].iter().find(|(_, o)| output_key(o) == key) {
            return Err(format!(
                "{} and {} would both be written to {}; nothing was rendered (render them \
                 separately with -o, or rename one scene file)",
                first.display(),
                scene.display(),
                out.display()
            ));
        }
        if let Some((s, _)) = jobs.iter().find(|(s, _)| same_file(s, out)) {
            return Err(format!(
                "output {} is the scene file {}; nothing was rendered",
                out.display(),
                s.display()
            ));
        }
    }
    Ok(())
}

/// Checks that `out` is none of `inputs` (the files the render reads); the message names the
/// input.
pub fn check_not_input(out: &Path, inputs: &[PathBuf]) -> Result<(), String> {
    match inputs.iter().find(|i| same_file(i, out)) {
        Some(i) => Err(format!(
            "output {} would overwrite {}, an input of the render; choose another -o",
            out.display(),
            i.display()
        )),
        None => Ok(()),
    }
}
