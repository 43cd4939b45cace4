//! The simulated population: the ranges participants' traits are drawn
//! from, each with its source or marked free.

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};

use crate::protocol::Protocol;
use crate::protocol::kind::Kinds;

/// A closed range `[low, high]` a trait is drawn from, uniformly.
pub type Range = [f64; 2];

/// The simulated population: the ranges participants' traits are drawn
/// from, and the constants no source gives (free; swept in
/// `analysis/claims.md`). SI units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Population {
    /// Hand (and arm) mass moving with the device, kg. [0.3, 1.0]: of the
    /// order of the arm's effective mass at the hand (Hogan 1985); seed 000
    /// takes 1 kg. Free within that order.
    pub hand_mass_kg: Range,
    /// Hand stiffness, N/m. [200, 800]: the range reported for a hand
    /// holding a stylus or handle (e.g. Kuchenbecker, Park & Niemeyer 2003;
    /// seed 000 uses 300). Free within it; swept.
    pub hand_stiffness_n_m: Range,
    /// Hand damping, N s/m. [10, 40] (same sources; seed 000 uses 20).
    /// Free within it; swept.
    pub hand_damping_n_s_m: Range,
    /// Motor noise `K`, s: a submovement's aim scatters with SD `K D / T`
    /// for amplitude `D` and duration `T` (the form: Meyer, Abrams,
    /// Kornblum, Wright & Smith 1988; Harris & Wolpert 1998). No source at
    /// hand gives `K`: free, swept. [0.01, 0.02] is the middle of the
    /// previous free range (an SD of 4-8 % of the amplitude in 0.2-0.3 s
    /// submovements: `K` of 0.008-0.024 s) in the law's form, set before
    /// any replay of issue 44.
    pub motor_noise_s: Range,
    /// Time to press, and to release, the click button, s: the
    /// Keystroke-Level Model's `B`, 0.1 s (Card, Moran & Newell 1980;
    /// Kieras 2001). A click is a press and a release.
    pub button_s: f64,
    /// Visual feedback delay before a correction, s. [0.1, 0.2] (Keele &
    /// Posner 1968; Carlton 1981).
    pub feedback_s: Range,
    /// Position perception noise (SD), m. [1e-4, 3e-4]: a tenth to a third
    /// of a millimetre on the display (free; swept with the other
    /// perceptual noises).
    pub position_sd_m: Range,
    /// Force Weber fraction. [0.07, 0.15] (Jones 1989; Pang, Tan & Durlach
    /// 1991).
    pub force_weber: Range,
    /// Weber fraction of the hand's own displacement (kinesthetic), for
    /// stiffness. [0.10, 0.18]: amplitude thresholds of index-finger
    /// movements of 6-19 mm (Rinker, Craig & Bernstein 1998, J. Acoust.
    /// Soc. Am.; abstract only at hand).
    pub displacement_weber: Range,
    /// Weber fraction of the hand's own velocity (kinesthetic), for
    /// viscosity. No source at hand measures it directly; [0.12, 0.24] is
    /// a speed judged as amplitude over period from the same study's
    /// amplitude (10-18 %) and period (6-16 %) thresholds, independent:
    /// sqrt(0.10^2 + 0.06^2) to sqrt(0.18^2 + 0.16^2). Swept.
    pub velocity_weber: Range,
    /// Vibration amplitude Weber fraction. [0.15, 0.3] (Gescheider et al.
    /// 1990: about 1.5 dB).
    pub vibration_weber: Range,
    /// Stevens exponent of magnitude estimates of friction. [0.6, 1.1]
    /// (free: no source gives one for friction).
    pub stevens_exponent: Range,
    /// Stevens exponent of magnitude estimates of viscosity. [0.42, 0.46]:
    /// stirring and shaking silicone fluids by three methods (Stevens &
    /// Guirao 1964, Science 144:1157-1158; abstract at hand). Calibration:
    /// the viscosity exponent's validation row measures this input.
    pub viscosity_exponent: Range,
    /// Stevens exponent of magnitude estimates of stiffness. 0.8:
    /// squeezing rubber (Harper & Stevens 1964, in Stevens' table of
    /// exponents; not at hand). No protocol shipped asks for it.
    pub stiffness_exponent: Range,
    /// SD of ln of a magnitude estimate. [0.1, 0.25] (free).
    pub answer_noise: Range,
    /// Break-away weight `w` of the friction percept (free, 0.5).
    pub breakaway_weight: f64,
    /// Force a full-scale vibrotactile drive feels like, N (free, 0.1; no
    /// source gives it: results are reported as a function of it).
    pub tactile_gain_n: f64,
    /// Vibration floor of the paired percept, N (free, 0.05).
    pub vibration_floor_n: f64,
    /// Distance difference answered "no difference", JND (free, 1).
    pub no_difference_jnd: f64,
    /// Finger-on-desk friction coefficient of the reference phase (free,
    /// 0.6).
    pub desk_mu: f64,
    /// Normal force on the desk, N (seed 000's 3 N).
    pub desk_normal_n: f64,
    /// An assumed effect, not a mechanism: when set, in a paired comparison
    /// the participant still explores both renderings but then calls the
    /// named condition nearer with probability `p` and the other one
    /// otherwise (never "no difference"); a pair without that condition is
    /// answered from the percept. For power planning under an effect size
    /// the experimenter assumes, and for known-answer tests of it (power is
    /// then a binomial tail). Absent by default, and never set in the
    /// reproductions (`analysis/`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub paired_preference: Option<PairedPreference>,
    /// Retired by issue 44 (the constant duration of a submovement and the
    /// motor noise as a fraction of the amplitude): still read, so that a
    /// population file or a session log written before keeps loading, and
    /// ignored.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motor_noise: Option<Range>,
    /// Retired by issue 44; see [`Population::motor_noise`].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub submovement_s: Option<Range>,
    /// The Fitts hand as a feedback controller (issue 65,
    /// `participant::feedback`) in place of the optimised submovements of
    /// `participant::movement`, with its own free constants. Absent by
    /// default: the reproductions keep the submovement hand until the
    /// feedback hand handles friction (its timeouts under friction are
    /// counted in `docs/guide/validation.md`). `{"feedback": {}}` turns it
    /// on with the defaults below.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub feedback: Option<Feedback>,
}

/// The free constants of the feedback-controlled Fitts hand
/// ([`Population::feedback`]), each drawn per participant. SI units.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields, default)]
pub struct Feedback {
    /// The noise of the controller's command: SD per unit of command, the
    /// command being the speed of the central equilibrium point
    /// (`participant::limb`; signal-dependent: Harris & Wolpert 1998;
    /// Todorov 2005). No source at hand gives it for this command: free.
    /// [0.2, 0.5]: a shift of `D` at a steady speed over `T`, in 10 ms
    /// steps, scatters by `c D sqrt(0.01 s / T)` before any correction;
    /// with `T` of 0.2-0.3 s that is the 4-8 % of the amplitude issue 44's
    /// model took for a submovement's scatter. Set before the first
    /// replay.
    pub command_noise: Range,
    /// The controller's weight on its squared command, s², against a
    /// weight of 1 per m² on the squared distance to the target: how much
    /// the participant minds effort against being off the target (the
    /// cost of Qian, Jiang, Jiang & Mazzoni 2013). No source gives it for
    /// this plant: free. [1e-7, 1e-5]: a decade either side of the weight
    /// with which the limb's noise-free test reach settles within a few
    /// hundred milliseconds. Set before the first replay.
    pub effort_weight: Range,
    /// How sure the participant wants to be that the cursor is inside
    /// before it clicks, as a share of the most it can be sure of at that
    /// target (`participant::feedback`). A speed-accuracy setting people
    /// choose; no source gives it: free. [0.75, 0.95]. The ISO 9241-9
    /// convention of about 4 % misses at the nominal width is a validation
    /// row, not this input. Set before the first replay.
    pub click_criterion: Range,
}

impl Default for Feedback {
    fn default() -> Self {
        Feedback {
            command_noise: [0.2, 0.5],
            effort_weight: [1e-7, 1e-5],
            click_criterion: [0.75, 0.95],
        }
    }
}

/// A set preference in paired comparisons ([`Population::paired_preference`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct PairedPreference {
    /// The preferred condition's id.
    pub condition: String,
    /// Probability of calling it nearer, in [0, 1].
    pub p: f64,
}

impl Default for Population {
    fn default() -> Self {
        Population {
            hand_mass_kg: [0.3, 1.0],
            hand_stiffness_n_m: [200.0, 800.0],
            hand_damping_n_s_m: [10.0, 40.0],
            motor_noise_s: [0.01, 0.02],
            button_s: 0.1,
            feedback_s: [0.1, 0.2],
            position_sd_m: [1e-4, 3e-4],
            force_weber: [0.07, 0.15],
            displacement_weber: [0.10, 0.18],
            velocity_weber: [0.12, 0.24],
            vibration_weber: [0.15, 0.3],
            stevens_exponent: [0.6, 1.1],
            viscosity_exponent: [0.42, 0.46],
            stiffness_exponent: [0.8, 0.8],
            answer_noise: [0.1, 0.25],
            breakaway_weight: 0.5,
            tactile_gain_n: 0.1,
            vibration_floor_n: 0.05,
            no_difference_jnd: 1.0,
            desk_mu: 0.6,
            desk_normal_n: 3.0,
            paired_preference: None,
            motor_noise: None,
            submovement_s: None,
            feedback: None,
        }
    }
}

impl Population {
    /// Every invalid field, as (field, what).
    #[must_use]
    pub fn problems(&self) -> Vec<(String, String)> {
        let mut out = Vec::new();
        let mut ranges = vec![
            ("hand_mass_kg", self.hand_mass_kg),
            ("hand_stiffness_n_m", self.hand_stiffness_n_m),
            ("hand_damping_n_s_m", self.hand_damping_n_s_m),
            ("motor_noise_s", self.motor_noise_s),
            ("feedback_s", self.feedback_s),
            ("position_sd_m", self.position_sd_m),
            ("force_weber", self.force_weber),
            ("displacement_weber", self.displacement_weber),
            ("velocity_weber", self.velocity_weber),
            ("vibration_weber", self.vibration_weber),
            ("stevens_exponent", self.stevens_exponent),
            ("viscosity_exponent", self.viscosity_exponent),
            ("stiffness_exponent", self.stiffness_exponent),
            ("answer_noise", self.answer_noise),
        ];
        if let Some(f) = &self.feedback {
            ranges.extend([
                ("feedback.command_noise", f.command_noise),
                ("feedback.effort_weight", f.effort_weight),
                ("feedback.click_criterion", f.click_criterion),
            ]);
        }
        for (name, [lo, hi]) in ranges {
            if !(lo.is_finite() && hi.is_finite() && lo >= 0.0 && lo <= hi) {
                out.push((
                    name.to_owned(),
                    format!("must be [low, high] with 0 <= low <= high, got [{lo}, {hi}]"),
                ));
            }
        }
        let mut positive = vec![
            ("hand_mass_kg", self.hand_mass_kg[0]),
            ("motor_noise_s", self.motor_noise_s[0]),
        ];
        if let Some(f) = &self.feedback {
            positive.push(("feedback.effort_weight", f.effort_weight[0]));
        }
        for (name, lo) in positive {
            if lo <= 0.0 {
                out.push((name.to_owned(), "must be above 0".to_owned()));
            }
        }
        if let Some(f) = &self.feedback
            && f.click_criterion[1] >= 1.0
        {
            out.push((
                "feedback.click_criterion".to_owned(),
                "must be below 1 (a probability no estimate reaches for sure)".to_owned(),
            ));
        }
        let scalars = [
            ("breakaway_weight", self.breakaway_weight, 1.0),
            ("button_s", self.button_s, 10.0),
            ("tactile_gain_n", self.tactile_gain_n, f64::INFINITY),
            ("vibration_floor_n", self.vibration_floor_n, f64::INFINITY),
            ("no_difference_jnd", self.no_difference_jnd, f64::INFINITY),
            ("desk_mu", self.desk_mu, f64::INFINITY),
            ("desk_normal_n", self.desk_normal_n, f64::INFINITY),
        ];
        for (name, v, max) in scalars {
            if !(v.is_finite() && v >= 0.0 && v <= max) {
                out.push((name.to_owned(), format!("must be in [0, {max}], got {v}")));
            }
        }
        if let Some(pref) = &self.paired_preference {
            if !(pref.p.is_finite() && (0.0..=1.0).contains(&pref.p)) {
                out.push((
                    "paired_preference.p".to_owned(),
                    format!("must be in [0, 1], got {}", pref.p),
                ));
            }
            if pref.condition.is_empty() {
                out.push((
                    "paired_preference.condition".to_owned(),
                    "must name a condition".to_owned(),
                ));
            }
        }
        out
    }

    /// Its problems with `protocol`, as (field, what): a paired preference
    /// must name one of a paired comparison's conditions.
    #[must_use]
    pub fn protocol_problems<K: Kinds>(&self, protocol: &Protocol<K>) -> Vec<(String, String)> {
        let Some(pref) = &self.paired_preference else {
            return Vec::new();
        };
        let what = match K::preferable(&protocol.design) {
            Some(ids) => {
                if ids.contains(&pref.condition.as_str()) {
                    return Vec::new();
                }
                format!(
                    "'{}' is not a condition of protocol '{}' ({})",
                    pref.condition,
                    protocol.id,
                    ids.join(", ")
                )
            }
            None => format!(
                "a paired preference, but protocol '{}' is not a paired comparison",
                protocol.id
            ),
        };
        vec![("paired_preference.condition".to_owned(), what)]
    }
}

/// Reads a population file (JSON: any of [`Population`]'s fields; the rest
/// keep their defaults), with every problem named by file and place.
///
/// # Errors
/// Unreadable file, invalid JSON (line:col), unknown or mistyped field, or
/// a value out of range (its JSON path).
pub fn read(path: &std::path::Path) -> Result<Population, Vec<crate::problem::Problem>> {
    use crate::problem::Problem;
    let file = path.display().to_string();
    let population: Population = crate::problem::read_json_file(path).map_err(|e| vec![e])?;
    let problems: Vec<Problem> = population
        .problems()
        .into_iter()
        .map(|(field, what)| Problem::new(format!("{file}: $.{field}"), what))
        .collect();
    if problems.is_empty() {
        Ok(population)
    } else {
        Err(problems)
    }
}
