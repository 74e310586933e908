//! Bayesian optimization (seed section 2.2.2; Jones, Schonlau & Welch 1998,
//! "Efficient global optimization of expensive black-box functions",
//! doi:10.1023/A:1008306431147): maximize a function over a bounded box with
//! a Gaussian-process surrogate ([`super::gaussian_process`]) and the
//! expected-improvement acquisition
//!
//! EI(x) = (μ − f⁺ − ξ) Φ(z) + σ φ(z),  z = (μ − f⁺ − ξ)/σ.
//!
//! The initial design is a seeded Latin hypercube; EI is maximized over
//! seeded random candidates plus perturbations of the best observations,
//! refined by a shrinking coordinate pattern search. Everything runs in the
//! unit cube and is deterministic for a seed.

use super::gaussian_process::{GaussianProcess, GpError};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// Tuning of [`maximize`].
#[derive(Clone, Debug, PartialEq)]
pub struct BayesianParams {
    /// Points of the Latin-hypercube initial design.
    pub initial: usize,
    /// Total number of function evaluations, initial design included.
    pub evaluations: usize,
    pub seed: u64,
    /// Random candidates per EI maximization.
    pub candidates: usize,
    /// Exploration margin ξ, relative to the standard deviation of the observations.
    pub xi: f64,
}

impl Default for BayesianParams {
    fn default() -> Self {
        BayesianParams {
            initial: 10,
            evaluations: 40,
            seed: 0,
            candidates: 2000,
            xi: 1e-3,
        }
    }
}

/// One evaluation of the objective.
#[derive(Clone, Debug, PartialEq)]
pub struct Evaluation {
    pub x: Vec<f64>,
    pub value: f64,
}

/// The best point found and every evaluation in order.
#[derive(Clone, Debug, PartialEq)]
pub struct BayesianResult {
    pub best: Evaluation,
    pub trace: Vec<Evaluation>,
}

/// Why an optimization cannot run.
#[derive(Debug, thiserror::Error)]
pub enum BayesianError {
    /// A bound is not finite or its lower end exceeds the upper.
    #[error("bound {index} [{lo}, {hi}] is empty or not finite")]
    InvalidBounds { index: usize, lo: f64, hi: f64 },
    #[error("the budget of {0} evaluations is empty")]
    NoBudget(usize),
    #[error(transparent)]
    Surrogate(#[from] GpError),
}

fn uniform(rng: &mut ChaCha8Rng) -> f64 {
    (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64
}

/// `n` points of a Latin hypercube in [0, 1]^d: each axis split into n
/// strata, one point per stratum, strata shuffled independently per axis.
pub fn latin_hypercube(n: usize, d: usize, rng: &mut ChaCha8Rng) -> Vec<Vec<f64>> {
    let mut pts = vec![vec![0.0; d]; n];
    for dim in 0..d {
        let mut perm: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            let j = (rng.next_u64() % (i as u64 + 1)) as usize;
            perm.swap(i, j);
        }
        for (p, s) in pts.iter_mut().zip(perm) {
            p[dim] = (s as f64 + uniform(rng)) / n as f64;
        }
    }
    pts
}

/// Standard normal cdf via erfc (Abramowitz & Stegun 7.1.26 on |x|, error < 1.5e-7).
fn normal_cdf(z: f64) -> f64 {
    let x = z.abs() / 2f64.sqrt();
    let t = 1.0 / (1.0 + 0.3275911 * x);
    let poly = t
        * (0.254829592
            + t * (-0.284496736 + t * (1.421413741 + t * (-1.453152027 + t * 1.061405429))));
    let erfc = poly * (-x * x).exp();
    if z >= 0.0 {
        1.0 - 0.5 * erfc
    } else {
        0.5 * erfc
    }
}

fn normal_pdf(z: f64) -> f64 {
    (-0.5 * z * z).exp() / (2.0 * std::f64::consts::PI).sqrt()
}

/// Expected improvement over `best` of a Gaussian with mean `mu`, sd `sd`.
pub fn expected_improvement(mu: f64, sd: f64, best: f64, xi: f64) -> f64 {
    let gain = mu - best - xi;
    if sd <= 1e-300 {
        return gain.max(0.0);
    }
    let z = gain / sd;
    gain * normal_cdf(z) + sd * normal_pdf(z)
}

/// Maximize `f` over the box `bounds` with at most `params.evaluations`
/// evaluations. `f` receives points in the original units.
pub fn maximize(
    mut f: impl FnMut(&[f64]) -> f64,
    bounds: &[(f64, f64)],
    params: &BayesianParams,
) -> Result<BayesianResult, BayesianError> {
    for (index, &(lo, hi)) in bounds.iter().enumerate() {
        if !(lo.is_finite() && hi.is_finite() && lo <= hi) {
            return Err(BayesianError::InvalidBounds { index, lo, hi });
        }
    }
    if params.evaluations == 0 {
        return Err(BayesianError::NoBudget(0));
    }
    let d = bounds.len();
    let to_box = |u: &[f64]| -> Vec<f64> {
        u.iter()
            .zip(bounds)
            .map(|(v, (lo, hi))| lo + v.clamp(0.0, 1.0) * (hi - lo))
            .collect()
    };
    let mut rng = ChaCha8Rng::seed_from_u64(params.seed);
    let n_init = params.initial.clamp(1, params.evaluations);
    let mut xs: Vec<Vec<f64>> = latin_hypercube(n_init, d, &mut rng);
    let mut ys: Vec<f64> = Vec::with_capacity(params.evaluations);
    let mut value = |u: &[f64]| {
        let v = f(&to_box(u));
        if v.is_finite() {
            v
        } else {
            f64::MIN / 4.0
        }
    };
    for u in &xs {
        ys.push(value(u));
    }
    while xs.len() < params.evaluations {
        let next = propose(&xs, &ys, params, &mut rng)?;
        ys.push(value(&next));
        xs.push(next);
    }
    let trace: Vec<Evaluation> = xs
        .iter()
        .zip(&ys)
        .map(|(u, &value)| Evaluation {
            x: to_box(u),
            value,
        })
        .collect();
    // First of the maximal values: deterministic tie-breaking.
    let mut best = trace[0].clone();
    for e in &trace[1..] {
        if e.value > best.value {
            best = e.clone();
        }
    }
    Ok(BayesianResult { best, trace })
}

/// The next point in the unit cube: the EI maximizer of the fitted surrogate.
fn propose(
    xs: &[Vec<f64>],
    ys: &[f64],
    params: &BayesianParams,
    rng: &mut ChaCha8Rng,
) -> Result<Vec<f64>, BayesianError> {
    let d = xs[0].len();
    let gp = GaussianProcess::fit(xs, ys)?;
    let best = ys.iter().cloned().fold(f64::MIN, f64::max);
    let spread = {
        let m = ys.iter().sum::<f64>() / ys.len() as f64;
        (ys.iter().map(|v| (v - m).powi(2)).sum::<f64>() / ys.len() as f64).sqrt()
    };
    let xi = params.xi * spread;
    let ei = |u: &[f64]| {
        let (mu, sd) = gp.predict(u);
        expected_improvement(mu, sd, best, xi)
    };
    // Candidates: uniform, and Gaussian perturbations of the 5 best observations.
    let mut order: Vec<usize> = (0..ys.len()).collect();
    order.sort_by(|&a, &b| ys[b].total_cmp(&ys[a]).then(a.cmp(&b)));
    let mut cands: Vec<Vec<f64>> = (0..params.candidates)
        .map(|_| (0..d).map(|_| uniform(rng)).collect())
        .collect();
    for &i in order.iter().take(5) {
        for scale in [0.02, 0.1] {
            for _ in 0..params.candidates / 20 {
                let c = xs[i]
                    .iter()
                    .map(|v| (v + scale * gauss(rng)).clamp(0.0, 1.0))
                    .collect();
                cands.push(c);
            }
        }
    }
    let mut scored: Vec<(f64, usize)> = cands.iter().enumerate().map(|(k, c)| (ei(c), k)).collect();
    scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    let mut winner: Option<(f64, Vec<f64>)> = None;
    for &(_, k) in scored.iter().take(3) {
        let (v, u) = pattern_search(&ei, cands[k].clone());
        if winner.as_ref().is_none_or(|w| v > w.0) {
            winner = Some((v, u));
        }
    }
    let (_, mut u) = winner.unwrap_or((0.0, cands[0].clone()));
    // A repeated point adds no information: explore a random one instead.
    let dup = xs
        .iter()
        .any(|x| x.iter().zip(&u).all(|(a, b)| (a - b).abs() < 1e-9));
    if dup {
        u = (0..d).map(|_| uniform(rng)).collect();
    }
    Ok(u)
}

/// Coordinate pattern search on `g` in the unit cube, step halving from 0.05
/// (also the local refinement of [`crate::ema::design`]).
pub fn pattern_search(g: &impl Fn(&[f64]) -> f64, mut u: Vec<f64>) -> (f64, Vec<f64>) {
    let mut v = g(&u);
    let mut step = 0.05;
    while step > 1e-4 {
        let mut improved = false;
        for dim in 0..u.len() {
            for sign in [1.0, -1.0] {
                let mut t = u.clone();
                t[dim] = (t[dim] + sign * step).clamp(0.0, 1.0);
                let tv = g(&t);
                if tv > v {
                    v = tv;
                    u = t;
                    improved = true;
                }
            }
        }
        if !improved {
            step *= 0.5;
        }
    }
    (v, u)
}

fn gauss(rng: &mut ChaCha8Rng) -> f64 {
    let a = uniform(rng).max(1e-300);
    let b = uniform(rng);
    (-2.0 * a.ln()).sqrt() * (2.0 * std::f64::consts::PI * b).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn branin(x: &[f64]) -> f64 {
        let (a, b, c) = (
            1.0,
            5.1 / (4.0 * std::f64::consts::PI.powi(2)),
            5.0 / std::f64::consts::PI,
        );
        let (r, s, t) = (6.0, 10.0, 1.0 / (8.0 * std::f64::consts::PI));
        a * (x[1] - b * x[0] * x[0] + c * x[0] - r).powi(2) + s * (1.0 - t) * x[0].cos() + s
    }

    #[test]
    fn finds_the_branin_minimum_within_60_evaluations() {
        let params = BayesianParams {
            initial: 10,
            evaluations: 60,
            seed: 3,
            ..Default::default()
        };
        let r = maximize(|x| -branin(x), &[(-5.0, 10.0), (0.0, 15.0)], &params).unwrap();
        assert_eq!(r.trace.len(), 60);
        let found = -r.best.value;
        assert!(
            (found - 0.397887).abs() < 1e-2,
            "best {found} at {:?}",
            r.best.x
        );
    }

    #[test]
    fn finds_one_dimensional_maxima() {
        // f(x) = −(x − 0.3)² on [−2, 2]: maximum 0 at 0.3.
        let params = BayesianParams {
            initial: 4,
            evaluations: 15,
            seed: 1,
            ..Default::default()
        };
        let r = maximize(|x| -(x[0] - 0.3).powi(2), &[(-2.0, 2.0)], &params).unwrap();
        assert!((r.best.x[0] - 0.3).abs() < 1e-2, "{:?}", r.best);
        // Multimodal: x sin(x) on [0, 10] has its maximum 7.9167 at x = 7.9787.
        let params = BayesianParams {
            initial: 5,
            evaluations: 20,
            seed: 2,
            ..Default::default()
        };
        let r = maximize(|x| x[0] * x[0].sin(), &[(0.0, 10.0)], &params).unwrap();
        assert!((r.best.value - 7.916727).abs() < 1e-3, "{:?}", r.best);
    }

    #[test]
    fn is_deterministic_for_a_seed_and_checks_bounds() {
        let params = BayesianParams {
            initial: 5,
            evaluations: 12,
            seed: 9,
            ..Default::default()
        };
        let f = |x: &[f64]| -(x[0] - 1.0).powi(2) - x[1].abs();
        let a = maximize(f, &[(-3.0, 3.0), (-1.0, 1.0)], &params).unwrap();
        let b = maximize(f, &[(-3.0, 3.0), (-1.0, 1.0)], &params).unwrap();
        assert_eq!(a, b);
        assert!(matches!(
            maximize(f, &[(1.0, -1.0)], &params),
            Err(BayesianError::InvalidBounds { index: 0, .. })
        ));
    }

    #[test]
    fn latin_hypercube_has_one_point_per_stratum() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        let pts = latin_hypercube(8, 3, &mut rng);
        for dim in 0..3 {
            let mut strata: Vec<usize> = pts.iter().map(|p| (p[dim] * 8.0) as usize).collect();
            strata.sort();
            assert_eq!(strata, (0..8).collect::<Vec<_>>());
        }
    }

    #[test]
    fn normal_cdf_known_values() {
        assert!((normal_cdf(0.0) - 0.5).abs() < 1e-7);
        assert!((normal_cdf(1.959964) - 0.975).abs() < 1e-6);
        assert!((normal_cdf(-1.0) - 0.158655).abs() < 1e-6);
    }
}
