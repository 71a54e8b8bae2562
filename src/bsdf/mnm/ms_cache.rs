//! Where the remainder tables of `evaluation = compensated` ([`super::ms_table`]) are kept: in
//! memory for the life of the process (one table per key, shared by every scene loaded; the
//! tables are leaked on purpose, ~60 KB each, bounded by the distinct nested BSDFs seen), and,
//! when enabled, on disk so that the next process does not rebuild them.
//!
//! The disk cache is off unless [`enable_disk_cache`] is called (the `groove` binary does, with
//! [`default_dir`]: `$XDG_CACHE_HOME/groove`, else `~/.cache/groove`); library users and tests
//! build in memory only unless they ask. A file is `ms-<FNV-1a 64 of the key>.bin` holding the
//! full key, which is compared on reading, so a hash collision or a stale layout is a miss. If
//! the folder cannot be written, the table is used from memory and the load reports a warning
//! (once per process).
//!
//! The misplaced-energy table of `evaluation = auto` ([`super::misplaced`]) is kept with its
//! remainder table (in memory: the table's own `misplaced` cell) and on disk as
//! `mm-<FNV-1a 64 of its key>.bin`, its key being the remainder table's plus the measurement's
//! parameters ([`misplaced`]).

use super::misplaced::{self as mm, Misplaced};
use super::ms_table::{MsTable, TableSpec};
use crate::bsdf::Bsdf;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

static TABLES: Mutex<Option<HashMap<String, &'static MsTable>>> = Mutex::new(None);
static DISK: Mutex<Option<PathBuf>> = Mutex::new(None);
static WARNED: Mutex<bool> = Mutex::new(false);

/// Keep tables on disk under `dir` (None: memory only, the default).
pub fn enable_disk_cache(dir: Option<PathBuf>) {
    *DISK.lock().unwrap_or_else(|e| e.into_inner()) = dir;
}

/// `$XDG_CACHE_HOME/groove`, else `$HOME/.cache/groove` (None without either).
pub fn default_dir() -> Option<PathBuf> {
    let base = match std::env::var_os("XDG_CACHE_HOME") {
        Some(x) if !x.is_empty() => PathBuf::from(x),
        _ => PathBuf::from(std::env::var_os("HOME").filter(|h| !h.is_empty())?).join(".cache"),
    };
    Some(base.join("groove"))
}

/// FNV-1a, 64 bits (stable across Rust versions, unlike `DefaultHasher`).
fn fnv1a(s: &str) -> u64 {
    let mut h: u64 = 0xcbf2_9ce4_8422_2325;
    for b in s.bytes() {
        h ^= b as u64;
        h = h.wrapping_mul(0x0100_0000_01b3);
    }
    h
}

/// The file of `key` under `dir`.
pub fn file_of(dir: &Path, key: &str) -> PathBuf {
    dir.join(format!("ms-{:016x}.bin", fnv1a(key)))
}

/// How a table was obtained (for the load's report).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Source {
    Memory,
    Disk,
    Built,
}

/// The table of `key`: from memory, from the disk cache, or built by `build` (and then stored).
/// The build runs without holding a lock (it may use rayon). Returns the table, where it came
/// from, and a warning when the disk cache could not be written.
pub fn get_or_build(
    key: &str,
    spec: TableSpec,
    build: impl FnOnce() -> MsTable,
) -> (&'static MsTable, Source, Option<String>) {
    if let Some(t) = TABLES
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .get_or_insert_with(HashMap::new)
        .get(key)
    {
        return (t, Source::Memory, None);
    }
    let dir = DISK.lock().unwrap_or_else(|e| e.into_inner()).clone();
    let from_disk = dir.as_ref().and_then(|d| {
        let bytes = std::fs::read(file_of(d, key)).ok()?;
        MsTable::from_bytes(&bytes, key, spec)
    });
    let (table, source, warning) = match from_disk {
        Some(t) => (t, Source::Disk, None),
        None => {
            let t = build();
            let warning = dir.and_then(|d| store(&d, key, &t).err());
            (t, Source::Built, warning)
        }
    };
    let warning = warning.filter(|_| {
        let mut w = WARNED.lock().unwrap_or_else(|e| e.into_inner());
        !std::mem::replace(&mut *w, true)
    });
    let mut map = TABLES.lock().unwrap_or_else(|e| e.into_inner());
    let map = map.get_or_insert_with(HashMap::new);
    // Another thread may have stored the same table meanwhile: keep the first.
    let t: &'static MsTable = match map.get(key) {
        Some(t) => t,
        None => {
            let t: &'static MsTable = Box::leak(Box::new(table));
            map.insert(key.to_string(), t);
            t
        }
    };
    (t, source, warning)
}

/// Write `t` under `dir` atomically (a temporary file renamed into place).
fn store(dir: &Path, key: &str, t: &MsTable) -> Result<(), String> {
    write_atomic(dir, &file_of(dir, key), &t.to_bytes())
}

/// Write `bytes` to `path` under `dir` atomically (a temporary file renamed into place).
fn write_atomic(dir: &Path, path: &Path, bytes: &[u8]) -> Result<(), String> {
    let fail = |e: std::io::Error| {
        format!(
            "cannot write the compensated normal-mapping table cache in '{}' ({e}); tables are rebuilt at every run",
            dir.display()
        )
    };
    std::fs::create_dir_all(dir).map_err(fail)?;
    let tmp = path.with_extension(format!("tmp{}", std::process::id()));
    std::fs::write(&tmp, bytes).map_err(fail)?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        fail(e)
    })
}

/// Set `table`'s misplaced-energy table (`evaluation = auto`) if it is not yet: from the disk
/// cache, else measured against the walk over `nested` (node `nested_index` of its arena) and
/// stored. A write failure is the same once-per-process warning as for the tables, returned.
pub fn misplaced(table: &'static MsTable, nested: &Bsdf, nested_index: u32) -> Option<String> {
    if table.misplaced.get().is_some() {
        return None;
    }
    let key = format!(
        "{} misplaced v{} cells={}x{} wi={} walks={} band={}..{}",
        table.key,
        mm::VERSION,
        mm::CELLS_U,
        mm::CELLS_PHI,
        mm::WI,
        mm::WALKS,
        mm::LO,
        mm::HI
    );
    let dir = DISK.lock().unwrap_or_else(|e| e.into_inner()).clone();
    let file = |d: &Path| d.join(format!("mm-{:016x}.bin", fnv1a(&key)));
    let from_disk = dir.as_ref().and_then(|d| {
        let bytes = std::fs::read(file(d)).ok()?;
        Misplaced::from_bytes(&bytes, &key)
    });
    let mut warning = None;
    let m = match from_disk {
        Some(m) => m,
        None => {
            let m = Misplaced::measure(nested, nested_index, table, mm::WALKS);
            if let Some(d) = &dir {
                warning = write_atomic(d, &file(d), &m.to_bytes(&key)).err();
            }
            m
        }
    };
    // Another thread may have set it meanwhile: the first stays (the same measurement).
    let _ = table.misplaced.set(m);
    warning.filter(|_| {
        let mut w = WARNED.lock().unwrap_or_else(|e| e.into_inner());
        !std::mem::replace(&mut *w, true)
    })
}
