//! The files made from the logs: each session's data CSV and the folder's
//! `dataset_description.json`.

use std::collections::BTreeSet;

use super::csv::{Row, text};
use super::folder::ResultsDir;
use super::session_log::{ReadLog, read_header};
use super::trial::LoggedTrial;
use super::{ResultsError, replace_file};
use crate::protocol::kind::Kinds;
use crate::protocol::kind::WriteCells as _;

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
    DataText::of(log).text
}

/// A session's data CSV made from its log ([`data_csv`]): its columns, its
/// text, and where each record's cells are in it, as the file holds them
/// (text quoted where it must be). Written straight into one text: a log
/// of a million trials makes its CSV without a string per cell.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct DataText {
    /// The columns.
    pub columns: Vec<&'static str>,
    /// The CSV's text, column names first.
    pub text: String,
    /// The byte where each cell of each record starts, then the end of the
    /// text; every cell is followed by one `,` or line break.
    starts: Vec<usize>,
    /// Where each record's cells start in `starts`, then their end.
    rows: Vec<usize>,
}

impl DataText {
    /// The data CSV of the session of `log`.
    #[must_use]
    pub fn of<K: Kinds>(log: &ReadLog<K>) -> Self {
        let (mut out, same) = Self::head(log, log.trials.len());
        for r in &log.trials {
            out.push_record(&same, r);
        }
        out.rows.push(out.starts.len());
        out.starts.push(out.text.len());
        out
    }

    /// The data CSV of the session of `log` if `text` is it byte for
    /// byte, with `text` as its text (not copied); else `text` back. Each
    /// record is made in turn and held against the text where it should
    /// be: the whole CSV is never made a second time.
    ///
    /// # Errors
    /// `text` back, when it is not the log's CSV.
    pub fn matching<K: Kinds>(log: &ReadLog<K>, text: String) -> Result<Self, String> {
        let (mut record, same) = Self::head(log, 1);
        let n = log.trials.len();
        let mut starts = Vec::with_capacity(n * record.columns.len() + 1);
        let mut rows = Vec::with_capacity(n + 1);
        let mut at = record.text.len();
        if !text.as_bytes().starts_with(record.text.as_bytes()) {
            return Err(text);
        }
        for r in &log.trials {
            record.text.clear();
            record.starts.clear();
            record.rows.clear();
            record.push_record(&same, r);
            let end = at + record.text.len();
            if text.as_bytes().get(at..end) != Some(record.text.as_bytes()) {
                return Err(text);
            }
            rows.push(starts.len());
            starts.extend(record.starts.iter().map(|s| at + s));
            at = end;
        }
        if at != text.len() {
            return Err(text);
        }
        rows.push(starts.len());
        starts.push(text.len());
        Ok(Self {
            columns: record.columns,
            text,
            starts,
            rows,
        })
    }

    /// The CSV's column names, with room for `records` records, and what
    /// every record of `log` has the same.
    fn head<K: Kinds>(log: &ReadLog<K>, records: usize) -> (Self, Same) {
        let lsl = log
            .trials
            .iter()
            .any(|r| r.lsl_start_s.is_some() || r.lsl_end_s.is_some());
        let mut columns = data_columns::<K>(log.header.protocol.kind());
        if lsl {
            columns.extend(LSL_COLUMNS);
        }
        let mut out = Self {
            text: String::with_capacity((records + 1) * 24 * columns.len()),
            starts: Vec::with_capacity(records * columns.len() + 1),
            rows: Vec::with_capacity(records + 1),
            columns,
        };
        out.text.push_str(&out.columns.join(","));
        out.text.push('\n');
        let h = &log.header;
        let same = Same {
            study: text(&h.protocol_id),
            kind: h.protocol.kind(),
            participant: text(&h.participant),
            session: h.session.to_string(),
            seed: h.plan_seed.to_string(),
            lsl,
        };
        (out, same)
    }

    /// Writes the CSV record of trial `r` of the session of `same`.
    fn push_record<K: Kinds>(&mut self, same: &Same, r: &LoggedTrial<K>) {
        self.rows.push(self.starts.len());
        let mut out = Row::new(&mut self.text, &mut self.starts, false);
        out.cell().push_str(&same.study);
        out.cell().push_str(same.kind);
        out.cell().push_str(&same.participant);
        out.cell().push_str(&same.session);
        out.whole(r.trial as u64);
        out.text(&r.block);
        out.cell().push_str(r.status.as_str());
        out.cell().push_str(&same.seed);
        out.cell()
            .push_str(if r.practice { "true" } else { "false" });
        out.whole(u64::from(r.repetition));
        K::row(&r.data, &mut out);
        if same.lsl {
            out.opt_num(r.lsl_start_s);
            out.opt_num(r.lsl_end_s);
        }
        self.text.push('\n');
    }

    /// The records' cells, each record's in column order.
    #[must_use = "an iterator does nothing until read"]
    pub fn records(&self) -> impl ExactSizeIterator<Item = Cells<'_>> {
        self.rows.windows(2).map(|w| Cells {
            text: &self.text,
            starts: &self.starts[w[0]..=w[1]],
        })
    }
}

/// The cells every record of a session's CSV has the same, as written.
struct Same {
    study: String,
    kind: &'static str,
    participant: String,
    session: String,
    seed: String,
    /// The CSV has the LSL columns.
    lsl: bool,
}

/// One record's cells in a [`DataText`].
#[derive(Debug, Clone, Copy)]
pub struct Cells<'a> {
    text: &'a str,
    /// Its cells' starts, then the start of the next record's first cell
    /// (or the end of the text).
    starts: &'a [usize],
}

impl<'a> Cells<'a> {
    /// Cell `i` as the file holds it, if the record has one.
    #[must_use]
    pub fn get(&self, i: usize) -> Option<&'a str> {
        let (&start, &next) = (self.starts.get(i)?, self.starts.get(i + 1)?);
        self.text.get(start..next - 1)
    }
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
