//! The analysis of a magnitude estimation's generic form (a `scaling`: one
//! parameter of a model at several levels, issue 35): Stevens' power law
//! `answer = k level^beta`, fitted per participant and across them.
//!
//! Per participant, `beta` is the least-squares slope of ln(answer) on
//! ln(level) over that participant's answers (every repetition): the log
//! scale takes out each participant's modulus, as the power law's fit in
//! Stevens and Guirao (1964) does. The group's exponent is the mean of the
//! participants' with its 95% t interval (participants are the unit of
//! replication). The geometric means per level are modulus-equalized as
//! seed 001's `pooled` means (each answer times the grand geometric mean
//! over that participant's geometric mean), and the slope of their
//! logarithms is reported beside it (`exponent_of_means`).

use serde_json::{Value, json};

use crate::analysis::stats::{linear_fit, log_summary, one_sample_t};
use crate::analysis::{Rows, Table, num, opt, text};
use crate::problem::Problem;

/// One scaling's results.
#[derive(Debug, Clone, PartialEq)]
pub struct ScalingResult {
    /// The display (what was judged).
    pub display: String,
    /// The parameter scaled.
    pub parameter: String,
    /// Each participant's exponent (participant id, beta), in first-seen
    /// order.
    pub exponents: Vec<(String, f64)>,
    /// The mean exponent and its 95% interval (two participants or more).
    pub exponent: Option<(f64, f64, f64)>,
    /// The slope of ln(geometric mean) on ln(level), and its r^2.
    pub exponent_of_means: Option<(f64, f64)>,
    /// The modulus-equalized geometric mean per level.
    pub means: Vec<LevelMean>,
}

/// One level's modulus-equalized geometric mean.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelMean {
    /// The level, in the parameter's units.
    pub level: f64,
    /// The geometric mean of the equalized answers.
    pub value: f64,
    /// Its 95% interval (t on the logarithms), low end.
    pub ci_low: Option<f64>,
    /// Its high end.
    pub ci_high: Option<f64>,
    /// Answers behind it.
    pub n: usize,
}

/// The scalings in `rows` (rows with a `level`), one per display.
///
/// # Errors
/// A magnitude or level that is not a positive number.
pub fn scalings(rows: &Rows) -> Result<Vec<ScalingResult>, Problem> {
    let magnitude = rows.numbers("magnitude")?;
    let level = rows.numbers("level")?;
    for (column, values) in [("magnitude", &magnitude), ("level", &level)] {
        if let Some(i) = values.iter().position(|x| *x <= 0.0) {
            return Err(rows.error(
                column,
                i,
                &format!("{} is not greater than 0 (a power law is fitted on logarithms)", values[i]),
            ));
        }
    }
    let (participant, participants) = rows.codes("participant");
    let (display, displays) = rows.codes("display");
    let mut out = Vec::new();
    for (d, name) in displays.iter().enumerate() {
        let at: Vec<usize> = (0..magnitude.len())
            .filter(|&i| display[i] as usize == d)
            .collect();
        let parameter = at
            .first()
            .map(|&i| rows.text("parameter", i).to_owned())
            .unwrap_or_default();
        out.push(one(&at, &magnitude, &level, &participant, &participants, name, parameter));
    }
    Ok(out)
}

fn one(
    at: &[usize],
    magnitude: &[f64],
    level: &[f64],
    participant: &[u32],
    participants: &[String],
    display: &str,
    parameter: String,
) -> ScalingResult {
    let mut exponents = Vec::new();
    let mut equalized: Vec<(f64, f64)> = Vec::new();
    let grand = at.iter().map(|&i| magnitude[i].ln()).sum::<f64>() / at.len().max(1) as f64;
    for (p, id) in participants.iter().enumerate() {
        let mine: Vec<usize> = at
            .iter()
            .copied()
            .filter(|&i| participant[i] as usize == p)
            .collect();
        if mine.is_empty() {
            continue;
        }
        let points: Vec<(f64, f64)> = mine
            .iter()
            .map(|&i| (level[i].ln(), magnitude[i].ln()))
            .collect();
        if let Some(fit) = linear_fit(&points) {
            exponents.push((id.clone(), fit.slope));
        }
        let own = points.iter().map(|p| p.1).sum::<f64>() / points.len() as f64;
        equalized.extend(points.iter().map(|&(x, y)| (x, y - own + grand)));
    }
    let betas: Vec<f64> = exponents.iter().map(|e| e.1).collect();
    let exponent = one_sample_t(&betas).map(|t| (t.mean, t.ci_low, t.ci_high));
    let mut levels: Vec<f64> = at.iter().map(|&i| level[i]).collect();
    levels.sort_by(f64::total_cmp);
    levels.dedup();
    let means: Vec<_> = levels
        .iter()
        .filter_map(|&l| {
            let ln: Vec<f64> = equalized
                .iter()
                .filter(|(x, _)| *x == l.ln())
                .map(|p| p.1)
                .collect();
            log_summary(&ln).map(|g| LevelMean {
                level: l,
                value: g.value,
                ci_low: g.ci_low,
                ci_high: g.ci_high,
                n: ln.len(),
            })
        })
        .collect();
    let exponent_of_means = linear_fit(
        &means
            .iter()
            .map(|m| (m.level.ln(), m.value.ln()))
            .collect::<Vec<_>>(),
    )
    .map(|f| (f.slope, f.r2));
    ScalingResult {
        display: display.to_owned(),
        parameter,
        exponents,
        exponent,
        exponent_of_means,
        means,
    }
}

/// The `scalings` list of `summary.json`'s `magnitude_estimation`.
#[must_use]
pub fn summary(results: &[ScalingResult]) -> Value {
    results
        .iter()
        .map(|r| {
            json!({
                "display": r.display,
                "parameter": r.parameter,
                "exponent": r.exponent.map(|e| e.0),
                "ci_low": r.exponent.map(|e| e.1),
                "ci_high": r.exponent.map(|e| e.2),
                "n": r.exponents.len(),
                "exponent_of_means": r.exponent_of_means.map(|e| e.0),
                "r2_of_means": r.exponent_of_means.map(|e| e.1),
                "participants": r.exponents.iter().map(|(p, b)| json!({"participant": p, "exponent": b})).collect::<Vec<_>>(),
                "geometric_means": r.means.iter().map(|m| json!({
                    "level": m.level, "value": m.value, "ci_low": m.ci_low,
                    "ci_high": m.ci_high, "n": m.n,
                })).collect::<Vec<_>>(),
            })
        })
        .collect()
}

/// The per-level geometric means and the participants' exponents as tables.
#[must_use]
pub fn tables(results: &[ScalingResult]) -> Vec<Table> {
    let names = |c: &[&str]| c.iter().map(|s| (*s).to_owned()).collect();
    vec![
        Table {
            name: "magnitude_scaling_means".into(),
            columns: names(&["display", "parameter", "level", "value", "ci_low", "ci_high", "n"]),
            rows: results
                .iter()
                .flat_map(|r| {
                    r.means.iter().map(|m| {
                        vec![
                            text(r.display.clone()),
                            text(r.parameter.clone()),
                            num(m.level),
                            num(m.value),
                            opt(m.ci_low),
                            opt(m.ci_high),
                            num(m.n as f64),
                        ]
                    })
                })
                .collect(),
        },
        Table {
            name: "magnitude_scaling_exponents".into(),
            columns: names(&["display", "parameter", "participant", "exponent"]),
            rows: results
                .iter()
                .flat_map(|r| {
                    r.exponents.iter().map(|(p, b)| {
                        vec![
                            text(r.display.clone()),
                            text(r.parameter.clone()),
                            text(p.clone()),
                            num(*b),
                        ]
                    })
                })
                .collect(),
        },
    ]
}
