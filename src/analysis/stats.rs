//! Small statistics, each a pure function with its definition in its doc.
//! Distributions come from `statrs`.

use statrs::distribution::{Binomial, ContinuousCDF, DiscreteCDF, StudentsT};

/// Geometric mean of positive values: `exp(mean(ln x))`; `None` if empty.
#[must_use]
pub fn geometric_mean(xs: &[f64]) -> Option<f64> {
    (!xs.is_empty()).then(|| (xs.iter().map(|x| x.ln()).sum::<f64>() / xs.len() as f64).exp())
}

/// Arithmetic mean; `None` if empty.
#[must_use]
pub fn mean(xs: &[f64]) -> Option<f64> {
    (!xs.is_empty()).then(|| xs.iter().sum::<f64>() / xs.len() as f64)
}

/// Sample standard deviation (n - 1); `None` for fewer than two values.
#[must_use]
pub fn sample_sd(xs: &[f64]) -> Option<f64> {
    let m = mean(xs)?;
    (xs.len() >= 2)
        .then(|| (xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (xs.len() - 1) as f64).sqrt())
}

/// Pearson correlation with its 95% confidence interval (Fisher z) and
/// two-sided p (t test, n - 2 degrees of freedom).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Correlation {
    /// Pearson r.
    pub r: f64,
    /// Number of pairs.
    pub n: usize,
    /// 95% CI lower bound (`None` for n <= 3).
    pub ci_low: Option<f64>,
    /// 95% CI upper bound (`None` for n <= 3).
    pub ci_high: Option<f64>,
    /// Two-sided p for r = 0 (`None` for n <= 2).
    pub p: Option<f64>,
}

/// Pearson r of the pairs; `None` for fewer than 3 pairs or no variance.
#[must_use]
pub fn pearson(pairs: &[(f64, f64)]) -> Option<Correlation> {
    let n = pairs.len();
    if n < 3 {
        return None;
    }
    let mx = pairs.iter().map(|p| p.0).sum::<f64>() / n as f64;
    let my = pairs.iter().map(|p| p.1).sum::<f64>() / n as f64;
    let (mut sxy, mut sxx, mut syy) = (0.0, 0.0, 0.0);
    for &(x, y) in pairs {
        sxy += (x - mx) * (y - my);
        sxx += (x - mx) * (x - mx);
        syy += (y - my) * (y - my);
    }
    if sxx <= 0.0 || syy <= 0.0 {
        return None;
    }
    let r = (sxy / (sxx * syy).sqrt()).clamp(-1.0, 1.0);
    let (ci_low, ci_high) = if n > 3 && r.abs() < 1.0 {
        let z = r.atanh();
        let half = 1.959_963_984_540_054 / ((n - 3) as f64).sqrt();
        (Some((z - half).tanh()), Some((z + half).tanh()))
    } else {
        (None, None)
    };
    let df = (n - 2) as f64;
    let p = if r.abs() >= 1.0 {
        Some(0.0)
    } else {
        let t = r * (df / (1.0 - r * r)).sqrt();
        StudentsT::new(0.0, 1.0, df)
            .ok()
            .map(|d| 2.0 * (1.0 - d.cdf(t.abs())))
    };
    Some(Correlation {
        r,
        n,
        ci_low,
        ci_high,
        p,
    })
}

/// A geometric mean with its spread and 95% confidence interval.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GeoSummary {
    /// The geometric mean.
    pub value: f64,
    /// Geometric standard deviation (`None` for fewer than 2 values).
    pub gsd: Option<f64>,
    /// 95% confidence interval of the geometric mean, low end (t interval
    /// on the logarithms).
    pub ci_low: Option<f64>,
    /// Its high end.
    pub ci_high: Option<f64>,
}

/// The geometric summary of positive values given as their logarithms.
#[must_use]
pub fn log_summary(ln: &[f64]) -> Option<GeoSummary> {
    let m = mean(ln)?;
    let sd = sample_sd(ln);
    let half = sd.and_then(|sd| {
        StudentsT::new(0.0, 1.0, (ln.len() - 1) as f64)
            .ok()
            .map(|t| t.inverse_cdf(0.975) * sd / (ln.len() as f64).sqrt())
    });
    Some(GeoSummary {
        value: m.exp(),
        gsd: sd.map(f64::exp),
        ci_low: half.map(|h| (m - h).exp()),
        ci_high: half.map(|h| (m + h).exp()),
    })
}

/// A one-sample t test of a mean against 0.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeanTest {
    /// The mean.
    pub mean: f64,
    /// Number of values.
    pub n: usize,
    /// t = mean / (sd / sqrt(n)).
    pub t: f64,
    /// Two-sided p (Student t, n - 1 degrees of freedom).
    pub p: f64,
    /// 95% confidence interval of the mean, low end.
    pub ci_low: f64,
    /// Its high end.
    pub ci_high: f64,
}

/// One-sample two-sided t test of `xs` against a mean of 0; `None` for
/// fewer than 2 values or no spread (an SD below 1e-12 of the mean's size:
/// equal values that rounding made unequal).
#[must_use]
pub fn one_sample_t(xs: &[f64]) -> Option<MeanTest> {
    let m = mean(xs)?;
    let sd = sample_sd(xs).filter(|sd| *sd > 1e-12 * m.abs().max(1e-300))?;
    let se = sd / (xs.len() as f64).sqrt();
    let dist = StudentsT::new(0.0, 1.0, (xs.len() - 1) as f64).ok()?;
    let t = m / se;
    let half = dist.inverse_cdf(0.975) * se;
    Some(MeanTest {
        mean: m,
        n: xs.len(),
        t,
        p: (2.0 * (1.0 - dist.cdf(t.abs()))).min(1.0),
        ci_low: m - half,
        ci_high: m + half,
    })
}

/// Ordinary least squares of y on x.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fit {
    /// Intercept.
    pub intercept: f64,
    /// Slope.
    pub slope: f64,
    /// Coefficient of determination.
    pub r2: f64,
    /// Points.
    pub n: usize,
}

/// OLS fit of y = intercept + slope x; `None` for fewer than 2 points or no
/// spread in x.
#[must_use]
pub fn linear_fit(points: &[(f64, f64)]) -> Option<Fit> {
    let n = points.len();
    if n < 2 {
        return None;
    }
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n as f64;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n as f64;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let slope = sxy / sxx;
    let intercept = my - slope * mx;
    let ss_tot: f64 = points.iter().map(|p| (p.1 - my).powi(2)).sum();
    let ss_res: f64 = points
        .iter()
        .map(|p| (p.1 - intercept - slope * p.0).powi(2))
        .sum();
    let r2 = if ss_tot > 0.0 {
        1.0 - ss_res / ss_tot
    } else {
        1.0
    };
    Some(Fit {
        intercept,
        slope,
        r2,
        n,
    })
}

/// Two-sided exact binomial test of `k` successes in `n` trials against
/// p = 0.5: `min(1, 2 P(X <= min(k, n - k)))`. `None` for n = 0.
#[must_use]
pub fn binomial_two_sided(k: u64, n: u64) -> Option<f64> {
    if n == 0 || k > n {
        return None;
    }
    let d = Binomial::new(0.5, n).ok()?;
    Some((2.0 * d.cdf(k.min(n - k))).min(1.0))
}

/// ISO 9241-9 effective throughput of one reciprocal tapping sequence,
/// from every click (hits and misses, in order, `hit` saying which), bits/s.
///
/// The sequence starts at the first hit. The lit target switches only on a
/// hit, so a movement runs from one hit to the next; a miss and its
/// correction belong to the movement they end. Targets are centred at
/// `-A/2` and `+A/2`, so a click on the target at `c` ends a movement in
/// direction `sgn(c)`, and its signed endpoint deviation along the axis is
/// `dx = (x - c) sgn(c)` (positive: overshoot).
/// - `We = 4.133 SD(dx)` over every click after the first hit (the spread
///   of every selection endpoint, misses included: hits alone would
///   truncate it at the target's edges);
/// - `Ae` = the mean distance between successive hits;
/// - `MT = (t_last hit - t_first hit) / movements`;
/// - `IDe = log2(Ae / We + 1)`, `TP = IDe / MT`.
///
/// `None` with fewer than 2 movements, no endpoint spread, or no time.
#[must_use]
pub fn effective_throughput(
    times: &[f64],
    x: &[f64],
    targets: &[f64],
    hit: &[bool],
) -> Option<f64> {
    let n = times.len().min(x.len()).min(targets.len()).min(hit.len());
    let hits: Vec<usize> = (0..n).filter(|&i| hit[i]).collect();
    let (&first, &last) = (hits.first()?, hits.last()?);
    if hits.len() < 3 {
        return None;
    }
    let deviations: Vec<f64> = (first + 1..n)
        .map(|i| (x[i] - targets[i]) * targets[i].signum())
        .collect();
    let amplitudes: Vec<f64> = hits.windows(2).map(|w| (x[w[1]] - x[w[0]]).abs()).collect();
    let we = 4.133 * sample_sd(&deviations)?;
    let ae = mean(&amplitudes)?;
    let mt = (times[last] - times[first]) / (hits.len() - 1) as f64;
    (we > 0.0 && mt > 0.0).then(|| (ae / we + 1.0).log2() / mt)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn binomial_matches_hand_values() {
        // 6 of 6: 2 * 0.5^6.
        assert!((binomial_two_sided(6, 6).unwrap() - 0.031_25).abs() < 1e-15);
        // 5 of 6: 2 * (1 + 6) / 64.
        assert!((binomial_two_sided(5, 6).unwrap() - 14.0 / 64.0).abs() < 1e-12);
        assert_eq!(binomial_two_sided(3, 6), Some(1.0));
        assert_eq!(binomial_two_sided(0, 0), None);
    }

    #[test]
    fn throughput_with_misses_matches_a_hand_computation() {
        // Targets at -0.05 and +0.05 m; click 2 misses (overshoot), click 3
        // corrects on the same target.
        let times = [0.0, 1.0, 1.4, 2.4, 3.5];
        let x = [-0.051, 0.062, 0.049, -0.047, 0.053];
        let targets = [-0.05, 0.05, 0.05, -0.05, 0.05];
        let hit = [true, false, true, true, true];
        // Signed deviations of the clicks after the first hit: 0.012,
        // -0.001, -0.003, 0.003; mean 0.00275, squared residuals 1.3275e-4
        // over 3 degrees of freedom.
        let we = 4.133 * (1.3275e-4_f64 / 3.0).sqrt();
        // Hit to hit: 0.100, 0.096, 0.100 m in 3.5 s.
        let ae = 0.296 / 3.0;
        let mt = 3.5 / 3.0;
        let expected = (ae / we + 1.0).log2() / mt;
        let tp = effective_throughput(&times, &x, &targets, &hit).unwrap();
        assert!((tp - expected).abs() < 1e-9, "{tp} vs {expected}");
        // The hits alone (the miss left out) overstate it: a narrower spread.
        let hits = [0, 2, 3, 4];
        let pick = |v: &[f64]| hits.iter().map(|&i| v[i]).collect::<Vec<_>>();
        let hits_only =
            effective_throughput(&pick(&times), &pick(&x), &pick(&targets), &[true; 4]).unwrap();
        assert!(hits_only > tp, "{hits_only} vs {tp}");
    }
}
