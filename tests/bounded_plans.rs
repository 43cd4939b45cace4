//! Issue 42: a protocol cannot take the machine. Before, `validate` of
//! magnitude-quick with `"repetitions": 1000000000` grew to 24 GB in 47 s
//! and was killed; `exploration_s` of `1e300` was accepted. Now a plan's
//! size is computed from the protocol's fields before anything is built
//! (at most `MAX_TRIALS` trials a session), every time in a protocol is
//! checked to fit the session's clock (at most a day), and what else a
//! field makes grow is bounded: such a protocol is refused at its place,
//! exit 2, within a second and under 100 MB. A property test puts extreme
//! numbers into every numeric field of every shipped protocol and runs
//! what `validate` and the window's builder run on each edit.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

mod common;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use frictionlab::kinds::Registry;
use nix::sys::resource::{UsageWho, getrusage};
use proptest::prelude::*;
use serde_json::Value;

const BIN: &str = env!("CARGO_BIN_EXE_frictionlab");

/// The tests that measure this process's own peak memory run one at a
/// time (a test's allocations would be counted against another's).
static OWN_MEMORY: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// The limits the issue sets: each check within a second, under 100 MB.
const MOST_TIME: Duration = Duration::from_secs(1);
const MOST_BYTES: i64 = 100 * 1024 * 1024;

fn shipped(name: &str) -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("protocols/{name}.json"));
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

/// This process's peak resident size so far, bytes.
fn own_peak() -> i64 {
    getrusage(UsageWho::RUSAGE_SELF).unwrap().max_rss() * 1024
}

/// `protocol` with the value at `pointer` (a JSON pointer) set to `value`.
fn with(mut protocol: Value, pointer: &str, value: Value) -> Value {
    *protocol.pointer_mut(pointer).unwrap() = value;
    protocol
}

/// A Fitts protocol whose 1,000 conditions at 1,000 levels make a
/// million trials from some 100 kB of JSON.
fn fitts_product() -> Value {
    let mut p = shipped("fitts-quick");
    let condition = p["design"]["conditions"][0].clone();
    let level = p["design"]["levels"][0].clone();
    p["design"]["conditions"] = (0..1000)
        .map(|i| {
            let mut c = condition.clone();
            c["id"] = format!("c{i}").into();
            c
        })
        .collect();
    p["design"]["levels"] = (0..1000).map(|_| level.clone()).collect();
    p["design"]["practice"] = Value::Array(Vec::new());
    p["design"]["practice_levels"] = Value::Array(Vec::new());
    p
}

/// Each case: a protocol, and where `validate` must say the problem is.
fn huge_cases() -> Vec<(&'static str, Value, &'static str)> {
    let magnitude = shipped("magnitude-quick");
    let discrimination = shipped("discrimination-quick");
    vec![
        (
            "repetitions 1e9",
            with(magnitude.clone(), "/repetitions", 1_000_000_000.into()),
            "repetitions: the plan would hold 6000000000 trials",
        ),
        (
            "exploration 1e300 s",
            with(magnitude.clone(), "/design/exploration_s", 1e300.into()),
            "design.exploration_s: 1e300 s is longer than",
        ),
        (
            "break 1e300 s",
            with(magnitude, "/break_s", 1e300.into()),
            "break_s: 1e300 s is longer than",
        ),
        (
            "fitts time limit 1e300 s",
            with(shipped("fitts-quick"), "/design/timeout_s", 1e300.into()),
            "design.timeout_s: 1e300 s is longer than",
        ),
        (
            "fitts 1000 conditions x 1000 levels",
            fitts_product(),
            "design: the plan would hold 1000000 trials",
        ),
        (
            "QUEST+ 4e9 trials a track",
            with(
                discrimination.clone(),
                "/design/method/max_trials",
                4_000_000_000_u32.into(),
            ),
            "design.method.max_trials: the session's trials",
        ),
        (
            "a grid of 1e12 points",
            with(
                discrimination,
                "/design/method/stimuli/count",
                1_000_000_000_000_u64.into(),
            ),
            "design.method.stimuli.count: the grid's points would be",
        ),
    ]
}

/// `validate` refuses each huge protocol with exit 2 and one located
/// message, each within a second, and run with its data limited to 100 MB
/// (`ulimit -d`: an allocation past it fails, and the process aborts; the
/// `validate` of before issue 42 aborted so after 2.6 s). A child's peak
/// resident size (`getrusage`) would not do: it counts the test process's
/// own pages from before the child's `exec`.
#[test]
fn validate_refuses_a_plan_too_large_at_its_place_within_a_second_and_100_mb_issue_42() {
    let dir = tempfile::tempdir().unwrap();
    for (what, protocol, place) in huge_cases() {
        let file = dir.path().join("p.json");
        std::fs::write(&file, serde_json::to_vec_pretty(&protocol).unwrap()).unwrap();
        let start = Instant::now();
        let o = Command::new("sh")
            .arg("-c")
            .arg(format!(
                "ulimit -d {}; exec \"$0\" validate \"$1\"",
                MOST_BYTES / 1024
            ))
            .arg(BIN)
            .arg(&file)
            .output()
            .unwrap();
        let took = start.elapsed();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{what}: {stderr}");
        let expected = format!("error: {}: {place}", file.display());
        assert!(stderr.starts_with(&expected), "{what}: {stderr}");
        assert!(took < MOST_TIME, "{what}: {took:?}");
        eprintln!("{what}: refused in {took:?}");
    }
}

/// The largest plan allowed is accepted, and its size is the limit.
#[test]
fn a_plan_of_the_limit_is_accepted() {
    let _one = OWN_MEMORY
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let limit = frictionlab::protocol::check::MAX_TRIALS;
    let per = 6; // magnitude-quick's trials per repetition
    let p = with(
        shipped("magnitude-quick"),
        "/repetitions",
        (limit / per).into(),
    );
    let parsed = frictionlab::protocol::load::parse::<Registry>(&p.to_string()).unwrap();
    assert_eq!(
        parsed.trials_per_session(),
        format!("{} trials per session", limit / per * per)
    );
    let p = with(
        shipped("magnitude-quick"),
        "/repetitions",
        (limit / per + 1).into(),
    );
    assert!(frictionlab::protocol::load::parse::<Registry>(&p.to_string()).is_err());
}

/// The size computed from the fields is the size of the plan built, for
/// every shipped protocol (0 for the kinds whose trials adapt).
#[test]
fn the_plan_size_computed_is_the_plan_built() {
    use frictionlab::protocol::kind::Kinds;
    for file in common::shipped_protocols() {
        let (p, _) = frictionlab::protocol::load::read::<Registry>(&file).unwrap();
        let per = Registry::trials_per_repetition(&p.design);
        let planned = Registry::source(&p, 1, 0).planned();
        match planned {
            Some(n) => assert_eq!(
                per * u64::from(p.repetitions),
                n as u64,
                "{}",
                file.display()
            ),
            None => assert_eq!(per, 0, "{}", file.display()),
        }
    }
}

/// Every numeric leaf of `v`, as a JSON pointer.
fn numeric_fields(v: &Value, at: &str, out: &mut Vec<String>) {
    match v {
        Value::Number(_) => out.push(at.to_owned()),
        Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                numeric_fields(x, &format!("{at}/{i}"), out);
            }
        }
        Value::Object(m) => {
            for (k, x) in m {
                numeric_fields(
                    x,
                    &format!("{at}/{}", k.replace('~', "~0").replace('/', "~1")),
                    out,
                );
            }
        }
        _ => {}
    }
}

/// Every shipped protocol and each of its numeric fields.
fn fields() -> Vec<(PathBuf, Value, String)> {
    let files = common::shipped_protocols();
    let mut out = Vec::new();
    for f in files {
        let v: Value = serde_json::from_str(&std::fs::read_to_string(&f).unwrap()).unwrap();
        let mut pointers = Vec::new();
        numeric_fields(&v, "", &mut pointers);
        for p in pointers {
            out.push((f.clone(), v.clone(), p));
        }
    }
    out
}

/// Numbers that have taken programs down: huge, tiny, negative, the edges
/// of the integer types, counts just over the limits and just inside.
fn extremes() -> Vec<Value> {
    vec![
        Value::from(1e300),
        Value::from(-1e300),
        Value::from(1e-300),
        Value::from(0),
        Value::from(-1),
        Value::from(u64::from(u32::MAX)),
        Value::from(u64::MAX),
        Value::from(i64::MIN),
        Value::from(9_007_199_254_740_993_u64),
        Value::from(1_000_000_000_u64),
        Value::from(100_001_u64),
        // Plans just inside the limit: built in full.
        Value::from(2_000_u64),
        Value::from(16_666_u64),
    ]
}

/// What `validate` and the builder run on a protocol's text after each
/// edit (parse and check, then the plan's size), timed, with this
/// process's peak memory before and after: `(took, grew)`.
fn check_as_validate_does(text: &str) -> (Duration, i64) {
    let _one = OWN_MEMORY
        .lock()
        .unwrap_or_else(std::sync::PoisonError::into_inner);
    let before = own_peak();
    let start = Instant::now();
    if let Ok(p) = frictionlab::protocol::load::parse::<Registry>(text) {
        let _ = p.trials_per_session();
    }
    (start.elapsed(), own_peak() - before)
}

/// Every extreme number in every numeric field of every shipped protocol,
/// one at a time: each check ends within a second and raises this
/// process's peak memory by less than 100 MB.
#[test]
fn no_extreme_number_in_any_field_takes_longer_than_a_second_or_100_mb_issue_42() {
    let all = fields();
    assert!(all.len() > 100, "{} numeric fields", all.len());
    let mut slowest = Duration::ZERO;
    for (file, protocol, pointer) in &all {
        for number in extremes() {
            let text = with(protocol.clone(), pointer, number.clone()).to_string();
            let (took, grew) = check_as_validate_does(&text);
            let at = format!("{}: {pointer} = {number}", file.display());
            assert!(took < MOST_TIME, "{at}: {took:?}");
            assert!(grew < MOST_BYTES, "{at}: {} MB more", grew >> 20);
            slowest = slowest.max(took);
        }
    }
    eprintln!(
        "{} fields x {} numbers, the slowest check {slowest:?}",
        all.len(),
        extremes().len()
    );
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]

    /// Any number, integer or not, in any numeric field: the same.
    #[test]
    fn no_number_in_any_field_takes_longer_than_a_second_or_100_mb(
        pick in any::<prop::sample::Index>(),
        number in prop_oneof![
            (0_u64..u64::MAX).prop_map(Value::from),
            (-1e12..1e12_f64).prop_map(Value::from),
            (-300_i32..300).prop_map(|e| Value::from(10_f64.powi(e))),
        ],
    ) {
        let all = fields();
        let (file, protocol, pointer) = &all[pick.index(all.len())];
        let text = with(protocol.clone(), pointer, number.clone()).to_string();
        let (took, grew) = check_as_validate_does(&text);
        prop_assert!(took < MOST_TIME, "{}: {pointer} = {number}: {took:?}", file.display());
        prop_assert!(grew < MOST_BYTES, "{}: {pointer} = {number}: {} MB more", file.display(), grew >> 20);
    }
}
