//! Rigid bodies: the 6×6 mass matrix at the centre of gravity and the rigid
//! transformation of a point, u_p = u_cg + θ × (p − cg), θ_p = θ
//! (small rotations, floating frame of reference, seed section 3.1.2).
#![allow(non_snake_case)]

use faer::Mat;

/// Mass matrix for DOFs (u_x, u_y, u_z, θ_x, θ_y, θ_z) at the centre of
/// gravity: diag(m, m, m) and the inertia tensor J_cg.
pub fn rigid_mass(mass: f64, inertia: &[[f64; 3]; 3]) -> Mat<f64> {
    let mut M = Mat::<f64>::zeros(6, 6);
    for i in 0..3 {
        M[(i, i)] = mass;
        for j in 0..3 {
            M[(3 + i, 3 + j)] = 0.5 * (inertia[i][j] + inertia[j][i]);
        }
    }
    M
}

/// 6×6 map from the DOFs of a reference point to the DOFs of a point at
/// offset r from it: [[I, −[r]×], [0, I]] (u_p = u + θ × r).
pub fn offset_map(r: [f64; 3]) -> [[f64; 6]; 6] {
    let mut T = [[0.0; 6]; 6];
    for (i, row) in T.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    // θ × r = −[r]× θ; [r]× = [[0,−r3,r2],[r3,0,−r1],[−r2,r1,0]].
    let skew = [[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]];
    for i in 0..3 {
        for j in 0..3 {
            T[i][3 + j] = -skew[i][j];
        }
    }
    T
}

/// True when a symmetric 3×3 inertia tensor is positive definite (Sylvester).
pub fn inertia_is_positive_definite(J: &[[f64; 3]; 3]) -> bool {
    let d1 = J[0][0];
    let d2 = J[0][0] * J[1][1] - J[0][1] * J[1][0];
    let d3 = J[0][0] * (J[1][1] * J[2][2] - J[1][2] * J[2][1])
        - J[0][1] * (J[1][0] * J[2][2] - J[1][2] * J[2][0])
        + J[0][2] * (J[1][0] * J[2][1] - J[1][1] * J[2][0]);
    d1 > 0.0 && d2 > 0.0 && d3 > 0.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn offset_map_is_cross_product() {
        let r = [0.3, -0.2, 0.5];
        let T = offset_map(r);
        let theta = [0.01, 0.02, -0.03];
        let u = [1.0, 2.0, 3.0, theta[0], theta[1], theta[2]];
        let up: Vec<f64> = (0..6)
            .map(|i| (0..6).map(|j| T[i][j] * u[j]).sum())
            .collect();
        let cross = [
            theta[1] * r[2] - theta[2] * r[1],
            theta[2] * r[0] - theta[0] * r[2],
            theta[0] * r[1] - theta[1] * r[0],
        ];
        for i in 0..3 {
            assert!((up[i] - (u[i] + cross[i])).abs() < 1e-15);
            assert_eq!(up[3 + i], theta[i]);
        }
    }

    #[test]
    fn inertia_check() {
        assert!(inertia_is_positive_definite(&[
            [1.0, 0.0, 0.0],
            [0.0, 2.0, 0.0],
            [0.0, 0.0, 3.0]
        ]));
        assert!(!inertia_is_positive_definite(&[
            [1.0, 0.0, 0.0],
            [0.0, -2.0, 0.0],
            [0.0, 0.0, 3.0]
        ]));
    }
}
