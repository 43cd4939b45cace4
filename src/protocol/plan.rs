//! Stage 2 of loading a protocol: resolve it into a session plan holding
//! every trial in presentation order, drawn from the seed before the first
//! trial starts.
//!
//! # Randomization (with a `ChaCha8` generator seeded by the plan seed)
//! - Blocks: paired comparison has one block (`main`); magnitude estimation
//!   one per set (named by its display); Fitts a `practice` block (if any)
//!   followed by `main`. Non-practice blocks are ordered as listed, or by a
//!   balanced Latin square (Williams design) row picked by the participant
//!   index (`block_order: latin_square`); practice always comes first.
//! - Trials within a block: `sequential` repeats the list; `random` shuffles
//!   it anew for each repetition; `full_random` shuffles all repetitions
//!   together.
//! - Paired comparison: the two members of each pair are presented in an
//!   order drawn per trial (the seed's "random order").
//! - Each trial gets its own seed, drawn last, so the randomness inside a
//!   trial (a simulated participant's noise) depends only on (plan seed,
//!   trial) and a resumed session replays it exactly.

use rand::{Rng, RngExt, SeedableRng, seq::SliceRandom};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::load::stimulus_model;
use super::{BlockOrder, Condition, Design, Kind, Protocol, Randomization};
use crate::friction::ModelParams;

/// Every trial of a session, in presentation order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Plan {
    /// The protocol the plan was drawn from.
    pub protocol: Protocol,
    /// The plan seed.
    pub seed: u64,
    /// The participant's index for counterbalancing (0-based).
    pub participant_index: u32,
    /// Block names in session order.
    pub blocks: Vec<String>,
    /// The trials.
    pub trials: Vec<PlannedTrial>,
}

/// One trial of the plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlannedTrial {
    /// 0-based presentation order.
    pub index: usize,
    /// Block name.
    pub block: String,
    /// Position of the block in the session, 0-based.
    pub block_index: usize,
    /// Practice trials are excluded from analysis.
    pub practice: bool,
    /// Which repetition of its block's list, 0-based.
    pub repetition: u32,
    /// Seed for everything random inside the trial.
    pub seed: u64,
    /// What the trial presents.
    pub spec: TrialSpec,
}

/// What a trial presents, by kind.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum TrialSpec {
    /// Two renderings, in presentation order.
    PairedComparison(PairedTrial),
    /// One stimulus.
    MagnitudeEstimation(MagnitudeTrial),
    /// One reciprocal tapping test.
    Fitts(FittsTrial),
}

/// One paired-comparison trial: two renderings, in presentation order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PairedTrial {
    /// Presented first.
    pub first: Condition,
    /// Presented second.
    pub second: Condition,
    /// Longest exploration of each, s.
    pub exploration_s: f64,
}

/// One magnitude-estimation trial: one stimulus.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MagnitudeTrial {
    /// Display name.
    pub display: String,
    /// The rendered model, with the stimulus's coefficients.
    pub model: ModelParams,
    /// Static coefficient.
    pub mu_s: f64,
    /// Kinetic coefficient.
    pub mu_k: f64,
    /// Longest exploration, s.
    pub exploration_s: f64,
}

/// One reciprocal tapping test of a Fitts study.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FittsTrial {
    /// Condition id.
    pub condition: String,
    /// The rendered model.
    pub model: ModelParams,
    /// Experimenter prompt before the test.
    pub prompt: Option<String>,
    /// Physical friction of the condition (simulated device only).
    pub physical: Option<ModelParams>,
    /// Distance between target centres A, m.
    pub amplitude_m: f64,
    /// Target width W, m.
    pub width_m: f64,
    /// Cursor diameter D, m.
    pub cursor_m: f64,
    /// Width that counts for hits, W' (W - D or W), m.
    pub effective_width_m: f64,
    /// Index of difficulty, bits.
    pub id_bits: f64,
    /// Successful taps to complete the test.
    pub taps: u32,
    /// Longest duration of the test, s.
    pub timeout_s: f64,
}

impl TrialSpec {
    /// The haptic loop rate its models need, Hz (the highest of them).
    #[must_use]
    pub fn loop_rate_hz(&self) -> f64 {
        match self {
            TrialSpec::MagnitudeEstimation(MagnitudeTrial { model, .. })
            | TrialSpec::Fitts(FittsTrial { model, .. }) => model.loop_rate_hz(),
            TrialSpec::PairedComparison(PairedTrial { first, second, .. }) => {
                first.model.loop_rate_hz().max(second.model.loop_rate_hz())
            }
        }
    }

    /// The kind of trial.
    #[must_use]
    pub fn kind(&self) -> Kind {
        match self {
            TrialSpec::PairedComparison(_) => Kind::PairedComparison,
            TrialSpec::MagnitudeEstimation(_) => Kind::MagnitudeEstimation,
            TrialSpec::Fitts(_) => Kind::Fitts,
        }
    }
}

/// A block before ordering: its name, whether practice, and its trial list.
struct BlockDraft {
    name: String,
    practice: bool,
    trials: Vec<TrialSpec>,
}

/// Resolves a checked protocol into the plan for one session.
#[must_use]
pub fn resolve(protocol: &Protocol, seed: u64, participant_index: u32) -> Plan {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let drafts = blocks(protocol);
    let (practice, main): (Vec<BlockDraft>, Vec<BlockDraft>) =
        drafts.into_iter().partition(|b| b.practice);
    let order = match protocol.block_order {
        BlockOrder::Fixed => (0..main.len()).collect(),
        BlockOrder::LatinSquare => williams_row(main.len(), participant_index as usize),
    };
    let mut main: Vec<Option<BlockDraft>> = main.into_iter().map(Some).collect();
    let ordered: Vec<BlockDraft> = practice
        .into_iter()
        .chain(
            order
                .iter()
                .filter_map(|&i| main.get_mut(i).and_then(Option::take)),
        )
        .collect();

    let mut trials = Vec::new();
    let mut names = Vec::new();
    for (block_index, block) in ordered.into_iter().enumerate() {
        names.push(block.name.clone());
        for (repetition, spec) in order_trials(
            &block.trials,
            protocol.randomization,
            protocol.repetitions,
            &mut rng,
        ) {
            let spec = match spec {
                TrialSpec::PairedComparison(p) if rng.random_bool(0.5) => {
                    TrialSpec::PairedComparison(PairedTrial {
                        first: p.second,
                        second: p.first,
                        exploration_s: p.exploration_s,
                    })
                }
                other => other,
            };
            trials.push(PlannedTrial {
                index: trials.len(),
                block: block.name.clone(),
                block_index,
                practice: block.practice,
                repetition,
                seed: 0,
                spec,
            });
        }
    }
    for t in &mut trials {
        t.seed = rng.next_u64();
    }
    Plan {
        protocol: protocol.clone(),
        seed,
        participant_index,
        blocks: names,
        trials,
    }
}

/// Each block's trial list, before ordering.
fn blocks(p: &Protocol) -> Vec<BlockDraft> {
    match &p.design {
        Design::PairedComparison(d) => {
            let find = |id: &str| d.conditions.iter().find(|c| c.id == id).cloned();
            let trials = d
                .pairs
                .iter()
                .filter_map(|[a, b]| {
                    Some(TrialSpec::PairedComparison(PairedTrial {
                        first: find(a)?,
                        second: find(b)?,
                        exploration_s: d.exploration_s,
                    }))
                })
                .collect();
            vec![BlockDraft {
                name: "main".into(),
                practice: false,
                trials,
            }]
        }
        Design::MagnitudeEstimation(d) => d
            .sets
            .iter()
            .map(|set| BlockDraft {
                name: set.display.clone(),
                practice: false,
                trials: set
                    .stimuli
                    .iter()
                    .map(|&s| {
                        TrialSpec::MagnitudeEstimation(MagnitudeTrial {
                            display: set.display.clone(),
                            model: stimulus_model(&set.model, s),
                            mu_s: s.mu_s,
                            mu_k: s.mu_k,
                            exploration_s: d.exploration_s,
                        })
                    })
                    .collect(),
            })
            .collect(),
        Design::Fitts(d) => {
            let test = |c: &super::FittsCondition, l: super::FittsLevel| {
                TrialSpec::Fitts(FittsTrial {
                    condition: c.id.clone(),
                    model: c.model.clone(),
                    prompt: c.prompt.clone(),
                    physical: c.physical.clone(),
                    amplitude_m: l.amplitude_m,
                    width_m: l.width_m,
                    cursor_m: d.cursor_m,
                    effective_width_m: d.effective_width(l.width_m),
                    id_bits: d.id_bits(l),
                    taps: d.taps,
                    timeout_s: d.timeout_s,
                })
            };
            let mut out = Vec::new();
            if !d.practice.is_empty() {
                let levels: Vec<usize> = if d.practice_levels.is_empty() {
                    (0..d.levels.len()).collect()
                } else {
                    d.practice_levels.clone()
                };
                let trials = d
                    .practice
                    .iter()
                    .filter_map(|id| d.conditions.iter().find(|c| &c.id == id))
                    .flat_map(|c| {
                        levels
                            .iter()
                            .filter_map(|&l| d.levels.get(l))
                            .map(|&l| test(c, l))
                    })
                    .collect();
                out.push(BlockDraft {
                    name: "practice".into(),
                    practice: true,
                    trials,
                });
            }
            let trials = d
                .conditions
                .iter()
                .flat_map(|c| d.levels.iter().map(move |&l| test(c, l)))
                .collect();
            out.push(BlockDraft {
                name: "main".into(),
                practice: false,
                trials,
            });
            out
        }
    }
}

/// The block's trials with their repetition index, in presentation order.
fn order_trials(
    trials: &[TrialSpec],
    randomization: Randomization,
    repetitions: u32,
    rng: &mut ChaCha8Rng,
) -> Vec<(u32, TrialSpec)> {
    let mut out: Vec<(u32, usize)> = Vec::new();
    for r in 0..repetitions {
        let mut idx: Vec<usize> = (0..trials.len()).collect();
        if randomization == Randomization::Random {
            idx.shuffle(rng);
        }
        out.extend(idx.into_iter().map(|i| (r, i)));
    }
    if randomization == Randomization::FullRandom {
        out.shuffle(rng);
    }
    out.into_iter()
        .map(|(r, i)| (r, trials[i].clone()))
        .collect()
}

/// Row `row` of a balanced Latin square (Williams design) of order `n`: each
/// block appears once in each position and, for even `n`, follows every
/// other block equally often. For odd `n` the square has `2n` rows, the
/// second half mirrored.
#[must_use]
pub fn williams_row(n: usize, row: usize) -> Vec<usize> {
    if n == 0 {
        return Vec::new();
    }
    let first: Vec<usize> = (0..n)
        .map(|j| {
            if j == 0 {
                0
            } else if j % 2 == 1 {
                j.div_ceil(2)
            } else {
                n - j / 2
            }
        })
        .collect();
    let rows = if n.is_multiple_of(2) { n } else { 2 * n };
    let r = row % rows;
    let mut out: Vec<usize> = first.iter().map(|&f| (f + r % n) % n).collect();
    if r >= n {
        out.reverse();
    }
    out
}

#[cfg(test)]
mod tests {
    use super::williams_row;

    #[test]
    fn williams_rows_are_permutations_balanced_by_position() {
        for n in 1..7 {
            let rows = if n % 2 == 0 { n } else { 2 * n };
            let mut count = vec![vec![0; n]; n];
            for r in 0..rows {
                let row = williams_row(n, r);
                let mut sorted = row.clone();
                sorted.sort_unstable();
                assert_eq!(sorted, (0..n).collect::<Vec<_>>());
                for (pos, &b) in row.iter().enumerate() {
                    count[pos][b] += 1;
                }
            }
            let expected = rows / n;
            assert!(
                count.iter().flatten().all(|&c| c == expected),
                "n={n}: {count:?}"
            );
        }
        assert_eq!(williams_row(2, 0), vec![0, 1]);
        assert_eq!(williams_row(2, 1), vec![1, 0]);
        assert_eq!(williams_row(4, 0), vec![0, 1, 3, 2]);
    }
}
