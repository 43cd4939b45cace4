//! The output table model: named columns of text and number cells, as a
//! kind's analysis makes them ([`Table`]), written as CSV here and as
//! Parquet by `output.rs`.

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
}
