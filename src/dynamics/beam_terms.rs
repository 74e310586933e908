//! A beam whose modulus is a model parameter: its stiffness as a sum of
//! rank-one terms, the form every parametric stiffness takes in the
//! assembly ([`super::assembly::JointTerms`]).
//!
//! The Euler–Bernoulli element stiffness is linear in E and G
//! (Przemieniecki 1968, ch. 5): k_e = E k_e¹ + G k_e^G with k_e¹ the
//! element stiffness at E = 1, G = 0 (axial and bending) and k_e^G at
//! E = 0, G = 1 (torsion). Each is symmetric positive semi-definite, so its
//! eigen-decomposition k = Σ_i λ_i v_i v_iᵀ over the non-zero λ_i gives
//! columns g_i = √λ_i v_i with k = Σ_i g_i g_iᵀ (rank 5 for k_e¹, 1 for
//! k_e^G; the six rigid-body motions are its null space). Then
//! K_beam(E, G) = E Σ g gᵀ + G Σ h hᵀ exactly, and an evaluation at a new E
//! costs what a new joint stiffness costs. The mass matrix does not depend
//! on E or G and stays in the body's fixed blocks.
#![allow(non_snake_case)]

use super::beam::{global_element_matrices, Section};

/// Sparse columns over a body's DOFs: (DOF index, value).
pub type Column = Vec<(usize, f64)>;

/// Eigenvalues and eigenvectors (columns of the returned matrix) of a
/// symmetric 12×12 matrix by cyclic Jacobi rotations (Golub & Van Loan,
/// *Matrix Computations*, 4th ed., alg. 8.5.3), to machine precision.
pub fn symmetric_eigen_12(a: &[[f64; 12]; 12]) -> ([f64; 12], [[f64; 12]; 12]) {
    let mut A = *a;
    let mut V = [[0.0; 12]; 12];
    for (i, row) in V.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    let norm: f64 = A.iter().flatten().map(|x| x * x).sum::<f64>().sqrt();
    for _sweep in 0..60 {
        let off: f64 = (0..12)
            .flat_map(|i| (0..12).filter(move |&j| j != i).map(move |j| (i, j)))
            .map(|(i, j)| A[i][j] * A[i][j])
            .sum::<f64>()
            .sqrt();
        if off <= f64::EPSILON * norm * 1e-3 || off == 0.0 {
            break;
        }
        for p in 0..11 {
            for q in p + 1..12 {
                if A[p][q] == 0.0 {
                    continue;
                }
                // Rotation (c, s) that zeroes A[p][q] (G&VL alg. 8.5.1).
                let tau = (A[q][q] - A[p][p]) / (2.0 * A[p][q]);
                let t = tau.signum() / (tau.abs() + (1.0 + tau * tau).sqrt());
                let t = if tau == 0.0 { 1.0 } else { t };
                let c = 1.0 / (1.0 + t * t).sqrt();
                let s = t * c;
                // A ← Jᵀ A J: columns p, q, then rows p, q.
                for row in A.iter_mut() {
                    let (akp, akq) = (row[p], row[q]);
                    row[p] = c * akp - s * akq;
                    row[q] = s * akp + c * akq;
                }
                let (rp, rq) = (A[p], A[q]);
                for k in 0..12 {
                    A[p][k] = c * rp[k] - s * rq[k];
                    A[q][k] = s * rp[k] + c * rq[k];
                }
                for row in V.iter_mut() {
                    let (vp, vq) = (row[p], row[q]);
                    row[p] = c * vp - s * vq;
                    row[q] = s * vp + c * vq;
                }
            }
        }
    }
    (std::array::from_fn(|i| A[i][i]), V)
}

/// Rank-one columns g_i = √λ_i v_i of a symmetric positive semi-definite
/// 12×12 matrix, k = Σ g_i g_iᵀ; eigenvalues below 10⁻¹⁰ of the largest
/// are the null space and dropped.
pub fn rank_one_columns(k: &[[f64; 12]; 12]) -> Vec<[f64; 12]> {
    let (lambda, V) = symmetric_eigen_12(k);
    let max = lambda.iter().fold(0.0f64, |m, &l| m.max(l.abs()));
    (0..12)
        .filter(|&i| lambda[i] > 1e-10 * max)
        .map(|i| std::array::from_fn(|r| lambda[i].sqrt() * V[r][i]))
        .collect()
}

/// Columns over the beam's DOFs (6 per node, node i at rows 6i..6i+6) with
/// Σ g gᵀ = the assembled stiffness of `section` (give E = 1, G = 0 for the
/// part proportional to E; E = 0, G = 1 for the part proportional to G).
pub fn stiffness_columns(
    start: [f64; 3],
    end: [f64; 3],
    elements: usize,
    R: [[f64; 3]; 3],
    section: &Section,
) -> Vec<Column> {
    let (kg, _) = global_element_matrices(start, end, elements, R, section);
    let element = rank_one_columns(&kg);
    let mut out = Vec::with_capacity(elements * element.len());
    for e in 0..elements {
        for g in &element {
            out.push(
                g.iter()
                    .enumerate()
                    .filter(|(_, v)| **v != 0.0)
                    .map(|(i, v)| (6 * e + i, *v))
                    .collect(),
            );
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::beam::{assemble_beam, local_axes};

    fn section(E: f64, G: f64) -> Section {
        Section {
            A: 2.5e-4,
            Iy: 5.2e-10,
            Iz: 5.2e-8,
            J: 2.0e-9,
            E,
            G,
            rho: 7880.0,
        }
    }

    /// Σ E g gᵀ + G h hᵀ reproduces the assembled beam stiffness at (E, G)
    /// to rounding, for a tilted beam; the ranks are 5 (axial and two
    /// bending planes) and 1 (torsion) per element.
    #[test]
    fn columns_reproduce_the_assembled_stiffness() {
        let (start, end) = ([0.1, -0.2, 0.3], [0.5, 0.1, 0.9]);
        let R = local_axes(start, end, [0.0, 0.0, 1.0]).unwrap();
        let (E, G) = (1.9e11, 7.3e10);
        let elements = 7;
        let ce = stiffness_columns(start, end, elements, R, &section(1.0, 0.0));
        let cg = stiffness_columns(start, end, elements, R, &section(0.0, 1.0));
        assert_eq!(ce.len(), 5 * elements);
        assert_eq!(cg.len(), elements);
        let K = assemble_beam(start, end, elements, R, &section(E, G))
            .K
            .to_dense();
        let n = K.nrows();
        let mut S = faer::Mat::<f64>::zeros(n, n);
        for (cols, v) in [(&ce, E), (&cg, G)] {
            for g in cols {
                for &(i, a) in g {
                    for &(j, b) in g {
                        S[(i, j)] += v * a * b;
                    }
                }
            }
        }
        let scale = (0..n).map(|i| K[(i, i)].abs()).fold(0.0, f64::max);
        for i in 0..n {
            for j in 0..n {
                let d = (S[(i, j)] - K[(i, j)]).abs();
                assert!(
                    d <= 1e-12 * scale,
                    "K[{i},{j}]: {} vs {}",
                    S[(i, j)],
                    K[(i, j)]
                );
            }
        }
    }

    /// Jacobi on a diagonal-plus-rank-one matrix with known spectrum:
    /// A = I + u uᵀ has eigenvalues 1 (11×) and 1 + |u|².
    #[test]
    fn jacobi_known_spectrum() {
        let u: [f64; 12] = std::array::from_fn(|i| (i as f64 + 1.0) / 10.0);
        let a: [[f64; 12]; 12] =
            std::array::from_fn(|i| std::array::from_fn(|j| u[i] * u[j] + f64::from(i == j)));
        let (mut l, _) = symmetric_eigen_12(&a);
        l.sort_by(f64::total_cmp);
        let top = 1.0 + u.iter().map(|x| x * x).sum::<f64>();
        assert!((l[11] - top).abs() < 1e-13 * top);
        assert!(l[..11].iter().all(|x| (x - 1.0).abs() < 1e-13));
    }
}
