//! Parameters of a simulated impact test ([`ImpactTestParams`], [`Estimator`])
//! and the validation of parameters and modal model before simulation: every
//! error names the offending field, DOF or mode and the valid range.

use super::{invalid, MeasurementError};
use crate::frf::{Dof, FrfQuantity};
use crate::modal::ModalModel;

/// Which estimator is stored as the FRF value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Estimator {
    /// H1 = S_yτ/S_ττ (eq. 2.55), robust to response noise.
    #[default]
    H1,
    /// H2 = S_yy/S_τy (eq. 2.56), robust to force noise.
    H2,
}

/// Parameters of [`super::simulate_impact_test`]. The default resolves 0–400 Hz
/// with 0.25 Hz lines (fs = 2048 Hz, 8192-sample blocks of 4 s).
#[derive(Clone, Debug, PartialEq)]
pub struct ImpactTestParams {
    /// Analyzer sample rate fs in Hz; must exceed 2·f_max of `band_hz`.
    pub sample_rate_hz: f64,
    /// Samples per block (record length N; line spacing fs/N), even, ≥ 16.
    pub block_size: usize,
    /// Internal oversampling factor R ≥ 1 of the time simulation (see
    /// [`super::signals`]); larger R reduces aliasing ∝ 1/R².
    pub oversampling: usize,
    /// Time before the hit kept in the record, s (≥ 0).
    pub pre_trigger_s: f64,
    /// Hammer pulse (half-sine) duration T, s; bandwidth ≈ 1/T.
    pub pulse_duration_s: f64,
    /// Hammer pulse peak force, N (> 0).
    pub peak_force_n: f64,
    /// Number of hits averaged, N_av ≥ 1.
    pub averages: usize,
    /// Force-channel noise standard deviation as a fraction of the peak force (≥ 0).
    pub force_noise: f64,
    /// Response-channel noise standard deviation as a fraction of each
    /// channel's clean peak (≥ 0).
    pub response_noise: f64,
    /// Log-standard deviation of the hit-to-hit force amplitude (≥ 0, < 1).
    pub force_variation: f64,
    /// Force window length after the trigger, s; `None` = no force window.
    pub force_window_s: Option<f64>,
    /// Value of the exponential window at the end of the record, in (0, 1];
    /// `None` = rectangular.
    pub exponential_window_end: Option<f64>,
    /// Frequency band [f_min, f_max] in Hz kept in the output; `None` = all
    /// lines below fs/2.
    pub band_hz: Option<(f64, f64)>,
    pub estimator: Estimator,
    /// What the response sensors measure and so the quantity of the output
    /// FRF: displacement (receptance; laser/capacitive probe), velocity
    /// (mobility; vibrometer) or acceleration (accelerance; accelerometer).
    /// Response noise is white in this quantity.
    pub quantity: FrfQuantity,
}

impl Default for ImpactTestParams {
    fn default() -> Self {
        ImpactTestParams {
            sample_rate_hz: 2048.0,
            block_size: 8192,
            oversampling: 4,
            pre_trigger_s: 0.01,
            pulse_duration_s: 1.5e-3,
            peak_force_n: 200.0,
            averages: 5,
            force_noise: 1e-3,
            response_noise: 1e-3,
            force_variation: 0.05,
            force_window_s: Some(0.05),
            exponential_window_end: None,
            band_hz: Some((0.0, 400.0)),
            estimator: Estimator::H1,
            quantity: FrfQuantity::Receptance,
        }
    }
}

fn check_positive(field: &'static str, value: f64) -> Result<(), MeasurementError> {
    if value.is_finite() && value > 0.0 {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("must be a finite number > 0, got {value}"),
        ))
    }
}

fn check_nonnegative(field: &'static str, value: f64) -> Result<(), MeasurementError> {
    if value.is_finite() && value >= 0.0 {
        Ok(())
    } else {
        Err(invalid(
            field,
            format!("must be a finite number ≥ 0, got {value}"),
        ))
    }
}

impl ImpactTestParams {
    /// The analyser sample at which the hammer pulse starts: the
    /// pre-trigger on the sample grid of `sample_rate_hz`.
    pub fn hit_start_sample(&self) -> usize {
        (self.pre_trigger_s * self.sample_rate_hz).round() as usize
    }

    /// Time from the record's start to the hit's centre, s: the pulse's
    /// first sample plus half the pulse. What `identify`'s
    /// `frf_pre_trigger_s` must be for these records (the defaults:
    /// 20/2048 + 0.0015/2 = 0.01055 s).
    pub fn hit_centre_s(&self) -> f64 {
        self.hit_start_sample() as f64 / self.sample_rate_hz + 0.5 * self.pulse_duration_s
    }

    /// Checks every field; errors name the field and the valid range.
    pub fn validate(&self) -> Result<(), MeasurementError> {
        check_positive("sample_rate_hz", self.sample_rate_hz)?;
        if self.block_size < 16 || !self.block_size.is_multiple_of(2) {
            return Err(invalid(
                "block_size",
                format!("must be even and ≥ 16, got {}", self.block_size),
            ));
        }
        if !(1..=64).contains(&self.oversampling) {
            return Err(invalid(
                "oversampling",
                format!("must be 1..=64, got {}", self.oversampling),
            ));
        }
        let record_s = self.block_size as f64 / self.sample_rate_hz;
        check_nonnegative("pre_trigger_s", self.pre_trigger_s)?;
        check_positive("pulse_duration_s", self.pulse_duration_s)?;
        if self.pre_trigger_s + self.pulse_duration_s >= record_s {
            return Err(invalid(
                "pre_trigger_s",
                format!(
                    "pre-trigger plus pulse ({} s) must fit in the record of {record_s} s",
                    self.pre_trigger_s + self.pulse_duration_s
                ),
            ));
        }
        let dt_int = 1.0 / (self.sample_rate_hz * self.oversampling as f64);
        if self.pulse_duration_s < 2.0 * dt_int {
            return Err(invalid(
                "pulse_duration_s",
                format!("{} s is shorter than two internal samples ({dt_int} s each); raise it or `oversampling`", self.pulse_duration_s),
            ));
        }
        check_positive("peak_force_n", self.peak_force_n)?;
        if self.averages == 0 {
            return Err(invalid("averages", "must be ≥ 1"));
        }
        check_nonnegative("force_noise", self.force_noise)?;
        check_nonnegative("response_noise", self.response_noise)?;
        check_nonnegative("force_variation", self.force_variation)?;
        if self.force_variation >= 1.0 {
            return Err(invalid(
                "force_variation",
                format!("must be < 1 (log-std), got {}", self.force_variation),
            ));
        }
        if let Some(w) = self.force_window_s {
            check_positive("force_window_s", w)?;
            if w < self.pulse_duration_s {
                return Err(invalid(
                    "force_window_s",
                    format!(
                        "{w} s would cut the {} s pulse; make it longer",
                        self.pulse_duration_s
                    ),
                ));
            }
        }
        if let Some(e) = self.exponential_window_end {
            if !(e.is_finite() && e > 0.0 && e <= 1.0) {
                return Err(invalid(
                    "exponential_window_end",
                    format!("must be in (0, 1], got {e}"),
                ));
            }
        }
        if let Some((lo, hi)) = self.band_hz {
            check_nonnegative("band_hz.min", lo)?;
            check_positive("band_hz.max", hi)?;
            if lo >= hi {
                return Err(invalid(
                    "band_hz",
                    format!("min {lo} Hz must be below max {hi} Hz"),
                ));
            }
            if self.sample_rate_hz <= 2.0 * hi {
                return Err(invalid(
                    "sample_rate_hz",
                    format!("{} Hz cannot resolve f_max = {hi} Hz: it must exceed 2·f_max = {} Hz (Nyquist)", self.sample_rate_hz, 2.0 * hi),
                ));
            }
        }
        Ok(())
    }
}

pub(crate) fn dof_index(
    model: &ModalModel,
    dof: Dof,
    role: &'static str,
) -> Result<usize, MeasurementError> {
    model
        .dofs
        .iter()
        .position(|&d| d == dof)
        .ok_or_else(|| MeasurementError::UnknownDof {
            dof,
            role,
            available: model
                .dofs
                .iter()
                .map(Dof::to_string)
                .collect::<Vec<_>>()
                .join(", "),
        })
}

pub(crate) fn validate_model(
    model: &ModalModel,
    internal_rate_hz: f64,
) -> Result<(), MeasurementError> {
    for (i, mode) in model.modes.iter().enumerate() {
        let reason = if !(mode.frequency_hz.is_finite() && mode.frequency_hz > 0.0) {
            format!(
                "frequency must be finite and > 0 Hz, got {}",
                mode.frequency_hz
            )
        } else if !(mode.damping_ratio.is_finite() && (0.0..1.0).contains(&mode.damping_ratio)) {
            format!(
                "damping ratio must be in [0, 1) for a time simulation, got {}",
                mode.damping_ratio
            )
        } else if mode.shape.len() != model.dofs.len() {
            format!(
                "shape has {} entries for {} DOFs",
                mode.shape.len(),
                model.dofs.len()
            )
        } else if mode.frequency_hz >= internal_rate_hz / 2.0 {
            format!(
                "{} Hz is above the internal Nyquist frequency {} Hz; raise `oversampling` or drop the mode",
                mode.frequency_hz,
                internal_rate_hz / 2.0
            )
        } else {
            continue;
        };
        return Err(MeasurementError::InvalidMode { mode: i, reason });
    }
    Ok(())
}
