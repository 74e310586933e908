//! Thick-restart block Lanczos for the largest eigenvalues μ of the
//! shift-inverted pencil (K + σM)⁻¹ M x = μ x, self-adjoint in the
//! M-inner product (Ericsson & Ruhe 1980, "The spectral transformation
//! Lanczos method"; thick restart after Wu & Simon 2000; blocks after
//! Grimes, Lewis & Simon 1994). The lowest modes λ = 1/μ − σ are the
//! largest, best separated μ, so a Krylov space of about twice the wanted
//! count holds them to machine precision after a few block steps.
//!
//! * Blocks of `p` vectors find eigenvalues of multiplicity up to `p`
//!   (rigid-body modes, the two equal bending modes of a symmetric beam),
//!   which a single-vector Krylov space can only find by rounding luck, and
//!   turn the solves with the factor into level-3 work.
//! * Full re-orthogonalization keeps the basis M-orthonormal: the new
//!   block's local recurrence is removed first, then one classical
//!   Gram–Schmidt pass against the whole basis, a second only when the
//!   first cancels (DGKS criterion, [`project_out`]); the block itself is
//!   orthonormalized by Cholesky QR, twice ([`cholesky_qr2`]). The basis
//!   and its M-image are stored, so a coefficient costs one dot product
//!   and a step one mass product of the new block. At n ≫ basis size a
//!   step is bound by reading the basis, so these passes are what the
//!   evaluation costs (README "One evaluation against LAPACK/ARPACK").
//! * Thick restart keeps the best Ritz vectors and the residual coupling of
//!   the pending block as an arrow in the projected matrix.
//!
//! Everything is sequential and in a fixed operation order (deterministic
//! start block), so results are bit-identical for any thread count. The
//! workspace ([`KrylovWorkspace`]) is reused across calls: no allocation of
//! basis-sized storage once it has grown to the problem.
#![allow(non_snake_case)]

mod locking;
mod orthogonalize;

pub use locking::{largest_eigenpairs_locked, CHUNK};

use faer::linalg::matmul::matmul;
use faer::reborrow::ReborrowMut;
use faer::{Accum, Mat, MatMut, MatRef, Par};
use orthogonalize::{cholesky_qr2, m_norm2, orthonormalize_block, project_out};

/// The operator of a shift-invert eigenproblem.
pub trait ShiftInvertOperator {
    /// Problem size n.
    fn dim(&self) -> usize;
    /// Y = M X.
    fn mass(&self, X: MatRef<'_, f64>, Y: MatMut<'_, f64>);
    /// X ← (K + σM)⁻¹ X.
    fn solve(&mut self, X: MatMut<'_, f64>);
}

/// Lanczos settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LanczosOptions {
    /// Block size p ≥ 1: eigenvalues of multiplicity up to p are found.
    pub block: usize,
    /// Basis size before a restart; default max(⌈2.5·nev⌉, nev + 2p). With
    /// half the surplus kept at a restart, 2.5·nev needed 96 operator
    /// applications and one restart for 30 modes at 50,430 DOF against 104
    /// and three at 2·nev, and 3·nev spent more on the longer
    /// orthogonalizations than it saved (evaluation 0.33 s vs 0.39 s and
    /// 0.41 s, same run).
    pub basis: Option<usize>,
    /// Converged when ‖op y − θ y‖_M ≤ tolerance · max(θ, 8 ε θ_max) for
    /// every wanted Ritz pair (θ, y): a backward error of about `tolerance`
    /// for K φ = λ M φ. Default 1e-12: the residual check of every mode
    /// (`solve.rs`) accepts 1000 ε √n ≥ 1e-12 for n ≥ 21, the eigenvalue
    /// error is of order tolerance² (Rayleigh quotient), so frequencies
    /// are exact to rounding; 1e-13 already cost a further restart cycle
    /// (0.43 s vs 0.33 s an evaluation at 50,430 DOF); the known-answer
    /// tests (`tests/eigensolvers.rs`) pass at 1e-14 and 1e-12.
    /// ARPACK's default (ε relative to θ on its own residual estimate) is
    /// stricter on paper but its SuperLU solves are not that accurate on
    /// these stiff models (README).
    pub tolerance: f64,
    /// Restarts before giving up.
    pub max_restarts: usize,
}

impl Default for LanczosOptions {
    fn default() -> Self {
        LanczosOptions {
            block: 4,
            basis: None,
            tolerance: 1e-12,
            max_restarts: 300,
        }
    }
}

/// Why the iteration stopped without a result.
#[derive(Debug, Clone, PartialEq)]
pub enum LanczosError {
    /// n is too small for a Krylov basis larger than the wanted count; use a
    /// dense solver.
    TooSmall,
    /// Not converged after the allowed restarts; the worst relative residual.
    NotConverged { restarts: usize, residual: f64 },
    /// Fewer than the wanted count of positive μ: the mass matrix has a
    /// rank below the mode count (massless DOFs), or is indefinite.
    NonPositive { wanted: usize, positive: usize },
}

/// The largest eigenpairs, descending μ, X M-orthonormal (n × nev).
#[derive(Debug, Clone)]
pub struct LanczosResult {
    pub mu: Vec<f64>,
    pub X: Mat<f64>,
    /// Restarts and operator applications (solves), for benchmarks.
    pub restarts: usize,
    pub applications: usize,
}

/// Reusable storage: basis, its M-image, projected matrix, restart buffer.
#[derive(Debug, Clone)]
pub struct KrylovWorkspace {
    V: Mat<f64>,
    MV: Mat<f64>,
    H: Mat<f64>,
    tmp: Mat<f64>,
}

impl Default for KrylovWorkspace {
    fn default() -> Self {
        KrylovWorkspace {
            V: Mat::zeros(0, 0),
            MV: Mat::zeros(0, 0),
            H: Mat::zeros(0, 0),
            tmp: Mat::zeros(0, 0),
        }
    }
}

impl KrylovWorkspace {
    /// Bytes held, for memory statements.
    pub fn bytes(&self) -> usize {
        8 * [&self.V, &self.MV, &self.H, &self.tmp]
            .iter()
            .map(|m| m.nrows() * m.ncols())
            .sum::<usize>()
    }
}

/// Deterministic start vectors in (−1, 1) (splitmix64 of the position).
fn start_value(i: usize, j: usize) -> f64 {
    let mut z = (i as u64)
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add((j as u64 + 1).wrapping_mul(0xD1B5_4A32_D192_ED03));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// One block Lanczos step from V[:, k..k+p]: the next block
/// V[:, k+p..k+2p] = op(V_k) orthogonalized and M-normalized, its
/// coefficients in H (diagonal block and coupling R). `lo` is where the
/// local recurrence starts ([`project_out`]).
fn block_step<O: ShiftInvertOperator + ?Sized>(
    op: &mut O,
    ws: &mut KrylovWorkspace,
    k: usize,
    p: usize,
    lo: usize,
    seed: usize,
) -> Result<(), LanczosError> {
    let (b0, b1) = (k, k + p);
    let KrylovWorkspace { V, MV, H, tmp } = ws;
    let (_, mut right) = V.as_mut().split_at_col_mut(b1);
    right
        .rb_mut()
        .subcols_mut(0, p)
        .copy_from(MV.subcols(b0, p));
    op.solve(right.subcols_mut(0, p));
    let C = project_out(&*op, V, MV, lo, b1, p);
    for j in 0..p {
        for i in 0..p {
            H[(b0 + i, b0 + j)] = 0.5 * (C[(b0 + i, j)] + C[(b0 + j, i)]);
        }
    }
    // Norm of each new column before projection (Pythagoras).
    let before: Vec<f64> = (0..p)
        .map(|j| {
            let removed = (0..b1).map(|i| C[(i, j)] * C[(i, j)]).sum::<f64>();
            (removed + m_norm2(V, MV, b1 + j)).sqrt()
        })
        .collect();
    let R = match cholesky_qr2(V, MV, tmp, b1, p, &before) {
        Some(R) => R,
        None => {
            orthonormalize_block(&*op, V, MV, b1, p, &before, seed).ok_or(LanczosError::TooSmall)?
        }
    };
    for j in 0..p {
        for i in 0..p {
            H[(b1 + i, b0 + j)] = R[(i, j)];
            H[(b0 + j, b1 + i)] = R[(i, j)];
        }
    }
    Ok(())
}

/// Ritz values θ (ascending) and vectors Y of H[0..k, 0..k], and the worst
/// residual ‖op y − θ y‖_M / max(θ, 8 ε θ_max) of the `nev` largest: per
/// mode relative to its own θ, down to the rounding floor of the operator.
fn rayleigh_ritz(
    H: &Mat<f64>,
    k: usize,
    p: usize,
    nev: usize,
) -> Option<(Vec<f64>, Mat<f64>, f64)> {
    let Hk = Mat::from_fn(k, k, |i, j| if i >= j { H[(i, j)] } else { H[(j, i)] });
    let (theta, Y) = super::eigen::symmetric_eigen(&Hk).ok()?;
    let theta_max = theta[k - 1].abs().max(f64::MIN_POSITIVE);
    let residual = |c: usize| -> f64 {
        (0..p)
            .map(|i| {
                let s: f64 = (0..k).map(|j| H[(k + i, j)] * Y[(j, c)]).sum();
                s * s
            })
            .sum::<f64>()
            .sqrt()
    };
    let worst = (k - nev..k)
        .rev()
        .map(|c| residual(c) / theta[c].abs().max(8.0 * f64::EPSILON * theta_max))
        .fold(0.0f64, f64::max);
    Some((theta, Y, worst))
}

/// Thick restart: keep the `kk` largest Ritz vectors after the `skip`
/// largest (0 at a restart; the converged count when a chunk's pairs are
/// locked and the rest carried to the next chunk, [`locking`]) and the
/// pending block V[:, k..k+p], with the residual coupling as an arrow in H.
#[allow(clippy::too_many_arguments)]
fn thick_restart(
    ws: &mut KrylovWorkspace,
    k: usize,
    p: usize,
    kk: usize,
    skip: usize,
    theta: &[f64],
    Y: &Mat<f64>,
) {
    let Ykeep = Mat::from_fn(k, kk, |i, r| Y[(i, k - 1 - skip - r)]);
    let coupling = Mat::from_fn(p, k, |i, j| ws.H[(k + i, j)]);
    for A in [&mut ws.V, &mut ws.MV] {
        let pending = A.subcols(k, p).to_owned();
        matmul(
            ws.tmp.as_mut().subcols_mut(0, kk),
            Accum::Replace,
            A.as_ref().subcols(0, k),
            Ykeep.as_ref(),
            1.0,
            Par::Seq,
        );
        A.as_mut()
            .subcols_mut(0, kk)
            .copy_from(ws.tmp.subcols(0, kk));
        A.as_mut().subcols_mut(kk, p).copy_from(&pending);
    }
    let mut arrow = Mat::<f64>::zeros(p, kk);
    matmul(
        arrow.as_mut(),
        Accum::Replace,
        coupling.as_ref(),
        Ykeep.as_ref(),
        1.0,
        Par::Seq,
    );
    let H = &mut ws.H;
    H.fill(0.0);
    for r in 0..kk {
        H[(r, r)] = theta[k - 1 - skip - r];
        for i in 0..p {
            H[(kk + i, r)] = arrow[(i, r)];
            H[(r, kk + i)] = arrow[(i, r)];
        }
    }
}

/// Basis size m for `nev` wanted pairs with blocks of `p` in dimension n:
/// [`LanczosOptions::basis`], or ⌈halves · nev / 2⌉ (5 halves for one
/// run, [`locking::CHUNK_BASIS_HALVES`] for a locked chunk); below nev + p
/// the problem is too small.
fn basis_size(options: &LanczosOptions, nev: usize, p: usize, n: usize, halves: usize) -> usize {
    let m = options
        .basis
        .unwrap_or((halves * nev).div_ceil(2).max(nev + 2 * p));
    m.min(n.saturating_sub(p))
}

/// Grow `A` to `rows` × at least `cols`, keeping its columns (a carried
/// thick-restart state lives in the leading ones).
fn grow(A: &mut Mat<f64>, rows: usize, cols: usize) {
    if A.nrows() != rows {
        *A = Mat::zeros(rows, cols);
    } else if A.ncols() < cols {
        A.resize_with(rows, cols, |_, _| 0.0);
    }
}

/// The start block V₀ = K_σ⁻¹ M R, M-orthonormal, in V[:, 0..p]; returns
/// the operator applications spent.
fn start_block<O: ShiftInvertOperator + ?Sized>(
    op: &mut O,
    ws: &mut KrylovWorkspace,
    p: usize,
) -> Result<usize, LanczosError> {
    let n = op.dim();
    for j in 0..p {
        for i in 0..n {
            ws.V[(i, j)] = start_value(i, j);
        }
    }
    // Start in the range of the operator, V₀ = K_σ⁻¹ M R: with a singular
    // M (massless DOFs) the M-inner product is definite only there, and a
    // start vector's null-space part would otherwise stay in every Ritz
    // vector (Nour-Omid, Parlett, Ericsson & Jensen 1987, "How to implement
    // the spectral transformation", Math. Comp. 48, sec. 3).
    op.mass(
        ws.V.as_ref().subcols(0, p),
        ws.MV.as_mut().subcols_mut(0, p),
    );
    ws.V.as_mut()
        .subcols_mut(0, p)
        .copy_from(ws.MV.subcols(0, p));
    op.solve(ws.V.as_mut().subcols_mut(0, p));
    op.mass(
        ws.V.as_ref().subcols(0, p),
        ws.MV.as_mut().subcols_mut(0, p),
    );
    let ones = vec![1.0; p];
    orthonormalize_block(&*op, &mut ws.V, &mut ws.MV, 0, p, &ones, 1000)
        .ok_or(LanczosError::TooSmall)?;
    Ok(p)
}

/// The `nev` largest eigenpairs of the operator (see module docs).
pub fn largest_eigenpairs<O: ShiftInvertOperator + ?Sized>(
    op: &mut O,
    nev: usize,
    options: &LanczosOptions,
    ws: &mut KrylovWorkspace,
) -> Result<LanczosResult, LanczosError> {
    let m = basis_size(options, nev, options.block.max(1), op.dim(), 5);
    run(op, nev, m, options, ws, 0, 0).map(|(r, _)| r)
}

/// [`largest_eigenpairs`] with a basis of `m` vectors, starting from the thick-restart state of
/// `start` Ritz vectors and a pending block left in `ws` by the previous
/// call (0: a fresh start block), and leaving up to `carry` of the next
/// Ritz vectors (after the `nev` returned) in `ws` as such a state for a
/// following call on the operator deflated by the returned pairs
/// ([`locking`]). Returns the count carried.
fn run<O: ShiftInvertOperator + ?Sized>(
    op: &mut O,
    nev: usize,
    m: usize,
    options: &LanczosOptions,
    ws: &mut KrylovWorkspace,
    start: usize,
    carry: usize,
) -> Result<(LanczosResult, usize), LanczosError> {
    let n = op.dim();
    let p = options.block.max(1);
    if nev == 0 || m < nev + p {
        return Err(LanczosError::TooSmall);
    }
    grow(&mut ws.V, n, m + p);
    grow(&mut ws.MV, n, m + p);
    grow(&mut ws.tmp, n, m);
    let mut H = Mat::zeros(m + p, m + p);
    if start > 0 {
        let s = start + p;
        H.as_mut()
            .submatrix_mut(0, 0, s, s)
            .copy_from(ws.H.submatrix(0, 0, s, s));
    }
    ws.H = H;
    let mut applications = if start == 0 {
        start_block(op, ws, p)?
    } else {
        0
    };
    // The first block after the start or a restart couples to all of
    // V[0..k] (a carried state is a restart).
    // The caller leaves room for a block step ([`locking`]).
    debug_assert!(
        start + p <= m,
        "carried state of {start} too large for a basis of {m}"
    );
    let (mut k, mut restarts, mut lo) = (start, 0, 0);
    loop {
        while k + p <= m {
            block_step(op, ws, k, p, lo, 31 * (k + p + restarts))?;
            applications += p;
            lo = k;
            k += p;
        }
        let (theta, Y, worst) =
            rayleigh_ritz(&ws.H, k, p, nev).ok_or(LanczosError::NotConverged {
                restarts,
                residual: f64::NAN,
            })?;
        if worst <= options.tolerance {
            // Descending μ.
            let Ysel = Mat::from_fn(k, nev, |i, r| Y[(i, k - 1 - r)]);
            let mut X = Mat::<f64>::zeros(n, nev);
            matmul(
                X.as_mut(),
                Accum::Replace,
                ws.V.subcols(0, k),
                Ysel.as_ref(),
                1.0,
                Par::Seq,
            );
            let carried = carry.min(k - nev);
            if carried > 0 {
                thick_restart(ws, k, p, carried, nev, &theta, &Y);
            }
            let mu = (0..nev).map(|r| theta[k - 1 - r]).collect();
            let r = LanczosResult {
                mu,
                X,
                restarts,
                applications,
            };
            return Ok((r, carried));
        }
        if restarts >= options.max_restarts || !worst.is_finite() {
            return Err(LanczosError::NotConverged {
                restarts,
                residual: worst,
            });
        }
        let kk = (nev + (k - nev) / 2).min(m - p).max(nev);
        thick_restart(ws, k, p, kk, 0, &theta, &Y);
        k = kk;
        lo = 0;
        restarts += 1;
    }
}
