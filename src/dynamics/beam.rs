//! Straight 3D beams from 12-DOF Euler-Bernoulli frame elements with
//! consistent mass (Przemieniecki, *Theory of Matrix Structural Analysis*,
//! 1968, ch. 5 and 11). Per node the DOFs are (u_x, u_y, u_z, θ_x, θ_y, θ_z)
//! in global axes. Shear deformation is neglected (Euler-Bernoulli): fine for
//! the slender machine-tool members modelled here (length/depth > 5); the
//! rotary inertia of bending is neglected, torsional inertia uses
//! I_p = I_y + I_z.
#![allow(non_snake_case)]

use super::fe_body::{FeBody, FeNode};
use super::sparse::Csc;

/// Cross-section and material of a beam, SI units: the numbers the element
/// matrices need (the model file's section with every parameter resolved).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Section {
    /// Area, m².
    pub A: f64,
    /// Second moment about local y (bending in the local x-z plane), m⁴.
    pub Iy: f64,
    /// Second moment about local z (bending in the local x-y plane), m⁴.
    pub Iz: f64,
    /// Torsion constant, m⁴.
    pub J: f64,
    /// Young's modulus, Pa.
    pub E: f64,
    /// Shear modulus, Pa.
    pub G: f64,
    /// Density, kg/m³.
    pub rho: f64,
}

/// Local element stiffness and mass (12×12) of length `l`.
pub fn element_matrices(s: &Section, l: f64) -> ([[f64; 12]; 12], [[f64; 12]; 12]) {
    let mut k = [[0.0; 12]; 12];
    let mut m = [[0.0; 12]; 12];
    let put = |mat: &mut [[f64; 12]; 12], idx: &[usize], vals: &[&[f64]], f: f64| {
        for (a, &i) in idx.iter().enumerate() {
            for (b, &j) in idx.iter().enumerate() {
                mat[i][j] += f * vals[a][b];
            }
        }
    };
    let (l2, l3) = (l * l, l * l * l);
    // Axial and torsion.
    put(
        &mut k,
        &[0, 6],
        &[&[1.0, -1.0], &[-1.0, 1.0]],
        s.E * s.A / l,
    );
    put(
        &mut k,
        &[3, 9],
        &[&[1.0, -1.0], &[-1.0, 1.0]],
        s.G * s.J / l,
    );
    // Bending in x-y plane (v, θz) and x-z plane (w, θy).
    let bxy: [&[f64]; 4] = [
        &[12.0, 6.0 * l, -12.0, 6.0 * l],
        &[6.0 * l, 4.0 * l2, -6.0 * l, 2.0 * l2],
        &[-12.0, -6.0 * l, 12.0, -6.0 * l],
        &[6.0 * l, 2.0 * l2, -6.0 * l, 4.0 * l2],
    ];
    let bxz: [&[f64]; 4] = [
        &[12.0, -6.0 * l, -12.0, -6.0 * l],
        &[-6.0 * l, 4.0 * l2, 6.0 * l, 2.0 * l2],
        &[-12.0, 6.0 * l, 12.0, 6.0 * l],
        &[-6.0 * l, 2.0 * l2, 6.0 * l, 4.0 * l2],
    ];
    put(&mut k, &[1, 5, 7, 11], &bxy, s.E * s.Iz / l3);
    put(&mut k, &[2, 4, 8, 10], &bxz, s.E * s.Iy / l3);
    let mass = s.rho * s.A * l;
    put(&mut m, &[0, 6], &[&[2.0, 1.0], &[1.0, 2.0]], mass / 6.0);
    put(
        &mut m,
        &[3, 9],
        &[&[2.0, 1.0], &[1.0, 2.0]],
        s.rho * (s.Iy + s.Iz) * l / 6.0,
    );
    let mxy: [&[f64]; 4] = [
        &[156.0, 22.0 * l, 54.0, -13.0 * l],
        &[22.0 * l, 4.0 * l2, 13.0 * l, -3.0 * l2],
        &[54.0, 13.0 * l, 156.0, -22.0 * l],
        &[-13.0 * l, -3.0 * l2, -22.0 * l, 4.0 * l2],
    ];
    let mxz: [&[f64]; 4] = [
        &[156.0, -22.0 * l, 54.0, 13.0 * l],
        &[-22.0 * l, 4.0 * l2, -13.0 * l, -3.0 * l2],
        &[54.0, -13.0 * l, 156.0, 22.0 * l],
        &[13.0 * l, -3.0 * l2, 22.0 * l, 4.0 * l2],
    ];
    put(&mut m, &[1, 5, 7, 11], &mxy, mass / 420.0);
    put(&mut m, &[2, 4, 8, 10], &mxz, mass / 420.0);
    (k, m)
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    (n > 1e-12 && n.is_finite()).then(|| [a[0] / n, a[1] / n, a[2] / n])
}

/// Rotation with rows = local x (along the beam), y, z in global axes, or
/// `None` when the beam has zero length or `orientation` is parallel to it.
pub fn local_axes(start: [f64; 3], end: [f64; 3], orientation: [f64; 3]) -> Option<[[f64; 3]; 3]> {
    let ex = normalize(sub(end, start))?;
    let ez = normalize(cross(ex, orientation))?;
    let ey = cross(ez, ex);
    Some([ex, ey, ez])
}

/// Element stiffness and mass (12×12) in global axes, Tᵀ k T with
/// T = blockdiag(R, R, R, R), of one of `elements` equal elements from
/// `start` to `end`.
pub fn global_element_matrices(
    start: [f64; 3],
    end: [f64; 3],
    elements: usize,
    R: [[f64; 3]; 3],
    s: &Section,
) -> ([[f64; 12]; 12], [[f64; 12]; 12]) {
    let d = sub(end, start);
    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt() / elements as f64;
    let (kl, ml) = element_matrices(s, l);
    // Global element matrices Tᵀ k T with T = blockdiag(R, R, R, R).
    let rot = |a: &[[f64; 12]; 12]| {
        let mut g = [[0.0; 12]; 12];
        let mut tmp = [[0.0; 12]; 12];
        // tmp = a T
        for i in 0..12 {
            for bj in 0..4 {
                for j in 0..3 {
                    tmp[i][3 * bj + j] = (0..3).map(|q| a[i][3 * bj + q] * R[q][j]).sum();
                }
            }
        }
        // g = Tᵀ tmp
        for bi in 0..4 {
            for i in 0..3 {
                for j in 0..12 {
                    g[3 * bi + i][j] = (0..3).map(|q| R[q][i] * tmp[3 * bi + q][j]).sum();
                }
            }
        }
        g
    };
    (rot(&kl), rot(&ml))
}

/// Assemble the full beam: `elements` equal elements from `start` to `end`,
/// node i at start + i/elements·(end − start). Caller validated the inputs.
pub fn assemble_beam(
    start: [f64; 3],
    end: [f64; 3],
    elements: usize,
    R: [[f64; 3]; 3],
    s: &Section,
) -> FeBody {
    let n_nodes = elements + 1;
    let n = 6 * n_nodes;
    let d = sub(end, start);
    let (kg, mg) = global_element_matrices(start, end, elements, R, s);
    let mut tk = Vec::with_capacity(144 * elements);
    let mut tm = Vec::with_capacity(144 * elements);
    for e in 0..elements {
        let o = 6 * e;
        for i in 0..12 {
            for j in 0..12 {
                tk.push((o + i, o + j, kg[i][j]));
                tm.push((o + i, o + j, mg[i][j]));
            }
        }
    }
    let (K, M) = (Csc::from_triplets(n, tk), Csc::from_triplets(n, tm));
    let nodes = (0..n_nodes)
        .map(|i| {
            let t = i as f64 / elements as f64;
            FeNode {
                id: i as u64,
                position: [
                    start[0] + t * d[0],
                    start[1] + t * d[1],
                    start[2] + t * d[2],
                ],
                dofs: std::array::from_fn(|j| Some(6 * i + j)),
            }
        })
        .collect();
    FeBody { M, K, nodes }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::dynamics::eigen::generalized_eigen;
    use faer::Mat;

    /// Cantilever bending frequencies vs Euler-Bernoulli:
    /// ω_n = (β_n L)² √(EI/(ρ A L⁴)), β_n L = 1.8751, 4.6941, 7.8548.
    #[test]
    fn cantilever_matches_euler_bernoulli() {
        let s = Section {
            A: 4e-4,
            Iy: 1.3e-8,
            Iz: 1.3e-8,
            J: 2.2e-8,
            E: 2.1e11,
            G: 8.1e10,
            rho: 7850.0,
        };
        let len = 1.0;
        // Tilted beam axis checks the rotation to global axes too.
        let end = [len / 3f64.sqrt(), len / 3f64.sqrt(), len / 3f64.sqrt()];
        let R = local_axes([0.0; 3], end, [0.0, 0.0, 1.0]).unwrap();
        let b = assemble_beam([0.0; 3], end, 20, R, &s);
        // Clamp node 0: drop its 6 DOFs.
        let keep: Vec<usize> = (6..b.n()).collect();
        let (Kd, Md) = (b.K.to_dense(), b.M.to_dense());
        let K = Mat::from_fn(keep.len(), keep.len(), |i, j| Kd[(keep[i], keep[j])]);
        let M = Mat::from_fn(keep.len(), keep.len(), |i, j| Md[(keep[i], keep[j])]);
        let (lambda, Phi) = generalized_eigen(&K, &M, 12).unwrap();
        crate::dynamics::eigen::tests::check_identities(&K, &M, &lambda, &Phi);
        let w: Vec<f64> = lambda.iter().map(|l| l.sqrt()).collect();
        let c = (s.E * s.Iy / (s.rho * s.A * len.powi(4))).sqrt();
        // Equal Iy = Iz: each bending mode appears twice.
        for (n, bl) in [1.8751f64, 4.6941, 7.8548].iter().enumerate() {
            let exact = bl * bl * c;
            let found = w
                .iter()
                .filter(|&&x| ((x - exact) / exact).abs() < 0.005)
                .count();
            assert_eq!(found, 2, "bending mode {n}: exact {exact}, got {w:?}");
        }
    }
}
