//! The analysis's files: `summary.json`, `report.html`, and each table as
//! CSV and Parquet (polars' writer).

use std::path::Path;

use polars::prelude::*;

use super::entry::Analysis;
use super::table::{Cell, Table};

impl Table {
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
