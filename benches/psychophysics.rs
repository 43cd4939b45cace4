//! Speed of the discrimination study's per-trial and per-track work
//! (`cargo bench --bench psychophysics`):
//! - the trial source replays a QUEST+ track from its answers and chooses
//!   the next difference on every trial: the shipped protocol's grid (40
//!   stimuli x 30 thresholds x 5 slopes x 3 lapses) after 150 answers;
//!   goal well under the 20 ms a trial's start can spare;
//! - one maximum-likelihood fit of a track (20 differences x 10 answers),
//!   which the analysis repeats for every bootstrap sample.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use frictionlab_psychophysics::adaptive::{QuestPlus, QuestPlusSpec};
use frictionlab_psychophysics::fit::{FitSpec, blocks, fit};
use frictionlab_psychophysics::psychometric::{GUESS_2IFC, Params, Psychometric, Shape};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn logspace(from: f64, to: f64, n: usize) -> Vec<f64> {
    #[expect(clippy::cast_precision_loss, reason = "small counts")]
    (0..n)
        .map(|i| (from.ln() + (to.ln() - from.ln()) * i as f64 / (n - 1) as f64).exp())
        .collect()
}

fn observer() -> Psychometric {
    Psychometric {
        shape: Shape::Weibull,
        params: Params {
            threshold: 0.2,
            slope: 2.0,
            lapse: 0.02,
        },
        guess: GUESS_2IFC,
    }
}

fn bench(c: &mut Criterion) {
    let spec = QuestPlusSpec {
        shape: Shape::Weibull,
        guess: GUESS_2IFC,
        stimuli: logspace(0.01, 1.0, 40),
        thresholds: logspace(0.02, 0.8, 30),
        slopes: vec![1.0, 1.5, 2.0, 3.0, 5.0],
        lapses: vec![0.0, 0.02, 0.04],
        stop_trials: None,
        stop_threshold_sd: None,
        max_trials: 200,
    };
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let mut q = QuestPlus::new(&spec);
    let mut answers = Vec::new();
    for _ in 0..150 {
        let x = q.next().unwrap_or(0.2);
        let correct = rng.random::<f64>() < observer().p_correct(x);
        q.update(x, correct);
        answers.push((x, correct));
    }
    c.bench_function("quest_plus/replay_150_answers_and_next", |b| {
        b.iter(|| {
            let q = QuestPlus::replay(black_box(&spec), answers.iter().copied());
            black_box(q.next())
        });
    });
    let trials: Vec<(f64, bool)> = (0..20)
        .flat_map(|i| {
            let x = 0.05 + 0.03 * f64::from(i);
            (0..10).map(move |_| x)
        })
        .map(|x| (x, rng.random::<f64>() < observer().p_correct(x)))
        .collect();
    let data = blocks(&trials);
    let fit_spec = FitSpec {
        shape: Shape::Weibull,
        guess: GUESS_2IFC,
        max_lapse: 0.06,
    };
    c.bench_function("fit/weibull_20_levels_x_10", |b| {
        b.iter(|| black_box(fit(black_box(&fit_spec), black_box(&data))));
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
