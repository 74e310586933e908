//! A solid FE model nobody tuned for modalflow: a regular block of 8-node
//! trilinear hexahedra (isotropic steel, consistent mass, 2×2×2 Gauss
//! points; Zienkiewicz & Taylor, *The Finite Element Method*, vol. 1,
//! ch. 6 and 8), written as Matrix Market text the way an FE code exports
//! it. Node (i, j, k) is number i + (nx+1)(j + (ny+1)k), its x, y, z
//! displacements rows 3·node, 3·node+1, 3·node+2 (0-based). Also a dense
//! reference solution of K φ = λ M φ by Cholesky of M and the full
//! symmetric eigensolver (LAPACK-style, independent of the Lanczos code).
#![allow(non_snake_case, dead_code)]

use faer::Mat;
use std::collections::BTreeMap;

/// Matrix entries (row, column) → value, both triangles.
pub type Entries = BTreeMap<(usize, usize), f64>;

pub struct Block {
    /// Elements per direction and element edge lengths, m.
    pub elements: [usize; 3],
    pub size: [f64; 3],
    /// Young's modulus Pa, Poisson's ratio, density kg/m³.
    pub E: f64,
    pub nu: f64,
    pub rho: f64,
}

impl Block {
    pub fn steel(elements: [usize; 3], size: [f64; 3]) -> Block {
        Block {
            elements,
            size,
            E: 2.1e11,
            nu: 0.3,
            rho: 7850.0,
        }
    }

    pub fn nodes(&self) -> usize {
        let [nx, ny, nz] = self.elements;
        (nx + 1) * (ny + 1) * (nz + 1)
    }

    pub fn node(&self, i: usize, j: usize, k: usize) -> usize {
        let [nx, ny, _] = self.elements;
        i + (nx + 1) * (j + (ny + 1) * k)
    }

    /// Element stiffness and consistent mass (24 × 24, DOF 3a + d of
    /// corner a in the order of [`CORNERS`]).
    fn element(&self) -> (Mat<f64>, Mat<f64>) {
        let [a, b, c] = self.size;
        let (E, nu) = (self.E, self.nu);
        let lam = E * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let mu = E / (2.0 * (1.0 + nu));
        let g = 1.0 / 3f64.sqrt();
        let det = a * b * c / 8.0;
        let mut Ke = Mat::<f64>::zeros(24, 24);
        let mut Me = Mat::<f64>::zeros(24, 24);
        for &x in &[-g, g] {
            for &y in &[-g, g] {
                for &z in &[-g, g] {
                    let mut N = [0.0; 8];
                    let mut dN = [[0.0; 3]; 8];
                    for (p, &(xi, yi, zi)) in CORNERS.iter().enumerate() {
                        let (u, v, w) = (1.0 + x * xi, 1.0 + y * yi, 1.0 + z * zi);
                        N[p] = u * v * w / 8.0;
                        dN[p] = [
                            xi * v * w / 8.0 * 2.0 / a,
                            yi * u * w / 8.0 * 2.0 / b,
                            zi * u * v / 8.0 * 2.0 / c,
                        ];
                    }
                    for p in 0..8 {
                        for q in 0..8 {
                            for i in 0..3 {
                                Me[(3 * p + i, 3 * q + i)] += self.rho * N[p] * N[q] * det;
                                for j in 0..3 {
                                    // σ_ij = λ δ_ij ε_kk + 2μ ε_ij.
                                    let mut k =
                                        lam * dN[p][i] * dN[q][j] + mu * dN[p][j] * dN[q][i];
                                    if i == j {
                                        k += mu * (0..3).map(|l| dN[p][l] * dN[q][l]).sum::<f64>();
                                    }
                                    Ke[(3 * p + i, 3 * q + j)] += k * det;
                                }
                            }
                        }
                    }
                }
            }
        }
        (Ke, Me)
    }

    /// Assembled (K, M) as maps (row, col) → value, both triangles.
    pub fn assemble(&self) -> (Entries, Entries) {
        let (Ke, Me) = self.element();
        let [nx, ny, nz] = self.elements;
        let (mut K, mut M) = (BTreeMap::new(), BTreeMap::new());
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let dofs: Vec<usize> = CORNERS
                        .iter()
                        .flat_map(|&(x, y, z)| {
                            let n = self.node(
                                i + (x > 0.0) as usize,
                                j + (y > 0.0) as usize,
                                k + (z > 0.0) as usize,
                            );
                            (0..3).map(move |d| 3 * n + d)
                        })
                        .collect();
                    for (p, &r) in dofs.iter().enumerate() {
                        for (q, &s) in dofs.iter().enumerate() {
                            *K.entry((r, s)).or_insert(0.0) += Ke[(p, q)];
                            *M.entry((r, s)).or_insert(0.0) += Me[(p, q)];
                        }
                    }
                }
            }
        }
        (K, M)
    }
}

/// Corner a of the reference cube, (ξ_a, η_a, ζ_a).
pub const CORNERS: [(f64, f64, f64); 8] = [
    (-1.0, -1.0, -1.0),
    (1.0, -1.0, -1.0),
    (1.0, 1.0, -1.0),
    (-1.0, 1.0, -1.0),
    (-1.0, -1.0, 1.0),
    (1.0, -1.0, 1.0),
    (1.0, 1.0, 1.0),
    (-1.0, 1.0, 1.0),
];

/// Matrix Market text (`coordinate real symmetric`, lower triangle, 17
/// significant digits) of an n × n matrix.
pub fn matrix_market(n: usize, A: &Entries) -> String {
    let lower: Vec<_> = A.iter().filter(|((i, j), _)| i >= j).collect();
    let mut s = format!(
        "%%MatrixMarket matrix coordinate real symmetric\n{n} {n} {}\n",
        lower.len()
    );
    for ((i, j), v) in lower {
        s.push_str(&format!("{} {} {:.17e}\n", i + 1, j + 1, v));
    }
    s
}

pub fn dense(n: usize, A: &Entries) -> Mat<f64> {
    let mut D = Mat::zeros(n, n);
    for (&(i, j), &v) in A {
        D[(i, j)] = v;
    }
    D
}

/// All eigenvalues of K φ = λ M φ, ascending: M = C Cᵀ, C⁻¹ K C⁻ᵀ by the
/// full symmetric eigensolver. Absolute error ~ ε ‖K‖ ‖M⁻¹‖, ample for a
/// well-conditioned solid (relative 1e-12 on its lowest elastic mode).
pub fn reference_eigenvalues(K: &Mat<f64>, M: &Mat<f64>) -> Vec<f64> {
    let C = M.llt(faer::Side::Lower).expect("M SPD").L().to_owned();
    let mut A = K.clone();
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(
        C.as_ref(),
        A.as_mut(),
        faer::Par::Seq,
    );
    let mut B = A.transpose().to_owned();
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(
        C.as_ref(),
        B.as_mut(),
        faer::Par::Seq,
    );
    let mut s = B.self_adjoint_eigenvalues(faer::Side::Lower).expect("evd");
    s.sort_by(f64::total_cmp);
    s
}

/// Lumped (row-sum) mass with the nodes in `massless` given none: the
/// model of a lumped-mass export with constraint or reference nodes.
pub fn lumped_mass(M: &Entries, massless: &[usize]) -> Entries {
    let mut L = BTreeMap::new();
    for (&(i, _), &v) in M {
        *L.entry((i, i)).or_insert(0.0) += v;
    }
    for node in massless {
        for d in 0..3 {
            L.insert((3 * node + d, 3 * node + d), 0.0);
        }
    }
    L
}

/// Eigenvalues of K φ = λ M φ for a diagonal M with zero entries, by
/// static (Guyan) condensation of the massless DOFs s, exact for them:
/// K_red = K_mm − K_ms K_ss⁻¹ K_sm, M_red = M_mm (Guyan 1965), then
/// [`reference_eigenvalues`].
pub fn condensed_eigenvalues(K: &Mat<f64>, M: &Mat<f64>) -> Vec<f64> {
    let n = K.nrows();
    let (m, s): (Vec<usize>, Vec<usize>) = (0..n).partition(|&i| M[(i, i)] > 0.0);
    let pick = |A: &Mat<f64>, r: &[usize], c: &[usize]| {
        Mat::from_fn(r.len(), c.len(), |i, j| A[(r[i], c[j])])
    };
    let Kss = pick(K, &s, &s);
    let Ksm = pick(K, &s, &m);
    let X = faer::prelude::Solve::solve(&Kss.llt(faer::Side::Lower).expect("K_ss SPD"), &Ksm);
    let Kred = pick(K, &m, &m) - Ksm.transpose() * &X;
    let Kred = Mat::from_fn(m.len(), m.len(), |i, j| 0.5 * (Kred[(i, j)] + Kred[(j, i)]));
    reference_eigenvalues(&Kred, &pick(M, &m, &m))
}
