//! Simulated impact (hammer) test of a modal model: N hits with seeded noise,
//! windows, FFT, averaged spectra and the H1/H2 estimate with coherence
//! (seed section 2.3.3, eq. 2.55–2.58). Signal generation is in
//! [`super::signals`], spectral processing in [`super::spectra`].
//!
//! The responses are simulated in the sensor's quantity (`params.quantity`:
//! displacement, velocity or acceleration) and the FRF is stored in it.
//! Per hit i: force τ_i = s_i·f + n_τ, response y_i = s_i·y + n_y, where
//! s_i = exp(v·ξ_i) is the hit-to-hit force variation (log-normal, log-std
//! `force_variation`), n_τ, n_y are white Gaussian noise with standard
//! deviation `force_noise`·max|f| and `response_noise`·max|y_j| (a fraction of
//! each channel's clean peak, like ADC noise relative to the range).
//! The force channel is multiplied by the force window and the exponential
//! window, the responses by the exponential window (both start at the
//! trigger). The exponential window's added damping is *not* corrected in
//! the output (see [`ExponentialWindow::corrected_damping`]).
//!
//! Random streams of `seed`: 0 force noise, 1 + j response channel j,
//! `u64::MAX` hit-to-hit variation; results do not depend on processing order.

use super::hysteretic::HystereticExcess;
use super::impact_params::{dof_index, validate_model, Estimator, ImpactTestParams};
use super::noise::GaussianStream;
use super::signals::{decimate, half_sine_pulse, modal_responses};
use super::spectra::{coherence, force_window, h1, h2, ExponentialWindow, SpectralAverages};
use super::superposition::convert_quantity;
use super::MeasurementError;
use crate::frf::{Dof, FrfChannel, FrfSet};
use crate::modal::ModalModel;
use num_complex::Complex64;
use rustfft::FftPlanner;

/// Simulates an impact test at `excitation_dof` measured at `response_dofs`
/// (see module docs) and returns the averaged FRF estimate with coherence on
/// the FFT lines k·fs/N inside `params.band_hz`.
pub fn simulate_impact_test(
    model: &ModalModel,
    excitation_dof: Dof,
    response_dofs: &[Dof],
    params: &ImpactTestParams,
    seed: u64,
) -> Result<FrfSet, MeasurementError> {
    simulate_impact_test_with(model, None, excitation_dof, response_dofs, params, seed)
}

/// [`simulate_impact_test`] of a structure whose modes carry hysteretic
/// damping `excess` beyond `model`'s poles ([`HystereticExcess`]; `None`:
/// the poles are the structure's).
pub fn simulate_impact_test_with(
    model: &ModalModel,
    excess: Option<&HystereticExcess>,
    excitation_dof: Dof,
    response_dofs: &[Dof],
    params: &ImpactTestParams,
    seed: u64,
) -> Result<FrfSet, MeasurementError> {
    params.validate()?;
    if let Some(x) = excess.filter(|x| x.len() != model.modes.len()) {
        return Err(MeasurementError::InvalidMode {
            mode: x.len().min(model.modes.len()),
            reason: format!(
                "the hysteretic damping has {} modes, the modal model {}",
                x.len(),
                model.modes.len()
            ),
        });
    }
    let (fs, r) = (params.sample_rate_hz, params.oversampling);
    validate_model(model, fs * r as f64)?;
    let k = dof_index(model, excitation_dof, "excitation")?;
    let responses: Vec<usize> = response_dofs
        .iter()
        .map(|&d| dof_index(model, d, "response"))
        .collect::<Result<_, _>>()?;
    let mut planner = FftPlanner::new();
    let mut clean = clean_signals(model, k, &responses, params, &mut planner);
    if let Some(x) = excess {
        let n = clean.force.len();
        let mut force: Vec<Complex64> = clean
            .force
            .iter()
            .map(|&f| Complex64::new(f, 0.0))
            .collect();
        planner.plan_fft_forward(n).process(&mut force);
        for (y, &j) in clean.responses.iter_mut().zip(&responses) {
            let add = excess_response(model, x, (j, k), &force, params, &mut planner);
            y.iter_mut().zip(add).for_each(|(v, a)| *v += a);
        }
    }
    let windows = windows(params, clean.start);
    let averages = average_hits(params, seed, &clean, &windows, &mut planner);
    Ok(frf_estimate(
        model,
        excitation_dof,
        response_dofs,
        params,
        &averages,
    ))
}

/// The noise-free signals of one hit at the sample rate fs.
struct CleanSignals {
    /// The force pulse.
    force: Vec<f64>,
    /// Per response channel, the response in the sensor's quantity.
    responses: Vec<Vec<f64>>,
    /// The trigger sample, where the pulse starts.
    start: usize,
}

/// The force pulse and the responses at `responses` to a hit at DOF index
/// `k`, simulated at the internal rate fs·r and decimated to fs.
fn clean_signals(
    model: &ModalModel,
    k: usize,
    responses: &[usize],
    params: &ImpactTestParams,
    planner: &mut FftPlanner<f64>,
) -> CleanSignals {
    let (fs, n, r) = (
        params.sample_rate_hz,
        params.block_size,
        params.oversampling,
    );
    // Clean signals at the internal rate, then decimated to fs (eq. 2.45 modes).
    let dt_int = 1.0 / (fs * r as f64);
    let start = params.hit_start_sample();
    let pulse = half_sine_pulse(params.peak_force_n, params.pulse_duration_s, dt_int);
    let mut force_int = vec![0.0; n * r];
    for (slot, p) in force_int[start * r..].iter_mut().zip(&pulse) {
        *slot = *p;
    }
    let modes: Vec<(f64, f64)> = model
        .modes
        .iter()
        .map(|m| (m.frequency_hz, m.damping_ratio))
        .collect();
    let q = modal_responses(&modes, &pulse, start * r, dt_int, n * r, params.quantity);
    let force = decimate(&force_int, r, planner);
    let clean: Vec<Vec<f64>> = responses
        .iter()
        .map(|&j| {
            let mut y = vec![0.0; n * r];
            for (mode, qr) in model.modes.iter().zip(&q) {
                let residue = mode.shape[j].re * mode.shape[k].re;
                for (yn, qn) in y.iter_mut().zip(qr) {
                    *yn += residue * qn;
                }
            }
            decimate(&y, r, planner)
        })
        .collect();
    CleanSignals {
        force,
        responses: clean,
        start,
    }
}

/// The response at fs to the decimated force (its DFT `spectrum`) of the
/// receptance `excess`
/// adds to `model`'s poles for DOF indices (response, reference):
/// IDFT(ΔH(f_k)·F(k)) over the block's bins (circular; module docs of
/// [`super::hysteretic`]), in the sensor's quantity.
fn excess_response(
    model: &ModalModel,
    excess: &HystereticExcess,
    (j, k): (usize, usize),
    spectrum: &[Complex64],
    params: &ImpactTestParams,
    planner: &mut FftPlanner<f64>,
) -> Vec<f64> {
    let n = spectrum.len();
    let df = params.sample_rate_hz / n as f64;
    let gain = |bin: usize| {
        let f = bin as f64 * df;
        convert_quantity(excess.receptance(model, j, k, f), f, params.quantity)
    };
    let mut out = vec![Complex64::new(0.0, 0.0); n];
    for bin in 1..n.div_ceil(2) {
        let v = gain(bin) * spectrum[bin];
        out[bin] = v;
        out[n - bin] = v.conj();
    }
    if n.is_multiple_of(2) {
        out[n / 2] = Complex64::new((gain(n / 2) * spectrum[n / 2]).re, 0.0);
    }
    planner.plan_fft_inverse(n).process(&mut out);
    out.iter().map(|z| z.re / n as f64).collect()
}

/// The weights of each sample of a block.
struct Windows {
    /// The exponential window (all ones without one): the responses'.
    exp: Vec<f64>,
    /// The force window times the exponential window: the force's.
    force: Vec<f64>,
}

/// The windows of `params`, both starting at the trigger sample `start`.
fn windows(params: &ImpactTestParams, start: usize) -> Windows {
    let (fs, n) = (params.sample_rate_hz, params.block_size);
    // Windows (both start at the trigger sample).
    let dt = 1.0 / fs;
    let exp = match params.exponential_window_end {
        Some(end) => {
            ExponentialWindow::from_end_value(end, (n - start) as f64 * dt).samples(n, start, dt)
        }
        None => vec![1.0; n],
    };
    let force_weights: Vec<f64> = match params.force_window_s {
        Some(w) => force_window(n, start + (w * fs).ceil() as usize),
        None => vec![1.0; n],
    }
    .iter()
    .zip(&exp)
    .map(|(a, b)| a * b)
    .collect();
    Windows {
        exp,
        force: force_weights,
    }
}

/// The spectra of `params.averages` hits, each scaled by its hit-to-hit
/// variation, with seeded noise added and windowed, averaged (eq. 2.55–2.58
/// take their auto- and cross-spectra).
fn average_hits(
    params: &ImpactTestParams,
    seed: u64,
    clean: &CleanSignals,
    windows: &Windows,
    planner: &mut FftPlanner<f64>,
) -> SpectralAverages {
    let n = params.block_size;
    let CleanSignals {
        force,
        responses: clean,
        ..
    } = clean;
    let (exp, force_weights) = (&windows.exp, &windows.force);
    let peak = |s: &[f64]| s.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    let sigma_force = params.force_noise * peak(force);
    let sigma_resp: Vec<f64> = clean
        .iter()
        .map(|y| params.response_noise * peak(y))
        .collect();
    let mut force_stream = GaussianStream::new(seed, 0);
    let mut resp_streams: Vec<GaussianStream> = (0..clean.len())
        .map(|j| GaussianStream::new(seed, 1 + j as u64))
        .collect();
    let mut variation = GaussianStream::new(seed, u64::MAX);

    let fft = planner.plan_fft_forward(n);
    let lines = n / 2;
    let mut averages = SpectralAverages::new(clean.len(), lines);
    let spectrum = |signal: &mut dyn Iterator<Item = f64>| {
        let mut buf: Vec<Complex64> = signal.map(|x| Complex64::new(x, 0.0)).collect();
        fft.process(&mut buf);
        buf.truncate(lines);
        buf
    };
    for _ in 0..params.averages {
        let scale = (params.force_variation * variation.standard()).exp();
        // Zero-level noise draws nothing (each channel has its own stream, so
        // skipping one cannot shift another's numbers).
        let draw = |stream: &mut GaussianStream, sigma: f64| {
            if sigma > 0.0 {
                sigma * stream.standard()
            } else {
                0.0
            }
        };
        let tau = spectrum(
            &mut force
                .iter()
                .zip(force_weights)
                .map(|(f, w)| (scale * f + draw(&mut force_stream, sigma_force)) * w),
        );
        let ys: Vec<Vec<Complex64>> = clean
            .iter()
            .zip(resp_streams.iter_mut())
            .zip(&sigma_resp)
            .map(|((y, stream), &sigma)| {
                spectrum(
                    &mut y
                        .iter()
                        .zip(exp)
                        .map(|(v, w)| (scale * v + draw(stream, sigma)) * w),
                )
            })
            .collect();
        averages.add(&tau, &ys);
    }
    averages
}

/// The FRF set of the `averages`: per response DOF the H1 or H2 estimate
/// (`params.estimator`) and the coherence on the lines inside the band.
fn frf_estimate(
    model: &ModalModel,
    excitation_dof: Dof,
    response_dofs: &[Dof],
    params: &ImpactTestParams,
    averages: &SpectralAverages,
) -> FrfSet {
    let (fs, n) = (params.sample_rate_hz, params.block_size);
    let lines = n / 2;
    let df = fs / n as f64;
    let (lo, hi) = params.band_hz.unwrap_or((0.0, f64::INFINITY));
    let kept: Vec<usize> = (0..lines)
        .filter(|&i| (lo..=hi).contains(&(i as f64 * df)))
        .collect();
    let frequencies_hz: Vec<f64> = kept.iter().map(|&i| i as f64 * df).collect();
    let channels = response_dofs
        .iter()
        .enumerate()
        .map(|(c, &dof)| {
            let (s_yy, s_yt) = (&averages.s_yy[c], &averages.s_yt[c]);
            let values = kept
                .iter()
                .map(|&i| match params.estimator {
                    Estimator::H1 => h1(s_yt[i], averages.s_tt[i]),
                    Estimator::H2 => h2(s_yy[i], s_yt[i]),
                })
                .collect();
            let gamma2 = kept
                .iter()
                .map(|&i| coherence(s_yt[i], s_yy[i], averages.s_tt[i]))
                .collect();
            FrfChannel {
                response: dof,
                reference: excitation_dof,
                values,
                coherence: Some(gamma2),
            }
        })
        .collect();
    FrfSet {
        position: model.position.clone(),
        quantity: params.quantity,
        frequencies_hz,
        channels,
    }
}
