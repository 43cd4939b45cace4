//! `power.html`: the power curves (power against sample size, the target
//! as a line) and a table of every test's power with its Monte Carlo
//! standard error.

use std::fmt::Write as _;

use serde_json::Value;

use crate::analysis::report::{esc, fmt, line_chart, line_chart_in};

/// Curves per chart at most; a family with more (Fitts per ID) is drawn
/// pooled over IDs only, and the table has them all.
const MAX_SERIES: usize = 10;

/// A test's family (its name without the bracketed selector) and the
/// selector.
fn family(name: &str) -> (String, String) {
    match (name.find('['), name.find(']')) {
        (Some(a), Some(b)) if a < b => (
            format!("{}{}", &name[..a], &name[b + 1..]),
            name[a + 1..b].to_owned(),
        ),
        _ => (name.to_owned(), String::new()),
    }
}

fn points(test: &Value) -> &[Value] {
    test["points"].as_array().map_or(&[], Vec::as_slice)
}

/// The page for a `power.json`.
#[must_use]
pub fn html(power: &Value) -> String {
    let plan = &power["plan"];
    let target = plan["target_power"].as_f64().unwrap_or(0.8);
    let tests = power["tests"].as_array().map_or(&[][..], Vec::as_slice);
    let mut s = String::from(
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>frictionlab power</title><style>\
         body{font-family:sans-serif;margin:2em;max-width:1500px;color:#222}\
         table{border-collapse:collapse;margin:1em 0;font-size:13px}\
         td,th{border:1px solid #bbb;padding:3px 7px;text-align:right}th{background:#eee}td:first-child{text-align:left}\
         .figs{display:flex;flex-wrap:wrap;gap:8px}</style></head><body>",
    );
    let _ = write!(
        s,
        "<h1>Power: {}</h1><p>Protocol <code>{}</code> ({}), {} studies per sample size, seed {}, alpha {}, target power {}, \
         CI widths reach their target at most {} wide. Each study replays every participant on the simulated device and runs \
         the same analysis as <code>frictionlab analyze</code>.</p>",
        esc(plan["protocol"].as_str().unwrap_or("?")),
        esc(plan["protocol"].as_str().unwrap_or("?")),
        esc(plan["kind"].as_str().unwrap_or("?")),
        plan["studies"],
        plan["seed"],
        plan["alpha"],
        plan["target_power"],
        plan["max_ci_width"],
    );
    let xs: Vec<f64> = plan["participants"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(Value::as_f64)
        .collect();
    s.push_str(&charts(tests, &xs, target));
    s.push_str(&table(tests, &xs));
    s.push_str("</body></html>\n");
    s
}

/// The power curves: one chart per family of tests (and the mean width of
/// CI-width statistics).
fn charts(tests: &[Value], xs: &[f64], target: f64) -> String {
    let mut s = String::new();
    // Families in first-seen order, each with its curves.
    let mut families: Vec<(String, Vec<(String, &Value)>)> = Vec::new();
    for t in tests {
        let (fam, sel) = family(t["name"].as_str().unwrap_or("?"));
        match families.iter_mut().find(|(f, _)| *f == fam) {
            Some((_, list)) => list.push((sel, t)),
            None => families.push((fam, vec![(sel, t)])),
        }
    }
    let (x0, x1) = (
        xs.first().copied().unwrap_or(0.0),
        xs.last().copied().unwrap_or(1.0),
    );
    s.push_str("<div class=\"figs\">");
    for (fam, list) in &families {
        let mut list: Vec<&(String, &Value)> = list.iter().collect();
        if list.len() > MAX_SERIES {
            list.retain(|(sel, _)| sel.contains("id_bits=all"));
        }
        let curve = |key: &str| -> Vec<(String, Vec<(f64, f64)>)> {
            list.iter()
                .take(MAX_SERIES)
                .map(|(sel, t)| {
                    let pts = points(t)
                        .iter()
                        .filter_map(|p| Some((p["participants"].as_f64()?, p[key].as_f64()?)))
                        .collect();
                    (
                        if sel.is_empty() {
                            fam.clone()
                        } else {
                            sel.clone()
                        },
                        pts,
                    )
                })
                .collect()
        };
        let is_width = list
            .first()
            .is_some_and(|(_, t)| t["statistic"] == "ci_width");
        let y_label = if is_width {
            "P(width <= max_ci_width)"
        } else {
            "power"
        };
        s.push_str(&line_chart_in(
            fam,
            "participants",
            y_label,
            &curve("power"),
            &[(x0, target, x1, target)],
            0.0..1.05,
        ));
        if is_width {
            s.push_str(&line_chart(
                &format!("{fam}: mean width"),
                "participants",
                "mean CI width",
                &curve("mean_width"),
                &[],
            ));
        }
    }
    s.push_str("</div>");
    s
}

/// Every test's power +- MCSE per sample size, and its smallest size.
fn table(tests: &[Value], xs: &[f64]) -> String {
    let mut s = String::from("<table><tr><th>test</th>");
    for n in xs {
        let _ = write!(s, "<th>n = {n}</th>");
    }
    s.push_str("<th>smallest n</th></tr>");
    for t in tests {
        let _ = write!(s, "<tr><td>{}</td>", esc(t["name"].as_str().unwrap_or("?")));
        for p in points(t) {
            let power = p["power"].as_f64().unwrap_or(f64::NAN);
            let mcse = p["mcse"].as_f64().unwrap_or(f64::NAN);
            let na = p["na"].as_u64().unwrap_or(0);
            let width = p["mean_width"]
                .as_f64()
                .map(|w| format!("; width {}", fmt(w)))
                .unwrap_or_default();
            let na = if na > 0 {
                format!("; {na} n/a")
            } else {
                String::new()
            };
            let _ = write!(
                s,
                "<td>{} &plusmn; {}{width}{na}</td>",
                fmt(power),
                fmt(mcse)
            );
        }
        let _ = write!(
            s,
            "<td>{}</td></tr>",
            t["smallest_n"]
                .as_u64()
                .map_or_else(|| "not reached".to_owned(), |n| n.to_string())
        );
    }
    s.push_str("</table>");
    s
}
