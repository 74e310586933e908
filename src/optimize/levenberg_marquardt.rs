//! Bounded Levenberg–Marquardt for nonlinear least squares,
//! min ½‖r(x)‖² with x in box bounds (Levenberg 1944, Marquardt 1963;
//! Nocedal & Wright, "Numerical Optimization", section 10.3), in the unit
//! box of [`Bounds`] like every optimizer here.
//!
//! Each iteration: the Jacobian J of the residuals by forward differences in
//! the unit box, evaluated as ONE batch of n points (a step that would leave
//! the box goes the other way); then trial steps
//! (JᵀJ + λ diag(JᵀJ)) δ = −Jᵀr (Marquardt's scaling, the diagonal floored
//! at 1e-12 · its largest entry), each coordinate clipped to ±`max_step`
//! and then to the box, until one lowers the cost: λ ÷ 3 on success, × 4 on
//! failure. Each trial is one evaluation. The clip is a trust region in the
//! unit box: Marquardt's scaling makes a parameter the data barely see as
//! mobile as any other, and a full Gauss–Newton step would throw it across
//! its range to fit a residual it hardly affects (on the 78-parameter test
//! bench such jumps ended at the bounds and stalled the fit at 4e-5 instead
//! of 1e-20).
//! For a zero-residual problem (a model that can match its reference) the
//! iteration converges quadratically near the solution, where a quasi-Newton
//! method on ‖r‖² first has to learn the curvature that JᵀJ gives at once.
//! Directions with no influence on r get no step (their diagonal is ~0 and
//! the damping term keeps them put).
//!
//! Stops when the budget cannot pay another Jacobian, when the cost fell by
//! less than `ftol` (relative) over an accepted step, when the residual is
//! orthogonal to the free Jacobian columns to `gtol` (More, Garbow &
//! Hillstrom, MINPACK-1, 1980), when no trial step
//! lowers it (λ above 1e12), after `max_iterations`, or as stalled when the
//! last `stall_window` steps together lowered it by less than
//! `stall_decrease` (a fit crawling along a bound). A point whose
//! residuals cannot be computed (`None`) costs +∞; a failed stencil point
//! gives a zero Jacobian column. Deterministic: the only parallel part is
//! the caller's batch evaluation.

mod secant;

use super::error::OptimizeError;
use super::jacobian::{forward as jacobian, Batch};
use super::problem::{Bounds, HistoryPoint, Termination};
use crate::dense::{normal_equations, solve_spd};
use serde::{Deserialize, Serialize};

/// Settings of Levenberg–Marquardt.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct LmParams {
    /// Forward-difference step in the unit box.
    pub step: f64,
    /// Initial damping λ.
    pub lambda: f64,
    /// Largest change of one coordinate per step, in the unit box.
    pub max_step: f64,
    /// Stop when an accepted step lowers the cost by less than this fraction.
    pub ftol: f64,
    pub max_iterations: usize,
    /// Converged when the cosine between the residual and every free
    /// Jacobian column is at most this (MINPACK's gtol): a least-squares
    /// minimum, reached at whatever noise floor the data have.
    pub gtol: f64,
    /// Stop as stalled when the last `stall_window` accepted steps lowered
    /// the cost by less than `stall_decrease` (relative) in all: a fit
    /// crawling along a bound or in a flat valley, far from any tolerance.
    pub stall_window: usize,
    pub stall_decrease: f64,
    /// Secant Jacobian ([`secant`]): after one forward-difference Jacobian,
    /// Broyden's rank-one update from every step and one refreshed column
    /// per step, a full Jacobian again only where the secant one fails or
    /// a stopping test must be confirmed. Off: a full Jacobian every step.
    pub secant: bool,
}

impl Default for LmParams {
    fn default() -> Self {
        LmParams {
            step: 1e-6,
            lambda: 1e-3,
            max_step: 0.05,
            ftol: 1e-10,
            max_iterations: 500,
            gtol: 1e-4,
            stall_window: 20,
            stall_decrease: 1e-2,
            secant: false,
        }
    }
}

impl LmParams {
    pub(crate) fn check(&self) -> Result<(), String> {
        if !(self.step > 0.0 && self.step < 0.5) {
            return Err(format!("step must be in (0, 0.5), got {}", self.step));
        }
        if !(self.max_step > 0.0 && self.max_step <= 1.0) {
            return Err(format!("max_step must be in (0, 1], got {}", self.max_step));
        }
        if !(self.lambda > 0.0 && self.lambda.is_finite()) {
            return Err(format!("lambda must be > 0, got {}", self.lambda));
        }
        if !(self.ftol >= 0.0 && self.ftol.is_finite()) {
            return Err(format!("ftol must be finite and ≥ 0, got {}", self.ftol));
        }
        Ok(())
    }
}

/// Residual vectors of a batch of physical points, in order (`None` where
/// the model cannot be evaluated).
pub type Residuals<'a> = dyn Fn(&[Vec<f64>]) -> Vec<Option<Vec<f64>>> + Sync + 'a;

/// What Levenberg–Marquardt returns.
#[derive(Debug, Clone, Serialize)]
pub struct LmResult {
    /// Best point (physical units) and its cost ½‖r‖².
    pub x_best: Vec<f64>,
    pub cost: f64,
    pub evaluations: usize,
    /// Accepted steps.
    pub iterations: usize,
    /// Best cost after each accepted step (and the start).
    pub history: Vec<HistoryPoint>,
    pub termination: Termination,
}

fn half_norm2(r: &Option<Vec<f64>>) -> f64 {
    match r {
        Some(r) => {
            let c = 0.5 * r.iter().map(|v| v * v).sum::<f64>();
            if c.is_finite() {
                c
            } else {
                f64::INFINITY
            }
        }
        None => f64::INFINITY,
    }
}

/// Minimize ½‖r(x)‖² within `bounds` from the physical point `x0` with at
/// most `budget` residual evaluations.
pub fn minimize(
    bounds: &Bounds,
    residuals: &Residuals,
    x0: &[f64],
    budget: usize,
    params: &LmParams,
) -> Result<LmResult, OptimizeError> {
    if params.secant {
        return secant::minimize(bounds, residuals, x0, budget, params);
    }
    check_inputs(bounds, x0, budget, params)?;
    let n = bounds.dim();
    let eval = unit_batch(bounds, residuals);
    let search = StepSearch {
        eval: &eval,
        budget,
        params,
    };
    let mut it = Iterate::start(&eval, bounds, x0);
    let mut lambda = params.lambda;
    let termination = loop {
        let res = match next_step_from(&it.r, it.iterations, params) {
            Ok(res) => res,
            Err(stop) => break stop,
        };
        if it.evaluations + n + 1 > budget {
            break Termination::BudgetExhausted;
        }
        if it.cost == 0.0 {
            break Termination::Converged;
        }
        // Jacobian, column-major: one forward-difference batch.
        let columns = jacobian(&eval, &it.u, res, params.step);
        it.evaluations += n;
        let normal = NormalEquations::new(&columns, res);
        let largest = normal.largest_diagonal();
        if largest == 0.0 {
            break Termination::Converged;
        }
        if normal.gradient_cosine(&it.u, it.cost) <= params.gtol {
            break Termination::Converged;
        }
        let floor = 1e-12 * largest;
        let accepted = search.trial_steps(
            &it.u,
            &normal,
            floor,
            it.cost,
            &mut lambda,
            &mut it.evaluations,
        );
        let Some((trial, rt, ct)) = accepted else {
            break if lambda > 1e12 {
                Termination::Converged
            } else {
                Termination::BudgetExhausted
            };
        };
        if it.accept(trial, rt, ct) < params.ftol {
            break Termination::Converged;
        }
        if stalled(&it.history, it.cost, params) {
            break Termination::Stalled;
        }
    };
    Ok(it.finish(bounds, termination))
}

/// The residuals of a batch of unit-box points.
fn unit_batch<'a>(
    bounds: &'a Bounds,
    residuals: &'a Residuals,
) -> impl Fn(&[Vec<f64>]) -> Vec<Option<Vec<f64>>> + 'a {
    move |u: &[Vec<f64>]| {
        let x: Vec<Vec<f64>> = u.iter().map(|u| bounds.to_physical(u)).collect();
        residuals(&x)
    }
}

/// The iterate and what both iterations (full and [`secant`]) count: the
/// unit-box point, its residuals and cost ½‖r‖², the evaluations spent,
/// the accepted steps and the cost after each.
struct Iterate {
    u: Vec<f64>,
    r: Option<Vec<f64>>,
    cost: f64,
    evaluations: usize,
    iterations: usize,
    history: Vec<HistoryPoint>,
}

impl Iterate {
    /// At the physical point `x0`: one evaluation.
    fn start(eval: &Batch, bounds: &Bounds, x0: &[f64]) -> Iterate {
        let u = bounds.to_unit(x0);
        let r = eval(std::slice::from_ref(&u)).pop().flatten();
        let cost = half_norm2(&r);
        Iterate {
            u,
            r,
            cost,
            evaluations: 1,
            iterations: 0,
            history: vec![HistoryPoint {
                evaluation: 1,
                f_best: cost,
            }],
        }
    }

    /// Moves to the accepted `trial` (residuals `rt`, cost `ct` below the
    /// current one); returns the cost's relative decrease.
    fn accept(&mut self, trial: Vec<f64>, rt: Option<Vec<f64>>, ct: f64) -> f64 {
        let decrease = (self.cost - ct) / self.cost;
        self.u = trial;
        self.r = rt;
        self.cost = ct;
        self.iterations += 1;
        self.history.push(HistoryPoint {
            evaluation: self.evaluations,
            f_best: ct,
        });
        decrease
    }

    fn finish(self, bounds: &Bounds, termination: Termination) -> LmResult {
        LmResult {
            x_best: bounds.to_physical(&self.u),
            cost: self.cost,
            evaluations: self.evaluations,
            iterations: self.iterations,
            history: self.history,
            termination,
        }
    }
}

/// The residuals `r` to take the next step from, or why no step is taken:
/// none at the start point, or `max_iterations` reached after `iterations`.
/// (A function of the two fields, so that the iterate's other fields stay
/// free to change while the residuals are borrowed.)
fn next_step_from<'a>(
    r: &'a Option<Vec<f64>>,
    iterations: usize,
    params: &LmParams,
) -> Result<&'a [f64], Termination> {
    let Some(res) = r.as_deref() else {
        return Err(Termination::Failed {
            message: "the residuals cannot be computed at the start point".into(),
        });
    };
    if iterations >= params.max_iterations {
        return Err(Termination::MaxIterations);
    }
    Ok(res)
}

/// `u + δ`, each coordinate of δ clipped to ±`max_step` (the trust region)
/// and the point then to the box.
fn clipped_trial(u: &[f64], delta: &[f64], max_step: f64) -> Vec<f64> {
    u.iter()
        .zip(delta)
        .map(|(a, b)| (a + b.clamp(-max_step, max_step)).clamp(0.0, 1.0))
        .collect()
}

/// The settings, start point and budget checked before the first
/// evaluation: an error names what cannot be used.
fn check_inputs(
    bounds: &Bounds,
    x0: &[f64],
    budget: usize,
    params: &LmParams,
) -> Result<(), OptimizeError> {
    params.check().map_err(|message| OptimizeError::Settings {
        optimizer: "levenberg_marquardt".into(),
        message,
    })?;
    let n = bounds.dim();
    if x0.len() != n || x0.iter().any(|v| !v.is_finite()) {
        return Err(OptimizeError::StartPoint {
            message: format!("need {n} finite values, got {x0:?}"),
        });
    }
    if budget < n + 2 {
        return Err(OptimizeError::Budget {
            message: format!("a budget of {budget} cannot pay one Jacobian of {n} parameters and a step; give at least {}", n + 2),
        });
    }
    Ok(())
}

/// The Gauss–Newton normal equations at the current point: JᵀJ (row-major,
/// n × n) and the gradient g = Jᵀr, from which every trial step of the
/// iteration is solved.
struct NormalEquations {
    n: usize,
    jtj: Vec<f64>,
    g: Vec<f64>,
}

impl NormalEquations {
    /// JᵀJ and Jᵀr from the Jacobian's `columns` and the residuals `res`.
    fn new(columns: &[Vec<f64>], res: &[f64]) -> Self {
        let (jtj, g) = normal_equations(columns, res);
        NormalEquations {
            n: columns.len(),
            jtj,
            g,
        }
    }

    /// The largest diagonal entry of JᵀJ (0: no direction moves r).
    fn largest_diagonal(&self) -> f64 {
        let n = self.n;
        (0..n).map(|i| self.jtj[i * n + i]).fold(0.0f64, f64::max)
    }

    /// The largest cosine between r and a Jacobian column that can move at
    /// `u` (`cost` = ½‖r‖²), compared with MINPACK's gtol.
    fn gradient_cosine(&self, u: &[f64], cost: f64) -> f64 {
        let (n, g, jtj) = (self.n, &self.g, &self.jtj);
        // MINPACK's gtol: r is orthogonal to every column that can move
        // (a column at a bound whose descent leaves the box cannot).
        let rnorm = (2.0 * cost).sqrt();
        (0..n)
            .filter(|&j| {
                let descent = -g[j];
                !((u[j] <= 0.0 && descent < 0.0) || (u[j] >= 1.0 && descent > 0.0))
            })
            .map(|j| g[j].abs() / (jtj[j * n + j].sqrt() * rnorm).max(f64::MIN_POSITIVE))
            .fold(0.0f64, f64::max)
    }

    /// The damped step δ of (JᵀJ + λ diag(JᵀJ)) δ = −Jᵀr, the diagonal
    /// floored at `floor` (Marquardt's scaling); `None` when the system
    /// cannot be solved.
    fn damped_step(&self, lambda: f64, floor: f64) -> Option<Vec<f64>> {
        let (n, jtj) = (self.n, &self.jtj);
        let mut a = jtj.clone();
        for i in 0..n {
            a[i * n + i] += lambda * jtj[i * n + i].max(floor);
        }
        let rhs: Vec<f64> = self.g.iter().map(|v| -v).collect();
        solve_spd(&a, n, &rhs, 1)
    }
}

/// An accepted trial: the unit-box point, its residuals and cost.
type Accepted = (Vec<f64>, Option<Vec<f64>>, f64);

/// What the search for a step that lowers the cost works with.
struct StepSearch<'a> {
    /// Residuals of a batch of unit-box points.
    eval: &'a Batch<'a>,
    budget: usize,
    params: &'a LmParams,
}

impl StepSearch<'_> {
    /// Trial steps from `u` (cost `cost`) with the damping updated after
    /// each: λ ÷ 3 on the first that lowers the cost (returned), × 4 on a
    /// failure, until λ passes 1e12 or the budget runs out (`None`). Each
    /// coordinate of a step is clipped to ±`max_step` (the trust region)
    /// and then to the box; each trial is one evaluation.
    fn trial_steps(
        &self,
        u: &[f64],
        normal: &NormalEquations,
        floor: f64,
        cost: f64,
        lambda: &mut f64,
        evaluations: &mut usize,
    ) -> Option<Accepted> {
        let params = self.params;
        while *evaluations < self.budget && *lambda <= 1e12 {
            let Some(delta) = normal.damped_step(*lambda, floor) else {
                *lambda *= 4.0;
                continue;
            };
            let trial = clipped_trial(u, &delta, params.max_step);
            let rt = (self.eval)(std::slice::from_ref(&trial)).pop().flatten();
            *evaluations += 1;
            let ct = half_norm2(&rt);
            if ct < cost {
                *lambda = (*lambda / 3.0).max(1e-12);
                return Some((trial, rt, ct));
            }
            *lambda *= 4.0;
        }
        None
    }
}

/// True when the last `stall_window` accepted steps (`history`, ending at
/// `cost`) lowered the cost by less than `stall_decrease` of where they
/// began: a fit crawling along a bound.
fn stalled(history: &[HistoryPoint], cost: f64, params: &LmParams) -> bool {
    let w = params.stall_window;
    if w > 0 && history.len() > w {
        let before = history[history.len() - 1 - w].f_best;
        if (before - cost) < params.stall_decrease * before {
            return true;
        }
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::parameter::Scale;

    /// A batch evaluator from a residual function of one point.
    pub(super) fn batch<'a>(
        f: impl Fn(&[f64]) -> Option<Vec<f64>> + Sync + 'a,
    ) -> impl Fn(&[Vec<f64>]) -> Vec<Option<Vec<f64>>> + Sync + 'a {
        move |xs: &[Vec<f64>]| xs.iter().map(|x| f(x)).collect()
    }

    #[test]
    fn rosenbrock_as_least_squares() {
        // r = (10 (y − x²), 1 − x): minimum 0 at (1, 1).
        let f = batch(|x: &[f64]| Some(vec![10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]]));
        let b = Bounds::linear(vec![-2.0, -2.0], vec![2.0, 2.0]).unwrap();
        let r = minimize(&b, &f, &[-1.2, 1.0], 2000, &LmParams::default()).unwrap();
        assert!((r.x_best[0] - 1.0).abs() < 1e-6, "{:?}", r.x_best);
        assert!((r.x_best[1] - 1.0).abs() < 1e-6, "{:?}", r.x_best);
        assert!(r.evaluations <= 2000 && r.iterations > 5);
        assert!(r.history.windows(2).all(|w| w[1].f_best < w[0].f_best));
    }

    #[test]
    fn exponential_fit_in_log_scale_converges_fast() {
        // Data y_k = 3 exp(−0.5 t_k), parameters (a, b) with b searched in
        // log10: a zero-residual problem converges in a few Jacobians.
        let t: Vec<f64> = (0..20).map(|k| k as f64 * 0.25).collect();
        let f = batch(|x: &[f64]| {
            Some(
                t.iter()
                    .map(|&t| x[0] * (-x[1] * t).exp() - 3.0 * (-0.5 * t).exp())
                    .collect(),
            )
        });
        let b = Bounds::new(
            vec![0.1, 0.01],
            vec![10.0, 10.0],
            vec![Scale::Linear, Scale::Log],
        )
        .unwrap();
        let r = minimize(&b, &f, &[1.0, 2.0], 500, &LmParams::default()).unwrap();
        assert!(
            (r.x_best[0] - 3.0).abs() < 1e-8 && (r.x_best[1] - 0.5).abs() < 1e-8,
            "{:?}",
            r.x_best
        );
        assert!(r.evaluations < 100, "{}", r.evaluations);
    }

    #[test]
    fn a_bound_stops_the_step_and_failures_are_rejected() {
        // r = x − 3 with x ≤ 2: the solution is the bound.
        let f = batch(|x: &[f64]| Some(vec![x[0] - 3.0]));
        let b = Bounds::linear(vec![0.0], vec![2.0]).unwrap();
        let r = minimize(&b, &f, &[0.5], 200, &LmParams::default()).unwrap();
        assert!((r.x_best[0] - 2.0).abs() < 1e-12, "{:?}", r.x_best);
        assert!((r.cost - 0.5).abs() < 1e-12);
        // Beyond x = 1.7 the residuals cannot be computed: such trial
        // points are refused, the fit ends below 1.7 with a finite cost,
        // deterministically and within the budget.
        let g = batch(|x: &[f64]| (x[0] <= 1.7).then(|| vec![x[0] - 3.0]));
        let r = minimize(&b, &g, &[0.5], 200, &LmParams::default()).unwrap();
        assert!(r.x_best[0] <= 1.7 && r.x_best[0] > 1.5, "{:?}", r.x_best);
        assert!(r.cost.is_finite() && r.evaluations <= 200);
        let again = minimize(&b, &g, &[0.5], 200, &LmParams::default()).unwrap();
        assert_eq!(again.x_best, r.x_best);
        // Too small a budget is an error, not a panic.
        assert!(minimize(&b, &f, &[0.5], 2, &LmParams::default()).is_err());
    }
}
