//! Data-CSV cells: how a kind's `row` (`protocol::kind::StudyKind::row`)
//! writes text, missing values and lists.

/// Text, quoted if it holds `,`, `"` or a line break.
#[must_use]
pub fn text(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// A value, or an empty cell.
#[must_use]
pub fn opt<T: ToString>(x: Option<T>) -> String {
    x.map(|v| v.to_string()).unwrap_or_default()
}

/// Numbers, `;`-separated.
#[must_use]
pub fn list(xs: &[f64]) -> String {
    xs.iter().map(f64::to_string).collect::<Vec<_>>().join(";")
}
