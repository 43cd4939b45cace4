//! `frictionlab analyze`: a results folder in, the three studies' statistics
//! out (`summary.json`, tables as CSV and Parquet, an HTML report with SVG
//! figures).
//!
//! It reads only the documented results files (`results-schema/`): the
//! session logs and the data CSVs, each once (`folder.rs`: each CSV held
//! against its log, the rows of a CSV that matches taken from the log
//! already parsed), keeping the completed non-practice trials. Cells stay
//! text until a kind's analysis asks for numbers (`rows.rs`), so that a
//! bad value is reported with its file, line and column.
//!
//! Statistics that cannot be computed (one display only, too few points)
//! are `null` in `summary.json`, with the reason in `notes`. Input that
//! cannot be analysed at all (no data files, missing columns, non-numeric or
//! non-positive magnitudes) is a [`Problem`] naming the file (with
//! `line:column` when known) or folder.
//!
//! The parts, each importing only those before it: `table.rs` (the output
//! table model), `rows.rs` (the rows API), `entry.rs` (a kind's analysis:
//! the seam the registry fills), `folder.rs` (reading a folder, or
//! sessions in memory, into each kind's rows), this file (the driver),
//! `output.rs` (the files, Parquet included); `stats.rs` and `report.rs`
//! are what the kinds' analyses build with.

pub mod counted;
mod entry;
mod folder;
mod output;
pub mod report;
mod rows;
pub mod stats;
mod table;

use std::collections::BTreeMap;
use std::path::Path;

use serde_json::{Value, json};

pub use entry::{
    AnalysedKinds, Analysis, AnalysisEntry, Context, KindAnalysis, RunAnalysis, Scope, Section,
    designs_of,
};
pub use folder::{Check, Tables, read};
pub use output::write;
pub use rows::Rows;
pub use table::{Cell, Table, num, opt, text};

use crate::problem::Problem;

/// Runs every analysis the folder's data allows, each data CSV first held
/// against its session log (issue 31).
///
/// # Errors
/// Input that cannot be analysed.
pub fn analyze<K: AnalysedKinds>(dir: &Path) -> Result<Analysis, Problem> {
    analyze_with::<K>(dir, Check::AgainstLogs)
}

/// [`analyze`], the data CSVs checked as `check` says: [`read`] the
/// folder's tables, then [`analyze_tables`] them.
///
/// # Errors
/// Input that cannot be analysed; with [`Check::AgainstLogs`], a CSV
/// unlike its log, or a damaged log.
pub fn analyze_with<K: AnalysedKinds>(dir: &Path, check: Check) -> Result<Analysis, Problem> {
    analyze_tables(&read::<K>(dir, check)?, Scope::Report)
}

/// Runs each kind's analysis on its tables, in registry order; with
/// [`Scope::Counted`], only the statistics (no report page).
///
/// # Errors
/// Input that cannot be analysed.
pub fn analyze_tables<K: AnalysedKinds>(t: &Tables<K>, scope: Scope) -> Result<Analysis, Problem> {
    let mut notes = t.notes.clone();
    let mut summary = serde_json::Map::new();
    let mut tables = Vec::new();
    let mut sections = Vec::new();
    let context = Context {
        folder: &t.folder,
        designs: &t.designs,
        scope,
    };
    for (kind, entry) in K::analyses() {
        let (Some(entry), Some(rows)) = (entry, t.rows.get(kind)) else {
            continue;
        };
        let section = (entry.run)(rows, &context)?;
        summary.insert(kind.into(), section.summary);
        notes.extend(section.notes);
        sections.push(section.html);
        tables.extend(section.tables);
    }
    let rows: BTreeMap<&str, usize> = t.rows.iter().map(|(k, v)| (*k, v.len())).collect();
    let mut inputs = json!({"folder": folder_name(&t.folder), "analysed_rows": rows, "rule": "completed, non-practice trials"});
    if !t.checked_against_logs {
        inputs["checked_against_logs"] = json!(false);
    }
    summary.insert("inputs".into(), inputs);
    summary.insert("notes".into(), json!(notes));
    let summary = Value::Object(summary);
    let html = match scope {
        Scope::Report => report::page(&folder_name(&t.folder), &summary, &sections, &notes),
        Scope::Counted => String::new(),
    };
    Ok(Analysis {
        summary,
        tables,
        html,
    })
}

/// The folder's own name (not its full path, so a report does not depend on
/// where it was made).
fn folder_name(dir: &Path) -> String {
    dir.file_name().map_or_else(
        || dir.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    )
}
