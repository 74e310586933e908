//! Times one simulated impact test (3 modes, 3 responses, 10 averages,
//! 4096-sample blocks, 4× oversampling) against the raw cost of the FFTs it
//! cannot avoid, measured in the same run: 4 channels × 10 averages forward
//! FFTs of 4096 points.

use modalflow::dynamics::measurement::sampled::modal_impulse_response;
use modalflow::dynamics::measurement::{simulate_impact_test, GaussianStream, ImpactTestParams};
use modalflow::frf::Dof;
use modalflow::frf::FrfQuantity;
use modalflow::modal::{ModalModel, Mode};
use num_complex::Complex64;
use rustfft::FftPlanner;
use std::hint::black_box;
use std::time::Instant;

fn model() -> ModalModel {
    let s = |v: [f64; 3]| {
        v.iter()
            .map(|&x| Complex64::new(x, 0.0))
            .collect::<Vec<_>>()
    };
    ModalModel {
        dofs: (1..=3).map(|n| Dof::new(n, 3)).collect(),
        modes: vec![
            Mode {
                frequency_hz: 62.0,
                damping_ratio: 0.02,
                shape: s([0.577, 0.577, 0.577]),
            },
            Mode {
                frequency_hz: 151.0,
                damping_ratio: 0.015,
                shape: s([0.707, 0.0, -0.707]),
            },
            Mode {
                frequency_hz: 287.0,
                damping_ratio: 0.025,
                shape: s([0.408, -0.816, 0.408]),
            },
        ],
        ..Default::default()
    }
}

/// Median wall time in seconds of `reps` calls of `f`.
fn median_time(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut times: Vec<f64> = (0..reps)
        .map(|_| {
            let t = Instant::now();
            f();
            t.elapsed().as_secs_f64()
        })
        .collect();
    times.sort_by(f64::total_cmp);
    times[reps / 2]
}

fn main() {
    let model = model();
    let responses: Vec<Dof> = model.dofs.clone();
    let params = ImpactTestParams {
        block_size: 4096,
        averages: 10,
        ..Default::default()
    };
    let reps = 30;

    let sim = median_time(reps, || {
        black_box(simulate_impact_test(&model, Dof::new(1, 3), &responses, &params, 7).unwrap());
    });

    let n = params.block_size;
    let ffts = (1 + responses.len()) * params.averages;
    let mut planner = FftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(n);
    let mut buffers: Vec<Vec<Complex64>> = (0..ffts)
        .map(|i| {
            (0..n)
                .map(|k| Complex64::new(((k * 31 + i) % 17) as f64, 0.0))
                .collect()
        })
        .collect();
    let raw = median_time(reps, || {
        for b in buffers.iter_mut() {
            fft.process(b);
        }
        black_box(&buffers);
    });

    // Components the simulation cannot avoid either: one Gaussian number per
    // noisy sample, one exp·sin per internal sample and mode.
    let gauss = median_time(reps, || {
        let mut g = GaussianStream::new(7, 0);
        black_box((0..ffts * n).map(|_| g.standard()).sum::<f64>());
    });
    let internal = n * params.oversampling;
    let dt_internal = 1.0 / (params.sample_rate_hz * params.oversampling as f64);
    let kernels = median_time(reps, || {
        for m in &model.modes {
            let q = FrfQuantity::Receptance;
            black_box(modal_impulse_response(
                m.frequency_hz,
                m.damping_ratio,
                dt_internal,
                internal,
                q,
            ));
        }
    });

    println!(
        "impact-test simulation, 3 modes × 3 responses, {} averages, N = {n}, oversampling {}",
        params.averages, params.oversampling
    );
    println!("{:<40} {:>12}", "case", "median ms");
    println!("{:<40} {:>12.3}", "simulate_impact_test", sim * 1e3);
    println!(
        "{:<40} {:>12.3}",
        format!("raw FFTs ({ffts} × {n} points)"),
        raw * 1e3
    );
    println!(
        "{:<40} {:>12.3}",
        format!("Gaussian draws ({} numbers)", ffts * n),
        gauss * 1e3
    );
    println!(
        "{:<40} {:>12.3}",
        format!("modal impulse responses (3 × {internal})"),
        kernels * 1e3
    );
    println!("{:<40} {:>12.1}", "ratio simulation / raw FFT", sim / raw);
}
