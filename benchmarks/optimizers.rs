//! Benchmark of the optimizers (SLSQP, PSO, GA).
//!
//! 1. Cost to reach f < 1e-3 on Rosenbrock-10D ([-2, 2]^10): evaluations
//!    and wall time per optimizer, as ratios to SLSQP in the same run.
//! 2. Batch-parallel speed-up: a ~1 ms objective (lowest five eigenvalues of
//!    a dense 150×150 symmetric matrix A(x) = A₀ + Σ xᵢ Bᵢ, faer, sequential
//!    inside) run on a 1-thread and a 2-thread rayon pool; results must be
//!    bit-identical, the time ratio is the speed-up (ideal: 2 on 2 cores).
//!
//! Run: `cargo bench --bench optimizers`.
#![allow(non_snake_case)]

use faer::Mat;
use modalflow::dynamics::eigen::symmetric_eigen;
use modalflow::optimize::ga::{self, GaParams};
use modalflow::optimize::problem::{parallel, sequential};
use modalflow::optimize::pso::{self, PsoParams};
use modalflow::optimize::slsqp::{self, SlsqpParams};
use modalflow::optimize::{Bounds, OptimizeResult, Optimizer, Problem};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::time::Instant;

fn rosenbrock(x: &[f64]) -> f64 {
    x.windows(2)
        .map(|w| 100.0 * (w[1] - w[0] * w[0]).powi(2) + (1.0 - w[0]).powi(2))
        .sum()
}

fn random_symmetric(n: usize, scale: f64, rng: &mut ChaCha8Rng) -> Mat<f64> {
    let mut A = Mat::<f64>::zeros(n, n);
    for j in 0..n {
        for i in j..n {
            let v = scale * (2.0 * rng.random::<f64>() - 1.0);
            A[(i, j)] = v;
            A[(j, i)] = v;
        }
    }
    A
}

fn row(name: &str, r: &OptimizeResult, secs: f64, reference: (f64, f64)) {
    println!(
        "{name:<6} {:>10} {:>10.4} {:>12.3e} {:>10.2} {:>10.2}  {:?}",
        r.evaluations,
        secs,
        r.f_best,
        r.evaluations as f64 / reference.0,
        secs / reference.1,
        r.termination
    );
}

fn rosenbrock_10d() {
    println!("Rosenbrock-10D, target f < 1e-3 (ratios to SLSQP)");
    println!(
        "{:<6} {:>10} {:>10} {:>12} {:>10} {:>10}  termination",
        "", "evals", "time s", "f_best", "evals/ref", "time/ref"
    );
    let f = sequential(rosenbrock);
    let n = 10;
    let bounds = Bounds::linear(vec![-2.0; n], vec![2.0; n]).expect("bounds");
    let x0: Vec<f64> = (0..n)
        .map(|i| if i % 2 == 0 { -1.2 } else { 1.0 })
        .collect();
    let p = Problem::new(bounds.clone(), &f, 20_000).with_target(1e-3);
    let t = Instant::now();
    let r = slsqp::minimize(&p, &SlsqpParams::default(), &x0).expect("slsqp");
    let reference = (r.evaluations as f64, t.elapsed().as_secs_f64());
    row("slsqp", &r, reference.1, reference);
    let p = Problem::new(bounds, &f, 1_000_000).with_target(1e-3);
    let t = Instant::now();
    let r = pso::minimize(&p, &PsoParams::default(), 1).expect("pso");
    row("pso", &r, t.elapsed().as_secs_f64(), reference);
    let t = Instant::now();
    let r = ga::minimize(&p, &GaParams::default(), 1).expect("ga");
    row("ga", &r, t.elapsed().as_secs_f64(), reference);
}

fn parallel_speedup() {
    let (size, dim) = (150, 4);
    let mut rng = ChaCha8Rng::seed_from_u64(2025);
    let mut A0 = random_symmetric(size, 1.0, &mut rng);
    for i in 0..size {
        A0[(i, i)] += 4.0 * size as f64;
    }
    let B: Vec<Mat<f64>> = (0..dim)
        .map(|_| random_symmetric(size, 1.0, &mut rng))
        .collect();
    let eig5 = |x: &[f64]| -> Vec<f64> {
        let mut A = A0.clone();
        for (xi, Bi) in x.iter().zip(&B) {
            A += Bi * faer::Scale(*xi);
        }
        symmetric_eigen(&A).map_or(vec![f64::NAN; 5], |(s, _)| s[..5].to_vec())
    };
    let truth = eig5(&[1.2, 0.8, 1.5, 1.0]);
    let objective = parallel(|x: &[f64]| {
        eig5(x)
            .iter()
            .zip(&truth)
            .map(|(a, b)| ((a - b) / b).powi(2))
            .sum()
    });
    let t = Instant::now();
    let one = sequential(|x: &[f64]| eig5(x)[0]);
    let reps = 50;
    for _ in 0..reps {
        std::hint::black_box(one.evaluate_batch());
    }
    println!(
        "\nbatch-parallel speed-up, {size}x{size} eigensolve per evaluation ({:.2} ms)",
        1e3 * t.elapsed().as_secs_f64() / reps as f64
    );
    println!(
        "{:<6} {:>8} {:>12} {:>12} {:>9}  identical",
        "", "evals", "1 thread s", "2 threads s", "speed-up"
    );
    // Reference: the same evaluations as bare batches of 30 (no optimizer).
    let batch: Vec<Vec<f64>> = (0..30).map(|k| vec![0.5 + 0.05 * k as f64; dim]).collect();
    let mut bare = Vec::new();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        let t = Instant::now();
        for _ in 0..10 {
            std::hint::black_box(pool.install(|| objective(&batch)));
        }
        bare.push(t.elapsed().as_secs_f64());
    }
    println!(
        "{:<6} {:>8} {:>12.3} {:>12.3} {:>9.2}  (reference)",
        "bare",
        300,
        bare[0],
        bare[1],
        bare[0] / bare[1]
    );
    let p = Problem::new(
        Bounds::linear(vec![0.5; dim], vec![2.0; dim]).expect("bounds"),
        &objective,
        300,
    );
    for name in Optimizer::NAMES {
        let o = Optimizer::from_settings(name, None).expect("defaults");
        let mut out = Vec::new();
        for threads in [1, 2] {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("pool");
            let t = Instant::now();
            let r = pool.install(|| o.minimize(&p, 7)).expect("run");
            out.push((t.elapsed().as_secs_f64(), r));
        }
        let identical = out[0].1.x_best == out[1].1.x_best && out[0].1.history == out[1].1.history;
        println!(
            "{name:<6} {:>8} {:>12.3} {:>12.3} {:>9.2}  {identical}",
            out[0].1.evaluations,
            out[0].0,
            out[1].0,
            out[0].0 / out[1].0
        );
    }
}

/// One pointwise call, for timing a single evaluation.
trait EvaluateBatch {
    fn evaluate_batch(&self) -> Vec<f64>;
}

impl<F: Fn(&[Vec<f64>]) -> Vec<f64>> EvaluateBatch for F {
    fn evaluate_batch(&self) -> Vec<f64> {
        self(&[vec![1.0; 4]])
    }
}

fn main() {
    rosenbrock_10d();
    parallel_speedup();
}
