//! The files made from the logs: each session's data CSV and the folder's
//! `dataset_description.json`.

use std::collections::BTreeSet;

use super::csv::text;
use super::folder::ResultsDir;
use super::session_log::{Header, ReadLog, read_header};
use super::{ResultsError, replace_file};
use crate::protocol::engine::TrialRecord;
use crate::protocol::kind::Kinds;

/// The data CSV columns every kind has.
pub const COMMON_COLUMNS: [&str; 10] = [
    "study",
    "kind",
    "participant",
    "session",
    "trial",
    "block",
    "status",
    "seed",
    "practice",
    "repetition",
];

/// The data CSV of a session, from its log. Lists (`tap_x_m`, ...) are
/// `;`-separated; missing values are empty cells.
///
/// A session published on the Lab Streaming Layer (any record with LSL
/// times) has two more columns at the end, [`LSL_COLUMNS`]: each trial's
/// start and end on LSL's clock, to line the rows up with an XDF
/// recording (empty for trials run without `--lsl`, as before a resume
/// that added it).
#[must_use]
pub fn data_csv<K: Kinds>(log: &ReadLog<K>) -> String {
    let (columns, rows) = data_rows(log);
    csv_text(&columns, &rows)
}

/// The columns and the rows' cells of a session's data CSV
/// ([`data_csv`]), as the file holds them (text quoted where it must be).
#[must_use]
pub fn data_rows<K: Kinds>(log: &ReadLog<K>) -> (Vec<&'static str>, Vec<Vec<String>>) {
    let lsl = log
        .trials
        .iter()
        .any(|r| r.lsl_start_s.is_some() || r.lsl_end_s.is_some());
    let mut columns = data_columns::<K>(log.header.protocol.kind());
    if lsl {
        columns.extend(LSL_COLUMNS);
    }
    let rows = log
        .trials
        .iter()
        .map(|r| {
            let mut cells = data_cells(&log.header, r);
            if lsl {
                cells.push(super::csv::opt_num(r.lsl_start_s));
                cells.push(super::csv::opt_num(r.lsl_end_s));
            }
            cells
        })
        .collect();
    (columns, rows)
}

/// CSV text of `columns` and `rows` of cells (quoted already).
#[must_use]
pub fn csv_text(columns: &[&str], rows: &[Vec<String>]) -> String {
    let width = rows
        .first()
        .map_or(0, |r| r.iter().map(|c| c.len() + 1).sum());
    let mut csv = String::with_capacity((rows.len() + 1) * width.max(64));
    csv.push_str(&columns.join(","));
    csv.push('\n');
    for cells in rows {
        for (i, cell) in cells.iter().enumerate() {
            if i > 0 {
                csv.push(',');
            }
            csv.push_str(cell);
        }
        csv.push('\n');
    }
    csv
}

/// The data-CSV columns of a session published on LSL (after the kind's).
pub const LSL_COLUMNS: [&str; 2] = ["lsl_start_s", "lsl_end_s"];

/// The data-CSV columns of a session of `kind`: the common ones, then the
/// kind's.
#[must_use]
pub fn data_columns<K: Kinds>(kind: &str) -> Vec<&'static str> {
    let mut out: Vec<&str> = COMMON_COLUMNS.to_vec();
    out.extend_from_slice(K::columns(kind).unwrap_or_default());
    out
}

/// The data-CSV cells of record `r` of the session of `h`, one per
/// [`data_columns`] entry, as the file holds them (text quoted where it
/// must be).
#[must_use]
pub fn data_cells<K: Kinds>(h: &Header<K>, r: &TrialRecord<K>) -> Vec<String> {
    let mut row = vec![
        text(&h.protocol_id),
        h.protocol.kind().to_owned(),
        text(&h.participant),
        h.session.to_string(),
        r.trial.to_string(),
        text(&r.block),
        r.status.as_str().to_owned(),
        h.plan_seed.to_string(),
        r.practice.to_string(),
        r.repetition.to_string(),
    ];
    row.extend(K::row(&r.data));
    row
}

/// Writes `dataset_description.json` listing every column of every data file
/// of the kinds present, with [`LSL_COLUMNS`] when `lsl` (a session
/// published on LSL) or when the description listed them already.
///
/// # Errors
/// Any I/O error.
pub fn write_dataset_description<K: Kinds>(
    dir: &ResultsDir,
    kinds: &BTreeSet<&'static str>,
    lsl: bool,
) -> Result<(), ResultsError> {
    let path = dir.root().join("dataset_description.json");
    let listed = std::fs::read_to_string(&path)
        .is_ok_and(|text| text.contains(&format!("\"{}\"", LSL_COLUMNS[0])));
    let mut columns: Vec<&str> = COMMON_COLUMNS.to_vec();
    for kind in K::KINDS {
        if kinds.contains(kind.name) {
            columns.extend(
                kind.columns
                    .iter()
                    .filter(|c| !columns.contains(c))
                    .collect::<Vec<_>>(),
            );
        }
    }
    if lsl || listed {
        columns.extend(LSL_COLUMNS);
    }
    let doc = serde_json::json!({
        "@context": "https://schema.org/",
        "@type": "Dataset",
        "name": "frictionlab results",
        "description": format!(
            "Friction perception sessions recorded by frictionlab {} ({}). One row per trial; \
             units SI; see results-schema/ in the frictionlab sources.",
            env!("CARGO_PKG_VERSION"),
            kinds.iter().copied().collect::<Vec<_>>().join(", ")
        ),
        "variableMeasured": columns,
    });
    let text = serde_json::to_string_pretty(&doc).unwrap_or_default() + "\n";
    replace_file(&path, text.as_bytes(), true)
}

/// The kinds of every session log in the folder.
#[must_use]
pub fn kinds_present<K: Kinds>(dir: &ResultsDir) -> BTreeSet<&'static str> {
    dir.logs()
        .iter()
        .filter_map(|p| read_header::<K>(p).ok())
        .map(|h| h.protocol.kind())
        .collect()
}
