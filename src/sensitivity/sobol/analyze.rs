//! Sobol indices from the model outputs at a Saltelli sample (seed section
//! 2.1.2, eq. 2.9–2.12), with bootstrap confidence intervals, as SALib's
//! `analyze/sobol.py`.
//!
//! With f(A), f(B), f(AB⁽ⁱ⁾) the outputs at the rows of A, B and AB⁽ⁱ⁾ and V
//! the variance of f over A ∪ B:
//!
//! - first order, Saltelli et al. (2010), doi:10.1016/j.cpc.2009.09.018, table 2 (b):
//!   S1ᵢ = mean_j f(B)_j (f(AB⁽ⁱ⁾)_j − f(A)_j) / V
//! - total, Jansen (1999), doi:10.1016/S0010-4655(98)00154-4 (Saltelli 2010 table 2 (f)):
//!   STᵢ = ½ mean_j (f(A)_j − f(AB⁽ⁱ⁾)_j)² / V
//! - second order, Saltelli (2002), doi:10.1016/S0010-4655(02)00280-1:
//!   S2ᵢₖ = mean_j (f(BA⁽ⁱ⁾)_j f(AB⁽ᵏ⁾)_j − f(A)_j f(B)_j) / V − S1ᵢ − S1ₖ
//!
//! Confidence: `*_conf` = z · std (ddof 1) of the estimate over `bootstrap`
//! resamples of the N base rows (with replacement), z the standard normal
//! quantile at ½ + confidence/2. Resample k draws its rows from its own
//! ChaCha8 stream (seed, stream k), so results do not depend on the thread
//! count. A constant output has no variance to apportion: its indices are 0
//! with a warning.

#![allow(non_snake_case)]

use super::super::SensitivityError;
use super::sample::Layout;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use statrs::distribution::{ContinuousCDF, Normal};

/// Bootstrap settings.
#[derive(Clone, Copy, Debug)]
pub struct AnalyzeParams {
    /// Number of bootstrap resamples (0: no confidence intervals, `*_conf` = 0).
    pub bootstrap: usize,
    /// Confidence level of the intervals, in (0, 1).
    pub confidence: f64,
    pub seed: u64,
}

impl Default for AnalyzeParams {
    fn default() -> Self {
        AnalyzeParams {
            bootstrap: 100,
            confidence: 0.95,
            seed: 0,
        }
    }
}

/// Sobol indices of one output, length d in varied-parameter order.
#[derive(Clone, Debug, PartialEq)]
pub struct SobolIndices {
    pub S1: Vec<f64>,
    pub S1_conf: Vec<f64>,
    pub ST: Vec<f64>,
    pub ST_conf: Vec<f64>,
    /// `S2[i][k]` for i < k (NaN elsewhere), with second order only.
    pub S2: Option<Vec<Vec<f64>>>,
    pub S2_conf: Option<Vec<Vec<f64>>>,
    /// ST of every bootstrap resample (`bootstrap` × d). Resample k draws
    /// the same base rows for every output of one study, so indices of
    /// several outputs can be combined per resample (e.g. the weighted mean
    /// of PUB2, [`crate::sensitivity::combined_intervals`]).
    pub ST_resamples: Vec<Vec<f64>>,
    pub warnings: Vec<String>,
}

/// The output column split into the blocks of the Saltelli layout.
struct Blocks {
    A: Vec<f64>,
    B: Vec<f64>,
    AB: Vec<Vec<f64>>,
    BA: Vec<Vec<f64>>,
}

fn split(layout: &Layout, y: &[f64]) -> Blocks {
    let (n, d, step) = (layout.n, layout.d, layout.step());
    let mut b = Blocks {
        A: Vec::with_capacity(n),
        B: Vec::with_capacity(n),
        AB: vec![Vec::with_capacity(n); d],
        BA: vec![Vec::with_capacity(if layout.second_order { n } else { 0 }); d],
    };
    // Centre on the mean of A ∪ B: the estimators are shift-invariant in
    // expectation, centring keeps the products small (SALib standardizes).
    let mean = (0..n)
        .map(|j| y[j * step] + y[j * step + step - 1])
        .sum::<f64>()
        / (2 * n) as f64;
    for row in y.chunks_exact(step) {
        b.A.push(row[0] - mean);
        b.B.push(row[step - 1] - mean);
        for i in 0..d {
            b.AB[i].push(row[1 + i] - mean);
            if layout.second_order {
                b.BA[i].push(row[1 + d + i] - mean);
            }
        }
    }
    b
}

/// Point estimates over the base rows `rows` (all rows, or one resample).
struct Estimate {
    S1: Vec<f64>,
    ST: Vec<f64>,
    S2: Vec<Vec<f64>>,
}

fn estimate(b: &Blocks, rows: &[usize], second_order: bool) -> Estimate {
    let d = b.AB.len();
    let m = rows.len() as f64;
    let (mut s, mut s2) = (0.0, 0.0);
    for &j in rows {
        for v in [b.A[j], b.B[j]] {
            s += v;
            s2 += v * v;
        }
    }
    let mean = s / (2.0 * m);
    let V = s2 / (2.0 * m) - mean * mean;
    if V <= 0.0 {
        return Estimate {
            S1: vec![0.0; d],
            ST: vec![0.0; d],
            S2: vec![vec![0.0; d]; d],
        };
    }
    // Gather the resampled A and B rows once; each parameter then gathers only AB⁽ⁱ⁾.
    let a: Vec<f64> = rows.iter().map(|&j| b.A[j]).collect();
    let bb: Vec<f64> = rows.iter().map(|&j| b.B[j]).collect();
    let mut S1 = vec![0.0; d];
    let mut ST = vec![0.0; d];
    for i in 0..d {
        let ab = &b.AB[i];
        let (mut first, mut total) = (0.0, 0.0);
        for ((&j, &aj), &bj) in rows.iter().zip(&a).zip(&bb) {
            let abj = ab[j];
            first += bj * (abj - aj);
            total += (aj - abj) * (aj - abj);
        }
        S1[i] = first / m / V;
        ST[i] = 0.5 * total / m / V;
    }
    let mut S2 = vec![vec![f64::NAN; d]; d];
    if second_order {
        for i in 0..d {
            for k in i + 1..d {
                let v: f64 = rows
                    .iter()
                    .map(|&j| b.BA[i][j] * b.AB[k][j] - b.A[j] * b.B[j])
                    .sum();
                S2[i][k] = v / m / V - S1[i] - S1[k];
            }
        }
    }
    Estimate { S1, ST, S2 }
}

/// z · sample standard deviation (ddof 1) of `values`.
fn conf(z: f64, values: impl Iterator<Item = f64> + Clone) -> f64 {
    let n = values.clone().count();
    if n < 2 {
        return 0.0;
    }
    let mean = values.clone().sum::<f64>() / n as f64;
    let var = values.map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
    z * var.sqrt()
}

/// Sobol indices of one output `y` evaluated at a sample of layout `layout`
/// (SALib's `analyze(problem, Y)`).
pub fn analyze(
    layout: &Layout,
    y: &[f64],
    params: &AnalyzeParams,
) -> Result<SobolIndices, SensitivityError> {
    if layout.n == 0 || layout.d == 0 || y.len() != layout.len() {
        return Err(SensitivityError::Invalid(format!(
            "{} outputs do not match a Saltelli sample of N = {} and {} parameters ({} expected)",
            y.len(),
            layout.n,
            layout.d,
            layout.len()
        )));
    }
    if let Some(i) = y.iter().position(|v| !v.is_finite()) {
        return Err(SensitivityError::Invalid(format!(
            "output of sample {i} is {}; every output must be finite",
            y[i]
        )));
    }
    if !(params.confidence > 0.0 && params.confidence < 1.0) {
        return Err(SensitivityError::Invalid(format!(
            "confidence level {} must lie strictly between 0 and 1",
            params.confidence
        )));
    }
    let d = layout.d;
    let mut warnings = Vec::new();
    let constant = y.iter().all(|v| *v == y[0]);
    if constant {
        warnings.push(format!(
            "the output is constant ({}) over all samples: its indices are set to 0",
            y[0]
        ));
    }
    let blocks = split(layout, y);
    let all: Vec<usize> = (0..layout.n).collect();
    let point = estimate(&blocks, &all, layout.second_order);
    let z = Normal::new(0.0, 1.0)
        .map_err(|e| SensitivityError::Invalid(e.to_string()))?
        .inverse_cdf(0.5 + params.confidence / 2.0);
    let resamples: Vec<Estimate> = (0..params.bootstrap)
        .into_par_iter()
        .map(|k| {
            let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
            rng.set_stream(k as u64);
            let rows: Vec<usize> = (0..layout.n)
                .map(|_| rng.random_range(0..layout.n))
                .collect();
            estimate(&blocks, &rows, layout.second_order)
        })
        .collect();
    let S1_conf = (0..d)
        .map(|i| conf(z, resamples.iter().map(|e| e.S1[i])))
        .collect();
    let ST_conf = (0..d)
        .map(|i| conf(z, resamples.iter().map(|e| e.ST[i])))
        .collect();
    let (S2, S2_conf) = if layout.second_order {
        let c = (0..d)
            .map(|i| {
                (0..d)
                    .map(|k| {
                        if k > i {
                            conf(z, resamples.iter().map(|e| e.S2[i][k]))
                        } else {
                            f64::NAN
                        }
                    })
                    .collect()
            })
            .collect();
        (Some(point.S2), Some(c))
    } else {
        (None, None)
    };
    Ok(SobolIndices {
        S1: point.S1,
        S1_conf,
        ST: point.ST,
        ST_conf,
        S2,
        S2_conf,
        ST_resamples: resamples.into_iter().map(|e| e.ST).collect(),
        warnings,
    })
}
