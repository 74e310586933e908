//! Real-coded genetic algorithm (seed section 2.2.2, "evolutionary
//! algorithms") in the unit box of a [`Problem`]: tournament selection,
//! simulated binary crossover (SBX, Deb & Agrawal 1995, Complex Systems 9),
//! bounded polynomial mutation (Deb & Goyal 1996; Deb 2001, "Multi-objective
//! optimization using evolutionary algorithms", sec. 4.2) and elitism.
//!
//! A generation keeps the `elite` best parents unchanged (selection, with
//! immortal elites as in a (μ + λ)-ES) and fills the rest with children:
//! two tournament winners recombine (recombination) with probability
//! `crossover_probability`, then every gene mutates with probability
//! `mutation_probability` (mutation). Only the children are evaluated, as
//! one batch per generation.
//!
//! Determinism: one ChaCha8 stream of the seed, consumed in a fixed order
//! (initial population individual by individual, then per generation child
//! pair by child pair); evaluation is the only parallel part.

use super::error::OptimizeError;
use super::problem::{Evaluator, OptimizeResult, Problem, Termination};
use super::pso::argmin;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// Settings of the GA (YAML `optimizer_settings:` when `optimizer: ga`).
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct GaParams {
    pub population: usize,
    /// Best individuals copied unchanged into the next generation.
    pub elite: usize,
    /// Individuals per tournament.
    pub tournament: usize,
    pub crossover_probability: f64,
    /// Distribution index η_c of SBX (larger: children closer to parents).
    pub crossover_eta: f64,
    /// Per-gene probability; default 1/n.
    pub mutation_probability: Option<f64>,
    /// Distribution index η_m of polynomial mutation.
    pub mutation_eta: f64,
    pub max_generations: usize,
    /// Stop after this many generations without improvement (0: never).
    pub stall_generations: usize,
}

impl Default for GaParams {
    fn default() -> Self {
        GaParams {
            population: 50,
            elite: 2,
            tournament: 3,
            crossover_probability: 0.9,
            crossover_eta: 15.0,
            mutation_probability: None,
            mutation_eta: 20.0,
            max_generations: 10_000,
            stall_generations: 0,
        }
    }
}

impl GaParams {
    pub(crate) fn check(&self) -> Result<(), String> {
        if self.population < 2 || self.elite >= self.population {
            return Err(format!(
                "need population ≥ 2 and elite < population, got {} and {}",
                self.population, self.elite
            ));
        }
        if self.tournament == 0 {
            return Err("tournament must be ≥ 1".into());
        }
        let pm = self.mutation_probability.unwrap_or(0.0);
        for (name, p) in [
            ("crossover_probability", self.crossover_probability),
            ("mutation_probability", pm),
        ] {
            if !(0.0..=1.0).contains(&p) {
                return Err(format!("{name} must be in [0, 1], got {p}"));
            }
        }
        if !(self.crossover_eta >= 0.0 && self.mutation_eta >= 0.0) {
            return Err("crossover_eta and mutation_eta must be ≥ 0".into());
        }
        Ok(())
    }
}

/// Minimizes with a population seeded by `seed`.
pub fn minimize(
    problem: &Problem,
    params: &GaParams,
    seed: u64,
) -> Result<OptimizeResult, OptimizeError> {
    problem.check()?;
    params.check().map_err(|message| OptimizeError::Settings {
        optimizer: "ga".into(),
        message,
    })?;
    if !problem.constraints.is_empty() {
        return Err(OptimizeError::ConstraintsUnsupported {
            optimizer: "ga".into(),
        });
    }
    let n = problem.bounds.dim();
    let size = params.population;
    let pm = params.mutation_probability.unwrap_or(1.0 / n as f64);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut pop: Vec<Vec<f64>> = (0..size)
        .map(|_| (0..n).map(|_| rng.random::<f64>()).collect())
        .collect();
    let mut ev = Evaluator::new(problem);
    let k = size.min(ev.remaining());
    pop.truncate(k);
    let mut fit = ev.evaluate(&pop)?;
    let (mut generations, mut stall) = (0, 0);
    let termination = loop {
        if ev.target_reached() {
            break Termination::TargetReached;
        }
        if ev.remaining() == 0 || pop.len() < size {
            break Termination::BudgetExhausted;
        }
        if generations >= params.max_generations {
            break Termination::MaxIterations;
        }
        if params.stall_generations > 0 && stall >= params.stall_generations {
            break Termination::Stalled;
        }
        let previous = fit[argmin(&fit)];
        let mut order: Vec<usize> = (0..size).collect();
        order.sort_by(|&a, &b| fit[a].total_cmp(&fit[b]).then(a.cmp(&b)));
        let mut children: Vec<Vec<f64>> = Vec::with_capacity(size - params.elite);
        while children.len() < size - params.elite {
            let a = &pop[tournament(&fit, params.tournament, &mut rng)];
            let b = &pop[tournament(&fit, params.tournament, &mut rng)];
            let (mut c1, mut c2) = if rng.random::<f64>() < params.crossover_probability {
                sbx(a, b, params.crossover_eta, &mut rng)
            } else {
                (a.clone(), b.clone())
            };
            mutate(&mut c1, pm, params.mutation_eta, &mut rng);
            mutate(&mut c2, pm, params.mutation_eta, &mut rng);
            children.push(c1);
            if children.len() < size - params.elite {
                children.push(c2);
            }
        }
        children.truncate(ev.remaining());
        let child_fit = ev.evaluate(&children)?;
        let mut next: Vec<Vec<f64>> = order[..params.elite]
            .iter()
            .map(|&i| pop[i].clone())
            .collect();
        let mut next_fit: Vec<f64> = order[..params.elite].iter().map(|&i| fit[i]).collect();
        next.extend(children);
        next_fit.extend(child_fit);
        pop = next;
        fit = next_fit;
        generations += 1;
        stall = if fit[argmin(&fit)] < previous {
            0
        } else {
            stall + 1
        };
    };
    let fallback = pop[argmin(&fit)].clone();
    Ok(ev.finish("ga", generations, termination, &fallback))
}

/// Index of the best of `size` uniformly drawn individuals.
fn tournament(fit: &[f64], size: usize, rng: &mut ChaCha8Rng) -> usize {
    let mut best = rng.random_range(0..fit.len());
    for _ in 1..size {
        let c = rng.random_range(0..fit.len());
        if fit[c] < fit[best] {
            best = c;
        }
    }
    best
}

/// SBX: per gene (probability 0.5) the spread factor β has the polynomial
/// density of index η; children c₁,₂ = ½[(1 ± β) a + (1 ∓ β) b], clamped.
fn sbx(a: &[f64], b: &[f64], eta: f64, rng: &mut ChaCha8Rng) -> (Vec<f64>, Vec<f64>) {
    let (mut c1, mut c2) = (a.to_vec(), b.to_vec());
    for i in 0..a.len() {
        let (cross, u): (f64, f64) = (rng.random(), rng.random());
        if cross > 0.5 {
            continue;
        }
        let beta = if u <= 0.5 {
            (2.0 * u).powf(1.0 / (eta + 1.0))
        } else {
            (1.0 / (2.0 * (1.0 - u))).powf(1.0 / (eta + 1.0))
        };
        c1[i] = (0.5 * ((1.0 + beta) * a[i] + (1.0 - beta) * b[i])).clamp(0.0, 1.0);
        c2[i] = (0.5 * ((1.0 - beta) * a[i] + (1.0 + beta) * b[i])).clamp(0.0, 1.0);
    }
    (c1, c2)
}

/// Bounded polynomial mutation in [0, 1] (Deb 2001): the perturbation δ
/// has a polynomial density of index η that never leaves the box.
fn mutate(x: &mut [f64], probability: f64, eta: f64, rng: &mut ChaCha8Rng) {
    let power = 1.0 / (eta + 1.0);
    for xi in x.iter_mut() {
        let (p, r): (f64, f64) = (rng.random(), rng.random());
        if p >= probability {
            continue;
        }
        let (d1, d2) = (*xi, 1.0 - *xi);
        let dq = if r < 0.5 {
            let v = 2.0 * r + (1.0 - 2.0 * r) * (1.0 - d1).powf(eta + 1.0);
            v.powf(power) - 1.0
        } else {
            let v = 2.0 * (1.0 - r) + 2.0 * (r - 0.5) * (1.0 - d2).powf(eta + 1.0);
            1.0 - v.powf(power)
        };
        *xi = (*xi + dq).clamp(0.0, 1.0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::problem::{sequential, Bounds};

    #[test]
    fn operators_stay_in_the_box() {
        let mut rng = ChaCha8Rng::seed_from_u64(5);
        for _ in 0..200 {
            let a: Vec<f64> = (0..4).map(|_| rng.random()).collect();
            let b: Vec<f64> = (0..4).map(|_| rng.random()).collect();
            let (mut c1, c2) = sbx(&a, &b, 2.0, &mut rng);
            // SBX preserves the mean of each gene unless clamped.
            for i in 0..4 {
                let inside = c1[i] > 0.0 && c1[i] < 1.0 && c2[i] > 0.0 && c2[i] < 1.0;
                if inside {
                    assert!((c1[i] + c2[i] - a[i] - b[i]).abs() < 1e-12);
                }
            }
            mutate(&mut c1, 1.0, 5.0, &mut rng);
            assert!(c1.iter().all(|v| (0.0..=1.0).contains(v)));
        }
    }

    #[test]
    fn sphere_converges_within_budget() {
        let f = sequential(|x: &[f64]| x.iter().map(|v| (v - 1.0) * (v - 1.0)).sum());
        let p = Problem::new(
            Bounds::linear(vec![-3.0; 3], vec![5.0; 3]).unwrap(),
            &f,
            3000,
        );
        let r = minimize(&p, &GaParams::default(), 9).unwrap();
        assert!(r.evaluations <= 3000);
        assert!(r.f_best < 1e-4, "{}", r.f_best);
    }
}
