//! `frictionlab analyze`: a results folder in, the three studies' statistics
//! out (`summary.json`, tables as CSV and Parquet, an HTML report with SVG
//! figures).
//!
//! It reads only the documented results files (`results-schema/`): the data
//! CSVs, with polars (lazy scan, all columns read as text, filtered to
//! completed non-practice trials), and the session logs' headers for the
//! order of the magnitude-estimation displays. Numbers are parsed here so that
//! a bad value is reported with its file and line.
//!
//! Statistics that cannot be computed (one display only, too few points)
//! are `null` in `summary.json`, with the reason in `notes`. Input that
//! cannot be analysed at all (no data files, missing columns, non-numeric or
//! non-positive magnitudes) is a [`Problem`] naming the file (with
//! `line:column` when known) or folder.

pub mod counted;
pub mod report;
pub mod stats;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use polars::prelude::*;
use serde_json::{Value, json};

use crate::problem::Problem;
use crate::protocol::kind::{Holds, Kinds, StudyKind};
use crate::results::{COMMON_COLUMNS, ReadLog, ResultsDir};

/// One output table: named columns of cells, written as CSV and Parquet.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    /// File stem and title.
    pub name: String,
    /// Column names.
    pub columns: Vec<String>,
    /// Rows (one cell per column).
    pub rows: Vec<Vec<Cell>>,
}

/// A table cell.
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    /// Text.
    Text(String),
    /// A number, or missing.
    Num(Option<f64>),
}

impl Cell {
    fn as_csv(&self) -> String {
        match self {
            Cell::Text(s) if s.contains([',', '"', '\n']) => {
                format!("\"{}\"", s.replace('"', "\"\""))
            }
            Cell::Text(s) => s.clone(),
            Cell::Num(Some(x)) => crate::results::csv::num(*x),
            Cell::Num(None) => String::new(),
        }
    }
}

/// A text cell.
pub fn text(s: impl Into<String>) -> Cell {
    Cell::Text(s.into())
}

/// A number cell.
#[must_use]
pub fn num(x: f64) -> Cell {
    Cell::Num(x.is_finite().then_some(x))
}

/// An optional number cell.
#[must_use]
pub fn opt(x: Option<f64>) -> Cell {
    Cell::Num(x.filter(|v| v.is_finite()))
}

impl Table {
    /// The table as CSV text.
    #[must_use]
    pub fn csv(&self) -> String {
        let mut out = self.columns.join(",");
        out.push('\n');
        for row in &self.rows {
            out.push_str(&row.iter().map(Cell::as_csv).collect::<Vec<_>>().join(","));
            out.push('\n');
        }
        out
    }

    /// The table as a polars `DataFrame` (text columns as strings, numbers as
    /// nullable f64).
    ///
    /// # Errors
    /// A polars error.
    pub fn frame(&self) -> PolarsResult<DataFrame> {
        let columns: Vec<Column> = self
            .columns
            .iter()
            .enumerate()
            .map(|(i, name)| {
                let is_text = self
                    .rows
                    .iter()
                    .any(|r| matches!(r.get(i), Some(Cell::Text(_))));
                if is_text {
                    let v: Vec<Option<String>> = self
                        .rows
                        .iter()
                        .map(|r| match r.get(i) {
                            Some(Cell::Text(s)) => Some(s.clone()),
                            Some(Cell::Num(Some(x))) => Some(x.to_string()),
                            _ => None,
                        })
                        .collect();
                    Column::new(name.as_str().into(), v)
                } else {
                    let v: Vec<Option<f64>> = self
                        .rows
                        .iter()
                        .map(|r| {
                            if let Some(Cell::Num(x)) = r.get(i) {
                                *x
                            } else {
                                None
                            }
                        })
                        .collect();
                    Column::new(name.as_str().into(), v)
                }
            })
            .collect();
        DataFrame::new_infer_height(columns)
    }
}

/// A kind's analysis: how its data files are told, what it reads, and
/// the entry that turns the rows into a report section.
#[derive(Debug, Clone, Copy)]
pub struct AnalysisEntry<K: Kinds> {
    /// A column only this kind's data CSVs have.
    pub marker: &'static str,
    /// The kind's columns the analysis does not need (they may be
    /// missing; every other column must be present).
    pub unread: &'static [&'static str],
    /// Of those, the ones it reads when every data file of the kind has
    /// them (columns added after older files were written).
    pub optional: &'static [&'static str],
    /// It also reads the rows that did not complete, to count them
    /// (`Rows::aborted`).
    pub counts_aborted: bool,
    /// The analysis of the completed, non-practice rows of this kind, with
    /// its [`Context`].
    pub run: RunAnalysis<K>,
    /// Which of its summary's statistics are tests (and intervals) that
    /// power planning counts.
    pub counted: counted::CountStatistics,
}

/// A kind's analysis of its rows ([`AnalysisEntry::run`]).
pub type RunAnalysis<K> = fn(rows: &Rows, context: &Context<'_, K>) -> Result<Section, Problem>;

/// How much of an analysis to make.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Scope {
    /// Everything `analyze` reports: the summary, the tables, every
    /// interval, the HTML report.
    Report,
    /// The summary's statistics that power planning counts (`power`): a
    /// kind may leave out what is costly and not counted (the tables, the
    /// report section, each discrimination track's bootstrap and profile
    /// intervals). The statistics it gives are those of
    /// [`Scope::Report`], bit for bit.
    Counted,
}

/// What a kind's analysis is given besides its rows.
#[derive(Debug)]
pub struct Context<'a, K: Kinds> {
    /// The results folder (for the place of a problem; a replay in memory
    /// names what stands in for it).
    pub folder: &'a Path,
    /// The designs of the sessions analysed (every kind's, in the order of
    /// their files), for what the data CSVs do not hold, such as the
    /// protocol's display order.
    pub designs: &'a [K::Design],
    /// How much to make.
    pub scope: Scope,
}

impl<K: Kinds> Context<'_, K> {
    /// A kind's report section, made only for [`Scope::Report`].
    pub fn report(&self, html: impl FnOnce() -> String) -> String {
        match self.scope {
            Scope::Report => html(),
            Scope::Counted => String::new(),
        }
    }
}

/// A kind's analysis, implemented in its folder beside its
/// [`StudyKind`].
pub trait KindAnalysis: StudyKind {
    /// The kind's analysis in a set of kinds that holds it; `None`: the
    /// kind has none.
    fn analysis<K: Holds<Self>>() -> Option<AnalysisEntry<K>>;
}

/// A set of kinds with their analyses: the registry, which hands itself to
/// [`analyze`].
pub trait AnalysedKinds: Kinds {
    /// Each kind's name and analysis, in registry order.
    fn analyses() -> Vec<(&'static str, Option<AnalysisEntry<Self>>)>;
}

/// The designs of the kind `S` among `designs`, in order.
pub fn designs_of<S: StudyKind, K: Holds<S>>(
    designs: &[K::Design],
) -> impl Iterator<Item = &S::Design> {
    designs.iter().filter_map(|d| K::design_of(d))
}

/// One kind's part of an analysis, from its [`AnalysisEntry`].
#[derive(Debug, Clone)]
pub struct Section {
    /// The kind's object in `summary.json`.
    pub summary: Value,
    /// Why some statistics are n/a.
    pub notes: Vec<String>,
    /// The kind's tables.
    pub tables: Vec<Table>,
    /// The kind's section of the HTML report.
    pub html: String,
}

/// A finished analysis.
#[derive(Debug, Clone)]
pub struct Analysis {
    /// `summary.json`'s content.
    pub summary: Value,
    /// The tables.
    pub tables: Vec<Table>,
    /// The HTML report.
    pub html: String,
}

/// The data rows of one kind, as read by polars (all columns text), and the
/// files they came from (to locate a bad value on the error path).
#[derive(Debug, Clone, Default)]
pub struct Rows {
    frame: DataFrame,
    /// The non-practice rows that did not complete (aborted, timed out).
    aborted: DataFrame,
    files: Vec<PathBuf>,
}

impl Rows {
    /// Number of rows.
    #[must_use]
    pub fn len(&self) -> usize {
        self.frame.height()
    }

    /// Whether there are no rows.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.frame.height() == 0
    }

    /// The rows of the same files that did not complete (aborted, timed
    /// out), which the analysis leaves out and counts (empty unless its
    /// entry `counts_aborted`).
    #[must_use]
    pub fn aborted(&self) -> Rows {
        Rows {
            frame: self.aborted.clone(),
            aborted: DataFrame::empty(),
            files: self.files.clone(),
        }
    }

    fn column(&self, column: &str) -> Option<&StringChunked> {
        self.frame.column(column).ok().and_then(|c| c.str().ok())
    }

    /// The rows whose `column` is filled (`filled`), or empty or missing
    /// (`!filled`); the rows that did not complete alike.
    ///
    /// # Errors
    /// Polars failed to filter.
    pub fn where_filled(&self, column: &str, filled: bool) -> Result<Rows, Problem> {
        let pick = |frame: &DataFrame| -> PolarsResult<DataFrame> {
            let mask: BooleanChunked = match frame.column(column).ok().and_then(|c| c.str().ok()) {
                Some(c) => c
                    .iter()
                    .map(|v| v.is_some_and(|t| !t.trim().is_empty()) == filled)
                    .collect(),
                None => std::iter::repeat_n(!filled, frame.height()).collect(),
            };
            frame.filter(&mask)
        };
        let fail = |e: PolarsError| Problem::new(column, e.to_string());
        Ok(Rows {
            frame: pick(&self.frame).map_err(fail)?,
            aborted: if self.aborted.height() == 0 {
                self.aborted.clone()
            } else {
                pick(&self.aborted).map_err(fail)?
            },
            files: self.files.clone(),
        })
    }

    /// The text of `column` at `row`.
    #[must_use]
    pub fn text(&self, column: &str, row: usize) -> &str {
        self.column(column).and_then(|c| c.get(row)).unwrap_or("")
    }

    /// Every value of `column` as a number.
    ///
    /// # Errors
    /// The first value that is not a finite number, with its file and line.
    pub fn numbers(&self, column: &str) -> Result<Vec<f64>, Problem> {
        let Some(c) = self.column(column) else {
            return Ok(Vec::new());
        };
        let mut out = Vec::with_capacity(c.len());
        for v in c.iter() {
            match v.unwrap_or("").trim().parse::<f64>() {
                Ok(x) if x.is_finite() => out.push(x),
                _ => {
                    let t = v.unwrap_or("");
                    return Err(self.error_at(column, t, &format!("'{t}' is not a finite number")));
                }
            }
        }
        Ok(out)
    }

    /// Every value of `column` as a small integer code, with the distinct
    /// values in order of first appearance.
    #[must_use]
    pub fn codes(&self, column: &str) -> (Vec<u32>, Vec<String>) {
        let mut names: Vec<String> = Vec::new();
        let mut index: std::collections::HashMap<&str, u32> = std::collections::HashMap::new();
        let codes = self
            .column(column)
            .map(|c| {
                c.iter()
                    .map(|v| {
                        let v = v.unwrap_or("");
                        *index.entry(v).or_insert_with(|| {
                            names.push(v.to_owned());
                            u32::try_from(names.len() - 1).unwrap_or(u32::MAX)
                        })
                    })
                    .collect()
            })
            .unwrap_or_default();
        (codes, names)
    }

    /// `column` at `row` as a number, with the file and line on error.
    ///
    /// # Errors
    /// The value is not a finite number.
    pub fn number(&self, column: &str, row: usize) -> Result<f64, Problem> {
        let t = self.text(column, row);
        match t.trim().parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => Err(self.error(column, row, &format!("'{t}' is not a finite number"))),
        }
    }

    /// `column` at `row` as a number, or `None` if the cell is empty.
    ///
    /// # Errors
    /// A non-empty value that is not a finite number.
    pub fn optional(&self, column: &str, row: usize) -> Result<Option<f64>, Problem> {
        if self.text(column, row).trim().is_empty() {
            Ok(None)
        } else {
            self.number(column, row).map(Some)
        }
    }

    /// `column` at `row` as a `;`-separated list of numbers.
    ///
    /// # Errors
    /// An element that is not a finite number.
    pub fn list(&self, column: &str, row: usize) -> Result<Vec<f64>, Problem> {
        let t = self.text(column, row);
        if t.trim().is_empty() {
            return Ok(Vec::new());
        }
        t.split(';')
            .map(|s| match s.trim().parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(self.error(
                    column,
                    row,
                    &format!("'{s}' in '{t}' is not a finite number"),
                )),
            })
            .collect()
    }

    /// An error about the value of `column` at `row`.
    #[must_use]
    pub fn error(&self, column: &str, row: usize, message: &str) -> Problem {
        self.error_at(column, self.text(column, row), message)
    }

    /// An error placed at the first analysed row (completed, non-practice)
    /// whose `column` holds `value`; found by reading the files again, only
    /// on this error path.
    fn error_at(&self, column: &str, value: &str, message: &str) -> Problem {
        for file in &self.files {
            if let Some((line, col)) = locate(file, column, value) {
                return Problem::new(
                    format!("{}: {line}:{col}", file.display()),
                    format!("{column}: {message}"),
                );
            }
        }
        let place = self
            .files
            .first()
            .map(|f| f.display().to_string())
            .unwrap_or_default();
        Problem::new(place, format!("{column}: {message}"))
    }
}

/// Line and column (1-based) of the first analysed row of a data CSV whose
/// `column` holds `value`.
fn locate(file: &Path, column: &str, value: &str) -> Option<(usize, usize)> {
    let text = std::fs::read_to_string(file).ok()?;
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next()?.split(',').collect();
    let at = |name: &str| header.iter().position(|h| *h == name);
    let (col, status, practice) = (at(column)?, at("status")?, at("practice")?);
    for (i, line) in lines.enumerate() {
        let cells = split_csv(line);
        let cell = |j: usize| cells.get(j).map_or("", String::as_str);
        if cell(status) == "completed" && cell(practice) == "false" && cell(col) == value {
            let offset: usize = line.split(',').take(col).map(|c| c.len() + 1).sum();
            return Some((i + 2, offset + 1));
        }
    }
    None
}

/// Splits one CSV line, honouring double quotes.
fn split_csv(line: &str) -> Vec<String> {
    let (mut cells, mut cur, mut quoted) = (Vec::new(), String::new(), false);
    let mut chars = line.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '"' if quoted && chars.peek() == Some(&'"') => {
                cur.push('"');
                chars.next();
            }
            '"' => quoted = !quoted,
            ',' if !quoted => cells.push(std::mem::take(&mut cur)),
            _ => cur.push(c),
        }
    }
    cells.push(cur);
    cells
}

/// Columns the analysis of a kind reads.
fn needed<K: Kinds>(kind: &str, entry: &AnalysisEntry<K>) -> Vec<&'static str> {
    let mut c: Vec<&str> = vec!["participant", "trial", "status", "practice"];
    c.extend(
        K::columns(kind)
            .unwrap_or_default()
            .iter()
            .filter(|k| !entry.unread.contains(k)),
    );
    c
}

/// A kind's data files: its name and entry, the files, and the optional
/// columns all of them have.
type Group<K> = (
    &'static str,
    AnalysisEntry<K>,
    Vec<PathBuf>,
    Vec<&'static str>,
);

/// Reads every data CSV of the folder, grouped by kind: completed,
/// non-practice rows only. Unchecked against the logs (see [`analyze`]).
///
/// # Errors
/// No data files, a file whose kind cannot be told, missing columns, or a
/// CSV polars cannot read.
pub fn load<K: AnalysedKinds>(dir: &Path) -> Result<BTreeMap<&'static str, Rows>, Problem> {
    load_files::<K>(dir, &crate::results::data_files(dir))
}

/// [`load`] of the data CSVs `files` of the folder `dir`.
///
/// # Errors
/// As [`load`].
fn load_files<K: AnalysedKinds>(
    dir: &Path,
    files: &[PathBuf],
) -> Result<BTreeMap<&'static str, Rows>, Problem> {
    if files.is_empty() {
        return Err(Problem::new(
            dir.display().to_string(),
            "no data files (expected data/*_data.csv, as written by frictionlab run or simulate)",
        ));
    }
    let analysed: Vec<(&'static str, AnalysisEntry<K>)> = K::analyses()
        .into_iter()
        .filter_map(|(k, a)| a.map(|a| (k, a)))
        .collect();
    // Per kind: its entry, its files, and the optional columns every one of
    // them has (read; else left out for all).
    let mut by_kind: BTreeMap<&'static str, Group<K>> = BTreeMap::new();
    for file in files {
        let name = file.display().to_string();
        let text = std::fs::read_to_string(file)
            .map_err(|e| Problem::new(&name, format!("cannot read: {e}")))?;
        let mut lines = text.lines();
        let header = lines
            .next()
            .map(|l| l.split(',').map(str::to_owned).collect::<Vec<_>>())
            .unwrap_or_default();
        let has = |c: &str| header.iter().any(|h| h == c);
        // The kind: the first row's `kind` cell (ids and kind names hold no
        // commas); in a file without rows, the first kind whose marker
        // column it has.
        let named = header
            .iter()
            .position(|h| h == "kind")
            .and_then(|i| lines.next()?.split(',').nth(i));
        let found = match named {
            Some(k) => {
                let Some(found) = analysed.iter().find(|(kind, _)| *kind == k) else {
                    return Err(Problem::new(
                        format!("{name}: 2:1"),
                        format!("no analysis for the kind of session '{k}'"),
                    ));
                };
                Some(found)
            }
            None => analysed.iter().find(|(_, a)| has(a.marker)),
        };
        let Some(&(kind, ref entry)) = found else {
            let markers: Vec<&str> = analysed.iter().map(|(_, a)| a.marker).collect();
            return Err(Problem::new(
                format!("{name}: 1:1"),
                format!(
                    "cannot tell the kind of session: none of the columns {}",
                    markers.join(", ")
                ),
            ));
        };
        for c in COMMON_COLUMNS.iter().copied().chain(needed(kind, entry)) {
            if !has(c) {
                return Err(Problem::new(
                    format!("{name}: 1:1"),
                    format!("missing column '{c}'"),
                ));
            }
        }
        let group = by_kind
            .entry(kind)
            .or_insert_with(|| (kind, *entry, Vec::new(), entry.optional.to_vec()));
        group.2.push(file.clone());
        group.3.retain(|c| has(c));
    }
    let mut out = BTreeMap::new();
    for (name, (kind, entry, paths, optional)) in by_kind {
        let mut columns = needed(kind, &entry);
        columns.extend(optional);
        out.insert(name, scan(&paths, &columns, entry.counts_aborted)?);
    }
    Ok(out)
}

/// Lazily scans `paths` (all columns as text), keeps the non-practice rows
/// and the `columns` asked for: the completed ones, and with
/// `keep_aborted` the others apart.
fn scan(paths: &[PathBuf], columns: &[&str], keep_aborted: bool) -> Result<Rows, Problem> {
    let place = paths
        .first()
        .map(|p| p.display().to_string())
        .unwrap_or_default();
    let fail = |e: PolarsError| Problem::new(&place, format!("cannot read the CSV: {e}"));
    let sources: Vec<PlRefPath> = paths
        .iter()
        .map(|p| PlRefPath::from(p.to_string_lossy().as_ref()))
        .collect();
    let scan = LazyCsvReader::new_paths(sources.into())
        .with_infer_schema_length(Some(0))
        .finish()
        .map_err(fail)?
        .filter(col("practice").eq(lit("false")))
        .select(columns.iter().map(|c| col(*c)).collect::<Vec<_>>());
    // Only a kind that counts the others reads them (the filter is pushed
    // into the scan otherwise).
    let completed = col("status").eq(lit("completed"));
    if !keep_aborted {
        return Ok(Rows {
            frame: scan.filter(completed).collect().map_err(fail)?,
            aborted: DataFrame::empty(),
            files: paths.to_vec(),
        });
    }
    let rows = scan.collect().map_err(fail)?;
    let completed = |yes: bool| {
        let status = col("status").eq(lit("completed"));
        rows.clone()
            .lazy()
            .filter(if yes { status } else { status.not() })
            .collect()
            .map_err(fail)
    };
    Ok(Rows {
        frame: completed(true)?,
        aborted: completed(false)?,
        files: paths.to_vec(),
    })
}

/// How the data CSVs are checked before they are analysed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Check {
    /// Each CSV held against its session log, the primary record
    /// ([`crate::results::verify`]); the default.
    AgainstLogs,
    /// The CSVs alone, unchecked (data edited by hand, or without logs):
    /// said in `summary.json` (`inputs.checked_against_logs: false` and a
    /// note).
    CsvOnly,
}

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

/// What an analysis reads: each kind's rows (completed, non-practice; the
/// others apart where a kind counts them), the designs of the sessions,
/// and what reading them noticed. Read from a results folder ([`read`]),
/// or made from session records in memory ([`Tables::from_logs`]).
#[derive(Debug)]
pub struct Tables<K: Kinds> {
    folder: PathBuf,
    rows: BTreeMap<&'static str, Rows>,
    designs: Vec<K::Design>,
    notes: Vec<String>,
    checked_against_logs: bool,
}

/// Reads a results folder's data for analysis: each data CSV held against
/// its session log first (unless `check` says [`Check::CsvOnly`]), then
/// the CSVs (polars lazy scan) and the logs' designs.
///
/// # Errors
/// Input that cannot be analysed; with [`Check::AgainstLogs`], a CSV
/// unlike its log, or a damaged log.
pub fn read<K: AnalysedKinds>(dir: &Path, check: Check) -> Result<Tables<K>, Problem> {
    let mut notes: Vec<String> = Vec::new();
    let rows = match check {
        Check::AgainstLogs => {
            let jobs = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
            let verified = crate::results::verify::<K>(dir, jobs)?;
            notes.extend(verified.notices);
            if verified.files.is_empty() && !crate::results::data_files(dir).is_empty() {
                return Err(Problem::new(
                    dir.display().to_string(),
                    format!(
                        "no data to analyse: every session is open in another process ({})",
                        notes.join("; ")
                    ),
                ));
            }
            load_files::<K>(dir, &verified.files)?
        }
        Check::CsvOnly => {
            notes.push(
                "the data CSVs were analysed alone, not held against their session logs (the primary record): edits or damage to them would go unnoticed".to_owned(),
            );
            load::<K>(dir)?
        }
    };
    let designs: Vec<K::Design> = ResultsDir::new(dir)
        .headers::<K>()
        .into_iter()
        .map(|h| h.protocol.design)
        .collect();
    Ok(Tables {
        folder: dir.to_owned(),
        rows,
        designs,
        notes,
        checked_against_logs: check == Check::AgainstLogs,
    })
}

impl<K: AnalysedKinds> Tables<K> {
    /// The tables of sessions held in memory (`logs`: each session's
    /// header and records, as a results folder's logs would hold them),
    /// for an analysis that writes and reads no file (power planning). The
    /// rows are the cells the data CSVs would hold, in the order of their
    /// files, so [`analyze_tables`] gives what `analyze` gives for the
    /// same sessions in a folder. `folder` names them in the summary.
    ///
    /// # Errors
    /// A session of a kind without an analysis, or a table polars cannot
    /// make.
    pub fn from_logs(folder: &Path, logs: &[&ReadLog<K>]) -> Result<Tables<K>, Problem> {
        let dir = ResultsDir::new(folder);
        let mut ordered: Vec<(PathBuf, &ReadLog<K>)> = logs
            .iter()
            .map(|l| {
                let h = &l.header;
                (dir.files(&h.protocol_id, &h.participant, h.session).csv, *l)
            })
            .collect();
        ordered.sort_by(|a, b| a.0.cmp(&b.0));
        let analyses = K::analyses();
        let mut by_kind: BTreeMap<&'static str, (AnalysisEntry<K>, Vec<&ReadLog<K>>)> =
            BTreeMap::new();
        for (csv, log) in &ordered {
            let kind = log.header.protocol.kind();
            let Some((name, Some(entry))) = analyses.iter().find(|(k, _)| *k == kind) else {
                return Err(Problem::new(
                    csv.display().to_string(),
                    format!("no analysis for the kind of session '{kind}'"),
                ));
            };
            by_kind
                .entry(name)
                .or_insert((*entry, Vec::new()))
                .1
                .push(log);
        }
        let mut rows = BTreeMap::new();
        for (kind, (entry, logs)) in by_kind {
            let mut columns = needed(kind, &entry);
            columns.extend(entry.optional);
            rows.insert(
                kind,
                rows_of(folder, kind, &columns, &logs, entry.counts_aborted)?,
            );
        }
        Ok(Tables {
            folder: folder.to_owned(),
            rows,
            designs: ordered
                .iter()
                .map(|(_, l)| l.header.protocol.design.clone())
                .collect(),
            notes: Vec::new(),
            checked_against_logs: true,
        })
    }
}

/// The non-practice rows of `logs` (all of kind `kind`), with `columns`,
/// as a CSV scan of their files would give them: the completed ones, and
/// with `keep_aborted` the others apart.
fn rows_of<K: Kinds>(
    folder: &Path,
    kind: &str,
    columns: &[&str],
    logs: &[&ReadLog<K>],
    keep_aborted: bool,
) -> Result<Rows, Problem> {
    let all = crate::results::data_columns::<K>(kind);
    let at: Vec<usize> = columns
        .iter()
        .filter_map(|c| all.iter().position(|a| a == c))
        .collect();
    let col = |name: &str| all.iter().position(|a| *a == name);
    let (status, practice) = (col("status"), col("practice"));
    let mut done: Vec<Vec<Option<String>>> = vec![Vec::new(); at.len()];
    let mut other: Vec<Vec<Option<String>>> = vec![Vec::new(); at.len()];
    for log in logs {
        for r in &log.trials {
            let cells = crate::results::data_cells(&log.header, r);
            let cell = |i: Option<usize>| i.and_then(|i| cells.get(i)).map(String::as_str);
            if cell(practice) != Some("false") {
                continue;
            }
            let target = if cell(status) == Some("completed") {
                &mut done
            } else if keep_aborted {
                &mut other
            } else {
                continue;
            };
            for (j, &i) in at.iter().enumerate() {
                target[j].push(cells.get(i).and_then(|c| unquote(c)));
            }
        }
    }
    let fail = |e: PolarsError| Problem::new(folder.display().to_string(), e.to_string());
    let frame = |cols: Vec<Vec<Option<String>>>| -> Result<DataFrame, Problem> {
        let columns: Vec<Column> = columns
            .iter()
            .zip(cols)
            .map(|(name, v)| Column::new((*name).into(), v))
            .collect();
        DataFrame::new_infer_height(columns).map_err(fail)
    };
    Ok(Rows {
        frame: frame(done)?,
        aborted: if keep_aborted {
            frame(other)?
        } else {
            DataFrame::empty()
        },
        files: Vec::new(),
    })
}

/// A CSV cell's value as a CSV reader gives it: unquoted, and missing
/// when empty.
fn unquote(cell: &str) -> Option<String> {
    if cell.is_empty() {
        None
    } else if cell.len() >= 2 && cell.starts_with('"') && cell.ends_with('"') {
        Some(cell[1..cell.len() - 1].replace("\"\"", "\""))
    } else {
        Some(cell.to_owned())
    }
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

/// Writes `summary.json`, `report.html`, and every table as
/// `tables/<name>.csv` and `tables/<name>.parquet` into `out`, holding a
/// lock on `out` meanwhile: two analyses into one folder write one after
/// the other, so its files are all from one of them (issue 31).
///
/// # Errors
/// An I/O or Parquet error, as (path, message).
pub fn write(analysis: &Analysis, out: &Path) -> Result<(), (String, String)> {
    use crate::results::replace_file;
    let io = |p: &Path| {
        let path = p.display().to_string();
        move |e: crate::results::ResultsError| (path, e.to_string())
    };
    let _held = crate::results::FolderLock::take(out, true).map_err(io(out))?;
    let summary = serde_json::to_string_pretty(&analysis.summary).unwrap_or_default() + "\n";
    let path = out.join("summary.json");
    replace_file(&path, summary.as_bytes(), true).map_err(io(&path))?;
    let path = out.join("report.html");
    replace_file(&path, analysis.html.as_bytes(), true).map_err(io(&path))?;
    for table in &analysis.tables {
        let path = out.join("tables").join(format!("{}.csv", table.name));
        replace_file(&path, table.csv().as_bytes(), true).map_err(io(&path))?;
        let path = out.join("tables").join(format!("{}.parquet", table.name));
        let mut bytes = Vec::new();
        let mut df = table
            .frame()
            .map_err(|e| (path.display().to_string(), e.to_string()))?;
        ParquetWriter::new(&mut bytes)
            .finish(&mut df)
            .map_err(|e| (path.display().to_string(), e.to_string()))?;
        replace_file(&path, &bytes, true).map_err(io(&path))?;
    }
    Ok(())
}
