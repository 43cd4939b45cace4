//! The participant's screens: what [`LiveSession::view`] says to show,
//! drawn large, and the participant's answers and clicks turned into
//! [`Command`]s. Positions are drawn in millimetres; everything else is SI.

use eframe::egui::{self, Color32, Key, Rect, RichText, Sense, Stroke, StrokeKind, pos2, vec2};

use super::Command;
use crate::protocol::engine::{Choice, Question, Screen};
use crate::session::{LiveSession, SessionState};

/// Half the width of the workspace strip, m: the simulated device's 32 mm
/// range plus a margin on each side.
pub const WORKSPACE_HALF_M: f64 = 0.02;
/// Half the simulated device's range of motion, m (seed 002's 32 mm).
const RANGE_HALF_M: f64 = 0.016;

/// Draws the participant's screen and collects what they do. `canvas` gets
/// the workspace strip's rectangle (where the pointer drives the hand).
#[expect(
    clippy::too_many_lines,
    reason = "one match over the participant's screens reads best in one place"
)]
pub(crate) fn show(
    ui: &mut egui::Ui,
    live: &LiveSession,
    answer: &mut String,
    commands: &mut Vec<Command>,
    canvas: &mut Option<Rect>,
) {
    ui.spacing_mut().button_padding = vec2(16.0, 10.0);
    let view = live.view();
    let now = live.now();
    match live.state() {
        SessionState::Finished => {
            big(ui, "Thank you! The session is complete.");
            return;
        }
        SessionState::Aborted => {
            big(ui, "The session has been stopped.");
            return;
        }
        SessionState::Paused => {
            big(ui, "Paused: please wait for the experimenter.");
            return;
        }
        SessionState::Running => {}
    }
    if view.prompt.is_some() {
        big(
            ui,
            "Please wait: the experimenter is preparing the next condition.",
        );
        return;
    }
    let mut fitts = None;
    // A kind's own screen, drawn by its kind's code.
    let own = view
        .own
        .as_ref()
        .zip(crate::kinds::screen_view(live.header().protocol.kind()));
    match &view.screen {
        _ if let Some((own, draw)) = own => {
            for input in draw(ui, own, now, view.question) {
                commands.push(Command::Input(input));
            }
        }
        None => big(ui, "Please wait."),
        Some(Screen::Instructions(text)) => {
            big(ui, text);
            continue_button(ui, commands);
        }
        Some(Screen::Reference {
            instructions,
            until,
        }) => {
            big(ui, instructions);
            countdown(ui, "Reference", (*until - now).secs());
            continue_button(ui, commands);
        }
        Some(Screen::Break { until }) => {
            big(ui, "Break");
            countdown(ui, "The next block starts", (*until - now).secs());
            continue_button(ui, commands);
        }
        Some(Screen::Explore { until }) => {
            big(ui, "Explore the surface.");
            countdown(ui, "Exploration", (*until - now).secs());
            magnitude_entry(ui, answer, view.question.is_some(), commands);
        }
        Some(Screen::Paired {
            active,
            until,
            forced,
        }) => {
            paired(
                ui,
                *active,
                (*until - now).secs(),
                view.question,
                forced.as_deref(),
                commands,
            );
        }
        Some(Screen::Targets {
            lit_m,
            other_m,
            width_m,
            cursor_m,
            missed,
            ..
        }) => {
            big(ui, "Click on the green target.");
            let text = if *missed {
                RichText::new("Missed: click inside the green target.")
                    .size(22.0)
                    .color(Color32::from_rgb(230, 120, 40))
            } else {
                RichText::new(" ").size(22.0)
            };
            ui.label(text);
            fitts = Some(Targets {
                lit_m: *lit_m,
                other_m: *other_m,
                width_m: *width_m,
                cursor_m: *cursor_m,
            });
            if ui.input(|i| i.key_pressed(Key::Space)) {
                commands.push(Command::Click);
            }
        }
    }
    if let Some(refused) = &view.refused {
        ui.label(
            RichText::new(refused)
                .size(22.0)
                .color(Color32::from_rgb(230, 80, 60)),
        );
    }
    ui.add_space(12.0);
    workspace(ui, live, fitts.as_ref(), commands, canvas);
}

#[expect(clippy::struct_field_names, reason = "SI unit suffixes")]
struct Targets {
    lit_m: f64,
    other_m: f64,
    width_m: f64,
    cursor_m: f64,
}

fn big(ui: &mut egui::Ui, text: &str) {
    ui.add(egui::Label::new(RichText::new(text).size(28.0)).wrap());
}

fn countdown(ui: &mut egui::Ui, what: &str, left_s: f64) {
    let text = if left_s > 0.0 {
        // Whole seconds, rounded up: "1 s left" until the very end.
        format!("{what}: {:.0} s left", left_s.ceil())
    } else {
        format!("{what}: time is up")
    };
    ui.label(RichText::new(text).size(22.0));
}

/// The Continue button; Space or Enter does the same (the participant
/// may have a hand on the device), and the screen says so.
fn continue_button(ui: &mut egui::Ui, commands: &mut Vec<Command>) {
    ui.add_space(12.0);
    let key = ui.input(|i| i.key_pressed(Key::Space) || i.key_pressed(Key::Enter));
    if ui.button(RichText::new("Continue").size(24.0)).clicked() || key {
        commands.push(Command::Continue);
    }
    ui.label(RichText::new("or press Space or Enter").size(18.0).weak());
}

/// The number entry: any text goes to the engine, which refuses empty,
/// non-numeric, zero, negative and non-finite numbers with a message.
fn magnitude_entry(
    ui: &mut egui::Ui,
    answer: &mut String,
    asked: bool,
    commands: &mut Vec<Command>,
) {
    ui.add_space(12.0);
    let prompt = if asked {
        "How strong was the friction? Type any positive number:"
    } else {
        "When ready, type any positive number for how strong the friction feels:"
    };
    ui.label(RichText::new(prompt).size(22.0));
    ui.horizontal(|ui| {
        let label = ui.label(RichText::new("Your number").size(22.0));
        let entry = ui
            .add(
                egui::TextEdit::singleline(answer)
                    .font(egui::FontId::proportional(40.0))
                    .desired_width(260.0),
            )
            .labelled_by(label.id);
        let entered = entry.lost_focus() && ui.input(|i| i.key_pressed(Key::Enter));
        // The entry takes the keyboard when nothing else has it, so a
        // participant with a hand on the device types the number and
        // presses Enter without the mouse (after Enter is read: asking for
        // focus clears `lost_focus`).
        if !entered && ui.memory(|m| m.focused().is_none()) {
            entry.request_focus();
        }
        if ui.button(RichText::new("Submit").size(28.0)).clicked() || entered {
            commands.push(Command::Magnitude(answer.clone()));
        }
    });
}

/// The two stimuli and the answers: the paired comparison's nearness, or
/// a forced choice's question (`forced`) answered stimulus 1 or 2.
fn paired(
    ui: &mut egui::Ui,
    active: usize,
    left_s: f64,
    question: Option<Question>,
    forced: Option<&str>,
    commands: &mut Vec<Command>,
) {
    big(ui, &format!("Stimulus {} is active.", active + 1));
    if left_s > 0.0 {
        countdown(ui, "Exploration", left_s);
        ui.horizontal(|ui| {
            for i in 0..2 {
                let text = RichText::new(format!("Feel stimulus {}", i + 1)).size(24.0);
                if ui.selectable_label(active == i, text).clicked() && active != i {
                    commands.push(Command::Switch(i));
                }
            }
        });
    } else {
        countdown(ui, "Exploration", left_s);
    }
    ui.add_space(12.0);
    if let Some(ask) = forced {
        let ask = if question.is_some() {
            ask.to_owned()
        } else {
            format!("Answer when you are sure: {ask}")
        };
        ui.label(RichText::new(ask).size(22.0));
        ui.horizontal(|ui| {
            for (text, choice) in [
                ("Stimulus 1", Choice::First),
                ("Stimulus 2", Choice::Second),
            ] {
                if ui.button(RichText::new(text).size(24.0)).clicked() {
                    commands.push(Command::Paired(choice));
                }
            }
        });
        return;
    }
    let ask = if question.is_some() {
        "Which felt nearer to the real surface?"
    } else {
        "Answer when you are sure: which feels nearer to the real surface?"
    };
    ui.label(RichText::new(ask).size(22.0));
    ui.horizontal(|ui| {
        for (text, choice) in [
            ("Stimulus 1 is nearer", Choice::First),
            ("Stimulus 2 is nearer", Choice::Second),
            ("No difference", Choice::NoDifference),
        ] {
            if ui.button(RichText::new(text).size(24.0)).clicked() {
                commands.push(Command::Paired(choice));
            }
        }
    });
}

/// The workspace strip: the device's range, the Fitts targets, the cursor at
/// the device's position (every frame) and the rendered force as an arrow.
/// The pointer over it, or dragging from it, drives the simulated hand; a
/// click (or the release of a drag) is a Fitts click.
fn workspace(
    ui: &mut egui::Ui,
    live: &LiveSession,
    fitts: Option<&Targets>,
    commands: &mut Vec<Command>,
    canvas: &mut Option<Rect>,
) {
    let height = if fitts.is_some() { 220.0 } else { 140.0 };
    let width = ui.available_width().max(200.0);
    let (rect, response) = ui.allocate_exact_size(vec2(width, height), Sense::click_and_drag());
    *canvas = Some(rect);
    let to_px = |x_m: f64| to_screen(rect, x_m);
    let painter = ui.painter_at(rect);
    painter.rect_filled(rect, 6.0, Color32::from_gray(40));
    let (lo, hi) = (to_px(-RANGE_HALF_M), to_px(RANGE_HALF_M));
    painter.rect_stroke(
        Rect::from_x_y_ranges(lo..=hi, rect.top() + 4.0..=rect.bottom() - 4.0),
        4.0,
        Stroke::new(1.0, Color32::from_gray(90)),
        StrokeKind::Inside,
    );
    let mid = rect.center().y;
    if let Some(t) = fitts {
        for (centre, colour) in [
            (t.other_m, Color32::from_rgb(200, 40, 40)),
            (t.lit_m, Color32::from_rgb(40, 190, 70)),
        ] {
            let (l, r) = (
                to_px(centre - t.width_m / 2.0),
                to_px(centre + t.width_m / 2.0),
            );
            painter.rect_filled(
                Rect::from_x_y_ranges(l..=r, rect.top() + 20.0..=rect.bottom() - 20.0),
                2.0,
                colour,
            );
        }
    }
    let sample = live.sample();
    let x = to_px(sample.x_m);
    let cursor_px = fitts.map_or(6.0, |t| (to_px(t.cursor_m / 2.0) - to_px(0.0)).max(2.0));
    painter.circle_filled(pos2(x, mid), cursor_px, Color32::WHITE);
    painter.line_segment(
        [pos2(x, rect.top() + 8.0), pos2(x, rect.bottom() - 8.0)],
        Stroke::new(1.0, Color32::from_gray(200)),
    );
    force_arrow(&painter, pos2(x, mid + 40.0), sample.force_n, width);
    // The hand follows the pointer (see `hand_target`).
    commands.push(Command::HandTarget(hand_target(rect, &response)));
    // A Fitts tap is a press and release: a click, or the end of a drag
    // (a press while moving).
    if fitts.is_some() && (response.clicked() || response.drag_stopped()) {
        commands.push(Command::Click);
    }
}

/// The rendered force as an arrow from `at`: 1 N is 40 px, capped to
/// half the strip's `width`.
pub(super) fn force_arrow(painter: &egui::Painter, at: egui::Pos2, force_n: f64, width: f32) {
    #[expect(clippy::cast_possible_truncation, reason = "pixels")]
    let len = (force_n * 40.0).clamp(-f64::from(width) / 2.0, f64::from(width) / 2.0) as f32;
    if len.abs() > 1.0 {
        painter.arrow(
            at,
            vec2(len, 0.0),
            Stroke::new(3.0, Color32::from_rgb(90, 160, 255)),
        );
    }
}

/// Where the pointer holds the hand over the strip `rect`, m: under the
/// pointer while it hovers, and while the button is held from a press on
/// the strip (a drag of the handle, which egui does not count as
/// hovering), wherever the pointer goes.
pub(super) fn hand_target(rect: Rect, response: &egui::Response) -> Option<f64> {
    let pointer = if response.is_pointer_button_down_on() || response.dragged() {
        response.interact_pointer_pos()
    } else {
        response.hover_pos()
    };
    pointer.map(|p| to_m(rect, p.x).clamp(-WORKSPACE_HALF_M, WORKSPACE_HALF_M))
}

/// Workspace position (m) to screen x (px).
#[must_use]
pub fn to_screen(rect: Rect, x_m: f64) -> f32 {
    #[expect(clippy::cast_possible_truncation, reason = "pixels")]
    let u = (x_m / WORKSPACE_HALF_M) as f32;
    rect.center().x + u * rect.width() / 2.0
}

/// Screen x (px) to workspace position (m).
#[must_use]
pub fn to_m(rect: Rect, x_px: f32) -> f64 {
    f64::from((x_px - rect.center().x) / (rect.width() / 2.0)) * WORKSPACE_HALF_M
}
