//! Sobol sensitivity analysis: cost of the analysis (estimators + bootstrap)
//! and of parallel model evaluation, as ratios measured in the same run, plus
//! the convergence of the Ishigami indices towards the analytic values.
//!
//! `cargo bench --bench sobol`

mod timing;

use timing::{best, pool};

use modalflow::sensitivity::sobol::{self, AnalyzeParams, Problem, SobolParams};
use modalflow::simulator::{evaluate_all, EvalError, Ishigami, Model, Parameter, Scale, SobolG};

/// A moderately expensive model (~20 µs per point): a damped oscillator chain
/// integrated with 2000 explicit steps; outputs the final displacement.
struct Oscillator(Vec<Parameter>, Vec<String>);

impl Model for Oscillator {
    fn parameters(&self) -> &[Parameter] {
        &self.0
    }
    fn outputs(&self) -> &[String] {
        &self.1
    }
    fn evaluate(&self, x: &[f64]) -> Result<Vec<f64>, EvalError> {
        let (k, c) = (x[0], x[1]);
        let (mut u, mut v) = (1.0f64, 0.0f64);
        let dt = 1e-3;
        for _ in 0..2000 {
            let a = -k * u - c * v;
            v += dt * a;
            u += dt * v;
        }
        Ok(vec![u])
    }
}

fn main() {
    println!("Sobol analysis (d = 20, Sobol-G outputs)");
    println!("{:<44} {:>10} {:>10}", "", "ms", "ratio");
    let a: Vec<f64> = (0..20)
        .map(|i| [0.0, 0.5, 1.0, 3.0, 9.0][i % 5] * (1 + i / 5) as f64)
        .collect();
    let g = SobolG::new(a).expect("coefficients");
    let problem = Problem::new(g.parameters().to_vec());
    let (t_sample, samples) = best(3, || {
        sobol::sample(&problem, 4096, false, 1).expect("sample")
    });
    let ys = evaluate_all(&g, &samples.points, 4096, &|_| {}).expect("evaluate");
    let y: Vec<f64> = ys.iter().map(|v| v[0]).collect();
    let point = AnalyzeParams {
        bootstrap: 0,
        ..AnalyzeParams::default()
    };
    let boot = AnalyzeParams {
        bootstrap: 100,
        ..AnalyzeParams::default()
    };
    let (t_point, _) = best(5, || {
        sobol::analyze(&samples.layout, &y, &point).expect("analyze")
    });
    let (t_boot1, r1) = pool(1).install(|| {
        best(3, || {
            sobol::analyze(&samples.layout, &y, &boot).expect("analyze")
        })
    });
    let (t_boot2, r2) = pool(2).install(|| {
        best(3, || {
            sobol::analyze(&samples.layout, &y, &boot).expect("analyze")
        })
    });
    assert_eq!(r1, r2, "bootstrap must not depend on the thread count");
    let row = |name: &str, t: f64, r: f64| println!("{name:<44} {:>10.2} {:>10.2}", t * 1e3, r);
    row("sample N=4096 (90112 points)", t_sample, t_sample / t_point);
    row("analyze, point estimates only (reference)", t_point, 1.0);
    row(
        "analyze + 100 bootstrap, 1 thread",
        t_boot1,
        t_boot1 / t_point,
    );
    row(
        "analyze + 100 bootstrap, 2 threads",
        t_boot2,
        t_boot2 / t_point,
    );
    println!(
        "throughput: {:.0} index sets (S1+ST, 20 params, 100 resamples) per second on 2 threads; 2-thread speed-up {:.2}x",
        1.0 / t_boot2,
        t_boot1 / t_boot2
    );

    println!();
    println!("Batch evaluation scaling (oscillator, 2000 steps per point)");
    let osc = Oscillator(
        vec![
            Parameter::new("k", 10.0, 1000.0, Scale::Log).expect("k"),
            Parameter::new("c", 0.1, 2.0, Scale::Linear).expect("c"),
        ],
        vec!["u".into()],
    );
    let pts = sobol::sample(&Problem::new(osc.parameters().to_vec()), 4096, false, 2)
        .expect("sample")
        .points;
    let (t1, y1) = pool(1).install(|| best(3, || osc.evaluate_batch(&pts)));
    let (t2, y2) = pool(2).install(|| best(3, || osc.evaluate_batch(&pts)));
    let same = y1.iter().zip(&y2).all(|(a, b)| match (a, b) {
        (Ok(a), Ok(b)) => a[0].to_bits() == b[0].to_bits(),
        _ => false,
    });
    assert!(same, "batch results must not depend on the thread count");
    println!("{:<44} {:>10} {:>10}", "", "ms", "speed-up");
    println!(
        "{:<44} {:>10.2} {:>10.2}",
        format!("{} points, 1 thread (reference)", pts.len()),
        t1 * 1e3,
        1.0
    );
    println!(
        "{:<44} {:>10.2} {:>10.2}",
        format!("{} points, 2 threads", pts.len()),
        t2 * 1e3,
        t1 / t2
    );
    println!(
        "per point: {:.1} µs on 1 thread",
        t1 / pts.len() as f64 * 1e6
    );

    println!();
    println!("Ishigami convergence (max |error| vs analytic S1/ST, 3 seeds)");
    println!(
        "{:>8} {:>12} {:>12} {:>12}",
        "N", "S1 error", "ST error", "mean ST_conf"
    );
    let m = Ishigami::new();
    let exact = m.analytic_indices();
    for n in [1024, 4096, 16384, 65536] {
        let (mut e1, mut et, mut conf) = (0.0f64, 0.0f64, 0.0);
        for seed in 0..3 {
            let p = SobolParams {
                n,
                seed,
                bootstrap: 100,
                ..SobolParams::default()
            };
            let r = sobol::run(&m, &p, &|_| {}).expect("run");
            let idx = &r.outputs[0].1;
            for i in 0..3 {
                e1 = e1.max((idx.S1[i] - exact.S1[i]).abs());
                et = et.max((idx.ST[i] - exact.ST[i]).abs());
                conf += idx.ST_conf[i] / 9.0;
            }
        }
        println!("{n:>8} {e1:>12.5} {et:>12.5} {conf:>12.5}");
        let tol = if n >= 16384 { 1e-2 } else { 5e-2 };
        assert!(
            e1 < tol && et < tol,
            "N = {n}: errors {e1} {et} above {tol}"
        );
    }
}
