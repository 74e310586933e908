//! Small dense complex kernels of the mode-selection steps: the eigen
//! decomposition of a Hermitian matrix by cyclic Jacobi rotations (Golub &
//! Van Loan, "Matrix Computations", 4th ed., section 8.5; A = V Λ Vᴴ) and,
//! from it, the singular values and left singular vectors of a tall matrix R
//! (n_rows × n_cols, few columns) through RᴴR = V Σ² Vᴴ, U = R V Σ⁻¹.
//!
//! Also the MAC between a vector and a subspace (the MAC with its orthogonal
//! projection on the span, by Gram–Schmidt), which compares participation
//! vectors and shapes at repeated roots.
//!
//! The matrices are the references × references blocks of an FRF matrix or a
//! residue matrix (a handful of columns), where a sequential Jacobi sweep is
//! exact to rounding, needs no workspace and is bit-identical on any thread
//! count.

use num_complex::Complex64;

/// Eigenvalues (descending) and unit eigenvectors (`vectors[k]` belongs to
/// `values[k]`) of the Hermitian `n × n` matrix `a` (row-major; only its
/// Hermitian part is used).
pub fn hermitian_eigen(a: &[Complex64], n: usize) -> (Vec<f64>, Vec<Vec<Complex64>>) {
    assert_eq!(a.len(), n * n, "hermitian_eigen: shape");
    let mut m: Vec<Complex64> = (0..n * n)
        .map(|k| {
            let (i, j) = (k / n, k % n);
            0.5 * (a[i * n + j] + a[j * n + i].conj())
        })
        .collect();
    let mut v: Vec<Complex64> = (0..n * n)
        .map(|k| Complex64::new(f64::from(u8::from(k / n == k % n)), 0.0))
        .collect();
    let total: f64 = m.iter().map(Complex64::norm_sqr).sum::<f64>().sqrt();
    for _sweep in 0..60 {
        let off: f64 = (0..n)
            .flat_map(|i| (0..n).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| m[i * n + j].norm_sqr())
            .sum::<f64>()
            .sqrt();
        if off <= 1e-15 * total || total == 0.0 {
            break;
        }
        for p in 0..n {
            for q in p + 1..n {
                rotate(&mut m, &mut v, n, p, q);
            }
        }
    }
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&x, &y| m[y * n + y].re.total_cmp(&m[x * n + x].re).then(x.cmp(&y)));
    let values = order.iter().map(|&k| m[k * n + k].re).collect();
    let vectors = order
        .iter()
        .map(|&k| (0..n).map(|i| v[i * n + k]).collect())
        .collect();
    (values, vectors)
}

/// One Jacobi rotation J = D G zeroing m[p][q]: D turns a_pq real, G is the
/// real rotation of the 2 × 2 block; m ← Jᴴ m J, v ← v J.
fn rotate(m: &mut [Complex64], v: &mut [Complex64], n: usize, p: usize, q: usize) {
    let apq = m[p * n + q];
    let r = apq.norm();
    if r == 0.0 {
        return;
    }
    let dq = (apq / r).conj();
    let (app, aqq) = (m[p * n + p].re, m[q * n + q].re);
    let tau = (aqq - app) / (2.0 * r);
    let t = if tau >= 0.0 {
        1.0 / (tau + (1.0 + tau * tau).sqrt())
    } else {
        -1.0 / (-tau + (1.0 + tau * tau).sqrt())
    };
    let c = 1.0 / (1.0 + t * t).sqrt();
    let s = t * c;
    // J = [[c, s], [−s d_q, c d_q]] on rows/columns (p, q).
    let (jpp, jpq, jqp, jqq) = (
        Complex64::new(c, 0.0),
        Complex64::new(s, 0.0),
        -s * dq,
        c * dq,
    );
    for k in 0..n {
        let (x, y) = (m[k * n + p], m[k * n + q]);
        m[k * n + p] = x * jpp + y * jqp;
        m[k * n + q] = x * jpq + y * jqq;
        let (x, y) = (v[k * n + p], v[k * n + q]);
        v[k * n + p] = x * jpp + y * jqp;
        v[k * n + q] = x * jpq + y * jqq;
    }
    for k in 0..n {
        let (x, y) = (m[p * n + k], m[q * n + k]);
        m[p * n + k] = jpp.conj() * x + jqp.conj() * y;
        m[q * n + k] = jpq.conj() * x + jqq.conj() * y;
    }
    m[p * n + q] = Complex64::new(0.0, 0.0);
    m[q * n + p] = Complex64::new(0.0, 0.0);
}

/// Singular values (descending) and left singular vectors of the
/// `rows × cols` row-major matrix `r` (cols small); vectors of zero singular
/// values are returned as zeros.
pub fn left_singular(r: &[Complex64], rows: usize, cols: usize) -> (Vec<f64>, Vec<Vec<Complex64>>) {
    assert_eq!(r.len(), rows * cols, "left_singular: shape");
    let mut g = vec![Complex64::new(0.0, 0.0); cols * cols];
    for row in r.chunks_exact(cols.max(1)) {
        for i in 0..cols {
            for j in 0..cols {
                g[i * cols + j] += row[i].conj() * row[j];
            }
        }
    }
    let (values, vectors) = hermitian_eigen(&g, cols);
    let sv: Vec<f64> = values.iter().map(|&l| l.max(0.0).sqrt()).collect();
    let u = vectors
        .iter()
        .zip(&sv)
        .map(|(vk, &s)| {
            (0..rows)
                .map(|o| {
                    if s > 0.0 {
                        (0..cols)
                            .map(|i| r[o * cols + i] * vk[i])
                            .sum::<Complex64>()
                            / s
                    } else {
                        Complex64::new(0.0, 0.0)
                    }
                })
                .collect()
        })
        .collect();
    (sv, u)
}

/// MAC between `v` and its projection on the span of `basis` (Gram–Schmidt).
pub fn subspace_mac(v: &[Complex64], basis: &[Vec<Complex64>]) -> f64 {
    let mut q: Vec<Vec<Complex64>> = Vec::new();
    for b in basis {
        let mut u = b.clone();
        for e in &q {
            let d: Complex64 = e.iter().zip(&u).map(|(x, y)| x.conj() * y).sum();
            u.iter_mut().zip(e).for_each(|(x, y)| *x -= d * y);
        }
        let n = u.iter().map(Complex64::norm_sqr).sum::<f64>().sqrt();
        if n > 1e-12 {
            q.push(u.into_iter().map(|x| x / n).collect());
        }
    }
    let vv: f64 = v.iter().map(Complex64::norm_sqr).sum();
    if vv == 0.0 {
        return 0.0;
    }
    q.iter()
        .map(|e| {
            e.iter()
                .zip(v)
                .map(|(x, y)| x.conj() * y)
                .sum::<Complex64>()
                .norm_sqr()
        })
        .sum::<f64>()
        / vv
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn random(n: usize, rng: &mut ChaCha8Rng) -> Vec<Complex64> {
        let mut u = || (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
        (0..n).map(|_| Complex64::new(u(), u())).collect()
    }

    #[test]
    fn jacobi_eigenpairs_satisfy_a_v_equals_lambda_v() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for n in 1..=7 {
            let b = random(n * n, &mut rng);
            // A = B + Bᴴ is Hermitian.
            let a: Vec<Complex64> = (0..n * n)
                .map(|k| b[k] + b[(k % n) * n + k / n].conj())
                .collect();
            let (vals, vecs) = hermitian_eigen(&a, n);
            let tol = 1e-13 * (n as f64).sqrt() * 4.0;
            for (l, v) in vals.iter().zip(&vecs) {
                let norm: f64 = v.iter().map(Complex64::norm_sqr).sum::<f64>().sqrt();
                assert!((norm - 1.0).abs() < tol);
                for i in 0..n {
                    let av: Complex64 = (0..n).map(|j| a[i * n + j] * v[j]).sum();
                    assert!((av - v[i] * l).norm() < tol * 10.0, "n {n}: residual");
                }
            }
            assert!(vals.windows(2).all(|w| w[0] >= w[1]));
        }
        // Degenerate inputs: zero and identity.
        let (v, _) = hermitian_eigen(&[Complex64::new(0.0, 0.0); 4], 2);
        assert_eq!(v, vec![0.0, 0.0]);
    }

    #[test]
    fn singular_values_of_a_rank_two_matrix() {
        // R = 3 u1 v1ᴴ + 1 u2 v2ᴴ with orthonormal u and v.
        let s2 = 0.5f64.sqrt();
        let u1 = [
            Complex64::new(s2, 0.0),
            Complex64::new(0.0, s2),
            Complex64::new(0.0, 0.0),
        ];
        let u2 = [
            Complex64::new(0.0, 0.0),
            Complex64::new(0.0, 0.0),
            Complex64::new(1.0, 0.0),
        ];
        let v1 = [Complex64::new(1.0, 0.0), Complex64::new(0.0, 0.0)];
        let v2 = [Complex64::new(0.0, 0.0), Complex64::new(0.0, 1.0)];
        let r: Vec<Complex64> = (0..6)
            .map(|k| {
                let (o, i) = (k / 2, k % 2);
                3.0 * u1[o] * v1[i].conj() + u2[o] * v2[i].conj()
            })
            .collect();
        let (s, u) = left_singular(&r, 3, 2);
        assert!(
            (s[0] - 3.0).abs() < 1e-14 && (s[1] - 1.0).abs() < 1e-14,
            "{s:?}"
        );
        assert!(crate::metrics::mac(&u[0], &u1) > 1.0 - 1e-14);
        assert!(crate::metrics::mac(&u[1], &u2) > 1.0 - 1e-14);
    }

    #[test]
    fn subspace_mac_sees_any_basis_of_the_span() {
        let e = |v: [f64; 3]| {
            v.iter()
                .map(|&x| Complex64::new(x, 0.0))
                .collect::<Vec<_>>()
        };
        let basis = [e([1.0, 0.0, 0.0]), e([0.0, 1.0, 0.0])];
        assert!((subspace_mac(&e([1.0, 1.0, 0.0]), &basis) - 1.0).abs() < 1e-15);
        assert!((subspace_mac(&e([1.0, 0.0, 1.0]), &basis) - 0.5).abs() < 1e-15);
        assert_eq!(subspace_mac(&e([0.0, 0.0, 1.0]), &basis), 0.0);
    }
}
