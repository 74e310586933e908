//! The lowest modes of K φ = λ M φ (eq. 2.30) from a factorization of
//! K_σ = K + σM: the operator K_σ⁻¹ M for [`lanczos`] on a dense Cholesky
//! factor (reduced models) or a sparse one (unreduced FE models), the
//! mapping λ = 1/μ − σ, and the per-thread scratch that evaluations reuse.
//!
//! The Lanczos vectors are M-orthonormal, so the eigenvectors come out
//! mass-normalized (Φᵀ M Φ = I, eq. 2.35) without rescaling.
#![allow(non_snake_case)]

use super::lanczos::{
    largest_eigenpairs, largest_eigenpairs_locked, KrylovWorkspace, LanczosError, LanczosOptions,
    ShiftInvertOperator,
};
use super::sparse::{Csc, FactorWorkspace, SparseCholesky};
use faer::linalg::matmul::matmul;
use faer::linalg::triangular_solve::{
    solve_lower_triangular_in_place, solve_upper_triangular_in_place,
};
use faer::reborrow::ReborrowMut;
use faer::{Accum, Mat, MatMut, MatRef, Par};
use std::sync::Mutex;

/// K_σ⁻¹ M with a dense Cholesky factor L (lower triangle) of K_σ.
pub struct DenseShiftInvert<'a> {
    pub L: &'a Mat<f64>,
    pub M: &'a Mat<f64>,
}

impl ShiftInvertOperator for DenseShiftInvert<'_> {
    fn dim(&self) -> usize {
        self.M.nrows()
    }
    fn mass(&self, X: MatRef<'_, f64>, Y: MatMut<'_, f64>) {
        matmul(Y, Accum::Replace, self.M.as_ref(), X, 1.0, Par::Seq);
    }
    fn solve(&mut self, mut X: MatMut<'_, f64>) {
        solve_lower_triangular_in_place(self.L.as_ref(), X.rb_mut(), Par::Seq);
        solve_upper_triangular_in_place(self.L.transpose(), X, Par::Seq);
    }
}

/// K_σ⁻¹ M with a sparse Cholesky factor held in a [`FactorWorkspace`].
pub struct SparseShiftInvert<'a> {
    pub chol: &'a SparseCholesky,
    pub factor: &'a mut FactorWorkspace,
    pub M: &'a Csc,
}

impl ShiftInvertOperator for SparseShiftInvert<'_> {
    fn dim(&self) -> usize {
        self.M.n
    }
    fn mass(&self, X: MatRef<'_, f64>, Y: MatMut<'_, f64>) {
        self.M.mul(X, Y);
    }
    fn solve(&mut self, X: MatMut<'_, f64>) {
        self.chol.solve(X, self.factor);
    }
}

/// Lowest `nev` modes (λ ascending, Φ mass-normalized) by shift-invert
/// Lanczos; rigid-body eigenvalues clamped to 0
/// ([`super::eigen::clamp_rigid_body`]).
pub fn lowest_modes<O: ShiftInvertOperator + ?Sized>(
    op: &mut O,
    sigma: f64,
    nev: usize,
    options: &LanczosOptions,
    ws: &mut KrylovWorkspace,
) -> Result<(Vec<f64>, Mat<f64>), LanczosError> {
    // More than ~40 modes: chunks with the converged pairs locked
    // (`lanczos/locking.rs`); up to 40 one run, as before.
    let r = if nev > 40 {
        largest_eigenpairs_locked(op, nev, options, ws)?
    } else {
        largest_eigenpairs(op, nev, options, ws)?
    };
    // μ = 1/(λ + σ) > 0 for every finite λ; μ at the rounding level of the
    // largest is an infinite λ of a massless direction, a negative one an
    // indefinite M.
    let top = r.mu.first().copied().unwrap_or(0.0);
    let positive =
        r.mu.iter()
            .take_while(|&&m| m > 1e3 * f64::EPSILON * top)
            .count();
    if positive < nev {
        return Err(LanczosError::NonPositive {
            wanted: nev,
            positive,
        });
    }
    let mut lambda: Vec<f64> =
        r.mu.iter()
            .map(|&m| 1.0 / m.max(f64::MIN_POSITIVE) - sigma)
            .collect();
    super::eigen::clamp_rigid_body(&mut lambda, sigma);
    Ok((lambda, r.X))
}

/// Scratch of one evaluation, reused by the next on the same thread: the
/// dense K_σ and its factor, or the sparse K_σ values and factor, and the
/// Krylov basis.
#[derive(Debug)]
pub struct Workspace {
    pub krylov: KrylovWorkspace,
    /// Dense K_σ, factored in place.
    pub dense: Mat<f64>,
    /// Sparse K_σ values on the model's pattern.
    pub values: Vec<f64>,
    pub factor: FactorWorkspace,
}

impl Default for Workspace {
    fn default() -> Self {
        Workspace {
            krylov: KrylovWorkspace::default(),
            dense: Mat::zeros(0, 0),
            values: Vec::new(),
            factor: FactorWorkspace::default(),
        }
    }
}

impl Workspace {
    /// Bytes held.
    pub fn bytes(&self) -> usize {
        self.krylov.bytes()
            + 8 * self.dense.nrows() * self.dense.ncols()
            + 8 * self.values.len()
            + self.factor.bytes()
    }
}

/// Workspaces of a prepared model: an evaluation takes one (or a fresh
/// one), uses it and puts it back, so a batch on t threads allocates t
/// workspaces once. Results never depend on which one is used: every
/// buffer is overwritten before it is read. Cloning a model gives the clone
/// an empty pool.
#[derive(Default)]
pub struct WorkspacePool(Mutex<Vec<Workspace>>);

impl WorkspacePool {
    pub fn take(&self) -> Workspace {
        self.0
            .lock()
            .ok()
            .and_then(|mut v| v.pop())
            .unwrap_or_default()
    }

    pub fn put(&self, ws: Workspace) {
        if let Ok(mut v) = self.0.lock() {
            v.push(ws);
        }
    }

    /// Bytes held by the pooled workspaces.
    pub fn bytes(&self) -> usize {
        self.0
            .lock()
            .map(|v| v.iter().map(Workspace::bytes).sum())
            .unwrap_or(0)
    }
}

impl Clone for WorkspacePool {
    fn clone(&self) -> Self {
        WorkspacePool::default()
    }
}

impl std::fmt::Debug for WorkspacePool {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "WorkspacePool({} bytes)", self.bytes())
    }
}
