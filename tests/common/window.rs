//! The experimenter window driven headless (egui_kittest), for the tests
//! that share a step.

use egui_kittest::{Harness, kittest::Queryable};
use frictionlab::gui::FrictionlabApp;

/// Clicks the control labelled `label`, then lets two frames run.
pub fn click(h: &mut Harness<'_, FrictionlabApp>, label: &str) {
    h.get_by_label(label).click();
    h.step();
    h.step();
}

/// Runs Analyze from the Results tab and waits (up to two minutes) until
/// the analysis has ended, as Open report appearing shows.
pub fn analyze_in_results_tab(h: &mut Harness<'_, FrictionlabApp>) {
    click(h, "Results");
    click(h, "Analyze");
    let mut done = false;
    for _ in 0..2400 {
        h.step();
        if h.query_by_label("Open report").is_some() {
            done = true;
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    assert!(done, "the analysis ended: {:?}", h.state().error());
}
