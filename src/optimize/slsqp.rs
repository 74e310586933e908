//! Sequential least-squares quadratic programming (SLSQP, Kraft 1988; seed
//! section 2.2.2) through the `slsqp` crate, a pure-Rust port of NLopt's
//! implementation, on the unit box of a [`Problem`].
//!
//! Gradients come from finite differences in the unit box, evaluated as ONE
//! batch per gradient (the point itself when not cached, plus n forward or
//! 2n central stencil points). Near a bound the stencil turns one-sided so
//! that no point leaves the box. A stencil point with a non-finite value
//! gives a zero derivative component.
//!
//! Constraints: inequalities `c(x) ≤ 0` are passed to SLSQP directly;
//! an equality `h(x) = 0` becomes the pair `h ≤ 0`, `−h ≤ 0` because the
//! crate's `minimize` takes inequalities only (Kraft's least-squares
//! subproblem treats the opposing linearizations as an equality). Constraint
//! gradients are finite differences too; constraints are not counted against
//! the budget.
//!
//! Budget: NLopt counts calls, not evaluations, so the wrapper counts itself.
//! When the next call does not fit into the budget, it returns +∞ without
//! evaluating; non-finite values never become NLopt's optimum, so the
//! reported point is always one that was evaluated.

use super::error::OptimizeError;
use super::problem::{ConstraintKind, Evaluator, OptimizeResult, Problem, Termination};
use serde::{Deserialize, Serialize};
use slsqp::{FailStatus, StopTols, SuccessStatus};
use std::cell::RefCell;

/// Finite-difference scheme of the gradient.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Difference {
    /// (g(u + h eᵢ) − g(u)) / h: n evaluations per gradient, error O(h).
    /// On ill-conditioned problems the bias moves the optimum by roughly
    /// h·cond (Rosenbrock: 2e-4 at h = 1e-7).
    Forward,
    /// (g(u + h eᵢ) − g(u − h eᵢ)) / 2h: 2n evaluations, error O(h²).
    #[default]
    Central,
}

/// Settings of SLSQP (YAML `optimizer_settings:` when `optimizer: slsqp`).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct SlsqpParams {
    pub difference: Difference,
    /// Finite-difference step in the unit box.
    pub step: f64,
    /// Stop when |Δg| < ftol_rel · |g| between iterates.
    pub ftol_rel: f64,
    /// Stop when |Δg| < ftol_abs between iterates.
    pub ftol_abs: f64,
    /// Stop when every unit coordinate changes by less than this.
    pub xtol_abs: f64,
    /// A round-off-limited result is accepted when its projected gradient
    /// (∞-norm, unit box) is ≤ kkt_tolerance · max(1, |g|).
    pub kkt_tolerance: f64,
    /// Number of starts for [`multistart`](super::multistart::multistart)
    /// when run through [`Optimizer`](super::optimizer::Optimizer).
    pub starts: usize,
    /// First start point in physical units (default: centre of the unit box
    /// for a single start; Latin hypercube points for further starts).
    pub x0: Option<Vec<f64>>,
}

impl Default for SlsqpParams {
    fn default() -> Self {
        SlsqpParams {
            difference: Difference::Central,
            step: 1e-6,
            ftol_rel: 1e-14,
            ftol_abs: 0.0,
            xtol_abs: 1e-12,
            kkt_tolerance: 1e-5,
            starts: 1,
            x0: None,
        }
    }
}

impl SlsqpParams {
    pub(crate) fn check(&self) -> Result<(), String> {
        if !(self.step > 0.0 && self.step < 0.5) {
            return Err(format!(
                "step must be in (0, 0.5) (unit box), got {}",
                self.step
            ));
        }
        if self.starts == 0 {
            return Err("starts must be at least 1".into());
        }
        for (name, v) in [
            ("ftol_rel", self.ftol_rel),
            ("ftol_abs", self.ftol_abs),
            ("xtol_abs", self.xtol_abs),
            ("kkt_tolerance", self.kkt_tolerance),
        ] {
            if !(v >= 0.0 && v.is_finite()) {
                return Err(format!("{name} must be finite and ≥ 0, got {v}"));
            }
        }
        Ok(())
    }
}

/// Minimizes from the physical start point `x0` with the whole budget.
pub fn minimize(
    problem: &Problem,
    params: &SlsqpParams,
    x0: &[f64],
) -> Result<OptimizeResult, OptimizeError> {
    minimize_with_budget(problem, params, x0, problem.budget)
}

/// Minimizes from `x0` using at most `budget` (≤ the problem's) evaluations.
pub fn minimize_with_budget(
    problem: &Problem,
    params: &SlsqpParams,
    x0: &[f64],
    budget: usize,
) -> Result<OptimizeResult, OptimizeError> {
    problem.check()?;
    params.check().map_err(|message| OptimizeError::Settings {
        optimizer: "slsqp".into(),
        message,
    })?;
    let b = &problem.bounds;
    if x0.len() != b.dim() || x0.iter().any(|v| !v.is_finite()) {
        return Err(OptimizeError::StartPoint {
            message: format!("need {} finite values, got {:?}", b.dim(), x0),
        });
    }
    if let Some(i) = (0..b.dim()).find(|&i| x0[i] < b.lower()[i] || x0[i] > b.upper()[i]) {
        return Err(OptimizeError::StartPoint {
            message: format!(
                "parameter {i} = {} lies outside [{}, {}]",
                x0[i],
                b.lower()[i],
                b.upper()[i]
            ),
        });
    }
    let u0 = b.to_unit(x0);
    let state = RefCell::new(State {
        evaluator: Evaluator::with_budget(problem, budget),
        params,
        cache: None,
        gradient: None,
        stop: None,
        error: None,
        iterations: 0,
        f_start: None,
    });

    let objective = |u: &[f64], grad: Option<&mut [f64]>, _: &mut ()| -> f64 {
        state.borrow_mut().call(u, grad)
    };
    let constraint_fns = constraint_callbacks(problem, params.step);
    let n = b.dim();
    let unit_bounds = vec![(0.0, 1.0); n];
    let tols = StopTols {
        ftol_rel: params.ftol_rel,
        ftol_abs: params.ftol_abs,
        xtol_rel: 0.0,
        xtol_abs: vec![params.xtol_abs; n],
    };
    // NLopt's own call limit only bounds the free calls made after the
    // budget is gone; the evaluator enforces the budget.
    let max_calls = budget
        .saturating_mul(2)
        .saturating_add(16)
        .min(i32::MAX as usize);
    let outcome = slsqp::minimize(
        objective,
        &u0,
        &unit_bounds,
        &constraint_fns,
        (),
        max_calls,
        Some(tols),
    );
    let (status, u_last) = match outcome {
        Ok((s, x, _)) => (Ok(s), x),
        Err((s, x, _)) => (Err(s), x),
    };
    let mut state = state.into_inner();
    if let Some(e) = state.error.take() {
        return Err(e);
    }
    let termination = match (state.stop.take(), status) {
        (Some(t), _) => t,
        (None, Ok(SuccessStatus::MaxEvalReached)) => Termination::BudgetExhausted,
        (None, Ok(SuccessStatus::MaxTimeReached)) => Termination::MaxIterations,
        (None, Ok(_)) => Termination::Converged,
        (None, Err(FailStatus::RoundoffLimited)) => state.roundoff_check()?,
        (None, Err(s)) => Termination::Failed {
            message: format!("NLopt SLSQP status {s:?}"),
        },
    };
    let iterations = state.iterations;
    Ok(state
        .evaluator
        .finish("slsqp", iterations, termination, &u_last))
}

/// Mutable state shared by the objective callback (NLopt takes `Fn`).
struct State<'p, 'a, 's> {
    evaluator: Evaluator<'p, 'a>,
    params: &'s SlsqpParams,
    /// Last evaluated unit point and its value (NLopt re-requests the
    /// accepted line-search point with its gradient).
    cache: Option<(Vec<f64>, f64)>,
    /// Last unit point whose gradient was computed, and the gradient.
    gradient: Option<(Vec<f64>, Vec<f64>)>,
    stop: Option<Termination>,
    error: Option<OptimizeError>,
    iterations: usize,
    f_start: Option<f64>,
}

impl State<'_, '_, '_> {
    fn call(&mut self, u: &[f64], grad: Option<&mut [f64]>) -> f64 {
        if self.stop.is_some() || self.error.is_some() {
            return f64::INFINITY;
        }
        let want_grad = grad.is_some();
        match self.value_and_gradient(u, want_grad) {
            Ok(Some((f, g))) => {
                if let (Some(out), Some(g)) = (grad, g) {
                    out.copy_from_slice(&g);
                }
                if self.evaluator.target_reached() {
                    self.stop = Some(Termination::TargetReached);
                }
                f
            }
            Ok(None) => {
                self.stop = Some(Termination::BudgetExhausted);
                f64::INFINITY
            }
            Err(e) => {
                self.error = Some(e);
                f64::INFINITY
            }
        }
    }

    /// g(u) and, if wanted, its finite-difference gradient, as one batch.
    /// `None` when the batch does not fit into the remaining budget.
    #[allow(clippy::type_complexity)]
    fn value_and_gradient(
        &mut self,
        u: &[f64],
        want_grad: bool,
    ) -> Result<Option<(f64, Option<Vec<f64>>)>, OptimizeError> {
        let cached = match &self.cache {
            Some((x, f)) if x.as_slice() == u => Some(*f),
            _ => None,
        };
        let mut batch = Vec::new();
        if cached.is_none() {
            batch.push(u.to_vec());
        }
        let stencil = if want_grad {
            Stencil::new(u, self.params)
        } else {
            Stencil::default()
        };
        batch.extend(stencil.points.iter().cloned());
        if batch.len() > self.evaluator.remaining() {
            // Still evaluate the point itself if it fits, so that a tiny
            // budget reports at least the start.
            if cached.is_none() && self.evaluator.remaining() > 0 {
                let f = self.evaluator.evaluate(&batch[..1])?[0];
                self.f_start.get_or_insert(f);
                self.cache = Some((u.to_vec(), f));
            }
            return Ok(None);
        }
        let values = self.evaluator.evaluate(&batch)?;
        let f = cached.unwrap_or_else(|| values[0]);
        self.f_start.get_or_insert(f);
        self.cache = Some((u.to_vec(), f));
        if !want_grad {
            return Ok(Some((f, None)));
        }
        self.iterations += 1;
        let offset = usize::from(cached.is_none());
        let g = stencil.gradient(f, &values[offset..]);
        self.gradient = Some((u.to_vec(), g.clone()));
        Ok(Some((f, Some(g))))
    }

    /// NLopt's `RoundoffLimited`: accept when the projected gradient at the
    /// best point is small (unconstrained), else when the best point is
    /// feasible and better than the start.
    fn roundoff_check(&mut self) -> Result<Termination, OptimizeError> {
        let Some((u, f)) = self.evaluator.best().map(|(u, f)| (u.to_vec(), f)) else {
            return Ok(Termination::RoundoffLimited {
                kkt_residual: None,
                accepted: false,
            });
        };
        if self.evaluator.problem().constraints.is_empty() {
            let g = match &self.gradient {
                Some((x, g)) if *x == u => Some(g.clone()),
                _ => {
                    self.cache = Some((u.clone(), f));
                    self.value_and_gradient(&u, true)?.and_then(|(_, g)| g)
                }
            };
            if let Some(g) = g {
                let kkt = projected_gradient_norm(&u, &g) / f.abs().max(1.0);
                return Ok(Termination::RoundoffLimited {
                    kkt_residual: Some(kkt),
                    accepted: kkt <= self.params.kkt_tolerance,
                });
            }
        }
        Ok(Termination::RoundoffLimited {
            kkt_residual: None,
            accepted: self.f_start.is_some_and(|f0| f < f0),
        })
    }
}

/// ∞-norm of the gradient with components that push against an active
/// bound of the unit box removed.
fn projected_gradient_norm(u: &[f64], g: &[f64]) -> f64 {
    u.iter()
        .zip(g)
        .map(|(&ui, &gi)| {
            if (ui <= 0.0 && gi > 0.0) || (ui >= 1.0 && gi < 0.0) {
                0.0
            } else {
                gi.abs()
            }
        })
        .fold(0.0, f64::max)
}

/// Finite-difference stencil around a unit point: for each dimension one
/// signed step (one-sided) or two (central).
#[derive(Default)]
struct Stencil {
    points: Vec<Vec<f64>>,
    /// Per dimension: the signed steps whose points follow in `points`.
    steps: Vec<(f64, Option<f64>)>,
}

impl Stencil {
    fn new(u: &[f64], params: &SlsqpParams) -> Self {
        let h = params.step;
        let mut s = Stencil::default();
        for i in 0..u.len() {
            let up = u[i] + h <= 1.0;
            let down = u[i] - h >= 0.0;
            let step = match (params.difference, up, down) {
                (Difference::Central, true, true) => (h, Some(-h)),
                (_, true, _) => (h, None),
                _ => (-h, None),
            };
            for d in std::iter::once(step.0).chain(step.1) {
                let mut p = u.to_vec();
                p[i] += d;
                s.points.push(p);
            }
            s.steps.push(step);
        }
        s
    }

    fn gradient(&self, f: f64, values: &[f64]) -> Vec<f64> {
        let mut k = 0;
        self.steps
            .iter()
            .map(|&(d1, d2)| {
                let g = match d2 {
                    None => (values[k] - f) / d1,
                    Some(d2) => (values[k] - values[k + 1]) / (d1 - d2),
                };
                k += 1 + usize::from(d2.is_some());
                if g.is_finite() {
                    g
                } else {
                    0.0
                }
            })
            .collect()
    }
}

type Callback<'c> = Box<dyn Fn(&[f64], Option<&mut [f64]>, &mut ()) -> f64 + 'c>;

/// NLopt inequality callbacks (`c ≤ 0`) in the unit box, with forward
/// differences of step `h`; an equality yields `h ≤ 0` and `−h ≤ 0`.
fn constraint_callbacks<'c>(problem: &'c Problem, h: f64) -> Vec<Callback<'c>> {
    let mut out: Vec<Callback<'c>> = Vec::new();
    for c in &problem.constraints {
        let signs: &[f64] = match c.kind {
            ConstraintKind::Inequality => &[1.0],
            ConstraintKind::Equality => &[1.0, -1.0],
        };
        for &sign in signs {
            let bounds = &problem.bounds;
            let f = &c.function;
            out.push(Box::new(
                move |u: &[f64], grad: Option<&mut [f64]>, _: &mut ()| {
                    let value = sign * f(&bounds.to_physical(u));
                    if let Some(g) = grad {
                        for i in 0..u.len() {
                            let d = if u[i] + h <= 1.0 { h } else { -h };
                            let mut p = u.to_vec();
                            p[i] += d;
                            let gi = (sign * f(&bounds.to_physical(&p)) - value) / d;
                            g[i] = if gi.is_finite() { gi } else { 0.0 };
                        }
                    }
                    value
                },
            ));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::problem::{sequential, Bounds};

    #[test]
    fn quadratic_converges_and_counts_batches() {
        let f = sequential(|x: &[f64]| (x[0] - 0.3).powi(2) + 10.0 * (x[1] + 0.2).powi(2));
        let p = Problem::new(
            Bounds::linear(vec![-1.0; 2], vec![1.0; 2]).unwrap(),
            &f,
            200,
        );
        let r = minimize(&p, &SlsqpParams::default(), &[0.9, 0.9]).unwrap();
        assert!((r.x_best[0] - 0.3).abs() < 1e-6 && (r.x_best[1] + 0.2).abs() < 1e-6);
        assert!(r.evaluations <= 200 && r.iterations >= 2, "{r:?}");
    }

    #[test]
    fn stencil_stays_in_the_box() {
        let params = SlsqpParams {
            difference: Difference::Central,
            step: 0.1,
            ..SlsqpParams::default()
        };
        let s = Stencil::new(&[0.0, 0.5, 1.0], &params);
        assert_eq!(s.points.len(), 4);
        assert!(s.points.iter().flatten().all(|v| (0.0..=1.0).contains(v)));
        // Linear g = 2 u0 − u1 + 3 u2: exact derivatives from any stencil.
        let g = |p: &[f64]| 2.0 * p[0] - p[1] + 3.0 * p[2];
        let values: Vec<f64> = s.points.iter().map(|p| g(p)).collect();
        let grad = s.gradient(g(&[0.0, 0.5, 1.0]), &values);
        for (a, b) in grad.iter().zip([2.0, -1.0, 3.0]) {
            assert!((a - b).abs() < 1e-12, "{grad:?}");
        }
    }

    #[test]
    fn start_outside_bounds_is_an_error() {
        let f = sequential(|x: &[f64]| x[0]);
        let p = Problem::new(Bounds::linear(vec![0.0], vec![1.0]).unwrap(), &f, 10);
        let e = minimize(&p, &SlsqpParams::default(), &[2.0]).unwrap_err();
        assert!(e.to_string().contains("outside"), "{e}");
    }
}
