//! Optimization: Gaussian-process regression ([`gaussian_process`]) and
//! Bayesian optimization with expected improvement ([`bayesian`]) over a
//! bounded box.

pub mod bayesian;
pub mod gaussian_process;
