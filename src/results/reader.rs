//! The one CSV reader, shared by the log check ([`super::verify`]) and the
//! analysis: the `csv` crate's records, each with the line and byte where
//! it starts, and the place (`line:column`) of any of its cells, so a
//! message can point at the cell it is about.

/// One record of a CSV text: its cells (unquoted) and where it starts.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Record {
    /// The line it starts on (1-based).
    pub line: usize,
    /// The byte of the text it starts at.
    pub byte: usize,
    /// Its cells, unquoted.
    pub cells: ::csv::StringRecord,
}

impl Record {
    /// Cell `i`, if the record has it.
    #[must_use]
    pub fn cell(&self, i: usize) -> Option<&str> {
        self.cells.get(i)
    }

    /// Cell `i`, or empty if the record is shorter.
    #[must_use]
    pub fn cell_or_empty(&self, i: usize) -> &str {
        self.cells.get(i).unwrap_or("")
    }

    /// Where cell `i` starts in `text` (the text the record was read
    /// from): its line and column (1-based, in characters). A cell past
    /// the record's last is placed at the record's start.
    #[must_use]
    pub fn place(&self, text: &str, i: usize) -> (usize, usize) {
        let raw = text.as_bytes().get(self.byte..).unwrap_or_default();
        let at = self.byte + cell_start(raw, i).unwrap_or(0);
        let before = text.get(self.byte..at).unwrap_or("");
        let line_start = text
            .get(..at)
            .and_then(|t| t.rfind('\n'))
            .map_or(0, |n| n + 1);
        let column = text.get(line_start..at).map_or(0, |t| t.chars().count());
        (self.line + before.matches('\n').count(), column + 1)
    }
}

/// The byte (from the record's start, `raw`) where cell `i` of the
/// record starts, read by the `csv` crate's own parser (`csv-core`), which
/// says how many input bytes each cell took; `None` if the record has no
/// cell `i`.
fn cell_start(raw: &[u8], i: usize) -> Option<usize> {
    let mut reader = csv_core::Reader::new();
    let mut out = [0_u8; 256];
    let (mut at, mut cell) = (0, 0);
    // Each call takes input or ends a cell, so this many calls suffice.
    for _ in 0..=2 * raw.len() + 2 {
        if cell == i {
            return Some(at);
        }
        let (result, taken, _) = reader.read_field(raw.get(at..).unwrap_or_default(), &mut out);
        at += taken;
        match result {
            csv_core::ReadFieldResult::Field { record_end: false } => cell += 1,
            csv_core::ReadFieldResult::Field { record_end: true }
            | csv_core::ReadFieldResult::End => return None,
            csv_core::ReadFieldResult::InputEmpty | csv_core::ReadFieldResult::OutputFull => {}
        }
    }
    None
}

/// A CSV text that cannot be read, at its `line:column`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReadError {
    /// The line (1-based).
    pub line: u64,
    /// What is wrong.
    pub message: String,
}

/// Every record of the CSV `text`, the column names first. With `same_length`
/// a row with more or fewer cells than the column names is an error;
/// without it, such rows are read as they are (the log check says how
/// they differ from their log).
///
/// # Errors
/// A record the `csv` crate cannot read, with its line.
pub fn records(text: &str, same_length: bool) -> Result<Vec<Record>, ReadError> {
    let mut reader = ::csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(!same_length)
        .from_reader(text.as_bytes());
    let mut out = Vec::new();
    let mut cells = ::csv::StringRecord::new();
    loop {
        let start = reader.position().clone();
        match reader.read_record(&mut cells) {
            Ok(false) => return Ok(out),
            Ok(true) => {
                let at = cells.position().unwrap_or(&start);
                let mut line = usize::try_from(at.line()).unwrap_or(usize::MAX);
                let mut byte = usize::try_from(at.byte()).unwrap_or(usize::MAX);
                // The position may be that of blank lines the reader
                // skipped before the record: its own start is after them.
                while let Some(&b) = text.as_bytes().get(byte)
                    && (b == b'\n' || b == b'\r')
                {
                    line += usize::from(b == b'\n');
                    byte += 1;
                }
                out.push(Record {
                    line,
                    byte,
                    cells: cells.clone(),
                });
            }
            Err(e) => return Err(read_error(&e, &start)),
        }
    }
}

/// The `csv` crate's error as a [`ReadError`] (its own position if it has
/// one, else that of the record being read).
fn read_error(e: &::csv::Error, start: &::csv::Position) -> ReadError {
    let (line, message) = match e.kind() {
        ::csv::ErrorKind::UnequalLengths {
            pos,
            expected_len,
            len,
        } => (
            pos.as_ref().map_or(start.line(), ::csv::Position::line),
            format!("a row of {len} cells, but the header names {expected_len} columns"),
        ),
        ::csv::ErrorKind::Utf8 { pos, err } => (
            pos.as_ref().map_or(start.line(), ::csv::Position::line),
            format!("not UTF-8 text: {err}"),
        ),
        _ => (start.line(), e.to_string()),
    };
    ReadError { line, message }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn records_keep_lines_and_columns_through_quotes() {
        let text = "a,b\n\"x,1\",2\n3,\"y\"\"\nz\",w\n\n5,6\n";
        let r = records(text, false).unwrap();
        assert_eq!(r.len(), 4);
        assert_eq!(r[1].line, 2);
        assert_eq!(r[1].cell(0), Some("x,1"));
        assert_eq!(r[1].place(text, 0), (2, 1));
        assert_eq!(r[1].place(text, 1), (2, 7));
        assert_eq!(r[2].cell(1), Some("y\"\nz"));
        assert_eq!(r[2].place(text, 2), (4, 4));
        // A blank line is skipped; the next record keeps its own line.
        assert_eq!((r[3].line, r[3].place(text, 1)), (6, (6, 3)));
        // A cell the record does not have: the record's start.
        assert_eq!(r[3].place(text, 9), (6, 1));
        assert_eq!(r[3].cell_or_empty(9), "");
    }

    #[test]
    fn rows_of_another_length_are_refused_with_their_line_when_asked() {
        let text = "a,b\n1,2\n3\n";
        assert_eq!(records(text, false).unwrap().len(), 3);
        let e = records(text, true).unwrap_err();
        assert_eq!(e.line, 3);
        assert!(e.message.contains("1 cells"), "{}", e.message);
    }
}
