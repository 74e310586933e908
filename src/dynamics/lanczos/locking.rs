//! Many modes by locking: the wanted eigenpairs are found in chunks of at
//! most [`CHUNK`], each by the thick-restart Lanczos of [`super`] on the
//! operator deflated by the pairs already converged (explicit deflation,
//! Saad, *Numerical Methods for Large Eigenvalue Problems*, 2nd ed., 2011,
//! 4.2.2; "locking" in ARPACK's terms). With X the locked, M-orthonormal
//! eigenvectors and P = I − X Xᵀ M, the operator P K_σ⁻¹ M has the same
//! eigenpairs as K_σ⁻¹ M on the M-orthogonal complement of X and μ = 0 on
//! X, so the next chunk's wanted μ are the largest again.
//!
//! Why: one Krylov space for 100 modes of a 10k-DOF solid stagnated at a
//! relative residual of 2.8e-9 after 300 restarts (93 CPU-s; issue 32,
//! 64 modes of a 14k-DOF solid took 51 CPU-s), while 30 modes converge in
//! a few restarts. A chunk needs a basis of a few times its own count, not
//! of the total, and its convergence test sees only the unconverged part
//! of the spectrum.
//!
//! A chunk does not start from scratch: when one converges, its Krylov
//! space already holds good approximations of the next pairs, so the Ritz
//! vectors after its wanted ones (with the pending block) are carried to
//! the next chunk as a thick-restart state (Stathopoulos, Saad & Wu 1998,
//! "Dynamic thick restarting of the Davidson and the implicitly restarted
//! Lanczos methods", SIAM J. Sci. Comput. 19; the locking of Wu & Simon
//! 2000, sec. 3). The relation op V Y_u = V Y_u Θ_u + W B holds for the
//! deflated operator too, as V Y_u and the pending block W are
//! M-orthogonal to the newly locked V Y_l. Measured at 9,963 DOF, 100
//! modes: 680 operator applications against 896 restarting every chunk
//! from the start block (Lanczos 2.7 vs 3.4 CPU-s, basis 2.5 × the chunk).
#![allow(non_snake_case)]

use super::ShiftInvertOperator;
use super::{basis_size, run, KrylovWorkspace, LanczosError, LanczosOptions, LanczosResult};
use faer::linalg::matmul::matmul;
use faer::reborrow::ReborrowMut;
use faer::{Accum, Mat, MatMut, MatRef, Par};

/// Most modes per Lanczos run; more are found by locking. 30 modes
/// converge in one or two restarts (module docs of [`super`]).
pub const CHUNK: usize = 32;

/// Basis of a chunk: 4 × its wanted count (8 halves). Measured on the
/// free-free hex8 column at 9,963 DOF (`benchmarks/fe_many_modes.rs`, 100
/// modes in 4 chunks of 25, carried Ritz vectors): 2.5 × needed 29
/// restarts and 680 operator applications (Lanczos 2.7 CPU-s), 3 × 17 and
/// 564 (2.2 s), 4 × 6 and 428 (1.6 s), 5 × 3 and 420 (2.0 s: longer
/// orthogonalizations). 6 × and chunks of 50 with 3–4 × stagnated at a
/// relative residual of 1e-9 to 2e-8 (300 restarts), as did one run for
/// all 100 modes: chunks of ~25 with a 4 × basis converged in every case
/// measured.
pub const CHUNK_BASIS_HALVES: usize = 8;

/// K_σ⁻¹ M followed by P = I − X Xᵀ M for the first `k` columns of X.
struct Deflated<'a, O: ShiftInvertOperator + ?Sized> {
    op: &'a mut O,
    X: &'a Mat<f64>,
    MX: &'a Mat<f64>,
    k: usize,
}

impl<O: ShiftInvertOperator + ?Sized> ShiftInvertOperator for Deflated<'_, O> {
    fn dim(&self) -> usize {
        self.op.dim()
    }
    fn mass(&self, X: MatRef<'_, f64>, Y: MatMut<'_, f64>) {
        self.op.mass(X, Y);
    }
    fn solve(&mut self, mut Y: MatMut<'_, f64>) {
        self.op.solve(Y.rb_mut());
        if self.k == 0 {
            return;
        }
        // Twice: classical Gram–Schmidt against the locked vectors.
        let mut C = Mat::<f64>::zeros(self.k, Y.ncols());
        for _ in 0..2 {
            matmul(
                C.as_mut(),
                Accum::Replace,
                self.MX.subcols(0, self.k).transpose(),
                Y.as_ref(),
                1.0,
                Par::Seq,
            );
            matmul(
                Y.rb_mut(),
                Accum::Add,
                self.X.subcols(0, self.k),
                C.as_ref(),
                -1.0,
                Par::Seq,
            );
        }
    }
}

/// The `nev` largest eigenpairs (descending μ), in chunks of at most
/// [`CHUNK`] with the converged ones locked (module docs).
pub fn largest_eigenpairs_locked<O: ShiftInvertOperator + ?Sized>(
    op: &mut O,
    nev: usize,
    options: &LanczosOptions,
    ws: &mut KrylovWorkspace,
) -> Result<LanczosResult, LanczosError> {
    let n = op.dim();
    let p = options.block.max(1);
    let chunks = nev.div_ceil(CHUNK).max(1);
    let size = nev.div_ceil(chunks);
    let mut X = Mat::<f64>::zeros(n, nev);
    let mut MX = Mat::<f64>::zeros(n, nev);
    let mut mu = Vec::with_capacity(nev);
    let (mut restarts, mut applications, mut start) = (0, 0, 0);
    while mu.len() < nev {
        let k = mu.len();
        let want = size.min(nev - k);
        let next = size.min(nev - k - want);
        // The next chunk starts from this one's unconverged Ritz vectors
        // (module docs): as many as a restart of it keeps, its wanted count
        // and half its surplus, leaving room for block steps.
        let carry = match next {
            0 => 0,
            _ => {
                let m = basis_size(options, next, p, n, CHUNK_BASIS_HALVES);
                (next + m.saturating_sub(next) / 2).min(m.saturating_sub(2 * p))
            }
        };
        let m = basis_size(options, want, p, n, CHUNK_BASIS_HALVES);
        let (r, carried) = {
            let mut d = Deflated {
                op: &mut *op,
                X: &X,
                MX: &MX,
                k,
            };
            run(&mut d, want, m, options, ws, start, carry)?
        };
        start = carried;
        X.as_mut().subcols_mut(k, want).copy_from(&r.X);
        op.mass(X.subcols(k, want), MX.as_mut().subcols_mut(k, want));
        mu.extend_from_slice(&r.mu);
        restarts += r.restarts;
        applications += r.applications;
    }
    // A mode a chunk missed (multiplicity above the block size) is found
    // by a later one: order by μ, descending.
    let mut order: Vec<usize> = (0..nev).collect();
    order.sort_by(|&a, &b| mu[b].total_cmp(&mu[a]));
    Ok(LanczosResult {
        mu: order.iter().map(|&i| mu[i]).collect(),
        X: Mat::from_fn(n, nev, |i, j| X[(i, order[j])]),
        restarts,
        applications,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// M = I, K = diag(λ) with every λ doubled (λ_i = 1 + ⌊i/2⌋ in a
    /// shuffled order): (K + σM)⁻¹ M = diag(1/(λ_i + σ)).
    struct Diagonal(Vec<f64>);

    impl ShiftInvertOperator for Diagonal {
        fn dim(&self) -> usize {
            self.0.len()
        }
        fn mass(&self, X: MatRef<'_, f64>, mut Y: MatMut<'_, f64>) {
            Y.copy_from(X);
        }
        fn solve(&mut self, mut X: MatMut<'_, f64>) {
            for j in 0..X.ncols() {
                for (i, l) in self.0.iter().enumerate() {
                    X[(i, j)] /= l + 1.0;
                }
            }
        }
    }

    #[test]
    fn locked_chunks_find_every_mode_once_with_repeated_pairs_across_chunk_borders() {
        let n = 600;
        let lambda: Vec<f64> = (0..n).map(|i| 1.0 + ((i * 7) % n / 2) as f64).collect();
        let mut op = Diagonal(lambda.clone());
        // Chunks of 25 (99 = 4 × 25 − 1): borders split the pairs at 24|25,
        // 49|50 and 74|75.
        let nev = 99;
        let options = LanczosOptions::default();
        let mut ws = KrylovWorkspace::default();
        let r = largest_eigenpairs_locked(&mut op, nev, &options, &mut ws).unwrap();
        let mut sorted = lambda.clone();
        sorted.sort_by(f64::total_cmp);
        for (k, &m) in r.mu.iter().enumerate() {
            let expected = 1.0 / (sorted[k] + 1.0);
            assert!((m / expected - 1.0).abs() < 1e-12, "{k}: {m} vs {expected}");
        }
        let G = r.X.transpose() * &r.X;
        let off = (&G - Mat::<f64>::identity(nev, nev)).norm_max();
        assert!(off < 1e-10, "XᵀX − I = {off:e}: a mode doubled");
        // Each vector is an eigenvector of its own μ.
        for k in 0..nev {
            let res: f64 = (0..n)
                .map(|i| (r.X[(i, k)] / (lambda[i] + 1.0) - r.mu[k] * r.X[(i, k)]).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(res < 1e-10 * r.mu[k], "{k}: residual {res:e}");
        }
    }
}
