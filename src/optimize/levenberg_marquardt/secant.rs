//! Levenberg–Marquardt with a secant Jacobian (Madsen, Nielsen & Tingleff,
//! "Methods for non-linear least squares problems", 2nd ed. 2004, section
//! 3.4, Algorithm 3.34), for residuals whose Jacobian costs n evaluations
//! and whose steps are short against the curvature, as in model updating,
//! where the trust region (`max_step`) lets a parameter move 5 % of its
//! range per step and a full Jacobian would be paid for each of the many
//! steps such a path takes.
//!
//! * The first Jacobian J is one forward-difference batch at the start.
//! * Every accepted step h, and every failed one once J is no longer a
//!   fresh difference Jacobian, updates J by Broyden's rank-one formula
//!   (eq. 3.32), J ← J + (r(u + h) − r(u) − J h) hᵀ/(hᵀh), so J reproduces
//!   the last difference exactly and is unchanged across h.
//! * J drifts from the tangent in directions no step explored: each step
//!   also refreshes one column j (cycling over the coordinates) by a forward
//!   difference at u when h has little component along e_j, |h_j| < 0.8‖h‖
//!   (eq. 3.33). The column's point goes into one batch with the trial, so
//!   an iteration is one batch of two evaluations instead of n + 1.
//! * A full forward-difference Jacobian is computed again where the secant
//!   one cannot be trusted: after two failed trials in a row, and before any
//!   stop (gtol, ftol, stall, λ above 1e12) that a secant J suggested — the
//!   stop is taken only when the fresh Jacobian confirms it. With a fresh J
//!   a failed trial only raises λ (the step was too long, not J wrong).
//!
//! Deterministic like the full iteration: the batches are fixed by the
//! iteration count alone.

use super::{
    check_inputs, clipped_trial, half_norm2, next_step_from, stalled, unit_batch, Iterate,
    LmParams, LmResult, NormalEquations, Residuals,
};
use crate::optimize::error::OptimizeError;
use crate::optimize::jacobian::{forward, forward_column, forward_point, Batch};
use crate::optimize::problem::{Bounds, Termination};

/// Failed trials in a row with a secant J after which J is recomputed.
const FAILURES_BEFORE_REFRESH: usize = 2;

/// The current Jacobian and whether it is a forward-difference one at the
/// current point.
struct Secant {
    columns: Vec<Vec<f64>>,
    fresh: bool,
    failures: usize,
    /// The coordinate whose column the next step may refresh.
    cycle: usize,
}

impl Secant {
    /// No Jacobian yet: the next step computes one.
    fn expired() -> Secant {
        Secant {
            columns: Vec::new(),
            fresh: false,
            failures: FAILURES_BEFORE_REFRESH,
            cycle: 0,
        }
    }

    /// Whether a full forward-difference Jacobian is due.
    fn stale(&self) -> bool {
        !self.fresh && self.failures >= FAILURES_BEFORE_REFRESH
    }

    /// The secant Jacobian is not trusted any more (a stop to confirm).
    fn expire(&mut self) {
        self.fresh = false;
        self.failures = FAILURES_BEFORE_REFRESH;
    }

    /// Evaluates the trial `trial` = `u` + h with, when h hardly explores
    /// the next coordinate k of the cycle (|h_k| < 0.8‖h‖, eq. 3.33) and J
    /// has been updated, the forward-difference point of column k in the
    /// same batch, which refreshes that column. The trial's residuals and
    /// the evaluations spent.
    fn evaluate_trial(
        &mut self,
        eval: &Batch,
        (u, res): (&[f64], &[f64]),
        trial: &[f64],
        h: &[f64],
        step: f64,
    ) -> (Option<Vec<f64>>, usize) {
        let h_norm = h.iter().map(|v| v * v).sum::<f64>().sqrt();
        let k = self.cycle % h.len().max(1);
        self.cycle += 1;
        let refresh = !self.fresh && h[k].abs() < 0.8 * h_norm;
        let mut batch = vec![trial.to_vec()];
        let step_k = refresh.then(|| {
            let (point, step_k) = forward_point(u, k, step);
            batch.push(point);
            step_k
        });
        let mut out = eval(&batch).into_iter();
        let rt = out.next().flatten();
        if let Some(step_k) = step_k {
            self.columns[k] = forward_column(out.next().flatten().as_deref(), res, step_k);
        }
        (rt, batch.len())
    }

    /// Broyden's update (eq. 3.32) from the step `h` and the residual change
    /// `dr` = r(u + h) − r(u).
    fn broyden(&mut self, h: &[f64], dr: &[f64]) {
        let hh: f64 = h.iter().map(|v| v * v).sum();
        if hh == 0.0 {
            return;
        }
        let m = dr.len();
        let mut defect = dr.to_vec();
        for (col, hk) in self.columns.iter().zip(h) {
            if *hk != 0.0 && col.len() == m {
                for (d, c) in defect.iter_mut().zip(col) {
                    *d -= c * hk;
                }
            }
        }
        for (col, hk) in self.columns.iter_mut().zip(h) {
            if *hk != 0.0 && col.len() == m {
                let s = hk / hh;
                for (c, d) in col.iter_mut().zip(&defect) {
                    *c += d * s;
                }
            }
        }
        self.fresh = false;
    }
}

/// [`super::minimize`] with a secant Jacobian (module docs).
pub(super) fn minimize(
    bounds: &Bounds,
    residuals: &Residuals,
    x0: &[f64],
    budget: usize,
    params: &LmParams,
) -> Result<LmResult, OptimizeError> {
    check_inputs(bounds, x0, budget, params)?;
    let n = bounds.dim();
    let eval = unit_batch(bounds, residuals);
    let mut it = Iterate::start(&eval, bounds, x0);
    let mut lambda = params.lambda;
    let mut j = Secant::expired();
    let termination = loop {
        let res = match next_step_from(&it.r, it.iterations, params) {
            Ok(res) => res,
            Err(stop) => break stop,
        };
        if it.cost == 0.0 {
            break Termination::Converged;
        }
        if j.stale() {
            if it.evaluations + n + 1 > budget {
                break Termination::BudgetExhausted;
            }
            j.columns = forward(&eval, &it.u, res, params.step);
            j.fresh = true;
            j.failures = 0;
            it.evaluations += n;
        } else if it.evaluations + 2 > budget {
            break Termination::BudgetExhausted;
        }
        let normal = NormalEquations::new(&j.columns, res);
        let largest = normal.largest_diagonal();
        if largest == 0.0 || normal.gradient_cosine(&it.u, it.cost) <= params.gtol {
            if j.fresh {
                break Termination::Converged;
            }
            j.expire();
            continue;
        }
        let Some(delta) = normal.damped_step(lambda, 1e-12 * largest) else {
            lambda *= 4.0;
            if lambda > 1e12 {
                if j.fresh {
                    break Termination::Converged;
                }
                j.expire();
            }
            continue;
        };
        let trial = clipped_trial(&it.u, &delta, params.max_step);
        let h: Vec<f64> = trial.iter().zip(&it.u).map(|(a, b)| a - b).collect();
        let (rt, spent) = j.evaluate_trial(&eval, (&it.u, res), &trial, &h, params.step);
        it.evaluations += spent;
        let used_fresh = j.fresh;
        let ct = half_norm2(&rt);
        let improved = ct < it.cost;
        // With a fresh J a failed trial says the step was too long, not
        // that J is wrong: J is kept as the tangent.
        if improved || !used_fresh {
            if let Some(rt) = rt.as_ref() {
                let dr: Vec<f64> = rt.iter().zip(res).map(|(a, b)| a - b).collect();
                j.broyden(&h, &dr);
            }
        }
        if improved {
            j.failures = 0;
            lambda = (lambda / 3.0).max(1e-12);
            let small = it.accept(trial, rt, ct) < params.ftol;
            if small || stalled(&it.history, it.cost, params) {
                if used_fresh {
                    break if small {
                        Termination::Converged
                    } else {
                        Termination::Stalled
                    };
                }
                // Confirm with a fresh Jacobian at the new point.
                j.expire();
            }
            continue;
        }
        lambda *= 4.0;
        if !used_fresh {
            j.failures += 1;
        }
        if lambda > 1e12 {
            if used_fresh {
                break Termination::Converged;
            }
            j.expire();
        }
    };
    Ok(it.finish(bounds, termination))
}

#[cfg(test)]
mod tests {
    use super::super::minimize as lm;
    use super::super::tests::batch;
    use super::*;

    fn secant() -> LmParams {
        LmParams {
            secant: true,
            ..LmParams::default()
        }
    }

    #[test]
    fn broyden_reproduces_the_last_difference_and_keeps_the_orthogonal_action() {
        // Known answer: after the update, J h = dr exactly and J v is
        // unchanged for v ⟂ h (eq. 3.32's least-change property).
        let mut s = Secant {
            columns: vec![vec![1.0, 0.0, 2.0], vec![0.0, 1.0, -1.0]],
            fresh: true,
            failures: 0,
            cycle: 0,
        };
        let h = [0.3, 0.4];
        let dr = [0.5, -0.2, 0.9];
        s.broyden(&h, &dr);
        for (i, d) in dr.iter().enumerate() {
            let jh = s.columns[0][i] * h[0] + s.columns[1][i] * h[1];
            assert!((jh - d).abs() < 1e-14, "{jh} vs {d}");
        }
        // v = (0.4, −0.3) ⟂ h: J v as before, (0.4, −0.3, 1.1).
        let v = [0.4, -0.3];
        let jv: Vec<f64> = (0..3)
            .map(|i| s.columns[0][i] * v[0] + s.columns[1][i] * v[1])
            .collect();
        for (a, b) in jv.iter().zip([0.4, -0.3, 1.1]) {
            assert!((a - b).abs() < 1e-14, "{jv:?}");
        }
        assert!(!s.fresh);
    }

    #[test]
    fn a_zero_residual_fit_of_many_parameters_costs_far_fewer_evaluations() {
        // r_i(x) = Σ_j A_ij x_j + 0.1 x_i³ − b_i, 30 parameters, a unit-box
        // trust region of 0.05: the path takes many short steps, each of
        // which costs 31 evaluations with a full Jacobian and 1–2 with a
        // secant one. Both must reach the known solution x* = 0.5.
        let n = 30;
        let a = |i: usize, j: usize| {
            if i == j {
                2.0
            } else {
                0.3 / (1.0 + (i + j) as f64)
            }
        };
        let model = move |x: &[f64]| -> Vec<f64> {
            (0..n)
                .map(|i| (0..n).map(|j| a(i, j) * x[j]).sum::<f64>() + 0.1 * x[i].powi(3))
                .collect()
        };
        let target = model(&vec![0.5; n]);
        let f = batch(move |x: &[f64]| {
            Some(model(x).iter().zip(&target).map(|(m, t)| m - t).collect())
        });
        let b = Bounds::linear(vec![-1.0; n], vec![1.0; n]).unwrap();
        let x0 = vec![-0.8; n];
        let full = lm(&b, &f, &x0, 100_000, &LmParams::default()).unwrap();
        let sec = lm(&b, &f, &x0, 100_000, &secant()).unwrap();
        for r in [&full, &sec] {
            assert_eq!(r.termination, Termination::Converged, "{:?}", r.termination);
            assert!(
                r.x_best.iter().all(|v| (v - 0.5).abs() < 1e-6),
                "{:?}",
                r.x_best
            );
        }
        assert!(
            3 * sec.evaluations < full.evaluations,
            "secant {} vs full {}",
            sec.evaluations,
            full.evaluations
        );
        // Bit-identical on a rerun.
        let again = lm(&b, &f, &x0, 100_000, &secant()).unwrap();
        assert_eq!(again.x_best, sec.x_best);
        assert_eq!(again.evaluations, sec.evaluations);
    }

    #[test]
    fn rosenbrock_and_a_bound_as_with_the_full_jacobian() {
        // The curved valley: a secant J is wrong after every turn, so the
        // refresh rules must still lead to (1, 1), and a stop there must be
        // confirmed by a fresh Jacobian.
        let f = batch(|x: &[f64]| Some(vec![10.0 * (x[1] - x[0] * x[0]), 1.0 - x[0]]));
        let b = Bounds::linear(vec![-2.0, -2.0], vec![2.0, 2.0]).unwrap();
        let r = lm(&b, &f, &[-1.2, 1.0], 4000, &secant()).unwrap();
        assert!((r.x_best[0] - 1.0).abs() < 1e-6, "{:?}", r.x_best);
        assert!((r.x_best[1] - 1.0).abs() < 1e-6, "{:?}", r.x_best);
        assert!(r.history.windows(2).all(|w| w[1].f_best < w[0].f_best));
        // r = x − 3 with x ≤ 2, failing beyond 1.7: ends below 1.7.
        let g = batch(|x: &[f64]| (x[0] <= 1.7).then(|| vec![x[0] - 3.0]));
        let b = Bounds::linear(vec![0.0], vec![2.0]).unwrap();
        let r = lm(&b, &g, &[0.5], 200, &secant()).unwrap();
        assert!(r.x_best[0] <= 1.7 && r.x_best[0] > 1.5, "{:?}", r.x_best);
        assert!(r.evaluations <= 200);
    }
}
