//! Cost of one step of each friction model (`cargo bench --bench friction`).
//!
//! Each iteration steps a model once along a smooth back-and-forth motion at
//! the model's loop rate (5 kHz for the stick-slip models, 1 kHz otherwise),
//! so stick, slip and transitions all occur. The budget is 200 us per step
//! at 5 kHz; the aim is under 50 ns.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use frictionlab::friction::{ForceLimit, Friction, Input, ModelParams};

fn motion(n: usize, dt: f64) -> Vec<Input> {
    (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            let w = std::f64::consts::TAU * 1.5;
            Input {
                x_m: 0.012 * (w * t).sin(),
                v_m_s: 0.012 * w * (w * t).cos(),
            }
        })
        .collect()
}

fn step_cost(c: &mut Criterion) {
    let mut group = c.benchmark_group("step");
    for name in ModelParams::NAMES {
        let params = ModelParams::default_for(name)
            .unwrap_or_else(|| panic!("{name}: no default parameters"));
        let dt = 1.0 / params.loop_rate_hz();
        let inputs = motion(10_000, dt);
        let mut model =
            Friction::new(&params, ForceLimit::default(), 0.0).unwrap_or_else(|errors| {
                let errors: Vec<String> = errors.iter().map(ToString::to_string).collect();
                panic!("{name}: {}", errors.join("; "))
            });
        let mut i = 0;
        group.bench_function(name, |b| {
            b.iter(|| {
                i = (i + 1) % inputs.len();
                black_box(model.step(dt, black_box(inputs[i])))
            });
        });
    }
    group.finish();
}

criterion_group!(benches, step_cost);
criterion_main!(benches);
