//! The sans-IO engine driven by hand: answers, clicks, the write rule, abort.
#![allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]

use frictionlab::kinds::fitts::FittsData;
use frictionlab::kinds::magnitude::MagnitudeData;
use frictionlab::kinds::paired::PairedData;
use frictionlab::kinds::{Action, Engine, TrialData, TrialRecord};
use frictionlab::protocol::engine::{Answer, Choice, Input, Question, Screen, Status};
use frictionlab::protocol::load::parse;
use frictionlab::protocol::plan::resolve;
use frictionlab::time::Time;

fn engine(name: &str) -> Engine {
    let text = std::fs::read_to_string(format!(
        "{}/protocols/{name}.json",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    Engine::new(resolve(&parse(&text).unwrap(), 5, 0), 0)
}

fn drain(e: &mut Engine) -> Vec<Action> {
    std::iter::from_fn(|| e.poll()).collect()
}

fn record(actions: &[Action]) -> Option<&TrialRecord> {
    actions.iter().find_map(|a| {
        if let Action::Record(r) = a {
            Some(r)
        } else {
            None
        }
    })
}

/// `x` seconds of session time.
fn s(x: f64) -> Time {
    Time::from_secs(x).unwrap()
}

#[test]
fn bad_magnitudes_are_refused_and_asked_again_never_logged() {
    let mut e = engine("magnitude-quick");
    e.handle(s(0.0), Input::Start);
    assert!(matches!(
        drain(&mut e)[..],
        [Action::Show(Screen::Instructions(_))]
    ));
    e.handle(s(0.0), Input::Continue);
    let a = drain(&mut e);
    assert!(a.iter().any(|a| matches!(a, Action::Render(Some(_)))));
    assert!(
        a.iter()
            .any(|a| matches!(a, Action::Show(Screen::Explore { until }) if *until == s(2.0)))
    );
    e.handle_timeout(s(2.0));
    assert!(drain(&mut e).contains(&Action::Ask(Question::Magnitude)));
    for bad in [
        "", "  ", "abc", "1,5", "0", "-3", "-0", "inf", "NaN", "1e999",
    ] {
        e.handle(s(2.5), Input::Answer(Answer::Magnitude(bad.into())));
        let a = drain(&mut e);
        assert!(
            matches!(
                a[..],
                [Action::Refused(_), Action::Ask(Question::Magnitude)]
            ),
            "{bad:?}: {a:?}"
        );
    }
    e.handle(s(3.0), Input::Answer(Answer::Magnitude(" 2.5 ".into())));
    let a = drain(&mut e);
    let r = record(&a).expect("recorded");
    let TrialData::MagnitudeEstimation(MagnitudeData {
        magnitude,
        response_time_s,
        ..
    }) = &r.data
    else {
        panic!()
    };
    assert_eq!((*magnitude, *response_time_s), (Some(2.5), Some(3.0)));
    assert_eq!(r.status, Status::Completed);
}

#[test]
fn the_next_trial_waits_until_the_record_is_on_disk() {
    let mut e = engine("magnitude-quick");
    e.handle(s(0.0), Input::Start);
    e.handle(s(0.0), Input::Continue);
    drain(&mut e);
    e.handle(s(1.0), Input::Answer(Answer::Magnitude("4".into())));
    assert!(record(&drain(&mut e)).is_some());
    // Nothing moves until Recorded: no new stimulus, answers ignored.
    e.handle_timeout(s(1.5));
    e.handle(s(1.5), Input::Answer(Answer::Magnitude("5".into())));
    assert!(drain(&mut e).is_empty());
    assert_eq!(e.trial_index(), 0);
    e.handle(s(1.6), Input::Recorded);
    assert_eq!(e.trial_index(), 1);
    assert!(
        drain(&mut e)
            .iter()
            .any(|a| matches!(a, Action::Show(Screen::Explore { .. })))
    );
}

#[test]
fn fitts_counts_hits_inside_the_lit_target_and_logs_every_click() {
    let mut e = engine("fitts-quick");
    // The test starts at 0.5 s: its click times are logged from there.
    e.handle(s(0.5), Input::Start);
    e.handle(s(0.5), Input::Continue);
    let a = drain(&mut e);
    // A = 16 mm, W = 3 mm, D = 1 mm: W' = 2 mm; first lit target at -8 mm.
    assert!(a.iter().any(
        |a| matches!(a, Action::Show(Screen::Targets { lit_m, other_m, .. })
        if (*lit_m + 0.008).abs() < 1e-12 && (*other_m - 0.008).abs() < 1e-12)
    ));
    e.handle(s(1.5), Input::Click { x_m: -0.0085 }); // hit: 0.5 mm from centre, W'/2 = 1 mm
    e.handle(s(2.0), Input::Click { x_m: -0.006 }); // miss: the lit one is now +8 mm
    e.handle(s(2.1), Input::Click { x_m: 0.0065 }); // miss by 0.5 mm
    e.handle(s(2.4), Input::Click { x_m: 0.0075 }); // hit, boundary inclusive would be 0.007
    e.handle(s(2.9), Input::Click { x_m: -0.0079 }); // hit
    e.handle(s(3.5), Input::Click { x_m: 0.0081 }); // fourth hit: done
    let a = drain(&mut e);
    let r = record(&a).expect("done after 4 hits");
    let TrialData::Fitts(FittsData {
        taps,
        errors,
        completion_time_s,
        mean_error_m,
        tap_x_m,
        target_x_m,
        miss_x_m,
        click_times_s,
        click_x_m,
        click_target_x_m,
        click_hit,
        ..
    }) = &r.data
    else {
        panic!()
    };
    assert_eq!((*taps, *errors), (4, 2));
    // Every click, in order, from the test's start (issue 42), with the
    // lit target's centre and whether it hit.
    assert_eq!(click_times_s, &[1.0, 1.5, 1.6, 1.9, 2.4, 3.0]);
    assert_eq!(
        click_x_m,
        &[-0.0085, -0.006, 0.0065, 0.0075, -0.0079, 0.0081]
    );
    assert_eq!(
        click_target_x_m,
        &[-0.008, 0.008, 0.008, 0.008, -0.008, 0.008]
    );
    assert_eq!(click_hit, &[true, false, false, true, true, true]);
    assert!(
        (completion_time_s.unwrap() - 2.0).abs() < 1e-12,
        "first to last hit"
    );
    // Misses: |x - c| - W'/2 = (0.014 - 0.001) and (0.0015 - 0.001).
    assert!((mean_error_m.unwrap() - f64::midpoint(0.013, 0.0005)).abs() < 1e-12);
    assert_eq!(tap_x_m, &[-0.0085, 0.0075, -0.0079, 0.0081]);
    assert_eq!(target_x_m, &[-0.008, 0.008, -0.008, 0.008]);
    assert_eq!(miss_x_m, &[-0.006, 0.0065]);
}

#[test]
fn a_physical_condition_prompts_the_experimenter_and_renders_nothing() {
    let text = std::fs::read_to_string(format!(
        "{}/protocols/fitts.json",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let plan = resolve(&parse(&text).unwrap(), 1, 0);
    let real = plan
        .trials
        .iter()
        .position(|t| format!("{:?}", t.spec).contains("condition: \"real\""))
        .unwrap();
    let mut e = Engine::new(plan, real);
    e.handle(s(0.0), Input::Start);
    let mut a = drain(&mut e);
    if matches!(a[..], [Action::Show(Screen::Instructions(_))]) {
        e.handle(s(0.0), Input::Continue);
        a = drain(&mut e);
    }
    assert!(
        matches!(&a[..], [Action::Prompt(text)] if text.contains("aluminum block")),
        "{a:?}"
    );
    e.handle(s(0.0), Input::Continue);
    let a = drain(&mut e);
    assert!(a.contains(&Action::Render(Some(
        frictionlab::friction::ModelParams::None
    ))));
    assert!(a.iter().any(|a| matches!(a, Action::Physical(Some(_)))));
}

#[test]
fn an_aborted_trial_is_logged_and_presented_again() {
    let mut e = engine("paired-quick");
    e.handle(s(0.0), Input::Start);
    e.handle(s(0.0), Input::Continue);
    e.handle_timeout(s(1.0)); // end of the reference phase
    drain(&mut e);
    e.handle(
        s(1.5),
        Input::Abort {
            reason: "device lost".into(),
            requeue: true,
        },
    );
    let a = drain(&mut e);
    let r = record(&a).unwrap();
    assert_eq!(
        (r.status, r.requeued, r.abort_reason.as_deref()),
        (Status::Aborted, true, Some("device lost"))
    );
    e.handle(s(1.6), Input::Recorded);
    assert_eq!(e.trial_index(), 0, "same trial again");
    e.handle(s(2.0), Input::Switch(1));
    e.handle(s(2.5), Input::Answer(Answer::Paired(Choice::Second)));
    let a = drain(&mut e);
    let r = record(&a).unwrap();
    let TrialData::PairedComparison(PairedData {
        second,
        choice,
        chosen,
        ..
    }) = &r.data
    else {
        panic!()
    };
    assert_eq!(choice, &Some(Choice::Second));
    assert_eq!(chosen.as_deref(), Some(second.as_str()));
    e.handle(s(2.6), Input::Recorded);
    assert!(drain(&mut e).contains(&Action::Finished) && e.is_finished());
}

/// Issue 13: the engine owns its timers (`poll_timeout`/`handle_timeout`);
/// a timeout that is not yet due does nothing, and an expired exploration
/// asks once.
#[test]
fn the_engine_says_when_to_wake_it_and_ignores_early_timeouts() {
    let mut e = engine("magnitude-quick");
    assert_eq!(e.poll_timeout(), None, "nothing is timed before the start");
    e.handle(s(0.0), Input::Start);
    e.handle(s(0.0), Input::Continue);
    drain(&mut e);
    assert_eq!(
        e.poll_timeout(),
        Some(s(2.0)),
        "the exploration ends at 2 s"
    );
    e.handle_timeout(s(1.999));
    assert!(drain(&mut e).is_empty(), "not due yet");
    e.handle_timeout(s(2.0));
    assert_eq!(
        drain(&mut e),
        vec![Action::Render(None), Action::Ask(Question::Magnitude)]
    );
    assert_eq!(e.poll_timeout(), None, "the question waits without a timer");
    e.handle_timeout(s(10.0));
    assert!(drain(&mut e).is_empty(), "an expired exploration asks once");
}

#[test]
fn a_fitts_record_logged_before_clicks_were_logged_still_reads() {
    let old = r#"{"kind":"fitts","condition":"baseline","amplitude_m":0.016,
        "width_m":0.003,"cursor_m":0.001,"effective_width_m":0.002,"id_bits":4.17,
        "completion_time_s":1.2,"taps":4,"errors":0,"mean_error_m":null,
        "tap_times_s":[0.0,0.4,0.8,1.2],"tap_x_m":[-0.008,0.008,-0.008,0.008],
        "target_x_m":[-0.008,0.008,-0.008,0.008],"miss_x_m":[]}"#;
    let TrialData::Fitts(d) = serde_json::from_str::<TrialData>(old).unwrap() else {
        panic!("a Fitts record")
    };
    assert_eq!(d.taps, 4);
    assert!(d.click_times_s.is_empty() && d.click_hit.is_empty());
}
