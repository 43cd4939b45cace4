//! The maximum-likelihood fit, the bootstrap and the profile-likelihood
//! interval, on simulated data.

use frictionlab_psychophysics::fit::{
    Block, Fit, FitSpec, Interval, blocks, bootstrap_threshold, fit, log_likelihood,
    profile_deviance, profile_threshold,
};
use frictionlab_psychophysics::psychometric::{GUESS_2IFC, Params, Psychometric, Shape};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn spec(shape: Shape, max_lapse: f64) -> FitSpec {
    FitSpec {
        shape,
        guess: GUESS_2IFC,
        max_lapse,
    }
}

fn simulate(psi: &Psychometric, xs: &[f64], n: u32, rng: &mut ChaCha8Rng) -> Vec<Block> {
    xs.iter()
        .map(|&x| {
            let p = psi.p_correct(x);
            let correct = (0..n).map(|_| u32::from(rng.random::<f64>() < p)).sum();
            Block { x, n, correct }
        })
        .collect()
}

/// A true function and stimulus levels for each shape.
fn truths() -> Vec<(Psychometric, Vec<f64>)> {
    vec![
        (
            Psychometric {
                shape: Shape::Weibull,
                params: Params {
                    threshold: 0.3,
                    slope: 3.0,
                    lapse: 0.02,
                },
                guess: GUESS_2IFC,
            },
            vec![0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.6, 0.8],
        ),
        (
            Psychometric {
                shape: Shape::Logistic,
                params: Params {
                    threshold: 0.5,
                    slope: 8.0,
                    lapse: 0.03,
                },
                guess: GUESS_2IFC,
            },
            vec![0.0, 0.15, 0.3, 0.45, 0.6, 0.75, 0.9, 1.05],
        ),
        (
            Psychometric {
                shape: Shape::CumulativeNormal,
                params: Params {
                    threshold: -0.2,
                    slope: 2.5,
                    lapse: 0.01,
                },
                guess: GUESS_2IFC,
            },
            vec![-1.2, -0.9, -0.6, -0.3, 0.0, 0.3, 0.6, 0.9],
        ),
    ]
}

#[test]
fn many_simulated_trials_recover_the_true_parameters() {
    let mut rng = ChaCha8Rng::seed_from_u64(17);
    for (truth, xs) in truths() {
        let data = simulate(&truth, &xs, 3000, &mut rng);
        let f = fit(&spec(truth.shape, 0.06), &data).unwrap();
        let (got, want) = (f.params, truth.params);
        eprintln!("{:?}: fitted {got:?}, true {want:?}", truth.shape);
        assert!(
            (got.threshold - want.threshold).abs() < 0.03 * want.threshold.abs().max(0.5),
            "{:?} threshold {got:?} vs {want:?}",
            truth.shape
        );
        assert!(
            (got.slope / want.slope - 1.0).abs() < 0.12,
            "{:?} slope {got:?} vs {want:?}",
            truth.shape
        );
        assert!(
            (got.lapse - want.lapse).abs() < 0.012,
            "{:?} lapse {got:?} vs {want:?}",
            truth.shape
        );
        let fitted = Psychometric {
            params: got,
            ..truth
        };
        let (t, t_true) = (
            fitted.threshold_at(0.75).unwrap(),
            truth.threshold_at(0.75).unwrap(),
        );
        assert!(
            (t - t_true).abs() < 0.02 * t_true.abs().max(0.5),
            "{t} vs {t_true}"
        );
    }
}

#[test]
fn the_fit_is_at_least_as_likely_as_the_truth_and_as_nearby_parameters() {
    let mut rng = ChaCha8Rng::seed_from_u64(5);
    for (truth, xs) in truths() {
        for _ in 0..10 {
            let data = simulate(&truth, &xs, 20, &mut rng);
            let s = spec(truth.shape, 0.05);
            let f = fit(&s, &data).unwrap();
            let at = |p: Params| log_likelihood(&s, &p, &data);
            let truth_lapse = Params {
                lapse: truth.params.lapse.min(0.05),
                ..truth.params
            };
            assert!(f.log_likelihood >= at(truth_lapse) - 1e-9);
            assert_eq!(f.log_likelihood, at(f.params));
            let p = f.params;
            for (dt, ds, dl) in [
                (1e-4, 0.0, 0.0),
                (-1e-4, 0.0, 0.0),
                (0.0, 1e-4, 0.0),
                (0.0, -1e-4, 0.0),
                (0.0, 0.0, 1e-4),
                (0.0, 0.0, -1e-4),
            ] {
                let q = Params {
                    threshold: p.threshold * (1.0 + dt),
                    slope: p.slope * (1.0 + ds),
                    lapse: p.lapse + dl,
                };
                // Outside the box (fit.rs's module docs) the likelihood is
                // no competitor.
                let w = |x: f64| match truth.shape {
                    Shape::Weibull => x.ln(),
                    Shape::Logistic | Shape::CumulativeNormal => x,
                };
                let (w_min, w_max) = (w(xs[0]), w(xs[xs.len() - 1]));
                let span = w_max - w_min;
                let inside = (0.0..=0.05).contains(&q.lapse)
                    && (0.01 / span..=100.0 / span).contains(&q.slope)
                    && (w_min - span..=w_max + span).contains(&w(q.threshold));
                if inside {
                    assert!(f.log_likelihood >= at(q) - 1e-12, "{p:?} beaten by {q:?}");
                }
            }
        }
    }
}

#[test]
fn the_lapse_rate_stays_within_its_bound_and_may_sit_on_it_exactly() {
    // Errors at the top levels ask for a lapse rate near 0.15.
    let data: Vec<Block> = [
        (0.1, 20),
        (0.2, 24),
        (0.4, 30),
        (0.8, 34),
        (1.6, 34),
        (3.2, 34),
    ]
    .into_iter()
    .map(|(x, correct)| Block { x, n: 40, correct })
    .collect();
    for shape in [Shape::Weibull, Shape::Logistic, Shape::CumulativeNormal] {
        let wide = fit(&spec(shape, 0.3), &data).unwrap();
        assert!(
            wide.params.lapse > 0.1 && wide.params.lapse < 0.2,
            "{wide:?}"
        );
        let capped = fit(&spec(shape, 0.05), &data).unwrap();
        assert_eq!(capped.params.lapse, 0.05, "{shape:?}");
        let none = fit(&spec(shape, 0.0), &data).unwrap();
        assert_eq!(none.params.lapse, 0.0, "{shape:?}");
        assert!(wide.log_likelihood > capped.log_likelihood);
        assert!(capped.log_likelihood > none.log_likelihood);
    }
    // All correct at the top: the lapse rate goes to 0, exactly.
    let clean: Vec<Block> = [(0.1, 21), (0.2, 25), (0.4, 33), (0.8, 40), (1.6, 40)]
        .into_iter()
        .map(|(x, correct)| Block { x, n: 40, correct })
        .collect();
    assert_eq!(
        fit(&spec(Shape::Weibull, 0.05), &clean)
            .unwrap()
            .params
            .lapse,
        0.0
    );
    // And on many small random data sets it never leaves [0, max_lapse].
    let mut rng = ChaCha8Rng::seed_from_u64(99);
    for (truth, xs) in truths() {
        for _ in 0..50 {
            let data = simulate(&truth, &xs, 5, &mut rng);
            let f = fit(&spec(truth.shape, 0.04), &data).unwrap();
            assert!((0.0..=0.04).contains(&f.params.lapse), "{f:?}");
        }
    }
}

#[test]
fn perfectly_separated_data_give_a_finite_fit_with_the_slope_at_its_bound() {
    // Chance up to x = 3, all correct from x = 4.
    let data: Vec<Block> = [
        (1.0, 10),
        (2.0, 9),
        (3.0, 10),
        (4.0, 20),
        (5.0, 20),
        (6.0, 20),
    ]
    .into_iter()
    .map(|(x, correct)| Block { x, n: 20, correct })
    .collect();
    for shape in [Shape::Logistic, Shape::CumulativeNormal] {
        let f = fit(&spec(shape, 0.04), &data).unwrap();
        // Span 5: the slope bound is 100 / 5.
        assert_eq!(f.params.slope, 20.0, "{shape:?} {f:?}");
        assert!(
            f.params.threshold > 3.0 && f.params.threshold < 4.0,
            "{f:?}"
        );
        assert_eq!(f.params.lapse, 0.0);
        assert!(f.log_likelihood.is_finite());
    }
    // The Weibull's span is ln(6 / 1).
    let f = fit(&spec(Shape::Weibull, 0.04), &data).unwrap();
    assert_eq!(f.params.slope, 100.0 / 6.0_f64.ln(), "{f:?}");
    assert!(
        f.params.threshold > 3.0 && f.params.threshold < 4.5,
        "{f:?}"
    );
    // Two levels, 0 % above chance and 100 %: the same.
    let two = [
        Block {
            x: 1.0,
            n: 3,
            correct: 1,
        },
        Block {
            x: 2.0,
            n: 3,
            correct: 3,
        },
    ];
    let f = fit(&spec(Shape::Logistic, 0.0), &two).unwrap();
    assert_eq!(f.params.slope, 100.0, "{f:?}");
    assert!(
        f.params.threshold > 1.0 && f.params.threshold < 2.0,
        "{f:?}"
    );
}

fn block(x: f64, n: u32, correct: u32) -> Block {
    Block { x, n, correct }
}

const SHAPES: [Shape; 3] = [Shape::Weibull, Shape::Logistic, Shape::CumulativeNormal];

#[test]
fn no_data_or_invalid_data_give_none_without_panicking() {
    let ok = block(1.0, 10, 7);
    let params = Params {
        threshold: 1.0,
        slope: 2.0,
        lapse: 0.0,
    };
    for shape in SHAPES {
        let s = spec(shape, 0.05);
        assert_eq!(fit(&s, &[]), None);
        assert_eq!(fit(&s, &[block(1.0, 0, 0)]), None, "no trials");
        for x in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
            let bad = [ok, block(x, 4, 2)];
            assert_eq!(fit(&s, &bad), None, "{x} {shape:?}");
            assert!(log_likelihood(&s, &params, &bad).is_nan());
        }
        assert_eq!(
            fit(&s, &[block(1.0, 3, 4)]),
            None,
            "more correct than trials"
        );
        for (guess, max_lapse) in [
            (1.0, 0.0),
            (-0.1, 0.0),
            (f64::NAN, 0.0),
            (0.5, -0.01),
            (0.5, 0.5),
            (0.5, f64::NAN),
        ] {
            let bad_spec = FitSpec {
                shape,
                guess,
                max_lapse,
            };
            assert_eq!(fit(&bad_spec, &[ok]), None, "{guess} {max_lapse}");
        }
        // Data spanning nearly all of f64 leave no box to search.
        let huge = [block(-f64::MAX, 1, 1), block(f64::MAX, 1, 1)];
        if shape != Shape::Weibull {
            assert_eq!(fit(&s, &huge), None, "{shape:?}");
        }
    }
}

#[test]
fn odd_but_valid_data_give_a_finite_fit_within_the_bounds() {
    for data in [
        vec![block(1.0, 10, 7)],
        vec![block(0.0, 5, 5)],
        vec![block(-3.0, 5, 0)],
        vec![block(0.0, 5, 5), block(0.0, 0, 0), block(-1.0, 2, 1)],
        vec![block(1e-300, 2, 1), block(1e300, u32::MAX, u32::MAX)],
        vec![block(f64::MIN_POSITIVE / 4.0, 1, 0), block(2.0, 1, 1)],
        vec![block(-1.0, 1000, 500), block(1.0, 1000, 500)],
    ] {
        for shape in SHAPES {
            let f = fit(&spec(shape, 0.05), &data)
                .unwrap_or_else(|| panic!("{shape:?} {data:?}: no fit"));
            assert!(f.log_likelihood.is_finite(), "{shape:?} {data:?} {f:?}");
            assert!((0.0..=0.05).contains(&f.params.lapse), "{f:?}");
            assert!(f.params.slope > 0.0 && f.params.slope.is_finite(), "{f:?}");
            assert!(f.params.threshold.is_finite(), "{f:?}");
        }
    }
}

#[test]
fn a_fit_is_deterministic_to_the_bit() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    for (truth, xs) in truths() {
        let data = simulate(&truth, &xs, 15, &mut rng);
        let s = spec(truth.shape, 0.05);
        let bits = |f: Fit| {
            [
                f.params.threshold.to_bits(),
                f.params.slope.to_bits(),
                f.params.lapse.to_bits(),
                f.log_likelihood.to_bits(),
            ]
        };
        let first = bits(fit(&s, &data).unwrap());
        for _ in 0..3 {
            assert_eq!(bits(fit(&s, &data).unwrap()), first);
        }
    }
}

#[test]
fn blocks_group_trials_by_equal_x_sorted() {
    let trials = [
        (0.3, true),
        (0.1, false),
        (0.3, false),
        (0.2, true),
        (0.1, true),
        (0.3, true),
    ];
    assert_eq!(
        blocks(&trials),
        vec![
            Block {
                x: 0.1,
                n: 2,
                correct: 1
            },
            Block {
                x: 0.2,
                n: 1,
                correct: 1
            },
            Block {
                x: 0.3,
                n: 3,
                correct: 2
            },
        ]
    );
    assert!(blocks(&[]).is_empty());
    // A NaN level makes a block of its own, which the fit then rejects.
    let with_nan = blocks(&[(f64::NAN, true), (1.0, true), (f64::NAN, false)]);
    assert_eq!(with_nan.len(), 3);
    assert_eq!(fit(&spec(Shape::Logistic, 0.0), &with_nan), None);
}

#[test]
fn log_likelihood_is_the_binomial_sum_over_trials_without_coefficients() {
    let psi = Psychometric {
        shape: Shape::Weibull,
        params: Params {
            threshold: 0.4,
            slope: 2.0,
            lapse: 0.03,
        },
        guess: GUESS_2IFC,
    };
    let data = [
        Block {
            x: 0.0,
            n: 4,
            correct: 3,
        },
        Block {
            x: 0.2,
            n: 10,
            correct: 6,
        },
        Block {
            x: 0.8,
            n: 7,
            correct: 7,
        },
    ];
    let want: f64 = data
        .iter()
        .map(|b| {
            let p = psi.p_correct(b.x);
            f64::from(b.correct) * p.ln() + f64::from(b.n - b.correct) * (1.0 - p).ln()
        })
        .sum();
    let got = log_likelihood(&spec(Shape::Weibull, 0.05), &psi.params, &data);
    assert!((got - want).abs() < 1e-12, "{got} {want}");
    // An error where psi = 1 is impossible.
    let certain = Params {
        threshold: 0.0,
        slope: 1e6,
        lapse: 0.0,
    };
    let wrong_at_top = [Block {
        x: 5.0,
        n: 2,
        correct: 1,
    }];
    assert_eq!(
        log_likelihood(&spec(Shape::Logistic, 0.0), &certain, &wrong_at_top),
        f64::NEG_INFINITY
    );
}

/// Coverage of the bootstrap's 95 % interval over repeated experiments.
#[test]
fn the_bootstrap_95_percent_interval_covers_the_true_threshold_about_95_percent_of_the_time() {
    let truth = Psychometric {
        shape: Shape::Logistic,
        params: Params {
            threshold: 0.5,
            slope: 10.0,
            lapse: 0.02,
        },
        guess: GUESS_2IFC,
    };
    let xs = [0.2, 0.35, 0.5, 0.65, 0.8, 0.95];
    let s = spec(Shape::Logistic, 0.05);
    let t_true = truth.threshold_at(0.75).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2024);
    let (repetitions, mut covered, mut failed) = (200, 0, 0);
    for _ in 0..repetitions {
        let data = simulate(&truth, &xs, 40, &mut rng);
        let f = fit(&s, &data).unwrap();
        let b = bootstrap_threshold(&s, &f, &data, 0.75, 200, 0.95, &mut rng).unwrap();
        assert_eq!(b.samples, 200);
        assert!(b.interval.lo <= b.interval.hi && b.sd > 0.0);
        failed += b.failed;
        if b.interval.contains(t_true) {
            covered += 1;
        }
    }
    let coverage = f64::from(covered) / f64::from(repetitions);
    eprintln!("coverage {covered}/{repetitions} = {coverage}, failed bootstrap samples {failed}");
    assert!((0.88..=0.99).contains(&coverage), "coverage {coverage}");
}

#[test]
fn the_bootstrap_is_reproducible_from_its_seed_and_counts_failed_samples() {
    let s = spec(Shape::Weibull, 0.05);
    let data = [
        Block {
            x: 0.1,
            n: 8,
            correct: 4,
        },
        Block {
            x: 0.2,
            n: 8,
            correct: 5,
        },
        Block {
            x: 0.4,
            n: 8,
            correct: 7,
        },
        Block {
            x: 0.8,
            n: 8,
            correct: 8,
        },
    ];
    let f = fit(&s, &data).unwrap();
    let run = |seed| {
        bootstrap_threshold(
            &s,
            &f,
            &data,
            0.75,
            100,
            0.9,
            &mut ChaCha8Rng::seed_from_u64(seed),
        )
        .unwrap()
    };
    assert_eq!(run(1), run(1));
    assert_ne!(run(1), run(2));
    // A criterion above 1 - max_lapse but reachable by some refits (lapse
    // 0): the others fail and are counted.
    let high = bootstrap_threshold(
        &s,
        &f,
        &data,
        0.97,
        100,
        0.9,
        &mut ChaCha8Rng::seed_from_u64(1),
    )
    .unwrap();
    assert!(high.failed > 0 && high.failed < 100, "{high:?}");
    // A criterion no function reaches: every sample fails.
    assert_eq!(
        bootstrap_threshold(
            &s,
            &f,
            &data,
            0.4,
            50,
            0.9,
            &mut ChaCha8Rng::seed_from_u64(1)
        ),
        None
    );
    for confidence in [0.0, 1.0, f64::NAN] {
        assert_eq!(
            bootstrap_threshold(
                &s,
                &f,
                &data,
                0.75,
                50,
                confidence,
                &mut ChaCha8Rng::seed_from_u64(1)
            ),
            None
        );
    }
}

/// The profile deviance at threshold `t` (criterion 0.75) by brute force,
/// independent of the library's search: the most likely of a dense grid
/// of slopes (log-spaced over `slopes`) and lapse rates (evenly over
/// `[0, max_lapse]`), the location following from `t`, through the public
/// `log_likelihood`. A grid can only miss the maximum, so this is at least
/// the true deviance.
fn brute_deviance(s: &FitSpec, f: &Fit, data: &[Block], t: f64, slopes: (f64, f64)) -> f64 {
    let mut best = f64::NEG_INFINITY;
    for i in 0..=600 {
        let slope = (slopes.0.ln() + (slopes.1 / slopes.0).ln() * f64::from(i) / 600.0).exp();
        for j in 0..=30 {
            let lapse = s.max_lapse * f64::from(j) / 30.0;
            let p = (0.75 - s.guess) / (1.0 - s.guess - lapse);
            let location = match s.shape {
                Shape::Weibull => t / s.shape.f_inverse(p, 1.0, slope),
                Shape::Logistic | Shape::CumulativeNormal => t - s.shape.f_inverse(p, 0.0, slope),
            };
            let ll = log_likelihood(
                s,
                &Params {
                    threshold: location,
                    slope,
                    lapse,
                },
                data,
            );
            best = best.max(ll);
        }
    }
    2.0 * (f.log_likelihood - best)
}

/// Each closed end of the interval is where the profile deviance crosses
/// the chi-square quantile 3.84: by an independent brute-force profile,
/// 1 % inside the end the deviance is below it and 1 % outside above it.
#[test]
fn the_profile_interval_ends_where_the_deviance_crosses_the_chi_square_quantile() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let mut closed_ends = 0;
    for (truth, xs) in truths() {
        for max_lapse in [0.0, 0.05] {
            let s = spec(truth.shape, max_lapse);
            let data = simulate(&truth, &xs, 20, &mut rng);
            let f = fit(&s, &data).unwrap();
            let t = Psychometric {
                shape: s.shape,
                params: f.params,
                guess: s.guess,
            }
            .threshold_at(0.75)
            .unwrap();
            let profile = profile_threshold(&s, &f, &data, 0.75, 0.95).unwrap();
            let Interval { lo, hi } = profile.interval;
            assert!(lo < t && t < hi, "{:?}: {lo} < {t} < {hi}", s.shape);
            // The slope box of the fit (module docs): its span of w.
            let w = |x: f64| if s.shape == Shape::Weibull { x.ln() } else { x };
            let span = w(xs[xs.len() - 1]) - w(xs[0]);
            let slopes = (0.01 / span, 100.0 / span);
            let step = 0.01 * (hi - lo);
            for (end, open, inward) in [(lo, profile.open[0], step), (hi, profile.open[1], -step)] {
                if open {
                    continue;
                }
                closed_ends += 1;
                let at_end = profile_deviance(&s, &f, &data, 0.75, end).unwrap();
                assert!(
                    (at_end - 3.841_458_820_694_124).abs() < 1e-6,
                    "deviance {at_end} at {end}"
                );
                let inside = brute_deviance(&s, &f, &data, end + inward, slopes);
                let outside = brute_deviance(&s, &f, &data, end - inward, slopes);
                assert!(
                    inside < 3.841 && outside > 3.841,
                    "{:?} lapse <= {max_lapse}: at the end {end}, deviance {inside} inside and {outside} outside",
                    s.shape
                );
            }
        }
    }
    assert!(closed_ends >= 10, "{closed_ends} closed ends checked");
}

/// Coverage of the profile interval over repeated constant-stimuli
/// experiments, as the bootstrap's above.
#[test]
fn the_profile_95_percent_interval_covers_the_true_threshold_about_95_percent_of_the_time() {
    let truth = Psychometric {
        shape: Shape::Weibull,
        params: Params {
            threshold: 0.3,
            slope: 3.0,
            lapse: 0.02,
        },
        guess: GUESS_2IFC,
    };
    let xs = [0.1, 0.15, 0.2, 0.3, 0.4, 0.6];
    let s = spec(Shape::Weibull, 0.05);
    let t_true = truth.threshold_at(0.75).unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(2025);
    let (repetitions, mut covered) = (400, 0);
    for _ in 0..repetitions {
        let data = simulate(&truth, &xs, 30, &mut rng);
        let f = fit(&s, &data).unwrap();
        let p = profile_threshold(&s, &f, &data, 0.75, 0.95).unwrap();
        covered += u32::from(p.interval.contains(t_true));
    }
    let coverage = f64::from(covered) / f64::from(repetitions);
    eprintln!("profile coverage {covered}/{repetitions} = {coverage}");
    assert!((0.92..=0.98).contains(&coverage), "coverage {coverage}");
}

/// Answers at chance everywhere do not bound the threshold: the interval
/// runs to the box's edge on the side the data cannot exclude, flagged
/// open; and invalid input gives `None` without panicking.
#[test]
fn unbounded_data_give_an_open_end_and_invalid_input_none() {
    let s = spec(Shape::Weibull, 0.05);
    let data = [block(0.1, 20, 10), block(0.2, 20, 11), block(0.4, 20, 10)];
    let f = fit(&s, &data).unwrap();
    let p = profile_threshold(&s, &f, &data, 0.75, 0.95).unwrap();
    assert!(p.open[1] && !p.open[0], "{p:?}");
    let good = [block(0.1, 20, 11), block(0.2, 20, 15), block(0.4, 20, 19)];
    let f = fit(&s, &good).unwrap();
    assert!(profile_threshold(&s, &f, &good, 0.75, 0.95).is_some());
    assert!(profile_threshold(&s, &f, &good, 0.75, 1.0).is_none());
    assert!(profile_threshold(&s, &f, &good, 0.75, f64::NAN).is_none());
    assert!(
        profile_threshold(&s, &f, &good, 0.5, 0.95).is_none(),
        "criterion at the guess rate"
    );
    assert!(profile_threshold(&s, &f, &[], 0.75, 0.95).is_none());
    assert!(profile_threshold(&s, &f, &[block(f64::NAN, 3, 1)], 0.75, 0.95).is_none());
    assert!(profile_threshold(&s, &f, &[block(0.1, 3, 4)], 0.75, 0.95).is_none());
}

/// Staircase tracks run by an observer whose psychometric function is the
/// fitted family itself (a Weibull), so no misfit of shape is involved:
/// the profile-likelihood interval covers the true threshold more often
/// than the bootstrap's, and both fall short of 95 %.
///
/// Measured (200 tracks of 80 trials each): 1-up-2-down profile 0.785,
/// bootstrap 0.67; 1-up-3-down 0.805 and 0.74; the same shortfall as the simulated participants'
/// recovery in `tests/discrimination.rs` (0.80 and 0.68), so it belongs to
/// fitting a free slope and lapse rate to a staircase's answers, not to
/// the simulated participant. Calibrating the deviance cutoff by re-running
/// the track from the fitted function (95th percentile of the simulated
/// deviances at the generating threshold, median cutoff 5.65 instead of
/// 3.84) raised 1-up-2-down to 0.84 only, at 100 refits a track; not used.
#[test]
fn on_staircase_tracks_the_profile_interval_covers_more_often_than_the_bootstrap() {
    use frictionlab_psychophysics::adaptive::{Staircase, StaircaseRule};
    let truth = Psychometric {
        shape: Shape::Weibull,
        params: Params {
            threshold: 0.25,
            slope: 3.0,
            lapse: 0.02,
        },
        guess: GUESS_2IFC,
    };
    let t_true = truth.threshold_at(0.75).unwrap();
    let s = spec(Shape::Weibull, 0.06);
    // Each rule's tracks draw from their own generator, seeded by `down`:
    // the two rules run on two threads with the same answers as in turn.
    let coverage = |down: u32| {
        let rule = StaircaseRule {
            down,
            start: 0.5,
            steps: vec![0.1, 0.05, 0.025, 0.0125],
            up_ratio: 1.0,
            min: 0.0125,
            max: 1.0,
            stop_trials: Some(80),
            stop_reversals: None,
        };
        let mut rng = ChaCha8Rng::seed_from_u64(u64::from(down));
        let (repetitions, mut profile_covered, mut bootstrap_covered) = (200, 0, 0);
        for _ in 0..repetitions {
            let mut track = Staircase::new(&rule);
            let mut answers = Vec::new();
            while let Some(x) = track.next(&rule) {
                let correct = rng.random::<f64>() < truth.p_correct(x);
                answers.push((x, correct));
                track.update(&rule, correct);
            }
            let data = blocks(&answers);
            let f = fit(&s, &data).unwrap();
            let p = profile_threshold(&s, &f, &data, 0.75, 0.95).unwrap();
            profile_covered += u32::from(p.interval.contains(t_true));
            if let Some(b) = bootstrap_threshold(&s, &f, &data, 0.75, 100, 0.95, &mut rng) {
                bootstrap_covered += u32::from(b.interval.contains(t_true));
            }
        }
        eprintln!(
            "1-up-{down}-down, 80 trials: coverage profile {profile_covered}/{repetitions}, bootstrap {bootstrap_covered}/{repetitions}"
        );
        (profile_covered, bootstrap_covered)
    };
    let (two, three) = std::thread::scope(|t| {
        let two = t.spawn(|| coverage(2));
        let three = coverage(3);
        (two.join().unwrap(), three)
    });
    for (down, (profile_covered, bootstrap_covered)) in [(2, two), (3, three)] {
        assert!(
            profile_covered > bootstrap_covered && profile_covered >= 150,
            "1-up-{down}-down: profile {profile_covered}, bootstrap {bootstrap_covered}"
        );
    }
}
