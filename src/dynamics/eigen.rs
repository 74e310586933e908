//! The generalized symmetric eigenproblem K φ = λ M φ (eq. 2.30), lowest
//! modes, by shift-invert Cholesky reduction to standard form:
//!
//! K_σ = K + σ M = L Lᵀ,  A = L⁻¹ M L⁻ᵀ,  A y = μ y,  μ = 1/(λ + σ),
//! (A is formed as X Xᵀ, X = L⁻¹ C with M = C Cᵀ precomputed),
//! φ = L⁻ᵀ y / √μ  (so Φᵀ M Φ = I, eq. 2.35, and Φᵀ K Φ = Λ, eq. 2.36).
//!
//! Why not M = L Lᵀ, A = L⁻¹ K L⁻ᵀ? Forming that A costs an absolute error
//! ε ‖L⁻¹‖² ‖K‖, which for machine-tool models (stiff joints on light
//! rotational DOFs: ‖K‖/λ₁ ~ 10¹⁰) swamps the lowest eigenvalues — exactly
//! the ones we need (Golub & Van Loan, *Matrix Computations*, 4th ed.,
//! 8.7.2). Inverted, the lowest modes are the *largest* μ, computed to
//! relative accuracy ε ‖M‖ ‖K_σ⁻¹‖ μ₁⁻¹. The shift σ > 0 keeps K_σ positive
//! definite for free-free models (rigid-body modes, λ = 0 → μ = 1/σ).
//! Everything runs with `Par::Seq` so results are bit-identical whatever the
//! caller's thread count.
#![allow(non_snake_case)]

use super::error::DynamicsError;
use faer::dyn_stack::{MemBuffer, MemStack};
use faer::linalg::cholesky::llt::factor::{
    cholesky_in_place as llt_in_place, cholesky_in_place_scratch,
};
use faer::linalg::evd::{self_adjoint_evd, self_adjoint_evd_scratch, ComputeEigenvectors};
use faer::linalg::matmul::triangular::{self as tri, BlockStructure};
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::{Accum, Mat, Par};

/// Cholesky factor L (lower, upper part zero) of a symmetric positive
/// definite matrix; `Err(pivot)` gives the first non-positive pivot.
pub fn cholesky(M: &Mat<f64>) -> Result<Mat<f64>, usize> {
    let mut L = M.clone();
    cholesky_in_place(&mut L)?;
    Ok(L)
}

/// [`cholesky`] in place (lower triangle read, upper zeroed).
pub fn cholesky_in_place(L: &mut Mat<f64>) -> Result<(), usize> {
    let n = L.nrows();
    let mut buf = MemBuffer::new(cholesky_in_place_scratch::<f64>(
        n,
        Par::Seq,
        Default::default(),
    ));
    llt_in_place(
        L.as_mut(),
        Default::default(),
        Par::Seq,
        MemStack::new(&mut buf),
        Default::default(),
    )
    .map_err(|e| match e {
        faer::linalg::cholesky::llt::factor::LltError::NonPositivePivot { index } => index,
    })?;
    for j in 0..n {
        for i in 0..j {
            L[(i, j)] = 0.0;
        }
    }
    Ok(())
}

/// Replace A by (A + Aᵀ)/2.
pub fn symmetrize(A: &mut Mat<f64>) {
    let n = A.nrows();
    for j in 0..n {
        for i in (j + 1)..n {
            let v = 0.5 * (A[(i, j)] + A[(j, i)]);
            A[(i, j)] = v;
            A[(j, i)] = v;
        }
    }
}

/// All eigenpairs of a symmetric matrix (lower triangle read), eigenvalues
/// ascending.
pub fn symmetric_eigen(A: &Mat<f64>) -> Result<(Vec<f64>, Mat<f64>), DynamicsError> {
    let n = A.nrows();
    let mut U = Mat::<f64>::zeros(n, n);
    let mut S = faer::diag::Diag::<f64>::zeros(n);
    let mut buf = MemBuffer::new(self_adjoint_evd_scratch::<f64>(
        n,
        ComputeEigenvectors::Yes,
        Par::Seq,
        Default::default(),
    ));
    self_adjoint_evd(
        A.as_ref(),
        S.as_mut(),
        Some(U.as_mut()),
        Par::Seq,
        MemStack::new(&mut buf),
        Default::default(),
    )
    .map_err(|_| DynamicsError::NoConvergence)?;
    let s = (0..n).map(|i| S[i]).collect();
    Ok((s, U))
}

/// Default shift σ = (2π · 1 Hz)² rad²/s²: below every elastic mode of a
/// machine tool, large enough to keep K + σM well away from singular.
pub const DEFAULT_SHIFT: f64 = 4.0 * std::f64::consts::PI * std::f64::consts::PI;

/// Set the round-off eigenvalues of rigid-body modes (free-free models) to
/// exactly zero: with shift-invert their error is about σ ε κ, far below
/// 10⁻⁶ σ (f < 1 mHz for the default shift), which no machine-tool mode
/// reaches; zero also keeps ζ = b/(2ω) of such modes at 0 instead of noise.
pub fn clamp_rigid_body(lambda: &mut [f64], sigma: f64) {
    for l in lambda.iter_mut() {
        if *l < 1e-6 * sigma {
            *l = 0.0;
        }
    }
}

/// φ = L⁻ᵀ y for the columns of Y.
pub fn back_transform(L: &Mat<f64>, Y: &mut Mat<f64>) {
    solve_upper_triangular_in_place(L.transpose(), Y.as_mut(), Par::Seq);
}

/// A = L⁻¹ M L⁻ᵀ = X Xᵀ with X = L⁻¹ C for M = C Cᵀ: one triangular solve
/// (X stays lower triangular) and a triangular product; lower half filled.
pub fn inverted_form(L: &Mat<f64>, C: &Mat<f64>) -> Mat<f64> {
    let n = L.nrows();
    let mut X = C.clone();
    solve_lower_triangular_in_place(L.as_ref(), X.as_mut(), Par::Seq);
    let mut A = Mat::<f64>::zeros(n, n);
    tri::matmul(
        A.as_mut(),
        BlockStructure::TriangularLower,
        Accum::Replace,
        X.as_ref(),
        BlockStructure::TriangularLower,
        X.transpose(),
        BlockStructure::TriangularUpper,
        1.0,
        Par::Seq,
    );
    A
}

/// Lowest `n_modes` eigenpairs of K φ = λ M φ given K_σ = K + σM and the
/// Cholesky factor C of M (see module docs); eigenvalues ascending, shapes
/// mass-normalized. `dof` names a DOF (row) for the error raised when K_σ
/// is not positive definite.
pub fn shift_invert(
    K_sigma: &Mat<f64>,
    C: &Mat<f64>,
    sigma: f64,
    n_modes: usize,
    dof: impl Fn(usize) -> String,
) -> Result<(Vec<f64>, Mat<f64>), DynamicsError> {
    let L = cholesky(K_sigma).map_err(|pivot| DynamicsError::StiffnessIndefinite {
        pivot,
        dof: dof(pivot),
    })?;
    shift_invert_factored(&L, Some(C), C, sigma, n_modes)
}

/// A = L⁻¹ M L⁻ᵀ for a positive semi-definite M without a Cholesky factor
/// (massless DOFs): two triangular solves, then symmetrized. Its null
/// space (μ = 0) holds the infinite eigenvalues of the massless DOFs.
pub fn inverted_form_semidefinite(L: &Mat<f64>, M: &Mat<f64>) -> Mat<f64> {
    let mut X = M.clone();
    solve_lower_triangular_in_place(L.as_ref(), X.as_mut(), Par::Seq);
    let mut A = X.transpose().to_owned();
    solve_lower_triangular_in_place(L.as_ref(), A.as_mut(), Par::Seq);
    symmetrize(&mut A);
    A
}

/// [`shift_invert`] with the Cholesky factor L of K_σ given: all
/// eigenpairs of A = L⁻¹ M L⁻ᵀ by the full symmetric eigensolver, the
/// `n_modes` largest μ kept. `C` is the Cholesky factor of M, `None` when
/// M is only semi-definite; then at most rank(M) modes are finite, and
/// asking for more is an error.
pub fn shift_invert_factored(
    L: &Mat<f64>,
    C: Option<&Mat<f64>>,
    M: &Mat<f64>,
    sigma: f64,
    n_modes: usize,
) -> Result<(Vec<f64>, Mat<f64>), DynamicsError> {
    let A = match C {
        Some(C) => inverted_form(L, C),
        None => inverted_form_semidefinite(L, M),
    };
    let (mu, U) = symmetric_eigen(&A)?;
    let n = mu.len();
    let m = n_modes.min(n);
    // μ = 1/(λ + σ) ≤ 1/σ; μ at rounding level of 1/σ is an infinite λ.
    let floor = 64.0 * f64::EPSILON * (n as f64) / sigma;
    let finite = match C {
        Some(_) => n,
        None => mu.iter().filter(|&&x| x > floor).count(),
    };
    if m > finite {
        return Err(DynamicsError::Lanczos {
            message: format!(
                "{m} modes wanted but the mass matrix has rank {finite} of {n} (massless DOFs have no finite frequency); ask for at most {finite} modes"
            ),
        });
    }
    // Largest μ first = lowest λ first.
    let mut lambda = Vec::with_capacity(m);
    let mut Y = Mat::<f64>::zeros(n, m);
    for r in 0..m {
        let src = n - 1 - r;
        let mu_r = mu[src].max(f64::MIN_POSITIVE);
        lambda.push(1.0 / mu_r - sigma);
        let scale = 1.0 / mu_r.sqrt();
        for i in 0..n {
            Y[(i, r)] = U[(i, src)] * scale;
        }
    }
    clamp_rigid_body(&mut lambda, sigma);
    back_transform(L, &mut Y);
    Ok((lambda, Y))
}

/// Lowest `n_modes` eigenpairs of K φ = λ M φ, mass-normalized (Φᵀ M Φ = I),
/// with the default shift: shift-invert block Lanczos
/// ([`super::lanczos`]) when the modes are at most a third of the DOFs,
/// else the full eigensolver. Errors name the pivot when M is not positive
/// definite, or when K is not positive semi-definite.
pub fn generalized_eigen(
    K: &Mat<f64>,
    M: &Mat<f64>,
    n_modes: usize,
) -> Result<(Vec<f64>, Mat<f64>), DynamicsError> {
    let C = cholesky(M).map_err(|pivot| DynamicsError::MassNotPositiveDefinite {
        pivot,
        dof: format!("row {pivot}"),
    })?;
    let mut L = K + M * faer::Scale(DEFAULT_SHIFT);
    cholesky_in_place(&mut L).map_err(|pivot| DynamicsError::StiffnessIndefinite {
        pivot,
        dof: format!("row {pivot}"),
    })?;
    if 3 * n_modes <= K.nrows() {
        use super::lanczos::{KrylovWorkspace, LanczosError, LanczosOptions};
        let mut op = super::shift_invert::DenseShiftInvert { L: &L, M };
        let options = LanczosOptions::default();
        let mut ws = KrylovWorkspace::default();
        match super::shift_invert::lowest_modes(&mut op, DEFAULT_SHIFT, n_modes, &options, &mut ws)
        {
            Err(LanczosError::TooSmall) => {}
            Err(_) => return Err(DynamicsError::NoConvergence),
            Ok(r) => return Ok(r),
        }
    }
    shift_invert_factored(&L, Some(&C), M, DEFAULT_SHIFT, n_modes)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Chain of n unit masses with unit springs, fixed at one end: λ_r = 4 sin²((2r−1)π/(2(2n+1))).
    #[test]
    fn spring_mass_chain_analytic() {
        for n in [1usize, 2, 5, 17, 40] {
            let mut K = Mat::<f64>::zeros(n, n);
            let M = Mat::<f64>::identity(n, n) * faer::Scale(2.5);
            let k = 1.0e4;
            for i in 0..n {
                K[(i, i)] = if i + 1 < n { 2.0 * k } else { k };
                if i + 1 < n {
                    K[(i, i + 1)] = -k;
                    K[(i + 1, i)] = -k;
                }
            }
            let (lambda, Phi) = generalized_eigen(&K, &M, n).unwrap();
            let tol = 64.0 * f64::EPSILON * (n as f64).sqrt();
            for (r, l) in lambda.iter().enumerate() {
                let s = (((2 * r + 1) as f64) * std::f64::consts::PI / (2.0 * (2 * n + 1) as f64))
                    .sin();
                let exact = 4.0 * k / 2.5 * s * s;
                assert!(
                    (l - exact).abs() <= tol * 4.0 * k / 2.5,
                    "n={n} r={r} {l} vs {exact}"
                );
            }
            check_identities(&K, &M, &lambda, &Phi);
        }
    }

    pub(crate) fn check_identities(K: &Mat<f64>, M: &Mat<f64>, lambda: &[f64], Phi: &Mat<f64>) {
        let n = K.nrows();
        let tol = 256.0 * f64::EPSILON * (n as f64).sqrt();
        let G = Phi.transpose() * M * Phi;
        for i in 0..G.nrows() {
            for j in 0..G.ncols() {
                let e = if i == j { 1.0 } else { 0.0 };
                assert!(
                    (G[(i, j)] - e).abs() < tol,
                    "PhiT M Phi [{i},{j}] = {}",
                    G[(i, j)]
                );
            }
        }
        let kn = K.norm_l2();
        let mn = M.norm_l2();
        for (r, &l) in lambda.iter().enumerate() {
            let phi = Phi.col(r);
            let res = K * phi - M * phi * faer::Scale(l);
            let scale = (kn + l.abs() * mn) * phi.norm_l2();
            assert!(
                res.norm_l2() <= tol * scale,
                "residual mode {r}: {}",
                res.norm_l2() / scale
            );
        }
    }

    #[test]
    fn non_spd_mass_is_an_error() {
        let K = Mat::<f64>::identity(3, 3);
        let mut M = Mat::<f64>::identity(3, 3);
        M[(1, 1)] = 0.0;
        assert!(matches!(
            generalized_eigen(&K, &M, 3),
            Err(DynamicsError::MassNotPositiveDefinite { pivot: 1, .. })
        ));
    }

    #[test]
    fn free_free_pair_has_zero_mode() {
        let mut K = Mat::<f64>::zeros(2, 2);
        K[(0, 0)] = 1.0e6;
        K[(1, 1)] = 1.0e6;
        K[(0, 1)] = -1.0e6;
        K[(1, 0)] = -1.0e6;
        let M = Mat::<f64>::identity(2, 2);
        let (lambda, _) = generalized_eigen(&K, &M, 2).unwrap();
        assert_eq!(lambda[0], 0.0, "{lambda:?}");
        assert!((lambda[1] - 2.0e6).abs() < 1e-9 * 2.0e6, "{lambda:?}");
    }
}
