//! The staircase in the window: its own screen ([`PairScreen`]: which
//! stimulus is on, the time left to explore, buttons to feel either and,
//! once asked, to answer), and no results view (a test-only template: the
//! window shows its object of `summary.json` as a tree).

use eframe::egui::{self, RichText};

use super::PairScreen;
use crate::kinds::figures::{ResultsView, ScreenView};
use crate::protocol::engine::{Answer, Choice, Input, OwnScreen, Question};
use crate::time::Time;

/// No figures: the window's tree of the object stands instead.
pub const VIEW: Option<ResultsView> = None;

/// The staircase's own screen, drawn by [`pair`].
pub const SCREEN: Option<ScreenView> = Some(pair);

/// Draws a trial's pair at `now`: the stimulus on, the seconds left, a
/// button to feel each, and with `question` open the three answers.
fn pair(ui: &mut egui::Ui, own: &OwnScreen, now: Time, question: Option<Question>) -> Vec<Input> {
    let mut inputs = Vec::new();
    let Some(screen) = own.get::<PairScreen>() else {
        // Another kind's screen under this kind: nothing to draw it with.
        ui.label(format!("(a screen '{}' this kind cannot draw)", own.name()));
        return inputs;
    };
    ui.label(RichText::new(format!("Stimulus {} of 2", screen.active + 1)).size(30.0));
    let left = (screen.until - now).secs().max(0.0);
    ui.label(RichText::new(format!("{left:.0} s to explore")).size(22.0));
    ui.horizontal(|ui| {
        for i in 0..2 {
            let label = format!("Feel stimulus {}", i + 1);
            if ui.selectable_label(screen.active == i, label).clicked() {
                inputs.push(Input::Switch(i));
            }
        }
    });
    if question.is_some() {
        ui.label(RichText::new("Which felt stronger?").size(22.0));
        ui.horizontal(|ui| {
            for (label, choice) in [
                ("The first", Choice::First),
                ("The second", Choice::Second),
                ("No difference", Choice::NoDifference),
            ] {
                if ui.button(label).clicked() {
                    inputs.push(Input::Answer(Answer::Paired(choice)));
                }
            }
        });
    }
    inputs
}

#[cfg(test)]
mod tests {
    use egui_kittest::Harness;
    use egui_kittest::kittest::Queryable;

    use super::*;

    /// Draws the screen `own` at 2 s, the question open or not; what the
    /// clicks gave is kept.
    fn harness(own: OwnScreen, question: Option<Question>) -> Harness<'static, Vec<Input>> {
        Harness::new_ui_state(
            move |ui, inputs: &mut Vec<Input>| {
                inputs.extend(pair(ui, &own, Time::from_whole_secs(2), question));
            },
            Vec::new(),
        )
    }

    #[test]
    fn the_pair_screen_shows_its_stimulus_and_gives_the_switch_and_the_answer() {
        let screen = OwnScreen::new(PairScreen {
            active: 1,
            until: Time::from_whole_secs(5),
        });
        let mut h = harness(screen.clone(), None);
        h.get_by_label("Stimulus 2 of 2");
        h.get_by_label("3 s to explore");
        assert!(h.query_by_label("The first").is_none(), "no answer before the question");
        h.get_by_label("Feel stimulus 1").click();
        h.run();
        assert_eq!(h.state(), &vec![Input::Switch(0)]);

        let mut h = harness(screen, Some(Question::PairedChoice));
        h.get_by_label("No difference").click();
        h.run();
        assert_eq!(
            h.state(),
            &vec![Input::Answer(Answer::Paired(Choice::NoDifference))]
        );
    }
}
