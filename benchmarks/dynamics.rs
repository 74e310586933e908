//! One model evaluation (assemble joint terms + factor K + σM + lowest 30
//! modes + modal damping + FRFs at the sensors) of the reference test bench
//! and of scaled, unreduced copies of it.
//!
//! * `cargo bench --bench dynamics` — test bench (216 DOF, dense):
//!   evaluation by block Lanczos against the previous algorithm (full
//!   symmetric eigensolver on the same factor) in the same run, their
//!   agreement, the block size, and batch throughput on 1 vs 2 threads.
//! * `cargo bench --bench dynamics -- export DIR NAME SCALE METHOD` writes
//!   the matrices of a scaled copy (beam elements × SCALE, no Craig–Bampton,
//!   solver METHOD) for `benchmarks/eigen_compare.py` (scipy in the same
//!   script), and `-- time NAME SCALE METHOD REPS` prints the best-of-REPS
//!   time of one evaluation, the preparation time and the memory held.
//! * `cargo bench --bench dynamics -- model SCALE_BED SCALE_COLUMN` prints the
//!   high-fidelity variant of the test bench (`pipelines/models/`).
#![allow(non_snake_case)]

mod timing;

use modalflow::dynamics::eigen::shift_invert_factored;
use modalflow::dynamics::model_file::SolverMethod;
use modalflow::dynamics::{Model, PreparedModel};
use modalflow::frf::FrfQuantity;
use rayon::prelude::*;
use std::io::Write;
use std::time::Instant;
use timing::{best, pool};

const BENCH: &str = include_str!("../pipelines/models/uniaxial_test_bench.yaml");

/// The test bench with beam elements (and node numbers of points) of the
/// listed bodies multiplied, Craig–Bampton reductions of those bodies
/// dropped, and a `solver:` block.
pub fn scaled_bench(scales: &[(&str, usize)], method: &str) -> String {
    let mut out = String::new();
    let mut body = String::new();
    for line in BENCH.lines() {
        let t = line.trim_start();
        if let Some(name) = t.strip_prefix("- name: ") {
            body = name.trim().to_string();
        }
        if t.starts_with("joints:") {
            body.clear();
        }
        let k = scales
            .iter()
            .find(|(b, _)| *b == body)
            .map_or(1, |(_, k)| *k);
        if k > 1 && t.starts_with("reduction:") {
            continue;
        }
        let mut l = line.to_string();
        if k > 1 {
            for key in ["elements: ", "{node: "] {
                if let Some(i) = l.find(key) {
                    let start = i + key.len();
                    let end = start
                        + l[start..]
                            .find(|c: char| !c.is_ascii_digit())
                            .unwrap_or(l.len() - start);
                    let v: usize = l[start..end].parse().expect("number");
                    l = format!("{}{}{}", &l[..start], v * k, &l[end..]);
                }
            }
        }
        out.push_str(&l);
        out.push('\n');
    }
    if method != "auto" {
        out.push_str(&format!("\nsolver: {{method: {method}}}\n"));
    }
    out
}

fn model(text: &str) -> Model {
    let files = |p: &str| -> std::io::Result<Vec<u8>> { std::fs::read(p) };
    Model::from_yaml(text, "scaled_test_bench.yaml", &files).expect("valid model")
}

/// Scale 0: the reduced test bench itself (216 DOF).
fn case(scale: usize, method: &str) -> String {
    if scale == 0 {
        return format!("{BENCH}\nsolver: {{method: {method}}}\n");
    }
    scaled_bench(
        &[("bed", scale), ("column", scale), ("screw", scale)],
        method,
    )
}

fn grid() -> Vec<f64> {
    (0..1000).map(|i| 0.5 * i as f64).collect()
}

/// One evaluation: 30 modes, damping, receptances at all sensor pairs.
fn evaluation(p: &PreparedModel, config: usize, values: &[f64]) -> f64 {
    let sol = p.evaluate(config, values, 30).expect("evaluation");
    let frf = p
        .frf_superposition(&sol, FrfQuantity::Receptance, &grid())
        .expect("frf");
    sol.eigenvalues[29] + frf.channels[0].values[10].re
}

fn rss_kib() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(0)
}

fn mac(a: &[f64], b: &[f64]) -> f64 {
    let ab: f64 = a.iter().zip(b).map(|(x, y)| x * y).sum();
    let aa: f64 = a.iter().map(|x| x * x).sum();
    let bb: f64 = b.iter().map(|x| x * x).sum();
    ab * ab / (aa * bb)
}

fn test_bench() {
    let p = PreparedModel::new(&model(BENCH)).expect("prepared");
    let values: Vec<f64> = p.parameters.iter().map(|q| q.value).collect();
    let n = p.n_dofs();
    // Previous algorithm on the same K_σ factor: full EVD of L⁻¹ M L⁻ᵀ.
    let storage = match &*p.storage {
        modalflow::dynamics::storage::Storage::Dense(d) => d,
        _ => panic!("test bench is dense"),
    };
    let factor = |c: usize| {
        let mut K = p.stiffness(c, &values).expect("K");
        K += &storage.M * faer::Scale(p.shift());
        modalflow::dynamics::eigen::cholesky(&K).expect("SPD")
    };
    let factors: Vec<_> = (0..4).map(factor).collect();
    let (mut new, mut old) = (f64::MAX, f64::MAX);
    for i in 0..60 {
        let t = Instant::now();
        std::hint::black_box(p.evaluate(i % 4, &values, 30).expect("eval"));
        new = new.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let L = factor(i % 4);
        std::hint::black_box(
            shift_invert_factored(&L, storage.M_chol.as_ref(), &storage.M, p.shift(), 30)
                .expect("evd"),
        );
        old = old.min(t.elapsed().as_secs_f64());
    }
    let (mut worst_f, mut worst_mac) = (0.0f64, 1.0f64);
    for (c, L) in factors.iter().enumerate() {
        let s = p.evaluate(c, &values, 30).expect("eval");
        let (l, Phi) = shift_invert_factored(L, storage.M_chol.as_ref(), &storage.M, p.shift(), 30)
            .expect("evd");
        for r in 0..30 {
            worst_f = worst_f.max((s.eigenvalues[r].sqrt() / l[r].sqrt() - 1.0).abs());
            let a: Vec<f64> = (0..n).map(|i| s.Phi[(i, r)]).collect();
            let b: Vec<f64> = (0..n).map(|i| Phi[(i, r)]).collect();
            worst_mac = worst_mac.min(mac(&a, &b));
        }
    }
    println!("| quantity | value |\n|---|---|");
    println!("| DOF (reduced, dense) | {n} |");
    println!(
        "| factor + lowest 30 modes: block Lanczos (this) vs full EVD (previous) | {:.2} ms vs {:.2} ms ({:.2}×) |",
        new * 1e3,
        old * 1e3,
        new / old
    );
    println!("| agreement over 4 positions × 30 modes | max |Δf/f| {worst_f:.1e}, min MAC {worst_mac:.9} |");
    for block in [1usize, 2, 4, 8] {
        let text = format!("{BENCH}\nsolver: {{block: {block}}}\n");
        let q = PreparedModel::new(&model(&text)).expect("prepared");
        let (t, _) = best(40, || q.evaluate(1, &values, 30).expect("eval"));
        println!("| block size {block}: one evaluation | {:.2} ms |", t * 1e3);
    }
    let batch: Vec<Vec<f64>> = (0..256)
        .map(|i| {
            values
                .iter()
                .map(|v| v * (0.8 + 0.4 * ((i * 37 % 101) as f64 / 100.0)))
                .collect()
        })
        .collect();
    let run = |threads: usize| {
        pool(threads).install(|| {
            best(3, || {
                batch
                    .par_iter()
                    .enumerate()
                    .map(|(i, v)| evaluation(&p, i % 4, v))
                    .collect::<Vec<f64>>()
            })
        })
    };
    let ((t1, y1), (t2, y2)) = (run(1), run(2));
    assert!(
        y1.iter().zip(&y2).all(|(a, b)| a.to_bits() == b.to_bits()),
        "bit-identical across thread counts"
    );
    println!(
        "| batch of 256 evaluations with FRFs (1000 lines), 1 / 2 threads | {:.2} / {:.2} ms per evaluation ({:.2}×), bit-identical |",
        t1 * 1e3 / 256.0,
        t2 * 1e3 / 256.0,
        t1 / t2
    );
}

fn write_f64(path: &std::path::Path, v: impl Iterator<Item = f64>) {
    let mut f = std::io::BufWriter::new(std::fs::File::create(path).expect("create"));
    for x in v {
        f.write_all(&x.to_le_bytes()).expect("write");
    }
}

fn export(dir: &str, name: &str, scale: usize, method: &str) {
    let p = PreparedModel::new(&model(&case(scale, method))).expect("prepared");
    let values: Vec<f64> = p.parameters.iter().map(|q| q.value).collect();
    let dir = std::path::Path::new(dir).join(name);
    std::fs::create_dir_all(&dir).expect("dir");
    let mats = p.sparse_matrices(1, &values).expect("matrices");
    for (m, tag) in mats.iter().zip(["M", "K", "B", "D"]) {
        let cols = (0..m.n).flat_map(|j| (m.col_ptr[j]..m.col_ptr[j + 1]).map(move |_| j as f64));
        write_f64(
            &dir.join(format!("{tag}.rows")),
            m.row_idx.iter().map(|&i| i as f64),
        );
        write_f64(&dir.join(format!("{tag}.cols")), cols);
        write_f64(&dir.join(format!("{tag}.vals")), m.values.iter().copied());
    }
    let c = &p.configurations[1];
    write_f64(
        &dir.join("S"),
        (0..c.S.nrows()).flat_map(|i| (0..c.S.ncols()).map(move |j| c.S[(i, j)])),
    );
    write_f64(
        &dir.join("E"),
        (0..c.E.nrows()).flat_map(|i| (0..c.E.ncols()).map(move |j| c.E[(i, j)])),
    );
    let sol = p.evaluate(1, &values, 30).expect("evaluation");
    write_f64(&dir.join("eigenvalues"), sol.eigenvalues.iter().copied());
    let meta = format!(
        "{{\"n\": {}, \"sensors\": {}, \"excitations\": {}, \"sigma\": {}}}",
        p.n_dofs(),
        c.S.nrows(),
        c.E.nrows(),
        p.shift()
    );
    std::fs::write(dir.join("meta.json"), meta).expect("meta");
}

fn time(name: &str, scale: usize, method: &str, reps: usize) {
    let t = Instant::now();
    let p = PreparedModel::new(&model(&case(scale, method))).expect("prepared");
    let prepare = t.elapsed().as_secs_f64();
    let values: Vec<f64> = p.parameters.iter().map(|q| q.value).collect();
    let (t, _) = best(reps, || evaluation(&p, 1, &values));
    let (nnz_k, nnz_l) = p.storage.nnz();
    println!(
        "{{\"name\": \"{name}\", \"n\": {}, \"method\": \"{:?}\", \"prepare_s\": {prepare:.4}, \"evaluation_s\": {t:.6}, \"nnz_K\": {nnz_k}, \"nnz_L\": {nnz_l}, \"peak_rss_kib\": {}}}",
        p.n_dofs(),
        p.solver_method(),
        rss_kib()
    );
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let arg = |i: usize| args.get(i).cloned().unwrap_or_default();
    let num = |i: usize| arg(i).parse::<usize>().expect("a number");
    match arg(0).as_str() {
        "export" => export(&arg(1), &arg(2), num(3), &arg(4)),
        "time" => time(&arg(1), num(2), &arg(3), num(4)),
        "model" => print!(
            "{}",
            scaled_bench(&[("bed", num(1)), ("column", num(2))], "auto")
        ),
        _ => {
            test_bench();
            let _ = SolverMethod::Auto;
        }
    }
}
