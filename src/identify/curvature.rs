//! The quadratic approximation behind every interval, checked against the
//! cost itself.
//!
//! The linearized interval of ln θ_i, ±1.96 σ_i ([`super::identifiability`]),
//! rests on the cost S = ‖r‖² of the whitened residuals being the quadratic
//! S₀ + δᵀGδ of the Jacobian (G = JᵀJ, δ the step in ln θ) over that range.
//! Where the model is nonlinear over the interval — a resonance that moves
//! by more than its half-power band, two parameters whose effects cancel
//! along a curved valley — the cost can rise far more slowly than G says,
//! and the interval is too narrow (Bates & Watts 1980, "Relative curvature
//! measures of nonlinearity", JRSS B 42; Seber & Wild 2003, "Nonlinear
//! Regression", §4.2 and §5.3: the profile of the cost is what a
//! likelihood interval follows).
//!
//! **The check.** Along the conditional direction of parameter i, the step
//! δ = t σ_i d_i with d_i = G⁺e_i / G⁺_ii, θ_i moves by t σ_i and every
//! other identified parameter to its linearized best value (the direction
//! a profile of the cost starts along); the quadratic predicts
//! ΔS = t² σ_i² / G⁺_ii. The cost is evaluated at t = ±2 (less where a
//! bound is nearer) and
//!
//! ρ_i = (ΔS₊ + ΔS₋) / (ΔS₊,pred + ΔS₋,pred),
//!
//! the sum of both sides cancelling the gradient term of a result that is
//! not exactly at the minimum. With ρ_i < 1 the cost rises more slowly
//! than the Jacobian says and σ_i (and its consider counterpart) is widened
//! by 1/√ρ_i, the width at which a quadratic of the measured curvature
//! gives the same rise. With ρ_i ≥ 1 it is kept: never narrowed, since a
//! cost steeper than quadratic at 2σ may still flatten beyond. With
//! ρ_i ≤ 0 the cost does not rise at all along that direction: the result
//! is no minimum there and the parameter gets no interval.
//!
//! The cost is in χ² units of the stated uncertainties. Where the
//! quadratic's rise at 2σ is below one such unit (a fit far inside the
//! stated noise, as with exact modes, whose σ̂² is 10⁻⁶–10⁻⁵), a rise or
//! fall over the interval is the optimizer's tolerance, not the shape of
//! the valley, and the parameter is not checked ([`MIN_RISE`]; on the test
//! bench's exact-mode family every one of 340 intervals, where without
//! this floor 18 had ρ between −21 and −0.2).
//!
//! Cost: two model evaluations per identified parameter, one batch, run
//! where that is at most 5 % of the update's budget, which keeps them
//! ([`super::updating::checks_intervals`]).

use super::assessment::residuals_at;
use super::consider::{pseudo_inverse, Consider};
use super::frf_objective::FrfReference;
use super::identifiability::Identifiability;
use super::objective::{ModalObjective, ModeSet};
use rayon::prelude::*;

/// Step of the check, in standard errors.
const STEP: f64 = 2.0;

/// Least rise of the quadratic at ±[`STEP`] σ (in χ² units of the stated
/// uncertainties, the units of S) for the check to judge: below it the fit
/// lies far inside the stated noise (exact modes) and the cost's change
/// over the interval is the optimizer's tolerance, not the valley's shape.
const MIN_RISE: f64 = 1.0;

/// The conditional direction of parameter `i`, d = G⁺e_i / G⁺_ii (so that
/// d_i = 1), and G⁺_ii; `None` when G⁺_ii is not positive (a structural
/// direction).
pub fn conditional_direction(g_plus: &faer::Mat<f64>, i: usize) -> Option<(Vec<f64>, f64)> {
    let gii = g_plus[(i, i)];
    (gii > 0.0 && gii.is_finite()).then(|| {
        (
            (0..g_plus.nrows()).map(|k| g_plus[(k, i)] / gii).collect(),
            gii,
        )
    })
}

/// ρ from the rises of the cost at the two ends and the quadratic's
/// predictions there (module docs); `None` without a prediction.
pub fn curvature_ratio(rise: (f64, f64), predicted: (f64, f64)) -> Option<f64> {
    let p = predicted.0 + predicted.1;
    (p > 0.0 && rise.0.is_finite() && rise.1.is_finite()).then(|| (rise.0 + rise.1) / p)
}

/// The factor on σ for a curvature ratio: 1/√ρ below 1, 1 above, `None`
/// (no interval) when the cost does not rise.
pub fn widening(rho: f64) -> Option<f64> {
    if rho <= 0.0 || !rho.is_finite() {
        None
    } else {
        Some(1.0 / rho.min(1.0).sqrt())
    }
}

/// The largest t ≤ [`STEP`] (in the direction `sign`) for which the checked
/// parameter, at `value` in `bounds`, stays within them when moved by
/// t·`step` in ln θ. The other parameters are clamped at their bounds
/// ([`moved`]): a clamped one cannot compensate, so the cost rises at least
/// as fast and the check widens nothing it should not.
fn reach(value: f64, step: f64, bounds: (f64, f64), sign: f64) -> f64 {
    if step == 0.0 {
        return STEP;
    }
    let room = if sign * step > 0.0 {
        (bounds.1 / value).ln()
    } else {
        (bounds.0 / value).ln()
    };
    (room / (sign * step)).clamp(0.0, STEP)
}

/// The check of one parameter: the step in ln θ per unit t (σ_i d_i), the
/// quadratic's rise per unit t² (σ_i²/G⁺_ii), and the reach t₋, t₊ of the
/// two sides.
struct Plan {
    step: Vec<f64>,
    rise: f64,
    down: f64,
    up: f64,
}

/// The cost S = ‖r‖² of the residuals the intervals come from
/// ([`super::assessment::residuals_at`]) at `p`.
fn cost(
    o: &ModalObjective,
    usable: &ModeSet,
    frf: Option<&FrfReference>,
    p: &[f64],
) -> Option<f64> {
    Some(residuals_at(o, usable, frf, p)?.iter().map(|v| v * v).sum())
}

/// ρ_i for every identified parameter with a standard error (`std_errors`,
/// relative, of ln θ), from the Jacobian `columns` (∂r/∂ln θ, the
/// structural directions removed) at the result `x`: `None` where no
/// check is possible (no standard error, a structural direction, a bound
/// at the result, a model that cannot be solved). Evaluations: two per
/// parameter checked, reported to `progress`.
fn check(
    o: &ModalObjective,
    frf: Option<&FrfReference>,
    x: &[f64],
    identified: &[usize],
    columns: &[Vec<f64>],
    std_errors: &[Option<f64>],
    progress: &(dyn Fn(u64) + Sync),
) -> (Vec<Option<f64>>, usize) {
    let (g_plus, _) = pseudo_inverse(columns);
    let usable = o.usable();
    let Some(s0) = cost(o, &usable, frf, x) else {
        return (vec![None; identified.len()], 1);
    };
    let bounds: (Vec<f64>, Vec<f64>) = o.parameters().iter().map(|p| (p.lower, p.upper)).unzip();
    let plans: Vec<Option<Plan>> = (0..identified.len())
        .map(|i| {
            let se = std_errors.get(i).copied().flatten()?;
            let (d, gii) = conditional_direction(&g_plus, i)?;
            let step: Vec<f64> = d.iter().map(|v| v * se).collect();
            let k = identified[i];
            let b = (bounds.0[k], bounds.1[k]);
            let (lo, hi) = (reach(x[k], se, b, -1.0), reach(x[k], se, b, 1.0));
            let rise = se * se / gii;
            (lo > 0.0 && hi > 0.0 && rise * STEP * STEP >= MIN_RISE).then_some(Plan {
                step,
                rise,
                down: lo,
                up: hi,
            })
        })
        .collect();
    let points: Vec<Vec<f64>> = plans
        .iter()
        .flatten()
        .flat_map(|p| [-p.down, p.up].map(|t| moved(x, identified, &p.step, t, &bounds)))
        .collect();
    let costs: Vec<Option<f64>> = points
        .par_iter()
        .map(|p| cost(o, &usable, frf, p))
        .collect();
    progress(points.len() as u64 + 1);
    let mut next = costs.into_iter();
    let ratios = plans
        .iter()
        .map(|plan| {
            let p = plan.as_ref()?;
            let (down, up) = (next.next().flatten(), next.next().flatten());
            curvature_ratio(
                (down? - s0, up? - s0),
                (p.down * p.down * p.rise, p.up * p.up * p.rise),
            )
        })
        .collect();
    (ratios, points.len() + 1)
}

/// Checks every interval of `analysis` (and `considered`, the same
/// parameters with the fixed ones' spread) at the result `x` and widens it
/// by 1/√ρ where the cost is flatter than its quadratic; a parameter
/// whose cost does not rise loses its interval (module docs). Records ρ
/// as `curvature`. Returns the evaluations spent.
pub(super) fn widen(
    o: &ModalObjective,
    frf: Option<&FrfReference>,
    x: &[f64],
    identified: &[usize],
    columns: &[Vec<f64>],
    (analysis, mut considered): (&mut Identifiability, Option<&mut Consider>),
    progress: &(dyn Fn(u64) + Sync),
) -> usize {
    let std_errors: Vec<Option<f64>> = analysis.parameters.iter().map(|p| p.std_error).collect();
    let (ratios, evaluations) = check(o, frf, x, identified, columns, &std_errors, progress);
    for ((j, rho), p) in ratios.into_iter().enumerate().zip(&mut analysis.parameters) {
        let Some(rho) = rho else { continue };
        p.curvature = Some(rho);
        match widening(rho) {
            Some(f) => {
                p.std_error = p.std_error.map(|s| s * f);
                if let Some(c) = considered.as_deref_mut() {
                    c.std_error[j] *= f;
                }
            }
            None => {
                p.std_error = None;
                p.identifiable = false;
            }
        }
    }
    evaluations
}

/// x with the identified parameters moved by t·step in ln θ, each clamped
/// to its `bounds`.
fn moved(
    x: &[f64],
    identified: &[usize],
    step: &[f64],
    t: f64,
    bounds: &(Vec<f64>, Vec<f64>),
) -> Vec<f64> {
    let mut p = x.to_vec();
    for (&k, s) in identified.iter().zip(step) {
        p[k] = (x[k] * (t * s).exp()).clamp(bounds.0[k], bounds.1[k]);
    }
    p
}

#[cfg(test)]
mod tests {
    use super::*;

    /// r(θ) = k·tanh(θ − θ̂) with noise-free data: S = k² tanh², J = k,
    /// G⁺ = 1/k². At ±2σ the cost rises by k² tanh²(2σ) where the
    /// quadratic says k²(2σ)², so ρ = (tanh(2σ)/(2σ))² and the interval
    /// widens by 2σ/tanh(2σ).
    #[test]
    fn a_cost_flatter_than_its_quadratic_widens_the_interval_by_the_known_factor() {
        let (k, sigma) = (3.0f64, 0.6f64);
        let g_plus = faer::Mat::from_fn(1, 1, |_, _| 1.0 / (k * k));
        let (d, gii) = conditional_direction(&g_plus, 0).unwrap();
        assert_eq!(d, vec![1.0]);
        let t = STEP * sigma;
        let rise = (k * (-t).tanh()).powi(2);
        let predicted = STEP * STEP * sigma * sigma / gii;
        let rho = curvature_ratio((rise, rise), (predicted, predicted)).unwrap();
        let exact = (t.tanh() / t).powi(2);
        assert!((rho - exact).abs() < 1e-12, "{rho} vs {exact}");
        let f = widening(rho).unwrap();
        assert!((f - t / t.tanh()).abs() < 1e-12);
        assert!(f > 1.3, "a real widening: {f}");
    }

    /// A linear model's cost is its quadratic: ρ = 1 whatever the step and
    /// the correlation, and nothing is widened; a steeper cost is not
    /// narrowed; a cost that falls gives no interval.
    #[test]
    fn a_linear_model_passes_and_a_falling_cost_has_no_interval() {
        // Two correlated columns; S(δ) = δᵀGδ exactly.
        let cols = [vec![1.0, 2.0, 0.5], vec![0.8, 1.5, 1.0]];
        let (g_plus, _) = pseudo_inverse(&cols);
        let g = crate::dense::gram(&cols);
        for i in 0..2 {
            let (d, gii) = conditional_direction(&g_plus, i).unwrap();
            let se = 0.3;
            let quad = |t: f64| {
                let s: Vec<f64> = d.iter().map(|v| v * se * t).collect();
                (0..2)
                    .map(|a| (0..2).map(|b| s[a] * g[(a, b)] * s[b]).sum::<f64>())
                    .sum::<f64>()
            };
            let pred = STEP * STEP * se * se / gii;
            assert!(
                (quad(STEP) - pred).abs() < 1e-12 * pred,
                "the prediction is δᵀGδ"
            );
            let rho = curvature_ratio((quad(-STEP), quad(STEP)), (pred, pred)).unwrap();
            assert!((rho - 1.0).abs() < 1e-12);
            assert!((widening(rho).unwrap() - 1.0).abs() < 1e-12);
        }
        assert_eq!(widening(4.0), Some(1.0), "never narrowed");
        assert_eq!(widening(-0.1), None);
        assert_eq!(curvature_ratio((1.0, 1.0), (0.0, 0.0)), None);
    }

    #[test]
    fn the_step_stops_at_the_nearer_bound() {
        // θ = 1 in [0.5, 1.1]: ln(1.1) = 0.0953 up, ln(0.5) = −0.693 down.
        let up = reach(1.0, 0.1, (0.5, 1.1), 1.0);
        assert!((up - 1.1f64.ln() / 0.1).abs() < 1e-12, "{up}");
        assert_eq!(reach(1.0, 0.1, (0.5, 1.1), -1.0), STEP);
        assert_eq!(reach(1.1, 0.1, (0.5, 1.1), 1.0), 0.0, "at its bound");
        // The other parameter is clamped at its bound, the checked one moves.
        let bounds = (vec![0.5, 1.0], vec![2.0, 1.0]);
        let p = moved(&[1.0, 1.0], &[0, 1], &[0.1, 0.3], 2.0, &bounds);
        assert_eq!(p, vec![0.2f64.exp(), 1.0]);
    }
}
