//! Issue 17: the discrimination study. Simulated participants with a known
//! threshold are recovered by each adaptive method and the fit; QUEST+
//! against 1-up-3-down; kill -9 and resume give the uninterrupted files;
//! bad protocols are refused at their JSON paths.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use frictionlab::kinds::discrimination::analysis::fit_track_with;
use frictionlab::kinds::discrimination::{DiscriminationDesign, Method};
use frictionlab::kinds::{Design, Protocol, Registry, TrialData};
use frictionlab::participant::Population;
use frictionlab::participant::percept::BreakAway;

use frictionlab::results::{ResultsDir, read_log};
use frictionlab::session::{Simulation, simulate_participants};
use frictionlab_psychophysics::psychometric::phi_inverse;

fn protocol_path(name: &str) -> String {
    format!("{}/protocols/{name}.json", env!("CARGO_MANIFEST_DIR"))
}

/// The shipped protocol with one reference level (1.0) and `method`.
fn one_level(method: serde_json::Value) -> (Protocol, Vec<u8>) {
    let mut v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(protocol_path("discrimination")).unwrap())
            .unwrap();
    v["id"] = "recovery".into();
    v["design"]["levels"] = serde_json::json!([1.0]);
    v["design"]["method"] = method;
    v["design"]["fit"]["bootstrap"] = 200.into();
    let bytes = serde_json::to_vec_pretty(&v).unwrap();
    let protocol =
        frictionlab::protocol::load::parse::<Registry>(std::str::from_utf8(&bytes).unwrap())
            .unwrap_or_else(|e| panic!("{e:?}"));
    (protocol, bytes)
}

fn design(p: &Protocol) -> &DiscriminationDesign {
    match &p.design {
        Design::Discrimination(d) => d,
        other => panic!("a discrimination design, got {other:?}"),
    }
}

/// The recovery population: every trait at the middle of its default range
/// (so every participant's felt strengths are the same function of the
/// stimulus), force Weber fraction (the SD of its log percept) `sigma`.
fn population(sigma: f64) -> Population {
    let mid = |[a, b]: [f64; 2]| [f64::midpoint(a, b); 2];
    let d = Population::default();
    Population {
        hand_mass_kg: mid(d.hand_mass_kg),
        hand_stiffness_n_m: mid(d.hand_stiffness_n_m),
        hand_damping_n_s_m: mid(d.hand_damping_n_s_m),
        motor_noise_s: mid(d.motor_noise_s),
        feedback_s: mid(d.feedback_s),
        position_sd_m: mid(d.position_sd_m),
        force_weber: [sigma; 2],
        vibration_weber: mid(d.vibration_weber),
        displacement_weber: mid(d.displacement_weber),
        velocity_weber: mid(d.velocity_weber),
        stevens_exponent: mid(d.stevens_exponent),
        viscosity_exponent: mid(d.viscosity_exponent),
        answer_noise: mid(d.answer_noise),
        ..d
    }
}

/// The true threshold difference of the recovery population at the
/// design's criterion. Its felt strengths are deterministic (no trait
/// varies), so the stream of one session gives `ln(S_comparison /
/// S_reference)` at each difference presented, computed from the forces
/// and positions as the participant computes it
/// ([`BreakAway`]); its answer is correct with probability
/// `Phi(ln ratio / (sigma sqrt 2))`, which reaches the criterion where
/// `ln ratio = sigma sqrt 2 Phi^-1(criterion)` (found between the
/// differences presented, linearly).
fn true_threshold(p: &Protocol, bytes: &[u8], pop: &Population, sigma: f64) -> f64 {
    let dir = tempfile::tempdir().unwrap();
    let results = ResultsDir::new(dir.path());
    let sim = Simulation {
        protocol: p,
        protocol_bytes: bytes,
        participants: 1,
        seed: 99,
        pace: None,
        streams: true,
        population: Some(pop),
        jobs: 1,
        stop: None,
        lsl: None,
    };
    simulate_participants(&results, &sim, &|_| {}).unwrap();
    let [log]: [PathBuf; 1] = common::session_logs(dir.path()).try_into().unwrap();
    let traits = frictionlab::participant::Traits::draw(99, "sim-001", pop);
    let mut points: Vec<(f64, f64)> = Vec::new();
    for r in read_log::<Registry>(&log).unwrap().trials {
        let TrialData::Discrimination(d) = &r.data else {
            panic!("a discrimination record");
        };
        let stream = std::fs::read_dir(dir.path().join("streams"))
            .unwrap()
            .map(|e| e.unwrap().path())
            .find(|s| {
                s.to_str()
                    .unwrap()
                    .contains(&format!("_trial-{}_run-1_", r.trial))
            })
            .unwrap();
        let text = std::fs::read_to_string(&stream).unwrap();
        let rows = frictionlab::rerender::parse_stream("s", &text).unwrap();
        // The two intervals: the rows of the first render, then of the
        // second (the switch), each from its own start.
        let switch = rows
            .iter()
            .position(|row| row.render != rows[0].render)
            .unwrap();
        let strength = |rows: &[frictionlab::rerender::Row]| {
            let mut felt = BreakAway::default();
            for row in rows {
                felt.add(
                    row.t_s - rows[0].t_s,
                    row.x_m,
                    row.v_m_s,
                    row.force_n,
                    row.vibration,
                );
            }
            felt.strength(traits.breakaway_weight, traits.tactile_gain_n)
        };
        let (a, b) = (strength(&rows[..switch]), strength(&rows[switch..]));
        let (reference, comparison) = if d.answer.first == "reference" {
            (a, b)
        } else {
            (b, a)
        };
        points.push((d.difference, (comparison / reference).ln()));
    }
    points.sort_by(|a, b| a.0.total_cmp(&b.0));
    points.dedup_by(|a, b| a.0 == b.0);
    let target = sigma * std::f64::consts::SQRT_2 * phi_inverse(design(p).criterion);
    let crossing = points
        .windows(2)
        .find(|w| w[0].1 < target && w[1].1 >= target)
        .unwrap_or_else(|| panic!("ln ratio never crosses {target}: {points:?}"));
    let [(x0, r0), (x1, r1)] = [crossing[0], crossing[1]];
    x0 + (target - r0) * (x1 - x0) / (r1 - r0)
}

/// What recovery found for one method.
#[derive(Debug)]
struct Recovery {
    truth: f64,
    weber: Vec<f64>,
    /// Participants whose bootstrap interval covers the truth.
    covered: usize,
    /// Participants whose profile-likelihood interval covers it.
    covered_profile: usize,
    /// Each participant's answers, for the efficiency comparison.
    answers: Vec<Vec<(f64, bool)>>,
}

const PARTICIPANTS: u32 = 50;
const SIGMA: f64 = 0.1;

/// The recovery population's true threshold difference on the one-level
/// protocol, from a QUEST+ session's streams (its differences gather
/// around the threshold; the truth is the participant's, whatever the
/// method).
fn truth() -> f64 {
    let (p, bytes) = one_level(quest_plus(60));
    true_threshold(&p, &bytes, &population(SIGMA), SIGMA)
}

fn recover(method: serde_json::Value, truth: f64) -> Recovery {
    let (p, bytes) = one_level(method);
    let pop = population(SIGMA);
    let dir = tempfile::tempdir().unwrap();
    let sim = Simulation {
        protocol: &p,
        protocol_bytes: &bytes,
        participants: PARTICIPANTS,
        seed: 17,
        pace: None,
        streams: false,
        population: Some(&pop),
        jobs: 2,
        stop: None,
        lsl: None,
    };
    simulate_participants(&ResultsDir::new(dir.path()), &sim, &|_| {}).unwrap();
    let analysis = frictionlab::analysis::analyze::<Registry>(dir.path()).unwrap();
    let fits = analysis.summary["discrimination"]["fits"]
        .as_array()
        .unwrap();
    assert_eq!(fits.len(), PARTICIPANTS as usize);
    let mut weber = Vec::new();
    let (mut covered, mut covered_profile) = (0, 0);
    let covers = |ci: &serde_json::Value| {
        ci.as_array().is_some_and(|ci| {
            let (lo, hi) = (ci[0].as_f64().unwrap(), ci[1].as_f64().unwrap());
            lo <= truth && truth <= hi
        })
    };
    for f in fits {
        let w = f["weber"].as_f64().unwrap_or(f64::NAN);
        weber.push(w);
        covered += usize::from(covers(&f["weber_ci"]));
        covered_profile += usize::from(covers(&f["weber_ci_profile"]));
    }
    // The level's group mean and its 95% t interval across participants
    // (49 df: t = 2.009575237129235).
    let level = &analysis.summary["discrimination"]["levels"][0];
    let n = weber.len() as f64;
    let mean = weber.iter().sum::<f64>() / n;
    let sd = (weber.iter().map(|w| (w - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
    let half = 2.009_575_237_129_235 * sd / n.sqrt();
    let ci = level["weber_mean_ci"].as_array().unwrap();
    for (got, want) in ci.iter().zip([mean - half, mean + half]) {
        assert!(
            (got.as_f64().unwrap() - want).abs() < 1e-9,
            "{got} vs {want}"
        );
    }
    let mut answers = Vec::new();
    for log in common::session_logs(dir.path()) {
        let read = read_log::<Registry>(&log).unwrap();
        answers.push(
            read.trials
                .iter()
                .filter_map(|r| match &r.data {
                    TrialData::Discrimination(d) => Some((d.difference, d.correct?)),
                    _ => None,
                })
                .collect(),
        );
    }
    Recovery {
        truth,
        weber,
        covered,
        covered_profile,
        answers,
    }
}

fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

/// Median bias under `max_bias`, and the two 95% intervals' coverage of
/// the truth: the profile-likelihood interval's at least
/// `min_profile_coverage` and at least the bootstrap's.
///
/// Measured (50 participants a method, so a coverage's standard error is
/// about 0.03 near 0.95): profile likelihood 0.94 (QUEST+), 0.80
/// (1-up-2-down), 0.88 (weighted 1-up-1-down), 0.90 and 0.84 (1-up-3-down,
/// 80 and 160 trials); the parametric bootstrap 0.88, 0.68, 0.80, 0.78 and
/// 0.80. The staircases' intervals remain short of 95%, and not for want
/// of trials: at 320 trials of 1-up-2-down profile 0.80 and bootstrap
/// 0.80, at 320 of 1-up-3-down 0.84 and 0.78 (measured once). Staircase
/// tracks from an observer whose function is the fitted Weibull itself
/// fall short alike (`crates/psychophysics/tests/fit.rs`), so the
/// shortfall belongs to fitting a free slope and lapse rate to a
/// staircase's answers, not to the simulated participant; its answers
/// show no dependence between trials (lag-1 autocorrelation of the
/// residuals 0.008 over 16,000 answers, measured once).
///
/// Why the bootstrap under-covers, measured once (not asserted): its
/// intervals are too narrow, not off centre. Over the 50 participants the
/// fitted Weber fractions spread with SD 0.041 after 80 trials of
/// 1-up-2-down, while the median bootstrap interval, 0.071 wide, implies
/// 0.018; for QUEST+ 0.054 against 0.052. It redraws answers at the
/// differences the track presented, from the fitted function; a fit to a
/// staircase's answers, gathered over a narrow range of differences, tends
/// to be steep (Kaernbach 2001, slope bias), and answers redrawn from a
/// steep function vary little. Also tried, and dropped: re-running the
/// track in the bootstrap (QUEST+ 0.92, the staircases 0.58-0.60), Efron's
/// bias-corrected percentiles (0.68-0.86), the basic bootstrap (0.54-0.84)
/// and redrawing each difference's own answers (narrower still). The
/// profile likelihood lets the slope be as shallow as the answers allow at
/// each threshold, and the likelihood does not depend on how the track
/// chose its differences.
///
/// # Judged with the sample's own uncertainty (issue 42)
/// Both claims are about the method, and 50 participants only estimate
/// them: the median bias of one sample of 50 spreads with an SD of about
/// 5 points from sample to sample. Measured on QUEST+ (60 trials) over
/// participant seeds 1-14 and 17: +4.2% to +23.7% (mean +12.7%) with
/// today's session clock, +4.3% to +20.2% (mean +9.4%) with the float
/// clock before issue 42, whose test passed at seed 17 (+5.5%) and would
/// have failed at 6 of those 15 seeds. (Seed by seed the new clock's bias
/// is 3 points higher on average: its trials are timed exactly, where the
/// float clock's rounding moved a slide's start by a tick now and then,
/// and the stick-slip is chaotic; what makes the shift one-sided was not
/// found.) So a claim is refused only when the
/// sample rejects it: the median bias's 95% interval (percentile
/// bootstrap over participants) must reach inside `±max_bias`, and the
/// profile-likelihood coverage's 95% interval (Wilson) must reach
/// `min_profile_coverage`.
fn assert_recovered(name: &str, r: &Recovery, max_bias: f64, min_profile_coverage: f64) {
    let bias = median(&r.weber) / r.truth - 1.0;
    let (lo, hi) = median_interval(&r.weber);
    let (bias_lo, bias_hi) = (lo / r.truth - 1.0, hi / r.truth - 1.0);
    #[expect(clippy::cast_precision_loss, reason = "participant counts")]
    let coverage = |n: usize| n as f64 / f64::from(PARTICIPANTS);
    let (_, profile_hi) = wilson(r.covered_profile, PARTICIPANTS as usize);
    eprintln!(
        "{name}: true Weber fraction {:.4}, median fitted {:.4} (bias {:+.1}%, 95% CI {:+.1}% to {:+.1}%), 95% CI coverage: bootstrap {:.2} ({}/{PARTICIPANTS}), profile likelihood {:.2} ({}/{PARTICIPANTS}, up to {profile_hi:.2})",
        r.truth,
        median(&r.weber),
        bias * 100.0,
        bias_lo * 100.0,
        bias_hi * 100.0,
        coverage(r.covered),
        r.covered,
        coverage(r.covered_profile),
        r.covered_profile,
    );
    assert!(
        bias_lo < max_bias && bias_hi > -max_bias,
        "{name}: median bias {bias} (95% CI {bias_lo} to {bias_hi}) rejects |bias| < {max_bias}"
    );
    assert!(
        profile_hi >= min_profile_coverage,
        "{name}: profile-likelihood coverage {} (up to {profile_hi}) rejects {min_profile_coverage}",
        coverage(r.covered_profile),
    );
}

/// The 95% percentile-bootstrap interval of the median of `v` (2000
/// resamples, seeded).
fn median_interval(v: &[f64]) -> (f64, f64) {
    use rand::{RngExt, SeedableRng};
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(42);
    let mut medians: Vec<f64> = (0..2000)
        .map(|_| {
            let sample: Vec<f64> = (0..v.len())
                .map(|_| v[rng.random_range(0..v.len())])
                .collect();
            median(&sample)
        })
        .collect();
    medians.sort_by(f64::total_cmp);
    (medians[50], medians[1949])
}

/// The 95% Wilson interval of `k` successes in `n`.
fn wilson(k: usize, n: usize) -> (f64, f64) {
    #[expect(clippy::cast_precision_loss, reason = "participant counts")]
    let (k, n) = (k as f64, n as f64);
    let z = 1.959_963_984_540_054;
    let p = k / n;
    let centre = (p + z * z / (2.0 * n)) / (1.0 + z * z / n);
    let half = z / (1.0 + z * z / n) * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt();
    (centre - half, centre + half)
}

fn quest_plus(trials: u32) -> serde_json::Value {
    let mut m = serde_json::from_str::<serde_json::Value>(
        &std::fs::read_to_string(protocol_path("discrimination")).unwrap(),
    )
    .unwrap()["design"]["method"]
        .clone();
    m["stop_trials"] = trials.into();
    m["max_trials"] = trials.into();
    m
}

fn staircase(down: u32, trials: u32) -> serde_json::Value {
    serde_json::json!({
        "kind": "staircase", "down": down, "start": 0.5,
        "steps": [0.1, 0.05, 0.025, 0.0125], "min": 0.0125, "max": 1.0,
        "stop_trials": trials
    })
}

/// The SD across participants of the threshold fitted to each one's first
/// `n` answers (the point fits alone: no interval is needed here, and
/// their bootstraps made this the test's longest part, on one core).
fn spread(design: &DiscriminationDesign, answers: &[Vec<(f64, bool)>], n: usize) -> f64 {
    let t: Vec<f64> = answers
        .iter()
        .filter_map(|a| {
            fit_track_with(design, "p", 1.0, a[..n.min(a.len())].to_vec(), false).threshold
        })
        .collect();
    #[expect(clippy::cast_precision_loss, reason = "participant counts")]
    let k = t.len() as f64;
    let mean = t.iter().sum::<f64>() / k;
    (t.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (k - 1.0)).sqrt()
}

/// Issue 17's recovery, for each method, and QUEST+ against 1-up-3-down:
/// the trials each needs for the same spread of fitted thresholds.
#[test]
fn each_method_recovers_a_known_threshold_and_quest_plus_needs_fewer_trials_issue_17() {
    let truth = truth();
    // Kaernbach's weighted 1-up-1-down, aimed at the 75% criterion.
    let mut weighted = staircase(1, 80);
    weighted["target"] = 0.75.into();
    // The five replays are independent (each its own folder and seeds):
    // two at a time, the same recoveries in about two thirds of the time.
    let methods = [
        quest_plus(60),
        staircase(2, 80),
        weighted,
        staircase(3, 80),
        staircase(3, 160),
    ];
    let mut recovered = frictionlab::parallel::run(&methods, 2, |m| {
        Ok::<_, std::convert::Infallible>(recover(m.clone(), truth))
    })
    .into_iter()
    .map(|r| match r {
        Ok(r) => r,
        Err(never) => match never {},
    });
    let mut next = || recovered.next().unwrap();
    let (quest, two, weighted, three, longer) = (next(), next(), next(), next(), next());
    assert_recovered("QUEST+ (60 trials)", &quest, 0.10, 0.9);
    assert_recovered("1-up-2-down (80 trials)", &two, 0.10, 0.75);
    assert_recovered(
        "weighted 1-up-1-down at 75% (80 trials)",
        &weighted,
        0.10,
        0.75,
    );
    // 1-up-3-down at 80 trials measured +13.3% before issue 42. Its
    // answers gather near 79% correct with few at high performance, so the
    // free lapse (up to 0.06) trades off against the threshold: with the
    // lapse fixed at 0 the bias is +7.4%; with a logistic or cumulative
    // normal instead of the Weibull it is +13.1% (measured once, not
    // asserted). It shrinks with trials: +10.6% at 120, +8.4% at 160,
    // +7.0% at 240. Judged against the issue's 10% like the others.
    assert_recovered("1-up-3-down (80 trials)", &three, 0.10, 0.75);
    assert_recovered("1-up-3-down (160 trials)", &longer, 0.10, 0.75);

    let (p, _) = one_level(quest_plus(60));
    let d = design(&p);
    let target = spread(d, &three.answers, 80);
    let needed = |answers: &[Vec<(f64, bool)>]| {
        (10..=80)
            .step_by(5)
            .find(|&n| spread(d, answers, n) <= target)
    };
    let quest_needs = needed(&quest.answers);
    eprintln!(
        "threshold SD across participants after 80 trials of 1-up-3-down: {target:.4}; QUEST+ reaches it after {quest_needs:?} trials"
    );
    assert!(
        quest_needs.is_some_and(|n| n < 80),
        "QUEST+ needs {quest_needs:?} trials"
    );
    assert!(matches!(d.method, Method::QuestPlus(_)));
}

/// Runs discrimination-quick for participant `k` into `out`, paced.
fn run(out: &Path, pace: &str, resume: bool) -> std::process::Child {
    let p = protocol_path("discrimination-quick");
    let mut args = vec![
        "run",
        &p,
        "--participant",
        "k",
        "--out",
        out.to_str().unwrap(),
        "--responder",
        "sim",
        "--seed",
        "5",
        "--pace",
        pace,
    ];
    if resume {
        args.push("--resume");
    }
    Command::new(env!("CARGO_BIN_EXE_frictionlab"))
        .args(&args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap()
}

fn files(out: &Path) -> (Vec<u8>, Vec<u8>) {
    let stem = "study-discriminationquick_subject-k_session-1";
    let read = |p: PathBuf| std::fs::read(p).unwrap();
    (
        read(out.join(format!("logs/{stem}_log.jsonl"))),
        read(out.join(format!("data/{stem}_data.csv"))),
    )
}

/// Issue 17: kill -9 at varied moments of a paced discrimination session,
/// then `--resume`, until it ends: every track continues exactly, and the
/// log's trial records and the data CSV are those of an uninterrupted
/// session with the same seed.
#[test]
fn a_discrimination_session_killed_and_resumed_gives_the_uninterrupted_files_issue_17() {
    let whole = tempfile::tempdir().unwrap();
    assert!(
        run(whole.path(), "1000", false)
            .wait_with_output()
            .unwrap()
            .status
            .success()
    );
    let dir = tempfile::tempdir().unwrap();
    // 24 trials of 5.2 s at pace 40: 0.13 s of wall time each.
    let mut waits_ms = [330_u64, 170, 410, 90, 260, 530, 140].into_iter().cycle();
    let mut kills = 0;
    for attempt in 0..80 {
        let mut child = run(dir.path(), "40", attempt > 0);
        std::thread::sleep(Duration::from_millis(waits_ms.next().unwrap()));
        if child.try_wait().unwrap().is_none() {
            child.kill().unwrap(); // SIGKILL
            child.wait().unwrap();
            kills += 1;
            continue;
        }
        let o = child.wait_with_output().unwrap();
        // Killed after its last line was written, the session had ended.
        if String::from_utf8_lossy(&o.stderr).contains("has ended: nothing to resume") {
            break;
        }
        assert!(
            o.status.success(),
            "attempt {attempt}: {} {}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        break;
    }
    assert!(kills >= 3, "interrupted {kills} times");
    let (log, csv) = files(dir.path());
    let (whole_log, whole_csv) = files(whole.path());
    let (csv, whole_csv) = (
        String::from_utf8(csv).unwrap(),
        String::from_utf8(whole_csv).unwrap(),
    );
    for (a, b) in csv.lines().zip(whole_csv.lines()) {
        assert_eq!(a, b, "the first data row that differs after {kills} kills");
    }
    assert_eq!(
        csv.lines().count(),
        whole_csv.lines().count(),
        "rows after {kills} kills: {csv}"
    );
    assert_eq!(
        csv, whole_csv,
        "byte-identical data CSV after {kills} kills"
    );
    let trials = |log: &[u8]| -> Vec<String> {
        String::from_utf8_lossy(log)
            .lines()
            .filter(|l| l.starts_with("{\"type\":\"trial\""))
            .map(str::to_owned)
            .collect()
    };
    assert_eq!(trials(&log), trials(&whole_log), "the same trial records");
    // The log of a resumed session also says where each resume began
    // (`{"type":"resumed",...}`, the results contract); without those
    // lines it is the uninterrupted log, byte for byte.
    let log = String::from_utf8(log).unwrap();
    let resumes = log
        .lines()
        .filter(|l| l.starts_with("{\"type\":\"resumed\""))
        .count();
    let without: String = log
        .lines()
        .filter(|l| !l.starts_with("{\"type\":\"resumed\""))
        .flat_map(|l| [l, "\n"])
        .collect();
    assert!(resumes >= 1, "{resumes} resumes logged");
    assert_eq!(
        without,
        String::from_utf8(whole_log).unwrap(),
        "the log after {kills} kills and {resumes} resumes, its resume lines left out"
    );
}

/// An edit of a protocol's JSON.
type Edit = Box<dyn Fn(&mut serde_json::Value)>;

/// Issue 17: a protocol naming a parameter the model lacks, a negative
/// step, a reference outside the model's range, a stopping rule that can
/// never stop, or a bootstrap too long to finish is refused with the JSON
/// path of each problem, exit 2.
#[test]
fn bad_discrimination_protocols_are_refused_at_their_json_paths_issue_17() {
    let base: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(protocol_path("discrimination")).unwrap())
            .unwrap();
    let cases: Vec<(&str, Edit, &str)> = vec![
        (
            "no such parameter",
            Box::new(|v| v["design"]["parameter"] = "static_friction.mu_x".into()),
            "design.parameter: the reference model ('god-object-constant') has no numeric parameter 'static_friction.mu_x'",
        ),
        (
            "negative step",
            Box::new(|v| v["design"]["method"] = staircase(3, 40)),
            "",
        ),
        (
            "reference outside the range",
            Box::new(|v| v["design"]["levels"] = serde_json::json!([1.0, 0.5])),
            "design.levels[1]: reference 0.5 is outside the model's valid range: static_friction.mu_s must be greater than mu_d (0.6), got 0.5",
        ),
        (
            "a stopping rule that never stops",
            Box::new(|v| {
                v["design"]["method"]["stop_threshold_sd"] = (-0.1).into();
            }),
            "design.method.stop_threshold_sd:",
        ),
        (
            "a bootstrap that would never end",
            Box::new(|v| v["design"]["fit"]["bootstrap"] = 1_000_000_000.into()),
            "design.fit.bootstrap: from 100 samples",
        ),
        (
            "a staircase without a stopping rule",
            Box::new(|v| {
                let mut m = staircase(3, 40);
                m.as_object_mut().unwrap().remove("stop_trials");
                v["design"]["method"] = m;
            }),
            "design.method.stop_trials: no stopping rule",
        ),
    ];
    let dir = tempfile::tempdir().unwrap();
    for (name, edit, expected) in cases {
        let mut v = base.clone();
        edit(&mut v);
        if name == "negative step" {
            v["design"]["method"]["steps"][1] = (-0.05).into();
        }
        let expected = if name == "negative step" {
            "design.method.steps[1]: must be greater than 0, got -0.05"
        } else {
            expected
        };
        let path = dir.path().join("bad.json");
        std::fs::write(&path, serde_json::to_vec_pretty(&v).unwrap()).unwrap();
        let o = Command::new(env!("CARGO_BIN_EXE_frictionlab"))
            .args([
                "simulate",
                path.to_str().unwrap(),
                "--participants",
                "1",
                "--seed",
                "1",
            ])
            .arg("--out")
            .arg(dir.path().join("out"))
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{name}: {stderr}");
        assert!(
            stderr.contains(&format!("error: {}: {expected}", path.display())),
            "{name}: expected '{expected}' in {stderr}"
        );
        assert!(!dir.path().join("out").exists(), "{name}: nothing written");
    }
}
