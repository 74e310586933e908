//! GSA on the uniaxial test bench (issue acceptance): model evaluations per
//! second with 1 and 2 threads (the 1-thread run is the reference, measured
//! in the same process on the same points), with modal outputs only and with
//! FRAC/CSF per frequency band; and the time of the Sobol estimators
//! (S1 + ST, bootstrap) on 10⁶ model evaluations.
//!
//! `cargo bench --bench gsa`

mod timing;

use timing::{best, pool};

use modalflow::dynamics::{directory_resolver, Model as Dynamics};
use modalflow::sensitivity::sobol::{self, AnalyzeParams, Layout, Problem};
use modalflow::simulator::{BandOptions, FrfBands, Model, StructuralModel, StructuralOptions};
use std::path::Path;

fn test_bench() -> Dynamics {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("pipelines/models/uniaxial_test_bench.yaml");
    let text = std::fs::read_to_string(&path).expect("model file");
    let dir = path.parent().expect("dir").to_path_buf();
    let resolver = directory_resolver(&dir);
    Dynamics::from_yaml(&text, "uniaxial_test_bench.yaml", &resolver).expect("model")
}

fn throughput(name: &str, model: &dyn Model, points: &[Vec<f64>]) {
    let (t1, y1) = pool(1).install(|| best(2, || model.evaluate_batch(points)));
    let (t2, y2) = pool(2).install(|| best(2, || model.evaluate_batch(points)));
    let same = y1.iter().zip(&y2).all(|(a, b)| match (a, b) {
        (Ok(a), Ok(b)) => a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits()),
        _ => false,
    });
    assert!(same, "batch results must not depend on the thread count");
    let n = points.len() as f64;
    println!(
        "{name:<40} {:>6} {:>10.0} {:>10.0} {:>8.2}",
        model.outputs().len(),
        n / t1,
        n / t2,
        t1 / t2
    );
}

fn main() {
    let dynamics = test_bench();
    let options = StructuralOptions {
        window: 1.0,
        modes: 8,
    };
    let modal = StructuralModel::new(&dynamics, None, options).expect("structural model");
    let bands = FrfBands::from_model(
        modal.prepared(),
        &dynamics.true_values(),
        &modal.reference_configs(),
        modal.modes(),
        &BandOptions {
            bands: (0..10)
                .map(|i| (10.0 + 19.0 * i as f64, 29.0 + 19.0 * i as f64))
                .collect(),
            step: 0.5,
        },
    )
    .expect("bands");
    let with_bands = StructuralModel::new(&dynamics, None, options)
        .expect("structural model")
        .with_frf_bands(bands);
    let problem = Problem::new(modal.parameters().to_vec());
    let points = sobol::sample(&problem, 4, false, 1).expect("sample").points;
    println!(
        "GSA model evaluations on uniaxial_test_bench ({} parameters, {} positions, {} points)",
        problem.dimension(),
        modal.reference_configs().len(),
        points.len()
    );
    println!(
        "{:<40} {:>6} {:>10} {:>10} {:>8}",
        "", "outputs", "evals/s 1T", "evals/s 2T", "speed-up"
    );
    throughput("modes (8 per position)", &modal, &points);
    throughput("modes + FRAC/CSF in 10 bands", &with_bands, &points);

    println!();
    println!("Sobol estimators on 10^6 model evaluations (Sobol-G outputs, 1 thread)");
    println!("{:<40} {:>10}", "", "ms");
    let p = 8;
    let layout = Layout {
        n: 1_000_000 / (p + 2),
        d: p,
        second_order: false,
    };
    let y: Vec<f64> = (0..layout.len())
        .map(|i| ((i as f64 * 0.618_033_988_7).fract() - 0.5).abs() * 4.0)
        .collect();
    for bootstrap in [0, 100] {
        let params = AnalyzeParams {
            bootstrap,
            confidence: 0.95,
            seed: 1,
        };
        let (t, r) = pool(1).install(|| best(2, || sobol::analyze(&layout, &y, &params)));
        r.expect("analyze");
        println!(
            "{:<40} {:>10.1}",
            format!(
                "{} evaluations, d = {p}, bootstrap {bootstrap}",
                layout.len()
            ),
            t * 1e3
        );
    }
}
