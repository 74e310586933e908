//! Benchmark of one model evaluation of the reference test bench (assemble
//! joint terms at given parameters + shift-invert reduction + dense
//! eigensolve, lowest 30 modes + modal damping) against a bare dense symmetric eigensolve of the
//! same size in the same run, and batch throughput on 1 vs 2 threads.
//!
//! Run: `cargo bench --bench dynamics`. Targets: evaluation / bare eigensolve
//! ≤ 1.5; 2-thread / 1-thread throughput ≥ 1.8 for 256 evaluations.
#![allow(non_snake_case)]

use modalflow::dynamics::eigen::{cholesky, inverted_form, symmetric_eigen};
use modalflow::dynamics::{Model, PreparedModel};
use rayon::prelude::*;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    v[v.len() / 2]
}

fn main() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/pipelines/models/uniaxial_test_bench.yaml"
    );
    let text = std::fs::read_to_string(path).expect("reference model");
    let no_files = |p: &str| -> std::io::Result<Vec<u8>> { std::fs::read(p) };
    let t = Instant::now();
    let model =
        Model::from_yaml(&text, "uniaxial_test_bench.yaml", &no_files).expect("valid model");
    let prepared = PreparedModel::new(&model).expect("prepared");
    let prep_ms = t.elapsed().as_secs_f64() * 1e3;
    let n = prepared.n_dofs();
    let values: Vec<f64> = prepared.parameters.iter().map(|p| p.value).collect();
    let reps = 40;
    // Interleave the two measurements so drift from other builds hits both.
    let (mut eval, mut bare) = (Vec::new(), Vec::new());
    // The bare eigensolve works on the same matrix the evaluation decomposes.
    let forms: Vec<_> = (0..prepared.configurations.len())
        .map(|c| {
            let K_sigma = prepared.shifted_stiffness(c, &values).expect("stiffness");
            let L = cholesky(&K_sigma).expect("K + σM positive definite");
            inverted_form(&L, &prepared.M_chol)
        })
        .collect();
    for i in 0..reps {
        let t = Instant::now();
        let sol = prepared
            .evaluate(i % prepared.configurations.len(), &values, 30)
            .expect("evaluation");
        eval.push(t.elapsed().as_secs_f64());
        std::hint::black_box(sol);
        let t = Instant::now();
        let r = symmetric_eigen(&forms[i % forms.len()]).expect("eigen");
        bare.push(t.elapsed().as_secs_f64());
        std::hint::black_box(r);
    }
    let (e, b) = (median(eval), median(bare));
    // Batch throughput: 256 evaluations with varied parameters.
    let batch: Vec<Vec<f64>> = (0..256)
        .map(|i| {
            values
                .iter()
                .map(|v| v * (0.8 + 0.4 * ((i * 37 % 101) as f64 / 100.0)))
                .collect()
        })
        .collect();
    let pool = |threads: usize| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
    };
    let run = |threads: usize| {
        let pool = pool(threads);
        let t = Instant::now();
        let out: Vec<f64> = pool.install(|| {
            batch
                .par_iter()
                .enumerate()
                .map(|(i, v)| {
                    prepared
                        .evaluate(i % 4, v, 30)
                        .expect("evaluation")
                        .eigenvalues[6]
                })
                .collect()
        });
        std::hint::black_box(out);
        t.elapsed().as_secs_f64()
    };
    // Platform reference: the same batch size of bare eigensolves, showing
    // what 2 threads can give on this machine for dense SIMD work.
    let run_bare = |threads: usize| {
        let pool = pool(threads);
        let t = Instant::now();
        let out: Vec<f64> = pool.install(|| {
            (0..256)
                .into_par_iter()
                .map(|i| symmetric_eigen(&forms[i % forms.len()]).expect("eigen").0[6])
                .collect()
        });
        std::hint::black_box(out);
        t.elapsed().as_secs_f64()
    };
    // Best of 3 for each, alternating, to damp interference from other jobs.
    let (mut t1, mut t2, mut r1, mut r2) = (f64::MAX, f64::MAX, f64::MAX, f64::MAX);
    for _ in 0..3 {
        t1 = t1.min(run(1));
        t2 = t2.min(run(2));
        r1 = r1.min(run_bare(1));
        r2 = r2.min(run_bare(2));
    }
    println!("| quantity | value |");
    println!("|---|---|");
    println!("| DOF (reduced) | {n} |");
    println!("| prepare (parse, CB, factor, 4 configurations) | {prep_ms:.1} ms |");
    println!(
        "| one evaluation (30 modes + damping) | {:.2} ms |",
        e * 1e3
    );
    println!(
        "| bare dense symmetric eigensolve n={n} | {:.2} ms |",
        b * 1e3
    );
    println!(
        "| ratio evaluation / eigensolve (target <= 1.5) | {:.2} |",
        e / b
    );
    println!(
        "| batch 256, 1 thread | {:.1} ms ({:.2} ms/eval) |",
        t1 * 1e3,
        t1 * 1e3 / 256.0
    );
    println!(
        "| batch 256, 2 threads | {:.1} ms ({:.2} ms/eval) |",
        t2 * 1e3,
        t2 * 1e3 / 256.0
    );
    println!(
        "| speed-up 2 vs 1 thread (target >= 1.8) | {:.2} |",
        t1 / t2
    );
    println!(
        "| reference: bare eigensolve batch speed-up 2 vs 1 thread | {:.2} |",
        r1 / r2
    );
}
