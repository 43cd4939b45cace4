//! A fast reader for trial lines as the log writes them: compact JSON (no
//! whitespace, no escape in a string), read straight into a serde type.
//!
//! serde_json stays the reader of record. This one reads a strict subset
//! of JSON and gives up on anything else (whitespace, an escape or a
//! control character in a string, a negative integer, an integer beyond
//! 20 digits, a number out of range, deep nesting, a type it does not
//! read, any error of the type itself); the caller then reads the line
//! with serde_json, which gives its value or its error. Where this reader
//! reads a line, it makes the calls serde_json makes on the type's
//! visitors (`visit_borrowed_str`, `visit_u64`, `visit_f64` correctly
//! rounded as serde_json's `float_roundtrip` reads, `visit_none` and
//! `visit_some`, unit variants), so the value is serde_json's: a test
//! holds the two against each other on every trial line of the shipped
//! protocols' logs and on damaged copies of them.
//!
//! Why: reading the logs with serde_json was half of `analyze`'s log
//! check (`docs/guide/speed.md`).

use std::fmt;

use serde::de::value::BorrowedStrDeserializer;
use serde::de::{self, DeserializeSeed, MapAccess, SeqAccess, Visitor};
use serde::forward_to_deserialize_any;

/// Reads `T` from the rest of an object whose opening (`{` and the keys
/// before `from`) the caller has read: `text[from..]` is the object's
/// remaining `"key":value` pairs and its closing `}`, which ends the
/// text. `None`: not read (the caller reads the line with serde_json).
pub(super) fn read_object_rest<'de, T: de::Deserialize<'de>>(
    text: &'de str,
    from: usize,
) -> Option<T> {
    let mut reader = Reader {
        text,
        bytes: text.as_bytes(),
        pos: from,
        depth: 1,
    };
    let value = T::deserialize(ObjectRest(&mut reader)).ok()?;
    (reader.pos == reader.bytes.len()).then_some(value)
}

/// Not read; the caller reads the line with serde_json.
#[derive(Debug)]
pub(super) struct GiveUp;

impl fmt::Display for GiveUp {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("not a compact log line")
    }
}

impl std::error::Error for GiveUp {}

impl de::Error for GiveUp {
    fn custom<T: fmt::Display>(_: T) -> Self {
        GiveUp
    }
}

/// Nesting beyond this gives up (serde_json's own limit is 128).
const MAX_DEPTH: u32 = 100;

/// The text and the place reached in it.
struct Reader<'de> {
    text: &'de str,
    bytes: &'de [u8],
    pos: usize,
    depth: u32,
}

/// A number as serde_json hands it to a visitor.
enum Number {
    U64(u64),
    F64(f64),
}

impl<'de> Reader<'de> {
    fn peek(&self) -> Option<u8> {
        self.bytes.get(self.pos).copied()
    }

    fn eat(&mut self, b: u8) -> Result<(), GiveUp> {
        if self.peek() == Some(b) {
            self.pos += 1;
            Ok(())
        } else {
            Err(GiveUp)
        }
    }

    fn word(&mut self, word: &[u8]) -> Result<(), GiveUp> {
        if self.bytes[self.pos..].starts_with(word) {
            self.pos += word.len();
            Ok(())
        } else {
            Err(GiveUp)
        }
    }

    /// A string without escapes or control characters.
    fn string(&mut self) -> Result<&'de str, GiveUp> {
        self.eat(b'"')?;
        let start = self.pos;
        let len = string_end(&self.bytes[start..]).ok_or(GiveUp)?;
        if self.bytes[start + len] != b'"' {
            return Err(GiveUp);
        }
        self.pos = start + len + 1;
        // Both ends are ASCII quotes: character boundaries.
        Ok(&self.text[start..start + len])
    }

    /// Digits from here on, their number; each taken into `w` (`wide`:
    /// `w` overflowed and no longer holds them).
    fn digits(&mut self, w: &mut u64, wide: &mut bool) -> usize {
        let start = self.pos;
        while let Some(&b) = self.bytes.get(self.pos) {
            if !b.is_ascii_digit() {
                break;
            }
            match w
                .checked_mul(10)
                .and_then(|v| v.checked_add(u64::from(b - b'0')))
            {
                Some(v) => *w = v,
                None => *wide = true,
            }
            self.pos += 1;
        }
        self.pos - start
    }

    /// A number by JSON's grammar: a whole non-negative one as `U64`
    /// (`u64::MAX` at most), one with a fraction or an exponent as `F64`
    /// (finite; not read as 0 from non-zero digits). Its digits are taken
    /// as one whole number `w` on the way: where `w` is at most 2^53 and
    /// the power of ten from 10^-22 to 10^22, `w` times or over that power
    /// is exact in one step, correctly rounded (Clinger's fast path, as in
    /// core's own parser); otherwise core parses the text.
    fn number(&mut self) -> Result<Number, GiveUp> {
        const POWERS: [f64; 23] = [
            1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
            1e16, 1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
        ];
        let start = self.pos;
        let negative = self.peek() == Some(b'-');
        if negative {
            self.pos += 1;
        }
        let (mut w, mut wide) = (0_u64, false);
        match self.peek() {
            Some(b'0') => self.pos += 1,
            Some(b'1'..=b'9') => {
                self.digits(&mut w, &mut wide);
            }
            _ => return Err(GiveUp),
        }
        let (mut float, mut scale, mut far) = (false, 0_i64, false);
        if self.peek() == Some(b'.') {
            self.pos += 1;
            let n = self.digits(&mut w, &mut wide);
            if n == 0 {
                return Err(GiveUp);
            }
            float = true;
            scale = -i64::try_from(n).map_err(|_| GiveUp)?;
        }
        if matches!(self.peek(), Some(b'e' | b'E')) {
            self.pos += 1;
            let sign = match self.peek() {
                Some(b'-') => -1,
                Some(b'+') => 1,
                _ => 0,
            };
            if sign != 0 {
                self.pos += 1;
            }
            let (mut e, mut e_wide) = (0_u64, false);
            let n = self.digits(&mut e, &mut e_wide);
            if n == 0 {
                return Err(GiveUp);
            }
            float = true;
            match i64::try_from(e) {
                Ok(e) if !e_wide && e < 1000 => scale += if sign < 0 { -e } else { e },
                _ => far = true,
            }
        }
        if !float {
            // serde_json reads a negative whole number as i64 (and -0 as
            // a float): left to it.
            return if negative || wide {
                Err(GiveUp)
            } else {
                Ok(Number::U64(w))
            };
        }
        let power = usize::try_from(scale.unsigned_abs())
            .ok()
            .and_then(|i| POWERS.get(i));
        let x = match power {
            Some(&p) if !wide && !far && w <= 1 << 53 => {
                #[allow(clippy::cast_precision_loss, reason = "w <= 2^53: exact")]
                let m = w as f64;
                let x = if scale < 0 { m / p } else { m * p };
                if negative { -x } else { x }
            }
            _ => self.text[start..self.pos].parse().map_err(|_| GiveUp)?,
        };
        if !x.is_finite() || (x == 0.0 && (wide || w != 0)) {
            return Err(GiveUp);
        }
        Ok(Number::F64(x))
    }

    fn visit_number<V: Visitor<'de>>(&mut self, visitor: V) -> Result<V::Value, GiveUp> {
        match self.number()? {
            Number::U64(n) => visitor.visit_u64(n),
            Number::F64(x) => visitor.visit_f64(x),
        }
    }

    fn deeper(&mut self) -> Result<(), GiveUp> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            return Err(GiveUp);
        }
        Ok(())
    }

    fn object<V: Visitor<'de>>(&mut self, visitor: V) -> Result<V::Value, GiveUp> {
        self.eat(b'{')?;
        self.deeper()?;
        let value = visitor.visit_map(Entries {
            reader: self,
            first: true,
        })?;
        self.depth -= 1;
        self.eat(b'}')?;
        Ok(value)
    }

    fn array<V: Visitor<'de>>(&mut self, visitor: V) -> Result<V::Value, GiveUp> {
        self.eat(b'[')?;
        self.deeper()?;
        let value = visitor.visit_seq(Elements {
            reader: self,
            first: true,
        })?;
        self.depth -= 1;
        self.eat(b']')?;
        Ok(value)
    }
}

/// The place of the first `"`, `\\` or control character in `bytes`,
/// eight bytes at a time (bit tricks on a `u64`: a byte's top bit is set
/// where it is one of them).
fn string_end(bytes: &[u8]) -> Option<usize> {
    const ONES: u64 = 0x0101_0101_0101_0101;
    const TOPS: u64 = 0x8080_8080_8080_8080;
    let mut i = 0;
    while let Some(chunk) = bytes.get(i..i + 8) {
        let mut word = [0_u8; 8];
        word.copy_from_slice(chunk);
        let v = u64::from_le_bytes(word);
        let quote = v ^ (ONES * u64::from(b'"'));
        let slash = v ^ (ONES * u64::from(b'\\'));
        // Zero bytes of `quote` and `slash`, bytes below 0x20 of `v`;
        // only the first hit counts (borrows run upward, past it).
        let hits = (quote.wrapping_sub(ONES) & !quote)
            | (slash.wrapping_sub(ONES) & !slash)
            | (v.wrapping_sub(ONES * 0x20) & !v);
        let hits = hits & TOPS;
        if hits != 0 {
            return Some(i + hits.trailing_zeros() as usize / 8);
        }
        i += 8;
    }
    bytes[i..]
        .iter()
        .position(|&b| b == b'"' || b == b'\\' || b < 0x20)
        .map(|k| i + k)
}

/// Methods that read a number as `deserialize_u64` does.
macro_rules! numbers {
    ($($method:ident)*) => {
        $(
            fn $method<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, GiveUp> {
                self.deserialize_u64(visitor)
            }
        )*
    };
}

impl<'de> de::Deserializer<'de> for &mut Reader<'de> {
    type Error = GiveUp;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, GiveUp> {
        match self.peek() {
            Some(b'"') => visitor.visit_borrowed_str(self.string()?),
            Some(b'{') => self.object(visitor),
            Some(b'[') => self.array(visitor),
            Some(b't') => {
                self.word(b"true")?;
                visitor.visit_bool(true)
            }
            Some(b'f') => {
                self.word(b"false")?;
                visitor.visit_bool(false)
            }
            Some(b'n') => {
                self.word(b"null")?;
                visitor.visit_unit()
            }
            Some(b'-' | b'0'..=b'9') => self.visit_number(visitor),
            _ => Err(GiveUp),
        }
    }

    fn deserialize_bool<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, GiveUp> {
        match self.peek() {
            Some(b't' | b'f') => self.deserialize_any(visitor),
            _ => Err(GiveUp),
        }
    }

    fn deserialize_u64<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, GiveUp> {
        match self.peek() {
            Some(b'-' | b'0'..=b'9') => self.visit_number(visitor),
            _ => Err(GiveUp),
        }
    }

    // Every number is read as serde_json reads one (its
    // `deserialize_number`): whatever type asks.
    numbers! {
        deserialize_u8 deserialize_u16 deserialize_u32 deserialize_i8 deserialize_i16
        deserialize_i32 deserialize_i64 deserialize_f32 deserialize_f64
    }

    fn deserialize_str<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, GiveUp> {
        visitor.visit_borrowed_str(self.string()?)
    }

    fn deserialize_string<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, GiveUp> {
        self.deserialize_str(visitor)
    }

    fn deserialize_identifier<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, GiveUp> {
        self.deserialize_str(visitor)
    }

    fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, GiveUp> {
        if self.peek() == Some(b'n') {
            self.word(b"null")?;
            visitor.visit_none()
        } else {
            visitor.visit_some(self)
        }
    }

    fn deserialize_unit<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, GiveUp> {
        self.word(b"null")?;
        visitor.visit_unit()
    }

    fn deserialize_unit_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        visitor: V,
    ) -> Result<V::Value, GiveUp> {
        self.deserialize_unit(visitor)
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(
        self,
        name: &'static str,
        visitor: V,
    ) -> Result<V::Value, GiveUp> {
        // serde_json's raw values are its own business.
        if name.starts_with("$serde_json") {
            return Err(GiveUp);
        }
        visitor.visit_newtype_struct(self)
    }

    fn deserialize_seq<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, GiveUp> {
        self.array(visitor)
    }

    fn deserialize_tuple<V: Visitor<'de>>(
        self,
        _len: usize,
        visitor: V,
    ) -> Result<V::Value, GiveUp> {
        self.array(visitor)
    }

    fn deserialize_tuple_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _len: usize,
        visitor: V,
    ) -> Result<V::Value, GiveUp> {
        self.array(visitor)
    }

    fn deserialize_map<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, GiveUp> {
        self.object(visitor)
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, GiveUp> {
        self.object(visitor)
    }

    /// A unit variant, by its name; a variant with content gives up.
    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value, GiveUp> {
        let name = self.string()?;
        visitor.visit_enum(BorrowedStrDeserializer::<GiveUp>::new(name))
    }

    fn deserialize_char<V: Visitor<'de>>(self, _: V) -> Result<V::Value, GiveUp> {
        Err(GiveUp)
    }

    fn deserialize_bytes<V: Visitor<'de>>(self, _: V) -> Result<V::Value, GiveUp> {
        Err(GiveUp)
    }

    fn deserialize_byte_buf<V: Visitor<'de>>(self, _: V) -> Result<V::Value, GiveUp> {
        Err(GiveUp)
    }

    fn deserialize_ignored_any<V: Visitor<'de>>(self, _: V) -> Result<V::Value, GiveUp> {
        Err(GiveUp)
    }
}

/// An object's entries.
struct Entries<'r, 'de> {
    reader: &'r mut Reader<'de>,
    first: bool,
}

impl<'de> MapAccess<'de> for Entries<'_, 'de> {
    type Error = GiveUp;

    fn next_key_seed<K: DeserializeSeed<'de>>(
        &mut self,
        seed: K,
    ) -> Result<Option<K::Value>, GiveUp> {
        match self.reader.peek() {
            Some(b'}') => return Ok(None),
            Some(b',') if !self.first => self.reader.pos += 1,
            _ if self.first => {}
            _ => return Err(GiveUp),
        }
        self.first = false;
        if self.reader.peek() != Some(b'"') {
            return Err(GiveUp);
        }
        seed.deserialize(Key(&mut *self.reader)).map(Some)
    }

    fn next_value_seed<V: DeserializeSeed<'de>>(&mut self, seed: V) -> Result<V::Value, GiveUp> {
        self.reader.eat(b':')?;
        seed.deserialize(&mut *self.reader)
    }
}

/// An array's elements.
struct Elements<'r, 'de> {
    reader: &'r mut Reader<'de>,
    first: bool,
}

impl<'de> SeqAccess<'de> for Elements<'_, 'de> {
    type Error = GiveUp;

    fn next_element_seed<T: DeserializeSeed<'de>>(
        &mut self,
        seed: T,
    ) -> Result<Option<T::Value>, GiveUp> {
        match self.reader.peek() {
            Some(b']') => return Ok(None),
            Some(b',') if !self.first => self.reader.pos += 1,
            _ if self.first => {}
            _ => return Err(GiveUp),
        }
        self.first = false;
        if self.reader.peek() == Some(b']') {
            return Err(GiveUp);
        }
        seed.deserialize(&mut *self.reader).map(Some)
    }
}

/// A key: read as a string by whatever asks (serde_json reads other
/// kinds of keys out of their strings; here they give up).
struct Key<'r, 'de>(&'r mut Reader<'de>);

impl<'de> de::Deserializer<'de> for Key<'_, 'de> {
    type Error = GiveUp;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, GiveUp> {
        visitor.visit_borrowed_str(self.0.string()?)
    }

    fn deserialize_bool<V: Visitor<'de>>(self, _: V) -> Result<V::Value, GiveUp> {
        Err(GiveUp)
    }

    fn deserialize_option<V: Visitor<'de>>(self, _: V) -> Result<V::Value, GiveUp> {
        Err(GiveUp)
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _: V,
    ) -> Result<V::Value, GiveUp> {
        Err(GiveUp)
    }

    fn deserialize_enum<V: Visitor<'de>>(
        self,
        _name: &'static str,
        _variants: &'static [&'static str],
        _: V,
    ) -> Result<V::Value, GiveUp> {
        Err(GiveUp)
    }

    forward_to_deserialize_any! {
        i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
        bytes byte_buf unit unit_struct seq tuple tuple_struct map struct
        identifier ignored_any
    }
}

/// The rest of an object already opened.
struct ObjectRest<'r, 'de>(&'r mut Reader<'de>);

impl<'de> ObjectRest<'_, 'de> {
    fn entries<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, GiveUp> {
        let value = visitor.visit_map(Entries {
            reader: &mut *self.0,
            first: true,
        })?;
        self.0.eat(b'}')?;
        Ok(value)
    }
}

/// Read as a map, whatever asks (a struct or a map; anything else gives
/// up in its visitor).
impl<'de> de::Deserializer<'de> for ObjectRest<'_, 'de> {
    type Error = GiveUp;

    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value, GiveUp> {
        self.entries(visitor)
    }

    forward_to_deserialize_any! {
        bool i8 i16 i32 i64 i128 u8 u16 u32 u64 u128 f32 f64 char str string
        bytes byte_buf option unit unit_struct newtype_struct seq tuple
        tuple_struct map struct enum identifier ignored_any
    }
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::{Number, Reader, read_object_rest, string_end};
    use crate::kinds::Registry;
    use crate::results::ResultsDir;
    use crate::results::trial::LoggedTrial;
    use crate::session::{Simulation, simulate_participants};

    const TRIAL: &str = r#"{"type":"trial","#;

    /// The record serde_json reads from a trial line (its tag left out,
    /// as `parse_line` does), or its error.
    fn by_serde_json(line: &str) -> Option<LoggedTrial<Registry>> {
        let rest = line.strip_prefix(TRIAL)?;
        serde_json::from_str(&format!("{{{rest}")).ok()
    }

    fn by_compact(line: &str) -> Option<LoggedTrial<Registry>> {
        line.starts_with(TRIAL)
            .then(|| read_object_rest(line, TRIAL.len()))
            .flatten()
    }

    /// The trial lines of one simulated session of each shipped quick
    /// protocol, and of the format 1 logs kept as fixtures; with the LSL
    /// times a session published on LSL adds, on a copy of each.
    fn trial_lines() -> Vec<String> {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
        let dir = tempfile::tempdir().unwrap();
        for name in [
            "magnitude-quick",
            "fitts-quick",
            "paired-quick",
            "discrimination-quick",
        ] {
            let bytes = std::fs::read(root.join(format!("protocols/{name}.json"))).unwrap();
            let protocol =
                crate::protocol::load::parse::<Registry>(std::str::from_utf8(&bytes).unwrap())
                    .unwrap();
            let sim = Simulation {
                protocol: &protocol,
                protocol_bytes: &bytes,
                participants: 1,
                seed: 5,
                pace: None,
                streams: false,
                population: None,
                jobs: 1,
                stop: None,
                lsl: None,
            };
            simulate_participants(&ResultsDir::new(dir.path()), &sim, &|_| {}).unwrap();
        }
        let mut logs: Vec<_> = ["log-v1/magnitude-quick", "log-v1/fitts-quick"]
            .iter()
            .map(|f| root.join("tests/fixtures").join(f))
            .chain([dir.path().to_owned()])
            .flat_map(|d| ResultsDir::new(&d).logs())
            .collect();
        logs.sort();
        let mut lines = Vec::new();
        for log in logs {
            for line in std::fs::read_to_string(log).unwrap().lines() {
                if line.starts_with(TRIAL) {
                    let lsl = format!(
                        "{},\"lsl_start_s\":81234.56789,\"lsl_end_s\":81237.5e0}}",
                        &line[..line.len() - 1]
                    );
                    lines.push(line.to_owned());
                    lines.push(lsl);
                }
            }
        }
        lines
    }

    /// Every trial line the log writes is read by the compact reader, to
    /// serde_json's record; and no damaged copy of a line (a byte left out,
    /// changed or added, at every place) reads to anything serde_json does
    /// not read it to: where serde_json refuses the line or reads it
    /// otherwise, the compact reader gives up.
    #[test]
    fn reads_the_logs_trial_lines_as_serde_json_does_and_gives_up_on_anything_else() {
        let lines = trial_lines();
        let kinds = [
            "magnitude_estimation",
            "fitts",
            "paired_comparison",
            "discrimination",
        ];
        for kind in kinds {
            assert!(
                lines
                    .iter()
                    .any(|l| l.contains(&format!("\"kind\":\"{kind}\""))),
                "{kind}"
            );
        }
        assert!(lines.iter().any(|l| l.contains("\"rendering\"")));
        for line in &lines {
            let want = by_serde_json(line).unwrap_or_else(|| panic!("serde_json: {line}"));
            assert_eq!(by_compact(line).as_ref(), Some(&want), "{line}");
        }
        let edits: &[u8] = b" \"\\-09.e,:}]n\x01";
        let (mut read, mut damaged) = (0, 0);
        // A few lines of each kind, each damaged at every place.
        for line in lines.iter().step_by(17) {
            let b = line.as_bytes();
            for at in TRIAL.len()..=b.len() {
                let mut variants = Vec::new();
                if at < b.len() {
                    variants.push([&b[..at], &b[at + 1..]].concat());
                    for &e in edits {
                        variants.push([&b[..at], &[e], &b[at + 1..]].concat());
                    }
                }
                for &e in edits {
                    variants.push([&b[..at], &[e], &b[at..]].concat());
                }
                for v in variants {
                    let Ok(text) = std::str::from_utf8(&v) else {
                        continue;
                    };
                    damaged += 1;
                    if let Some(got) = by_compact(text) {
                        read += 1;
                        assert_eq!(Some(got), by_serde_json(text), "{text}");
                    }
                }
            }
        }
        assert!(
            damaged > 30_000 && read > 0 && read < damaged / 2,
            "{} lines; {damaged} damaged copies, {read} of them read",
            lines.len()
        );
    }

    /// The string scan eight bytes at a time finds what a byte at a time
    /// finds, in any bytes (UTF-8 ones among them) at any length.
    #[test]
    fn a_strings_end_is_found_as_byte_by_byte() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let alphabet: &[u8] = b"ab\"\\\x00\x1f\x20\x7f\x80\xc3\xa9\xff";
        for _ in 0..200_000 {
            let len = rng.random_range(0..40);
            let bytes: Vec<u8> = (0..len)
                .map(|_| {
                    if rng.random_bool(0.8) {
                        rng.random_range(0x20..0x7f_u8)
                    } else {
                        alphabet[rng.random_range(0..alphabet.len())]
                    }
                })
                .collect();
            let want = bytes
                .iter()
                .position(|&b| b == b'"' || b == b'\\' || b < 0x20);
            assert_eq!(string_end(&bytes), want, "{bytes:?}");
        }
    }

    /// A number with a fraction or an exponent reads to the correctly
    /// rounded double (core's `parse`), by the fast path or not: decimals
    /// of 1 to 20 digits with the point anywhere and exponents near the
    /// fast path's limits, and the shortest text of random doubles.
    #[test]
    fn a_decimal_reads_as_core_parses_it() {
        let mut rng = ChaCha8Rng::seed_from_u64(4);
        for i in 0..400_000 {
            let text = if i % 2 == 0 {
                let digits: String = (0..rng.random_range(1..=20))
                    .map(|_| char::from(b'0' + rng.random_range(0..10_u8)))
                    .collect();
                let digits = digits.trim_start_matches('0');
                let digits = if digits.is_empty() { "0" } else { digits };
                let point = rng.random_range(1..=digits.len());
                let mantissa = format!("{}.{}0", &digits[..point], &digits[point..]);
                let sign = if rng.random_bool(0.2) { "-" } else { "" };
                match rng.random_range(0..3) {
                    0 => format!("{sign}{mantissa}"),
                    1 => format!("{sign}{mantissa}e{}", rng.random_range(-26..=26)),
                    _ => format!("{sign}{}E+{}", &digits, rng.random_range(0..=26)),
                }
            } else {
                let x = f64::from_bits(rng.random::<u64>() >> 2);
                let x = if x.is_finite() { x } else { 1.5 };
                let mut b = zmij::Buffer::new();
                let text = b.format(x).to_owned();
                if text.contains(['.', 'e']) {
                    text
                } else {
                    format!("{text}.0")
                }
            };
            let mut reader = Reader {
                text: &text,
                bytes: text.as_bytes(),
                pos: 0,
                depth: 0,
            };
            let Ok(Number::F64(x)) = reader.number() else {
                panic!("{text} not read");
            };
            assert_eq!(reader.pos, text.len(), "{text}");
            assert_eq!(
                x.to_bits(),
                text.parse::<f64>().unwrap().to_bits(),
                "{text}"
            );
        }
    }
}
