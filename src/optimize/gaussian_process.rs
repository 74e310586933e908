//! Gaussian-process regression with a Matérn 5/2 kernel and automatic
//! relevance determination (one length scale per input), the surrogate of
//! Bayesian optimization (seed section 2.2.2; Rasmussen & Williams 2006,
//! "Gaussian Processes for Machine Learning", eq. 2.25–2.30 and 4.17).
//!
//! k(x, x') = σ² (1 + √5 r + 5r²/3) exp(−√5 r), r² = Σ_d (x_d − x'_d)²/ℓ_d².
//!
//! Targets are standardized; σ² is profiled out of the log marginal
//! likelihood (its optimum is yᵀC⁻¹y/n for the correlation matrix C), and the
//! length scales and the nugget are chosen by maximizing it: a grid over an
//! isotropic scale and nugget, then coordinate-wise refinement of each ℓ_d.

#![allow(non_snake_case)]

use crate::dense::{backward_substitute_t, cholesky, forward_substitute};

/// Why a Gaussian process cannot be fitted.
#[derive(Debug, thiserror::Error)]
pub enum GpError {
    /// No observations, or inputs and targets of different lengths or dimensions.
    #[error("invalid training data: {0}")]
    InvalidData(String),
    /// The covariance matrix is not positive definite for any tried nugget
    /// (duplicated inputs with different targets at zero noise).
    #[error("covariance matrix is singular for every tried hyperparameter")]
    Singular,
}

/// A fitted Gaussian process on inputs in (roughly) the unit cube.
#[derive(Clone, Debug)]
pub struct GaussianProcess {
    x: Vec<Vec<f64>>,
    /// Cholesky factor of C + ηI (row-major, n × n).
    L: Vec<f64>,
    /// (C + ηI)⁻¹ y_standardized.
    alpha: Vec<f64>,
    pub length_scales: Vec<f64>,
    /// Relative nugget η (noise variance over signal variance).
    pub nugget: f64,
    /// Profiled signal variance σ² of the standardized targets.
    pub signal_variance: f64,
    y_mean: f64,
    y_scale: f64,
}

/// The Matérn 5/2 correlation at scaled distance r.
pub fn matern52(r: f64) -> f64 {
    let s = 5f64.sqrt() * r;
    (1.0 + s + s * s / 3.0) * (-s).exp()
}

fn correlation(a: &[f64], b: &[f64], ls: &[f64]) -> f64 {
    let r2: f64 = a
        .iter()
        .zip(b)
        .zip(ls)
        .map(|((x, y), l)| ((x - y) / l).powi(2))
        .sum();
    matern52(r2.sqrt())
}

/// Factor, weights and profiled log marginal likelihood for one hyperparameter set.
fn evaluate(
    x: &[Vec<f64>],
    y: &[f64],
    ls: &[f64],
    nugget: f64,
) -> Option<(Vec<f64>, Vec<f64>, f64, f64)> {
    let n = x.len();
    let mut C = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..=i {
            let c = correlation(&x[i], &x[j], ls);
            C[i * n + j] = c;
            C[j * n + i] = c;
        }
        C[i * n + i] += nugget;
    }
    if !cholesky(&mut C, n) {
        return None;
    }
    let mut alpha = y.to_vec();
    forward_substitute(&C, n, &mut alpha, 1, n);
    let quad: f64 = alpha.iter().map(|a| a * a).sum();
    backward_substitute_t(&C, n, &mut alpha, 1);
    let sigma2 = (quad / n as f64).max(1e-300);
    let log_det: f64 = (0..n).map(|i| 2.0 * C[i * n + i].ln()).sum();
    let nf = n as f64;
    let lml = -0.5 * nf * sigma2.ln()
        - 0.5 * log_det
        - 0.5 * nf * (1.0 + (2.0 * std::f64::consts::PI).ln());
    Some((C, alpha, sigma2, lml))
}

impl GaussianProcess {
    /// Fit to observations `y` at inputs `x` (each of the same dimension),
    /// choosing length scales and nugget by maximum likelihood.
    pub fn fit(x: &[Vec<f64>], y: &[f64]) -> Result<GaussianProcess, GpError> {
        let n = x.len();
        if n == 0 || y.len() != n {
            return Err(GpError::InvalidData(format!(
                "{n} inputs, {} targets",
                y.len()
            )));
        }
        let d = x[0].len();
        if x.iter().any(|p| p.len() != d) || y.iter().any(|v| !v.is_finite()) {
            return Err(GpError::InvalidData(
                "inputs of different dimension or non-finite targets".into(),
            ));
        }
        let y_mean = y.iter().sum::<f64>() / n as f64;
        let var = y.iter().map(|v| (v - y_mean).powi(2)).sum::<f64>() / n as f64;
        let y_scale = if var > 0.0 { var.sqrt() } else { 1.0 };
        let ys: Vec<f64> = y.iter().map(|v| (v - y_mean) / y_scale).collect();
        // Isotropic grid over ℓ ∈ [0.05, 3] (log-spaced) and the nugget.
        let mut best: Option<(f64, Vec<f64>, f64)> = None;
        for &nugget in &[1e-8, 1e-6, 1e-4, 1e-2] {
            for k in 0..12 {
                let l = 0.05 * (3.0f64 / 0.05).powf(k as f64 / 11.0);
                let ls = vec![l; d];
                if let Some((_, _, _, lml)) = evaluate(x, &ys, &ls, nugget) {
                    if best.as_ref().is_none_or(|b| lml > b.0) {
                        best = Some((lml, ls, nugget));
                    }
                }
            }
        }
        let (mut lml, mut ls, nugget) = best.ok_or(GpError::Singular)?;
        // Coordinate-wise refinement of each length scale.
        if d > 1 {
            for _ in 0..3 {
                for dim in 0..d {
                    for &m in &[0.25, 0.5, 0.7, 1.4, 2.0, 4.0] {
                        let mut trial = ls.clone();
                        trial[dim] = (trial[dim] * m).clamp(0.01, 20.0);
                        if let Some((_, _, _, v)) = evaluate(x, &ys, &trial, nugget) {
                            if v > lml {
                                lml = v;
                                ls = trial;
                            }
                        }
                    }
                }
            }
        }
        let (L, alpha, signal_variance, _) =
            evaluate(x, &ys, &ls, nugget).ok_or(GpError::Singular)?;
        Ok(GaussianProcess {
            x: x.to_vec(),
            L,
            alpha,
            length_scales: ls,
            nugget,
            signal_variance,
            y_mean,
            y_scale,
        })
    }

    /// Posterior mean and standard deviation at `p` (eq. 2.25–2.26), in the
    /// units of the original targets.
    pub fn predict(&self, p: &[f64]) -> (f64, f64) {
        let n = self.x.len();
        let mut k: Vec<f64> = self
            .x
            .iter()
            .map(|xi| correlation(xi, p, &self.length_scales))
            .collect();
        let mean: f64 = k.iter().zip(&self.alpha).map(|(a, b)| a * b).sum();
        forward_substitute(&self.L, n, &mut k, 1, n);
        let v: f64 = k.iter().map(|a| a * a).sum();
        let var = (self.signal_variance * (1.0 + self.nugget - v)).max(0.0);
        (self.y_mean + self.y_scale * mean, self.y_scale * var.sqrt())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matern_known_values() {
        assert_eq!(matern52(0.0), 1.0);
        // r = 1: (1 + √5 + 5/3) e^{−√5}.
        let s = 5f64.sqrt();
        assert!((matern52(1.0) - (1.0 + s + 5.0 / 3.0) * (-s).exp()).abs() < 1e-15);
    }

    #[test]
    fn interpolates_a_smooth_function_and_is_uncertain_far_away() {
        let x: Vec<Vec<f64>> = (0..12).map(|i| vec![i as f64 / 11.0]).collect();
        let y: Vec<f64> = x.iter().map(|p| (6.0 * p[0]).sin()).collect();
        let gp = GaussianProcess::fit(&x, &y).unwrap();
        for (p, v) in x.iter().zip(&y) {
            let (m, s) = gp.predict(p);
            assert!((m - v).abs() < 1e-3, "at {p:?}: {m} vs {v}");
            assert!(s < 0.05);
        }
        let mid: f64 = 0.5 / 11.0 + 0.5;
        let (m, _) = gp.predict(&[mid]);
        assert!((m - (6.0 * mid).sin()).abs() < 0.02);
        let (_, far) = gp.predict(&[3.0]);
        assert!(far > 0.5, "prior uncertainty far from data: {far}");
    }

    #[test]
    fn irrelevant_input_gets_a_long_length_scale() {
        let mut x = Vec::new();
        for i in 0..6 {
            for j in 0..4 {
                x.push(vec![i as f64 / 5.0, j as f64 / 3.0]);
            }
        }
        let y: Vec<f64> = x.iter().map(|p| (4.0 * p[0]).cos()).collect();
        let gp = GaussianProcess::fit(&x, &y).unwrap();
        assert!(
            gp.length_scales[1] > 3.0 * gp.length_scales[0],
            "{:?}",
            gp.length_scales
        );
    }
}
