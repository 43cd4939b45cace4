//! What the window's protocol builder needs to know of a protocol's form,
//! without naming a kind: the JSON Schema of [`Protocol<K>`] (every field,
//! its doc comment, its default), navigated over the JSON being edited,
//! the kinds' templates for a new protocol, the text a protocol is saved
//! as, and the friction models it holds.
//!
//! A kind describes its form in its own folder: its design's type (fields,
//! doc comments, units in the field names) gives the schema, and
//! [`super::kind::StudyKind::template`] gives a new design. The builder
//! draws whatever the schema holds, so a field added to a kind's design
//! appears in the builder with no change outside the kind's folder.
//!
//! Saved text is pretty JSON with a stable key order: an object's required
//! fields in the order its type declares them, then its optional fields in
//! the schema's (alphabetical) order; `$schema` first when present. The
//! same protocol is always the same text, so saved protocols diff cleanly.

use std::fmt::Write as _;

use serde_json::{Map, Value};

use super::Protocol;
use super::kind::Kinds;
use crate::friction::ModelParams;

/// The schema of the protocols of a set of kinds, to navigate.
#[derive(Debug, Clone)]
pub struct Form {
    schema: Value,
}

impl Form {
    /// The form of `Protocol<K>`.
    #[must_use]
    pub fn of<K: Kinds>() -> Self {
        let schema = schemars::schema_for!(Protocol<K>);
        Form {
            schema: serde_json::to_value(&schema).unwrap_or(Value::Null),
        }
    }

    /// The schema node of the whole protocol.
    #[must_use]
    pub fn root(&self) -> &Value {
        &self.schema
    }

    /// `node` with its `$ref`s followed (`#/$defs/Name`).
    #[must_use]
    pub fn resolve<'a>(&'a self, mut node: &'a Value) -> &'a Value {
        for _ in 0..16 {
            let Some(name) = node
                .get("$ref")
                .and_then(Value::as_str)
                .and_then(|r| r.strip_prefix("#/$defs/"))
            else {
                break;
            };
            match self.schema.get("$defs").and_then(|d| d.get(name)) {
                Some(target) => node = target,
                None => break,
            }
        }
        node
    }

    /// The alternatives of a tagged union, an optional value or a choice
    /// (`oneOf`, `anyOf`), resolved; `None` for any other node.
    #[must_use]
    pub fn alternatives<'a>(&'a self, node: &'a Value) -> Option<Vec<&'a Value>> {
        let node = self.resolve(node);
        let list = node
            .get("oneOf")
            .or_else(|| node.get("anyOf"))?
            .as_array()?;
        Some(list.iter().map(|n| self.resolve(n)).collect())
    }

    /// The fixed strings a node allows (`enum`, or alternatives that are
    /// each a `const` string); `None` for a node that is not a choice.
    #[must_use]
    pub fn choices(&self, node: &Value) -> Option<Vec<String>> {
        let node = self.resolve(node);
        if let Some(list) = node.get("enum").and_then(Value::as_array) {
            return Some(
                list.iter()
                    .filter_map(|v| v.as_str().map(str::to_owned))
                    .collect(),
            );
        }
        let alternatives = self.alternatives(node)?;
        alternatives
            .iter()
            .map(|a| a.get("const").and_then(Value::as_str).map(str::to_owned))
            .collect()
    }

    /// The tag key and value of an alternative of a tagged union (its
    /// property with a `const` string: `kind`, `model`).
    #[must_use]
    pub fn tag<'a>(&'a self, alternative: &'a Value) -> Option<(&'a str, &'a str)> {
        let properties = self.resolve(alternative).get("properties")?.as_object()?;
        properties.iter().find_map(|(key, p)| {
            p.get("const")
                .and_then(Value::as_str)
                .map(|value| (key.as_str(), value))
        })
    }

    /// The alternatives of a tagged union with their tags, or `None` when
    /// `node` is not one.
    #[must_use]
    pub fn tagged<'a>(&'a self, node: &'a Value) -> Option<Vec<(&'a str, &'a str, &'a Value)>> {
        let alternatives = self.alternatives(node)?;
        alternatives
            .into_iter()
            .map(|a| self.tag(a).map(|(k, v)| (k, v, a)))
            .collect::<Option<Vec<_>>>()
            .filter(|v| !v.is_empty())
    }

    /// The schema of `value` where `node` allows several shapes: the
    /// alternative whose tag `value` carries, the non-null one of an
    /// optional value, or `node` itself (resolved).
    #[must_use]
    pub fn pick<'a>(&'a self, node: &'a Value, value: &Value) -> &'a Value {
        let node = self.resolve(node);
        if let Some(tagged) = self.tagged(node) {
            return tagged
                .iter()
                .find(|(key, tag, _)| value.get(*key).and_then(Value::as_str) == Some(*tag))
                .map_or(node, |(_, _, a)| *a);
        }
        if let Some(alternatives) = self.alternatives(node)
            && self.choices(node).is_none()
        {
            let not_null: Vec<_> = alternatives
                .into_iter()
                .filter(|a| a.get("type").and_then(Value::as_str) != Some("null"))
                .collect();
            if not_null.len() == 1 {
                return self.resolve(not_null[0]);
            }
        }
        node
    }

    /// The type a node holds (`object`, `array`, `number`, `integer`,
    /// `string`, `boolean`), nullable types by their other type.
    #[must_use]
    pub fn kind_of<'a>(&self, node: &'a Value) -> Option<&'a str> {
        match node.get("type")? {
            Value::String(t) => Some(t),
            Value::Array(list) => list.iter().filter_map(Value::as_str).find(|t| *t != "null"),
            _ => None,
        }
    }

    /// An object node's properties in form order: the required ones as
    /// the type declares them, then the others (alphabetical).
    #[must_use]
    pub fn fields<'a>(&'a self, node: &'a Value) -> Vec<(&'a str, &'a Value, bool)> {
        let node = self.resolve(node);
        let Some(properties) = node.get("properties").and_then(Value::as_object) else {
            return Vec::new();
        };
        let required: Vec<&str> = node
            .get("required")
            .and_then(Value::as_array)
            .map(|r| r.iter().filter_map(Value::as_str).collect())
            .unwrap_or_default();
        let mut out: Vec<(&str, &Value, bool)> = required
            .iter()
            .filter_map(|k| properties.get_key_value(*k))
            .map(|(k, v)| (k.as_str(), v, true))
            .collect();
        out.extend(
            properties
                .iter()
                .filter(|(k, _)| !required.contains(&k.as_str()))
                .map(|(k, v)| (k.as_str(), v, false)),
        );
        if let Some(at) = out.iter().position(|(k, _, _)| *k == "$schema") {
            let schema = out.remove(at);
            out.insert(0, schema);
        }
        out
    }

    /// A new value for `node`: its default, else the smallest value of
    /// its type (an object with its required fields, the first choice or
    /// the first alternative of a union).
    #[must_use]
    pub fn new_value(&self, node: &Value) -> Value {
        if let Some(default) = node.get("default") {
            return default.clone();
        }
        let node = self.resolve(node);
        if let Some(default) = node.get("default") {
            return default.clone();
        }
        if let Some(c) = node.get("const") {
            return c.clone();
        }
        if let Some(first) = self.choices(node).and_then(|c| c.into_iter().next()) {
            return Value::String(first);
        }
        if let Some(first) = self.alternatives(node).and_then(|a| {
            a.into_iter()
                .find(|n| n.get("type").and_then(Value::as_str) != Some("null"))
        }) {
            return self.new_value(first);
        }
        match self.kind_of(node) {
            Some("object") => Value::Object(
                self.fields(node)
                    .into_iter()
                    .filter(|(_, _, required)| *required)
                    .map(|(k, n, _)| (k.to_owned(), self.new_value(n)))
                    .collect(),
            ),
            Some("array") => {
                let items = node.get("items").unwrap_or(&Value::Null);
                let n = node.get("minItems").and_then(Value::as_u64).unwrap_or(0);
                Value::Array((0..n).map(|_| self.new_value(items)).collect())
            }
            Some("number" | "integer") => Value::from(0),
            Some("string") => Value::String(String::new()),
            Some("boolean") => Value::Bool(false),
            _ => Value::Null,
        }
    }

    /// The alternative of a tagged union `node` with tag `tag`, as a new
    /// value: the kind's template for a design, a model's seed defaults,
    /// else its required fields.
    #[must_use]
    pub fn new_alternative<K: Kinds>(&self, node: &Value, tag: &str) -> Option<Value> {
        let (key, _, alternative) = self
            .tagged(node)?
            .into_iter()
            .find(|(_, value, _)| *value == tag)?;
        if key == "kind"
            && let Some(design) = K::template(tag)
        {
            return Some(design);
        }
        if key == "model"
            && let Some(model) = ModelParams::default_for(tag)
        {
            return serde_json::to_value(model).ok();
        }
        let mut value = self.new_value(alternative);
        if let Value::Object(m) = &mut value {
            m.insert(key.to_owned(), Value::String(tag.to_owned()));
        }
        Some(value)
    }

    /// A protocol's text as saved: pretty JSON in form order (see the
    /// module docs), ending in a newline.
    #[must_use]
    pub fn text(&self, value: &Value) -> String {
        let mut out = String::new();
        self.write(&mut out, value, self.root(), 0);
        out.push('\n');
        out
    }

    fn write(&self, out: &mut String, value: &Value, node: &Value, depth: usize) {
        let pad = |out: &mut String, depth: usize| out.push_str(&"  ".repeat(depth));
        match value {
            Value::Object(map) if !map.is_empty() => {
                let node = self.pick(node, value);
                let order = self.ordered(map, node);
                out.push_str("{\n");
                for (i, (key, child_node)) in order.iter().enumerate() {
                    pad(out, depth + 1);
                    let _ = write!(out, "{}: ", Value::String((*key).to_owned()));
                    self.write(out, &map[*key], child_node, depth + 1);
                    out.push_str(if i + 1 < order.len() { ",\n" } else { "\n" });
                }
                pad(out, depth);
                out.push('}');
            }
            Value::Array(list) if !list.is_empty() => {
                let node = self.pick(node, value);
                let items = node.get("items").unwrap_or(&Value::Null);
                out.push_str("[\n");
                for (i, item) in list.iter().enumerate() {
                    pad(out, depth + 1);
                    self.write(out, item, items, depth + 1);
                    out.push_str(if i + 1 < list.len() { ",\n" } else { "\n" });
                }
                pad(out, depth);
                out.push(']');
            }
            other => out.push_str(&other.to_string()),
        }
    }

    /// The keys of `map` in form order, each with its schema node.
    fn ordered<'a>(
        &'a self,
        map: &'a Map<String, Value>,
        node: &'a Value,
    ) -> Vec<(&'a str, &'a Value)> {
        let mut order: Vec<(&str, &Value)> = self
            .fields(node)
            .into_iter()
            .filter(|(k, _, _)| map.contains_key(*k))
            .map(|(k, n, _)| (k, n))
            .collect();
        // Keys the schema does not know (validate names them) keep their
        // place at the end.
        let unknown: Vec<(&str, &Value)> = map
            .keys()
            .filter(|k| !order.iter().any(|(o, _)| o == k))
            .map(|k| (k.as_str(), &Value::Null))
            .collect();
        order.extend(unknown);
        order
    }
}

/// A new protocol of the kind named `kind`: the kind's template under the
/// common fields (`None` for a kind the set does not have).
#[must_use]
pub fn new_protocol<K: Kinds>(kind: &str) -> Option<Value> {
    let design = K::template(kind)?;
    let id = format!("new-{}", kind.replace('_', "-"));
    Some(serde_json::json!({
        "id": id,
        "title": format!("New {} study", kind.replace('_', " ")),
        "description": "",
        "randomization": "random",
        "repetitions": 1,
        "block_order": "fixed",
        "break_s": 0.0,
        "instructions": "",
        "design": design,
    }))
}

/// The unit of a field named with an SI suffix (`exploration_s`: s,
/// `damping_n_s_m`: N s/m), for the form's labels.
#[must_use]
pub fn unit(key: &str) -> Option<&'static str> {
    const UNITS: &[(&str, &str)] = &[
        ("_n_s_m", "N s/m"),
        ("_n_m", "N/m"),
        ("_m_s", "m/s"),
        ("_rad_m", "rad/m"),
        ("_per_s", "1/s"),
        ("_per_n", "1/N"),
        ("_kg", "kg"),
        ("_hz", "Hz"),
        ("_s", "s"),
        ("_m", "m"),
        ("_n", "N"),
    ];
    if key.starts_with("mu_") {
        // Friction coefficients (mu_s, mu_k, mu_d) are ratios.
        return None;
    }
    UNITS
        .iter()
        .find(|(suffix, _)| key.ends_with(suffix))
        .map(|(_, unit)| *unit)
}

/// Every friction model a protocol (as JSON) holds, readable as one:
/// each with a label (its condition's id, or its JSON path) and its JSON
/// path, in document order.
#[must_use]
pub fn models(value: &Value) -> Vec<(String, String, ModelParams)> {
    let mut out = Vec::new();
    collect_models(value, "$", None, &mut out);
    out
}

fn collect_models(
    value: &Value,
    path: &str,
    owner: Option<&str>,
    out: &mut Vec<(String, String, ModelParams)>,
) {
    match value {
        Value::Object(map) => {
            if map.get("model").is_some_and(Value::is_string)
                && let Ok(model) = serde_json::from_value::<ModelParams>(value.clone())
            {
                let label = owner.map_or_else(|| path.to_owned(), str::to_owned);
                out.push((label, path.to_owned(), model));
                return;
            }
            let id = map.get("id").and_then(Value::as_str);
            for (key, child) in map {
                let label = match (id, key.as_str()) {
                    (Some(id), "model") => Some(id.to_owned()),
                    (Some(id), other) => Some(format!("{id} ({other})")),
                    (None, _) => None,
                };
                collect_models(child, &super::load::join(path, key), label.as_deref(), out);
            }
        }
        Value::Array(list) => {
            for (i, child) in list.iter().enumerate() {
                collect_models(child, &format!("{path}[{i}]"), owner, out);
            }
        }
        _ => {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinds::Registry;
    use crate::protocol::load::parse;

    #[test]
    fn every_kinds_new_protocol_is_valid_and_its_text_reads_back_the_same() {
        let form = Form::of::<Registry>();
        for kind in Registry::KINDS {
            let value = new_protocol::<Registry>(kind.name).unwrap();
            let text = form.text(&value);
            let parsed = parse::<Registry>(&text);
            assert!(parsed.is_ok(), "{}: {:?}", kind.name, parsed.err());
            let again: Value = serde_json::from_str(&text).unwrap();
            assert_eq!(again, value);
            assert_eq!(form.text(&again), text, "{}", kind.name);
        }
    }

    #[test]
    fn shipped_protocols_saved_from_the_builder_keep_their_meaning() {
        let form = Form::of::<Registry>();
        for (name, text) in crate::protocol::SHIPPED {
            let value: Value = serde_json::from_str(text).unwrap();
            let saved = form.text(&value);
            let before = parse::<Registry>(text).unwrap();
            let after = parse::<Registry>(&saved).unwrap();
            assert_eq!(before, after, "{name}");
            assert!(saved.starts_with("{\n  \"$schema\": "), "{name}: {saved}");
            // Required fields first, in their declared order.
            let id = saved.find("\"id\"").unwrap();
            let title = saved.find("\"title\"").unwrap();
            let design = saved.find("\"design\"").unwrap();
            assert!(id < title && title < design, "{name}");
        }
    }

    #[test]
    fn a_model_field_switched_to_another_model_takes_the_seeds_defaults() {
        let form = Form::of::<Registry>();
        let condition = form.resolve(&form.root()["$defs"]["Condition"]).clone();
        let model = &form.fields(&condition)[1];
        assert_eq!(model.0, "model");
        let dahl = form.new_alternative::<Registry>(model.1, "dahl").unwrap();
        assert_eq!(
            serde_json::from_value::<ModelParams>(dahl).unwrap(),
            ModelParams::default_for("dahl").unwrap()
        );
        let kinds: Vec<String> = form
            .tagged(&form.root()["properties"]["design"])
            .unwrap()
            .iter()
            .map(|(_, tag, _)| (*tag).to_owned())
            .collect();
        let names: Vec<&str> = Registry::KINDS.iter().map(|k| k.name).collect();
        assert_eq!(kinds, names);
    }

    #[test]
    fn units_come_from_the_si_suffix_and_models_are_found_with_their_condition() {
        assert_eq!(unit("exploration_s"), Some("s"));
        assert_eq!(unit("coupling_damping_n_s_m"), Some("N s/m"));
        assert_eq!(unit("stiffness_n_m"), Some("N/m"));
        assert_eq!(unit("zero_velocity_band_m_s"), Some("m/s"));
        assert_eq!(unit("mu_s"), None);
        assert_eq!(unit("c_per_s"), Some("1/s"));
        let (_, text) = crate::protocol::SHIPPED
            .iter()
            .find(|(n, _)| *n == "fitts-quick.json")
            .unwrap();
        let found = models(&serde_json::from_str(text).unwrap());
        let labels: Vec<&str> = found.iter().map(|(l, _, _)| l.as_str()).collect();
        assert_eq!(
            labels,
            ["baseline", "real", "real (physical)", "high_stiction"]
        );
        assert_eq!(found[3].1, "design.conditions[2].model");
    }
}
