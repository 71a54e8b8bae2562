//! Links Debian's Embree 3 (package `libembree-dev`) and fails early, with the package name, when it
//! is missing. The `embree3` crate emits the link directive itself; this script only checks.

use std::path::Path;

fn main() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rerun-if-changed=build.rs");
    if std::env::var_os("DOCS_RS").is_some() {
        return;
    }
    let custom = std::env::var_os("EMBREE_DIR");
    let candidates: Vec<std::path::PathBuf> = match &custom {
        Some(dir) => vec![Path::new(dir).join("lib")],
        None => vec![
            "/usr/lib/x86_64-linux-gnu".into(),
            "/usr/lib/aarch64-linux-gnu".into(),
            "/usr/lib".into(),
            "/usr/local/lib".into(),
        ],
    };
    let found = candidates.iter().any(|d| d.join("libembree3.so").exists());
    if !found {
        panic!(
            "\n\ngroove needs Intel Embree 3 (libembree3.so) and could not find it.\n\
             On Debian/Ubuntu install it with:\n\n    sudo apt-get install -y libembree-dev\n\n\
             (or point EMBREE_DIR at an Embree 3.13 installation whose lib/ holds libembree3.so)\n\n"
        );
    }
}
