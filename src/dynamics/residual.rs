//! The residual check of every computed mode, relative to the mode's own
//! scale, so that a loss of accuracy is an error and never a result.
//!
//! For a computed pair (λ, φ) of K φ = λ M φ with the residual
//! r = Kφ − λMφ (formed from K and M themselves, not from the factor the
//! eigensolver used), the check measures
//!
//! η = ‖K_σ⁻¹ r‖_M / ‖φ‖_M = ‖φ − (λ + σ) K_σ⁻¹ M φ‖_M / ‖φ‖_M,
//!
//! the residual of the shift-inverted problem relative to the pair itself.
//! An error e_j along an eigenvector φ_j enters η weighted by the relative
//! gap |λ_j − λ|/(λ_j + σ), and an error of λ as |Δλ|/(λ + σ): η bounds the
//! relative eigenvalue error (relative to σ for rigid-body modes, λ = 0),
//! and the Rayleigh quotient makes it quadratic in η (Parlett, *The
//! Symmetric Eigenvalue Problem*, 1998, 4.5 and 11.4; Ericsson & Ruhe
//! 1980). The 2-norm backward error (‖K‖ + |λ|‖M‖)‖φ‖ used before allowed
//! λ_max/λ times more and let a free-free solid's elastic modes through
//! with 10⁻⁶ frequency errors (issue 32); a plain 2-norm ‖r‖/(λ‖Mφ‖)
//! flags correct modes of models with very stiff joints, whose residual
//! lies in the high-frequency directions that K_σ⁻¹ weighs down.
//!
//! Cost: the products KΦ and MΦ, one solve of the m columns with the
//! factor already held, one more mass product. (The Rayleigh quotient
//! φᵀKφ/φᵀMφ is not substituted for λ: with joint springs 10⁴× stiffer
//! than the modes it cancels to ε λ_max/λ and was less exact than the
//! Ritz value, measured on the clamped cantilever of
//! `tests/eigensolvers.rs`.)
#![allow(non_snake_case)]

use super::assembly::{Configuration, PreparedModel};
use super::error::DynamicsError;
use super::shift_invert::Workspace;
use faer::Mat;

/// Largest accepted η, a first-order bound on |Δλ|/(λ + σ). Measured (`tests/fe_solver.rs`, `tests/eigensolvers.rs`):
/// well-conditioned solids η ~ 1e-14, the test bench (joints 10⁴× stiffer
/// than its bodies' lowest modes) up to 4e-8, the cantilever clamped by
/// 10¹² springs 1.1e-7; the free-free block with a fixed 1 Hz shift
/// 7e-3 (frequency errors 2e-5).
pub const RESIDUAL_TOLERANCE: f64 = 1e-6;

impl PreparedModel {
    /// Check η of every mode (module docs): the worst η, or an error naming
    /// the first mode above its allowance [`allowance`]. `ws` holds the
    /// factor of K_σ.
    pub fn check_residuals(
        &self,
        c: &Configuration,
        values: &[f64],
        lambda: &[f64],
        Phi: &Mat<f64>,
        ws: &mut Workspace,
    ) -> Result<f64, DynamicsError> {
        let (n, m) = (Phi.nrows(), Phi.ncols());
        let mut R = Mat::<f64>::zeros(n, m);
        let mut MP = Mat::<f64>::zeros(n, m);
        self.storage.stiffness_mul(Phi.as_ref(), R.as_mut());
        self.storage.mass_mul(Phi.as_ref(), MP.as_mut());
        // Joint springs: K_j φ = v g (gᵀφ).
        let terms = &c.stiffness;
        let P = terms.project(Phi);
        for (ci, (g, &p)) in terms.columns.iter().zip(&terms.params).enumerate() {
            for r in 0..m {
                let s = values[p] * P[(ci, r)];
                for &(i, gi) in g {
                    R[(i, r)] += s * gi;
                }
            }
        }
        for (r, &l) in lambda.iter().enumerate() {
            for i in 0..n {
                R[(i, r)] -= l * MP[(i, r)];
            }
        }
        self.storage.solve(R.as_mut(), ws);
        let mut MR = Mat::<f64>::zeros(n, m);
        self.storage.mass_mul(R.as_ref(), MR.as_mut());
        let dot = |A: &Mat<f64>, B: &Mat<f64>, r: usize| {
            (0..n).map(|i| A[(i, r)] * B[(i, r)]).sum::<f64>()
        };
        let sigma = self.shift();
        let first = lambda.iter().copied().find(|&l| l > 0.0).unwrap_or(0.0);
        // The full eigensolver (many modes of a small dense model) resolves
        // every vector only to ε μ_1 absolutely, so any mode's η may reach
        // ε λ_max/λ_e; the Lanczos path resolves each pair to its own μ.
        let full = self.solver_method() == super::model_file::SolverMethod::Dense && 3 * m > n;
        let top = lambda.last().copied().unwrap_or(0.0);
        let mut worst = 0.0f64;
        for (r, &l) in lambda.iter().enumerate() {
            let scale = dot(Phi, &MP, r).max(f64::MIN_POSITIVE);
            let eta = (dot(&R, &MR, r).max(0.0) / scale).sqrt();
            let tol = if full {
                allowance(top, first, sigma, n) * 100.0
            } else {
                allowance(l, first, sigma, n)
            };
            worst = worst.max(eta);
            if eta.is_nan() || eta > tol {
                return Err(DynamicsError::Lanczos {
                    message: format!(
                        "mode {} ({:.6} Hz) fails the residual check: ‖K_σ⁻¹(Kφ − λMφ)‖_M / ‖φ‖_M = {eta:.1e} > {tol:.1e}, so its frequency may be wrong; set `solver.shift` (Hz) just below the first elastic mode, or use `solver: {{method: dense}}` for a small model",
                        r + 1,
                        l.max(0.0).sqrt() / (2.0 * std::f64::consts::PI),
                    ),
                });
            }
        }
        Ok(worst)
    }
}

/// The largest η accepted for mode λ_r: [`RESIDUAL_TOLERANCE`], or for
/// modes far above the first elastic one λ_e the inherent accuracy of
/// shift-invert, 10⁴ ε √n (λ_r + σ)/(λ_e + σ): μ = 1/(λ + σ) is resolved
/// to about ε μ_e, and a high mode's vector contaminated by ε along the
/// first one shows η ≈ ε λ_r/λ_e (measured: 1.6e-6 for the 123rd of all
/// 216 modes of the test bench, 10 kHz against 26 Hz). Rigid-body modes
/// (λ = 0) do not set the scale: a free-free model's elastic modes are
/// held to [`RESIDUAL_TOLERANCE`] whatever the shift. For the full
/// eigensolver (more than a third of a dense model's modes) the check uses
/// 100× this at the largest computed λ: measured η = 0.55 for the 213th of
/// all 216 modes of the test bench (1 MHz, stiff-joint modes; ratio 1.5e9).
/// Such modes are resolved only in backward error.
pub fn allowance(lambda: f64, first_elastic: f64, sigma: f64, n: usize) -> f64 {
    let inherent =
        1e4 * f64::EPSILON * (n.max(1) as f64).sqrt() * (lambda + sigma) / (first_elastic + sigma);
    RESIDUAL_TOLERANCE.max(inherent)
}
