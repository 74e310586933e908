//! Multi-start SLSQP: several local runs from a seeded Latin hypercube
//! design (McKay, Beckman & Conover 1979) in the unit box, sharing one
//! evaluation budget. The sensitivity-guided identification (DESIGN.md,
//! "Identification") repeats SLSQP from several starts and needs every run.

use super::error::OptimizeError;
use super::problem::{OptimizeResult, Problem, Termination};
use super::slsqp::{minimize_with_budget, SlsqpParams};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// `points` Latin-hypercube points in [0, 1]^dim: in every dimension each of
/// the `points` equal strata holds exactly one point, placed uniformly in
/// its stratum. One ChaCha8 stream of `seed`, consumed dimension by
/// dimension (Fisher–Yates permutation, then the offsets).
pub fn latin_hypercube(points: usize, dim: usize, seed: u64) -> Vec<Vec<f64>> {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut design: Vec<Vec<f64>> = vec![Vec::with_capacity(dim); points];
    for _ in 0..dim {
        let mut perm: Vec<usize> = (0..points).collect();
        for i in (1..points).rev() {
            let j = rng.random_range(0..=i);
            perm.swap(i, j);
        }
        for (point, p) in design.iter_mut().zip(&perm) {
            let offset: f64 = rng.random();
            point.push((*p as f64 + offset) / points as f64);
        }
    }
    design
}

/// Runs SLSQP from `starts` points and returns every run, in start order.
/// The first start is `params.x0` when given, the others come from
/// [`latin_hypercube`] with `seed`. Run k gets an equal share of what the
/// earlier runs left of the budget; the runs stop early once one reaches
/// the problem's target or the budget is gone. Combine with
/// [`combine`](super::problem::combine) for one result.
pub fn multistart(
    problem: &Problem,
    params: &SlsqpParams,
    starts: usize,
    seed: u64,
) -> Result<Vec<OptimizeResult>, OptimizeError> {
    problem.check()?;
    let starts = starts.max(1);
    let n = problem.bounds.dim();
    let mut points: Vec<Vec<f64>> = Vec::with_capacity(starts);
    if let Some(x0) = &params.x0 {
        points.push(x0.clone());
    }
    let lhs = latin_hypercube(starts - points.len(), n, seed);
    points.extend(lhs.iter().map(|u| problem.bounds.to_physical(u)));
    let mut runs = Vec::with_capacity(starts);
    let mut used = 0;
    for (k, x0) in points.iter().enumerate() {
        let left = problem.budget - used;
        let share = left / (starts - k);
        if share == 0 {
            continue;
        }
        let run = minimize_with_budget(problem, params, x0, share)?;
        used += run.evaluations;
        let done = run.termination == Termination::TargetReached;
        runs.push(run);
        if done {
            break;
        }
    }
    Ok(runs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::problem::{combine, sequential, Bounds};

    #[test]
    fn latin_hypercube_fills_every_stratum() {
        let d = latin_hypercube(7, 3, 11);
        for dim in 0..3 {
            let mut strata: Vec<usize> = d.iter().map(|p| (p[dim] * 7.0) as usize).collect();
            strata.sort_unstable();
            assert_eq!(strata, (0..7).collect::<Vec<_>>());
        }
        assert_eq!(d, latin_hypercube(7, 3, 11));
        assert_ne!(d, latin_hypercube(7, 3, 12));
    }

    #[test]
    fn multistart_finds_both_basins_within_budget() {
        // Double well (x² − 1)²: minima at ±1; starts spread over [−2, 2].
        let f = sequential(|x: &[f64]| (x[0] * x[0] - 1.0).powi(2));
        let p = Problem::new(Bounds::linear(vec![-2.0], vec![2.0]).unwrap(), &f, 300);
        let runs = multistart(&p, &SlsqpParams::default(), 6, 3).unwrap();
        assert_eq!(runs.len(), 6);
        let total: usize = runs.iter().map(|r| r.evaluations).sum();
        assert!(total <= 300);
        assert!(runs.iter().any(|r| (r.x_best[0] - 1.0).abs() < 1e-5));
        assert!(runs.iter().any(|r| (r.x_best[0] + 1.0).abs() < 1e-5));
        let best = combine(&runs).unwrap();
        assert_eq!(best.evaluations, total);
        assert!(best.f_best < 1e-10);
    }
}
