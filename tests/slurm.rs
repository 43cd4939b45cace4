//! Issue 18: `frictionlab power` on a real one-node Slurm cluster.
//! `.ci/slurm-test` starts the cluster, submits `docs/slurm/submit.sh` as a
//! 4-task array with the dependent merge, compares the merged power.json
//! with an unsharded run byte for byte, and stops its daemons. Slurm and
//! munge come from `.ci/run` (apt-get); without them the test fails under
//! CI (`CI` set) and is skipped elsewhere, as it is without root (the
//! daemons run as root).
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use std::process::Command;

fn have(program: &str) -> bool {
    Command::new("sh")
        .args(["-c", &format!("command -v {program}")])
        .output()
        .is_ok_and(|o| o.status.success())
}

#[test]
fn a_four_task_slurm_array_merges_to_the_unsharded_power_json() {
    let root = Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0");
    let here = ["slurmctld", "slurmd", "sbatch", "munged"]
        .iter()
        .all(|p| have(p));
    if std::env::var_os("CI").is_some() {
        assert!(
            here && root,
            "Slurm and munge must be installed (.ci/run does) and the test run as root"
        );
    } else if !(here && root) {
        eprintln!("skipped: Slurm or munge missing, or not root");
        return;
    }
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/.ci/slurm-test");
    let o = Command::new("bash")
        .arg(script)
        .arg(env!("CARGO_BIN_EXE_frictionlab"))
        .output()
        .unwrap();
    let (out, err) = (
        String::from_utf8_lossy(&o.stdout),
        String::from_utf8_lossy(&o.stderr),
    );
    println!("{out}");
    assert!(o.status.success(), "{out}\n{err}");
    assert!(
        out.contains("merged 4-task array = unsharded run, byte for byte"),
        "{out}"
    );
}
