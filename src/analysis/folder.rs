//! Folder reading: a results folder's data, or sessions held in memory,
//! as each kind's [`Rows`] ([`Tables`]).
//!
//! Each file is read once. With the log check (the default), each data
//! CSV is held against its session log ([`crate::results::verify`]), which
//! reads both; a CSV that is its log's byte for byte gets its rows from
//! the log already parsed, any other from the records the check read.
//! Without it, each CSV is read by the one CSV reader
//! ([`crate::results::reader`]). Only the completed, non-practice rows are
//! kept (and, for a kind that counts them, the others apart), with the
//! columns the kind's analysis reads.

use std::borrow::Cow;
use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use super::entry::{AnalysedKinds, AnalysisEntry};
use super::rows::{Frame, Rows};
use crate::problem::Problem;
use crate::protocol::kind::Kinds;
use crate::results::reader::{Record, records};
use crate::results::{
    COMMON_COLUMNS, DataText, ReadLog, ResultsDir, Source, data_files, read_header,
};

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

/// What an analysis reads: each kind's rows (completed, non-practice; the
/// others apart where a kind counts them), the designs of the sessions,
/// and what reading them noticed. Read from a results folder ([`read`]),
/// or made from session records in memory ([`Tables::from_logs`]).
#[derive(Debug)]
pub struct Tables<K: Kinds> {
    pub(super) folder: PathBuf,
    pub(super) rows: BTreeMap<&'static str, Rows>,
    pub(super) designs: Vec<K::Design>,
    pub(super) notes: Vec<String>,
    pub(super) checked_against_logs: bool,
}

/// The kinds that have an analysis, in registry order.
type Analysed<K> = Vec<(&'static str, AnalysisEntry<K>)>;

fn analysed<K: AnalysedKinds>() -> Analysed<K> {
    K::analyses()
        .into_iter()
        .filter_map(|(k, a)| a.map(|a| (k, a)))
        .collect()
}

/// One data file's rows for its kind's analysis: the completed ones and
/// (for a kind that counts them) the others, with the columns the
/// analysis reads that the file has.
#[derive(Debug)]
struct Chunk {
    kind: &'static str,
    done: Frame,
    other: Frame,
}

/// Reads a results folder's data for analysis: each data CSV held against
/// its session log first (unless `check` says [`Check::CsvOnly`]), each
/// file read once, and the logs' designs.
///
/// # Errors
/// Input that cannot be analysed; with [`Check::AgainstLogs`], a CSV
/// unlike its log, or a damaged log.
pub fn read<K: AnalysedKinds>(dir: &Path, check: Check) -> Result<Tables<K>, Problem> {
    let jobs = std::thread::available_parallelism().map_or(1, std::num::NonZero::get);
    let analysed = analysed::<K>();
    let results = ResultsDir::new(dir);
    let mut notes: Vec<String> = Vec::new();
    let (files, chunks, designs) = match check {
        Check::AgainstLogs => {
            let verified = crate::results::verify::<K, _>(dir, jobs, |csv, source| {
                chunk_of_source(&analysed, csv, source)
            })?;
            notes.extend(verified.notices);
            if verified.files.is_empty() && !data_files(dir).is_empty() {
                return Err(Problem::new(
                    dir.display().to_string(),
                    format!(
                        "no data to analyse: every session is open in another process ({})",
                        notes.join("; ")
                    ),
                ));
            }
            // The designs of every log, in the logs' order: those checked
            // from the headers already read, the others (sessions left
            // out, logs without trials) from their first line.
            let mut read: HashMap<PathBuf, &K::Design> = verified
                .files
                .iter()
                .map(|c| {
                    let h = &c.header;
                    let log = results.files(&h.protocol_id, &h.participant, h.session).log;
                    (log, &h.protocol.design)
                })
                .collect();
            let designs: Vec<K::Design> = results
                .logs()
                .iter()
                .filter_map(|log| match read.remove(log) {
                    Some(design) => Some(design.clone()),
                    None => read_header::<K>(log).ok().map(|h| h.protocol.design),
                })
                .collect();
            let (files, chunks): (Vec<PathBuf>, Vec<Result<Chunk, Problem>>) =
                verified.files.into_iter().map(|c| (c.csv, c.taken)).unzip();
            (files, chunks, designs)
        }
        Check::CsvOnly => {
            notes.push(
                "the data CSVs were analysed alone, not held against their session logs (the primary record): edits or damage to them would go unnoticed".to_owned(),
            );
            let files = data_files(dir);
            let chunks = crate::parallel::run(&files, jobs, |csv| {
                let text = std::fs::read_to_string(csv).map_err(|e| {
                    Problem::new(csv.display().to_string(), format!("cannot read: {e}"))
                })?;
                let all = records(&text, true).map_err(|e| {
                    Problem::new(format!("{}: {}:1", csv.display(), e.line), e.message)
                })?;
                Ok::<_, Problem>(chunk_of_records(&analysed, csv, &text, &all))
            })
            .into_iter()
            .collect::<Result<Vec<_>, Problem>>()?;
            let designs = results
                .headers::<K>()
                .into_iter()
                .map(|h| h.protocol.design)
                .collect();
            (files, chunks, designs)
        }
    };
    if files.is_empty() {
        return Err(Problem::new(
            dir.display().to_string(),
            "no data files (expected data/*_data.csv, as written by frictionlab run or simulate)",
        ));
    }
    Ok(Tables {
        folder: dir.to_owned(),
        rows: group::<K>(&analysed, &files, chunks, true)?,
        designs,
        notes,
        checked_against_logs: check == Check::AgainstLogs,
    })
}

/// Each kind's rows from its files' chunks (in file order): the columns
/// the kind's analysis needs, and the optional ones every file of the
/// kind has; `placed`: the rows keep their files, to place a bad value.
fn group<K: Kinds>(
    analysed: &Analysed<K>,
    files: &[PathBuf],
    chunks: Vec<Result<Chunk, Problem>>,
    placed: bool,
) -> Result<BTreeMap<&'static str, Rows>, Problem> {
    let mut by_kind: BTreeMap<&'static str, Vec<(&PathBuf, Chunk)>> = BTreeMap::new();
    for (file, chunk) in files.iter().zip(chunks) {
        let chunk = chunk?;
        by_kind.entry(chunk.kind).or_default().push((file, chunk));
    }
    let mut out = BTreeMap::new();
    for (kind, chunks) in by_kind {
        let Some((_, entry)) = analysed.iter().find(|(k, _)| *k == kind) else {
            continue;
        };
        let mut columns = needed(kind, entry);
        columns.extend(
            entry
                .optional
                .iter()
                .filter(|c| chunks.iter().all(|(_, ch)| ch.done.has(c))),
        );
        let (mut done, mut other) = (Frame::new(&columns), Frame::new(&columns));
        let mut paths = Vec::new();
        for (i, (path, chunk)) in chunks.into_iter().enumerate() {
            done.append(chunk.done, i);
            other.append(chunk.other, i);
            if placed {
                paths.push(path.clone());
            }
        }
        out.insert(kind, Rows::new(done, other, paths));
    }
    Ok(out)
}

/// The rows of a CSV the log check handed over.
fn chunk_of_source<K: Kinds>(
    analysed: &Analysed<K>,
    csv: &Path,
    source: Source<'_, K>,
) -> Result<Chunk, Problem> {
    match source {
        Source::Log { made, .. } => {
            // The CSV is this text: its kind is told as from the file, by
            // the first row's `kind` cell, placed where the file has it.
            let kind = made.columns.iter().position(|c| *c == "kind");
            let first = made.records().next().zip(kind).and_then(|(row, i)| {
                let column: usize = (0..i)
                    .map(|j| row.get(j).map_or(0, |c| c.chars().count()) + 1)
                    .sum();
                Some((unquote(row.get(i)?), (2, column + 1)))
            });
            let first = first.as_ref().map(|(k, at)| (k.as_ref(), *at));
            let (kind, entry) = kind_of(analysed, csv, &made.columns, first)?;
            Ok(chunk_of_made(kind, entry, made, true))
        }
        Source::Csv { text, records } => chunk_of_records(analysed, csv, text, records),
    }
}

/// The rows of a CSV made from its log, for the analysis of `kind`;
/// `numbered`: each row placed by its record number (a file's), else not
/// at all (sessions in memory).
fn chunk_of_made<K: Kinds>(
    kind: &'static str,
    entry: &AnalysisEntry<K>,
    made: &DataText,
    numbered: bool,
) -> Chunk {
    let mut chunk = chunk_for(kind, entry, &made.columns);
    let at = chunk_columns(&chunk, &made.columns);
    for (k, row) in made.records().enumerate() {
        let cell = |i: usize| row.get(i).map_or(Cow::Borrowed(""), unquote);
        chunk.take(
            &at,
            cell,
            entry.counts_aborted,
            if numbered { k + 1 } else { 0 },
        );
    }
    chunk
}

/// The rows of a CSV's `records` (the column names first), read from
/// `text`.
fn chunk_of_records<K: Kinds>(
    analysed: &Analysed<K>,
    csv: &Path,
    text: &str,
    records: &[Record],
) -> Result<Chunk, Problem> {
    let header: Vec<&str> = records
        .first()
        .map(|r| r.cells.iter().collect())
        .unwrap_or_default();
    let first = records.get(1).and_then(|row| {
        let i = header.iter().position(|c| *c == "kind")?;
        Some((row.cell(i)?, row.place(text, i)))
    });
    let (kind, entry) = kind_of(analysed, csv, &header, first)?;
    let mut chunk = chunk_for(kind, entry, &header);
    let at = chunk_columns(&chunk, &header);
    for (k, row) in records.iter().enumerate().skip(1) {
        chunk.take(&at, |i| row.cell_or_empty(i), entry.counts_aborted, k);
    }
    Ok(chunk)
}

/// The kind of a data file with the columns `header`: the first row's
/// `kind` cell (`first`: its text and place), or in a file without rows
/// the first kind whose marker column it has; then every column its
/// analysis needs must be there.
fn kind_of<'a, K: Kinds>(
    analysed: &'a Analysed<K>,
    csv: &Path,
    header: &[&str],
    first: Option<(&str, (usize, usize))>,
) -> Result<(&'static str, &'a AnalysisEntry<K>), Problem> {
    let name = csv.display();
    let has = |c: &str| header.contains(&c);
    let found = match first {
        Some((k, (line, column))) => {
            let Some(found) = analysed.iter().find(|(kind, _)| *kind == k) else {
                return Err(Problem::new(
                    format!("{name}: {line}:{column}"),
                    format!("no analysis for the kind of session '{k}'"),
                ));
            };
            Some(found)
        }
        None => analysed.iter().find(|(_, a)| has(a.marker)),
    };
    let Some((kind, entry)) = found else {
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
    Ok((kind, entry))
}

/// An empty chunk of `kind` with the columns its analysis reads that
/// `header` has.
fn chunk_for<K: Kinds>(kind: &'static str, entry: &AnalysisEntry<K>, header: &[&str]) -> Chunk {
    let mut columns = needed(kind, entry);
    columns.extend(entry.optional.iter().filter(|c| header.contains(c)));
    Chunk {
        kind,
        done: Frame::new(&columns),
        other: Frame::new(&columns),
    }
}

/// Where the chunk's columns, `status` and `practice` are in `header`.
struct At {
    columns: Vec<usize>,
    status: usize,
    practice: usize,
}

fn chunk_columns(chunk: &Chunk, header: &[&str]) -> At {
    let at = |name: &str| header.iter().position(|h| *h == name).unwrap_or(usize::MAX);
    At {
        columns: chunk.done.names().iter().map(|c| at(c)).collect(),
        status: at("status"),
        practice: at("practice"),
    }
}

impl Chunk {
    /// Keeps record `record`, whose cell `i` is `cell(i)`, if it is a
    /// non-practice row: with the completed ones, or (`others`) apart.
    fn take<S: AsRef<str>>(
        &mut self,
        at: &At,
        cell: impl Fn(usize) -> S,
        others: bool,
        record: usize,
    ) {
        if cell(at.practice).as_ref() != "false" {
            return;
        }
        let to = if cell(at.status).as_ref() == "completed" {
            &mut self.done
        } else if others {
            &mut self.other
        } else {
            return;
        };
        to.push(at.columns.iter().map(|&i| cell(i)), 0, record);
    }
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

/// A cell as the CSV holds it (quoted where it must be), as a CSV reader
/// gives it: unquoted.
fn unquote(cell: &str) -> Cow<'_, str> {
    match cell.strip_prefix('"').and_then(|c| c.strip_suffix('"')) {
        Some(inner) => inner.replace("\"\"", "\"").into(),
        None => cell.into(),
    }
}

impl<K: AnalysedKinds> Tables<K> {
    /// The tables of sessions held in memory (`logs`: each session's
    /// header and records, as a results folder's logs would hold them),
    /// for an analysis that writes and reads no file (power planning). The
    /// rows are the cells the data CSVs would hold, in the order of their
    /// files, so [`super::analyze_tables`] gives what `analyze` gives for
    /// the same sessions in a folder. `folder` names them in the summary.
    ///
    /// # Errors
    /// A session of a kind without an analysis.
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
        let analysed = analysed::<K>();
        let mut chunks = Vec::new();
        for (csv, log) in &ordered {
            let kind = log.header.protocol.kind();
            let Some((name, entry)) = analysed.iter().find(|(k, _)| *k == kind) else {
                return Err(Problem::new(
                    csv.display().to_string(),
                    format!("no analysis for the kind of session '{kind}'"),
                ));
            };
            chunks.push(Ok(chunk_of_made(name, entry, &DataText::of(log), false)));
        }
        let files: Vec<PathBuf> = ordered.iter().map(|(csv, _)| csv.clone()).collect();
        Ok(Tables {
            folder: folder.to_owned(),
            // Rows made in memory: no file places them.
            rows: group::<K>(&analysed, &files, chunks, false)?,
            designs: ordered
                .iter()
                .map(|(_, l)| l.header.protocol.design.clone())
                .collect(),
            notes: Vec::new(),
            checked_against_logs: true,
        })
    }
}
