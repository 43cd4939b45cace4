//! Data-CSV cells: how a kind's `row` (`protocol::kind::StudyKind::row`)
//! writes text, numbers, missing values and lists.
//!
//! # Numbers
//! Every float in a CSV is written by [`Num`]: the shortest digits that
//! read back to the same `f64`, in plain notation or with an exponent,
//! whichever is shorter (`0.25`, `1e-7`, `-9.706021847767924e-17`, never
//! a 300-digit decimal). A field is at most 24 characters.

/// Text, quoted if it holds `,`, `"` or a line break.
#[must_use]
pub fn text(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// A float as written in every CSV (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let plain = self.0.to_string();
        let exp = format!("{:e}", self.0);
        f.write_str(if exp.len() < plain.len() {
            &exp
        } else {
            &plain
        })
    }
}

/// A float as written in every CSV (module docs).
#[must_use]
pub fn num(x: f64) -> String {
    Num(x).to_string()
}

/// A value, or an empty cell.
#[must_use]
pub fn opt<T: ToString>(x: Option<T>) -> String {
    x.map(|v| v.to_string()).unwrap_or_default()
}

/// A float, or an empty cell.
#[must_use]
pub fn opt_num(x: Option<f64>) -> String {
    x.map(num).unwrap_or_default()
}

/// Numbers, `;`-separated.
#[must_use]
pub fn list(xs: &[f64]) -> String {
    xs.iter().map(|&x| num(x)).collect::<Vec<_>>().join(";")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_float_is_written_in_its_shortest_exact_form() {
        for (x, want) in [
            (0.25, "0.25"),
            (1.0, "1"),
            (0.0, "0"),
            (-0.0, "-0"),
            (1e-7, "1e-7"),
            (0.001, "1e-3"),
            (0.01, "0.01"),
            (5e-324, "5e-324"),
            (-9.706_021_847_767_924e-17, "-9.706021847767924e-17"),
            (123_456.0, "123456"),
            (1e21, "1e21"),
            (f64::MIN_POSITIVE, "2.2250738585072014e-308"),
        ] {
            assert_eq!(num(x), want);
        }
        // Every one reads back exactly, and no field is longer than 24.
        let mut x: f64 = 1.234_567_890_123_456_7e-300;
        while x < 1e300 {
            for y in [x, -x, 1.0 / 3.0 * x] {
                let s = num(y);
                assert_eq!(s.parse::<f64>().unwrap().to_bits(), y.to_bits(), "{s}");
                assert!(s.len() <= 24, "{s}");
            }
            x *= 7.3;
        }
    }
}
