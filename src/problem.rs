//! [`Problem`]: one problem with the user's input, where it is and what is
//! wrong. Every part that checks input (model parameters, protocol files,
//! `--set` overrides, identification data, results folders, the analysis,
//! the command line's flags) reports this one type; the command line (`src/cli/`) prints it as
//! `error: <place>: <message>`.

/// A problem with the input: where and what. Displayed as `place: message`
/// (the command line puts `error: ` before it).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{place}: {message}")]
pub struct Problem {
    /// Where: a flag (`--set mu_s`), a file (with `line:column` or a
    /// column where known), a JSON path in a protocol
    /// (`design.levels[2].width_m`, `$` for the whole document), or a
    /// parameter's field relative to its object (`static_friction.mu_d`).
    pub place: String,
    /// What is wrong, for a person.
    pub message: String,
}

impl Problem {
    /// A problem at `place`.
    #[must_use]
    pub fn new(place: impl Into<String>, message: impl Into<String>) -> Self {
        Problem {
            place: place.into(),
            message: message.into(),
        }
    }

    /// The same problem with `prefix.` put before its place: a field of an
    /// object nested under `prefix`.
    #[must_use]
    pub fn within(mut self, prefix: &str) -> Self {
        self.place = format!("{prefix}.{}", self.place);
        self
    }
}

/// Reads a JSON file into `T`: an unreadable file, or invalid JSON or a
/// mistyped field at its line:column, is a problem naming the file.
///
/// # Errors
/// The problem.
pub fn read_json_file<T: serde::de::DeserializeOwned>(
    path: &std::path::Path,
) -> Result<T, Problem> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path)
        .map_err(|e| Problem::new(&file, format!("cannot read: {e}")))?;
    serde_json::from_str(&text).map_err(|e| {
        Problem::new(
            format!("{file}: {}:{}", e.line(), e.column()),
            e.to_string(),
        )
    })
}
