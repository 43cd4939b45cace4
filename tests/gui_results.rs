//! The Results tab's view of each kind (issue 45): after Analyze, the
//! window shows each study's key statistics in a sentence each, with the
//! numbers `summary.json` holds, its figures, and its full tree one click
//! away. Driven headless through egui_kittest over folders that
//! `frictionlab simulate` fills.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "tests: a panic is a failure"
)]

use crate::common;

use std::path::Path;
use std::process::Command as Process;

use eframe::egui;
use egui_kittest::{Harness, kittest::Queryable};
use frictionlab::gui::{FrictionlabApp, Launch};
use serde_json::Value;

use common::window::click;

/// Simulates `participants` participants of the shipped `protocol` into
/// `out`.
fn simulate(out: &Path, protocol: &str, participants: u32) {
    let o = Process::new(env!("CARGO_BIN_EXE_frictionlab"))
        .arg("simulate")
        .arg(format!(
            "{}/protocols/{protocol}",
            env!("CARGO_MANIFEST_DIR")
        ))
        .args(["--participants", &participants.to_string(), "--seed", "1"])
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

/// Opens the window on `out`, runs Analyze from the Results tab, and
/// returns the harness and the summary the analysis wrote.
fn analysed(out: &Path) -> (Harness<'static, FrictionlabApp>, Value) {
    let launch = Launch {
        out: out.to_path_buf(),
        ..Launch::default()
    };
    let mut h = Harness::builder()
        .with_size(egui::vec2(1920.0, 1200.0))
        .with_step_dt(0.05)
        .build_eframe(move |_cc| FrictionlabApp::new(launch));
    common::window::analyze_in_results_tab(&mut h);
    h.step();
    let text = std::fs::read_to_string(out.join("report/summary.json")).unwrap();
    (h, serde_json::from_str(&text).unwrap())
}

/// `x` to `d` decimals.
fn f(x: &Value, d: usize) -> String {
    format!("{:.d$}", x.as_f64().unwrap())
}

/// A p value: three decimals, four below 0.001, `< 0.0001` below that.
fn p(x: &Value) -> String {
    match x.as_f64() {
        None => "p n/a".into(),
        Some(p) if p < 1e-4 => "p < 0.0001".into(),
        Some(p) if p < 1e-3 => format!("p = {p:.4}"),
        Some(p) => format!("p = {p:.3}"),
    }
}

/// Asserts the window shows `sentence` as a label of its own.
fn shows(h: &Harness<'_, FrictionlabApp>, sentence: &str) {
    assert!(
        h.query_by_label(sentence).is_some(),
        "the Results tab does not show: {sentence}"
    );
}

/// Asserts the kind's full tree is folded, then one click shows its
/// `leaf` (a `key: value` line of the tree).
fn tree_one_click_away(h: &mut Harness<'_, FrictionlabApp>, kind: &str, leaf: &str) {
    assert!(
        h.query_by_label(leaf).is_none(),
        "{leaf} shown before the tree is opened"
    );
    click(h, &format!("Full tree of {kind}"));
    assert!(
        h.query_by_label(leaf).is_some(),
        "the full tree of {kind} does not show {leaf}"
    );
}

#[test]
fn paired_comparison_results_show_the_counts_test_and_order_sentences() {
    let dir = tempfile::tempdir().unwrap();
    simulate(dir.path(), "paired-comparison.json", 8);
    let (mut h, summary) = analysed(dir.path());
    let s = &summary["paired_comparison"];
    let counts = s["counts"].as_object().unwrap();
    assert_eq!(counts.len(), 2, "the shipped protocol compares two");
    let chosen: Vec<String> = counts
        .iter()
        .map(|(k, n)| format!("{k} chosen {n}"))
        .collect();
    shows(
        &h,
        &format!(
            "{} ({} decisive of {} trials, no difference {}): two-sided exact binomial test, {}.",
            chosen.join(", "),
            s["decisive"],
            s["trials"],
            s["no_difference"],
            p(&s["binomial_p"])
        ),
    );
    let o = &s["order"];
    shows(
        &h,
        &format!(
            "Presentation order: first chosen {}, second chosen {}, two-sided exact binomial test, {}.",
            o["first_chosen"],
            o["second_chosen"],
            p(&o["binomial_p"])
        ),
    );
    h.get_by_label("Which rendering is nearer to the real surface: answers by what was chosen");
    tree_one_click_away(
        &mut h,
        "paired_comparison",
        &format!("decisive: {}", s["decisive"]),
    );
}

#[test]
fn magnitude_results_show_the_display_effect_ratio_and_correlations() {
    let dir = tempfile::tempdir().unwrap();
    simulate(dir.path(), "magnitude-estimation.json", 8);
    let (mut h, summary) = analysed(dir.path());
    let s = &summary["magnitude_estimation"];
    let d: Vec<&str> = s["displays"]
        .as_array()
        .unwrap()
        .iter()
        .map(|d| d.as_str().unwrap())
        .collect();
    let e = &s["display_effect"];
    shows(
        &h,
        &format!(
            "Display effect, {} over {} (paired t test across participants): ratio {}, 95% CI [{}, {}], t({}) = {}, {}.",
            d[0],
            d[1],
            f(&e["ratio"], 3),
            f(&e["ci_low"], 3),
            f(&e["ci_high"], 3),
            e["n"].as_u64().unwrap() - 1,
            f(&e["t"], 2),
            p(&e["p"])
        ),
    );
    shows(
        &h,
        &format!(
            "Display ratio (geometric mean of {}'s pooled values over {}'s): {}.",
            d[0],
            d[1],
            f(&s["display_ratio"], 3)
        ),
    );
    let correlations = s["correlations"].as_array().unwrap();
    assert!(!correlations.is_empty());
    for c in correlations {
        shows(
            &h,
            &format!(
                "delta_mu {}: {} against {} (per-display means): r = {}, 95% CI [{}, {}], {} (n = {} stimuli).",
                c["delta_mu"].as_f64().unwrap(),
                d[0],
                d[1],
                f(&c["r"], 2),
                f(&c["ci95_low"], 2),
                f(&c["ci95_high"], 2),
                p(&c["p"]),
                c["n"]
            ),
        );
    }
    for display in &d {
        h.get_by_label(&format!(
            "{display}: geometric means against mu_s (pooled), 95% CIs"
        ));
    }
    // The other normalization is one click away.
    click(&mut h, "per display");
    h.get_by_label(&format!(
        "{}: geometric means against mu_s (per_display), 95% CIs",
        d[0]
    ));
    tree_one_click_away(
        &mut h,
        "magnitude_estimation",
        &format!("participants: {}", s["participants"]),
    );
}

#[test]
fn fitts_results_show_each_regression_and_each_conditions_quadrants() {
    let dir = tempfile::tempdir().unwrap();
    simulate(dir.path(), "fitts.json", 8);
    let (mut h, summary) = analysed(dir.path());
    let s = &summary["fitts"];
    for r in s["regression"].as_array().unwrap() {
        let c = r["condition"].as_str().unwrap();
        shows(
            &h,
            &format!(
                "{c}: MT = {} s + {} s/bit × ID, r² = {} (n = {} tests); throughput {} bits/s.",
                f(&r["intercept_s"], 3),
                f(&r["slope_s_per_bit"], 3),
                f(&r["r2"], 2),
                r["n"],
                f(&s["throughput_bits_per_s"][c], 2)
            ),
        );
    }
    let pooled: Vec<&Value> = s["quadrants"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|q| q["id_bits"].is_null())
        .collect();
    assert!(!pooled.is_empty(), "the shipped protocol has a baseline");
    for q in pooled {
        let n = |k: &str| q[k].as_u64().unwrap();
        // Every count of the entry (its p values are fractions).
        let total: u64 = q
            .as_object()
            .unwrap()
            .values()
            .filter_map(Value::as_u64)
            .sum();
        shows(
            &h,
            &format!(
                "{} against baseline, all IDs: of {total} participants, {} slower and less accurate, {} faster and less accurate, {} faster and more accurate, {} slower and more accurate, {} tied; sign tests: time {}, accuracy {}.",
                q["condition"].as_str().unwrap(),
                n("slower_less_accurate"),
                n("faster_less_accurate"),
                n("faster_more_accurate"),
                n("slower_more_accurate"),
                n("ties"),
                p(&q["time_sign_p"]),
                p(&q["accuracy_sign_p"])
            ),
        );
    }
    h.get_by_label("Movement time against ID (OLS line per condition)");
    h.get_by_label("Participants by change in time and accuracy against own baseline (all IDs)");
    tree_one_click_away(&mut h, "fitts", &format!("tests: {}", s["tests"]));
}

#[test]
fn discrimination_results_show_the_fit_and_each_levels_weber_fraction() {
    let dir = tempfile::tempdir().unwrap();
    simulate(dir.path(), "discrimination-quick.json", 4);
    let (mut h, summary) = analysed(dir.path());
    let s = &summary["discrimination"];
    let parameter = s["parameter"].as_str().unwrap();
    shows(
        &h,
        &format!(
            "Threshold at {:.1}% correct (two intervals, guess rate {}, lapse rate fitted within [0, {}]), {} functions, {} fits of {parameter}, 95% parametric-bootstrap intervals ({} samples).",
            s["criterion"].as_f64().unwrap() * 100.0,
            s["guess"].as_f64().unwrap(),
            s["max_lapse"].as_f64().unwrap(),
            s["shape"].as_str().unwrap(),
            s["fits"].as_array().unwrap().len(),
            s["bootstrap"]
        ),
    );
    for l in s["levels"].as_array().unwrap() {
        shows(
            &h,
            &format!(
                "Reference {parameter} = {}: Weber fraction {}, 95% CI [{}, {}] (mean of {} participants; SD {}, median {}); mean JND {}.",
                l["level"].as_f64().unwrap(),
                f(&l["weber_mean"], 3),
                f(&l["weber_mean_ci"][0], 3),
                f(&l["weber_mean_ci"][1], 3),
                l["participants"],
                f(&l["weber_sd"], 3),
                f(&l["weber_median"], 3),
                f(&l["jnd_mean"], 4)
            ),
        );
    }
    h.get_by_label("Weber fraction against the reference level, 95% CIs");
    tree_one_click_away(
        &mut h,
        "discrimination",
        &format!("bootstrap: {}", s["bootstrap"]),
    );
}
