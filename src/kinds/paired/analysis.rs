//! Paired comparison (seed 000): choice counts, "no difference", a two-sided
//! exact binomial test on the decisive answers, and a presentation-order
//! check.
//!
//! `binomial_p` tests the two compared conditions' counts against an even
//! split; it needs exactly two conditions in the data (otherwise it is n/a).
//! `order` (extra) tests first-presented against second-presented choices.

use std::collections::BTreeMap;

use serde_json::{Value, json};

use crate::analysis::counted::KindCounted;
use crate::analysis::stats::binomial_two_sided;
use crate::analysis::{Rows, Table, num, opt, text};
use crate::problem::Problem;

/// The paired-comparison results.
#[derive(Debug, Clone)]
pub struct Paired {
    /// The `paired_comparison` object of `summary.json`.
    pub summary: Value,
    /// Tables.
    pub tables: Vec<Table>,
    /// Why some statistics are n/a.
    pub notes: Vec<String>,
    /// Choice counts per condition id, then `no_difference`.
    pub counts: Vec<(String, u64)>,
}

/// Analyses the paired-comparison rows.
///
/// # Errors
/// A `choice` that is not `first`, `second` or `no_difference`.
pub fn analyze(rows: &Rows) -> Result<Paired, Problem> {
    let mut counts: BTreeMap<String, u64> = BTreeMap::new();
    let (mut no_difference, mut first, mut second) = (0_u64, 0_u64, 0_u64);
    for i in 0..rows.len() {
        for c in ["first", "second"] {
            counts.entry(rows.text(c, i).to_owned()).or_insert(0);
        }
        match rows.text("choice", i) {
            "first" => first += 1,
            "second" => second += 1,
            "no_difference" => no_difference += 1,
            other => {
                return Err(rows.error(
                    "choice",
                    i,
                    &format!("'{other}': expected first, second or no_difference"),
                ));
            }
        }
        let chosen = rows.text("chosen", i);
        if chosen != "no_difference" {
            *counts.entry(chosen.to_owned()).or_insert(0) += 1;
        }
    }
    let mut notes = Vec::new();
    let binomial_p = if counts.len() == 2 {
        let mut it = counts.values();
        let (a, b) = (*it.next().unwrap_or(&0), *it.next().unwrap_or(&0));
        let p = binomial_two_sided(a, a + b);
        if p.is_none() {
            notes.push("paired_comparison.binomial_p: n/a: no decisive answers".to_owned());
        }
        p
    } else {
        notes.push(format!(
            "paired_comparison.binomial_p: n/a: {} conditions compared; the test needs exactly two",
            counts.len()
        ));
        None
    };
    let order_p = binomial_two_sided(first, first + second);
    let summary = json!({
        "counts": counts,
        "no_difference": no_difference,
        "binomial_p": binomial_p,
        "decisive": counts.values().sum::<u64>(),
        "trials": rows.len(),
        "order": {"first_chosen": first, "second_chosen": second, "binomial_p": order_p},
    });
    let mut list: Vec<(String, u64)> = counts.into_iter().collect();
    list.push(("no_difference".into(), no_difference));
    let table = Table {
        name: "paired_counts".into(),
        columns: ["chosen", "count"].map(String::from).to_vec(),
        rows: list
            .iter()
            .map(|(c, n)| vec![text(c.clone()), num(*n as f64)])
            .collect(),
    };
    let order_table = Table {
        name: "paired_order".into(),
        columns: ["first_chosen", "second_chosen", "binomial_p"]
            .map(String::from)
            .to_vec(),
        rows: vec![vec![num(first as f64), num(second as f64), opt(order_p)]],
    };
    Ok(Paired {
        summary,
        tables: vec![table, order_table],
        notes,
        counts: list,
    })
}

/// What power counts: the binomial test.
pub fn counted(s: &Value, out: &mut KindCounted<'_>) {
    out.test("binomial_p", &s["binomial_p"]);
}
