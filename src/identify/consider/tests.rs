use super::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Gauss–Jordan inverse of a small dense matrix (independent of faer).
fn inverse(mut a: Vec<Vec<f64>>) -> Vec<Vec<f64>> {
    let n = a.len();
    let mut inv: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| f64::from(u8::from(i == j))).collect())
        .collect();
    for c in 0..n {
        let p = (c..n)
            .max_by(|&x, &y| a[x][c].abs().total_cmp(&a[y][c].abs()))
            .unwrap();
        a.swap(c, p);
        inv.swap(c, p);
        let d = a[c][c];
        for j in 0..n {
            a[c][j] /= d;
            inv[c][j] /= d;
        }
        for i in 0..n {
            if i != c {
                let f = a[i][c];
                for j in 0..n {
                    a[i][j] -= f * a[c][j];
                    inv[i][j] -= f * inv[c][j];
                }
            }
        }
    }
    inv
}

/// A linear Gaussian model r = Jθ δθ + Jc δc + e, flat prior on θ, c ~
/// N(0, diag σ_c²), unit noise: the consider covariance equals the
/// marginal posterior covariance of θ, the θθ block of
/// (JᵀJ + diag(0, σ_c⁻²))⁻¹, computed directly.
#[test]
fn consider_covariance_is_the_marginal_posterior_of_a_linear_model() {
    let m = 40;
    let t: Vec<f64> = (0..m).map(|k| k as f64 / (m - 1) as f64).collect();
    // θ: offset and slope; c: a quadratic term, a bump and a column the
    // θ absorb entirely (a line: invisible to the data, so its prior
    // spread passes through whole).
    let theta = vec![vec![1.0; m], t.clone()];
    let fixed = vec![
        t.iter().map(|x| x * x).collect::<Vec<f64>>(),
        t.iter()
            .map(|x| (-(x - 0.5f64).powi(2) / 0.01).exp())
            .collect(),
        t.iter().map(|x| 0.5 - 2.0 * x).collect(),
    ];
    let spreads = [0.3, 0.05, 0.2];
    let names: Vec<String> = ["q", "bump", "line"].map(String::from).to_vec();
    let c = consider(
        &theta,
        &fixed,
        &vec![0.0; m],
        &names,
        &spreads,
        1.0,
        &Correlation::independent(),
    );
    let cols: Vec<&Vec<f64>> = theta.iter().chain(&fixed).collect();
    let lambda: Vec<Vec<f64>> = (0..5)
        .map(|a| {
            (0..5)
                .map(|b| {
                    let dot: f64 = cols[a].iter().zip(cols[b]).map(|(x, y)| x * y).sum();
                    dot + if a == b && a >= 2 {
                        spreads[a - 2].powi(-2)
                    } else {
                        0.0
                    }
                })
                .collect()
        })
        .collect();
    let cov = inverse(lambda);
    for (i, row) in cov.iter().take(2).enumerate() {
        let direct = row[i].sqrt();
        assert!(
            (c.std_error[i] / direct - 1.0).abs() < 1e-9,
            "θ{i}: consider {} vs direct {direct}",
            c.std_error[i]
        );
    }
    // The line is absorbed whole (δoffset = −0.5 δc, δslope = 2 δc): its
    // influence is its largest effect, on the slope, 2·0.2 = 0.4.
    assert!(
        (c.fixed[2].influence - 0.4).abs() < 1e-9,
        "{:?}",
        c.fixed[2]
    );
    // With no residual nothing is implicated.
    assert!(c.fixed.iter().all(|f| !f.implicated && f.statistic == 0.0));
    // Exact fixed parameters (spread 0): only the data's own part.
    let exact = consider(
        &theta,
        &fixed,
        &vec![0.0; m],
        &names,
        &[0.0; 3],
        1.0,
        &Correlation::independent(),
    );
    let plain = inverse(vec![
        vec![m as f64, t.iter().sum()],
        vec![t.iter().sum(), t.iter().map(|x| x * x).sum()],
    ]);
    assert!((exact.std_error[0] - plain[0][0].sqrt()).abs() < 1e-12);
}

/// A planted wrong fixed parameter is implicated and its change found;
/// the innocent one is not, at the noise.
#[test]
fn the_score_test_finds_a_planted_fixed_parameter() {
    let m = 60;
    let t: Vec<f64> = (0..m).map(|k| k as f64 / (m - 1) as f64).collect();
    let theta = vec![vec![1.0; m], t.clone()];
    let quad: Vec<f64> = t.iter().map(|x| 30.0 * x * x).collect();
    let wave: Vec<f64> = t.iter().map(|x| (9.0 * x).sin()).collect();
    let fixed = vec![quad.clone(), wave.clone()];
    let names = ["quad".to_string(), "wave".to_string()];
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let noise: Vec<f64> = (0..m)
        .map(|_| {
            // Unit-variance noise (sum of 12 uniforms − 6).
            (0..12).map(|_| rng.random::<f64>()).sum::<f64>() - 6.0
        })
        .collect();
    // Data made with quad's ln c off by +0.8; the fit holds it at 0, so
    // the residual (model − data) after re-fitting θ is −(I−P) quad·0.8.
    let fit = |y: &[f64]| -> Vec<f64> {
        let n = m as f64;
        let (sx, sxx) = (t.iter().sum::<f64>(), t.iter().map(|x| x * x).sum::<f64>());
        let (sy, sxy) = (
            y.iter().sum::<f64>(),
            y.iter().zip(&t).map(|(a, b)| a * b).sum::<f64>(),
        );
        let b = (n * sxy - sx * sy) / (n * sxx - sx * sx);
        let a = (sy - b * sx) / n;
        t.iter().zip(y).map(|(x, v)| a + b * x - v).collect()
    };
    let y: Vec<f64> = (0..m).map(|k| 0.8 * quad[k] + noise[k]).collect();
    let r = fit(&y);
    let rss: f64 = r.iter().map(|v| v * v).sum();
    let c = consider(
        &theta,
        &fixed,
        &r,
        &names,
        &[0.1, 0.1],
        rss / (m - 2) as f64,
        &Correlation::independent(),
    );
    assert!(c.fixed[0].implicated, "{:?}", c.fixed);
    assert!(!c.fixed[1].implicated, "{:?}", c.fixed);
    assert!((c.fixed[0].change - 0.8).abs() < 0.2, "{:?}", c.fixed[0]);
    assert_eq!(c.implicated()[0].parameter, "quad");
    // At the truth (noise only), neither is implicated.
    let r0 = fit(&noise);
    let c0 = consider(
        &theta,
        &fixed,
        &r0,
        &names,
        &[0.1, 0.1],
        1.0,
        &Correlation::independent(),
    );
    assert!(c0.fixed.iter().all(|f| !f.implicated), "{:?}", c0.fixed);
}

/// Non-finite numbers (structural directions, an undefined p-value)
/// are written as JSON null and read back.
#[test]
fn the_analysis_survives_json_with_non_finite_numbers() {
    let c = Consider {
        std_error: vec![0.1, f64::INFINITY],
        fixed: vec![FixedParameter {
            parameter: "a".into(),
            spread: 0.8,
            statistic: 3.0,
            p_value: f64::NAN,
            change: 0.1,
            at_bound: false,
            implicated: false,
            influence: 0.01,
        }],
        critical: f64::INFINITY,
    };
    let text = serde_json::to_string(&c).unwrap();
    let back: Consider = serde_json::from_str(&text).unwrap();
    assert_eq!(back.std_error[0], 0.1);
    assert!(back.std_error[1].is_nan() && back.fixed[0].p_value.is_nan());
    assert_eq!(back.fixed[0].statistic, 3.0);
}

#[test]
fn bounds_spread_is_the_uniform_standard_deviation() {
    let s = bounds_spread(1.0, 0.25, 4.0, true);
    assert!((s - 16f64.ln() / 12f64.sqrt()).abs() < 1e-15);
    assert!((bounds_spread(2.0, 1.0, 3.0, false) - 2.0 / (12f64.sqrt() * 2.0)).abs() < 1e-15);
    assert_eq!(bounds_spread(0.0, -1.0, 1.0, false), 0.0);
}
