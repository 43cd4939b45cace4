//! Cost of one step of each friction model (`cargo bench --bench friction`),
//! in both floats the core runs in: `f64` (the host) and `f32` (a device's
//! single-precision FPU; the same code the firmware runs).
//!
//! Each iteration steps a model once along a smooth back-and-forth motion at
//! the model's loop rate (5 kHz for the stick-slip models, 1 kHz otherwise),
//! so stick, slip and transitions all occur. The budget is 200 us per step
//! at 5 kHz; the aim is at most 25 ns on the host.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use frictionlab::friction::{ForceLimit, Friction, Input, ModelParams, Real};

fn motion<T: Real>(n: usize, dt: f64) -> Vec<Input<T>> {
    (0..n)
        .map(|i| {
            let t = i as f64 * dt;
            let w = std::f64::consts::TAU * 1.5;
            Input {
                x_m: T::of(0.012 * (w * t).sin()),
                v_m_s: T::of(0.012 * w * (w * t).cos()),
            }
        })
        .collect()
}

fn step_cost_in<T: Real>(c: &mut Criterion, width: &str) {
    let mut group = c.benchmark_group(format!("step-{width}"));
    for name in ModelParams::NAMES {
        let params = ModelParams::default_for(name)
            .unwrap_or_else(|| panic!("{name}: no default parameters"));
        let dt = 1.0 / params.loop_rate_hz();
        let inputs = motion::<T>(10_000, dt);
        let mut model = Friction::<T>::new(&params, ForceLimit::default(), T::ZERO)
            .unwrap_or_else(|e| panic!("{name}: {}: {e}", e.field));
        let dt = T::of(dt);
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

fn step_cost(c: &mut Criterion) {
    step_cost_in::<f64>(c, "f64");
    step_cost_in::<f32>(c, "f32");
}

criterion_group!(benches, step_cost);
criterion_main!(benches);
