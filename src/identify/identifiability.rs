//! Identifiability and uncertainty at a least-squares solution (Gauss–Newton
//! linearization; Bard 1974, "Nonlinear Parameter Estimation", ch. 7;
//! Friswell & Mottershead 1995, ch. 7).
//!
//! With J the Jacobian of the weighted residuals r (each divided by its
//! standard deviation, [`super::Uncertainty`]) with respect to ln p — so
//! columns are "residual change in σ units per relative change of p" —
//! J = U S Vᵀ, and:
//!
//! - **Structural non-identifiability**: a direction v_k with s_k below
//!   10⁻⁶ s_max is a combination Σ v_ik ln p_i the model's modes cannot see
//!   at all: two springs in parallel have identical columns, so s = 0 for
//!   v = (1, −1)/√2 — their ratio is free, only their sum counts (the test
//!   bench's two front mounts laterally; left and right guide shoes of one
//!   carriage laterally). Every parameter with |v_ik| ≥ 0.05 in such a
//!   direction is not identifiable, whatever the data quality.
//! - **Covariance**, the textbook Gauss–Newton estimate scaled by the
//!   residual variance: C = σ̂² (JᵀJ)⁺ over the other directions, with
//!   σ̂² = ‖r‖²/(m − rank). A parameter is identifiable when its standard
//!   error √C_ii (relative, of ln p) is at most `max_std_error`; so with
//!   noisy data a weakly determined parameter is flagged, while exact data
//!   (σ̂ → 0) determine everything that is not structurally free. The
//!   errors give 95 % intervals p·exp(±1.96 √C_ii).
//! - The a-priori error √C₀,ii with C₀ = (JᵀJ)⁺ (σ̂ = 1: the precision the
//!   stated uncertainty of the reference allows) is reported beside it.
//!
//! The Jacobian comes from central differences (so an exact degeneracy
//! shows as s ≈ 10⁻⁹ s_max, far below the threshold); the singular values
//! from the eigenvalues of JᵀJ (n ≤ a few dozen parameters; sequential, so
//! bit-identical whatever the thread count).

#![allow(non_snake_case)]

use super::batch_means::{data_variance, Correlation};
use super::consider::pseudo_inverse_of;
use super::joint_effect::JointEffect;
use crate::dynamics::eigen::symmetric_eigen;
use faer::Mat;
use serde::{Deserialize, Serialize};

/// Singular values below this fraction of the largest are structural zeros
/// (eigenvalues of JᵀJ below its square).
pub(crate) const STRUCTURAL: f64 = 1e-6;

/// z of a two-sided 95 % interval (the normal's 0.975 quantile).
pub const Z95: f64 = 1.959_963_984_540_054;

/// The 95 % interval value·exp(∓[`Z95`] σ) of a value whose logarithm has
/// standard error `sigma`, cut at `bounds` (the update cannot leave them).
pub fn interval(value: f64, sigma: f64, bounds: (f64, f64)) -> (f64, f64) {
    (
        (value * (-Z95 * sigma).exp()).max(bounds.0),
        (value * (Z95 * sigma).exp()).min(bounds.1),
    )
}

/// Smallest |v_ik| for a parameter to share a structural null direction.
pub(crate) const IN_NULL_SPACE: f64 = 0.05;

/// Smallest |v_ik| for a parameter to be named in a combination.
const NAMED_WEIGHT: f64 = 0.2;

/// One parameter's verdict and uncertainty.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ParameterUncertainty {
    pub parameter: String,
    pub identifiable: bool,
    /// In a structural null direction (the model cannot see it at all).
    pub structural: bool,
    /// A-priori relative standard error at the stated uncertainty (+∞ when
    /// structural).
    #[serde(deserialize_with = "super::verdict::nan_if_null")]
    pub prior_std_error: f64,
    /// Relative standard error (identifiable only): σ̂ √(τ C₀,ii), or the
    /// batch-means sandwich's when larger ([`super::batch_means`]),
    /// widened where the cost is flatter than its quadratic
    /// ([`super::curvature`]).
    pub std_error: Option<f64>,
    /// ρ of [`super::curvature`]: the cost's rise at ±2σ along the
    /// parameter's conditional direction over the quadratic's (1 for a
    /// linear model; `None` where not checked).
    #[serde(default)]
    pub curvature: Option<f64>,
}

/// A combination of parameters the data do not determine.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Combination {
    /// Singular value s_k of the direction (σ units per unit of ln p); 0
    /// for a structural group.
    pub singular_value: f64,
    /// Free directions in it: 1 for a weak direction; for a structural
    /// group, the dimension of its null space (two parallel springs: 1).
    pub free: usize,
    /// A weak direction: (parameter, weight v_ik) with |v_ik| ≥ 0.2, largest
    /// first. A structural group: its parameters with their share of the
    /// null space (the diagonal of its projector).
    pub parameters: Vec<(String, f64)>,
    /// A structural group's sum, when that is what the data determine of
    /// it, with its uncertainty ([`super::joint_effect`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub joint: Option<JointEffect>,
}

impl Combination {
    /// `0.71·ln me1.k_x − 0.71·ln me2.k_x` for a weak direction;
    /// `{me1.k_x, me2.k_x}: 1 free combination` for a structural group.
    pub fn describe(&self) -> String {
        if self.singular_value == 0.0 {
            let names: Vec<&str> = self.parameters.iter().map(|p| p.0.as_str()).collect();
            let joint = self
                .joint
                .as_ref()
                .map_or(String::new(), |j| format!("; {}", j.describe()));
            return format!(
                "{{{}}}: {} free combination{} (the modes see only {}){joint}",
                names.join(", "),
                self.free,
                if self.free == 1 { "" } else { "s" },
                if self.free + 1 == names.len() {
                    "their joint effect"
                } else {
                    "part of them"
                }
            );
        }
        let mut s = String::new();
        for (k, (name, w)) in self.parameters.iter().enumerate() {
            let sign = if *w < 0.0 { "−" } else { "+" };
            if k == 0 {
                if *w < 0.0 {
                    s.push('−');
                }
            } else {
                s.push_str(&format!(" {sign} "));
            }
            s.push_str(&format!("{:.2}·ln {name}", w.abs()));
        }
        s
    }
}

/// The identifiability analysis at one point.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Identifiability {
    pub parameters: Vec<ParameterUncertainty>,
    /// Singular values of J, descending.
    pub singular_values: Vec<f64>,
    pub undetermined: Vec<Combination>,
    /// Residuals (m) and numerical rank of J.
    pub residuals: usize,
    pub rank: usize,
    /// σ̂² = ‖r‖²/(m − rank): ≈ 1 when the model fits to the stated noise,
    /// ≫ 1 when it cannot (model error), ≈ 0 for exact data — `None` when
    /// m ≤ rank.
    pub residual_variance: Option<f64>,
    pub max_std_error: f64,
    /// FRF lines per block of the batch-means sandwich
    /// ([`super::batch_means`]); 0 without FRFs (no sandwich).
    #[serde(default)]
    pub batch_lines: usize,
    /// The FRF residuals' integrated autocorrelation time along frequency,
    /// in lines (1 for white residuals; without FRFs 1).
    #[serde(default = "one")]
    pub integrated_time_lines: f64,
}

fn one() -> f64 {
    1.0
}

impl Identifiability {
    /// The standard error of ln p that analysed parameter `j`'s interval
    /// states (parameters.csv's `std_error_with_fixed_rel`): the consider
    /// analysis's, with the fixed parameters' spread, where that was
    /// computed, else its own; `None` without a finite one or for a
    /// parameter the data do not determine.
    pub fn stated_std_error(
        &self,
        j: usize,
        considered: Option<&super::consider::Consider>,
    ) -> Option<f64> {
        let own = self.parameters[j].std_error.filter(|s| s.is_finite())?;
        match considered {
            Some(c) => Some(c.std_error[j]).filter(|s| s.is_finite()),
            None => Some(own),
        }
    }

    /// The identifiable parameters whose stated 95 % interval
    /// ([`interval`]) reaches both of their bounds: the data do not
    /// determine them within their box. `at` gives each analysed
    /// parameter's value and bounds, in the order of `parameters`; the
    /// interval is the one parameters.csv states
    /// ([`Self::stated_std_error`]). Identifiability rests
    /// on the design at the noise ([`analyze`]); the stated error also
    /// counts the residuals' correlation (the batch-means sandwich) and the
    /// cost's curvature ([`super::curvature`]) and can be far larger, as at
    /// a lightly damped resonance whose misfit is a needle in the
    /// parameter.
    pub fn spanning_their_box(
        &self,
        at: impl IntoIterator<Item = (f64, (f64, f64))>,
        considered: Option<&super::consider::Consider>,
    ) -> Vec<&str> {
        self.parameters
            .iter()
            .zip(at)
            .enumerate()
            .filter(|(_, (p, _))| p.identifiable)
            .filter_map(|(j, (p, (value, bounds)))| {
                let (lo, hi) = interval(value, self.stated_std_error(j, considered)?, bounds);
                (lo <= bounds.0 && hi >= bounds.1).then_some(p.parameter.as_str())
            })
            .collect()
    }

    /// A warning naming [`Self::spanning_their_box`], or `None`.
    pub fn spanning_warning(
        &self,
        at: impl IntoIterator<Item = (f64, (f64, f64))>,
        considered: Option<&super::consider::Consider>,
    ) -> Option<String> {
        let names = self.spanning_their_box(at, considered);
        (!names.is_empty()).then(|| {
            format!(
                "{} not determined within their bounds: identifiable by the design at the noise, but the stated 95 % interval (with the residuals' correlation and the cost's curvature) spans the whole box; the value is where the update stopped, and the modes it sets are as uncertain",
                names.join(", ")
            )
        })
    }
}

/// Analyze the Jacobian `columns` (one per parameter, ∂r/∂ln p, each of
/// length m) at residuals `r`; `names` name the parameters. `correlation`
/// says how the residuals are correlated: its AR(1) factor multiplies the
/// data variance, and the reported standard error is the larger of that
/// and the batch-means sandwich ([`super::batch_means`]); whether a
/// parameter is identifiable rests on the former (the design at the
/// noise), its interval on the latter.
pub fn analyze(
    columns: &[Vec<f64>],
    r: &[f64],
    names: &[String],
    max_std_error: f64,
    correlation: &Correlation,
) -> Identifiability {
    let n = columns.len();
    let m = r.len();
    let (mu, V) = gram_eigen(columns);
    let flags = null_flags(&mu);
    let null = |k: usize| flags[k];
    let rank = (0..n).filter(|&k| !null(k)).count();
    let rss: f64 = r.iter().map(|v| v * v).sum();
    let residual_variance = (m > rank).then(|| rss / (m - rank) as f64);
    let structural: Vec<bool> = (0..n)
        .map(|i| (0..n).any(|k| null(k) && V[(i, k)].abs() >= IN_NULL_SPACE))
        .collect();
    let prior: Vec<f64> = (0..n)
        .map(|i| {
            if structural[i] {
                return f64::INFINITY;
            }
            (0..n)
                .filter(|&k| !null(k))
                .map(|k| V[(i, k)] * V[(i, k)] / mu[k])
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    // Without residual degrees of freedom the stated uncertainty stands in.
    let sigma = (residual_variance.unwrap_or(1.0) * correlation.inflation.max(1.0)).sqrt();
    let g_plus = pseudo_inverse_of(&mu, &V, &null);
    let data = data_variance(
        columns,
        r,
        &g_plus,
        residual_variance.unwrap_or(1.0),
        correlation,
    );
    let parameters = (0..n)
        .map(|i| {
            let identifiable = !structural[i] && sigma * prior[i] <= max_std_error;
            ParameterUncertainty {
                parameter: names[i].clone(),
                identifiable,
                structural: structural[i],
                prior_std_error: prior[i],
                std_error: identifiable.then(|| data[i].max(0.0).sqrt()),
                curvature: None,
            }
        })
        .collect();
    let mut undetermined = structural_groups(&V, &null, names);
    // Weak directions, ascending in μ: the weakest first.
    for k in 0..n {
        let s = mu[k].max(0.0).sqrt();
        if null(k) || sigma / s <= max_std_error {
            continue;
        }
        let mut named: Vec<(String, f64)> = (0..n)
            .filter(|&i| V[(i, k)].abs() >= NAMED_WEIGHT)
            .map(|i| (names[i].clone(), V[(i, k)]))
            .collect();
        named.sort_by(|a, b| b.1.abs().total_cmp(&a.1.abs()));
        // One sign convention: the largest weight positive.
        if named.first().is_some_and(|(_, w)| *w < 0.0) {
            for (_, w) in &mut named {
                *w = -*w;
            }
        }
        undetermined.push(Combination {
            singular_value: s,
            free: 1,
            parameters: named,
            joint: None,
        });
    }
    let mut singular_values: Vec<f64> = mu.iter().map(|v| v.max(0.0).sqrt()).collect();
    singular_values.reverse();
    Identifiability {
        parameters,
        singular_values,
        undetermined,
        residuals: m,
        rank,
        residual_variance,
        max_std_error,
        batch_lines: correlation.block_lines,
        integrated_time_lines: correlation.integrated_time,
    }
}

/// The eigenpairs (ascending) of G = JᵀJ for Jacobian `columns`; on a
/// failed decomposition all zero (every direction undetermined).
fn gram_eigen(columns: &[Vec<f64>]) -> (Vec<f64>, Mat<f64>) {
    let n = columns.len();
    if n == 0 {
        return (Vec::new(), Mat::<f64>::zeros(0, 0));
    }
    let G = crate::dense::gram(columns);
    symmetric_eigen(&G).unwrap_or_else(|_| (vec![0.0; n], Mat::<f64>::identity(n, n)))
}

/// Which eigenvalues `mu` are structural zeros ([`STRUCTURAL`]).
fn null_flags(mu: &[f64]) -> Vec<bool> {
    let largest = mu.iter().copied().fold(0.0f64, f64::max);
    mu.iter()
        .map(|&m| m <= STRUCTURAL * STRUCTURAL * largest || m <= 0.0)
        .collect()
}

/// The structural null directions of Jacobian `columns` as [`analyze`]
/// decides them (unit vectors in ln p).
pub(crate) fn null_space(columns: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let (mu, V) = gram_eigen(columns);
    let flags = null_flags(&mu);
    (0..mu.len())
        .filter(|&k| flags[k])
        .map(|k| (0..mu.len()).map(|i| V[(i, k)]).collect())
        .collect()
}

/// Eigenvalues of the normalized Gram matrix of the system matrices'
/// derivatives below this are exact null directions (rounding is 10⁻¹⁶;
/// two springs a milliradian off one line of action are at 10⁻⁶).
const EXACT: f64 = 1e-10;

/// The directions in ln p (orthonormal) that change no system matrix,
/// from their derivatives' Gram matrix `gram`
/// ([`crate::dynamics::PreparedModel::matrix_derivative_gram`]): exact
/// structural null directions, found without finite differences of any
/// prediction. Each parameter's row is scaled to unit diagonal first, so
/// stiffnesses and dampers of any size count alike; parameters with a
/// zero diagonal (entering no joint term) take no part.
pub(crate) fn exact_null_directions(gram: &Mat<f64>) -> Vec<Vec<f64>> {
    let n = gram.nrows();
    let active: Vec<usize> = (0..n).filter(|&i| gram[(i, i)] > 0.0).collect();
    let d: Vec<f64> = active.iter().map(|&i| gram[(i, i)].sqrt()).collect();
    let m = active.len();
    let normalized = Mat::<f64>::from_fn(m, m, |a, b| gram[(active[a], active[b])] / (d[a] * d[b]));
    let Ok((mu, W)) = symmetric_eigen(&normalized) else {
        return Vec::new();
    };
    let mut out: Vec<Vec<f64>> = Vec::new();
    for k in (0..m).filter(|&k| mu[k] <= EXACT) {
        // Back to ln p (v = w / d), then orthonormal to those before.
        let mut v = vec![0.0; n];
        for (a, &i) in active.iter().enumerate() {
            v[i] = W[(a, k)] / d[a];
        }
        for u in &out {
            let c: f64 = u.iter().zip(&v).map(|(a, b)| a * b).sum();
            v.iter_mut().zip(u).for_each(|(x, y)| *x -= c * y);
        }
        let norm = v.iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm > 0.0 {
            out.push(v.into_iter().map(|x| x / norm).collect());
        }
    }
    out
}

/// The structural null directions shared by every block of Jacobian rows
/// (`blocks[b][i]`: block b's column for parameter i), as unit vectors in
/// ln p. Each block's Gram matrix is scaled by its largest eigenvalue, so
/// that a block of small numbers counts as much as one of large numbers;
/// a direction is structural when the sum's eigenvalue is below
/// [`STRUCTURAL`]² of the largest, i.e. when no block sees it.
pub(crate) fn structural_directions(blocks: &[Vec<Vec<f64>>]) -> Vec<Vec<f64>> {
    let n = blocks.first().map_or(0, Vec::len);
    let mut G = Mat::<f64>::zeros(n, n);
    for block in blocks.iter().filter(|b| b.len() == n) {
        let B = Mat::<f64>::from_fn(n, n, |a, b| {
            block[a].iter().zip(&block[b]).map(|(x, y)| x * y).sum()
        });
        let largest = match symmetric_eigen(&B) {
            Ok((mu, _)) => mu.iter().copied().fold(0.0f64, f64::max),
            Err(_) => continue,
        };
        if largest > 0.0 {
            G += B * faer::Scale(1.0 / largest);
        }
    }
    let Ok((mu, V)) = symmetric_eigen(&G) else {
        return Vec::new();
    };
    let largest = mu.iter().copied().fold(0.0f64, f64::max);
    (0..n)
        .filter(|&k| largest > 0.0 && mu[k] <= STRUCTURAL * STRUCTURAL * largest)
        .map(|k| (0..n).map(|i| V[(i, k)]).collect())
        .collect()
}

/// `columns` (one per parameter) with the `directions` (orthonormal, in
/// parameter space) removed: J (I − N Nᵀ), so J v = 0 exactly for v in
/// their span and J v is unchanged for v orthogonal to it.
pub(crate) fn without_directions(columns: &[Vec<f64>], directions: &[Vec<f64>]) -> Vec<Vec<f64>> {
    let m = columns.first().map_or(0, Vec::len);
    let mut out = columns.to_vec();
    for d in directions {
        // J d, then each column i loses (J d)·d_i.
        let mut jd = vec![0.0; m];
        for (col, &w) in columns.iter().zip(d) {
            jd.iter_mut().zip(col).for_each(|(a, c)| *a += w * c);
        }
        for (col, &w) in out.iter_mut().zip(d) {
            col.iter_mut().zip(&jd).for_each(|(c, a)| *c -= w * a);
        }
    }
    out
}

/// The structural null space split into independent groups of parameters.
/// Its basis is arbitrary (eigenvectors of a repeated zero eigenvalue mix),
/// so the groups come from the projector P = V₀V₀ᵀ onto it, which is not:
/// two parameters belong together when |P_ij| ≥ 0.05, and a group's number
/// of free combinations is the trace of P over it.
fn structural_groups(
    V: &Mat<f64>,
    null: &dyn Fn(usize) -> bool,
    names: &[String],
) -> Vec<Combination> {
    let n = names.len();
    let ks: Vec<usize> = (0..n).filter(|&k| null(k)).collect();
    let p = |i: usize, j: usize| -> f64 { ks.iter().map(|&k| V[(i, k)] * V[(j, k)]).sum() };
    let member: Vec<bool> = (0..n)
        .map(|i| p(i, i) >= IN_NULL_SPACE * IN_NULL_SPACE)
        .collect();
    let mut group = vec![usize::MAX; n];
    let mut out = Vec::new();
    for seed in 0..n {
        if !member[seed] || group[seed] != usize::MAX {
            continue;
        }
        let id = out.len();
        let mut stack = vec![seed];
        group[seed] = id;
        let mut items = Vec::new();
        while let Some(i) = stack.pop() {
            items.push(i);
            for j in 0..n {
                if member[j] && group[j] == usize::MAX && p(i, j).abs() >= IN_NULL_SPACE {
                    group[j] = id;
                    stack.push(j);
                }
            }
        }
        items.sort_unstable();
        let trace: f64 = items.iter().map(|&i| p(i, i)).sum();
        out.push(Combination {
            singular_value: 0.0,
            free: (trace.round() as usize).max(1),
            parameters: items.iter().map(|&i| (names[i].clone(), p(i, i))).collect(),
            joint: None,
        });
    }
    out
}

#[cfg(test)]
mod tests;
