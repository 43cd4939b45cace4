//! Each data CSV held against its session log (issue 31): the log is the
//! primary record and the CSV is made from it, so before anything is
//! analysed every CSV row must be the row its log's record gives, once, in
//! the log's order. `analyze` runs this first.
//!
//! Refused, each naming the file, line (and column) and trial: a CSV row
//! doubled, missing, foreign (another study, participant or session) or
//! unlike its log record; a CSV without its log (or a log with trials
//! without its CSV); a log line that is not a whole record, a log without
//! its header, or an empty log. Tolerated, with a notice: the torn last
//! line of a killed session (a last line without its newline: the trials
//! before it are analysed), and a session open in another process (left
//! out: its files are still being written).

use std::path::{Path, PathBuf};

use super::export::DataText;
use super::folder::ResultsDir;
use super::reader::{Record, records};
use super::session_log::{Header, LogLine, ReadLog, parse_log_lines};
use super::{ResultsError, lock};
use crate::problem::Problem;
use crate::protocol::kind::Kinds;

/// The start of the message of a data CSV without its session log (the
/// command line adds how to analyse such data unchecked).
pub const NO_LOG: &str = "no session log";

/// The data CSVs to analyse, each with what was taken from it, and what
/// was found and tolerated.
#[derive(Debug, Clone)]
pub struct Verified<K: Kinds, T> {
    /// The data CSVs, sorted (sessions open elsewhere left out).
    pub files: Vec<Checked<K, T>>,
    /// One line each: a torn last line left out, a session open in another
    /// process left out.
    pub notices: Vec<String>,
}

/// A data CSV that matches its log.
#[derive(Debug, Clone)]
pub struct Checked<K: Kinds, T> {
    /// The data CSV.
    pub csv: PathBuf,
    /// Its log's header.
    pub header: Header<K>,
    /// What the caller took from its rows ([`verify`]'s `take`).
    pub taken: T,
}

/// The rows of a data CSV that matches its log, as [`verify`] hands them
/// to its caller: each file is read once.
#[derive(Debug, Clone, Copy)]
pub enum Source<'a, K: Kinds> {
    /// The CSV is the one its log makes, byte for byte: its rows as the
    /// log gives them, not read again from the CSV.
    Log {
        /// The log.
        read: &'a ReadLog<K>,
        /// The CSV as the log makes it: its columns, and each trial
        /// record's cells as the CSV holds them.
        made: &'a DataText,
    },
    /// The CSV's own records (the column names first), read from `text`:
    /// the log's rows in another notation of the same numbers, or with
    /// columns of its own.
    Csv {
        /// The CSV's text.
        text: &'a str,
        /// Its records.
        records: &'a [Record],
    },
}

/// The data CSVs of `dir` (`data/*_data.csv`), sorted.
#[must_use]
pub fn data_files(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir.join("data"))
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|e| e.path())
                .filter(|p| p.to_string_lossy().ends_with("_data.csv"))
                .collect()
        })
        .unwrap_or_default();
    files.sort();
    files
}

/// Holds every data CSV of `dir` against its session log (module docs),
/// on `jobs` threads, and hands the rows of each that matches to `take`
/// (with the CSV's path), whose answer it keeps; the first problem in file
/// order is returned.
///
/// # Errors
/// The first problem found.
pub fn verify<K: Kinds, T: Send>(
    dir: &Path,
    jobs: usize,
    take: impl Fn(&Path, Source<'_, K>) -> T + Sync,
) -> Result<Verified<K, T>, Problem> {
    let files = data_files(dir);
    let checked = crate::parallel::run(&files, jobs, |csv| check_file::<K, T>(dir, csv, &take));
    let mut out = Verified {
        files: Vec::new(),
        notices: Vec::new(),
    };
    for (csv, result) in files.iter().zip(checked) {
        let (taken, notice) = result?;
        if let Some((header, taken)) = taken {
            out.files.push(Checked {
                csv: csv.clone(),
                header,
                taken,
            });
        }
        out.notices.extend(notice);
    }
    for log in ResultsDir::new(dir).logs() {
        if let Some(problem) = log_without_csv::<K>(dir, &log) {
            return Err(problem);
        }
    }
    Ok(out)
}

/// A log with trials whose data CSV is missing (a session open elsewhere
/// may not have written its CSV yet).
fn log_without_csv<K: Kinds>(dir: &Path, log: &Path) -> Option<Problem> {
    let name = log.file_name()?.to_string_lossy().into_owned();
    let stem = name.strip_suffix("_log.jsonl")?;
    let csv = dir.join("data").join(format!("{stem}_data.csv"));
    if csv.exists() || lock::open_elsewhere(log).is_some() {
        return None;
    }
    let bytes = std::fs::read(log).ok()?;
    let (read, _) = parse_log_lines::<K>(log, &bytes).ok()?;
    (!read.trials.is_empty()).then(|| {
        Problem::new(
            log.display().to_string(),
            format!(
                "its data CSV {} is missing (the log records {} trials)",
                csv.display(),
                read.trials.len()
            ),
        )
    })
}

/// What checking one CSV gives: its header and what `take` took from it
/// (`None`: left out), and a notice.
type FileChecked<K, T> = (Option<(Header<K>, T)>, Option<String>);

/// Checks one CSV and hands its rows to `take`.
fn check_file<K: Kinds, T>(
    dir: &Path,
    csv: &Path,
    take: &(impl Fn(&Path, Source<'_, K>) -> T + Sync),
) -> Result<FileChecked<K, T>, Problem> {
    let name = csv
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let stem = name.strip_suffix("_data.csv").unwrap_or(&name);
    let log = dir.join("logs").join(format!("{stem}_log.jsonl"));
    let at = |place: String, message: String| Problem::new(place, message);
    if !log.is_file() {
        return Err(at(
            csv.display().to_string(),
            format!(
                "{NO_LOG} {} to hold it against (the log is the primary record the CSV is made from)",
                log.display()
            ),
        ));
    }
    if let Some(holder) = lock::open_elsewhere(&log) {
        return Ok((
            None,
            Some(format!(
                "{}: the session is open in another process{}: left out of this analysis; analyse again once it has ended",
                log.display(),
                holder.pid_text()
            )),
        ));
    }
    let bytes = std::fs::read(&log)
        .map_err(|e| at(log.display().to_string(), format!("cannot read: {e}")))?;
    let (read, lines) =
        parse_log_lines::<K>(&log, &bytes).map_err(|e| log_problem::<K>(e, &bytes))?;
    let mut notice = None;
    if read.torn_bytes > 0 {
        let valid = usize::try_from(read.valid_len).unwrap_or(bytes.len());
        // The torn line's number: one more than the lines before it.
        let line = bytes[..valid].split(|&b| b == b'\n').count();
        if bytes.ends_with(b"\n") {
            // A whole line, yet no record: not a write a kill cut short.
            let text = String::from_utf8_lossy(&bytes[valid..]);
            let why = serde_json::from_str::<LogLine<K>>(text.trim_end())
                .err()
                .map_or_else(|| "not a log record".to_owned(), |e| e.to_string());
            return Err(at(
                format!("{}: {line}:1", log.display()),
                format!(
                    "not a whole log record{}: {why}",
                    after(&read, read.trials.len())
                ),
            ));
        }
        notice = Some(format!(
            "{}: {line}:1: a torn last line ({} bytes: the session was stopped mid-write) is left out; the records before it are analysed",
            log.display(),
            read.torn_bytes
        ));
    }
    let h = &read.header;
    let own = ResultsDir::new(dir).files(&h.protocol_id, &h.participant, h.session);
    if own.log != log {
        return Err(at(
            format!("{}: 1:1", log.display()),
            format!(
                "its header is session {} of '{}' in study '{}', whose files are named {}",
                h.session,
                h.participant,
                h.protocol_id,
                own.log
                    .file_name()
                    .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
            ),
        ));
    }
    let text = std::fs::read_to_string(csv)
        .map_err(|e| at(csv.display().to_string(), format!("cannot read: {e}")))?;
    let taken = compare(csv, &log, text, &read, &lines, take)?;
    Ok((Some((read.header, taken)), notice))
}

/// A log's problem with the trial it follows, as a [`Problem`].
fn log_problem<K: Kinds>(e: ResultsError, bytes: &[u8]) -> Problem {
    match e {
        ResultsError::Log {
            path,
            line,
            column,
            message,
        } => {
            // The last trial record before the bad line, for the message.
            let before = bytes
                .split(|&b| b == b'\n')
                .take(line.saturating_sub(1))
                .filter_map(|l| match serde_json::from_slice::<LogLine<K>>(l) {
                    Ok(LogLine::Trial(r)) => Some(r.trial),
                    _ => None,
                })
                .last();
            let after = before
                .map(|t| format!(" (after trial {t}'s record)"))
                .unwrap_or_default();
            Problem::new(
                format!("{path}: {line}:{column}"),
                format!("{message}{after}"),
            )
        }
        other => Problem::new(String::new(), other.to_string()),
    }
}

/// ` (after trial T's record)` for the record before index `i`.
fn after<K: Kinds>(read: &ReadLog<K>, i: usize) -> String {
    i.checked_sub(1)
        .and_then(|k| read.trials.get(k))
        .map(|r| format!(" (after trial {}'s record)", r.trial))
        .unwrap_or_default()
}

/// Two cells alike: the same text, or the same numbers (`;`-separated
/// lists too), whatever their notation.
fn alike(a: &str, b: &str) -> bool {
    a == b
        || (a.split(';').count() == b.split(';').count()
            && a.split(';').zip(b.split(';')).all(|(x, y)| {
                x == y
                    || matches!(
                        (x.trim().parse::<f64>(), y.trim().parse::<f64>()),
                        (Ok(p), Ok(q)) if p == q || (p.is_nan() && q.is_nan())
                    )
            }))
}

/// Holds the CSV `text` against the rows its log gives (module docs),
/// and hands the rows that match to `take`.
fn compare<K: Kinds, T>(
    csv: &Path,
    log: &Path,
    text: String,
    read: &ReadLog<K>,
    lines: &[usize],
    take: &(impl Fn(&Path, Source<'_, K>) -> T + Sync),
) -> Result<T, Problem> {
    // The CSV as its session wrote it, byte for byte: nothing to tell.
    let text = match DataText::matching(read, text) {
        Ok(made) => return Ok(take(csv, Source::Log { read, made: &made })),
        Err(text) => text,
    };
    let text = text.as_str();
    let made = DataText::of(read).text;
    let unreadable = |e: super::reader::ReadError| {
        Problem::new(format!("{}: {}:1", csv.display(), e.line), e.message)
    };
    let actual = records(text, false).map_err(unreadable)?;
    let expected = records(&made, false).map_err(unreadable)?;
    let (Some(head), Some(exp_head)) = (actual.first(), expected.first()) else {
        return Ok(take(
            csv,
            Source::Csv {
                text,
                records: &actual,
            },
        ));
    };
    let names: Vec<&str> = head.cells.iter().collect();
    let held = Held {
        csv,
        log,
        text,
        read,
        lines,
        // The CSV's columns that the log gives, by position in each.
        map: exp_head
            .cells
            .iter()
            .enumerate()
            .filter_map(|(j, name)| names.iter().position(|n| *n == name).map(|i| (i, j)))
            .collect(),
        exp_trial: exp_head.cells.iter().position(|c| c == "trial"),
        names,
    };
    let (body, expected) = (&actual[1..], &expected[1..]);
    let mut next = 0;
    for (k, row) in body.iter().enumerate() {
        held.own(row)?;
        if expected.get(next).is_some_and(|e| held.same(row, e)) {
            next += 1;
            continue;
        }
        return Err(held.unlike(&body[..k], row, &expected[next..], next));
    }
    match read.trials.get(next) {
        None => Ok(take(
            csv,
            Source::Csv {
                text,
                records: &actual,
            },
        )),
        Some(missing) => {
            let more = read.trials.len() - next - 1;
            Err(Problem::new(
                format!(
                    "{}: {}:1",
                    csv.display(),
                    body.last().map_or(1, |r| r.line) + 1
                ),
                format!(
                    "trial {} (log line {}) is missing from the CSV{}{}",
                    missing.trial,
                    lines[next],
                    if more > 0 {
                        format!(", and {more} more after it")
                    } else {
                        String::new()
                    },
                    if read.ended {
                        ""
                    } else {
                        " (a session stopped between a trial's log line and its CSV row: resuming the session rewrites the CSV from the log)"
                    }
                ),
            ))
        }
    }
}

/// A CSV and what its log gives, being compared.
struct Held<'a, K: Kinds> {
    csv: &'a Path,
    log: &'a Path,
    /// The CSV's text.
    text: &'a str,
    read: &'a ReadLog<K>,
    /// Each trial record's log line.
    lines: &'a [usize],
    /// The CSV's column names.
    names: Vec<&'a str>,
    /// (CSV column, log-given column) of each column both have.
    map: Vec<(usize, usize)>,
    /// The log-given CSV's `trial` column.
    exp_trial: Option<usize>,
}

impl<K: Kinds> Held<'_, K> {
    fn col(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| *n == name)
    }

    fn trial(&self, r: &Record) -> String {
        self.col("trial")
            .and_then(|i| r.cell(i))
            .unwrap_or("?")
            .to_owned()
    }

    /// The place of cell `i` of `r`.
    fn place(&self, r: &Record, i: usize) -> String {
        let (line, column) = r.place(self.text, i);
        format!("{}: {line}:{column}", self.csv.display())
    }

    /// The row's cells alike the log-given row's.
    fn same(&self, a: &Record, e: &Record) -> bool {
        self.map
            .iter()
            .all(|&(i, j)| alike(a.cell_or_empty(i), e.cell_or_empty(j)))
    }

    /// The row is of this file's study, participant and session.
    fn own(&self, row: &Record) -> Result<(), Problem> {
        let h = &self.read.header;
        let session = h.session.to_string();
        for (name, own) in [
            ("study", h.protocol_id.as_str()),
            ("participant", h.participant.as_str()),
            ("session", session.as_str()),
        ] {
            let at = self.col(name);
            if let Some(value) = at.and_then(|i| row.cell(i))
                && value != own
            {
                return Err(Problem::new(
                    self.place(row, at.unwrap_or(0)),
                    format!(
                        "trial {}: {name} is '{value}', but this is the CSV of session {} of '{}' in study '{}' (its log {})",
                        self.trial(row),
                        h.session,
                        h.participant,
                        h.protocol_id,
                        self.log.display()
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Why `row` (after the rows `before`) is not the log's next row
    /// (`rest[0]`, record `next`): doubled, preceded by missing rows,
    /// unlike its record, or not in the log.
    fn unlike(&self, before: &[Record], row: &Record, rest: &[Record], next: usize) -> Problem {
        let message = if let Some(first) = before.iter().find(|a| a.cells == row.cells) {
            format!(
                "trial {}: the same row as line {}; its log records it once",
                self.trial(row),
                first.line
            )
        } else if let Some(skip) = rest.iter().position(|e| self.same(row, e)) {
            format!(
                "trial {} (log line {}) is missing from the CSV before this row{}",
                self.read.trials[next].trial,
                self.lines[next],
                if skip > 1 {
                    format!(", and {} more", skip - 1)
                } else {
                    String::new()
                }
            )
        } else if let Some(e) = rest.first()
            && self.exp_trial.and_then(|j| e.cell(j)) == self.col("trial").and_then(|i| row.cell(i))
        {
            let differs = self
                .map
                .iter()
                .find(|&&(i, j)| !alike(row.cell_or_empty(i), e.cell_or_empty(j)));
            let &(i, j) = differs.unwrap_or(&(0, 0));
            return Problem::new(
                self.place(row, i),
                format!(
                    "trial {}: {} is '{}', but its log (line {}) records '{}'",
                    self.trial(row),
                    self.names.get(i).unwrap_or(&"?"),
                    row.cell_or_empty(i),
                    self.lines[next],
                    e.cell_or_empty(j)
                ),
            );
        } else {
            format!(
                "trial {}: this row is not in its log {}{}",
                self.trial(row),
                self.log.display(),
                self.read
                    .trials
                    .get(next)
                    .map(|r| format!(
                        ", whose next record is trial {} (line {})",
                        r.trial, self.lines[next]
                    ))
                    .unwrap_or_default()
            )
        };
        Problem::new(self.place(row, 0), message)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cells_are_alike_in_any_notation_of_the_same_numbers() {
        assert!(alike("0.25", "2.5e-1"));
        assert!(alike("1;2.5", "1.0;2.5"));
        assert!(!alike("1;2", "1;2;3"));
        assert!(!alike("0.25", "0.250001"));
        assert!(!alike("first", "second"));
    }
}
