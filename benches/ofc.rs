//! Speed of the simulated participant's feedback controller (issue 65,
//! `cargo bench --bench ofc`): one steady-state solve of the limb with a
//! 50 ms sensory delay (21 states; `participant::limb`), which each
//! participant with the feedback hand (`participant::feedback`) needs
//! once. A replay of 20 participants can afford seconds; a power curve's
//! thousands of participants cannot, so this is the number to bring down
//! before that hand is the default. Medians: 6.2 ms for this default
//! participant's limb; 10.6 ms for the earlier bench's hand-written limb
//! at 21 states and 1e-7 tolerance, 346.7 ms at 30 states and 1e-10.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use frictionlab::participant::limb::Limb;
use frictionlab::participant::ofc::solve;
use frictionlab::participant::{Population, Traits};

/// A default participant's limb on seed 002's handle, as the feedback
/// hand solves it.
fn limb() -> Limb {
    Traits::draw(3504, "sim-002", &Population::default()).limb(0.692)
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
