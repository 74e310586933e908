//! The shift σ of the shift-invert eigensolver, chosen from the problem.
//!
//! The solver factors K_σ = K + σM (σ > 0: the pole of the spectral
//! transformation sits at −σ, below every eigenvalue, so K_σ is definite
//! for any positive semi-definite K and M; Ericsson & Ruhe 1980). Its
//! accuracy is governed by κ(K_σ) ≈ (λ_max + σ)/(λ_min + σ): a solve with
//! the factor has a forward error of about ε κ(K_σ), concentrated in the
//! directions of the smallest eigenvalues of K_σ (Higham, *Accuracy and
//! Stability of Numerical Algorithms*, 2nd ed., 10.1). For a clamped model
//! λ_min is the first mode and σ hardly matters. For a free-free model
//! λ_min = 0 (rigid-body modes), so κ(K_σ) ≈ λ_max/σ: with a fixed
//! σ = (2π · 1 Hz)² and a solid mesh (λ_max ~ 10¹²) that is ε · 10¹⁰ ≈
//! 10⁻⁶ of error in the rigid-body directions, which leaks into the elastic
//! Ritz pairs (issue 32 measured 1.6e-6 on frequencies and split repeated
//! pairs).
//!
//! The automatic choice: one solve of the lowest modes at the nominal
//! parameter values with the default shift σ₀ = (2π · 1 Hz)²; modes with
//! λ < 10⁻⁴ σ₀ (f < 0.01 Hz) are rigid-body modes. Without any, σ₀ stays
//! (results of clamped or elastically supported models do not change). With
//! them, σ = max(σ₀, λ_e/2) for the first elastic eigenvalue λ_e: κ(K_σ)
//! drops by λ_e/(2σ₀) (10⁷ for a first mode at 1 kHz), and the rigid-body
//! modes (μ = 1/σ) stay well separated from the elastic ones
//! (μ ≤ 1/(λ_e + σ) = 2/3 · 1/σ). The choice is made once per prepared
//! model from nominal values only, so it does not depend on which
//! evaluation comes first or on the thread count.
#![allow(non_snake_case)]

use super::assembly::PreparedModel;
use super::eigen::DEFAULT_SHIFT;

/// How the shift is set: fixed by the caller or the model file's
/// `solver.shift`, or chosen on the first evaluation.
#[derive(Debug, Clone)]
pub enum Shift {
    Fixed(f64),
    Auto(std::sync::OnceLock<ShiftChoice>),
}

/// The outcome of the automatic choice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShiftChoice {
    /// σ, rad²/s².
    pub sigma: f64,
    /// Rigid-body modes found at the nominal values (0: none, or the
    /// search was inconclusive and σ₀ was kept).
    pub rigid_body_modes: usize,
}

/// σ = (2π f)² for a shift given as a frequency f in Hz.
pub fn sigma_from_hz(f: f64) -> f64 {
    (2.0 * std::f64::consts::PI * f).powi(2)
}

/// Rigid-body modes: λ < 10⁻⁴ σ₀ (f < 0.01 Hz for the default σ₀). Their
/// computed λ is of order ε κ(K_σ₀) σ₀ ≤ 10⁻⁶ σ₀ for κ ≤ 10¹⁰.
const RIGID_BODY: f64 = 1e-4;

/// Most modes searched for the first elastic one (16 free bodies).
const MAX_SEARCH: usize = 96;

impl PreparedModel {
    /// The eigensolver shift σ, rad²/s² (see the module docs of
    /// [`crate::dynamics::shift`]); chosen on first use when automatic.
    pub fn shift(&self) -> f64 {
        self.shift_choice().sigma
    }

    /// The shift and the rigid-body modes found when choosing it.
    pub fn shift_choice(&self) -> ShiftChoice {
        match &self.shift {
            Shift::Fixed(sigma) => ShiftChoice {
                sigma: *sigma,
                rigid_body_modes: 0,
            },
            Shift::Auto(cell) => *cell.get_or_init(|| self.choose_shift()),
        }
    }

    fn choose_shift(&self) -> ShiftChoice {
        let keep = ShiftChoice {
            sigma: DEFAULT_SHIFT,
            rigid_body_modes: 0,
        };
        let Ok(c) = self.config(0) else {
            return keep;
        };
        let values: Vec<f64> = self.parameters.iter().map(|p| p.value).collect();
        let mut ws = self.scratch.take();
        let factored = self.storage.factor(
            0,
            &c.stiffness,
            &values,
            DEFAULT_SHIFT,
            &mut ws,
            &self.dof_labels,
        );
        let n = self.n_dofs();
        // One free body has six rigid-body modes: eight modes hold the
        // first elastic one (more bodies: the count doubles below).
        let mut nev = 8.min(n);
        // Only λ_e/2 is needed: a relative residual of 1e-3 gives the
        // Ritz values to ~1e-6 relative (quadratic in it; Parlett 1998,
        // 11.4), so a rigid-body λ stays ~1e-6 σ₀, far below the
        // [`RIGID_BODY`] threshold of 1e-4 σ₀, and λ_e/2 is fixed to well
        // within what the shift needs; rigid-body μ = 1/σ₀ are the dominant
        // ones and converge first. (12 modes to 1e-4 before: 0.21 CPU-s of
        // a 1.6 s run at 9,963 DOF, `benchmarks/fe_many_modes.rs`.)
        let loose = super::lanczos::LanczosOptions {
            tolerance: 1e-3,
            ..self.lanczos
        };
        let mut choice = keep;
        while factored.is_ok() {
            let Ok((lambda, _)) = self.storage.lowest(nev, DEFAULT_SHIFT, &loose, &mut ws) else {
                break;
            };
            let rigid = lambda
                .iter()
                .take_while(|&&l| l < RIGID_BODY * DEFAULT_SHIFT)
                .count();
            if rigid == 0 {
                break;
            }
            if let Some(&first_elastic) = lambda.get(rigid) {
                choice = ShiftChoice {
                    sigma: DEFAULT_SHIFT.max(0.5 * first_elastic),
                    rigid_body_modes: rigid,
                };
                break;
            }
            if nev >= n || nev >= MAX_SEARCH {
                choice.rigid_body_modes = rigid;
                break;
            }
            nev = (2 * nev).min(n);
        }
        self.scratch.put(ws);
        choice
    }
}
