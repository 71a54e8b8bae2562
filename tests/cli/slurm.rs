//! The Slurm tier (ignored by default; needs root, installs Debian's Slurm when missing):
//! `cargo test --release --test cli -- --ignored slurm`. Runs `scripts/slurm/e2e-test.sh` (a
//! private single-node Slurm on 127.0.0.1: an array of tiles with one failing task, the merge
//! job naming it, the resubmission of that index alone, the merge) and compares the merged image
//! with a single render bit for bit. The slow node-loss tier is module `node_loss`.

use super::tmpdir;
use std::path::PathBuf;

#[test]
#[ignore = "needs root and Slurm (installed by the script); run with --ignored slurm"]
fn slurm_array_with_a_failed_task_resubmitted_merges_to_the_single_render() {
    run_and_compare("e2e-test.sh", "slurm-e2e");
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
        .arg(&d)
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
