//! Power planning (issue 18): a known answer, sharding that changes no
//! byte, refused merges, and a killed shard's rerun.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use frictionlab::kinds::Registry;
use frictionlab::participant::Population;
use frictionlab::participant::population::PairedPreference;
use frictionlab::power::{self, Plan, PlanHeader, Shard};
use frictionlab::protocol::load;

const BIN: &str = env!("CARGO_BIN_EXE_frictionlab");

fn protocol_path(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("protocols")
        .join(format!("{name}.json"))
}

fn frictionlab(args: &[&str]) -> Output {
    Command::new(BIN).args(args).output().unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Exact power of the two-sided exact binomial test (p = min(1, 2 P(X <=
/// min(k, n - k))) under an even split) at level `alpha`, when each of `n`
/// participants chooses one side with probability `q`: the sum of the
/// Binomial(n, q) probabilities of the significant counts. Computed here
/// from factorials, apart from the analysis's statrs.
fn exact_power(n: i32, q: f64, alpha: f64) -> f64 {
    let choose = |k: i32| -> f64 {
        (0..k)
            .map(|i| f64::from(n - i) / f64::from(i + 1))
            .product()
    };
    let even = |k: i32| choose(k) * 0.5f64.powi(n);
    (0..=n)
        .filter(|&k| {
            let tail: f64 = (0..=k.min(n - k)).map(even).sum();
            (2.0 * tail).min(1.0) < alpha
        })
        .map(|k| choose(k) * q.powi(k) * (1.0 - q).powi(n - k))
        .sum()
}

/// A paired comparison whose simulated participants call time-varying
/// friction nearer with probability 0.75 (one trial each): its power is a
/// binomial tail, and the estimate from 200 replayed studies per size lands
/// within 2 Monte Carlo standard errors of it at each size.
#[test]
fn estimated_power_matches_the_exact_binomial_power_within_two_mcse() {
    let (protocol, bytes) = load::read::<Registry>(&protocol_path("paired-quick")).unwrap();
    let q = 0.75;
    let population = Population {
        paired_preference: Some(PairedPreference {
            condition: "time_varying".into(),
            p: q,
        }),
        ..Population::default()
    };
    let header = PlanHeader {
        protocol: protocol.id.clone(),
        kind: "paired_comparison".into(),
        protocol_sha256: String::new(),
        participants: vec![6, 10, 16],
        studies: 200,
        seed: 18,
        alpha: 0.05,
        target_power: 0.8,
        max_ci_width: 0.05,
        population: Some(population),
    };
    let plan = Plan {
        header: header.clone(),
        protocol: &protocol,
        protocol_bytes: &bytes,
    };
    let dir = tempfile::tempdir().unwrap();
    let outcome = power::run_shard(&plan, Shard::ALL, dir.path(), 2, &|_, _| {}).unwrap();
    assert_eq!(outcome.studies.len(), 600);
    let summary = power::summarize(&header, &outcome.studies);
    let test = &summary["tests"][0];
    assert_eq!(test["name"], "paired_comparison.binomial_p");
    for (point, n) in test["points"].as_array().unwrap().iter().zip([6, 10, 16]) {
        let exact = exact_power(n, q, 0.05);
        let mcse = (exact * (1.0 - exact) / 200.0).sqrt();
        let estimate = point["power"].as_f64().unwrap();
        println!(
            "n = {n}: estimated {estimate:.3} (reported MCSE {:.4}), exact {exact:.4}, {:.2} MCSE apart",
            point["mcse"].as_f64().unwrap(),
            (estimate - exact).abs() / mcse
        );
        assert_eq!(point["participants"], n);
        assert_eq!(point["na"], 0, "every study has decisive answers");
        assert!(
            (estimate - exact).abs() <= 2.0 * mcse,
            "n = {n}: estimated {estimate}, exact {exact}, MCSE {mcse}"
        );
    }
    // The hand-checked tails: n = 6 needs all six alike (0.75^6 + 0.25^6).
    assert!((exact_power(6, q, 0.05) - (0.75f64.powi(6) + 0.25f64.powi(6))).abs() < 1e-12);
}

const PLAN: [&str; 8] = [
    "--participants",
    "3,5",
    "--studies",
    "12",
    "--seed",
    "7",
    "--jobs",
    "2",
];

fn power_run(out: &Path, extra: &[&str]) -> Output {
    let protocol = protocol_path("magnitude-quick");
    let mut args = vec!["power", protocol.to_str().unwrap()];
    args.extend(PLAN);
    args.extend(["--out", out.to_str().unwrap()]);
    args.extend(extra);
    let o = frictionlab(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    o
}

/// Three shards merged give the unsharded run's power.json byte for byte;
/// so do shards chosen by Slurm's array variables. A missing shard, a
/// duplicated one and one of another plan are refused (exit 2) and nothing
/// is written.
#[test]
fn merged_shards_are_byte_identical_to_an_unsharded_run_and_bad_merges_are_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let whole = tmp.path().join("whole");
    power_run(&whole, &[]);
    let unsharded = std::fs::read(whole.join("power.json")).unwrap();
    let shards = tmp.path().join("shards");
    for k in 0..3 {
        power_run(&shards, &["--shard", &format!("{k}/3")]);
    }
    assert!(
        !shards.join("power.json").exists(),
        "a shard writes no power.json"
    );
    let merged = tmp.path().join("merged");
    let o = frictionlab(&[
        "power-merge",
        shards.to_str().unwrap(),
        "--out",
        merged.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(merged.join("power.json")).unwrap(), unsharded);
    assert!(merged.join("power.html").exists());

    // Slurm's variables pick the shard (an array 1-2: task ids from 1).
    let slurm = tmp.path().join("slurm");
    let protocol = protocol_path("magnitude-quick");
    for id in 1..=2 {
        let mut args = vec!["power", protocol.to_str().unwrap()];
        args.extend(PLAN);
        args.extend(["--out", slurm.to_str().unwrap()]);
        let o = Command::new(BIN)
            .args(&args)
            .env("SLURM_ARRAY_TASK_ID", id.to_string())
            .env("SLURM_ARRAY_TASK_MIN", "1")
            .env("SLURM_ARRAY_TASK_COUNT", "2")
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        assert!(
            slurm
                .join(format!("power-shard-{}-of-2.json", id - 1))
                .exists()
        );
    }
    let o = frictionlab(&["power-merge", slurm.to_str().unwrap()]);
    assert!(o.status.success(), "{}", stderr(&o));
    assert_eq!(std::fs::read(slurm.join("power.json")).unwrap(), unsharded);

    // A missing shard.
    let partial = tmp.path().join("partial");
    std::fs::create_dir_all(&partial).unwrap();
    for k in [0, 2] {
        let name = format!("power-shard-{k}-of-3.json");
        std::fs::copy(shards.join(&name), partial.join(&name)).unwrap();
    }
    let o = frictionlab(&["power-merge", partial.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("shard(s) 1 of 3 missing"),
        "{}",
        stderr(&o)
    );
    assert!(!partial.join("power.json").exists());
    // A duplicated one: shard 0 in two folders.
    let o = frictionlab(&[
        "power-merge",
        shards.to_str().unwrap(),
        partial.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("shard 0 of 3 twice"), "{}", stderr(&o));
    // One of another plan (another seed).
    let other = tmp.path().join("other");
    let mut args = vec!["power", protocol.to_str().unwrap()];
    args.extend(PLAN);
    args[7] = "8";
    args.extend(["--out", other.to_str().unwrap(), "--shard", "1/3"]);
    let o = frictionlab(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    std::fs::copy(
        other.join("power-shard-1-of-3.json"),
        partial.join("power-shard-1-of-3.json"),
    )
    .unwrap();
    let o = frictionlab(&["power-merge", partial.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("another plan"), "{}", stderr(&o));
    assert!(!partial.join("power.json").exists());
}

/// A shard killed mid-run (SIGKILL) and rerun with the same options
/// finishes the studies it had not journaled and writes the same shard
/// file as an uninterrupted run, also when the kill tore the journal's last
/// line.
#[test]
fn a_killed_shard_rerun_gives_the_uninterrupted_shard_file() {
    let tmp = tempfile::tempdir().unwrap();
    let protocol = protocol_path("paired-quick");
    let args = |out: &Path| -> Vec<String> {
        [
            "power",
            protocol.to_str().unwrap(),
            "--participants",
            "4,6",
            "--studies",
            "60",
            "--seed",
            "3",
            "--jobs",
            "1",
            "--shard",
            "1/2",
            "--out",
            out.to_str().unwrap(),
        ]
        .map(String::from)
        .to_vec()
    };
    let whole = tmp.path().join("whole");
    let o = Command::new(BIN).args(args(&whole)).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let expected = std::fs::read(whole.join("power-shard-1-of-2.json")).unwrap();

    let killed = tmp.path().join("killed");
    let journal = killed.join("power-shard-1-of-2.partial.jsonl");
    let mut child = Command::new(BIN).args(args(&killed)).spawn().unwrap();
    let lines = |p: &Path| std::fs::read_to_string(p).map_or(0, |t| t.lines().count());
    while lines(&journal) < 6 {
        assert!(
            child.try_wait().unwrap().is_none(),
            "finished before the kill"
        );
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let journaled = lines(&journal) - 1;
    assert!(
        !killed.join("power-shard-1-of-2.json").exists(),
        "the kill came before the shard finished"
    );
    assert!(journaled < 60, "{journaled} of 60 studies journaled");
    // A torn last line, as a kill mid-write leaves.
    std::fs::write(
        &journal,
        [std::fs::read(&journal).unwrap(), b"{\"index\": 9".to_vec()].concat(),
    )
    .unwrap();
    let o = Command::new(BIN).args(args(&killed)).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        said.contains(&format!(
            "{} studies run, {journaled} found done",
            60 - journaled
        )),
        "{said}"
    );
    assert_eq!(
        std::fs::read(killed.join("power-shard-1-of-2.json")).unwrap(),
        expected
    );
    assert!(
        !journal.exists(),
        "the journal is removed once the shard is written"
    );
}

/// Bad flags and files are refused with their place, exit 2, nothing
/// written.
#[test]
fn bad_power_input_is_refused_with_its_place() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("out");
    let paired = protocol_path("paired-quick");
    let magnitude = protocol_path("magnitude-quick");
    let pop = tmp.path().join("pop.json");
    std::fs::write(
        &pop,
        r#"{"paired_preference": {"condition": "nope", "p": 0.7}}"#,
    )
    .unwrap();
    let bad_p = tmp.path().join("bad_p.json");
    std::fs::write(
        &bad_p,
        r#"{"paired_preference": {"condition": "time_varying", "p": 1.5}}"#,
    )
    .unwrap();
    let bad_f = tmp.path().join("bad-feedback.json");
    std::fs::write(&bad_f, r#"{"feedback": {"click_criterion": [0.9, 1.0]}}"#).unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["--participants", "8,4"],
            "--participants: sizes must increase",
        ),
        (
            vec!["--participants", "1,4"],
            "--participants: sizes must be at least 2",
        ),
        (vec!["--studies", "0"], "--studies: must be at least 1"),
        (vec!["--alpha", "1.5"], "--alpha: must be in (0, 1)"),
        (vec!["--shard", "3/3"], "--shard: '3/3': expected K/N"),
        (
            vec!["--population", pop.to_str().unwrap()],
            "$.paired_preference.condition: 'nope' is not a condition",
        ),
        (
            vec!["--population", bad_p.to_str().unwrap()],
            "$.paired_preference.p: must be in [0, 1]",
        ),
        (
            vec!["--population", bad_f.to_str().unwrap()],
            "$.feedback.click_criterion: must be below 1",
        ),
    ];
    for (extra, expected) in cases {
        let mut args = vec!["power", paired.to_str().unwrap(), "--seed", "1"];
        args.extend(["--out", out.to_str().unwrap()]);
        args.extend(&extra);
        let o = frictionlab(&args);
        assert_eq!(o.status.code(), Some(2), "{extra:?}");
        assert!(stderr(&o).contains(expected), "{extra:?}: {}", stderr(&o));
        assert!(!out.exists(), "{extra:?} wrote something");
    }
    let o = frictionlab(&[
        "power",
        magnitude.to_str().unwrap(),
        "--seed",
        "1",
        "--out",
        out.to_str().unwrap(),
        "--population",
        pop.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("not a paired comparison"),
        "{}",
        stderr(&o)
    );
    let o = Command::new(BIN)
        .args(["power", paired.to_str().unwrap(), "--seed", "1"])
        .args(["--out", out.to_str().unwrap()])
        .env("SLURM_ARRAY_TASK_ID", "5")
        .env("SLURM_ARRAY_TASK_COUNT", "4")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("SLURM_ARRAY_TASK_ID: task 5 is not one of 4"),
        "{}",
        stderr(&o)
    );
    assert!(!out.exists());
}

/// Issue 31: two processes on one shard would append to one journal. The
/// second is refused while the first runs (exit 2, the holder's pid), a
/// merge meanwhile says the shard is still running, and the first finishes
/// its shard whole.
#[test]
fn a_shard_runs_in_one_process_at_a_time_issue_31() {
    let tmp = tempfile::tempdir().unwrap();
    let protocol = protocol_path("paired-quick");
    let out = tmp.path().join("out");
    let args: Vec<String> = [
        "power",
        protocol.to_str().unwrap(),
        "--participants",
        "4,6",
        "--studies",
        "60",
        "--seed",
        "3",
        "--jobs",
        "1",
        "--shard",
        "1/2",
        "--out",
        out.to_str().unwrap(),
    ]
    .map(String::from)
    .to_vec();
    let journal = out.join("power-shard-1-of-2.partial.jsonl");
    let mut first = Command::new(BIN).args(&args).spawn().unwrap();
    let lines = |p: &Path| std::fs::read_to_string(p).map_or(0, |t| t.lines().count());
    while lines(&journal) < 3 {
        assert!(first.try_wait().unwrap().is_none(), "finished too soon");
        std::thread::sleep(std::time::Duration::from_millis(2));
    }
    let second = Command::new(BIN).args(&args).output().unwrap();
    assert_eq!(second.status.code(), Some(2), "{}", stderr(&second));
    assert!(
        stderr(&second).contains(&format!(
            "shard 1/2 of this plan is being run by another process (pid {})",
            first.id()
        )),
        "{}",
        stderr(&second)
    );
    let merge = frictionlab(&["power-merge", out.to_str().unwrap()]);
    assert_eq!(merge.status.code(), Some(2));
    assert!(
        stderr(&merge).contains(&format!(
            "a shard still running in another process (pid {})",
            first.id()
        )),
        "{}",
        stderr(&merge)
    );
    assert!(first.wait().unwrap().success());
    let shard: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("power-shard-1-of-2.json")).unwrap())
            .unwrap();
    assert_eq!(shard["studies"].as_array().unwrap().len(), 60);
}
