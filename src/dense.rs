//! Small dense real linear algebra on `Vec<f64>` blocks: the Cholesky
//! factorization A = L Lᵀ and triangular solves that PolyMAX and the Gaussian
//! process need on matrices of a few hundred rows, and Householder QR least
//! squares for LSFD (Golub & Van Loan, "Matrix Computations", alg. 5.3.2). Sequential and
//! in a fixed operation order, so results are bit-identical on any thread count.

use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};

/// In-place Cholesky factorization of the symmetric `n × n` matrix `a`
/// (row-major, lower triangle read): on success the lower triangle holds L
/// with A = L Lᵀ and the strict upper triangle is zeroed. Returns `false` when
/// a pivot is not positive (A not positive definite).
pub fn cholesky(a: &mut [f64], n: usize) -> bool {
    assert_eq!(a.len(), n * n, "cholesky needs an n × n matrix");
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if !d.is_finite() || d <= 0.0 {
            return false;
        }
        let d = d.sqrt();
        a[j * n + j] = d;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s / d;
        }
        for k in j + 1..n {
            a[j * n + k] = 0.0;
        }
    }
    true
}

/// Solve L X = B in place for `B` (`n × m`, row-major) with the lower
/// triangular `L` (`n × n`) of [`cholesky`]; only the first `rows` rows of
/// L and B are used (leading sub-block), `ld` is L's row stride.
pub fn forward_substitute(l: &[f64], ld: usize, b: &mut [f64], m: usize, rows: usize) {
    for i in 0..rows {
        for k in 0..i {
            let lik = l[i * ld + k];
            if lik != 0.0 {
                for c in 0..m {
                    b[i * m + c] -= lik * b[k * m + c];
                }
            }
        }
        let d = l[i * ld + i];
        for c in 0..m {
            b[i * m + c] /= d;
        }
    }
}

/// Solve Lᵀ X = B in place (`B` is `n × m`, row-major).
pub fn backward_substitute_t(l: &[f64], n: usize, b: &mut [f64], m: usize) {
    for i in (0..n).rev() {
        for k in i + 1..n {
            let lki = l[k * n + i];
            if lki != 0.0 {
                for c in 0..m {
                    b[i * m + c] -= lki * b[k * m + c];
                }
            }
        }
        let d = l[i * n + i];
        for c in 0..m {
            b[i * m + c] /= d;
        }
    }
}

/// Solve the symmetric positive definite system A X = B (`B` is `n × m`);
/// `None` when A is not positive definite.
pub fn solve_spd(a: &[f64], n: usize, b: &[f64], m: usize) -> Option<Vec<f64>> {
    let mut l = a.to_vec();
    if !cholesky(&mut l, n) {
        return None;
    }
    let mut x = b.to_vec();
    forward_substitute(&l, n, &mut x, m, n);
    backward_substitute_t(&l, n, &mut x, m);
    Some(x)
}

/// The normal equations of a least-squares problem with Jacobian J (given
/// as its `columns`, each m long) and residuals r: G = JᵀJ (row-major
/// n × n, exactly symmetric) and g = Jᵀr. One blocked matrix product (faer,
/// sequential: a fixed operation order, so bit-identical on any thread
/// count) instead of n²/2 passes over m-long columns: with FRF residuals
/// (m ≈ 60,000, n ≈ 24) those passes read the whole Jacobian from memory
/// n/2 times and were 13 % of an update's CPU time.
pub fn normal_equations(columns: &[Vec<f64>], r: &[f64]) -> (Vec<f64>, Vec<f64>) {
    let n = columns.len();
    let p = transposed_product(columns, Some(r));
    let mut g = vec![0.0; n * n];
    for i in 0..n {
        for j in 0..n {
            // The lower triangle mirrored: exactly symmetric.
            g[i * n + j] = p[(i.max(j), i.min(j))];
        }
    }
    (g, (0..n).map(|j| p[(n, j)]).collect())
}

/// G = JᵀJ of [`normal_equations`] as a matrix (exactly symmetric).
pub fn gram(columns: &[Vec<f64>]) -> Mat<f64> {
    let p = transposed_product(columns, None);
    Mat::from_fn(columns.len(), columns.len(), |i, j| p[(i.max(j), i.min(j))])
}

/// [J r]ᵀ J for J's `columns` (and r, when given, as a last row).
fn transposed_product(columns: &[Vec<f64>], r: Option<&[f64]>) -> Mat<f64> {
    let n = columns.len();
    let m = columns.first().map_or(r.map_or(0, <[f64]>::len), Vec::len);
    assert!(
        columns
            .iter()
            .map(Vec::len)
            .chain(r.map(<[f64]>::len))
            .all(|l| l == m),
        "normal equations: every column and r need the same number of rows"
    );
    let extra = usize::from(r.is_some());
    let mut a = Mat::<f64>::zeros(m, n + extra);
    for (j, c) in columns.iter().enumerate() {
        a.col_as_slice_mut(j).copy_from_slice(c);
    }
    if let Some(r) = r {
        a.col_as_slice_mut(n).copy_from_slice(r);
    }
    let mut p = Mat::<f64>::zeros(n + extra, n);
    matmul(
        p.as_mut(),
        Accum::Replace,
        a.as_ref().transpose(),
        a.as_ref().subcols(0, n),
        1.0,
        Par::Seq,
    );
    p
}

/// Least-squares solution of A X ≈ B by Householder QR. `a` is `rows × cols`
/// column-major (destroyed), `b` is `rows × nrhs` column-major (destroyed);
/// returns X column-major (`cols × nrhs`), or `None` when A is rank deficient.
pub fn least_squares(
    a: &mut [f64],
    rows: usize,
    cols: usize,
    b: &mut [f64],
    nrhs: usize,
) -> Option<Vec<f64>> {
    assert!(
        a.len() == rows * cols && b.len() == rows * nrhs && rows >= cols,
        "least_squares shapes"
    );
    let mut v = vec![0.0; rows];
    for k in 0..cols {
        let col = &a[k * rows..(k + 1) * rows];
        let norm = col[k..].iter().map(|x| x * x).sum::<f64>().sqrt();
        if norm == 0.0 || !norm.is_finite() {
            return None;
        }
        let alpha = if col[k] > 0.0 { -norm } else { norm };
        let len = rows - k;
        v[..len].copy_from_slice(&col[k..]);
        v[0] -= alpha;
        let vv: f64 = v[..len].iter().map(|x| x * x).sum();
        if vv > 0.0 {
            let reflect = |y: &mut [f64]| {
                let s: f64 = v[..len].iter().zip(y.iter()).map(|(p, q)| p * q).sum();
                let f = 2.0 * s / vv;
                for (q, p) in y.iter_mut().zip(&v[..len]) {
                    *q -= f * p;
                }
            };
            for j in k + 1..cols {
                reflect(&mut a[j * rows + k..(j + 1) * rows]);
            }
            for r in 0..nrhs {
                reflect(&mut b[r * rows + k..(r + 1) * rows]);
            }
        }
        a[k * rows + k] = alpha;
    }
    let mut x = vec![0.0; cols * nrhs];
    for r in 0..nrhs {
        for c in (0..cols).rev() {
            let mut s = b[r * rows + c];
            for j in c + 1..cols {
                s -= a[j * rows + c] * x[r * cols + j];
            }
            x[r * cols + c] = s / a[c * rows + c];
        }
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cholesky_reconstructs_and_solves_a_known_system() {
        // A = [[4, 2, 0], [2, 5, 1], [0, 1, 3]]; x = [1, -1, 2] gives b = A x.
        let a = [4.0, 2.0, 0.0, 2.0, 5.0, 1.0, 0.0, 1.0, 3.0];
        let mut l = a.to_vec();
        assert!(cholesky(&mut l, 3));
        for i in 0..3 {
            for j in 0..3 {
                let llt: f64 = (0..3).map(|k| l[i * 3 + k] * l[j * 3 + k]).sum();
                assert!((llt - a[i * 3 + j]).abs() < 1e-14);
            }
        }
        let x = solve_spd(&a, 3, &[2.0, -1.0, 5.0], 1).unwrap();
        for (got, want) in x.iter().zip([1.0, -1.0, 2.0]) {
            assert!((got - want).abs() < 1e-14);
        }
        assert!(!cholesky(&mut [1.0, 2.0, 2.0, 1.0], 2), "indefinite");
    }

    #[test]
    fn least_squares_fits_a_line_exactly_and_in_the_mean() {
        // y = 2 + 3t at t = 0..4 is fitted exactly.
        let t = [0.0, 1.0, 2.0, 3.0, 4.0];
        let mut a: Vec<f64> = [1.0; 5].iter().chain(t.iter()).copied().collect();
        let mut b: Vec<f64> = t.iter().map(|t| 2.0 + 3.0 * t).collect();
        let x = least_squares(&mut a.clone(), 5, 2, &mut b, 1).unwrap();
        assert!(
            (x[0] - 2.0).abs() < 1e-14 && (x[1] - 3.0).abs() < 1e-14,
            "{x:?}"
        );
        // Normal equations of y = [1, 0, 0, 0, 0]: AᵀA = [[5, 10], [10, 30]], Aᵀy = [1, 0] → x = [0.6, −0.2].
        let mut y = vec![1.0, 0.0, 0.0, 0.0, 0.0];
        let x = least_squares(&mut a, 5, 2, &mut y, 1).unwrap();
        assert!(
            (x[0] - 0.6).abs() < 1e-14 && (x[1] + 0.2).abs() < 1e-14,
            "{x:?}"
        );
        assert!(least_squares(&mut [1.0, 1.0, 0.0, 0.0], 2, 2, &mut [1.0, 1.0], 1).is_none());
    }

    #[test]
    fn normal_equations_match_the_column_dot_products() {
        // J = [[1, 2], [3, 4], [5, 6]], r = [1, -1, 2]:
        // JᵀJ = [[35, 44], [44, 56]], Jᵀr = [8, 10].
        let columns = vec![vec![1.0, 3.0, 5.0], vec![2.0, 4.0, 6.0]];
        let (g, jr) = normal_equations(&columns, &[1.0, -1.0, 2.0]);
        assert_eq!(g, vec![35.0, 44.0, 44.0, 56.0]);
        assert_eq!(jr, vec![8.0, 10.0]);
        let gm = gram(&columns);
        assert_eq!((gm[(0, 1)], gm[(1, 0)], gm[(1, 1)]), (44.0, 44.0, 56.0));
        // Long integer-valued columns (every sum exact in any order): the
        // blocked product against plain sums, entry for entry.
        let m = 5003;
        let c: Vec<Vec<f64>> = (0..7)
            .map(|j| {
                (0..m)
                    .map(|i| ((i * 7 + j * 13) % 17) as f64 - 8.0)
                    .collect()
            })
            .collect();
        let r: Vec<f64> = (0..m).map(|i| (i % 5) as f64 - 2.0).collect();
        let (g, jr) = normal_equations(&c, &r);
        for a in 0..7 {
            let want: f64 = c[a].iter().zip(&r).map(|(x, y)| x * y).sum();
            assert_eq!(jr[a], want, "integer-valued sums are exact");
            for b in 0..7 {
                let want: f64 = c[a].iter().zip(&c[b]).map(|(x, y)| x * y).sum();
                assert_eq!(g[a * 7 + b], want);
            }
        }
        assert!(normal_equations(&[], &[]).0.is_empty());
    }
}
