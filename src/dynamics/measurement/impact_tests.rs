//! End-to-end tests of [`super::simulate_impact_test`] against the exact modal
//! superposition FRFs (eq. 2.45 and its sampled form) and the noise-bias
//! theory of H1/H2 (eq. 2.55–2.58).

use super::superposition::tests::three_mode_model;
use super::*;
use crate::frf::{Dof, FrfQuantity, FrfSet};
use crate::modal::ModalModel;
use num_complex::Complex64;

/// Noise-free, rectangular, fully decayed record (8 s; the slowest mode decays
/// as e^{-7.8 t}), no oversampling: the simulated test is the sampled system.
fn exact_params() -> ImpactTestParams {
    ImpactTestParams {
        block_size: 16384,
        oversampling: 1,
        averages: 1,
        force_noise: 0.0,
        response_noise: 0.0,
        force_variation: 0.0,
        force_window_s: None,
        ..Default::default()
    }
}

fn dof(n: u32) -> Dof {
    Dof::new(n, 3)
}

fn run(model: &ModalModel, params: &ImpactTestParams, seed: u64) -> FrfSet {
    simulate_impact_test(model, dof(1), &[dof(1), dof(2), dof(3)], params, seed).unwrap()
}

/// Largest relative deviation of every channel from `reference(j, f)`.
fn max_rel_error(
    set: &FrfSet,
    reference: impl Fn(usize, f64) -> Complex64,
    use_h: &dyn Fn(usize) -> Vec<Complex64>,
) -> f64 {
    let mut worst = 0.0_f64;
    for j in 0..set.channels.len() {
        for (h, &f) in use_h(j).iter().zip(&set.frequencies_hz) {
            let exact = reference(j, f);
            worst = worst.max((h - exact).norm() / exact.norm());
        }
    }
    worst
}

#[test]
fn noise_free_h1_h2_equal_sampled_frf_in_every_quantity() {
    let model = three_mode_model();
    for quantity in [
        FrfQuantity::Receptance,
        FrfQuantity::Mobility,
        FrfQuantity::Accelerance,
    ] {
        let mut params = ImpactTestParams {
            quantity,
            ..exact_params()
        };
        let fs = params.sample_rate_hz;
        let set1 = run(&model, &params, 1);
        params.estimator = Estimator::H2;
        let set2 = run(&model, &params, 1);
        assert_eq!(set1.frequencies_hz.len(), 3201); // 0..=400 Hz at 0.125 Hz
        assert_eq!(set1.frequencies_hz[8], 1.0);
        assert_eq!(set1.quantity, quantity);
        for set in [&set1, &set2] {
            let values = |j: usize| set.channels[j].values.clone();
            let err = max_rel_error(
                set,
                |j, f| frf_sampled(&model, j, 0, f, fs, quantity),
                &values,
            );
            assert!(err < 1e-9, "{quantity:?}: {err}");
            for c in &set.channels {
                assert!(c
                    .coherence
                    .as_ref()
                    .unwrap()
                    .iter()
                    .all(|g| (g - 1.0).abs() < 1e-12));
            }
        }
    }
}

#[test]
fn oversampled_test_approaches_continuous_receptance() {
    let model = three_mode_model();
    let params = ImpactTestParams {
        oversampling: 8,
        ..exact_params()
    };
    let fs_int = params.sample_rate_hz * 8.0;
    let set = run(&model, &params, 1);
    let values = |j: usize| set.channels[j].values.clone();
    // Decimation is an ideal low-pass: the result is exactly the system sampled at 8·fs.
    let sampled = max_rel_error(
        &set,
        |j, f| receptance_sampled(&model, j, 0, f, fs_int),
        &values,
    );
    assert!(sampled < 1e-9, "{sampled}");
    // Against eq. 2.45 only the aliasing of 8·fs remains (∝ 4ζ(f_r/f_int)² at peaks).
    for (mode, j) in [(62.0, 0), (151.0, 0), (287.0, 2)] {
        let i = set.frequencies_hz.iter().position(|&f| f == mode).unwrap();
        let exact = receptance(&model, j, 0, mode);
        let rel = (set.channels[j].values[i] - exact).norm() / exact.norm();
        assert!(rel < 5e-5, "mode {mode}: {rel}");
    }
}

#[test]
fn default_test_is_close_to_truth() {
    // Default parameters (4 s records, 4× oversampling, 50 ms force window,
    // 0.1 % noise, 5 hits): H1 within a few percent of eq. 2.45 at the
    // resonances with coherence near 1 there; dips at the anti-resonance.
    let model = three_mode_model();
    for quantity in [FrfQuantity::Receptance, FrfQuantity::Accelerance] {
        let set = run(
            &model,
            &ImpactTestParams {
                quantity,
                ..Default::default()
            },
            3,
        );
        assert_eq!(set.frequencies_hz.len(), 1601);
        for (mode, j, tolerance) in [(62.0, 0, 1e-2), (151.0, 0, 1e-2), (287.0, 2, 5e-2)] {
            let i = set.frequencies_hz.iter().position(|&f| f == mode).unwrap();
            let exact = convert_quantity(receptance(&model, j, 0, mode), mode, quantity);
            let rel = (set.channels[j].values[i] - exact).norm() / exact.norm();
            assert!(rel < tolerance, "{quantity:?} mode {mode}: {rel}");
            assert!(set.channels[j].coherence.as_ref().unwrap()[i] > 0.99);
        }
        let i = set.frequencies_hz.iter().position(|&f| f == 100.0).unwrap();
        assert!(set.channels[0].coherence.as_ref().unwrap()[i] < 0.995);
    }
}

#[test]
fn exponential_and_force_window_add_known_damping() {
    let model = three_mode_model();
    let params = ImpactTestParams {
        exponential_window_end: Some(1e-3),
        force_window_s: Some(0.05),
        ..exact_params()
    };
    let set = run(&model, &params, 1);
    // The window multiplies h(t) by e^{-t/τ}: the estimate is the sampled FRF of
    // the apparent modes (ζ raised by ≈ 1/(τω_r)).
    let start = params.hit_start_sample() as f64;
    let window = ExponentialWindow::from_end_value(
        1e-3,
        (params.block_size as f64 - start) / params.sample_rate_hz,
    );
    let apparent = ModalModel {
        modes: model
            .modes
            .iter()
            .map(|m| window.apparent_mode(m))
            .collect(),
        ..model.clone()
    };
    let fs = params.sample_rate_hz;
    let err = max_rel_error(
        &set,
        |j, f| receptance_sampled(&apparent, j, 0, f, fs),
        &|j| set.channels[j].values.clone(),
    );
    assert!(err < 1e-8, "{err}");
    // and differs visibly from the unwindowed truth at the first resonance.
    let i = set.frequencies_hz.iter().position(|&f| f == 62.0).unwrap();
    let truth = receptance_sampled(&model, 0, 0, 62.0, fs);
    assert!((set.channels[0].values[i] - truth).norm() / truth.norm() > 0.05);
}

/// Mean |estimate|/|exact| over the `count` lines of lowest exact |H| between
/// 70 and 140 Hz (the driving-point anti-resonance between modes 1 and 2).
fn ratio_at_antiresonance(
    model: &ModalModel,
    set: &FrfSet,
    estimate: &[Complex64],
    count: usize,
) -> f64 {
    let fs = 2048.0;
    let mut lines: Vec<(f64, f64)> = set
        .frequencies_hz
        .iter()
        .zip(estimate)
        .filter(|(&f, _)| (70.0..140.0).contains(&f))
        .map(|(&f, h)| {
            let exact = receptance_sampled(model, 0, 0, f, fs).norm();
            (exact, h.norm() / exact)
        })
        .collect();
    lines.sort_by(|a, b| a.0.total_cmp(&b.0));
    lines.iter().take(count).map(|l| l.1).sum::<f64>() / count as f64
}

#[test]
fn response_noise_biases_h2_high_not_h1() {
    let model = three_mode_model();
    let mut params = ImpactTestParams {
        response_noise: 0.0015,
        averages: 40,
        ..exact_params()
    };
    let set1 = run(&model, &params, 5);
    params.estimator = Estimator::H2;
    let set2 = run(&model, &params, 5);
    let r1 = ratio_at_antiresonance(&model, &set1, &set1.channels[0].values, 20);
    let r2 = ratio_at_antiresonance(&model, &set2, &set2.channels[0].values, 20);
    assert!((r1 - 1.0).abs() < 0.1, "H1/H = {r1}");
    assert!(r2 > 1.5, "H2/H = {r2}");
    let gamma = set1.channels[0].coherence.as_ref().unwrap();
    assert!(gamma.iter().all(|g| (0.0..=1.0).contains(g)));
    assert!(gamma.iter().fold(1.0_f64, |m, &g| m.min(g)) < 0.5);
}

#[test]
fn force_noise_biases_h1_low_not_h2() {
    let model = three_mode_model();
    let mut params = ImpactTestParams {
        force_noise: 0.01,
        averages: 40,
        ..exact_params()
    };
    let fs = params.sample_rate_hz;
    let set1 = run(&model, &params, 9);
    params.estimator = Estimator::H2;
    let set2 = run(&model, &params, 9);
    let mean_ratio = |set: &FrfSet| {
        let c = &set.channels[1];
        let sum: f64 = c
            .values
            .iter()
            .zip(&set.frequencies_hz)
            .map(|(h, &f)| h.norm() / receptance_sampled(&model, 1, 0, f, fs).norm())
            .sum();
        sum / c.values.len() as f64
    };
    // Theory: E[S_ττ] = |F|² + Nσ², so H1 ≈ H·|F|²/(|F|² + Nσ²) < H; H2 unbiased.
    let (r1, r2) = (mean_ratio(&set1), mean_ratio(&set2));
    let pulse =
        super::signals::half_sine_pulse(params.peak_force_n, params.pulse_duration_s, 1.0 / fs);
    // σ is relative to the peak of the sampled pulse (below F̂ at 4 samples per pulse).
    let sampled_peak = pulse.iter().fold(0.0_f64, |m, &p| m.max(p));
    let noise_power = params.block_size as f64 * (params.force_noise * sampled_peak).powi(2);
    let predicted = set1
        .frequencies_hz
        .iter()
        .map(|&f| {
            let spectrum: Complex64 = pulse
                .iter()
                .enumerate()
                .map(|(m, &p)| {
                    Complex64::from_polar(p, -2.0 * std::f64::consts::PI * f * m as f64 / fs)
                })
                .sum();
            spectrum.norm_sqr() / (spectrum.norm_sqr() + noise_power)
        })
        .sum::<f64>()
        / set1.frequencies_hz.len() as f64;
    assert!(predicted < 0.8, "{predicted}");
    assert!(
        (r1 / predicted - 1.0).abs() < 0.03,
        "H1/H = {r1}, theory {predicted}"
    );
    assert!((r2 - 1.0).abs() < 0.02, "H2/H = {r2}");
    assert!(set1.channels[1]
        .coherence
        .as_ref()
        .unwrap()
        .iter()
        .all(|&g| g < 1.0));
}

#[test]
fn seeded_runs_are_bitwise_reproducible() {
    let model = three_mode_model();
    let params = ImpactTestParams::default();
    let a = run(&model, &params, 42);
    assert_eq!(a, run(&model, &params, 42));
    assert_ne!(a, run(&model, &params, 43));
    // A channel's noise does not depend on which other channels are measured
    // when it keeps its index: measuring only DOF 1 reproduces channel 0.
    let single = simulate_impact_test(&model, dof(1), &[dof(1)], &params, 42).unwrap();
    assert_eq!(single.channels[0], a.channels[0]);
}

#[test]
fn invalid_inputs_name_the_field() {
    let model = three_mode_model();
    let err = |p: ImpactTestParams| {
        simulate_impact_test(&model, dof(1), &[dof(2)], &p, 0)
            .unwrap_err()
            .to_string()
    };
    let d = ImpactTestParams::default;
    assert!(err(ImpactTestParams {
        sample_rate_hz: 800.0,
        ..d()
    })
    .contains("sample_rate_hz"));
    assert!(err(ImpactTestParams { averages: 0, ..d() }).contains("averages"));
    assert!(err(ImpactTestParams {
        response_noise: -1.0,
        ..d()
    })
    .contains("response_noise"));
    assert!(err(ImpactTestParams {
        force_noise: f64::NAN,
        ..d()
    })
    .contains("force_noise"));
    assert!(err(ImpactTestParams {
        pulse_duration_s: 0.0,
        ..d()
    })
    .contains("pulse_duration_s"));
    assert!(err(ImpactTestParams {
        exponential_window_end: Some(0.0),
        ..d()
    })
    .contains("exponential_window_end"));
    assert!(err(ImpactTestParams {
        block_size: 15,
        ..d()
    })
    .contains("block_size"));
    assert!(err(ImpactTestParams {
        band_hz: Some((300.0, 200.0)),
        ..d()
    })
    .contains("band_hz"));
    let unknown = simulate_impact_test(&model, dof(9), &[dof(1)], &d(), 0).unwrap_err();
    assert!(
        matches!(
            unknown,
            MeasurementError::UnknownDof {
                role: "excitation",
                ..
            }
        ),
        "{unknown}"
    );
    let mut high = model.clone();
    high.modes[2].frequency_hz = 5000.0;
    let e = simulate_impact_test(&high, dof(1), &[dof(1)], &d(), 0).unwrap_err();
    assert!(
        matches!(e, MeasurementError::InvalidMode { mode: 2, .. }),
        "{e}"
    );
}

/// A structure with hysteretic modal damping (η 0.04 and 0.05 on two of
/// three modes, none viscous): the modal model holds each mode's pole, and
/// with the excess receptance added the noise-free test's H1 is the
/// structure's receptance α = Σ φφ/(ω_r² − ω² + jη_r ω_r²) to the
/// oversampled simulation's aliasing at every line of 20–350 Hz; from the
/// poles alone it is 2 % of the peak away.
#[test]
fn hysteretic_damping_is_measured_as_the_structure_has_it() {
    use std::f64::consts::PI;
    let mut model = three_mode_model();
    let eta: [f64; 3] = [0.04, 0.0, 0.05];
    let zeta = [0.0, 0.015, 0.0];
    let omega2: Vec<f64> = model
        .modes
        .iter()
        .map(|m| (2.0 * PI * m.frequency_hz).powi(2))
        .collect();
    // Each mode's pole: ω_p = ω_r (1 + η²)^¼, ζ_p = sin(atan(η)/2).
    for (m, &e) in model.modes.iter_mut().zip(&eta) {
        if e > 0.0 {
            m.frequency_hz *= (1.0 + e * e).powf(0.25);
            m.damping_ratio = (e.atan() / 2.0).sin();
        }
    }
    let structure = |j: usize, f: f64| -> Complex64 {
        let w = 2.0 * PI * f;
        let base = three_mode_model();
        (0..3)
            .map(|r| {
                let l = omega2[r];
                let phi = base.modes[r].shape[j].re * base.modes[r].shape[0].re;
                phi / Complex64::new(l - w * w, 2.0 * zeta[r] * w * l.sqrt() + eta[r] * l)
            })
            .sum()
    };
    let params = ImpactTestParams {
        oversampling: 8,
        ..exact_params()
    };
    let excess = HystereticExcess::new(&omega2, &zeta, &eta).unwrap();
    let responses = [dof(1), dof(2), dof(3)];
    // Largest deviation over 20–350 Hz relative to the channel's peak.
    let worst = |set: &FrfSet| -> f64 {
        let mut worst = 0.0f64;
        for (j, c) in set.channels.iter().enumerate() {
            let band = || {
                c.values
                    .iter()
                    .zip(&set.frequencies_hz)
                    .filter(|(_, f)| (20.0..=350.0).contains(*f))
            };
            let peak = band()
                .map(|(_, &f)| structure(j, f).norm())
                .fold(0.0, f64::max);
            for (h, &f) in band() {
                worst = worst.max((h - structure(j, f)).norm() / peak);
            }
        }
        worst
    };
    let with =
        simulate_impact_test_with(&model, Some(&excess), dof(1), &responses, &params, 1).unwrap();
    let poles_only = run(&model, &params, 1);
    let (w, p) = (worst(&with), worst(&poles_only));
    // 6e-6 of the peak (the aliasing of 8·fs), against 2 % from the poles.
    assert!(w < 1e-4, "with the excess: {w}");
    assert!(p > 1e-2, "poles only: {p}");
    // A mode count that does not match the modal model is refused.
    let short = HystereticExcess::new(&omega2[..2], &zeta[..2], &eta[..2]).unwrap();
    assert!(
        simulate_impact_test_with(&model, Some(&short), dof(1), &responses, &params, 1).is_err()
    );
}
