//! The files made from the logs: each session's data CSV and the folder's
//! `dataset_description.json`.

use std::collections::BTreeSet;

use super::folder::ResultsDir;
use super::session_log::{ReadLog, read_header};
use super::{ResultsError, replace_file};
use crate::protocol::Kind;
use crate::protocol::engine::TrialData;

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

/// Kind-specific data CSV columns.
#[must_use]
pub fn kind_columns(kind: Kind) -> &'static [&'static str] {
    match kind {
        Kind::PairedComparison => &["first", "second", "choice", "chosen"],
        Kind::MagnitudeEstimation => &[
            "display",
            "mu_s",
            "mu_k",
            "delta_mu",
            "magnitude",
            "response_time_s",
        ],
        Kind::Fitts => &[
            "condition",
            "amplitude_m",
            "width_m",
            "cursor_m",
            "effective_width_m",
            "id_bits",
            "completion_time_s",
            "taps",
            "errors",
            "mean_error_m",
            "tap_times_s",
            "tap_x_m",
            "target_x_m",
            "miss_x_m",
        ],
    }
}

fn csv_text(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

fn opt<T: ToString>(x: Option<T>) -> String {
    x.map(|v| v.to_string()).unwrap_or_default()
}

fn list(xs: &[f64]) -> String {
    xs.iter().map(f64::to_string).collect::<Vec<_>>().join(";")
}

/// The data CSV of a session, from its log. Lists (`tap_x_m`, ...) are
/// `;`-separated; missing values are empty cells.
#[must_use]
pub fn data_csv(log: &ReadLog) -> String {
    let h = &log.header;
    let kind = h.protocol.design.kind();
    let mut out: Vec<&str> = COMMON_COLUMNS.to_vec();
    out.extend_from_slice(kind_columns(kind));
    let mut text = out.join(",");
    text.push('\n');
    for r in &log.trials {
        let mut row = vec![
            csv_text(&h.protocol_id),
            kind.as_str().to_owned(),
            csv_text(&h.participant),
            h.session.to_string(),
            r.trial.to_string(),
            csv_text(&r.block),
            r.status.as_str().to_owned(),
            h.plan_seed.to_string(),
            r.practice.to_string(),
            r.repetition.to_string(),
        ];
        match &r.data {
            TrialData::PairedComparison {
                first,
                second,
                choice,
                chosen,
            } => {
                row.extend([
                    csv_text(first),
                    csv_text(second),
                    opt(choice.map(crate::protocol::engine::Choice::as_str)),
                    opt(chosen.as_deref()),
                ]);
            }
            TrialData::MagnitudeEstimation {
                display,
                mu_s,
                mu_k,
                delta_mu,
                magnitude,
                response_time_s,
            } => row.extend([
                csv_text(display),
                mu_s.to_string(),
                mu_k.to_string(),
                delta_mu.to_string(),
                opt(*magnitude),
                opt(*response_time_s),
            ]),
            TrialData::Fitts {
                condition,
                amplitude_m,
                width_m,
                cursor_m,
                effective_width_m,
                id_bits,
                completion_time_s,
                taps,
                errors,
                mean_error_m,
                tap_times_s,
                tap_x_m,
                target_x_m,
                miss_x_m,
            } => row.extend([
                csv_text(condition),
                amplitude_m.to_string(),
                width_m.to_string(),
                cursor_m.to_string(),
                effective_width_m.to_string(),
                id_bits.to_string(),
                opt(*completion_time_s),
                taps.to_string(),
                errors.to_string(),
                opt(*mean_error_m),
                list(tap_times_s),
                list(tap_x_m),
                list(target_x_m),
                list(miss_x_m),
            ]),
        }
        text.push_str(&row.join(","));
        text.push('\n');
    }
    text
}

/// Writes `dataset_description.json` listing every column of every data file
/// of the kinds present.
///
/// # Errors
/// Any I/O error.
pub fn write_dataset_description(
    dir: &ResultsDir,
    kinds: &BTreeSet<&'static str>,
) -> Result<(), ResultsError> {
    let mut columns: Vec<&str> = COMMON_COLUMNS.to_vec();
    for kind in [
        Kind::PairedComparison,
        Kind::MagnitudeEstimation,
        Kind::Fitts,
    ] {
        if kinds.contains(kind.as_str()) {
            columns.extend(
                kind_columns(kind)
                    .iter()
                    .filter(|c| !columns.contains(c))
                    .collect::<Vec<_>>(),
            );
        }
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
    replace_file(
        &dir.root().join("dataset_description.json"),
        text.as_bytes(),
        true,
    )
}

/// The kinds of every session log in the folder.
#[must_use]
pub fn kinds_present(dir: &ResultsDir) -> BTreeSet<&'static str> {
    dir.logs()
        .iter()
        .filter_map(|p| read_header(p).ok())
        .map(|h| h.protocol.design.kind().as_str())
        .collect()
}
