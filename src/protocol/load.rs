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

use super::{
    BlockOrder, Condition, Design, FittsCondition, FittsDesign, FittsLevel, IdFormula,
    MagnitudeDesign, MagnitudeSet, PairedDesign, Protocol, Randomization, Stimulus, Tolerance,
};
use crate::friction::{
    DahlParams, GodObjectParams, KarnoppParams, ModelParams, NakanoParams, ViscousParams,
};
use crate::problem::Problem;

/// Parses and checks a protocol.
///
/// # Errors
/// Every problem found, each with its place.
pub fn parse(text: &str) -> Result<Protocol, Vec<Problem>> {
    let value: Value = serde_json::from_str(text).map_err(|e| {
        vec![Problem::new(
            format!("{}:{}", e.line(), e.column()),
            e.to_string().split(" at line ").next().unwrap_or_default(),
        )]
    })?;
    let mut w = Walk::default();
    let protocol = w.protocol(&value);
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
pub fn read(path: &std::path::Path) -> Result<(Protocol, Vec<u8>), Vec<Problem>> {
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

/// Letters, digits, `-` and `_`, at least one letter or digit.
#[must_use]
pub fn is_valid_id(id: &str) -> bool {
    id.chars().any(|c| c.is_ascii_alphanumeric())
        && id
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '-' || c == '_')
}

#[derive(Default)]
struct Walk {
    errors: Vec<Problem>,
}

fn join(path: &str, key: &str) -> String {
    if path == "$" {
        key.to_owned()
    } else {
        format!("{path}.{key}")
    }
}

impl Walk {
    fn err(&mut self, path: impl Into<String>, message: impl Into<String>) {
        self.errors.push(Problem::new(path, message));
    }

    /// `v` as an object whose keys are all in `known`.
    fn object<'v>(
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
    fn value<T: DeserializeOwned>(&mut self, v: &Value, path: &str) -> Option<T> {
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
    fn required<T: DeserializeOwned>(
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
    fn optional<T: DeserializeOwned>(
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
    fn list<T>(
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

    fn protocol(&mut self, v: &Value) -> Option<Protocol> {
        const KEYS: [&str; 10] = [
            "$schema",
            "id",
            "title",
            "description",
            "randomization",
            "repetitions",
            "block_order",
            "break_s",
            "instructions",
            "design",
        ];
        let m = self.object(v, "$", &KEYS)?;
        let p = "$";
        let schema = self.optional::<Option<String>>(m, "$schema", p, None);
        let id = self.required::<String>(m, "id", p);
        let title = self.required::<String>(m, "title", p);
        let description = self.optional(m, "description", p, String::new());
        let randomization = self.optional(m, "randomization", p, Randomization::default());
        let repetitions = self.optional(m, "repetitions", p, 1_u32);
        let block_order = self.optional(m, "block_order", p, BlockOrder::default());
        let break_s = self.optional(m, "break_s", p, 0.0_f64);
        let instructions = self.optional(m, "instructions", p, String::new());
        let design = if let Some(d) = m.get("design") {
            self.design(d, "design")
        } else {
            self.err("design", "missing required field");
            None
        };
        Some(Protocol {
            schema: schema?,
            id: id?,
            title: title?,
            description: description?,
            randomization: randomization?,
            repetitions: repetitions?,
            block_order: block_order?,
            break_s: break_s?,
            instructions: instructions?,
            design: design?,
        })
    }

    fn design(&mut self, v: &Value, path: &str) -> Option<Design> {
        let kinds = ["paired_comparison", "magnitude_estimation", "fitts"];
        let kind = v.get("kind").and_then(Value::as_str);
        match kind {
            Some("paired_comparison") => self.paired(v, path).map(Design::PairedComparison),
            Some("magnitude_estimation") => {
                self.magnitude(v, path).map(Design::MagnitudeEstimation)
            }
            Some("fitts") => self.fitts(v, path).map(Design::Fitts),
            Some(other) => {
                self.err(
                    join(path, "kind"),
                    format!(
                        "unknown kind '{other}'; expected one of: {}",
                        kinds.join(", ")
                    ),
                );
                None
            }
            None => {
                self.err(
                    join(path, "kind"),
                    format!("missing; expected one of: {}", kinds.join(", ")),
                );
                None
            }
        }
    }

    fn condition(&mut self, v: &Value, path: &str) -> Option<Condition> {
        let m = self.object(v, path, &["id", "model"])?;
        let id = self.required::<String>(m, "id", path);
        let model = self.model_field(m, "model", path);
        Some(Condition {
            id: id?,
            model: model?,
        })
    }

    fn paired(&mut self, v: &Value, path: &str) -> Option<PairedDesign> {
        let keys = [
            "kind",
            "reference_s",
            "reference_instructions",
            "exploration_s",
            "conditions",
            "pairs",
        ];
        let m = self.object(v, path, &keys)?;
        let reference_s = self.required(m, "reference_s", path);
        let reference_instructions = self.required(m, "reference_instructions", path);
        let exploration_s = self.required(m, "exploration_s", path);
        let conditions = self.list(m, "conditions", path, Self::condition);
        let pairs = self.list(m, "pairs", path, Walk::value::<[String; 2]>);
        Some(PairedDesign {
            reference_s: reference_s?,
            reference_instructions: reference_instructions?,
            exploration_s: exploration_s?,
            conditions: conditions?,
            pairs: pairs?,
        })
    }

    fn magnitude(&mut self, v: &Value, path: &str) -> Option<MagnitudeDesign> {
        let m = self.object(v, path, &["kind", "exploration_s", "sets"])?;
        let exploration_s = self.required(m, "exploration_s", path);
        let sets = self.list(m, "sets", path, |w, v, p| {
            let m = w.object(v, p, &["display", "model", "stimuli"])?;
            let display = w.required::<String>(m, "display", p);
            let model = w.model_field(m, "model", p);
            let stimuli = w.list(m, "stimuli", p, Walk::value::<Stimulus>);
            Some(MagnitudeSet {
                display: display?,
                model: model?,
                stimuli: stimuli?,
            })
        });
        Some(MagnitudeDesign {
            exploration_s: exploration_s?,
            sets: sets?,
        })
    }

    fn fitts(&mut self, v: &Value, path: &str) -> Option<FittsDesign> {
        let keys = [
            "kind",
            "cursor_m",
            "taps",
            "id_formula",
            "tolerance",
            "timeout_s",
            "conditions",
            "levels",
            "practice",
            "practice_levels",
        ];
        let m = self.object(v, path, &keys)?;
        let cursor_m = self.required(m, "cursor_m", path);
        let taps = self.required(m, "taps", path);
        let id_formula = self.optional(m, "id_formula", path, IdFormula::default());
        let tolerance = self.optional(m, "tolerance", path, Tolerance::default());
        let timeout_s = self.optional(m, "timeout_s", path, super::fitts_timeout());
        let conditions = self.list(m, "conditions", path, |w, v, p| {
            let m = w.object(v, p, &["id", "model", "prompt", "physical"])?;
            let id = w.required::<String>(m, "id", p);
            let model = w.model_field(m, "model", p);
            let prompt = w.optional::<Option<String>>(m, "prompt", p, None);
            let physical = match m.get("physical") {
                Some(v) => w.model(v, &join(p, "physical")).map(Some),
                None => Some(None),
            };
            Some(FittsCondition {
                id: id?,
                model: model?,
                prompt: prompt?,
                physical: physical?,
            })
        });
        let levels = self.list(m, "levels", path, Walk::value::<FittsLevel>);
        let practice = self.optional(m, "practice", path, Vec::<String>::new());
        let practice_levels = self.optional(m, "practice_levels", path, Vec::<usize>::new());
        Some(FittsDesign {
            cursor_m: cursor_m?,
            taps: taps?,
            id_formula: id_formula?,
            tolerance: tolerance?,
            timeout_s: timeout_s?,
            conditions: conditions?,
            levels: levels?,
            practice: practice?,
            practice_levels: practice_levels?,
        })
    }

    fn model_field(
        &mut self,
        m: &Map<String, Value>,
        key: &str,
        path: &str,
    ) -> Option<ModelParams> {
        if let Some(v) = m.get(key) {
            self.model(v, &join(path, key))
        } else {
            self.err(join(path, key), "missing required field");
            None
        }
    }

    /// A friction model object, dispatched on its `model` tag, then validated.
    fn model(&mut self, v: &Value, path: &str) -> Option<ModelParams> {
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

/// The set's model with the stimulus's coefficients.
#[must_use]
pub fn stimulus_model(model: &ModelParams, s: Stimulus) -> ModelParams {
    match model {
        ModelParams::StickSlipTactile(p) => ModelParams::StickSlipTactile(NakanoParams {
            mu_s: s.mu_s,
            mu_k: s.mu_k,
            ..*p
        }),
        ModelParams::StickSlipForce(p) => ModelParams::StickSlipForce(NakanoParams {
            mu_s: s.mu_s,
            mu_k: s.mu_k,
            ..*p
        }),
        other => other.clone(),
    }
}
