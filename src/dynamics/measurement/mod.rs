//! Measurement simulation for the `synthesize` stage: reference FRFs with
//! realistic measurement error, so studies can test AutoEMA and identification
//! against a known truth (DESIGN.md "Measurement simulation").
//!
//! Two ways to spoil an exact FRF:
//! - [`add_relative_noise`]: complex Gaussian noise on each channel, scaled to
//!   the channel's RMS magnitude ([`noise`]).
//! - [`simulate_impact_test`]: a hammer test in the time domain (half-sine
//!   force pulse, exact modal superposition of the analytic impulse responses,
//!   noise, windows, averaging) evaluated with the H1/H2 estimators and the
//!   coherence of seed section 2.3.3, eq. 2.55–2.58 ([`impact`], [`spectra`]).
//!
//! The exact references are modal superposition, eq. 2.45 ([`receptance`]),
//! and its sampled (impulse-invariant) counterpart [`frf_sampled`] ([`sampled`]),
//! which is what the simulated test reproduces to rounding error
//! (continuous: [`superposition`]).

pub mod hysteretic;
pub mod impact;
pub mod impact_params;
pub mod noise;
pub mod sampled;
pub mod signals;
pub mod spectra;
pub mod superposition;

#[cfg(test)]
mod impact_tests;

pub use hysteretic::HystereticExcess;
pub use impact::{simulate_impact_test, simulate_impact_test_with};
pub use impact_params::{Estimator, ImpactTestParams};
pub use noise::{add_relative_noise, GaussianStream};
pub use sampled::{frf_sampled, receptance_sampled};
pub use spectra::{coherence, h1, h2, ExponentialWindow};
pub use superposition::{convert_quantity, modal_frf_set, receptance};

use crate::frf::Dof;

/// Errors of the measurement simulation. Every variant names the offending
/// parameter, DOF or mode and says how to fix it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MeasurementError {
    /// A simulation parameter is out of range or not finite; `field` is the
    /// parameter's name as written in the params struct / YAML.
    #[error("invalid measurement parameter `{field}`: {reason}")]
    InvalidParameter { field: &'static str, reason: String },
    /// A requested excitation or response DOF is not among the modal model's DOFs.
    #[error(
        "{role} DOF {dof} is not among the modal model's DOFs ({available}); \
         add it to the model's sensor/excitation list or choose one of those"
    )]
    UnknownDof {
        dof: Dof,
        role: &'static str,
        available: String,
    },
    /// A mode of the modal model cannot be simulated in the time domain.
    #[error("mode {mode} (0-based) of the modal model: {reason}")]
    InvalidMode { mode: usize, reason: String },
}

/// Shorthand for parameter errors.
pub(crate) fn invalid(field: &'static str, reason: impl Into<String>) -> MeasurementError {
    MeasurementError::InvalidParameter {
        field,
        reason: reason.into(),
    }
}
