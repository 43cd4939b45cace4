//! Reading a union tagged by its `kind` key without buffering it.
//!
//! serde's internally tagged enums (`#[serde(tag = "kind")]`) read the
//! whole object into a buffer to find the tag, then read the variant from
//! that buffer: for the `data` of every trial of a log, that buffering was
//! the largest single cost of reading a log. The log writes the tag first,
//! so [`read_tagged`] reads the first key; when it is `kind`, the variant
//! reads the rest of the object straight from the input. An object whose
//! `kind` comes later (a log edited by hand) is read the general way, with
//! the same result and the same errors for a missing or unknown kind.

use std::fmt;

use serde::de::value::MapAccessDeserializer;
use serde::de::{self, DeserializeSeed, MapAccess, Visitor};
use serde_json::Value;

/// The name of the tag key.
const TAG: &str = "kind";

/// Reads an object tagged by its `kind` (one of `names`) from `map`: with
/// `kind` first, `variant` reads the rest of it (given its kind, one of
/// `names`); otherwise the object is buffered and `general` reads
/// it (serde's derived tagged union).
///
/// # Errors
/// Those of the input, a missing `kind`, a kind not among `names`, and
/// those of the variant.
pub(super) fn read_tagged<'de, A, T>(
    mut map: A,
    names: &'static [&'static str],
    variant: impl FnOnce(&'static str, MapAccessDeserializer<A>) -> Result<T, A::Error>,
    general: impl FnOnce(Value) -> Result<T, serde_json::Error>,
) -> Result<T, A::Error>
where
    A: MapAccess<'de>,
{
    match map.next_key_seed(FirstKey)? {
        None => Err(de::Error::missing_field(TAG)),
        Some(None) => {
            let kind = map.next_value_seed(KindName(names))?;
            variant(kind, MapAccessDeserializer::new(map))
        }
        Some(Some(first)) => {
            let mut object = serde_json::Map::new();
            object.insert(first, map.next_value::<Value>()?);
            while let Some((key, value)) = map.next_entry::<String, Value>()? {
                object.insert(key, value);
            }
            general(Value::Object(object)).map_err(de::Error::custom)
        }
    }
}

/// The first key: `None` for the tag, else the key itself.
struct FirstKey;

impl<'de> DeserializeSeed<'de> for FirstKey {
    type Value = Option<String>;

    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        d.deserialize_str(self)
    }
}

impl Visitor<'_> for FirstKey {
    type Value = Option<String>;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("a key")
    }

    fn visit_str<E: de::Error>(self, key: &str) -> Result<Self::Value, E> {
        Ok((key != TAG).then(|| key.to_owned()))
    }
}

/// The tag's value, one of the names.
struct KindName(&'static [&'static str]);

impl<'de> DeserializeSeed<'de> for KindName {
    type Value = &'static str;

    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<&'static str, D::Error> {
        d.deserialize_str(self)
    }
}

impl Visitor<'_> for KindName {
    type Value = &'static str;

    fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("variant identifier")
    }

    fn visit_str<E: de::Error>(self, name: &str) -> Result<&'static str, E> {
        self.0
            .iter()
            .find(|n| **n == name)
            .copied()
            .ok_or_else(|| E::unknown_variant(name, self.0))
    }
}

#[cfg(test)]
mod tests {
    use crate::kinds::{TaggedData, TrialData};

    const FIELDS: &str = r#""display":"tactile","mu_s":0.4,"mu_k":0.30000000000000004,"delta_mu":0.1,"magnitude":2.0674823241307463,"response_time_s":3.2"#;

    fn read(text: &str) -> Result<TrialData, String> {
        serde_json::from_str(text).map_err(|e| e.to_string())
    }

    /// serde's derived tagged union, the way data was read before.
    fn general(text: &str) -> Result<TrialData, String> {
        serde_json::from_str::<TaggedData>(text)
            .map(TrialData::from)
            .map_err(|e| e.to_string())
    }

    #[test]
    fn data_with_its_kind_first_or_last_reads_as_the_derived_union_reads_it() {
        let first = format!(r#"{{"kind":"magnitude_estimation",{FIELDS}}}"#);
        let last = format!(r#"{{{FIELDS},"kind":"magnitude_estimation"}}"#);
        let a = read(&first).unwrap();
        assert_eq!(Ok(a.clone()), general(&first));
        assert_eq!(read(&last), Ok(a.clone()));
        assert_eq!(serde_json::to_string(&a).unwrap(), first);
    }

    #[test]
    fn bad_data_is_refused_with_the_derived_unions_message() {
        for text in [
            format!(r#"{{"kind":"tapping",{FIELDS}}}"#),
            format!("{{{FIELDS}}}"),
            "{}".to_owned(),
            r#"{"kind":3}"#.to_owned(),
            r#"{"kind":"magnitude_estimation","mu_s":0.4}"#.to_owned(),
            format!(r#"{{"kind":"magnitude_estimation",{FIELDS},"mu_s":1}}"#),
            format!(r#"{{"kind":"magnitude_estimation","display":7,{FIELDS}}}"#),
        ] {
            // The message; its line and column are the input's in each.
            let message = |e: String| e.split(" at line").next().unwrap_or_default().to_owned();
            let (ours, derived) = (read(&text), general(&text));
            assert!(derived.is_err(), "{text}");
            assert_eq!(ours.map_err(message), derived.map_err(message), "{text}");
        }
    }
}
