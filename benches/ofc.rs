//! Speed of the simulated participant's feedback controller (issue 65,
//! `cargo bench --bench ofc`): one steady-state solve of the limb with a
//! 50 ms sensory delay (21 states; `participant::limb`), which each
//! participant with the feedback hand (`participant::feedback`) needs
//! once. A replay of 20 participants can afford seconds; a power curve's
//! thousands of participants cannot, so this is the number to bring down
//! before that hand is the default (10.6 ms median at the issue-65
//! sitting that made it 21 states and 1e-7 tolerant; 346.7 ms at 30 states
//! and 1e-10).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use frictionlab::participant::limb::Limb;
use frictionlab::participant::ofc::solve;

fn limb() -> Limb {
    Limb {
        mass_kg: 1.0,
        stiffness_n_m: 500.0,
        damping_n_s_m: 20.0,
        muscle_tau_s: 0.04,
        step_s: 0.01,
        delay_s: 0.05,
        command_noise: 0.5,
        command_sd_m: 1e-5,
        sense_sd: [1e-4, 1e-3, 0.1],
        load_drift_n: 0.01,
        load_memory_s: 10.0,
        distance_weight: 1e4,
        effort_weight: 1e-2,
    }
}

fn bench(c: &mut Criterion) {
    let (plant, cost) = limb().plant();
    if let Err(e) = solve(&plant, &cost) {
        panic!("the benchmark's limb has no controller: {e}");
    }
    let mut group = c.benchmark_group("ofc");
    group.sample_size(10);
    group.bench_function("solve limb, 50 ms delay (21 states)", |b| {
        b.iter(|| solve(black_box(&plant), black_box(&cost)));
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
