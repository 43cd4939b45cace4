//! `NAME=VALUE` overrides of parameter objects (`frictionlab render --set`).
//!
//! Parameters are edited as JSON, so any serde parameter struct can be
//! overridden by field name without a hand-written list of names. A name is a
//! dotted path (`static_friction.mu_d`) or, when unambiguous, a bare field
//! name found anywhere in the object (`mu_d`).

use serde::{Serialize, de::DeserializeOwned};
use serde_json::Value;

use crate::problem::Problem;

/// Splits `NAME=VALUE`.
///
/// # Errors
/// When there is no `=` or the name is empty.
pub fn split_setting(text: &str) -> Result<(&str, &str), Problem> {
    match text.split_once('=') {
        Some((name, value)) if !name.trim().is_empty() => Ok((name.trim(), value.trim())),
        _ => Err(Problem::new(text, "expected NAME=VALUE")),
    }
}

/// Every leaf path of `value` (dotted), skipping the tag field `tag`.
#[must_use]
pub fn leaf_paths(value: &Value, tag: &str) -> Vec<String> {
    fn walk(value: &Value, prefix: &str, tag: &str, out: &mut Vec<String>) {
        if let Value::Object(map) = value {
            for (key, child) in map {
                if prefix.is_empty() && key == tag {
                    continue;
                }
                let path = if prefix.is_empty() {
                    key.clone()
                } else {
                    format!("{prefix}.{key}")
                };
                if child.is_object() {
                    walk(child, &path, tag, out);
                } else {
                    out.push(path);
                }
            }
        }
    }
    let mut out = Vec::new();
    walk(value, "", tag, &mut out);
    out
}

/// Applies `overrides` (name, value) to `base` and deserializes the result.
/// `tag` is the field naming the variant (`model`, `scenario`), which cannot
/// be set; `what` names the object in messages (`model karnopp`).
///
/// # Errors
/// Unknown or ambiguous names, values that are not finite numbers of the
/// field's kind, and anything serde refuses. Each problem's place is the
/// setting's name as given, or `what` for what serde refuses.
pub fn apply<T: Serialize + DeserializeOwned>(
    base: &T,
    tag: &str,
    what: &str,
    overrides: &[(&str, &str)],
) -> Result<T, Vec<Problem>> {
    match apply_all(base, tag, what, overrides) {
        (Some(value), errors) if errors.is_empty() => Ok(value),
        (_, errors) => Err(errors),
    }
}

/// Like [`apply`], but applies every override it can and returns the result
/// (if serde accepts it) together with the errors of the others, so that a
/// caller can report every problem at once.
pub fn apply_all<T: Serialize + DeserializeOwned>(
    base: &T,
    tag: &str,
    what: &str,
    overrides: &[(&str, &str)],
) -> (Option<T>, Vec<Problem>) {
    let whole = |message: String| Problem::new(what, message);
    let mut value = match serde_json::to_value(base) {
        Ok(v) => v,
        Err(e) => return (None, vec![whole(e.to_string())]),
    };
    let paths = leaf_paths(&value, tag);
    let mut errors = Vec::new();
    for &(name, text) in overrides {
        if let Err(message) =
            resolve(&paths, name, what).and_then(|path| set(&mut value, &path, text))
        {
            errors.push(Problem::new(name, message));
        }
    }
    match serde_json::from_value(value) {
        Ok(t) => (Some(t), errors),
        Err(e) => {
            errors.push(whole(e.to_string()));
            (None, errors)
        }
    }
}

/// The full path `name` refers to.
fn resolve(paths: &[String], name: &str, what: &str) -> Result<String, String> {
    if paths.iter().any(|p| p == name) {
        return Ok(name.to_owned());
    }
    let suffix = format!(".{name}");
    let matches: Vec<&String> = paths.iter().filter(|p| p.ends_with(&suffix)).collect();
    match matches.as_slice() {
        [one] => Ok((*one).clone()),
        [] => Err(format!(
            "unknown parameter of {what}; known: {}",
            paths.join(", ")
        )),
        many => Err(format!(
            "ambiguous; write one of {}",
            many.iter()
                .map(|s| s.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        )),
    }
}

/// Sets the number at `path` from `text`, keeping the field's kind.
fn set(value: &mut Value, path: &str, text: &str) -> Result<(), String> {
    let slot = path
        .split('.')
        .try_fold(value, |v, key| v.get_mut(key))
        .ok_or_else(|| format!("no field {path}"))?;
    let new = match slot {
        Value::Number(n) if n.is_u64() => text
            .parse::<u64>()
            .map(Value::from)
            .map_err(|_| format!("expected a whole number, got '{text}'"))?,
        Value::Number(_) => {
            let x: f64 = text
                .parse()
                .map_err(|_| format!("expected a number, got '{text}'"))?;
            if !x.is_finite() {
                return Err(format!("must be finite, got {text}"));
            }
            Value::from(x)
        }
        Value::Bool(_) => text
            .parse::<bool>()
            .map(Value::from)
            .map_err(|_| format!("expected true or false, got '{text}'"))?,
        Value::Array(_) => serde_json::from_str::<Value>(text)
            .ok()
            .filter(Value::is_array)
            .ok_or_else(|| format!("expected a list such as [0.01, 0.1, 0], got '{text}'"))?,
        _ => Value::from(text),
    };
    *slot = new;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::friction::ModelParams;

    fn params(name: &str) -> ModelParams {
        ModelParams::default_for(name).unwrap()
    }

    #[test]
    fn a_bare_name_reaches_a_nested_field() {
        let p = apply(
            &params("god-object-time-varying"),
            "model",
            "model",
            &[("mu_d", "0.5")],
        )
        .unwrap();
        let ModelParams::GodObjectTimeVarying(g) = p else {
            panic!("variant changed")
        };
        assert!((g.static_friction.mu_d - 0.5).abs() < 1e-15);
    }

    #[test]
    fn unknown_names_non_numbers_and_infinities_are_refused() {
        for (name, value, message) in [
            ("mu_x", "1", "unknown parameter of m; known:"),
            ("model", "dahl", "unknown parameter of m; known:"),
            ("mu_s", "abc", "expected a number, got 'abc'"),
            ("mu_s", "inf", "must be finite, got inf"),
            ("mu_s", "NaN", "must be finite, got NaN"),
        ] {
            let errors =
                apply(&params("stick-slip-force"), "model", "m", &[(name, value)]).unwrap_err();
            assert_eq!(errors.len(), 1);
            assert_eq!(errors[0].place, name);
            assert!(
                errors[0].message.starts_with(message),
                "{name}={value}: {errors:?}"
            );
        }
    }

    #[test]
    fn a_setting_without_equals_sign_is_refused() {
        assert_eq!(split_setting("mu_s=1.2").unwrap(), ("mu_s", "1.2"));
        assert!(split_setting("mu_s").is_err());
        assert!(split_setting("=3").is_err());
    }
}
