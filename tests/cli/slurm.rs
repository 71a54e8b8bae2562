//! The Slurm tier: part of `cargo test --release` when run as root (as CI runs), which installs
//! Debian's Slurm when missing (about 40 s once, then about 15 s a run: issue 20 asks for it in
//! CI when it adds at most 2 minutes); as any other user it says it is skipped and passes, since
//! it cannot start daemons or install packages. Alone: `cargo test --release --test cli slurm`.
//! Runs `scripts/slurm/e2e-test.sh` (a
//! private single-node Slurm on 127.0.0.1: an array of tiles with one failing task, the merge
//! job naming it, the resubmission of that index alone, the merge) and compares the merged image
//! with a single render bit for bit. The slow node-loss tier is module `node_loss`.

use super::tmpdir;
use std::path::PathBuf;

#[test]
fn slurm_array_with_a_failed_task_resubmitted_merges_to_the_single_render() {
    if !is_root() {
        eprintln!("skipped: the Slurm tier needs root (it installs Slurm and starts its daemons)");
        return;
    }
    run_and_compare("e2e-test.sh", "slurm-e2e");
}

/// Whether this process runs as root (`id -u` is 0).
fn is_root() -> bool {
    std::process::Command::new("id")
        .arg("-u")
        .output()
        .map(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
        .unwrap_or(false)
}

/// Runs `scripts/slurm/SCRIPT GROOVE DIR`, which must succeed and leave `result.exr` (the
/// merge of the Slurm job's parts) and `single.exr` (one plain render) in DIR, and checks that
/// the two are the same bits.
pub(super) fn run_and_compare(script: &str, name: &str) {
    let d = tmpdir(name);
    let script = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("scripts/slurm")
        .join(script);
    let out = std::process::Command::new("bash")
        .arg(&script)
        .arg(assert_cmd::cargo::cargo_bin("groove"))
        .arg(d.as_os_str())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    let read = |name: &str| groove::output::read_exr_channels(&d.join(name)).unwrap();
    let (a, b) = (read("result.exr"), read("single.exr"));
    assert_eq!((a.0, a.1), (b.0, b.1));
    assert_eq!(a.2.len(), b.2.len());
    for ((na, va), (nb, vb)) in a.2.iter().zip(&b.2) {
        assert_eq!(na, nb);
        let same = va.iter().zip(vb).all(|(x, y)| x.to_bits() == y.to_bits());
        assert!(
            same,
            "channel {na} differs between the merge and the single render"
        );
    }
}
