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
//! * Full re-orthogonalization (two classical Gram–Schmidt passes, "twice
//!   is enough") keeps the basis M-orthonormal; the basis and its M-image
//!   are stored, so a coefficient costs one dot product and no mass product.
//! * Thick restart keeps the best Ritz vectors and the residual coupling of
//!   the pending block as an arrow in the projected matrix.
//!
//! Everything is sequential and in a fixed operation order (deterministic
//! start block), so results are bit-identical for any thread count. The
//! workspace ([`KrylovWorkspace`]) is reused across calls: no allocation of
//! basis-sized storage once it has grown to the problem.
#![allow(non_snake_case)]

use faer::linalg::matmul::matmul;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::{Accum, Mat, MatMut, MatRef, Par};

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
    /// Basis size before a restart; default max(2·nev, nev + 2p).
    pub basis: Option<usize>,
    /// Converged when ‖op y − θ y‖_M ≤ tolerance · max(θ, 8 ε θ_max) for
    /// every wanted Ritz pair (θ, y): a backward error of about `tolerance`
    /// for K φ = λ M φ.
    pub tolerance: f64,
    /// Restarts before giving up.
    pub max_restarts: usize,
}

impl Default for LanczosOptions {
    fn default() -> Self {
        LanczosOptions {
            block: 4,
            basis: None,
            tolerance: 1e-14,
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

fn ensure(A: &mut Mat<f64>, rows: usize, cols: usize) {
    if A.nrows() != rows || A.ncols() < cols {
        *A = Mat::zeros(rows, cols);
    }
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

fn dot(a: MatRef<'_, f64>, b: MatRef<'_, f64>, ca: usize, cb: usize) -> f64 {
    let (x, y) = (a.col(ca), b.col(cb));
    (0..x.nrows()).map(|i| x[i] * y[i]).sum()
}

/// Remove the components along V[:, 0..b] from V[:, b..b+p] (M-inner
/// product, two passes); returns the summed coefficients (b × p).
fn project_out(V: &mut Mat<f64>, MV: &Mat<f64>, b: usize, p: usize) -> Mat<f64> {
    let mut C = Mat::<f64>::zeros(b, p);
    if b == 0 {
        return C;
    }
    for _ in 0..2 {
        let (basis, mut rest) = V.as_mut().split_at_col_mut(b);
        let mut W = rest.rb_mut().subcols_mut(0, p);
        let mut Cp = Mat::<f64>::zeros(b, p);
        matmul(
            Cp.as_mut(),
            Accum::Replace,
            MV.subcols(0, b).transpose(),
            W.rb(),
            1.0,
            Par::Seq,
        );
        matmul(
            W.rb_mut(),
            Accum::Add,
            basis.rb(),
            Cp.as_ref(),
            -1.0,
            Par::Seq,
        );
        C += &Cp;
    }
    C
}

/// M-orthonormalize the block V[:, b..b+p] (whose M-image MV[:, b..b+p] is
/// current and which is already M-orthogonal to V[:, 0..b]) by modified
/// Gram–Schmidt, twice. A column that collapses below `1e-12 · before[j]`
/// (the Krylov space is invariant in that direction) is replaced by a fresh
/// start vector orthogonalized against everything; its coupling is zero.
/// Returns R (p × p upper) with W_in = W_out R, or `None` if the space is
/// exhausted.
fn orthonormalize_block<O: ShiftInvertOperator + ?Sized>(
    op: &O,
    V: &mut Mat<f64>,
    MV: &mut Mat<f64>,
    b: usize,
    p: usize,
    before: &[f64],
    fresh_seed: usize,
) -> Option<Mat<f64>> {
    let mut R = Mat::<f64>::zeros(p, p);
    for j in 0..p {
        let c = b + j;
        let mut replaced = false;
        for attempt in 0..3 {
            for _ in 0..2 {
                for i in b..c {
                    let r = dot(MV.as_ref(), V.as_ref(), i, c);
                    if !replaced {
                        R[(i - b, j)] += r;
                    }
                    for row in 0..V.nrows() {
                        V[(row, c)] -= r * V[(row, i)];
                        MV[(row, c)] -= r * MV[(row, i)];
                    }
                }
            }
            let nrm = dot(MV.as_ref(), V.as_ref(), c, c).max(0.0).sqrt();
            let scale = if replaced { 1.0 } else { before[j] };
            if nrm > 1e-12 * scale && nrm.is_finite() {
                if !replaced {
                    R[(j, j)] = nrm;
                }
                for row in 0..V.nrows() {
                    V[(row, c)] /= nrm;
                    MV[(row, c)] /= nrm;
                }
                break;
            }
            if attempt == 2 || c >= V.nrows() {
                return None;
            }
            // Deflate: a fresh vector, orthogonal to the basis.
            replaced = true;
            for row in 0..V.nrows() {
                V[(row, c)] = start_value(row, fresh_seed + 7919 * attempt + j);
            }
            let _ = project_out(V, MV, c, 1);
            op.mass(V.as_ref().subcols(c, 1), MV.as_mut().subcols_mut(c, 1));
        }
    }
    Some(R)
}

/// The `nev` largest eigenpairs of the operator (see module docs).
pub fn largest_eigenpairs<O: ShiftInvertOperator + ?Sized>(
    op: &mut O,
    nev: usize,
    options: &LanczosOptions,
    ws: &mut KrylovWorkspace,
) -> Result<LanczosResult, LanczosError> {
    let n = op.dim();
    let p = options.block.max(1);
    let mut m = options.basis.unwrap_or((2 * nev).max(nev + 2 * p));
    if m + p > n {
        m = n.saturating_sub(p);
    }
    if nev == 0 || m < nev + p {
        return Err(LanczosError::TooSmall);
    }
    ensure(&mut ws.V, n, m + p);
    ensure(&mut ws.MV, n, m + p);
    ensure(&mut ws.tmp, n, m);
    ws.H = Mat::zeros(m + p, m + p);
    let (V, MV) = (&mut ws.V, &mut ws.MV);
    for j in 0..p {
        for i in 0..n {
            V[(i, j)] = start_value(i, j);
        }
    }
    op.mass(V.as_ref().subcols(0, p), MV.as_mut().subcols_mut(0, p));
    let ones = vec![1.0; p];
    orthonormalize_block(&*op, V, MV, 0, p, &ones, 1000).ok_or(LanczosError::TooSmall)?;
    let mut k = 0;
    let mut applications = 0;
    let mut restarts = 0;
    loop {
        while k + p <= m {
            let (b0, b1) = (k, k + p);
            let (_, mut right) = V.as_mut().split_at_col_mut(b1);
            right
                .rb_mut()
                .subcols_mut(0, p)
                .copy_from(MV.subcols(b0, p));
            op.solve(right.subcols_mut(0, p));
            applications += p;
            let C = project_out(V, MV, b1, p);
            let H = &mut ws.H;
            for j in 0..p {
                for i in 0..p {
                    H[(b0 + i, b0 + j)] = 0.5 * (C[(b0 + i, j)] + C[(b0 + j, i)]);
                }
            }
            op.mass(V.as_ref().subcols(b1, p), MV.as_mut().subcols_mut(b1, p));
            // Norm of each new column before projection (Pythagoras).
            let before: Vec<f64> = (0..p)
                .map(|j| {
                    let after = dot(MV.as_ref(), V.as_ref(), b1 + j, b1 + j).max(0.0);
                    ((0..b1).map(|i| C[(i, j)] * C[(i, j)]).sum::<f64>() + after).sqrt()
                })
                .collect();
            let R = orthonormalize_block(&*op, V, MV, b1, p, &before, 31 * (b1 + restarts))
                .ok_or(LanczosError::TooSmall)?;
            for j in 0..p {
                for i in 0..p {
                    H[(b1 + i, b0 + j)] = R[(i, j)];
                    H[(b0 + j, b1 + i)] = R[(i, j)];
                }
            }
            k = b1;
        }
        // Rayleigh–Ritz on the lower triangle of H[0..k, 0..k].
        let Hk = Mat::from_fn(
            k,
            k,
            |i, j| {
                if i >= j {
                    ws.H[(i, j)]
                } else {
                    ws.H[(j, i)]
                }
            },
        );
        let (theta, Y) =
            super::eigen::symmetric_eigen(&Hk).map_err(|_| LanczosError::NotConverged {
                restarts,
                residual: f64::NAN,
            })?;
        // Descending order.
        let order: Vec<usize> = (0..k).rev().collect();
        let theta_max = theta[k - 1].abs().max(f64::MIN_POSITIVE);
        let coupling = Mat::from_fn(p, k, |i, j| ws.H[(k + i, j)]);
        let residual = |r: usize| -> f64 {
            let y = Y.col(order[r]);
            (0..p)
                .map(|i| {
                    let s: f64 = (0..k).map(|j| coupling[(i, j)] * y[j]).sum();
                    s * s
                })
                .sum::<f64>()
                .sqrt()
        };
        // Per mode relative to its own θ, down to the rounding floor of the
        // operator (a few ε θ_max).
        let worst = (0..nev)
            .map(|r| {
                let floor = 8.0 * f64::EPSILON * theta_max;
                residual(r) / (theta[order[r]].abs().max(floor))
            })
            .fold(0.0f64, f64::max);
        if worst <= options.tolerance {
            let Ysel = Mat::from_fn(k, nev, |i, r| Y[(i, order[r])]);
            let mut X = Mat::<f64>::zeros(n, nev);
            matmul(
                X.as_mut(),
                Accum::Replace,
                V.subcols(0, k),
                Ysel.as_ref(),
                1.0,
                Par::Seq,
            );
            return Ok(LanczosResult {
                mu: (0..nev).map(|r| theta[order[r]]).collect(),
                X,
                restarts,
                applications,
            });
        }
        if restarts >= options.max_restarts || !worst.is_finite() {
            return Err(LanczosError::NotConverged {
                restarts,
                residual: worst,
            });
        }
        // Thick restart: keep the kk best Ritz vectors and the pending block.
        let kk = (nev + (k - nev) / 2).min(m - p).max(nev);
        let Ykeep = Mat::from_fn(k, kk, |i, r| Y[(i, order[r])]);
        for A in [&mut *V, &mut *MV] {
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
            H[(r, r)] = theta[order[r]];
            for i in 0..p {
                H[(kk + i, r)] = arrow[(i, r)];
                H[(r, kk + i)] = arrow[(i, r)];
            }
        }
        k = kk;
        restarts += 1;
    }
}
