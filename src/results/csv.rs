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
    // Bytes, not chars: this runs for every text cell of every CSV.
    if s.bytes().any(|b| matches!(b, b',' | b'"' | b'\n' | b'\r')) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// A float as written in every CSV (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

/// A float's text on the stack (the longest is 24 bytes).
struct Buf {
    bytes: [u8; 40],
    len: usize,
}

impl Buf {
    fn of(x: f64, exp: bool) -> Option<Buf> {
        use std::fmt::Write as _;
        let mut b = Buf {
            bytes: [0; 40],
            len: 0,
        };
        let r = if exp {
            write!(b, "{x:e}")
        } else {
            write!(b, "{x}")
        };
        r.ok().map(|()| b)
    }
    fn text(&self) -> &str {
        std::str::from_utf8(&self.bytes[..self.len]).unwrap_or("")
    }
}

impl std::fmt::Write for Buf {
    fn write_str(&mut self, s: &str) -> std::fmt::Result {
        let end = self.len + s.len();
        self.bytes
            .get_mut(self.len..end)
            .ok_or(std::fmt::Error)?
            .copy_from_slice(s.as_bytes());
        self.len = end;
        Ok(())
    }
}

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Longer than the buffer (a huge or tiny number): the exponent
        // form is the shorter.
        let Some(plain) = Buf::of(self.0, false) else {
            return write!(f, "{:e}", self.0);
        };
        // The exponent form can be shorter only with two or more zeros
        // after the point (0.001) or three at the end of a whole number
        // (1000); otherwise the plain form is as short or shorter.
        let digits = plain.text().trim_start_matches('-');
        if (digits.starts_with("0.00") || digits.ends_with("000"))
            && let Some(exp) = Buf::of(self.0, true)
            && exp.len < plain.len
        {
            return f.write_str(exp.text());
        }
        f.write_str(plain.text())
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
