//! Each kind's data-CSV columns ([`StudyKind::COLUMNS`]) name the cells its
//! `row()` writes, in the same order: a kind lists them twice (the names,
//! then the values), and nothing but this test ties the two lists.
//!
//! [`StudyKind::COLUMNS`]: frictionlab::protocol::kind::StudyKind::COLUMNS
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use std::collections::BTreeMap;

use frictionlab::kinds::Registry;
use frictionlab::protocol::kind::Kinds;
use frictionlab::protocol::load::parse;
use frictionlab::session::{Simulation, simulate_in_memory};
use serde_json::Value;

/// Whether a CSV cell holds `v`: the same number, text, truth value (1 or
/// 0, as the CSVs write it), or empty for nothing. `None`: `v` is no single value (a list, an object).
fn holds(cell: &str, v: &Value) -> Option<bool> {
    Some(match v {
        Value::Null => cell.is_empty(),
        Value::Bool(b) => cell == if *b { "1" } else { "0" },
        Value::Number(n) => cell.parse::<f64>().ok() == n.as_f64(),
        Value::String(s) => cell == s,
        Value::Array(_) | Value::Object(_) => return None,
    })
}

/// The fields of one trial's logged data (a kind's data is tagged with its
/// kind's name, or flat).
fn fields(data: Value, kind: &str) -> serde_json::Map<String, Value> {
    let Value::Object(mut m) = data else {
        panic!("{kind}: its data is not an object");
    };
    match m.remove(kind) {
        Some(Value::Object(inner)) if m.is_empty() => inner,
        Some(other) => {
            m.insert(kind.to_owned(), other);
            m
        }
        None => m,
    }
}

#[test]
fn every_kinds_columns_name_the_cells_its_row_writes() {
    let root = env!("CARGO_MANIFEST_DIR");
    // Columns whose name is a field of the data, checked against it, per kind.
    let mut checked: BTreeMap<&str, usize> = BTreeMap::new();
    for name in [
        "paired-quick",
        "magnitude-quick",
        "fitts-quick",
        "discrimination-quick",
    ] {
        let text = std::fs::read_to_string(format!("{root}/protocols/{name}.json")).unwrap();
        let protocol = parse(&text).unwrap();
        let sim = Simulation {
            protocol: &protocol,
            protocol_bytes: text.as_bytes(),
            participants: 1,
            seed: 5,
            pace: None,
            streams: false,
            population: None,
            jobs: 1,
            stop: None,
            lsl: None,
        };
        let log = simulate_in_memory(&sim, 0).unwrap();
        assert!(!log.trials.is_empty(), "{name}: no trial");
        for record in &log.trials {
            let kind = Registry::data_kind(&record.data);
            let columns = Registry::columns(kind).unwrap();
            let row = record.data.row();
            assert_eq!(
                columns.len(),
                row.len(),
                "{name} trial {}: {kind} has {} columns and writes {} cells",
                record.trial,
                columns.len(),
                row.len()
            );
            let fields = fields(serde_json::to_value(&record.data).unwrap(), kind);
            for (column, cell) in columns.iter().zip(&row) {
                let Some(v) = fields.get(*column) else {
                    continue;
                };
                if let Some(same) = holds(cell, v) {
                    assert!(
                        same,
                        "{name} trial {}: column {column} holds {cell:?}, the data's {column} is {v}",
                        record.trial
                    );
                    *checked.entry(kind).or_default() += 1;
                }
            }
        }
    }
    eprintln!("columns checked against the data, per kind: {checked:?}");
    for kind in [
        "paired_comparison",
        "magnitude_estimation",
        "fitts",
        "discrimination",
    ] {
        assert!(
            checked.get(kind).is_some_and(|&n| n > 0),
            "{kind}: no column is named after a field of its data ({checked:?})"
        );
    }
}
