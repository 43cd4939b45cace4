//! Stage 2 of loading a protocol: resolve it into a session plan holding
//! every trial in presentation order, drawn from the seed before the first
//! trial starts.
//!
//! # Randomization (with a `ChaCha8` generator seeded by the plan seed)
//! - Blocks: each kind lists its own ([`super::kind::StudyKind::blocks`]):
//!   paired comparison has one block (`main`); magnitude estimation one per
//!   set (named by its display); Fitts a `practice` block (if any) followed
//!   by `main`. Non-practice blocks are ordered as listed, or by a
//!   balanced Latin square (Williams design) row picked by the participant
//!   index (`block_order: latin_square`); practice always comes first.
//! - Trials within a block: `sequential` repeats the list; `random` shuffles
//!   it anew for each repetition; `full_random` shuffles all repetitions
//!   together.
//! - Then each trial's kind draws what it draws per trial
//!   (`StudyKind::draw`): paired comparison the order of the pair's two
//!   members (the seed's "random order"); the others nothing.
//! - Each trial gets its own seed, drawn last, so the randomness inside a
//!   trial (a simulated participant's noise) depends only on (plan seed,
//!   trial) and a resumed session replays it exactly.

use rand::{Rng, SeedableRng, seq::SliceRandom};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

use super::kind::{Block, Kinds};
use super::{BlockOrder, Protocol, Randomization};

/// Every trial of a session, in presentation order.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct Plan<K: Kinds> {
    /// The protocol the plan was drawn from.
    pub protocol: Protocol<K>,
    /// The plan seed.
    pub seed: u64,
    /// The participant's index for counterbalancing (0-based).
    pub participant_index: u32,
    /// Block names in session order.
    pub blocks: Vec<String>,
    /// The trials.
    pub trials: Vec<PlannedTrial<K>>,
}

/// One trial of the plan.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(bound = "")]
pub struct PlannedTrial<K: Kinds> {
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
    pub spec: K::Trial,
}

/// Resolves a checked protocol into the plan for one session.
#[must_use]
pub fn resolve<K: Kinds>(protocol: &Protocol<K>, seed: u64, participant_index: u32) -> Plan<K> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let (practice, main): (Vec<_>, Vec<_>) = K::blocks(&protocol.design)
        .into_iter()
        .partition(|b| b.practice);
    let order = match protocol.block_order {
        BlockOrder::Fixed => (0..main.len()).collect(),
        BlockOrder::LatinSquare => williams_row(main.len(), participant_index as usize),
    };
    let mut main: Vec<Option<Block<K::Trial>>> = main.into_iter().map(Some).collect();
    let ordered: Vec<Block<K::Trial>> = practice
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
            let spec = K::draw(spec, &mut rng);
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

/// The block's trials with their repetition index, in presentation order.
fn order_trials<T: Clone>(
    trials: &[T],
    randomization: Randomization,
    repetitions: u32,
    rng: &mut ChaCha8Rng,
) -> Vec<(u32, T)> {
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
