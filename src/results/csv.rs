//! Data-CSV cells: how a kind's `row` (`protocol::kind::StudyKind::row`)
//! writes text, numbers, missing values and lists ([`Row`]).
//!
//! # Numbers
//! Every float in a CSV is written by [`Num`]: the shortest digits that
//! read back to the same `f64`, in plain notation or with an exponent,
//! whichever is shorter (`0.25`, `1e-7`, `-9.706021847767924e-17`, never
//! a 300-digit decimal). A field is at most 24 characters.

use crate::protocol::kind::WriteCells;

/// Text, quoted if it holds `,`, `"` or a line break.
#[must_use]
pub fn text(s: &str) -> String {
    if needs_quotes(s) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_owned()
    }
}

/// Whether a text cell is quoted: it holds `,`, `"` or a line break.
fn needs_quotes(s: &str) -> bool {
    // Bytes, not chars: this runs for every text cell of every CSV.
    s.bytes().any(|b| matches!(b, b',' | b'"' | b'\n' | b'\r'))
}

/// A float as written in every CSV (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Num(pub f64);

/// The longest plain form [`Num`] writes, bytes: a longer one (a huge or
/// tiny number) is written with its exponent, which is then the shorter.
const PLAIN_MAX: usize = 40;

/// A float's text by `core::fmt` (`{}`, or `{:e}` where the module docs
/// say): how every CSV float was written before zmij, and still is where
/// zmij's text may differ ([`Num::with_text`]).
fn by_core_fmt(x: f64) -> String {
    let plain = format!("{x}");
    if plain.len() > PLAIN_MAX {
        return format!("{x:e}");
    }
    // The exponent form can be shorter only with two or more zeros after
    // the point (0.001) or three at the end of a whole number (1000);
    // otherwise the plain form is as short or shorter.
    let digits = plain.trim_start_matches('-');
    if digits.starts_with("0.00") || digits.ends_with("000") {
        let exp = format!("{x:e}");
        if exp.len() < plain.len() {
            return exp;
        }
    }
    plain
}

/// Whether two shortest forms of `x` can be equally near it (a tie, which
/// zmij breaks to the even digit and `core::fmt` upward: 758641930659884.25
/// is `…884.2` by one, `…884.3` by the other). Shortest digits are unique
/// unless `x` is exactly halfway between two of them, which needs its exact
/// decimal value to have at most 18 significant digits: `x = m 2^e` with `m`
/// odd, whose exact decimal is `m 5^-e` (e < 0). Nor can it have 15 or
/// fewer (0.375): two decimals of at most 15 significant digits are at
/// least 1e-15 of their size apart, more than a double's rounding (2^-53
/// of it) bridges, so that exact decimal is the only one of its length
/// that reads back to `x`. A whole number (e >= 0) counts as a possible
/// tie.
fn may_tie(x: f64) -> bool {
    let bits = x.to_bits();
    let biased = i32::try_from((bits >> 52) & 0x7ff).unwrap_or(0);
    let fraction = bits & ((1 << 52) - 1);
    let (m, e) = if biased == 0 {
        (fraction, -1074)
    } else {
        (fraction | (1 << 52), biased - 1075)
    };
    if m == 0 {
        return true;
    }
    let zeros = m.trailing_zeros();
    let (m, e) = (m >> zeros, e + i32::try_from(zeros).unwrap_or(0));
    let Ok(k @ 1..) = u32::try_from(-e) else {
        // A whole number.
        return true;
    };
    POW5.get(k as usize).is_some_and(|&p| {
        (10_u128.pow(15)..10_u128.pow(18)).contains(&(u128::from(m) * u128::from(p)))
    })
}

/// zmij's text of `x` where it is `core::fmt`'s ([`Num::with_text`]): a
/// finite number that cannot tie, in plain notation, not `0.00…`.
fn by_zmij(x: f64, buffer: &mut zmij::Buffer) -> Option<&str> {
    if !x.is_finite() || may_tie(x) {
        return None;
    }
    let text = buffer.format_finite(x);
    (!text.contains('e') && !text.trim_start_matches('-').starts_with("0.00")).then_some(text)
}

/// `5^k` for the exponents [`may_tie`] asks about.
const POW5: [u64; 27] = {
    let mut p = [1_u64; 27];
    let mut k = 1;
    while k < 27 {
        p[k] = p[k - 1] * 5;
        k += 1;
    }
    p
};

impl Num {
    /// Hands the number's text (module docs) to `f`. Most floats data
    /// hold are written as zmij writes them (serde_json's float writer,
    /// already built; several times faster than `core::fmt`: a data CSV of
    /// a million trials, and its log check, make millions): its shortest
    /// digits are `core::fmt`'s but for ties, and its plain notation is
    /// the same for a number with a fraction. The others (exponents,
    /// `0.00…`, whole numbers, possible ties, NaN and infinities) are
    /// written by `core::fmt`, as they always were.
    pub fn with_text<R>(self, f: impl FnOnce(&str) -> R) -> R {
        let mut buffer = zmij::Buffer::new();
        match by_zmij(self.0, &mut buffer) {
            Some(text) => f(text),
            None => f(&by_core_fmt(self.0)),
        }
    }

    /// Appends the number's text to `out`.
    pub fn write_to(self, out: &mut String) {
        self.with_text(|t| out.push_str(t));
    }
}

impl std::fmt::Display for Num {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.with_text(|t| f.write_str(t))
    }
}

/// A float as written in every CSV (module docs).
#[must_use]
pub fn num(x: f64) -> String {
    let mut text = String::with_capacity(24);
    Num(x).write_to(&mut text);
    text
}

/// A record's cells as a kind's `row` writes them
/// ([`crate::protocol::kind::WriteCells`]): end to end into one text, each
/// after a `,` but for a record's first, with where each starts. A
/// million records are written without a string per cell.
#[derive(Debug)]
pub struct Row<'a> {
    text: &'a mut String,
    starts: &'a mut Vec<usize>,
    /// A cell of the record is already written: the next goes after a `,`.
    after: bool,
}

impl<'a> Row<'a> {
    /// Cells written to `text`, each cell's start pushed to `starts`;
    /// `after`: the record has cells before these.
    pub fn new(text: &'a mut String, starts: &'a mut Vec<usize>, after: bool) -> Row<'a> {
        Row {
            text,
            starts,
            after,
        }
    }

    /// Starts a cell (its separator, its start) and returns the text to
    /// write it to.
    pub fn cell(&mut self) -> &mut String {
        if self.after {
            self.text.push(',');
        }
        self.after = true;
        self.starts.push(self.text.len());
        self.text
    }

    /// `;`-separated items, each written by `write`.
    fn joined<T>(&mut self, xs: &[T], write: impl Fn(&T, &mut String)) {
        let out = self.cell();
        for (i, x) in xs.iter().enumerate() {
            if i > 0 {
                out.push(';');
            }
            write(x, out);
        }
    }
}

impl WriteCells for Row<'_> {
    fn text(&mut self, s: &str) {
        let out = self.cell();
        if needs_quotes(s) {
            out.push('"');
            out.push_str(&s.replace('"', "\"\""));
            out.push('"');
        } else {
            out.push_str(s);
        }
    }

    fn opt_text(&mut self, s: Option<&str>) {
        self.cell().push_str(s.unwrap_or_default());
    }

    fn num(&mut self, x: f64) {
        Num(x).write_to(self.cell());
    }

    fn opt_num(&mut self, x: Option<f64>) {
        let out = self.cell();
        if let Some(x) = x {
            Num(x).write_to(out);
        }
    }

    fn whole(&mut self, n: u64) {
        self.cell().push_str(itoa::Buffer::new().format(n));
    }

    fn list(&mut self, xs: &[f64]) {
        self.joined(xs, |&x, out| Num(x).write_to(out));
    }

    fn flags(&mut self, xs: &[bool]) {
        self.joined(xs, |&x, out| out.push_str(if x { "true" } else { "false" }));
    }
}

/// The cells `write` writes to a [`Row`] of their own.
pub fn cells(write: impl FnOnce(&mut Row<'_>)) -> Vec<String> {
    let (mut text, mut starts) = (String::new(), Vec::new());
    write(&mut Row::new(&mut text, &mut starts, false));
    starts.push(text.len() + 1);
    starts
        .windows(2)
        .map(|w| text.get(w[0]..w[1] - 1).unwrap_or_default().to_owned())
        .collect()
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

    #[test]
    fn floats_are_written_as_core_fmt_wrote_them() {
        use rand::{RngExt, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut xs = vec![
            758_641_930_659_884.2,
            0.0,
            -0.0,
            f64::MIN_POSITIVE,
            f64::MAX,
            f64::MIN,
            f64::EPSILON,
            5e-324,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
        ];
        for e in -325..=309 {
            let p = 10_f64.powi(e);
            xs.extend([p, -p, 1.5 * p, 123_456_789.0 * p, p / 3.0]);
        }
        for k in 0..200_000_u64 {
            // Exact binary fractions, whose exact decimals are short
            // (0.375, 1.5e-3 of a metre).
            let j: i32 = rng.random_range(0..=40);
            let i = rng.random_range(1..1_u64 << 20);
            xs.push(i as f64 * 2_f64.powi(-j));
            // Any bit pattern, and the decimals and whole numbers data hold.
            xs.push(f64::from_bits(rng.random::<u64>()));
            xs.push(f64::from(rng.random_range(-1_000_000..1_000_000_i32)) / 1000.0);
            xs.push((k as f64) * 1000.0);
            xs.push(rng.random_range(0.0..20.0));
        }
        let mut fast = 0;
        for x in xs {
            assert_eq!(num(x), by_core_fmt(x), "{x:e} ({:#x})", x.to_bits());
            fast += usize::from(by_zmij(x, &mut zmij::Buffer::new()).is_some());
        }
        // zmij wrote most of them (the others are whole numbers, short
        // decimals, possible ties, exponents and 0.00…).
        assert!(fast > 300_000, "{fast}");
    }
}
