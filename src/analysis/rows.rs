//! The rows API: a kind's data rows as the data CSVs hold them (every cell
//! text, an empty cell the same as a missing one), read by column name,
//! with numbers parsed on the way out so that a bad value is reported with
//! its file, line and column.

use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::Arc;

use crate::problem::Problem;
use crate::results::reader::records;

/// A column of text cells, stored end to end.
#[derive(Debug, Clone, Default)]
struct Column {
    text: String,
    ends: Vec<usize>,
}

impl Column {
    fn push(&mut self, cell: &str) {
        self.text.push_str(cell);
        self.ends.push(self.text.len());
    }

    fn get(&self, i: usize) -> Option<&str> {
        let end = *self.ends.get(i)?;
        let start = i.checked_sub(1).map_or(0, |k| self.ends[k]);
        self.text.get(start..end)
    }

    fn iter(&self) -> impl Iterator<Item = &str> {
        let mut start = 0;
        self.ends.iter().map(move |&end| {
            let cell = self.text.get(start..end).unwrap_or("");
            start = end;
            cell
        })
    }
}

/// Rows of one piece (in a folder's data, one file's), every column in
/// the order of its frame's names, each row with where it came from.
#[derive(Debug, Clone, Default)]
struct Part {
    columns: Vec<Column>,
    origin: Vec<(u32, u32)>,
}

/// Rows of text cells by column name, each row with where it came from:
/// its file (an index into [`Rows`]' files) and its record in that file
/// (the column names are record 0). The rows are kept in parts as they
/// were read (a file's rows one part): a folder's million rows are put
/// together without a copy.
#[derive(Debug, Clone)]
pub(super) struct Frame {
    names: Vec<&'static str>,
    parts: Vec<Part>,
    /// The row each part starts at, then the number of rows.
    starts: Vec<usize>,
}

impl Default for Frame {
    fn default() -> Frame {
        Frame::new(&[])
    }
}

/// One column of a frame, across its parts.
#[derive(Clone, Copy)]
struct ColumnOf<'a> {
    frame: &'a Frame,
    index: usize,
}

impl<'a> ColumnOf<'a> {
    fn get(self, row: usize) -> Option<&'a str> {
        let (part, i) = self.frame.locate(row)?;
        part.columns.get(self.index)?.get(i)
    }

    /// Its cells in the parts `parts`.
    fn iter_parts(self, parts: std::ops::Range<usize>) -> impl Iterator<Item = &'a str> {
        self.frame
            .parts
            .get(parts)
            .unwrap_or_default()
            .iter()
            .filter_map(move |p| p.columns.get(self.index))
            .flat_map(Column::iter)
    }

    fn iter(self) -> impl Iterator<Item = &'a str> {
        self.frame
            .parts
            .iter()
            .filter_map(move |p| p.columns.get(self.index))
            .flat_map(Column::iter)
    }
}

impl Frame {
    /// An empty frame of the columns `names`.
    pub(super) fn new(names: &[&'static str]) -> Frame {
        Frame {
            names: names.to_vec(),
            parts: Vec::new(),
            starts: vec![0],
        }
    }

    /// Adds a row: one cell per column, from record `record` of file
    /// `file`.
    pub(super) fn push<S: AsRef<str>>(
        &mut self,
        cells: impl IntoIterator<Item = S>,
        file: usize,
        record: usize,
    ) {
        let origin = (
            u32::try_from(file).unwrap_or(u32::MAX),
            u32::try_from(record).unwrap_or(u32::MAX),
        );
        self.push_from(cells, origin);
    }

    /// Adds a row from `origin` (file, record).
    fn push_from<S: AsRef<str>>(&mut self, cells: impl IntoIterator<Item = S>, origin: (u32, u32)) {
        if self.parts.is_empty() {
            self.parts.push(Part {
                columns: vec![Column::default(); self.names.len()],
                origin: Vec::new(),
            });
            self.starts.push(0);
        }
        let Some(part) = self.parts.last_mut() else {
            return;
        };
        for (column, cell) in part.columns.iter_mut().zip(cells) {
            column.push(cell.as_ref());
        }
        part.origin.push(origin);
        if let Some(end) = self.starts.last_mut() {
            *end += 1;
        }
    }

    /// Adds the rows of `other` (which has every column of this frame),
    /// as rows of file `file`: its parts are moved, not copied.
    pub(super) fn append(&mut self, other: Frame, file: usize) {
        let file = u32::try_from(file).unwrap_or(u32::MAX);
        let at: Vec<Option<usize>> = self
            .names
            .iter()
            .map(|n| other.names.iter().position(|o| o == n))
            .collect();
        for mut part in other.parts {
            let rows = part.origin.len();
            if rows == 0 {
                continue;
            }
            let columns = at
                .iter()
                .map(|i| i.map_or_else(Column::default, |i| std::mem::take(&mut part.columns[i])))
                .collect();
            let origin = part
                .origin
                .iter()
                .map(|&(_, record)| (file, record))
                .collect();
            self.parts.push(Part { columns, origin });
            let end = self.height() + rows;
            self.starts.push(end);
        }
    }

    /// Its columns.
    pub(super) fn names(&self) -> &[&'static str] {
        &self.names
    }

    /// Whether it has the column `name`.
    pub(super) fn has(&self, name: &str) -> bool {
        self.names.contains(&name)
    }

    fn height(&self) -> usize {
        self.starts.last().copied().unwrap_or(0)
    }

    /// The part that holds `row`, and the row's index in it.
    fn locate(&self, row: usize) -> Option<(&Part, usize)> {
        if row >= self.height() {
            return None;
        }
        // The last part that starts at or before `row` (parts are never
        // empty, so it holds the row).
        let k = self.starts.partition_point(|&s| s <= row).checked_sub(1)?;
        Some((self.parts.get(k)?, row - self.starts[k]))
    }

    /// Where row `row` came from.
    fn origin(&self, row: usize) -> Option<(u32, u32)> {
        let (part, i) = self.locate(row)?;
        part.origin.get(i).copied()
    }

    /// The parts in up to `n` runs of about as many rows each: each run's
    /// first row and its parts.
    fn runs(&self, n: usize) -> Vec<(usize, std::ops::Range<usize>)> {
        let per = self.height().div_ceil(n.max(1)).max(1);
        let mut runs: Vec<(usize, std::ops::Range<usize>)> = Vec::new();
        for k in 0..self.parts.len() {
            match runs.last_mut() {
                Some((first, parts)) if self.starts[k] - *first < per => parts.end = k + 1,
                _ => runs.push((self.starts[k], k..k + 1)),
            }
        }
        runs
    }

    fn column(&self, name: &str) -> Option<ColumnOf<'_>> {
        let index = self.names.iter().position(|n| *n == name)?;
        Some(ColumnOf { frame: self, index })
    }

    /// The rows where `keep` holds.
    fn filter(self: &Arc<Frame>, keep: &[bool]) -> Arc<Frame> {
        // Every row, or none (a folder of one form): no row by row copy.
        if keep.iter().all(|k| *k) {
            return Arc::clone(self);
        }
        let mut out = Frame::new(&self.names);
        if !keep.contains(&true) {
            return Arc::new(out);
        }
        let columns: Vec<ColumnOf<'_>> = (0..self.names.len())
            .map(|index| ColumnOf { frame: self, index })
            .collect();
        for (row, _) in keep.iter().enumerate().filter(|(_, k)| **k) {
            out.push_from(
                columns.iter().map(|c| c.get(row).unwrap_or("")),
                self.origin(row).unwrap_or((u32::MAX, u32::MAX)),
            );
        }
        Arc::new(out)
    }
}

/// The data rows of one kind (completed, non-practice), and the files
/// they came from (to place a bad value on the error path). Its frames
/// and files are shared: the rows picked from it are, when they are all of
/// them, the same frame, not a copy of a million rows.
#[derive(Debug, Clone, Default)]
pub struct Rows {
    frame: Arc<Frame>,
    /// The non-practice rows that did not complete (aborted, timed out).
    aborted: Arc<Frame>,
    files: Arc<[PathBuf]>,
}

impl Rows {
    /// The rows `frame` (completed) and `aborted` of `files` (empty: rows
    /// made in memory, which no file places).
    pub(super) fn new(frame: Frame, aborted: Frame, files: Vec<PathBuf>) -> Rows {
        Rows {
            frame: Arc::new(frame),
            aborted: Arc::new(aborted),
            files: files.into(),
        }
    }

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
            frame: Arc::clone(&self.aborted),
            aborted: Arc::default(),
            files: Arc::clone(&self.files),
        }
    }

    /// The rows whose `column` is filled (`filled`), or empty or missing
    /// (`!filled`); the rows that did not complete alike.
    #[must_use]
    pub fn where_filled(&self, column: &str, filled: bool) -> Rows {
        let pick = |frame: &Arc<Frame>| {
            let keep: Vec<bool> = match frame.column(column) {
                Some(c) => c.iter().map(|t| t.trim().is_empty() != filled).collect(),
                None => vec![!filled; frame.height()],
            };
            frame.filter(&keep)
        };
        Rows {
            frame: pick(&self.frame),
            aborted: pick(&self.aborted),
            files: Arc::clone(&self.files),
        }
    }

    /// The text of `column` at `row`.
    #[must_use]
    pub fn text(&self, column: &str, row: usize) -> &str {
        self.frame
            .column(column)
            .and_then(|c| c.get(row))
            .unwrap_or("")
    }

    /// Every value of `column` as a number; a column of many rows is
    /// read on every core, in runs of its parts.
    ///
    /// # Errors
    /// The first value that is not a finite number, with its file and line.
    pub fn numbers(&self, column: &str) -> Result<Vec<f64>, Problem> {
        let Some(c) = self.frame.column(column) else {
            return Ok(Vec::new());
        };
        let jobs = if self.len() >= PARALLEL_ROWS {
            std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
        } else {
            1
        };
        let runs = self.frame.runs(jobs);
        let parsed = crate::parallel::run(&runs, jobs, |&(first, ref parts)| {
            let rows = self
                .frame
                .starts
                .get(parts.end)
                .map_or(0, |end| end - first);
            let mut out = Vec::with_capacity(rows);
            for (k, t) in c.iter_parts(parts.clone()).enumerate() {
                match finite(t) {
                    Some(x) => out.push(x),
                    None => return Err((first + k, t)),
                }
            }
            Ok(out)
        });
        let mut out = Vec::with_capacity(self.len());
        for run in parsed {
            match run {
                Ok(xs) => out.extend(xs),
                Err((row, t)) => {
                    return Err(self.error(column, row, &format!("'{t}' is not a finite number")));
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
        let mut index: HashMap<&str, u32> = HashMap::new();
        // The value of the row before and its code: a column such as the
        // participant holds runs of one value.
        let mut last: Option<(&str, u32)> = None;
        let codes = self
            .frame
            .column(column)
            .map(|c| {
                c.iter()
                    .map(|v| match last {
                        Some((l, code)) if l == v => code,
                        _ => {
                            let code = *index.entry(v).or_insert_with(|| {
                                names.push(v.to_owned());
                                u32::try_from(names.len() - 1).unwrap_or(u32::MAX)
                            });
                            last = Some((v, code));
                            code
                        }
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
        finite(t).ok_or_else(|| self.error(column, row, &format!("'{t}' is not a finite number")))
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
            .map(|s| match finite(s) {
                Some(x) => Ok(x),
                None => Err(self.error(
                    column,
                    row,
                    &format!("'{s}' in '{t}' is not a finite number"),
                )),
            })
            .collect()
    }

    /// An error about the value of `column` at `row`, placed at its cell
    /// (`file: line:column`), found by reading its file again, only on
    /// this error path.
    #[must_use]
    pub fn error(&self, column: &str, row: usize, message: &str) -> Problem {
        let message = format!("{column}: {message}");
        let origin = self.frame.origin(row);
        let file = origin.and_then(|(f, _)| self.files.get(usize::try_from(f).ok()?));
        let Some(file) = file.or(self.files.first()) else {
            return Problem::new("", message);
        };
        let place = origin
            .and_then(|(_, record)| cell_place(file, column, usize::try_from(record).ok()?))
            .map_or_else(
                || file.display().to_string(),
                |(line, col)| format!("{}: {line}:{col}", file.display()),
            );
        Problem::new(place, message)
    }
}

/// The rows from which [`Rows::numbers`] reads a column on every core.
const PARALLEL_ROWS: usize = 1 << 17;

/// A cell's finite number (spaces around it allowed), if it is one.
fn finite(t: &str) -> Option<f64> {
    // Most cells have no spaces to trim: a quick look first.
    let bare = t
        .as_bytes()
        .first()
        .zip(t.as_bytes().last())
        .is_some_and(|(a, z)| a.is_ascii_graphic() && z.is_ascii_graphic());
    let t = if bare { t } else { t.trim() };
    t.parse::<f64>().ok().filter(|x| x.is_finite())
}

/// Line and column (1-based) of `column`'s cell in record `record` of the
/// data CSV `file` (its column names are record 0).
fn cell_place(file: &std::path::Path, column: &str, record: usize) -> Option<(usize, usize)> {
    let text = std::fs::read_to_string(file).ok()?;
    let all = records(&text, false).ok()?;
    let i = all.first()?.cells.iter().position(|h| h == column)?;
    Some(all.get(record)?.place(&text, i))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Rows of `level` values (empty for none), with their origins.
    fn frame(levels: &[&str]) -> Frame {
        let mut f = Frame::new(&["trial", "level"]);
        for (k, level) in levels.iter().enumerate() {
            f.push([k.to_string().as_str(), level], 0, k + 1);
        }
        f
    }

    /// Where each row came from.
    fn origins(f: &Frame) -> Vec<(u32, u32)> {
        (0..f.height()).filter_map(|r| f.origin(r)).collect()
    }

    fn rows(frame: Frame) -> Rows {
        Rows::new(frame, Frame::default(), vec![PathBuf::from("a.csv")])
    }

    #[test]
    fn where_filled_keeps_the_rows_asked_for_whole_some_or_none() {
        let trials = |r: &Rows| {
            (0..r.len())
                .map(|i| r.text("trial", i).to_owned())
                .collect::<Vec<_>>()
        };
        let mixed = rows(frame(&["", "2", " ", "4"]));
        assert_eq!(trials(&mixed.where_filled("level", true)), ["1", "3"]);
        assert_eq!(trials(&mixed.where_filled("level", false)), ["0", "2"]);
        let filled = mixed.where_filled("level", true);
        assert_eq!(origins(&filled.frame), [(0, 2), (0, 4)]);
        let all = rows(frame(&["1", "2"]));
        assert_eq!(trials(&all.where_filled("level", true)), ["0", "1"]);
        assert!(all.where_filled("level", false).is_empty());
        assert_eq!(
            all.where_filled("level", false).frame.names(),
            ["trial", "level"]
        );
    }

    #[test]
    fn numbers_of_many_rows_are_read_in_order_and_the_first_bad_one_is_placed() {
        // Two files of more rows together than are read on one core.
        let file = |n: usize, bad: Option<usize>| {
            let mut f = Frame::new(&["trial", "level"]);
            for k in 0..n {
                let level = if Some(k) == bad {
                    "x".to_owned()
                } else {
                    format!(" {}.5", k % 1000)
                };
                f.push([k.to_string().as_str(), level.as_str()], 0, k + 1);
            }
            f
        };
        let n = PARALLEL_ROWS / 2 + 10;
        let rows = |bad: Option<usize>, late: Option<usize>| {
            let mut all = Frame::new(&["trial", "level"]);
            all.append(file(n, bad), 0);
            all.append(file(n, late), 1);
            Rows::new(all, Frame::default(), vec!["a.csv".into(), "b.csv".into()])
        };
        let good = rows(None, None);
        assert!(good.len() >= PARALLEL_ROWS);
        let want: Vec<f64> = (0..2 * n).map(|r| (r % n % 1000) as f64 + 0.5).collect();
        assert_eq!(good.numbers("level").unwrap(), want);
        // A bad cell in the second file's rows: that file's line, whether
        // or not an earlier one is bad too (the earlier is the one told).
        let e = rows(None, Some(7)).numbers("level").unwrap_err();
        assert_eq!(
            (e.place.as_str(), e.message.as_str()),
            ("b.csv", "level: 'x' is not a finite number")
        );
        let e = rows(Some(n - 1), Some(7)).numbers("level").unwrap_err();
        assert_eq!(e.place, "a.csv");
        assert_eq!(finite(" 2.5\t"), Some(2.5));
        assert_eq!(finite("inf"), None);
        assert_eq!(finite(""), None);
    }

    #[test]
    fn appended_frames_keep_every_cell_and_where_it_came_from() {
        let mut all = Frame::new(&["trial", "level"]);
        all.append(frame(&["a", "b"]), 0);
        all.append(frame(&["", "c", "d"]), 1);
        let r = rows(all);
        let cells: Vec<(&str, &str)> = (0..r.len())
            .map(|i| (r.text("trial", i), r.text("level", i)))
            .collect();
        assert_eq!(
            cells,
            [("0", "a"), ("1", "b"), ("0", ""), ("1", "c"), ("2", "d")]
        );
        assert_eq!(origins(&r.frame), [(0, 1), (0, 2), (1, 1), (1, 2), (1, 3)]);
        // Rows picked across the parts, each from its own file and record.
        let filled = r.where_filled("level", true);
        let picked: Vec<&str> = (0..filled.len()).map(|i| filled.text("level", i)).collect();
        assert_eq!(picked, ["a", "b", "c", "d"]);
        assert_eq!(origins(&filled.frame), [(0, 1), (0, 2), (1, 2), (1, 3)]);
        assert_eq!(r.text("level", 5), "");
        // A frame made by default takes rows as one made by name.
        let mut empty = Frame::default();
        empty.push(Vec::<&str>::new(), 3, 7);
        assert_eq!((empty.height(), empty.origin(0)), (1, Some((3, 7))));
    }
}
