//! The template for a new kind (docs/adding-a-kind.md), compiled for tests
//! only: a 1-up-1-down
//! staircase over the comparison's static coefficient mu_s. Each trial
//! pairs a stick-slip reference with a comparison whose mu_s exceeds the
//! reference's by the current difference, in an order drawn per trial; the
//! participant picks the one that felt stronger. A pick of the comparison
//! lowers the difference by one step (not below one step), any other
//! answer raises it; the session ends after `reversals` reversals.
//!
//! It reuses the paired comparison's live trial, so it needs no engine or
//! participant code, and shows its pairs on a screen of its own
//! ([`PairScreen`], drawn by `view.rs`'s `SCREEN`): the window draws it
//! with this folder's code, while the simulated participant and the LSL
//! markers take it for the paired comparison's screen, its task. Its trials come from its own
//! [`TrialSource`], whose state (difference, reversals) is rebuilt from the
//! logged answers on resume. Its analysis ([`analysis`]) gives each
//! participant's threshold and their mean; it has no results view
//! (`view.rs`), so the window shows its summary object as a tree.

use std::collections::VecDeque;
use std::sync::Arc;

use frictionlab_psychophysics::decimal;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::analysis::{AnalysisEntry, KindAnalysis, Section};
use crate::friction::ModelParams;
use crate::kinds::magnitude::{Stimulus, stimulus_model};
use crate::kinds::paired::{Compare, Paired, PairedData, PairedTrial};

pub mod view;
use crate::protocol::check::{ValueChecks, MAX_TRIALS};
use crate::protocol::engine::{
    Action, Input, KindScreen, OwnScreen, Screen, Status, TrialRecord, TrialSource,
};
use crate::protocol::kind::{WriteCells, Holds, Kinds, LiveTrial, Next, StudyKind, TrackAnswers};
use crate::protocol::load::{Walk, read_object};
use crate::protocol::plan::PlannedTrial;
use crate::protocol::{Condition, Protocol};
use crate::time::Time;

pub mod analysis;

/// The toy staircase kind.
#[derive(Debug)]
pub struct Staircase;

/// The staircase's design.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StaircaseDesign {
    /// The reference rendering (a stick-slip model).
    pub reference: ModelParams,
    /// First difference of the comparison's mu_s over the reference's.
    pub start_delta: f64,
    /// Step of the difference (also its floor).
    pub step: f64,
    /// Reversals after which the session ends.
    pub reversals: u32,
    /// Longest exploration of each stimulus, s.
    pub exploration_s: f64,
    /// Ends the session after this many trials even before `reversals`
    /// reversals (a cap on its length); none when absent.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub max_trials: Option<u32>,
}

/// One staircase trial: the pair, and the difference it presents.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StaircaseTrial {
    /// The two renderings, in presentation order.
    pub pair: PairedTrial,
    /// The comparison's mu_s minus the reference's.
    pub delta_mu_s: f64,
}

/// What a staircase trial logs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct StaircaseData {
    /// The difference presented.
    pub delta_mu_s: f64,
    /// The answer, as a paired comparison logs it.
    pub answer: PairedData,
}

/// The live trial: a paired comparison that remembers its difference.
#[derive(Debug, Clone)]
pub struct Track {
    compare: Compare,
    delta_mu_s: f64,
}

/// The coefficients of a stick-slip model.
fn coefficients(model: &ModelParams) -> Option<Stimulus> {
    match model {
        ModelParams::StickSlipTactile(p) | ModelParams::StickSlipForce(p) => Some(Stimulus {
            mu_s: p.mu_s,
            mu_k: p.mu_k,
        }),
        _ => None,
    }
}

impl StudyKind for Staircase {
    type Design = StaircaseDesign;
    type Trial = StaircaseTrial;
    type Live = Track;
    type Data = StaircaseData;

    const COLUMNS: &'static [&'static str] = &["delta_mu_s", "first", "second", "choice", "chosen"];

    fn read(w: &mut Walk, v: &Value, path: &str) -> Option<StaircaseDesign> {
        read_object!(w, v, path, ["kind"], StaircaseDesign {
            reference: model_field,
            start_delta: required,
            step: required,
            reversals: required,
            exploration_s: required,
            max_trials: optional(None),
        })
    }

    /// A stick-slip reference, differences of 0.1 in mu_s.
    fn template() -> Value {
        serde_json::json!({
            "kind": "toy_staircase",
            "reference": {"model": "stick-slip-force"},
            "start_delta": 0.3,
            "step": 0.1,
            "reversals": 4,
            "exploration_s": 2.0
        })
    }

    fn check(d: &StaircaseDesign, c: &mut ValueChecks) {
        if coefficients(&d.reference).is_none() {
            c.err("reference.model", "the reference needs a stick-slip model");
        }
        c.positive("start_delta", d.start_delta);
        c.positive("step", d.step);
        c.positive_duration("exploration_s", d.exploration_s);
        if let Some(m) = d.max_trials {
            c.at_most("max_trials", "the session's trials", u64::from(m), MAX_TRIALS);
        }
        if d.max_trials == Some(0) {
            c.err("max_trials", "must be at least 1");
        }
        if d.reversals == 0 {
            c.err("reversals", "must be at least 1");
        }
    }

    /// None: the track makes its trials.
    fn trials_per_repetition(_: &StaircaseDesign) -> u64 {
        0
    }

    fn source<K: Holds<Self>>(
        _protocol: &Protocol<K>,
        design: &StaircaseDesign,
        seed: u64,
        _participant_index: u32,
    ) -> Arc<dyn TrialSource<K>> {
        Arc::new(Source {
            design: design.clone(),
            seed,
        })
    }

    fn loop_rate_hz(t: &StaircaseTrial) -> f64 {
        Paired::loop_rate_hz(&t.pair)
    }

    /// The one track: each completed trial's difference, marked when the
    /// comparison was picked.
    fn tracks<K: Holds<Self>>(history: &[TrialRecord<K>]) -> Vec<TrackAnswers> {
        let answers: Vec<(f64, bool)> = history
            .iter()
            .filter(|r| !r.requeued && r.status == Status::Completed)
            .filter_map(|r| K::data_of(&r.data))
            .map(|d| (d.delta_mu_s, d.answer.chosen.as_deref() == Some("comparison")))
            .collect();
        if answers.is_empty() {
            return Vec::new();
        }
        vec![TrackAnswers {
            track: 0,
            name: "difference in mu_s".to_owned(),
            answers,
        }]
    }

    fn start<K: Kinds>(t: &StaircaseTrial, now: Time, out: &mut VecDeque<Action<K>>) -> Track {
        Track {
            compare: own_screens(out, |out| <Paired as StudyKind>::start(&t.pair, now, out)),
            delta_mu_s: t.delta_mu_s,
        }
    }

    fn row<W: WriteCells>(d: &StaircaseData, out: &mut W) {
        out.num(d.delta_mu_s);
        Paired::row(&d.answer, out);
    }
}

impl LiveTrial for Track {
    type Data = StaircaseData;

    fn timeout(&self) -> Option<Time> {
        self.compare.timeout()
    }

    fn on_timeout<K: Kinds>(&mut self, now: Time, out: &mut VecDeque<Action<K>>) -> Next {
        own_screens(out, |out| self.compare.on_timeout(now, out))
    }

    fn on_input<K: Kinds>(
        &mut self,
        now: Time,
        input: Input,
        out: &mut VecDeque<Action<K>>,
    ) -> Next {
        own_screens(out, |out| self.compare.on_input(now, input, out))
    }

    fn data(&self, started: Time, now: Time, completed: bool) -> StaircaseData {
        StaircaseData {
            delta_mu_s: self.delta_mu_s,
            answer: self.compare.data(started, now, completed),
        }
    }
}

/// The staircase's own screen: the pair of a trial, stimulus `active`
/// (0 first, 1 second) rendered until `until`. Its task is the paired
/// comparison's screen it replaces.
#[derive(Debug, Clone, PartialEq)]
pub struct PairScreen {
    /// The stimulus rendered.
    pub active: usize,
    /// End of the exploration (session time).
    pub until: Time,
}

impl KindScreen for PairScreen {
    fn name(&self) -> &'static str {
        "staircase_pair"
    }

    fn task(&self) -> Screen {
        Screen::Paired {
            active: self.active,
            until: self.until,
            forced: None,
        }
    }
}

/// Runs `push` (the paired comparison's live trial pushing its actions)
/// and shows the screens it pushed as the staircase's own.
fn own_screens<K: Kinds, R>(
    out: &mut VecDeque<Action<K>>,
    push: impl FnOnce(&mut VecDeque<Action<K>>) -> R,
) -> R {
    let from = out.len();
    let pushed = push(out);
    for action in out.iter_mut().skip(from) {
        if let Action::Show(Screen::Paired {
            active,
            until,
            forced: None,
        }) = action
        {
            *action = Action::ShowOwn(OwnScreen::new(PairScreen {
                active: *active,
                until: *until,
            }));
        }
    }
    pushed
}

/// The staircase's trials: a pure function of the design, the plan seed
/// and the logged answers.
#[derive(Debug)]
struct Source {
    design: StaircaseDesign,
    seed: u64,
}

impl Source {
    /// Replays the logged answers: the current difference and the reversals
    /// so far.
    fn track<K: Holds<Staircase>>(&self, history: &[TrialRecord<K>]) -> (f64, u32) {
        let d = &self.design;
        let (mut delta, mut reversals, mut last) = (d.start_delta, 0, None);
        for r in history
            .iter()
            .filter(|r| !r.requeued && r.status == Status::Completed)
        {
            let Some(data) = K::data_of(&r.data) else {
                continue;
            };
            let down = data.answer.chosen.as_deref() == Some("comparison");
            if last.is_some_and(|l| l != down) {
                reversals += 1;
            }
            last = Some(down);
            delta = if down {
                decimal::sub(delta, d.step)
            } else {
                decimal::add(delta, d.step)
            }
            .max(d.step);
        }
        (delta, reversals)
    }
}

impl<K: Holds<Staircase>> TrialSource<K> for Source {
    fn trial(&self, index: usize, history: &[TrialRecord<K>]) -> Option<PlannedTrial<K>> {
        let d = &self.design;
        let (delta, reversals) = self.track(history);
        let base = coefficients(&d.reference)?;
        if reversals >= d.reversals || d.max_trials.is_some_and(|m| index >= m as usize) {
            return None;
        }
        let with = |id: &str, mu_s: f64| Condition {
            id: id.into(),
            model: stimulus_model(&d.reference, Stimulus { mu_s, ..base }),
        };
        let (reference, comparison) = (
            with("reference", base.mu_s),
            with("comparison", decimal::add(base.mu_s, delta)),
        );
        let seed = (self.seed ^ index as u64).wrapping_mul(0x9e37_79b9_7f4a_7c15);
        let (first, second) = if seed >> 63 == 0 {
            (reference, comparison)
        } else {
            (comparison, reference)
        };
        Some(PlannedTrial {
            index,
            block: "staircase".into(),
            block_index: 0,
            practice: false,
            repetition: 0,
            seed,
            spec: K::wrap_trial(StaircaseTrial {
                pair: PairedTrial {
                    first,
                    second,
                    exploration_s: d.exploration_s,
                },
                delta_mu_s: delta,
            }),
        })
    }

    fn planned(&self) -> Option<usize> {
        None
    }

    fn loop_rate_hz(&self) -> f64 {
        self.design.reference.loop_rate_hz()
    }
}

/// Each participant's threshold and their mean ([`analysis`]); no report
/// section beyond the tables.
impl KindAnalysis for Staircase {
    fn analysis<K: Holds<Self>>() -> Option<AnalysisEntry<K>> {
        Some(AnalysisEntry {
            marker: "delta_mu_s",
            unread: &["first", "second", "choice", "chosen"],
            optional: &[],
            counts_aborted: false,
            counted: analysis::counted,
            run: |rows, _| {
                let t = analysis::analyze(rows)?;
                Ok(Section::new(String::new(), t.summary, t.notes, t.tables))
            },
        })
    }
}

#[cfg(test)]
#[allow(
    clippy::unwrap_used,
    clippy::expect_used,
    reason = "a failed unwrap is a failed test"
)]
mod tests {
    use std::path::Path;
    use std::process::Command;
    use std::time::Duration;

    use super::{StaircaseData, StaircaseTrial};
    use crate::device::DeviceSample;
    use crate::hand::HandDrive;
    use crate::kinds::{Action, PlannedTrial, TrialData, TrialSpec};
    use crate::protocol::engine::{Answer, Choice, Input, Question, Screen};
    use crate::results::{ResultsDir, read_log};
    use crate::time::Time;
    use crate::session::{
        DeviceChoice, Reaction, Responder, SessionRequest, plan as plan_session, run_planned,
    };

    /// The test observer's threshold: it picks the comparison when the
    /// difference is at least this.
    const THRESHOLD: f64 = 0.15;

    /// The toy protocol: reference mu_s 0.6 on seed 001's tactile model (as
    /// in `protocols/magnitude-quick.json`),
    /// difference from 0.4 in steps of 0.1, 4 reversals.
    const PROTOCOL: &str = r#"{
        "id": "stairs", "title": "Toy staircase",
        "design": {
            "kind": "toy_staircase",
            "reference": {"model": "stick-slip-tactile", "mass_kg": 0.00016,
                "stiffness_n_m": 63.0, "damping_n_s_m": 0.001, "normal_load_n": 0.016,
                "mu_s": 0.6, "mu_k": 0.3},
            "start_delta": 0.4, "step": 0.1, "reversals": 4, "exploration_s": 3.0
        }
    }"#;

    /// An observer that continues past every screen and, asked, picks the
    /// comparison when the difference is at least [`THRESHOLD`].
    struct Observer;

    impl Responder for Observer {
        const LABEL: &'static str = "sim";
        fn hand_mass_kg(&self) -> f64 {
            0.4
        }
        fn on_action(&mut self, _: Time, action: &Action, trial: Option<&PlannedTrial>) -> Reaction {
            let inputs = match (action, trial.map(|t| &t.spec)) {
                (Action::Show(Screen::Instructions(_)), _) => vec![Input::Continue],
                (
                    Action::Ask(Question::PairedChoice),
                    Some(TrialSpec::Staircase(StaircaseTrial { pair, delta_mu_s })),
                ) => {
                    let picks_comparison = *delta_mu_s >= THRESHOLD - 1e-9;
                    let comparison_first = pair.first.id == "comparison";
                    let choice = if picks_comparison == comparison_first {
                        Choice::First
                    } else {
                        Choice::Second
                    };
                    vec![Input::Answer(Answer::Paired(choice))]
                }
                _ => vec![],
            };
            Reaction {
                inputs,
                reset_to: None,
            }
        }
        fn decide(&mut self, _: Time, _: &DeviceSample) -> Reaction {
            Reaction::default()
        }
        fn drive(&self, _: Time, _: &DeviceSample) -> Option<HandDrive> {
            None
        }
        fn hand_force(&mut self, _: Time, _: f64, _: &DeviceSample) -> f64 {
            0.0
        }
    }

    /// The toy protocol, read.
    fn protocol() -> crate::kinds::Protocol {
        crate::protocol::load::parse::<crate::kinds::Registry>(PROTOCOL).unwrap()
    }

    /// A session of `protocol` for participant p1 on the simulated device.
    fn request(
        protocol: &crate::kinds::Protocol,
        resume: bool,
        pace: Option<f64>,
    ) -> SessionRequest<'_> {
        SessionRequest {
            protocol,
            protocol_bytes: PROTOCOL.as_bytes(),
            participant: "p1",
            participant_index: Some(0),
            seed: 1,
            resume,
            pace,
            device: &DeviceChoice::Simulated,
            streams: false,
            population: None,
            sound: crate::session::sound::Sound::default(),
            lsl: None,
        }
    }

    /// Runs (or resumes) the staircase session in `out`, paced.
    fn run(out: &Path, resume: bool, pace: Option<f64>) {
        let protocol = protocol();
        let dir = ResultsDir::new(out);
        let req = request(&protocol, resume, pace);
        let planned = plan_session(&dir, &req, Observer::LABEL).unwrap();
        run_planned(&dir, planned, pace, |_| Observer, None, &mut |_, _| {}).unwrap();
    }

    /// The window draws the staircase's pairs with its own screen, reached
    /// through the registry (the window names no kind), and passes on what
    /// the participant clicks; the session takes the screen for the paired
    /// comparison's, its task, and asks the paired choice.
    #[test]
    fn the_window_draws_the_pairs_with_the_kinds_own_screen() {
        use egui_kittest::Harness;
        use egui_kittest::kittest::Queryable;

        use crate::gui::Command;
        use crate::session::LiveSession;

        let dir = tempfile::tempdir().unwrap();
        let protocol = protocol();
        let req = request(&protocol, false, None);
        let mut live = LiveSession::start(&ResultsDir::new(dir.path()), &req).unwrap();
        for _ in 0..100_000 {
            if live.view().own.is_some() {
                break;
            }
            live.feed(crate::session::Feed::Tick).unwrap();
        }
        let own = live.view().own.clone().expect("the first pair shown");
        assert_eq!(own.name(), "staircase_pair");
        assert!(matches!(
            live.view().screen,
            Some(Screen::Paired { active: 0, .. })
        ));
        let mut h = Harness::new_ui_state(
            |ui, (live, commands): &mut (LiveSession, Vec<Command>)| {
                crate::gui::participant::show(ui, live, &mut String::new(), commands, &mut None);
            },
            (live, Vec::new()),
        );
        h.get_by_label("Stimulus 1 of 2");
        h.get_by_label("Feel stimulus 2").click();
        h.run();
        // The workspace under it reports where the pointer is; the screen's
        // input is the one other command.
        let inputs: Vec<&Command> =
            h.state().1.iter().filter(|c| !matches!(c, Command::HandTarget(_))).collect();
        assert_eq!(inputs, [&Command::Input(Input::Switch(1))]);
    }

    /// The simulated participant does what the staircase's own screen
    /// asks, its task: the same as for the paired comparison's screen.
    #[test]
    fn the_simulated_participant_does_the_own_screens_task() {
        use crate::participant::{Population, SimParticipant};
        use crate::protocol::engine::OwnScreen;

        let (now, until) = (Time::from_whole_secs(1), Time::from_whole_secs(4));
        let own = Action::ShowOwn(OwnScreen::new(super::PairScreen { active: 0, until }));
        let task = Action::Show(Screen::Paired {
            active: 0,
            until,
            forced: None,
        });
        let react = |action: &Action| {
            let mut p = SimParticipant::new(7, "p1", &Population::default());
            let reaction = p.on_action(now, action, None);
            (reaction, p.decide(now, &DeviceSample::default()))
        };
        let (reaction, decided) = react(&own);
        // Told to slide from its start, as the paired screen tells it.
        assert!(reaction.reset_to.is_some());
        assert_eq!((reaction, decided), react(&task));
    }

    const CHILD_ENV: &str = "FRICTIONLAB_TOY_STAIRCASE_OUT";

    /// The session process that `the_toy_kind_resumes_exactly_after_kill_9`
    /// kills.
    #[test]
    #[ignore = "run as a child process by the_toy_kind_resumes_exactly_after_kill_9"]
    fn toy_staircase_child() {
        let out = std::env::var(CHILD_ENV).expect("run by the kill -9 test");
        run(Path::new(&out), std::env::var("RESUME").is_ok(), Some(20.0));
    }

    fn log_path(out: &Path) -> std::path::PathBuf {
        out.join("logs/study-stairs_subject-p1_session-1_log.jsonl")
    }

    fn csv(out: &Path) -> String {
        std::fs::read_to_string(out.join("data/study-stairs_subject-p1_session-1_data.csv"))
            .unwrap()
    }

    /// (difference, comparison chosen) per logged trial.
    fn track(out: &Path) -> Vec<(f64, bool)> {
        read_log::<crate::kinds::Registry>(&log_path(out))
            .unwrap()
            .trials
            .iter()
            .map(|r| match &r.data {
                TrialData::Staircase(StaircaseData { delta_mu_s, answer }) => {
                    (*delta_mu_s, answer.chosen.as_deref() == Some("comparison"))
                }
                other => panic!("a staircase record, got {other:?}"),
            })
            .collect()
    }

    #[test]
    fn the_toy_kind_runs_logs_and_stops_after_four_reversals() {
        let dir = tempfile::tempdir().unwrap();
        run(dir.path(), false, None);
        // 0.4 c, 0.3 c, 0.2 c, 0.1 w (1), 0.2 c (2), 0.1 w (3), 0.2 c (4): stop.
        let track = track(dir.path());
        // The design's decimals, exactly (issue 42).
        let deltas: Vec<f64> = track.iter().map(|t| t.0).collect();
        let picks: Vec<bool> = track.iter().map(|t| t.1).collect();
        assert_eq!(deltas, [0.4, 0.3, 0.2, 0.1, 0.2, 0.1, 0.2]);
        assert_eq!(picks, [true, true, true, false, true, false, true]);
        let log = read_log::<crate::kinds::Registry>(&log_path(dir.path())).unwrap();
        assert!(log.ended);
        assert_eq!(log.header.planned_trials, 0, "unknown in advance");
        // The experimenter's live plot gets the same track, through the
        // registry (the window names no kind).
        let records: Vec<_> = log.trials.iter().map(|t| t.record.clone()).collect();
        let plotted = crate::kinds::Registry::tracks(&records);
        assert_eq!(plotted.len(), 1);
        assert_eq!(plotted[0].answers, track);
        let csv = csv(dir.path());
        let mut lines = csv.lines();
        assert!(
            lines
                .next()
                .unwrap()
                .ends_with(",delta_mu_s,first,second,choice,chosen")
        );
        assert_eq!(lines.count(), 7);
    }

    #[test]
    fn the_toy_kind_resumes_exactly_after_kill_9() {
        let whole = tempfile::tempdir().unwrap();
        run(whole.path(), false, None);
        let dir = tempfile::tempdir().unwrap();
        let child = |resume: bool| {
            let mut c = Command::new(std::env::current_exe().unwrap());
            c.args([
                "--ignored",
                "--exact",
                "kinds::staircase::tests::toy_staircase_child",
                "--test-threads",
                "1",
            ])
            .env(CHILD_ENV, dir.path());
            if resume {
                c.env("RESUME", "1");
            }
            c
        };
        // Paced 20x: a trial (6 s of exploration) takes about 0.3 s. Killed
        // after some trials are logged, then resumed until it ends.
        let mut first = child(false).spawn().unwrap();
        let start = std::time::Instant::now();
        while read_log::<crate::kinds::Registry>(&log_path(dir.path()))
            .map_or(0, |l| l.trials.len())
            < 3
            && start.elapsed().as_secs() < 60
        {
            std::thread::sleep(Duration::from_millis(5));
        }
        std::thread::sleep(Duration::from_millis(120));
        first.kill().unwrap(); // SIGKILL
        first.wait().unwrap();
        let logged = read_log::<crate::kinds::Registry>(&log_path(dir.path())).unwrap();
        assert!(!logged.ended && (3..7).contains(&logged.trials.len()));
        let o = child(true).output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stdout));
        assert_eq!(track(dir.path()), track(whole.path()));
        assert_eq!(csv(dir.path()), csv(whole.path()), "byte-identical data");
    }

    /// The seam of issue 37: the window's protocol builder draws this
    /// kind's form from this folder alone (its design's fields and doc
    /// comments, its template). Every field of `StaircaseDesign` is on the
    /// form of a new toy staircase, and the new protocol is valid; a field
    /// added here is on the form with no change anywhere else.
    #[test]
    fn the_builder_shows_every_field_of_the_staircase_design_from_this_folder() {
        use eframe::egui;
        use egui_kittest::Harness;
        use egui_kittest::kittest::Queryable;

        use crate::gui::{FrictionlabApp, Launch};

        let schema = serde_json::to_value(schemars::schema_for!(super::StaircaseDesign)).unwrap();
        let fields: Vec<String> = schema["properties"]
            .as_object()
            .unwrap()
            .keys()
            .filter(|k| *k != "kind")
            .cloned()
            .collect();
        assert!(fields.len() >= 5, "{fields:?}");
        let mut h = Harness::builder()
            .with_size(egui::vec2(1600.0, 2400.0))
            .build_eframe(|_cc| FrictionlabApp::new(Launch::default()));
        for label in ["Build a protocol", "toy_staircase"] {
            h.get_by_label(label).click();
            h.step();
            h.step();
        }
        h.get_by_label("ok: toy_staircase 'new-toy-staircase', trials set by the answers");
        for key in &fields {
            let with_unit = crate::protocol::form::unit(key).map(|u| format!("{key} ({u})"));
            let shown = h.query_by_label(key).is_some()
                || with_unit.is_some_and(|l| h.query_by_label(&l).is_some());
            assert!(shown, "the builder does not show '{key}'");
        }
    }

    #[test]
    fn max_trials_ends_the_staircase_before_its_reversals() {
        use crate::kinds::Registry;
        use crate::protocol::kind::Kinds;
        let mut v = crate::protocol::form::new_protocol::<Registry>("toy_staircase").unwrap();
        v["design"]["max_trials"] = 2.into();
        let protocol = crate::protocol::load::parse::<Registry>(&v.to_string()).unwrap();
        let source = Registry::source(&protocol, 1, 0);
        assert!(source.trial(1, &[]).is_some());
        assert!(source.trial(2, &[]).is_none());
        v["design"]["max_trials"] = 0.into();
        let problems = crate::protocol::load::parse::<Registry>(&v.to_string()).unwrap_err();
        assert_eq!(problems[0].place, "design.max_trials", "{problems:?}");
    }
}
