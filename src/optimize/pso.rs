//! Particle swarm optimization (seed eq. 2.25–2.26; Poli, Kennedy & Blackwell
//! 2007, doi:10.1007/s11721-007-0002-0) in the unit box of a [`Problem`].
//!
//! Each particle l moves by
//!   v ← w₁ v + w₂ r₂ ∘ (x̃_l − x) + w₃ r₃ ∘ (x̃ˢ − x)   (eq. 2.26)
//!   x ← x + v                                         (eq. 2.25)
//! with inertia w₁, nostalgia (cognitive) weight w₂, social weight w₃, the
//! particle's best point x̃_l and the swarm's best point x̃ˢ (global
//! topology). r₂, r₃ are uniform in [0, 1] and drawn per dimension. As in
//! Poli et al. the freshly updated velocity moves the particle (the seed's
//! index i vs i+1 in eq. 2.25 would lag the move by one iteration).
//! Velocities are clamped to ±`max_velocity` (unit box per dimension).
//!
//! Bounds: `reflect` (default) mirrors a particle that left the box at the
//! violated face and reverses that velocity component; `clamp` puts it on the
//! face and zeroes the component.
//!
//! Determinism: one ChaCha8 stream of the seed, consumed in a fixed order
//! (initial positions and velocities particle by particle, then per
//! iteration particle by particle and dimension by dimension: r₂, r₃). The
//! swarm is evaluated as one batch per iteration; that is the only parallel
//! part, so results are bit-identical for any number of threads.

use super::error::OptimizeError;
use super::problem::{Evaluator, OptimizeResult, Problem, Termination};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};

/// What happens to a particle that leaves the unit box.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum BoundHandling {
    /// Mirror at the face, reverse the velocity component.
    #[default]
    Reflect,
    /// Stop on the face, zero the velocity component.
    Clamp,
}

/// Settings of PSO (YAML `optimizer_settings:` when `optimizer: pso`).
/// Defaults: Clerc's constriction weights w₁ = 0.7298, w₂ = w₃ = 1.49618
/// (Poli et al. 2007), 30 particles as in the seed's figure 2.5.
#[derive(Debug, Clone, PartialEq, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct PsoParams {
    pub swarm_size: usize,
    /// w₁ of eq. 2.26.
    pub inertia: f64,
    /// w₂ of eq. 2.26 (nostalgia, cognitive).
    pub cognitive: f64,
    /// w₃ of eq. 2.26 (social).
    pub social: f64,
    /// Velocity limit per dimension, as a fraction of the unit box.
    pub max_velocity: f64,
    pub bound_handling: BoundHandling,
    pub max_iterations: usize,
    /// Stop after this many iterations without improvement (0: never).
    pub stall_iterations: usize,
}

impl Default for PsoParams {
    fn default() -> Self {
        PsoParams {
            swarm_size: 30,
            inertia: 0.7298,
            cognitive: 1.49618,
            social: 1.49618,
            max_velocity: 0.2,
            bound_handling: BoundHandling::Reflect,
            max_iterations: 10_000,
            stall_iterations: 0,
        }
    }
}

impl PsoParams {
    pub(crate) fn check(&self) -> Result<(), String> {
        if self.swarm_size < 2 {
            return Err(format!("swarm_size must be ≥ 2, got {}", self.swarm_size));
        }
        if !(self.max_velocity > 0.0 && self.max_velocity <= 1.0) {
            return Err(format!(
                "max_velocity must be in (0, 1], got {}",
                self.max_velocity
            ));
        }
        for (name, v) in [
            ("inertia", self.inertia),
            ("cognitive", self.cognitive),
            ("social", self.social),
        ] {
            if !(v.is_finite() && v >= 0.0) {
                return Err(format!("{name} must be finite and ≥ 0, got {v}"));
            }
        }
        Ok(())
    }
}

/// Minimizes with a swarm seeded by `seed`.
pub fn minimize(
    problem: &Problem,
    params: &PsoParams,
    seed: u64,
) -> Result<OptimizeResult, OptimizeError> {
    problem.check()?;
    params.check().map_err(|message| OptimizeError::Settings {
        optimizer: "pso".into(),
        message,
    })?;
    if !problem.constraints.is_empty() {
        return Err(OptimizeError::ConstraintsUnsupported {
            optimizer: "pso".into(),
        });
    }
    let n = problem.bounds.dim();
    let s = params.swarm_size;
    let vmax = params.max_velocity;
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut x: Vec<Vec<f64>> = Vec::with_capacity(s);
    let mut v: Vec<Vec<f64>> = Vec::with_capacity(s);
    for _ in 0..s {
        x.push((0..n).map(|_| rng.random::<f64>()).collect());
        v.push(
            (0..n)
                .map(|_| vmax * (2.0 * rng.random::<f64>() - 1.0))
                .collect(),
        );
    }
    let mut ev = Evaluator::new(problem);
    let k = s.min(ev.remaining());
    let f = ev.evaluate(&x[..k])?;
    let mut best_x = x.clone();
    let mut best_f = vec![f64::INFINITY; s];
    best_f[..k].copy_from_slice(&f);
    let mut g = argmin(&best_f);
    let (mut iterations, mut stall) = (0, 0);
    let termination = loop {
        if ev.target_reached() {
            break Termination::TargetReached;
        }
        if ev.remaining() == 0 {
            break Termination::BudgetExhausted;
        }
        if iterations >= params.max_iterations {
            break Termination::MaxIterations;
        }
        if params.stall_iterations > 0 && stall >= params.stall_iterations {
            break Termination::Stalled;
        }
        let gx = best_x[g].clone();
        for l in 0..s {
            for d in 0..n {
                let (r2, r3): (f64, f64) = (rng.random(), rng.random());
                let vel = params.inertia * v[l][d]
                    + params.cognitive * r2 * (best_x[l][d] - x[l][d])
                    + params.social * r3 * (gx[d] - x[l][d]);
                v[l][d] = vel.clamp(-vmax, vmax);
                x[l][d] += v[l][d];
                confine(&mut x[l][d], &mut v[l][d], params.bound_handling);
            }
        }
        let k = s.min(ev.remaining());
        let f = ev.evaluate(&x[..k])?;
        let previous = best_f[g];
        for l in 0..k {
            if f[l] < best_f[l] {
                best_f[l] = f[l];
                best_x[l].clone_from(&x[l]);
            }
        }
        g = argmin(&best_f);
        stall = if best_f[g] < previous { 0 } else { stall + 1 };
        iterations += 1;
    };
    Ok(ev.finish("pso", iterations, termination, &best_x[g]))
}

/// Keeps one coordinate in [0, 1] (see the module docs).
fn confine(x: &mut f64, v: &mut f64, mode: BoundHandling) {
    if (0.0..=1.0).contains(x) {
        return;
    }
    match mode {
        BoundHandling::Reflect => {
            *x = if *x < 0.0 { -*x } else { 2.0 - *x };
            *v = -*v;
            *x = x.clamp(0.0, 1.0);
        }
        BoundHandling::Clamp => {
            *x = x.clamp(0.0, 1.0);
            *v = 0.0;
        }
    }
}

/// Index of the smallest value (first on ties; +∞ everywhere gives 0).
pub(crate) fn argmin(values: &[f64]) -> usize {
    let mut best = 0;
    for (i, v) in values.iter().enumerate() {
        if *v < values[best] {
            best = i;
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::optimize::problem::{sequential, Bounds};

    #[test]
    fn reflect_and_clamp_keep_particles_in_the_box() {
        let (mut x, mut v) = (1.15, 0.3);
        confine(&mut x, &mut v, BoundHandling::Reflect);
        assert!((x - 0.85).abs() < 1e-15 && v == -0.3);
        let (mut x, mut v) = (-0.1, -0.2);
        confine(&mut x, &mut v, BoundHandling::Clamp);
        assert!(x == 0.0 && v == 0.0);
    }

    #[test]
    fn sphere_converges_and_budget_is_exact() {
        let f = sequential(|x: &[f64]| x.iter().map(|v| v * v).sum());
        let p = Problem::new(
            Bounds::linear(vec![-3.0; 3], vec![5.0; 3]).unwrap(),
            &f,
            3001,
        );
        let r = minimize(&p, &PsoParams::default(), 1).unwrap();
        assert_eq!(r.evaluations, 3001);
        assert_eq!(r.termination, Termination::BudgetExhausted);
        assert!(r.f_best < 1e-6, "{}", r.f_best);
    }

    #[test]
    fn constraints_are_rejected() {
        let f = sequential(|x: &[f64]| x[0]);
        let p = Problem::new(Bounds::linear(vec![0.0], vec![1.0]).unwrap(), &f, 10)
            .with_constraint(crate::optimize::Constraint::inequality(|x: &[f64]| {
                x[0] - 0.5
            }));
        assert!(minimize(&p, &PsoParams::default(), 0).is_err());
    }
}
