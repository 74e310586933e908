//! The parameters an update left fixed, at its result: how much their own
//! spread widens the identified parameters' uncertainty (the **consider
//! covariance**), and whether the residual points at any of them (the
//! **score test**).
//!
//! Every update identifies a subset θ of the model's parameters (the
//! screening's significant ones) and holds the others, c, at their file
//! values. The Gauss–Newton covariance of θ ([`super::identifiability`])
//! assumes those values exact. On a real machine they are not: the
//! screening only said they matter little *over their whole box*.
//!
//! **Consider covariance** (Tapley, Schutz & Born 2004, "Statistical Orbit
//! Determination", §6.3; Bard 1974 §7-9). With J_θ, J_c the Jacobians of
//! the whitened residuals r (σ units) with respect to ln θ and ln c,
//! G = J_θᵀJ_θ and G⁺ its pseudo-inverse over the determined directions, a
//! change δc moves the least-squares estimate by δθ̂ = S δc with
//!
//! S = −G⁺ J_θᵀ J_c,
//!
//! so with P_c = diag(σ_c²) the spread assumed for the fixed parameters
//! the textbook consider covariance is C = σ̂² G⁺ + S P_c Sᵀ. The data
//! themselves say something of c, through the part of their columns θ
//! cannot absorb, A = (I − J_θ G⁺ J_θᵀ) J_c; conditioned on it, c's
//! spread is Σ_c = (AᵀA/s² + P_c⁻¹)⁻¹ and
//!
//! C = σ̂² G⁺ + S Σ_c Sᵀ,
//!
//! which for a linear model with Gaussian noise and prior is exactly the
//! marginal posterior covariance of θ with c integrated out (the θθ block
//! of (JᵀJ + diag(0, P_c⁻¹))⁻¹, by the block-inverse identity): a fixed
//! parameter the data cannot see passes its whole spread on, one they see
//! passes on only what they leave open — and if they see it off its
//! value, the score test below says so.
//!
//! By default σ_c is the standard deviation of a value uniform in ln c over
//! its bounds, ln(upper/lower)/√12 (linear-scale parameters: the same of c
//! over its bounds, relative to c): "anywhere within the bounds the model
//! file states". `fixed_spread` replaces it with one relative standard
//! deviation for all, and 0 restores the assumption that they are exact.
//!
//! **Score (Lagrange-multiplier) test** (Rao 1948; Seber & Wild 2003,
//! "Nonlinear Regression", §5.9.2): is c_j right, with θ re-adjusted? The
//! part of its column the identified parameters cannot absorb is
//! a_j = (I − J_θ G⁺ J_θᵀ) J_c,j; the statistic
//!
//! T_j = (a_jᵀ r)² / (s² ‖a_j‖²),   s² = max(1, σ̂²),
//!
//! is χ²₁ under "c_j is right and the residuals are noise of the stated
//! size" (s² = σ̂² when the residuals are larger than stated: the test then
//! asks whether c_j explains them better than their own scatter). A fixed
//! parameter is **implicated** when T_j exceeds the χ²₁ quantile at the
//! Bonferroni level α/q over the q fixed parameters (α = 0.05): the data,
//! with every identified parameter free to compensate, still point at it.
//! Its linearized best change is δ ln c_j = −a_jᵀr/‖a_j‖².

#![allow(non_snake_case)]

use super::batch_means::{data_variance, Correlation};
use super::identifiability::{IN_NULL_SPACE, STRUCTURAL};
use super::verdict::nan_if_null;
use crate::dynamics::eigen::symmetric_eigen;
use faer::Mat;
use serde::{Deserialize, Serialize};
use statrs::distribution::{ChiSquared, ContinuousCDF};

/// Family-wise level of the score test over all fixed parameters.
pub const ALPHA: f64 = 0.05;

/// What the score test says of one fixed parameter.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FixedParameter {
    pub parameter: String,
    /// Standard deviation of ln c assumed for it (the consider spread).
    #[serde(deserialize_with = "nan_if_null")]
    pub spread: f64,
    /// T_j, χ²₁ under "its value is right" (module docs).
    #[serde(deserialize_with = "nan_if_null")]
    pub statistic: f64,
    /// P(χ²₁ ≥ T_j).
    #[serde(deserialize_with = "nan_if_null")]
    pub p_value: f64,
    /// The change of ln c_j that would fit best (linearized), identified
    /// parameters re-adjusted; 0 when the residual cannot see it.
    #[serde(deserialize_with = "nan_if_null")]
    pub change: f64,
    /// The change takes it to the outer 2.5 % of its range at either end,
    /// where the bound holds it, not the data (set where the bounds are
    /// known: `assessment`; see [`super::verdict::Implication`]).
    #[serde(default)]
    pub at_bound: bool,
    /// T_j above the Bonferroni-corrected χ²₁ quantile.
    pub implicated: bool,
    /// Its largest contribution to an identified parameter's standard error
    /// (of ln θ): |S_ij| σ_c,j.
    #[serde(deserialize_with = "nan_if_null")]
    pub influence: f64,
}

/// The consider analysis at one point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Consider {
    /// Per identified parameter: the standard error of ln θ with the fixed
    /// parameters' spread included, √C_ii (+∞ in a structural direction;
    /// JSON null, read back as NaN).
    #[serde(deserialize_with = "nan_if_null_each")]
    pub std_error: Vec<f64>,
    /// Per fixed parameter, in the order given.
    pub fixed: Vec<FixedParameter>,
    /// The χ²₁ quantile a statistic must exceed to implicate.
    #[serde(deserialize_with = "nan_if_null")]
    pub critical: f64,
}

/// Numbers that JSON may hold as null (non-finite ones), read back as NaN.
fn nan_if_null_each<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
    Ok(Vec::<Option<f64>>::deserialize(d)?
        .into_iter()
        .map(|v| v.unwrap_or(f64::NAN))
        .collect())
}

impl Consider {
    /// The implicated fixed parameters, largest statistic first.
    pub fn implicated(&self) -> Vec<&FixedParameter> {
        let mut v: Vec<&FixedParameter> = self.fixed.iter().filter(|f| f.implicated).collect();
        v.sort_by(|a, b| b.statistic.total_cmp(&a.statistic));
        v
    }
}

/// The consider covariance and score tests at residuals `r` (σ units) of a
/// least-squares result: `theta` are the identified parameters' Jacobian
/// columns (∂r/∂ln θ), `fixed` the fixed parameters' with their `names` and
/// assumed `spreads` (σ of ln c), `sigma2` the residual variance σ̂² the
/// data covariance is scaled by (1 when it cannot be estimated), and
/// `correlation` how the residuals are correlated: its AR(1) factor
/// ([`ar1_inflation`]) makes the tests and the conditioning on the data
/// less confident, and the identified parameters' data variance is that
/// of [`super::batch_means::data_variance`].
pub fn consider(
    theta: &[Vec<f64>],
    fixed: &[Vec<f64>],
    r: &[f64],
    names: &[String],
    spreads: &[f64],
    sigma2: f64,
    correlation: &Correlation,
) -> Consider {
    let inflation = correlation.inflation;
    let n = theta.len();
    let m = r.len();
    let (g_plus, structural) = pseudo_inverse(theta);
    // Jθᵀ x for a residual-space vector x.
    let project = |x: &[f64]| -> Vec<f64> {
        theta
            .iter()
            .map(|c| c.iter().zip(x).map(|(a, b)| a * b).sum())
            .collect()
    };
    let q = fixed.len();
    let critical = ChiSquared::new(1.0)
        .map(|d| d.inverse_cdf(1.0 - ALPHA / q.max(1) as f64))
        .unwrap_or(f64::INFINITY);
    let chi2 = ChiSquared::new(1.0).ok();
    // s_j = −G⁺ Jθᵀ c_j: how the estimate follows c_j; a_j = c_j + Jθ s_j:
    // the part of its column θ cannot absorb.
    let follow: Vec<Vec<f64>> = fixed
        .iter()
        .map(|col| {
            let b = project(col);
            (0..n)
                .map(|i| -(0..n).map(|k| g_plus[(i, k)] * b[k]).sum::<f64>())
                .collect()
        })
        .collect();
    let absorbed: Vec<Vec<f64>> = fixed
        .iter()
        .zip(&follow)
        .map(|(col, s)| {
            (0..m)
                .map(|t| col[t] + (0..n).map(|i| theta[i][t] * s[i]).sum::<f64>())
                .collect()
        })
        .collect();
    let s2 = sigma2.max(1.0) * inflation.max(1.0);
    let sigma_c = posterior(&absorbed, spreads, s2);
    let mut variance = data_variance(theta, r, &g_plus, sigma2, correlation);
    for (i, v) in variance.iter_mut().enumerate() {
        for j in 0..q {
            for k in 0..q {
                *v += follow[j][i] * sigma_c[(j, k)] * follow[k][i];
            }
        }
    }
    let mut out: Vec<FixedParameter> = (0..q)
        .map(|j| FixedParameter {
            parameter: names[j].clone(),
            spread: spreads[j],
            statistic: 0.0,
            p_value: 1.0,
            change: 0.0,
            at_bound: false,
            implicated: false,
            influence: follow[j]
                .iter()
                .map(|s| (s * sigma_c[(j, j)].max(0.0).sqrt()).abs())
                .fold(0.0, f64::max),
        })
        .collect();
    let dof = m.saturating_sub(n).max(1) as f64;
    score_tests(&mut out, absorbed, r, s2, dof, critical);
    for f in &mut out {
        f.p_value = chi2.as_ref().map_or(f64::NAN, |d| 1.0 - d.cdf(f.statistic));
    }
    let std_error = (0..n)
        .map(|i| {
            if structural[i] {
                f64::INFINITY
            } else {
                variance[i].max(0.0).sqrt()
            }
        })
        .collect();
    Consider {
        std_error,
        fixed: out,
        critical,
    }
}

/// The covariance of the fixed parameters (σ of ln c) given the data:
/// Σ = (AᵀA/s² + P_c⁻¹)⁻¹ over those with a spread (module docs); 0 for
/// the exact ones (spread 0).
fn posterior(absorbed: &[Vec<f64>], spreads: &[f64], s2: f64) -> Mat<f64> {
    let q = absorbed.len();
    let free: Vec<usize> = (0..q).filter(|&j| spreads[j] > 0.0).collect();
    let k = free.len();
    let M = Mat::<f64>::from_fn(k, k, |a, b| {
        let (ja, jb) = (free[a], free[b]);
        let dot: f64 = absorbed[ja]
            .iter()
            .zip(&absorbed[jb])
            .map(|(x, y)| x * y)
            .sum();
        dot / s2 + if a == b { spreads[ja].powi(-2) } else { 0.0 }
    });
    let mut out = Mat::<f64>::zeros(q, q);
    if k == 0 {
        return out;
    }
    // M is symmetric positive definite (the prior term): invert by its
    // eigenvectors; a failed decomposition falls back to the prior alone.
    match symmetric_eigen(&M) {
        Ok((mu, V)) => {
            for a in 0..k {
                for b in 0..k {
                    out[(free[a], free[b])] = (0..k)
                        .filter(|&l| mu[l] > 0.0)
                        .map(|l| V[(a, l)] * V[(b, l)] / mu[l])
                        .sum();
                }
            }
        }
        Err(_) => {
            for &j in &free {
                out[(j, j)] = spreads[j].powi(2);
            }
        }
    }
    out
}

/// The score tests by forward selection: each round tests every fixed
/// parameter not yet implicated on the residual with the implicated ones
/// re-fitted (their absorbed columns `a` orthogonalized out), implicates the
/// largest statistic above `critical`, and stops when none is. A marginal
/// test alone would also implicate a parameter merely correlated with the
/// real cause (its column sees part of the cause's misfit). `s2`: the
/// residual variance floor (1: the stated noise); it is re-estimated from
/// the remaining residual over `dof` degrees of freedom after each round.
fn score_tests(
    out: &mut [FixedParameter],
    mut a: Vec<Vec<f64>>,
    r: &[f64],
    s2: f64,
    dof: f64,
    critical: f64,
) {
    let dot = |x: &[f64], y: &[f64]| -> f64 { x.iter().zip(y).map(|(p, q)| p * q).sum() };
    let mut r = r.to_vec();
    let mut s2 = s2;
    let mut dof = dof;
    loop {
        let mut best: Option<(usize, f64)> = None;
        for (j, f) in out.iter_mut().enumerate() {
            if f.implicated {
                continue;
            }
            let aa = dot(&a[j], &a[j]);
            let visible = aa > f64::MIN_POSITIVE && aa.is_finite();
            let ar = dot(&a[j], &r);
            f.statistic = if visible { ar * ar / (s2 * aa) } else { 0.0 };
            f.change = if visible { -ar / aa } else { 0.0 };
            if f.statistic > critical && best.is_none_or(|(_, t)| f.statistic > t) {
                best = Some((j, f.statistic));
            }
        }
        let Some((k, _)) = best else { return };
        out[k].implicated = true;
        // Re-fit c_k: remove its direction from the residual and from the
        // other columns (Gram–Schmidt), so the next round is conditional.
        let ak = a[k].clone();
        let kk = dot(&ak, &ak);
        let rk = dot(&ak, &r) / kk;
        r.iter_mut().zip(&ak).for_each(|(v, x)| *v -= rk * x);
        for (j, col) in a.iter_mut().enumerate() {
            if j != k && !out[j].implicated {
                let c = dot(&ak, col) / kk;
                col.iter_mut().zip(&ak).for_each(|(v, x)| *v -= c * x);
            }
        }
        dof = (dof - 1.0).max(1.0);
        s2 = (dot(&r, &r) / dof).max(1.0);
    }
}

/// The variance factor (1 + ρ)/(1 − ρ) of a linear combination of AR(1)
/// residuals with lag-1 correlation ρ (ρ clipped to [0, 0.98]): smooth FRF
/// misfits hold far fewer independent lines than they have, and a test
/// that counted each line as independent would implicate anything (Box,
/// Jenkins & Reinsel, "Time Series Analysis", the effective sample size).
pub fn ar1_inflation(rho: f64) -> f64 {
    let rho = if rho.is_finite() {
        rho.clamp(0.0, 0.98)
    } else {
        0.0
    };
    (1.0 + rho) / (1.0 - rho)
}

/// The standard deviation of ln p for a value uniform over its bounds
/// (module docs): ln(upper/lower)/√12 on a log scale, (upper − lower)/(√12
/// |p|) on a linear one; 0 for degenerate bounds.
pub fn bounds_spread(value: f64, lower: f64, upper: f64, log: bool) -> f64 {
    let s = if log && lower > 0.0 {
        (upper / lower).ln() / 12f64.sqrt()
    } else if value != 0.0 {
        (upper - lower) / (12f64.sqrt() * value.abs())
    } else {
        0.0
    };
    if s.is_finite() {
        s.max(0.0)
    } else {
        0.0
    }
}

/// G⁺ = (JᵀJ)⁺ over the determined directions and which parameters lie in
/// a structural null direction, as [`super::identifiability`] decides them
/// (one eigen-decomposition of G; sequential, so bit-identical).
pub(super) fn pseudo_inverse(columns: &[Vec<f64>]) -> (Mat<f64>, Vec<bool>) {
    let n = columns.len();
    if n == 0 {
        return (Mat::zeros(0, 0), Vec::new());
    }
    let G = crate::dense::gram(columns);
    let (mu, V) =
        symmetric_eigen(&G).unwrap_or_else(|_| (vec![0.0; n], Mat::<f64>::identity(n, n)));
    let largest = mu.iter().copied().fold(0.0f64, f64::max);
    let null: Vec<bool> = mu
        .iter()
        .map(|&m| m <= STRUCTURAL * STRUCTURAL * largest || m <= 0.0)
        .collect();
    let g_plus = pseudo_inverse_of(&mu, &V, &|k| null[k]);
    let structural = (0..n)
        .map(|i| (0..n).any(|k| null[k] && V[(i, k)].abs() >= IN_NULL_SPACE))
        .collect();
    (g_plus, structural)
}

/// G⁺ = Σ_k v_k v_kᵀ/μ_k over the eigenpairs (μ, V) of G that are not
/// `null`.
pub(super) fn pseudo_inverse_of(
    mu: &[f64],
    V: &Mat<f64>,
    null: &dyn Fn(usize) -> bool,
) -> Mat<f64> {
    let n = mu.len();
    Mat::from_fn(n, n, |i, j| {
        (0..n)
            .filter(|&k| !null(k))
            .map(|k| V[(i, k)] * V[(j, k)] / mu[k])
            .sum()
    })
}

#[cfg(test)]
mod tests;
