//! The slow node-loss tier of the Slurm recipe (ignored by default; needs root, installs
//! Debian's Slurm when missing; about 3 minutes): `cargo test --release --test cli -- --ignored
//! node_loss`. Its name does not contain "slurm", so the `slurm` filter picks the fast tier alone.
//! Runs `scripts/slurm/e2e-node-loss.sh`: on a private single-node Slurm, a `--requeue` array
//! task is running when its node dies (slurmd, slurmstepd and the task killed); slurmctld
//! requeues it, slurmd comes back, the task renders again, and the merge must equal a single
//! render bit for bit.

use super::slurm::run_and_compare;

#[test]
#[ignore = "slow (about 3 min), needs root and Slurm; run with --ignored node_loss"]
fn node_loss_requeued_task_reruns_and_merges_to_the_single_render() {
    run_and_compare("e2e-node-loss.sh", "slurm-node-loss");
}
