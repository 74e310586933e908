//! Known-answer tests of the optimizers (SLSQP, PSO, GA) on Rosenbrock,
//! Rastrigin and Hock–Schittkowski 71, plus the shared contracts: the budget
//! is never exceeded, seeded runs are reproducible and independent of the
//! rayon thread count, non-finite objective values are survived.

use modalflow::optimize::ga::{self, GaParams};
use modalflow::optimize::problem::{parallel, sequential};
use modalflow::optimize::pso::{self, PsoParams};
use modalflow::optimize::slsqp::{self, Difference, SlsqpParams};
use modalflow::optimize::{Bounds, Constraint, OptimizeResult, Optimizer, Problem, Termination};
use modalflow::parameter::Scale;
use std::f64::consts::PI;

fn rosenbrock(x: &[f64]) -> f64 {
    x.windows(2)
        .map(|w| 100.0 * (w[1] - w[0] * w[0]).powi(2) + (1.0 - w[0]).powi(2))
        .sum()
}

fn rastrigin(x: &[f64]) -> f64 {
    10.0 * x.len() as f64
        + x.iter()
            .map(|v| v * v - 10.0 * (2.0 * PI * v).cos())
            .sum::<f64>()
}

fn boxed(n: usize, lo: f64, hi: f64) -> Bounds {
    Bounds::linear(vec![lo; n], vec![hi; n]).unwrap()
}

fn assert_near(x: &[f64], expected: &[f64], tol: f64) {
    for (a, b) in x.iter().zip(expected) {
        assert!((a - b).abs() <= tol, "{x:?} vs {expected:?} (tol {tol})");
    }
}

fn assert_budget(r: &OptimizeResult, budget: usize) {
    assert!(r.evaluations <= budget, "{} > {budget}", r.evaluations);
    let last = r.history.last().map_or(0, |h| h.evaluation);
    assert!(last <= r.evaluations);
    assert!(r.history.windows(2).all(|w| w[1].f_best < w[0].f_best));
}

#[test]
fn slsqp_rosenbrock_2d_and_5d() {
    let f = sequential(rosenbrock);
    for n in [2, 5] {
        let p = Problem::new(boxed(n, -2.0, 2.0), &f, 20_000);
        let x0: Vec<f64> = (0..n)
            .map(|i| if i % 2 == 0 { -1.2 } else { 1.0 })
            .collect();
        // Central differences reach 1e-6; forward ones carry an O(h) bias
        // that the ill-conditioned valley amplifies (about 3e-4 at h = 1e-7).
        for (difference, step, tol) in [
            (Difference::Central, 1e-6, 1e-6),
            (Difference::Forward, 1e-7, 1e-3),
        ] {
            let params = SlsqpParams {
                difference,
                step,
                ..SlsqpParams::default()
            };
            let r = slsqp::minimize(&p, &params, &x0).unwrap();
            assert_near(&r.x_best, &vec![1.0; n], tol);
            assert_budget(&r, 20_000);
            assert!(
                matches!(
                    r.termination,
                    Termination::Converged | Termination::RoundoffLimited { accepted: true, .. }
                ),
                "{:?}",
                r.termination
            );
        }
    }
}

#[test]
fn slsqp_rastrigin_finds_the_local_minimum_of_its_basin() {
    let f = sequential(rastrigin);
    for n in [2, 5] {
        let p = Problem::new(boxed(n, -5.12, 5.12), &f, 5_000);
        // The first SQP step uses an identity Hessian in the unit box, so a
        // start must be close to 0 to stay in its basin (0.3 ends at −0.995).
        let r = slsqp::minimize(&p, &SlsqpParams::default(), &vec![0.05; n]).unwrap();
        assert_near(&r.x_best, &vec![0.0; n], 1e-6);
        assert!(r.f_best < 1e-9);
        // From near (1, …, 1) it stays in the local minimum x ≈ 0.99496.
        let r = slsqp::minimize(&p, &SlsqpParams::default(), &vec![1.2; n]).unwrap();
        assert_near(&r.x_best, &vec![0.994_959; n], 1e-5);
        assert!(
            (r.f_best - 0.994_959_057 * n as f64).abs() < 1e-6,
            "{}",
            r.f_best
        );
    }
}

/// Hock & Schittkowski (1981) problem 71: f* = 17.0140173 at
/// x* = (1, 4.7430, 3.82115, 1.37941), one active inequality and one equality.
#[test]
fn slsqp_hock_schittkowski_71() {
    let f = sequential(|x: &[f64]| x[0] * x[3] * (x[0] + x[1] + x[2]) + x[2]);
    let p = Problem::new(boxed(4, 1.0, 5.0), &f, 2_000)
        .with_constraint(Constraint::inequality(|x: &[f64]| {
            25.0 - x[0] * x[1] * x[2] * x[3]
        }))
        .with_constraint(Constraint::equality(|x: &[f64]| {
            x.iter().map(|v| v * v).sum::<f64>() - 40.0
        }));
    let r = slsqp::minimize(&p, &SlsqpParams::default(), &[1.0, 5.0, 5.0, 1.0]).unwrap();
    assert!((r.f_best - 17.014_017_3).abs() < 1e-6, "{r:?}");
    assert_near(
        &r.x_best,
        &[1.0, 4.742_999_6, 3.821_149_9, 1.379_408_3],
        1e-4,
    );
    assert!(r.max_violation <= 1e-6);
    assert_budget(&r, 2_000);
}

#[test]
fn pso_and_ga_rosenbrock() {
    let f = sequential(rosenbrock);
    for (n, budget) in [(2, 6_000), (5, 40_000)] {
        let p = Problem::new(boxed(n, -2.0, 2.0), &f, budget);
        let r = pso::minimize(&p, &PsoParams::default(), 7).unwrap();
        assert!(r.f_best < 1e-2, "pso {n}-D: {}", r.f_best);
        assert_budget(&r, budget);
        // The GA is slow in the curved valley: at 40 000 evaluations only
        // some seeds get below 1e-2 in 5-D (seed 3 does, after ~2 900).
        let r = ga::minimize(&p, &GaParams::default(), 3).unwrap();
        assert!(r.f_best < 1e-2, "ga {n}-D: {}", r.f_best);
        assert_budget(&r, budget);
    }
}

#[test]
fn pso_and_ga_rastrigin_global_optimum() {
    let f = sequential(rastrigin);
    for (n, budget) in [(2, 5_000), (5, 30_000)] {
        let p = Problem::new(boxed(n, -5.12, 5.12), &f, budget).with_target(1e-4);
        // A global-best swarm of 30 often freezes one coordinate in the
        // local minimum ±0.995 of 5-D Rastrigin; 100 particles rarely do.
        let params = PsoParams {
            swarm_size: 100,
            ..PsoParams::default()
        };
        let r = pso::minimize(&p, &params, 3).unwrap();
        assert!(r.f_best < 1e-4, "pso {n}-D: {} at {:?}", r.f_best, r.x_best);
        assert_eq!(r.termination, Termination::TargetReached);
        assert_budget(&r, budget);
        let r = ga::minimize(&p, &GaParams::default(), 3).unwrap();
        assert!(r.f_best < 1e-4, "ga {n}-D: {} at {:?}", r.f_best, r.x_best);
        assert_budget(&r, budget);
    }
}

#[test]
fn budget_is_never_exceeded() {
    let f = sequential(rosenbrock);
    for budget in [1, 2, 3, 7, 31, 52, 101] {
        let p = Problem::new(boxed(3, -2.0, 2.0), &f, budget);
        for name in Optimizer::NAMES {
            let o = Optimizer::from_settings(name, None).unwrap();
            let r = o.minimize(&p, 1).unwrap();
            assert!(
                r.evaluations <= budget,
                "{name}: {} > {budget}",
                r.evaluations
            );
            if name != "slsqp" {
                assert_eq!(r.evaluations, budget, "{name} should use the whole budget");
            }
            assert!(r.f_best.is_finite());
        }
        let ms: serde_yaml_ng::Value = serde_yaml_ng::from_str("starts: 4").unwrap();
        let r = Optimizer::from_settings("slsqp", Some(&ms))
            .unwrap()
            .minimize(&p, 1);
        if let Ok(r) = r {
            assert!(r.evaluations <= budget);
        }
    }
}

#[test]
fn same_seed_same_history_other_seed_differs() {
    let f = sequential(rastrigin);
    let p = Problem::new(boxed(3, -5.12, 5.12), &f, 2_000);
    for name in ["pso", "ga"] {
        let o = Optimizer::from_settings(name, None).unwrap();
        let (a, b, c) = (
            o.minimize(&p, 11).unwrap(),
            o.minimize(&p, 11).unwrap(),
            o.minimize(&p, 12).unwrap(),
        );
        assert_eq!(a.history, b.history, "{name}");
        assert_eq!(a.x_best, b.x_best, "{name}");
        assert_ne!(a.history, c.history, "{name}");
    }
}

#[test]
fn one_and_two_threads_give_bit_identical_results() {
    let f = parallel(rastrigin);
    let p = Problem::new(boxed(4, -5.12, 5.12), &f, 1_500);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            Optimizer::NAMES
                .iter()
                .map(|name| {
                    let o = Optimizer::from_settings(name, None).unwrap();
                    let r = o.minimize(&p, 5).unwrap();
                    let bits: Vec<u64> = r.x_best.iter().map(|v| v.to_bits()).collect();
                    (bits, r.f_best.to_bits(), r.history, r.evaluations)
                })
                .collect::<Vec<_>>()
        })
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn non_finite_objective_values_count_as_infinity() {
    // Quadratic with its minimum at (0.5, 0.5), undefined (NaN) for x₀ > 1
    // and +∞ for x₁ < −1: every optimizer still finds the minimum.
    let f = sequential(|x: &[f64]| {
        if x[0] > 1.0 {
            f64::NAN
        } else if x[1] < -1.0 {
            f64::INFINITY
        } else {
            (x[0] - 0.5).powi(2) + (x[1] - 0.5).powi(2)
        }
    });
    let p = Problem::new(boxed(2, -2.0, 2.0), &f, 3_000);
    let r = pso::minimize(&p, &PsoParams::default(), 1).unwrap();
    assert!(r.non_finite > 0 && r.f_best < 1e-8, "{r:?}");
    let r = ga::minimize(&p, &GaParams::default(), 1).unwrap();
    assert!(r.non_finite > 0 && r.f_best < 1e-6, "{r:?}");
    let r = slsqp::minimize(&p, &SlsqpParams::default(), &[0.99, -0.99]).unwrap();
    assert!(r.f_best < 1e-8, "{r:?}");
    let nan = sequential(|_: &[f64]| f64::NAN);
    let p = Problem::new(boxed(2, -2.0, 2.0), &nan, 100);
    for name in Optimizer::NAMES {
        let r = Optimizer::from_settings(name, None)
            .unwrap()
            .minimize(&p, 1)
            .unwrap();
        assert_eq!(r.f_best, f64::INFINITY);
        assert_eq!(r.non_finite, r.evaluations);
        assert!(r.evaluations <= 100);
    }
}

#[test]
fn log_scaled_parameters_are_searched_in_decades() {
    // Minimum at k = 3.7e7 in [1e5, 1e10]: a log10 objective that SLSQP
    // solves in the unit box.
    let f = sequential(|x: &[f64]| (x[0].log10() - 3.7e7f64.log10()).powi(2));
    let b = Bounds::new(vec![1e5], vec![1e10], vec![Scale::Log]).unwrap();
    let p = Problem::new(b, &f, 200);
    let r = slsqp::minimize(&p, &SlsqpParams::default(), &[1e6]).unwrap();
    assert!((r.x_best[0] / 3.7e7 - 1.0).abs() < 1e-6, "{:?}", r.x_best);
}
