//! The user's documentation stays inside the repository: every relative Markdown link of README.md
//! and docs/**/*.md names a file or folder of the checkout, and no page points at the team's
//! shared folder or at a machine path (the documents it needs are copied into docs/). The one
//! exception is the shared scene set (`../shared/scenes/`), which the tests also read from beside
//! the checkout.

use std::path::{Path, PathBuf};

/// Text that names a place outside the repository.
const OUTSIDE: [&str; 4] = [
    "../shared/spec",
    "../shared/design",
    "../shared/tools",
    "/work/",
];

/// Generated reports whose "Command:" line records the run as it was typed.
const GENERATED: [&str; 1] = ["docs/bench/groove-bench.md"];

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn markdown_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() {
            markdown_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "md") {
            out.push(p);
        }
    }
}

/// The targets of the inline links and images `[text](target)` / `![alt](target "title")`.
fn link_targets(text: &str) -> Vec<(usize, String)> {
    let mut out = Vec::new();
    let mut rest = text;
    let mut offset = 0;
    while let Some(i) = rest.find("](") {
        let after = &rest[i + 2..];
        let end = after.find([')', ' ', '\n']).unwrap_or(after.len());
        let line = text[..offset + i].matches('\n').count() + 1;
        out.push((line, after[..end].to_string()));
        offset += i + 2;
        rest = after;
    }
    out
}

#[test]
fn readme_and_docs_links_resolve_inside_the_repository() {
    let root = root().canonicalize().unwrap();
    let mut files = vec![root.join("README.md")];
    markdown_files(&root.join("docs"), &mut files);
    let mut bad = Vec::new();
    let mut checked = 0;
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        let rel = f
            .strip_prefix(&root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        for (line, target) in link_targets(&text) {
            if target.contains("://") || target.starts_with('#') || target.starts_with("mailto:") {
                continue;
            }
            let path = target.split('#').next().unwrap();
            let resolved = f.parent().unwrap().join(path);
            checked += 1;
            match resolved.canonicalize() {
                Ok(p) if p.starts_with(&root) => {}
                Ok(p) => bad.push(format!(
                    "{rel}:{line}: `{target}` leaves the repository ({})",
                    p.display()
                )),
                Err(_) => bad.push(format!("{rel}:{line}: `{target}` does not exist")),
            }
        }
        if GENERATED.contains(&rel.as_str()) {
            continue;
        }
        for (n, l) in text.lines().enumerate() {
            for o in OUTSIDE {
                if l.contains(o) {
                    bad.push(format!("{rel}:{}: names `{o}`: {l}", n + 1));
                }
            }
        }
    }
    assert!(
        checked >= 10,
        "only {checked} links found: is the link scanner broken?"
    );
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn link_scanner_finds_links_images_and_titles() {
    let t = "a [x](one.md) b\n![img\nalt](pics/two.png \"title\") [y](#anchor) [z](three.md#s)";
    let got = link_targets(t);
    let want = [
        (1, "one.md"),
        (3, "pics/two.png"),
        (3, "#anchor"),
        (3, "three.md#s"),
    ];
    assert_eq!(got.len(), want.len(), "{got:?}");
    for ((gl, gt), (wl, wt)) in got.iter().zip(want) {
        assert_eq!((*gl, gt.as_str()), (wl, wt));
    }
}
