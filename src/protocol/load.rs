//! Stage 1 of loading a protocol: parse and check, reporting every error with
//! its JSON path and reason.
//!
//! serde alone stops at the first error and loses the path inside internally
//! tagged enums (`design`, `model`), so the loader walks the known structure
//! itself. It checks each object's keys and deserializes each leaf with
//! `serde_path_to_error`. It dispatches the tagged enums by their tag, and
//! then `check.rs` checks the values (ranges, cross-references, zero trials).
//! Pure: [`parse`] takes the file's text, not its path.

use serde::de::DeserializeOwned;
use serde_json::{Map, Value};

use super::kind::Kinds;
use super::{BlockOrder, Condition, Protocol, Randomization};
use crate::friction::Validate;
use crate::friction::{
    DahlParams, GodObjectParams, KarnoppParams, ModelParams, NakanoParams, ViscousParams,
};
use crate::problem::Problem;

/// Parses and checks a protocol.
///
/// # Errors
/// Every problem found, each with its place.
pub fn parse<K: Kinds>(text: &str) -> Result<Protocol<K>, Vec<Problem>> {
    let value: Value = serde_json::from_str(text).map_err(|e| {
        vec![Problem::new(
            format!("{}:{}", e.line(), e.column()),
            e.to_string().split(" at line ").next().unwrap_or_default(),
        )]
    })?;
    let mut w = Walk::default();
    let protocol = w.protocol::<K>(&value);
    match protocol {
        Some(p) if w.errors.is_empty() => {
            super::check::check(&p, &mut w.errors);
            if w.errors.is_empty() {
                Ok(p)
            } else {
                Err(w.errors)
            }
        }
        _ => Err(w.errors),
    }
}

/// Reads and checks a protocol file; returns it with the file's bytes
/// (hashed into session logs). Each error's `place` starts with the file:
/// `<file>: <json path or line:col>`.
///
/// # Errors
/// The file cannot be read or is not UTF-8, or every problem [`parse`] finds.
pub fn read<K: Kinds>(path: &std::path::Path) -> Result<(Protocol<K>, Vec<u8>), Vec<Problem>> {
    let file = path.display().to_string();
    let whole = |message: String| vec![Problem::new(&file, message)];
    let bytes = std::fs::read(path).map_err(|e| whole(format!("cannot read: {e}")))?;
    let text = std::str::from_utf8(&bytes).map_err(|e| whole(format!("not UTF-8 text: {e}")))?;
    let protocol = parse(text).map_err(|errors| {
        errors
            .into_iter()
            .map(|e| Problem::new(format!("{file}: {}", e.place), e.message))
            .collect::<Vec<_>>()
    })?;
    Ok((protocol, bytes))
}

/// The longest id (protocol, condition, participant), in characters. A
/// session's file names hold two ids, and file systems allow 255 bytes a
/// name: a longer id would fail only when its first file is written.
pub const MAX_ID_CHARS: usize = 64;

/// Why `id` is not a valid id (its rules named), or `None`: letters,
/// digits, `-` and `_`, at least one letter or digit, at most
/// [`MAX_ID_CHARS`].
#[must_use]
pub fn id_problem(id: &str) -> Option<String> {
    let chars = id.chars().count();
    if chars > MAX_ID_CHARS {
        let start: String = id.chars().take(16).collect();
        return Some(format!(
            "'{start}...' is {chars} characters long: at most {MAX_ID_CHARS}"
        ));
    }
    let valid = id.chars().any(|c| c.is_ascii_alphanumeric())
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_');
    (!valid).then(|| {
        format!(
            "'{id}': use letters, digits, '-' and '_' (and at least one letter or digit, at most {MAX_ID_CHARS})"
        )
    })
}

/// The walk over a protocol's JSON: each reader takes a value and its JSON
/// path, records every problem it finds, and returns `None` if any part
/// failed. A kind's `read` ([`super::kind::StudyKind::read`]) walks its
/// design with these.
#[derive(Debug, Default)]
pub struct Walk {
    errors: Vec<Problem>,
}

/// Reads the object `v` at `path` into the struct `T`, each field named
/// once: its key is the field's name (or the `as "key"` after it, for a
/// key that is no Rust name), and after it the [`Walk`] method that reads
/// it, with that method's last arguments if it has any (`required`,
/// `model_field`, `optional(default)`, `list(read_each)`,
/// `required_object(read)`, `optional_object(read)`, `with(read)`). Keys that are no field (and
/// not among the `[...]` also allowed, such as a design's `kind`) are
/// refused; every problem is recorded at its JSON path, and the fields are
/// read in the order listed.
///
/// ```ignore
/// read_object!(w, v, path, ["kind"], PairedDesign {
///     reference_s: required,
///     conditions: list(Walk::condition),
/// })
/// ```
macro_rules! read_object {
    ($w:ident, $v:expr, $path:expr, [$($also:literal),* $(,)?], $T:ident {
        $($field:ident $(as $key:literal)?: $how:ident $(($($arg:expr),* $(,)?))?),+ $(,)?
    }) => {{
        let m = $w.object(
            $v,
            $path,
            &[$($also,)* $($crate::protocol::load::key_of!($field $($key)?)),+],
        )?;
        $(let $field = $w.$how(
            m,
            $crate::protocol::load::key_of!($field $($key)?),
            $path $($(, $arg)*)?
        );)+
        Some($T { $($field: $field?),+ })
    }};
}
pub(crate) use read_object;

/// A field's key in [`read_object!`]: its `as "key"`, else its name.
macro_rules! key_of {
    ($field:ident) => {
        stringify!($field)
    };
    ($field:ident $key:literal) => {
        $key
    };
}
pub(crate) use key_of;

/// `path.key` (just `key` at the root `$`).
#[must_use]
pub fn join(path: &str, key: &str) -> String {
    if path == "$" {
        key.to_owned()
    } else {
        format!("{path}.{key}")
    }
}

impl Walk {
    /// Records a problem at `path`.
    pub fn err(&mut self, path: impl Into<String>, message: impl Into<String>) {
        self.errors.push(Problem::new(path, message));
    }

    /// `v` as an object whose keys are all in `known`.
    pub fn object<'v>(
        &mut self,
        v: &'v Value,
        path: &str,
        known: &[&str],
    ) -> Option<&'v Map<String, Value>> {
        let Some(map) = v.as_object() else {
            self.err(path, format!("expected an object, got {}", kind_of(v)));
            return None;
        };
        for key in map.keys() {
            if !known.contains(&key.as_str()) {
                self.err(
                    join(path, key),
                    format!("unknown field; expected one of: {}", known.join(", ")),
                );
            }
        }
        Some(map)
    }

    /// Deserializes `v` (at `path`) as `T`.
    pub fn value<T: DeserializeOwned>(&mut self, v: &Value, path: &str) -> Option<T> {
        match serde_path_to_error::deserialize::<_, T>(v) {
            Ok(t) => Some(t),
            Err(e) => {
                let inner = e.path().to_string();
                let full = if inner == "." || inner.is_empty() {
                    path.to_owned()
                } else if inner.starts_with('[') {
                    format!("{path}{inner}")
                } else {
                    join(path, &inner)
                };
                self.err(full, e.into_inner().to_string());
                None
            }
        }
    }

    /// A required field.
    pub fn required<T: DeserializeOwned>(
        &mut self,
        map: &Map<String, Value>,
        key: &str,
        path: &str,
    ) -> Option<T> {
        if let Some(v) = map.get(key) {
            self.value(v, &join(path, key))
        } else {
            self.err(join(path, key), "missing required field");
            None
        }
    }

    /// An optional field with a default; `None` if present but invalid.
    pub fn optional<T: DeserializeOwned>(
        &mut self,
        map: &Map<String, Value>,
        key: &str,
        path: &str,
        default: T,
    ) -> Option<T> {
        match map.get(key) {
            Some(v) => self.value(v, &join(path, key)),
            None => Some(default),
        }
    }

    /// A required array, each element read by `f`; `None` if any failed.
    pub fn list<T>(
        &mut self,
        map: &Map<String, Value>,
        key: &str,
        path: &str,
        mut f: impl FnMut(&mut Self, &Value, &str) -> Option<T>,
    ) -> Option<Vec<T>> {
        let p = join(path, key);
        let Some(v) = map.get(key) else {
            self.err(p, "missing required field");
            return None;
        };
        let Some(items) = v.as_array() else {
            self.err(p, format!("expected an array, got {}", kind_of(v)));
            return None;
        };
        let out: Vec<Option<T>> = items
            .iter()
            .enumerate()
            .map(|(i, item)| f(self, item, &format!("{p}[{i}]")))
            .collect();
        out.into_iter().collect()
    }

    fn protocol<K: Kinds>(&mut self, v: &Value) -> Option<Protocol<K>> {
        let w = self;
        read_object!(w, v, "$", [], Protocol {
            schema as "$schema": optional(None),
            id: required,
            title: required,
            description: optional(String::new()),
            randomization: optional(Randomization::default()),
            repetitions: optional(1_u32),
            block_order: optional(BlockOrder::default()),
            break_s: optional(0.0_f64),
            instructions: optional(String::new()),
            masking: optional(None),
            design: required_object(K::read_design),
            validation: optional(Vec::new()),
        })
    }

    /// A design whose `kind` is missing or not a registered kind.
    pub fn unknown_kind<K: Kinds>(&mut self, path: &str, kind: Option<&str>) {
        let kinds: Vec<&str> = K::KINDS.iter().map(|k| k.name).collect();
        let message = match kind {
            Some(other) => format!(
                "unknown kind '{other}'; expected one of: {}",
                kinds.join(", ")
            ),
            None => format!("missing; expected one of: {}", kinds.join(", ")),
        };
        self.err(join(path, "kind"), message);
    }

    /// A named rendering `{id, model}`.
    pub fn condition(&mut self, v: &Value, path: &str) -> Option<Condition> {
        let w = self;
        read_object!(
            w,
            v,
            path,
            [],
            Condition {
                id: required,
                model: model_field,
            }
        )
    }

    /// The optional model object under `key`: `Some(None)` when absent,
    /// `None` when present but invalid.
    pub fn optional_model(
        &mut self,
        m: &Map<String, Value>,
        key: &str,
        path: &str,
    ) -> Option<Option<ModelParams>> {
        self.optional_object(m, key, path, Walk::model)
    }

    /// The optional value under `key`, read by `read` (given it and its
    /// path): `Some(None)` when absent, `None` when present but invalid.
    pub fn optional_object<T>(
        &mut self,
        m: &Map<String, Value>,
        key: &str,
        path: &str,
        read: impl FnOnce(&mut Self, &Value, &str) -> Option<T>,
    ) -> Option<Option<T>> {
        match m.get(key) {
            Some(v) => read(self, v, &join(path, key)).map(Some),
            None => Some(None),
        }
    }

    /// The field `key` read by `read`, which is given the whole object (a
    /// field whose rule involves its neighbours' keys).
    pub fn with<T>(
        &mut self,
        m: &Map<String, Value>,
        key: &str,
        path: &str,
        read: impl FnOnce(&mut Self, &Map<String, Value>, &str, &str) -> Option<T>,
    ) -> Option<T> {
        read(self, m, key, path)
    }

    /// The required model object under `key`.
    pub fn model_field(
        &mut self,
        m: &Map<String, Value>,
        key: &str,
        path: &str,
    ) -> Option<ModelParams> {
        self.required_object(m, key, path, Walk::model)
    }

    /// The required value under `key`, read by `read` (given it and its
    /// path).
    pub fn required_object<T>(
        &mut self,
        m: &Map<String, Value>,
        key: &str,
        path: &str,
        read: impl FnOnce(&mut Self, &Value, &str) -> Option<T>,
    ) -> Option<T> {
        let found = self.optional_object(m, key, path, read)?;
        if found.is_none() {
            self.err(join(path, key), "missing required field");
        }
        found
    }

    /// A friction model object, dispatched on its `model` tag, then validated.
    pub fn model(&mut self, v: &Value, path: &str) -> Option<ModelParams> {
        let Some(map) = v.as_object() else {
            self.err(path, format!("expected a model object, got {}", kind_of(v)));
            return None;
        };
        let name = if let Some(Value::String(s)) = map.get("model") {
            s.as_str()
        } else {
            self.err(
                join(path, "model"),
                format!(
                    "missing model name; expected one of: {}",
                    ModelParams::NAMES.join(", ")
                ),
            );
            return None;
        };
        let mut rest = map.clone();
        rest.remove("model");
        let rest = Value::Object(rest);
        let params = match name {
            "god-object-constant" => self
                .value::<GodObjectParams<_>>(&rest, path)
                .map(ModelParams::GodObjectConstant),
            "god-object-time-varying" => self
                .value::<GodObjectParams<_>>(&rest, path)
                .map(ModelParams::GodObjectTimeVarying),
            "stick-slip-tactile" => self
                .value::<NakanoParams>(&rest, path)
                .map(ModelParams::StickSlipTactile),
            "stick-slip-force" => self
                .value::<NakanoParams>(&rest, path)
                .map(ModelParams::StickSlipForce),
            "karnopp" => self
                .value::<KarnoppParams>(&rest, path)
                .map(ModelParams::Karnopp),
            "dahl" => self.value::<DahlParams>(&rest, path).map(ModelParams::Dahl),
            "viscous" => self
                .value::<ViscousParams>(&rest, path)
                .map(ModelParams::Viscous),
            "none" => {
                if let Some(k) = rest.as_object().and_then(|m| m.keys().next()) {
                    self.err(join(path, k), "unknown field; model none has no parameters");
                    None
                } else {
                    Some(ModelParams::None)
                }
            }
            other => {
                self.err(
                    join(path, "model"),
                    format!(
                        "unknown model '{other}'; expected one of: {}",
                        ModelParams::NAMES.join(", ")
                    ),
                );
                None
            }
        }?;
        let errors = params.validate();
        let ok = errors.is_empty();
        for e in errors {
            self.err(join(path, &e.place), e.message);
        }
        ok.then_some(params)
    }
}

fn kind_of(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}
