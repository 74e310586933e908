//! The bounded minimization problem every optimizer solves (eq. 2.13–2.16):
//! parameter bounds and their scaling to the unit box, the batch objective,
//! optional constraints, the evaluation budget, and the bookkeeping shared
//! by all optimizers (evaluation counter, best-so-far history, result).
//!
//! Optimizers work in the unit box `u ∈ [0, 1]^n`; [`Bounds`] maps each
//! coordinate to its physical value, linearly or in log10 (a stiffness
//! spanning 1e6…1e9 N/m is searched in decades). The objective and the
//! constraints always receive PHYSICAL values.
//!
//! The objective is evaluated in batches (a PSO swarm, a GA generation, a
//! finite-difference stencil) so that the caller can evaluate the points in
//! parallel (see [`parallel`]). Evaluation is the only parallel part of every
//! optimizer, so results do not depend on the number of threads as long as
//! the objective is a deterministic function of its point.

use super::error::OptimizeError;
use crate::parameter::Scale;
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// Box bounds `x_l ≤ x ≤ x_u` (eq. 2.16) with a scale per dimension.
#[derive(Debug, Clone, PartialEq)]
pub struct Bounds {
    lower: Vec<f64>,
    upper: Vec<f64>,
    scale: Vec<Scale>,
}

impl Bounds {
    /// Checks that all three vectors have the same non-zero length, bounds
    /// are finite with `lower < upper`, and log10 bounds are positive.
    pub fn new(lower: Vec<f64>, upper: Vec<f64>, scale: Vec<Scale>) -> Result<Self, OptimizeError> {
        let n = lower.len();
        if n == 0 || upper.len() != n || scale.len() != n {
            return Err(OptimizeError::Bounds {
                index: 0,
                message: format!(
                    "lower, upper and scale need the same non-zero length (got {}, {}, {})",
                    n,
                    upper.len(),
                    scale.len()
                ),
            });
        }
        for i in 0..n {
            let (l, u) = (lower[i], upper[i]);
            if !(l.is_finite() && u.is_finite() && l < u) {
                return Err(OptimizeError::Bounds {
                    index: i,
                    message: format!("need finite lower < upper, got [{l}, {u}]"),
                });
            }
            if scale[i] == Scale::Log && l <= 0.0 {
                return Err(OptimizeError::Bounds {
                    index: i,
                    message: format!("log scale needs lower > 0, got {l}; use a linear scale"),
                });
            }
        }
        Ok(Bounds {
            lower,
            upper,
            scale,
        })
    }

    /// Linear bounds in every dimension.
    pub fn linear(lower: Vec<f64>, upper: Vec<f64>) -> Result<Self, OptimizeError> {
        let n = lower.len();
        Bounds::new(lower, upper, vec![Scale::Linear; n])
    }

    /// Number of parameters n.
    pub fn dim(&self) -> usize {
        self.lower.len()
    }

    pub fn lower(&self) -> &[f64] {
        &self.lower
    }

    pub fn upper(&self) -> &[f64] {
        &self.upper
    }

    pub fn scale(&self) -> &[Scale] {
        &self.scale
    }

    /// Physical point of a unit-box point (coordinates clamped to [0, 1]).
    pub fn to_physical(&self, u: &[f64]) -> Vec<f64> {
        u.iter()
            .enumerate()
            .map(|(i, &ui)| {
                let t = ui.clamp(0.0, 1.0);
                let (l, h) = (self.lower[i], self.upper[i]);
                self.scale[i].from_unit(t, l, h).clamp(l, h)
            })
            .collect()
    }

    /// Unit-box point of a physical point (clamped to the bounds).
    pub fn to_unit(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .enumerate()
            .map(|(i, &xi)| {
                let (l, h) = (self.lower[i], self.upper[i]);
                let x = xi.clamp(l, h);
                self.scale[i].to_unit(x, l, h).clamp(0.0, 1.0)
            })
            .collect()
    }

    /// The bounds of the coordinates `idx` (a subproblem's or a refinement's
    /// free parameters); an empty `idx` is an error, as in [`Bounds::new`].
    pub fn select(&self, idx: &[usize]) -> Result<Bounds, OptimizeError> {
        Bounds::new(
            idx.iter().map(|&i| self.lower[i]).collect(),
            idx.iter().map(|&i| self.upper[i]).collect(),
            idx.iter().map(|&i| self.scale[i]).collect(),
        )
    }

    /// Point `k` of the scrambled Sobol sequence (scramble `seed`) over the
    /// coordinates `free` of the box, the others at `x0`: a space-filling
    /// start for a multi-start over a subset of the parameters.
    pub fn sobol_point(&self, x0: &[f64], free: &[usize], k: u32, seed: u32) -> Vec<f64> {
        let mut u = self.to_unit(x0);
        for (d, &i) in free.iter().enumerate() {
            let dim = d as u32 % sobol_burley::NUM_DIMENSIONS;
            u[i] = f64::from(sobol_burley::sample(k, dim, seed));
        }
        self.to_physical(&u)
    }
}

/// An objective g(x) evaluated on a batch of PHYSICAL points; returns one
/// value per point, in order. Non-finite values mean "failed evaluation" and
/// are treated as +∞. Any `Fn(&[Vec<f64>]) -> Vec<f64> + Sync` is an
/// objective (`Sync` so that a problem can be moved into a rayon pool).
pub trait Objective: Sync {
    fn evaluate(&self, points: &[Vec<f64>]) -> Vec<f64>;
}

impl<F: Fn(&[Vec<f64>]) -> Vec<f64> + Sync> Objective for F {
    fn evaluate(&self, points: &[Vec<f64>]) -> Vec<f64> {
        self(points)
    }
}

/// A batch objective that evaluates a pointwise function on the current
/// rayon pool (order of results = order of points).
pub fn parallel<F: Fn(&[f64]) -> f64 + Sync>(f: F) -> impl Fn(&[Vec<f64>]) -> Vec<f64> + Sync {
    move |points: &[Vec<f64>]| points.par_iter().map(|x| f(x)).collect()
}

/// A batch objective that evaluates a pointwise function in order, on the
/// calling thread.
pub fn sequential<F: Fn(&[f64]) -> f64 + Sync>(f: F) -> impl Fn(&[Vec<f64>]) -> Vec<f64> + Sync {
    move |points: &[Vec<f64>]| points.iter().map(|x| f(x)).collect()
}

/// Equality κ(x) = 0 (eq. 2.14) or inequality κ(x) ≤ 0. Note the sign: the
/// seed's eq. 2.15 writes κ ≥ 0; here inequalities are `c(x) ≤ 0` (NLopt).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ConstraintKind {
    Equality,
    Inequality,
}

/// A constraint function of PHYSICAL values.
pub type ConstraintFn<'a> = Box<dyn Fn(&[f64]) -> f64 + Sync + 'a>;

/// A constraint on PHYSICAL values. Constraints are assumed cheap: they are
/// evaluated pointwise and NOT counted against the budget.
pub struct Constraint<'a> {
    pub kind: ConstraintKind,
    pub function: ConstraintFn<'a>,
}

impl<'a> Constraint<'a> {
    /// `c(x) ≤ 0`.
    pub fn inequality(f: impl Fn(&[f64]) -> f64 + Sync + 'a) -> Self {
        Constraint {
            kind: ConstraintKind::Inequality,
            function: Box::new(f),
        }
    }

    /// `h(x) = 0`.
    pub fn equality(f: impl Fn(&[f64]) -> f64 + Sync + 'a) -> Self {
        Constraint {
            kind: ConstraintKind::Equality,
            function: Box::new(f),
        }
    }

    /// How much the constraint is violated at x (0 when satisfied).
    pub fn violation(&self, x: &[f64]) -> f64 {
        let c = (self.function)(x);
        let v = match self.kind {
            ConstraintKind::Equality => c.abs(),
            ConstraintKind::Inequality => c.max(0.0),
        };
        if v.is_nan() {
            f64::INFINITY
        } else {
            v
        }
    }
}

/// min g(x) s.t. bounds, constraints, with at most `budget` evaluations of g.
pub struct Problem<'a> {
    pub bounds: Bounds,
    pub objective: &'a dyn Objective,
    pub constraints: Vec<Constraint<'a>>,
    /// Maximum number of objective evaluations; never exceeded.
    pub budget: usize,
    /// Stop as soon as a (feasible) value ≤ target has been found.
    pub target: Option<f64>,
    /// A point counts as feasible when every violation is ≤ this.
    pub constraint_tolerance: f64,
}

impl<'a> Problem<'a> {
    pub fn new(bounds: Bounds, objective: &'a dyn Objective, budget: usize) -> Self {
        Problem {
            bounds,
            objective,
            constraints: Vec::new(),
            budget,
            target: None,
            constraint_tolerance: 1e-6,
        }
    }

    pub fn with_target(mut self, target: f64) -> Self {
        self.target = Some(target);
        self
    }

    pub fn with_constraint(mut self, constraint: Constraint<'a>) -> Self {
        self.constraints.push(constraint);
        self
    }

    /// Largest constraint violation at a physical point (0 if unconstrained).
    pub fn max_violation(&self, x: &[f64]) -> f64 {
        self.constraints
            .iter()
            .map(|c| c.violation(x))
            .fold(0.0, f64::max)
    }

    pub(crate) fn check(&self) -> Result<(), OptimizeError> {
        if self.budget == 0 {
            return Err(OptimizeError::Budget {
                message: "the evaluation budget must be at least 1".into(),
            });
        }
        Ok(())
    }
}

/// One step of the best-so-far curve: after `evaluation` evaluations
/// (1-based), the best (feasible) objective value was `f_best`. A point is
/// recorded only when the best value improves.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct HistoryPoint {
    pub evaluation: usize,
    pub f_best: f64,
}

/// Why an optimizer stopped.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case", tag = "reason")]
pub enum Termination {
    /// The optimizer's own tolerance was met (SLSQP ftol/xtol).
    Converged,
    /// A value ≤ the problem's target was found.
    TargetReached,
    /// The next step would have exceeded the evaluation budget.
    BudgetExhausted,
    /// The iteration/generation limit of the settings was reached.
    MaxIterations,
    /// The best value did not improve for the configured number of
    /// iterations (PSO/GA).
    Stalled,
    /// SLSQP could not make progress due to rounding (NLopt
    /// `RoundoffLimited`). `accepted` tells whether the result passed the
    /// check: KKT residual (projected unit-box gradient, ∞-norm, relative to
    /// max(1, |f|)) below tolerance, or, when no residual is available,
    /// a feasible point better than the start.
    RoundoffLimited {
        kkt_residual: Option<f64>,
        accepted: bool,
    },
    /// The optimizer reported a failure (message from the backend).
    Failed { message: String },
}

/// What an optimizer returns. `x_best` is the best evaluated (feasible)
/// point in physical units; `u_best` the same in the unit box.
#[derive(Debug, Clone, Serialize)]
pub struct OptimizeResult {
    pub optimizer: String,
    pub x_best: Vec<f64>,
    pub u_best: Vec<f64>,
    pub f_best: f64,
    /// Objective evaluations used (≤ the problem's budget).
    pub evaluations: usize,
    /// Evaluations that returned NaN/±∞ (treated as +∞).
    pub non_finite: usize,
    /// SQP iterations (gradient evaluations), PSO iterations or GA generations.
    pub iterations: usize,
    pub history: Vec<HistoryPoint>,
    pub termination: Termination,
    /// Largest constraint violation at `x_best` (0 if unconstrained).
    pub max_violation: f64,
    /// Wall-clock time of the run in seconds (not deterministic).
    pub wall_time_s: f64,
}

/// Combines several runs that shared one budget (multi-start) into one
/// result: the best run's point, summed evaluations and iterations, and the
/// best-so-far history over all runs in run order. `None` when empty.
pub fn combine(runs: &[OptimizeResult]) -> Option<OptimizeResult> {
    let best = runs
        .iter()
        .enumerate()
        .min_by(|a, b| a.1.f_best.total_cmp(&b.1.f_best).then(a.0.cmp(&b.0)))?
        .1;
    let mut history = Vec::new();
    let (mut offset, mut f_best) = (0, f64::INFINITY);
    for run in runs {
        for h in &run.history {
            if h.f_best < f_best {
                f_best = h.f_best;
                history.push(HistoryPoint {
                    evaluation: offset + h.evaluation,
                    f_best,
                });
            }
        }
        offset += run.evaluations;
    }
    Some(OptimizeResult {
        history,
        evaluations: offset,
        non_finite: runs.iter().map(|r| r.non_finite).sum(),
        iterations: runs.iter().map(|r| r.iterations).sum(),
        wall_time_s: runs.iter().map(|r| r.wall_time_s).sum(),
        ..best.clone()
    })
}

/// The evaluation bookkeeping of one run: counts evaluations against the
/// budget, sanitizes non-finite values, tracks the best feasible point and
/// the best-so-far history.
pub struct Evaluator<'p, 'a> {
    problem: &'p Problem<'a>,
    budget: usize,
    evaluations: usize,
    non_finite: usize,
    history: Vec<HistoryPoint>,
    best: Option<(Vec<f64>, f64)>,
    started: Instant,
}

impl<'p, 'a> Evaluator<'p, 'a> {
    pub fn new(problem: &'p Problem<'a>) -> Self {
        Evaluator::with_budget(problem, problem.budget)
    }

    /// An evaluator with a smaller share of the problem's budget (one run of
    /// a multi-start); the share is capped at the problem's budget.
    pub fn with_budget(problem: &'p Problem<'a>, budget: usize) -> Self {
        Evaluator {
            problem,
            budget: budget.min(problem.budget),
            evaluations: 0,
            non_finite: 0,
            history: Vec::new(),
            best: None,
            started: Instant::now(),
        }
    }

    pub fn problem(&self) -> &'p Problem<'a> {
        self.problem
    }

    /// Evaluations left in the budget.
    pub fn remaining(&self) -> usize {
        self.budget.saturating_sub(self.evaluations)
    }

    pub fn evaluations(&self) -> usize {
        self.evaluations
    }

    /// Best feasible (unit point, value) so far.
    pub fn best(&self) -> Option<(&[f64], f64)> {
        self.best.as_ref().map(|(u, f)| (u.as_slice(), *f))
    }

    /// True once a feasible value ≤ the problem's target has been found.
    pub fn target_reached(&self) -> bool {
        match (self.problem.target, &self.best) {
            (Some(t), Some((_, f))) => *f <= t,
            _ => false,
        }
    }

    /// Evaluates unit-box points as one batch. Non-finite values come back
    /// as +∞. Fails (evaluating nothing) if the batch exceeds the budget or
    /// the objective returns the wrong number of values.
    pub fn evaluate(&mut self, unit_points: &[Vec<f64>]) -> Result<Vec<f64>, OptimizeError> {
        if unit_points.len() > self.remaining() {
            return Err(OptimizeError::Budget {
                message: format!(
                    "a batch of {} points exceeds the {} evaluations left",
                    unit_points.len(),
                    self.remaining()
                ),
            });
        }
        if unit_points.is_empty() {
            return Ok(Vec::new());
        }
        let physical: Vec<Vec<f64>> = unit_points
            .iter()
            .map(|u| self.problem.bounds.to_physical(u))
            .collect();
        let mut values = self.problem.objective.evaluate(&physical);
        if values.len() != physical.len() {
            return Err(OptimizeError::ObjectiveLength {
                expected: physical.len(),
                got: values.len(),
            });
        }
        for (k, v) in values.iter_mut().enumerate() {
            self.evaluations += 1;
            if !v.is_finite() {
                self.non_finite += 1;
                *v = f64::INFINITY;
            }
            let feasible = self.problem.constraints.is_empty()
                || self.problem.max_violation(&physical[k]) <= self.problem.constraint_tolerance;
            let improves = self.best.as_ref().is_none_or(|(_, f)| *v < *f);
            if feasible && improves && v.is_finite() {
                self.best = Some((unit_points[k].clone(), *v));
                self.history.push(HistoryPoint {
                    evaluation: self.evaluations,
                    f_best: *v,
                });
            }
        }
        Ok(values)
    }

    /// The result of the run. `fallback` is the unit point reported when no
    /// feasible finite value was found (e.g. SLSQP's least infeasible
    /// iterate); its value is reported as +∞.
    pub fn finish(
        self,
        optimizer: &str,
        iterations: usize,
        termination: Termination,
        fallback: &[f64],
    ) -> OptimizeResult {
        let (u_best, f_best) = match self.best {
            Some((u, f)) => (u, f),
            None => (fallback.to_vec(), f64::INFINITY),
        };
        let x_best = self.problem.bounds.to_physical(&u_best);
        OptimizeResult {
            optimizer: optimizer.to_string(),
            max_violation: self.problem.max_violation(&x_best),
            x_best,
            u_best,
            f_best,
            evaluations: self.evaluations,
            non_finite: self.non_finite,
            iterations,
            history: self.history,
            termination,
            wall_time_s: self.started.elapsed().as_secs_f64(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_scale_maps_decades() {
        let b = Bounds::new(
            vec![1e6, -1.0],
            vec![1e9, 1.0],
            vec![Scale::Log, Scale::Linear],
        )
        .unwrap();
        let x = b.to_physical(&[1.0 / 3.0, 0.25]);
        assert!((x[0] / 1e7 - 1.0).abs() < 1e-12, "{x:?}");
        assert!((x[1] + 0.5).abs() < 1e-15);
        let u = b.to_unit(&x);
        assert!((u[0] - 1.0 / 3.0).abs() < 1e-12 && (u[1] - 0.25).abs() < 1e-15);
        assert_eq!(b.to_physical(&[0.0, 1.0]), vec![1e6, 1.0]);
        assert_eq!(b.to_physical(&[1.0, 0.0]), vec![1e9, -1.0]);
    }

    #[test]
    fn selected_coordinates_and_sobol_points_over_a_subset() {
        let b = Bounds::new(
            vec![1e6, -1.0, 0.0],
            vec![1e9, 1.0, 2.0],
            vec![Scale::Log, Scale::Linear, Scale::Linear],
        )
        .unwrap();
        let s = b.select(&[2, 0]).unwrap();
        assert_eq!(s.lower(), &[0.0, 1e6]);
        assert_eq!(s.upper(), &[2.0, 1e9]);
        assert_eq!(s.scale(), &[Scale::Linear, Scale::Log]);
        assert!(b.select(&[]).is_err());
        // Coordinates outside `free` stay at x0; the scramble seed changes
        // the points, the same seed repeats them.
        let x0 = [1e7, 0.5, 1.0];
        let p = b.sobol_point(&x0, &[0, 2], 0, 0);
        assert!(p[1] == 0.5 && (1e6..=1e9).contains(&p[0]) && (0.0..=2.0).contains(&p[2]));
        assert_eq!(p, b.sobol_point(&x0, &[0, 2], 0, 0));
        assert_ne!(p, b.sobol_point(&x0, &[0, 2], 0, 1));
        let points: Vec<Vec<f64>> = (1..64).map(|k| b.sobol_point(&x0, &[1], k, 7)).collect();
        assert!(points.iter().all(|p| p[0] == 1e7 && p[2] == 1.0));
        assert!(points.iter().all(|p| (-1.0..=1.0).contains(&p[1])));
        let below = points.iter().filter(|p| p[1] < 0.0).count();
        assert!(
            (28..=35).contains(&below),
            "{below} of 63 in the lower half"
        );
    }

    #[test]
    fn invalid_bounds_are_errors() {
        assert!(Bounds::linear(vec![1.0], vec![1.0]).is_err());
        assert!(Bounds::linear(vec![0.0], vec![f64::NAN]).is_err());
        assert!(Bounds::linear(vec![], vec![]).is_err());
        let e = Bounds::new(vec![0.0], vec![1.0], vec![Scale::Log]).unwrap_err();
        assert!(e.to_string().contains("lower > 0"), "{e}");
    }

    #[test]
    fn evaluator_counts_sanitizes_and_records() {
        let f = sequential(|x: &[f64]| if x[0] < 0.5 { f64::NAN } else { x[0] });
        let p = Problem::new(Bounds::linear(vec![0.0], vec![1.0]).unwrap(), &f, 4);
        let mut e = Evaluator::new(&p);
        let v = e.evaluate(&[vec![0.1], vec![0.9], vec![0.7]]).unwrap();
        assert_eq!(v[0], f64::INFINITY);
        assert_eq!(e.remaining(), 1);
        assert!(e.evaluate(&[vec![0.6], vec![0.6]]).is_err());
        assert_eq!(e.evaluations(), 3);
        let r = e.finish("test", 1, Termination::BudgetExhausted, &[0.5]);
        assert_eq!(r.non_finite, 1);
        assert_eq!(r.f_best, 0.7);
        let evals: Vec<usize> = r.history.iter().map(|h| h.evaluation).collect();
        assert_eq!(evals, vec![2, 3]);
    }
}
