//! Modal damping from the diagonals of Φᵀ B Φ and Φᵀ D Φ, off-diagonal
//! terms neglected (seed section 2.3.1, SHAHRUZ 1990):
//! viscous ratio ζ_r = b_r / (2 ω_r) (eq. 2.46 with m_r = 1, k_r = ω_r²),
//! loss factor η_r = d_r / ω_r² (eq. 2.43 with m_r = 1).
//! With every damper rank one (b g gᵀ), b_r = Σ_i b_i (g_iᵀ φ_r)², so only
//! Gᵀ Φ is needed, never the full damping matrix.
#![allow(non_snake_case)]

use super::assembly::JointTerms;
use faer::Mat;

/// Diagonal of Φᵀ C Φ for C = Σ_i c_i g_i g_iᵀ (mass-normalized Φ).
pub fn modal_diagonal(t: &JointTerms, values: &[f64], Phi: &Mat<f64>) -> Vec<f64> {
    let m = Phi.ncols();
    if t.params.is_empty() {
        return vec![0.0; m];
    }
    let P = t.project(Phi);
    (0..m)
        .map(|r| {
            (0..P.nrows())
                .map(|i| values[t.params[i]] * P[(i, r)] * P[(i, r)])
                .sum()
        })
        .collect()
}

/// ζ_r = b_r/(2ω_r) and η_r = d_r/ω_r²; zero for rigid-body modes (ω_r = 0).
pub fn damping_ratios(eigenvalues: &[f64], b: &[f64], d: &[f64]) -> (Vec<f64>, Vec<f64>) {
    eigenvalues
        .iter()
        .zip(b.iter().zip(d))
        .map(|(&l, (&b, &d))| {
            if l > 0.0 {
                (b / (2.0 * l.sqrt()), d / l)
            } else {
                (0.0, 0.0)
            }
        })
        .unzip()
}
