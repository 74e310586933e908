//! Orthogonalization for the block Lanczos of [`super`]: removing a new
//! block's components along the basis in the M-inner product (local
//! recurrence, then classical Gram–Schmidt with the DGKS criterion for a
//! second pass), and M-orthonormalizing the block itself (Cholesky QR,
//! twice, or modified Gram–Schmidt with deflation when the block is
//! nearly rank-deficient). Sequential, fixed operation order.
#![allow(non_snake_case)]

use super::{start_value, ShiftInvertOperator};
use faer::linalg::matmul::matmul;
use faer::reborrow::{Reborrow, ReborrowMut};
use faer::{Accum, Mat, Par};

fn col(A: &Mat<f64>, j: usize) -> &[f64] {
    A.col_as_slice(j)
}

fn dot(x: &[f64], y: &[f64]) -> f64 {
    x.iter().zip(y).map(|(a, b)| a * b).sum()
}

/// ⟨V_c, V_c⟩_M from the stored M-image.
pub(super) fn m_norm2(V: &Mat<f64>, MV: &Mat<f64>, c: usize) -> f64 {
    dot(col(MV, c), col(V, c)).max(0.0)
}

/// A[:, dst] −= r A[:, src] for src < dst (element by element, in row
/// order: the same operations whatever the layout).
fn axpy(A: &mut Mat<f64>, src: usize, dst: usize, r: f64) {
    let (left, mut right) = A.as_mut().split_at_col_mut(dst);
    let x = left.rb().col(src);
    let mut y = right.rb_mut().col_mut(0);
    for (yi, xi) in y.rb_mut().iter_mut().zip(x.iter()) {
        *yi -= r * xi;
    }
}

/// One classical Gram–Schmidt pass (level-3: two matrix products) of
/// W = V[:, b..b+p] against V[:, lo..b] in the M-inner product, using the
/// stored M-images: Cp[lo..b] = (M V)ᵀ W, W ← W − V Cp. Rows of `Cp`
/// outside lo..b are zeroed.
fn cgs_pass(V: &mut Mat<f64>, MV: &Mat<f64>, lo: usize, b: usize, p: usize, Cp: &mut Mat<f64>) {
    Cp.fill(0.0);
    if lo == b {
        return;
    }
    let (basis, mut rest) = V.as_mut().split_at_col_mut(b);
    let mut W = rest.rb_mut().subcols_mut(0, p);
    let mut C = Cp.as_mut().subrows_mut(lo, b - lo);
    matmul(
        C.rb_mut(),
        Accum::Replace,
        MV.subcols(lo, b - lo).transpose(),
        W.rb(),
        1.0,
        Par::Seq,
    );
    matmul(
        W.rb_mut(),
        Accum::Add,
        basis.rb().subcols(lo, b - lo),
        C.rb(),
        -1.0,
        Par::Seq,
    );
}

/// Remove from W = V[:, b..b+p] its components along V[:, 0..b] (M-inner
/// product) and set MV[:, b..b+p] = M W; returns the summed coefficients
/// (b × p).
///
/// A block Lanczos vector couples only to the previous block and its own
/// (or, first after a restart, to every kept Ritz vector: `lo` = 0), so a
/// pass against V[:, lo..b] removes the large components. One full
/// classical Gram–Schmidt pass then restores orthogonality to working
/// precision unless it cancels: the criterion of Daniel, Gragg, Kaufman &
/// Stewart (1976), a second full pass only when a column's M-norm drops
/// below 1/√2 of its norm before the pass (the "before" norm by
/// Pythagoras, ‖x‖² = ‖y‖² + ‖c‖², so no extra mass product). ARPACK
/// (`dsaitr`) uses the same test with threshold 0.717. Full passes are
/// most of the cost of a step at n ≫ basis size (README "One evaluation
/// against LAPACK/ARPACK": with two unconditional passes, matrix products
/// were ~40 % of an evaluation's samples at 50,430 DOF).
pub(super) fn project_out<O: ShiftInvertOperator + ?Sized>(
    op: &O,
    V: &mut Mat<f64>,
    MV: &mut Mat<f64>,
    lo: usize,
    b: usize,
    p: usize,
) -> Mat<f64> {
    let mut C = Mat::<f64>::zeros(b, p);
    let mut Cp = Mat::<f64>::zeros(b, p);
    if lo > 0 {
        cgs_pass(V, MV, lo, b, p, &mut Cp);
        C += &Cp;
    }
    for _ in 0..2 {
        cgs_pass(V, MV, 0, b, p, &mut Cp);
        C += &Cp;
        op.mass(V.as_ref().subcols(b, p), MV.as_mut().subcols_mut(b, p));
        let cancelled = (0..p).any(|j| {
            let removed: f64 = (0..b).map(|i| Cp[(i, j)] * Cp[(i, j)]).sum();
            m_norm2(V, MV, b + j) < removed
        });
        if !cancelled {
            break;
        }
    }
    C
}

/// W ← W T in place for the n × p block W = A[:, b..b+p] (through `tmp`,
/// n × p or larger).
fn right_multiply(A: &mut Mat<f64>, b: usize, T: &Mat<f64>, tmp: &mut Mat<f64>) {
    let p = T.nrows();
    let mut out = tmp.as_mut().subcols_mut(0, p);
    matmul(
        out.rb_mut(),
        Accum::Replace,
        A.as_ref().subcols(b, p),
        T.as_ref(),
        1.0,
        Par::Seq,
    );
    A.as_mut().subcols_mut(b, p).copy_from(out.rb());
}

/// Cholesky QR, twice (Yamamoto et al. 2015, "Roundoff error analysis of
/// the CholeskyQR2 algorithm"), of the block W = V[:, b..b+p] in the
/// M-inner product: G = Wᵀ M W = Rᵀ R, W ← W R⁻¹, with its M-image
/// transformed alike. Two level-3 passes over the block replace the
/// p(p−1) column sweeps of modified Gram–Schmidt (6 % of an evaluation's
/// samples at 50,430 DOF, with element-wise indexing). Orthogonal to
/// working precision when cond(W) ≲ ε^{−1/2}; returns `None` (the caller
/// falls back to Gram–Schmidt with deflation) when a pivot falls below
/// 1e-5 of its column's norm, or a column below 1e-12 of `before`.
pub(super) fn cholesky_qr2(
    V: &mut Mat<f64>,
    MV: &mut Mat<f64>,
    tmp: &mut Mat<f64>,
    b: usize,
    p: usize,
    before: &[f64],
) -> Option<Mat<f64>> {
    if p > 16 {
        return None;
    }
    let mut R = Mat::<f64>::identity(p, p);
    'passes: for pass in 0..2 {
        let mut G = Mat::<f64>::zeros(p, p);
        matmul(
            G.as_mut(),
            Accum::Replace,
            MV.subcols(b, p).transpose(),
            V.subcols(b, p),
            1.0,
            Par::Seq,
        );
        // Upper Cholesky factor U of the symmetrized Gram matrix.
        let mut U = Mat::<f64>::zeros(p, p);
        for j in 0..p {
            let g = G[(j, j)];
            let d = g - (0..j).map(|l| U[(l, j)] * U[(l, j)]).sum::<f64>();
            // Pass 0 decides: the block is well conditioned and no column
            // collapsed (else deflation by Gram–Schmidt). Pass 1 sees a
            // Gram matrix within ~1e-6 of I; should it still fail, the
            // block of pass 0 stands.
            let ok = d > 1e-10 * g && d.sqrt() > 1e-12 * before[j];
            if pass == 0 && !ok {
                return None;
            }
            if d.is_nan() || d <= 0.0 {
                break 'passes;
            }
            U[(j, j)] = d.sqrt();
            for c in j + 1..p {
                let gjc = 0.5 * (G[(j, c)] + G[(c, j)]);
                U[(j, c)] = (gjc - (0..j).map(|l| U[(l, j)] * U[(l, c)]).sum::<f64>()) / U[(j, j)];
            }
        }
        // T = U⁻¹ (upper), column by column.
        let mut T = Mat::<f64>::zeros(p, p);
        for c in 0..p {
            T[(c, c)] = 1.0 / U[(c, c)];
            for r in (0..c).rev() {
                let s: f64 = (r + 1..=c).map(|l| U[(r, l)] * T[(l, c)]).sum();
                T[(r, c)] = -s / U[(r, r)];
            }
        }
        right_multiply(V, b, &T, tmp);
        right_multiply(MV, b, &T, tmp);
        // W_in = W_1 U_1 = W_2 U_2 U_1.
        let mut next = Mat::<f64>::zeros(p, p);
        matmul(
            next.as_mut(),
            Accum::Replace,
            U.as_ref(),
            R.as_ref(),
            1.0,
            Par::Seq,
        );
        R = next;
    }
    Some(R)
}

/// M-orthonormalize the block V[:, b..b+p] (whose M-image MV[:, b..b+p] is
/// current and which is already M-orthogonal to V[:, 0..b]) by modified
/// Gram–Schmidt, twice. A column that collapses below `1e-12 · before[j]`
/// (the Krylov space is invariant in that direction) is replaced by a fresh
/// start vector orthogonalized against everything; its coupling is zero.
/// Returns R (p × p upper) with W_in = W_out R, or `None` if the space is
/// exhausted.
pub(super) fn orthonormalize_block<O: ShiftInvertOperator + ?Sized>(
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
                    let r = dot(col(MV, i), col(V, c));
                    if !replaced {
                        R[(i - b, j)] += r;
                    }
                    axpy(V, i, c, r);
                    axpy(MV, i, c, r);
                }
            }
            let nrm = m_norm2(V, MV, c).sqrt();
            let scale = if replaced { 1.0 } else { before[j] };
            if nrm > 1e-12 * scale && nrm.is_finite() {
                if !replaced {
                    R[(j, j)] = nrm;
                }
                for A in [&mut *V, &mut *MV] {
                    for x in A.col_as_slice_mut(c) {
                        *x /= nrm;
                    }
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
            let _ = project_out(op, V, MV, 0, c, 1);
        }
    }
    Some(R)
}

#[cfg(test)]
mod tests {
    use super::*;
    use faer::{MatMut, MatRef};

    /// M = diag(1, 2, …, n); the solve is not used here.
    struct Diagonal(usize);

    impl ShiftInvertOperator for Diagonal {
        fn dim(&self) -> usize {
            self.0
        }
        fn mass(&self, X: MatRef<'_, f64>, mut Y: MatMut<'_, f64>) {
            for j in 0..X.ncols() {
                for i in 0..X.nrows() {
                    Y[(i, j)] = (i + 1) as f64 * X[(i, j)];
                }
            }
        }
        fn solve(&mut self, _: MatMut<'_, f64>) {}
    }

    fn block(n: usize, cols: usize, f: impl Fn(usize, usize) -> f64) -> (Mat<f64>, Mat<f64>) {
        let V = Mat::from_fn(n, cols, f);
        let mut MV = Mat::zeros(n, cols);
        Diagonal(n).mass(V.as_ref(), MV.as_mut());
        (V, MV)
    }

    #[test]
    fn cholesky_qr2_orthonormalizes_and_reproduces_the_block() {
        let (n, p) = (50, 4);
        let (mut V, mut MV) = block(n, p, start_value);
        let W = V.clone();
        let mut tmp = Mat::zeros(n, p);
        let R = cholesky_qr2(&mut V, &mut MV, &mut tmp, 0, p, &[1.0; 4]).expect("well conditioned");
        let G = MV.transpose() * &V;
        assert!(
            (&G - Mat::<f64>::identity(p, p)).norm_max() < 1e-14,
            "{G:?}"
        );
        assert!((&V * &R - &W).norm_max() < 1e-13 * W.norm_max());
        for j in 0..p {
            for i in j + 1..p {
                assert_eq!(R[(i, j)], 0.0);
            }
        }
    }

    #[test]
    fn cholesky_qr2_declines_a_rank_deficient_block() {
        let (n, p) = (50, 4);
        // Column 3 = column 0 + column 1: Gram–Schmidt must deflate it.
        let (mut V, mut MV) = block(n, p, |i, j| match j {
            3 => start_value(i, 0) + start_value(i, 1),
            _ => start_value(i, j),
        });
        let mut tmp = Mat::zeros(n, p);
        assert!(cholesky_qr2(&mut V, &mut MV, &mut tmp, 0, p, &[1.0; 4]).is_none());
    }

    #[test]
    fn one_pass_suffices_unless_the_projection_cancels() {
        // Basis: 4 M-orthonormal vectors (e_i / sqrt(i+1)); the new column
        // is a basis vector plus a small orthogonal part, so the first pass
        // cancels and a second one runs; the result is M-orthogonal.
        let n = 20;
        let (mut V, mut MV) = block(n, 5, |i, j| match j {
            4 => (if i == 2 { 1.0 } else { 0.0 }) + 1e-9 * start_value(i, 9),
            _ if i == j => 1.0 / ((i + 1) as f64).sqrt(),
            _ => 0.0,
        });
        let op = Diagonal(n);
        let C = project_out(&op, &mut V, &mut MV, 0, 4, 1);
        assert!((C[(2, 0)] - 3f64.sqrt()).abs() < 1e-8);
        let norm = m_norm2(&V, &MV, 4).sqrt();
        assert!(norm > 1e-10 && norm < 1e-8, "{norm:e}");
        for j in 0..4 {
            let d: f64 = (0..n).map(|i| MV[(i, j)] * V[(i, 4)]).sum();
            assert!(d.abs() < 1e-14 * norm, "{j}: {d:e} vs {norm:e}");
        }
        let mut check = Mat::zeros(n, 1);
        op.mass(V.as_ref().subcols(4, 1), check.as_mut());
        assert_eq!(check, MV.subcols(4, 1).to_owned());
    }
}
