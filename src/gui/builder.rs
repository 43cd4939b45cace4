//! The protocol builder: a protocol as forms, checked as it is typed.
//!
//! It edits the protocol as JSON and draws it from the protocol's schema
//! ([`crate::protocol::form::Form`]): every field, with its unit and its
//! doc comment, and for a tagged union (the design's `kind`, a model's
//! `model`) a choice that switches it. It names no kind: the kinds are the
//! registry's list, a new design is the kind's template, and a kind's
//! fields are its design's schema, all from the kind's own folder.
//!
//! After each edit the text is checked as `frictionlab validate` checks a
//! file ([`crate::protocol::load::parse`]); each problem is shown under the
//! field it names, as `<json path>: <what>`. A number that does not parse
//! is kept as typed (as a string), so the check names it. Save is refused
//! while a problem remains; it writes the text in a stable key order
//! ([`Form::text`]), to a new file or to the file opened or saved last,
//! and the protocol can then go to the setup at once. "Feel a condition"
//! renders one of the protocol's models on the session's device
//! ([`Feel`]) with the pointer holding the hand.

use std::collections::{HashMap, HashSet};
use std::path::PathBuf;

use eframe::egui::{self, Color32, Rect, RichText, Sense, Stroke, pos2, vec2};
use serde_json::Value;

use super::choose::{Choose, choose};
use super::{Command, ERROR_RED, participant};
use crate::kinds::Registry;
use crate::problem::Problem;
use crate::protocol::SHIPPED;
use crate::protocol::form::{self, Form};
use crate::protocol::kind::Kinds;
use crate::session::{DeviceChoice, Feel};

/// What the builder keeps between frames.
pub(super) struct BuilderPanel {
    form: Form,
    /// The protocol being edited.
    value: Value,
    /// What it started from (a shipped protocol, a file, a new kind).
    from: String,
    /// Number fields as typed, by JSON path.
    typed: HashMap<String, String>,
    /// The check's problems, after the last edit.
    problems: Vec<Problem>,
    /// `ok: ...` when the protocol is valid.
    valid: Option<String>,
    /// The paths of the fields drawn last frame.
    drawn: HashSet<String>,
    /// The file to save to (or open).
    file: String,
    /// The file opened or saved last: Save may replace it.
    owned: Option<PathBuf>,
    /// What the last open or save did.
    message: Option<(bool, String)>,
    /// The shipped protocol chosen to start from.
    shipped: usize,
    /// The model chosen to feel.
    feel_choice: usize,
    feel: Option<Feel>,
}

impl Default for BuilderPanel {
    fn default() -> Self {
        let mut builder = BuilderPanel {
            form: Form::of::<Registry>(),
            value: Value::Null,
            from: String::new(),
            typed: HashMap::new(),
            problems: Vec::new(),
            valid: None,
            drawn: HashSet::new(),
            file: String::new(),
            owned: None,
            message: None,
            shipped: 0,
            feel_choice: 0,
            feel: None,
        };
        builder.start_from_shipped(0);
        builder
    }
}

impl BuilderPanel {
    /// Starts from shipped protocol `i`.
    fn start_from_shipped(&mut self, i: usize) {
        if let Some((name, text)) = SHIPPED.get(i)
            && let Ok(value) = serde_json::from_str(text)
        {
            self.replace(value, format!("shipped {name}"), None);
            self.file = format!("protocols/my-{name}");
        }
    }

    /// Starts a new protocol of kind `kind`.
    fn start_new(&mut self, kind: &str) {
        if let Some(value) = form::new_protocol::<Registry>(kind) {
            self.replace(value, format!("new {kind}"), None);
            self.file = format!("protocols/new-{}.json", kind.replace('_', "-"));
        }
    }

    /// Opens the file typed in.
    fn open_file(&mut self) {
        let path = PathBuf::from(self.file.trim());
        let read = std::fs::read_to_string(&path)
            .map_err(|e| e.to_string())
            .and_then(|text| serde_json::from_str::<Value>(&text).map_err(|e| e.to_string()));
        match read {
            Ok(value) => {
                self.replace(value, path.display().to_string(), Some(path));
            }
            Err(e) => {
                self.message = Some((false, format!("error: {}: {e}", path.display())));
            }
        }
    }

    fn replace(&mut self, value: Value, from: String, owned: Option<PathBuf>) {
        self.value = value;
        self.from = from;
        self.owned = owned;
        self.typed.clear();
        self.message = None;
        self.feel = None;
        self.feel_choice = 0;
        self.check();
    }

    /// Checks the protocol as `validate` does.
    fn check(&mut self) {
        match crate::protocol::load::parse::<Registry>(&self.form.text(&self.value)) {
            Ok(p) => {
                self.problems.clear();
                self.valid = Some(format!(
                    "ok: {} '{}', {}",
                    p.kind(),
                    p.id,
                    p.trials_per_session()
                ));
            }
            Err(problems) => {
                self.problems = problems;
                self.valid = None;
            }
        }
    }

    /// Saves to the file typed in: a new file, or the one opened or saved
    /// last. Returns the path saved.
    fn save(&mut self) -> Option<PathBuf> {
        let path = PathBuf::from(self.file.trim());
        let result = if !self.problems.is_empty() {
            Err(format!(
                "not saved: {} problem(s) to fix first",
                self.problems.len()
            ))
        } else if path.as_os_str().is_empty() {
            Err("not saved: type the file to save to".to_owned())
        } else if path.exists() && self.owned.as_deref() != Some(path.as_path()) {
            Err(format!(
                "not saved: {} exists (open it to edit it, or choose another name)",
                path.display()
            ))
        } else {
            crate::results::replace_file(&path, self.form.text(&self.value).as_bytes(), true)
                .map_err(|e| format!("error: {e}"))
        };
        match result {
            Ok(()) => {
                self.owned = Some(path.clone());
                self.message = Some((true, format!("saved {}", path.display())));
                Some(path)
            }
            Err(e) => {
                self.message = Some((false, e));
                None
            }
        }
    }

    /// Draws the builder; `device` is where a condition is felt.
    #[must_use]
    pub(super) fn ui(
        &mut self,
        ui: &mut egui::Ui,
        now: f64,
        device: &DeviceChoice,
    ) -> Vec<Command> {
        let mut commands = Vec::new();
        self.start_row(ui);
        ui.horizontal(|ui| {
            let label = ui.label("Protocol file");
            ui.add(
                egui::TextEdit::singleline(&mut self.file)
                    .id_salt("builder file")
                    .desired_width(380.0),
            )
            .labelled_by(label.id);
            if ui.button("Open").clicked() {
                self.open_file();
            }
            if ui.button("Browse…").clicked() {
                match choose(Choose::Protocol, &self.file) {
                    Ok(path) => {
                        self.file = path.display().to_string();
                        self.open_file();
                    }
                    Err(m) => self.message = Some((false, m)),
                }
            }
            if ui
                .add_enabled(self.problems.is_empty(), egui::Button::new("Save"))
                .on_disabled_hover_text("fix the problems first")
                .clicked()
            {
                self.save();
            }
            if ui
                .add_enabled(self.problems.is_empty(), egui::Button::new("Save as…"))
                .clicked()
            {
                match choose(Choose::SaveProtocol, &self.file) {
                    Ok(path) => {
                        // The desktop's chooser asked before replacing.
                        self.owned = Some(path.clone());
                        self.file = path.display().to_string();
                        self.save();
                    }
                    Err(m) => self.message = Some((false, m)),
                }
            }
            if let Some(path) = &self.owned
                && self.problems.is_empty()
                && ui.button("Use for a session").clicked()
            {
                commands.push(Command::UseProtocol(path.clone()));
            }
        });
        if let Some((ok, m)) = &self.message {
            let colour = if *ok { Color32::LIGHT_GREEN } else { ERROR_RED };
            ui.label(RichText::new(m).color(colour));
        }
        ui.label(RichText::new(format!("Editing: {}", self.from)).weak());
        if let Some(ok) = &self.valid {
            ui.label(RichText::new(ok).color(Color32::LIGHT_GREEN));
        } else {
            ui.label(
                RichText::new(format!(
                    "{} problem(s), each shown at its field; Save is refused until they are fixed",
                    self.problems.len()
                ))
                .color(ERROR_RED),
            );
            // Problems at no field drawn (a whole design, say).
            for p in self
                .problems
                .iter()
                .filter(|p| !self.drawn.contains(&p.place))
            {
                ui.label(RichText::new(format!("{}: {}", p.place, p.message)).color(ERROR_RED));
            }
        }
        self.feel_row(ui, now, device);
        ui.separator();
        self.form_ui(ui);
        if self.feel.is_some() {
            ui.ctx().request_repaint();
        }
        commands
    }

    fn start_row(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            ui.label("Start from");
            egui::ComboBox::from_id_salt("builder shipped")
                .selected_text(SHIPPED.get(self.shipped).map_or("", |s| s.0))
                .show_ui(ui, |ui| {
                    for (i, (name, _)) in SHIPPED.iter().enumerate() {
                        ui.selectable_value(&mut self.shipped, i, *name);
                    }
                });
            if ui.button("Edit a copy").clicked() {
                self.start_from_shipped(self.shipped);
            }
            ui.separator();
            ui.label("or a new");
            for kind in Registry::KINDS {
                if ui.button(kind.name).clicked() {
                    self.start_new(kind.name);
                }
            }
        });
    }

    /// "Feel a condition": one of the protocol's models on the device.
    fn feel_row(&mut self, ui: &mut egui::Ui, now: f64, device: &DeviceChoice) {
        let models = form::models(&self.value);
        ui.horizontal(|ui| {
            ui.label("Feel a condition");
            self.feel_choice = self.feel_choice.min(models.len().saturating_sub(1));
            egui::ComboBox::from_id_salt("builder feel")
                .selected_text(models.get(self.feel_choice).map_or("", |m| m.0.as_str()))
                .show_ui(ui, |ui| {
                    for (i, (label, path, model)) in models.iter().enumerate() {
                        ui.selectable_value(
                            &mut self.feel_choice,
                            i,
                            format!("{label} ({}, {path})", model.name()),
                        );
                    }
                });
            if self.feel.is_some() {
                if ui.button("Stop feeling").clicked() {
                    self.feel = None;
                }
            } else if let Some((_, _, model)) = models.get(self.feel_choice)
                && ui
                    .button(format!("Feel it on the {} device", device_name(device)))
                    .clicked()
            {
                match Feel::start(device, model, now) {
                    Ok(feel) => self.feel = Some(feel),
                    Err(e) => self.message = Some((false, format!("error: {e}"))),
                }
            }
        });
        if let Some(feel) = &mut self.feel {
            strip(ui, feel, now);
        }
    }

    fn form_ui(&mut self, ui: &mut egui::Ui) {
        let mut value = std::mem::take(&mut self.value);
        let mut editor = Editor {
            form: &self.form,
            typed: &mut self.typed,
            problems: &self.problems,
            drawn: HashSet::new(),
            changed: false,
        };
        editor.object(ui, self.form.root(), &mut value, "$");
        let (changed, drawn) = (editor.changed, editor.drawn);
        self.value = value;
        self.drawn = drawn;
        if changed {
            self.message = None;
            self.check();
            // Show the check's verdict now, not at the next input.
            ui.ctx().request_repaint();
        }
    }
}

fn device_name(device: &DeviceChoice) -> String {
    match device {
        DeviceChoice::Simulated => "simulated".to_owned(),
        DeviceChoice::Device(a) => a.to_string(),
    }
}

/// The surface a condition is felt on: the pointer over it (or dragging
/// from it) holds the hand; the cursor is the device, the arrow its force.
fn strip(ui: &mut egui::Ui, feel: &mut Feel, now: f64) {
    let width = ui.available_width().clamp(200.0, 900.0);
    let (rect, response) = ui.allocate_exact_size(vec2(width, 90.0), Sense::click_and_drag());
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 6.0, Color32::from_gray(40));
    feel.advance(now, participant::hand_target(rect, &response));
    let s = *feel.sample();
    let x = participant::to_screen(rect, s.x_m);
    let mid = rect.center().y;
    painter.circle_filled(pos2(x, mid), 6.0, Color32::WHITE);
    participant::force_arrow(&painter, pos2(x, mid + 25.0), s.force_n, width);
    painter.rect_stroke(
        Rect::from_center_size(rect.center(), rect.size()),
        6.0,
        Stroke::new(1.0, Color32::from_gray(90)),
        egui::StrokeKind::Inside,
    );
    ui.label(format!(
        "{}{} · position {:.2} mm · velocity {:.1} mm/s · force {:.3} N · vibration {:.2}",
        feel.model().name(),
        if feel.connected() {
            ""
        } else {
            " · NOT CONNECTED"
        },
        shown(s.x_m * 1e3, 1e-2),
        shown(s.v_m_s * 1e3, 1e-1),
        shown(s.force_n, 1e-3),
        shown(s.vibration, 1e-2)
    ));
}

/// Draws the form of one value and applies the edits.
struct Editor<'a> {
    form: &'a Form,
    typed: &'a mut HashMap<String, String>,
    problems: &'a [Problem],
    drawn: HashSet<String>,
    changed: bool,
}

impl<'a> Editor<'a> {
    /// The problems at `path`, under its field.
    fn problems(&mut self, ui: &mut egui::Ui, path: &str) {
        self.drawn.insert(path.to_owned());
        for p in self.problems.iter().filter(|p| p.place == path) {
            ui.label(RichText::new(format!("{}: {}", p.place, p.message)).color(ERROR_RED));
        }
    }

    /// An object's fields, in form order; optional fields left out offer
    /// to be set, and set ones to be removed.
    fn object(&mut self, ui: &mut egui::Ui, node: &'a Value, value: &mut Value, path: &str) {
        let node = self.form.pick(node, value);
        let tag = self.form.tag(node).map(|(k, _)| k.to_owned());
        let Value::Object(map) = value else {
            return;
        };
        // Plain fields first, then the nested ones (the design, lists),
        // each in form order.
        let mut fields = self.form.fields(node);
        fields.sort_by_key(|(key, _, _)| {
            map.get(*key).is_some_and(|v| v.is_object() || v.is_array())
        });
        for (key, child, required) in fields {
            if Some(key) == tag.as_deref() || key == "$schema" {
                continue;
            }
            let child_path = crate::protocol::load::join(path, key);
            if let Some(v) = map.get_mut(key) {
                let remove = self.field(
                    ui,
                    key,
                    child,
                    v,
                    &child_path,
                    (!required).then_some("unset"),
                );
                if remove {
                    map.remove(key);
                    // Set again later, it shows its new value, not the old text.
                    self.typed.retain(|p, _| !p.starts_with(&child_path));
                    self.changed = true;
                }
            } else {
                ui.horizontal(|ui| {
                    ui.label(RichText::new(label_text(key)).weak());
                    let default = child
                        .get("default")
                        .map_or_else(|| "not set".to_owned(), |d| format!("default {d}"));
                    ui.label(RichText::new(default).weak());
                    if ui.small_button("set").clicked() {
                        map.insert(key.to_owned(), self.form.new_value(child));
                        self.changed = true;
                    }
                });
                self.problems(ui, &child_path);
            }
        }
        // Keys the schema does not know: `validate` names them.
        let unknown: Vec<String> = map
            .keys()
            .filter(|k| !self.form.fields(node).iter().any(|(f, _, _)| f == k))
            .cloned()
            .collect();
        for key in unknown {
            let child_path = crate::protocol::load::join(path, &key);
            ui.horizontal(|ui| {
                ui.label(RichText::new(&key).color(ERROR_RED));
                if ui.small_button("remove").clicked() {
                    map.remove(&key);
                    self.changed = true;
                }
            });
            self.problems(ui, &child_path);
        }
    }

    /// One field: its label (key, unit, doc comment on hover) and editor.
    /// `removable`: the button that removes it (an optional field, a list
    /// element). Returns true when it was clicked.
    fn field(
        &mut self,
        ui: &mut egui::Ui,
        key: &str,
        node: &'a Value,
        value: &mut Value,
        path: &str,
        removable: Option<&str>,
    ) -> bool {
        let resolved = self.form.resolve(node);
        let doc = node
            .get("description")
            .or_else(|| resolved.get("description"))
            .and_then(Value::as_str)
            .unwrap_or("")
            .to_owned();
        let text = label_text(key);
        let mut remove = false;
        let picked = self.form.pick(node, value);
        let composite = value.is_object() || value.is_array();
        if composite {
            let id = ui.make_persistent_id(path);
            egui::collapsing_header::CollapsingState::load_with_default_open(ui.ctx(), id, true)
                .show_header(ui, |ui| {
                    ui.label(RichText::new(&text).strong()).on_hover_text(&doc);
                    if let Some(tagged) = self.form.tagged(node) {
                        self.tag_choice(ui, node, &tagged, value, path);
                    }
                    if let Some(button) = removable
                        && ui.small_button(button).clicked()
                    {
                        remove = true;
                    }
                })
                .body(|ui| {
                    self.problems(ui, path);
                    if value.is_object() {
                        self.object(ui, node, value, path);
                    } else {
                        self.array(ui, picked, value, path);
                    }
                });
        } else {
            ui.horizontal(|ui| {
                let label = ui.label(&text).on_hover_text(&doc);
                self.scalar(ui, node, picked, value, path, label.id);
                if let Some(button) = removable
                    && ui.small_button(button).clicked()
                {
                    remove = true;
                }
            });
            self.problems(ui, path);
        }
        remove
    }

    /// The choice that switches a tagged union (a design's kind, a model).
    fn tag_choice(
        &mut self,
        ui: &mut egui::Ui,
        node: &Value,
        tagged: &[(&str, &str, &Value)],
        value: &mut Value,
        path: &str,
    ) {
        let Some(&(key, _, _)) = tagged.first() else {
            return;
        };
        let current = value
            .get(key)
            .and_then(Value::as_str)
            .unwrap_or("")
            .to_owned();
        let mut chosen = current.clone();
        egui::ComboBox::from_id_salt(format!("{path} tag"))
            .selected_text(&chosen)
            .show_ui(ui, |ui| {
                for (_, tag, _) in tagged {
                    ui.selectable_value(&mut chosen, (*tag).to_owned(), *tag);
                }
            });
        if chosen != current
            && let Some(new) = self.form.new_alternative::<Registry>(node, &chosen)
        {
            *value = new;
            self.typed.retain(|p, _| !p.starts_with(path));
            self.changed = true;
        }
    }

    /// A list: each element, with remove, and an add that copies the last.
    fn array(&mut self, ui: &mut egui::Ui, node: &'a Value, value: &mut Value, path: &str) {
        const NONE: &Value = &Value::Null;
        let items = node.get("items").unwrap_or(NONE);
        let Value::Array(list) = value else {
            return;
        };
        let mut remove = None;
        for (i, item) in list.iter_mut().enumerate() {
            let item_path = format!("{path}[{i}]");
            ui.push_id(&item_path, |ui| {
                if item.is_object() || item.is_array() {
                    if self.field(
                        ui,
                        &format!("[{i}]"),
                        items,
                        item,
                        &item_path,
                        Some("remove"),
                    ) {
                        remove = Some(i);
                    }
                } else {
                    ui.horizontal(|ui| {
                        let label = ui.label(format!("[{i}]"));
                        let picked = self.form.pick(items, item);
                        self.scalar(ui, items, picked, item, &item_path, label.id);
                        if ui.small_button("remove").clicked() {
                            remove = Some(i);
                        }
                    });
                    self.problems(ui, &item_path);
                }
            });
        }
        if let Some(i) = remove {
            list.remove(i);
            self.typed.retain(|p, _| !p.starts_with(path));
            self.changed = true;
        }
        if ui.small_button(format!("add to {path}")).clicked() {
            let new = list
                .last()
                .cloned()
                .unwrap_or_else(|| self.form.new_value(items));
            list.push(new);
            self.changed = true;
        }
    }

    /// A number, string, boolean or choice.
    fn scalar(
        &mut self,
        ui: &mut egui::Ui,
        node: &Value,
        picked: &Value,
        value: &mut Value,
        path: &str,
        label: egui::Id,
    ) {
        if let Some(choices) = self.form.choices(node) {
            let current = value.as_str().unwrap_or("").to_owned();
            let mut chosen = current.clone();
            egui::ComboBox::from_id_salt(path)
                .selected_text(&chosen)
                .show_ui(ui, |ui| {
                    for c in &choices {
                        ui.selectable_value(&mut chosen, c.clone(), c);
                    }
                });
            if chosen != current {
                *value = Value::String(chosen);
                self.changed = true;
            }
            return;
        }
        let kind = self.form.kind_of(picked);
        let numeric =
            matches!(kind, Some("number" | "integer")) || (kind.is_none() && value.is_number());
        match (kind, &*value) {
            (Some("boolean"), _) | (_, Value::Bool(_)) => {
                let mut b = value.as_bool().unwrap_or(false);
                if ui.checkbox(&mut b, "").labelled_by(label).changed() {
                    *value = Value::Bool(b);
                    self.changed = true;
                }
            }
            _ if numeric => {
                let integer = kind == Some("integer");
                let text = self
                    .typed
                    .entry(path.to_owned())
                    .or_insert_with(|| match &*value {
                        Value::String(s) => s.clone(),
                        other => other.to_string(),
                    });
                let edit = ui
                    .add(
                        egui::TextEdit::singleline(text)
                            .id_salt(path)
                            .desired_width(110.0),
                    )
                    .labelled_by(label);
                if edit.changed() {
                    *value =
                        number(text.trim(), integer).unwrap_or_else(|| Value::String(text.clone()));
                    self.changed = true;
                }
            }
            _ => {
                let mut text = match &*value {
                    Value::String(s) => s.clone(),
                    Value::Null => String::new(),
                    other => other.to_string(),
                };
                let long = text.len() > 60 || text.contains('\n');
                // Ids from the path: a problem shown above the field moves
                // it, and must not take the typing focus away.
                let edit = if long {
                    egui::TextEdit::multiline(&mut text)
                        .desired_width(600.0)
                        .desired_rows(2)
                } else {
                    egui::TextEdit::singleline(&mut text).desired_width(300.0)
                }
                .id_salt(path);
                if ui.add(edit).labelled_by(label).changed() {
                    *value = Value::String(text);
                    self.changed = true;
                }
            }
        }
    }
}

/// `x` as printed to `step` (its last digit): a value that rounds to zero
/// prints as 0, not -0.
fn shown(x: f64, step: f64) -> f64 {
    if x.abs() < step / 2.0 { 0.0 } else { x }
}

/// A field's label: its key, and its unit where the key has one.
fn label_text(key: &str) -> String {
    match form::unit(key) {
        Some(unit) => format!("{key} ({unit})"),
        None => key.to_owned(),
    }
}

/// `text` as a JSON number (a whole number for an integer field).
fn number(text: &str, integer: bool) -> Option<Value> {
    if integer {
        return text
            .parse::<u64>()
            .map(Value::from)
            .or_else(|_| text.parse::<i64>().map(Value::from))
            .ok();
    }
    let x: f64 = text.parse().ok()?;
    serde_json::Number::from_f64(x).map(Value::Number)
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_readout_that_rounds_to_zero_prints_0_not_minus_0() {
        assert_eq!(format!("{:.3}", super::shown(-0.0004, 1e-3)), "0.000");
        assert_eq!(format!("{:.3}", super::shown(-0.0006, 1e-3)), "-0.001");
        assert_eq!(format!("{:.3}", super::shown(-1.777, 1e-3)), "-1.777");
    }
}
