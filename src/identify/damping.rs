//! Damping parameters by bounded linear least squares (PUB3, second step).
//!
//! For fixed stiffness the mode shapes and frequencies do not depend on the
//! damping, and the modal damping is linear in the damping parameters
//! (seed section 2.3.2, eq. 2.43/2.46 with mass-normalized shapes):
//! 2 ζ_r ω_r = Σ_j c_j (g_jᵀφ_r)² for viscous dampers, η_r ω_r² = Σ_j d_j
//! (g_jᵀφ_r)² for hysteretic ones, so the equivalent ratio ζ_r + η_r/2 is
//! ζ(c) = ζ(l) + A (c − l). Column j of A is a difference of two model evaluations:
//! all free c_j at their lower bounds once, then c_j alone at its upper bound (exact, since ζ is linear). The
//! damping values then solve min ‖A (c − l) − (ζ_ref − ζ(l))‖² within the
//! bounds ([`bvls`]), over the paired modes of all positions.

use super::{IdentifyError, ModalObjective};

/// The fitted damping values and the fit's bookkeeping.
#[derive(Clone, Debug)]
pub struct DampingFit {
    /// All parameter values: `x` with the free damping parameters replaced.
    pub x: Vec<f64>,
    /// Model evaluations used (1 per free parameter + 1).
    pub evaluations: usize,
    /// Paired modes used as equations.
    pub equations: usize,
    /// Root-mean-square damping-ratio residual at the solution.
    pub rms_residual: f64,
}

/// Fit the damping parameters `free` (indices into the model's parameters)
/// with all other values taken from `x`.
pub fn identify_damping(
    objective: &ModalObjective,
    x: &[f64],
    free: &[usize],
) -> Result<DampingFit, IdentifyError> {
    let params = objective.parameters();
    let mut base = x.to_vec();
    for &j in free {
        base[j] = params[j].lower;
    }
    let zeta_of = |x: &[f64]| -> Result<Vec<Option<(f64, f64)>>, IdentifyError> {
        let all = objective.matches(x)?;
        let mut out = Vec::new();
        for (p, ms) in all.iter().enumerate() {
            for (r, m) in ms.iter().enumerate() {
                out.push(m.map(|m| (m.damping_ratio, objective.reference_damping(p, r))));
            }
        }
        Ok(out)
    };
    let z0 = zeta_of(&base)?;
    let rows: Vec<usize> = (0..z0.len()).filter(|&i| z0[i].is_some()).collect();
    if rows.is_empty() {
        return Err(IdentifyError::Invalid(
            "no reference mode pairs with a model mode at the identified stiffness; widen `window`"
                .into(),
        ));
    }
    let b: Vec<f64> = rows
        .iter()
        .filter_map(|&i| z0[i].map(|(z, zr)| zr - z))
        .collect();
    // Column j scaled by the bound range: unknowns t_j ∈ [0, 1].
    let mut a = vec![vec![0.0; free.len()]; rows.len()];
    for (k, &j) in free.iter().enumerate() {
        let mut hi = base.clone();
        hi[j] = params[j].upper;
        let z1 = zeta_of(&hi)?;
        for (row, &i) in rows.iter().enumerate() {
            // Pairing does not depend on damping; a lost pair contributes 0.
            let d = match (z1[i], z0[i]) {
                (Some(a), Some(b)) => a.0 - b.0,
                _ => 0.0,
            };
            a[row][k] = d;
        }
    }
    let t = bvls(&a, &b, 1e-13, 20_000);
    let mut out = base;
    for (k, &j) in free.iter().enumerate() {
        out[j] = params[j].lower + t[k] * (params[j].upper - params[j].lower);
    }
    let res: f64 = a
        .iter()
        .zip(&b)
        .map(|(row, bi)| {
            let r: f64 = row.iter().zip(&t).map(|(x, y)| x * y).sum::<f64>() - bi;
            r * r
        })
        .sum();
    Ok(DampingFit {
        x: out,
        evaluations: 1 + free.len(),
        equations: rows.len(),
        rms_residual: (res / rows.len() as f64).sqrt(),
    })
}

/// min ½‖A t − b‖² subject to 0 ≤ t ≤ 1 (A is m × n, rows of length n).
///
/// First the unconstrained least-squares solution by the normal equations
/// (Gaussian elimination with partial pivoting); when it exists and lies in
/// the box it is the answer. Otherwise accelerated projected gradient
/// (FISTA, step 1/L with L = ‖AᵀA‖_F ≥ λ_max) from its clamped value (or the
/// box centre) until the iterate moves by less than `tol` or after
/// `max_iter` iterations. Deterministic.
pub fn bvls(a: &[Vec<f64>], b: &[f64], tol: f64, max_iter: usize) -> Vec<f64> {
    let n = a.first().map_or(0, Vec::len);
    if n == 0 {
        return Vec::new();
    }
    let mut q = vec![vec![0.0; n]; n];
    let mut c = vec![0.0; n];
    for (row, bi) in a.iter().zip(b) {
        for i in 0..n {
            c[i] += row[i] * bi;
            for k in 0..n {
                q[i][k] += row[i] * row[k];
            }
        }
    }
    let start = match solve(&q, &c) {
        Some(t) if t.iter().all(|v| (0.0..=1.0).contains(v)) => return t,
        Some(t) => t.iter().map(|v| v.clamp(0.0, 1.0)).collect(),
        None => vec![0.5; n],
    };
    let l: f64 = q.iter().flatten().map(|v| v * v).sum::<f64>().sqrt();
    if l == 0.0 {
        return start;
    }
    let (mut t, mut y, mut s) = (start.clone(), start, 1.0f64);
    for _ in 0..max_iter {
        let grad: Vec<f64> = (0..n)
            .map(|i| (0..n).map(|k| q[i][k] * y[k]).sum::<f64>() - c[i])
            .collect();
        let next: Vec<f64> = (0..n)
            .map(|i| (y[i] - grad[i] / l).clamp(0.0, 1.0))
            .collect();
        let s_next = (1.0 + (1.0 + 4.0 * s * s).sqrt()) / 2.0;
        let moved = next
            .iter()
            .zip(&t)
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        y = (0..n)
            .map(|i| next[i] + (s - 1.0) / s_next * (next[i] - t[i]))
            .map(|v| v.clamp(0.0, 1.0))
            .collect();
        t = next;
        s = s_next;
        if moved < tol {
            break;
        }
    }
    t
}

/// Solve Q t = c by Gaussian elimination with partial pivoting; `None` when
/// Q is (numerically) singular.
fn solve(q: &[Vec<f64>], c: &[f64]) -> Option<Vec<f64>> {
    let n = c.len();
    let mut m: Vec<Vec<f64>> = q
        .iter()
        .zip(c)
        .map(|(row, ci)| row.iter().copied().chain([*ci]).collect())
        .collect();
    let scale = q.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
    for col in 0..n {
        let piv = (col..n).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))?;
        if m[piv][col].abs() <= 1e-12 * scale {
            return None;
        }
        m.swap(col, piv);
        let pivot_row = m[col].clone();
        for row in m.iter_mut().skip(col + 1) {
            let f = row[col] / pivot_row[col];
            for (v, p) in row.iter_mut().zip(&pivot_row).skip(col) {
                *v -= f * p;
            }
        }
    }
    let mut t = vec![0.0; n];
    for i in (0..n).rev() {
        let s: f64 = (i + 1..n).map(|k| m[i][k] * t[k]).sum();
        t[i] = (m[i][n] - s) / m[i][i];
    }
    Some(t)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::identify::black_box::tests::{objective, truth};

    #[test]
    fn bvls_known_answers() {
        // Interior solution: exact.
        let a = vec![vec![2.0, 0.0], vec![0.0, 4.0], vec![1.0, 1.0]];
        let t = bvls(&a, &[1.0, 1.0, 0.75], 1e-14, 1000);
        assert!(
            (t[0] - 0.5).abs() < 1e-12 && (t[1] - 0.25).abs() < 1e-12,
            "{t:?}"
        );
        // Unconstrained optimum t = (2, 0.25) → t0 clamps at 1, t1 stays 0.25.
        let t = bvls(&[vec![1.0, 0.0], vec![0.0, 1.0]], &[2.0, 0.25], 1e-14, 1000);
        assert!(
            (t[0] - 1.0).abs() < 1e-12 && (t[1] - 0.25).abs() < 1e-9,
            "{t:?}"
        );
        // Coupled: min (t0 + t1 − 3)² + (t0 − t1)² → (1, 1) on the corner.
        let t = bvls(&[vec![1.0, 1.0], vec![1.0, -1.0]], &[3.0, 0.0], 1e-14, 5000);
        assert!(
            (t[0] - 1.0).abs() < 1e-9 && (t[1] - 1.0).abs() < 1e-9,
            "{t:?}"
        );
    }

    #[test]
    fn damping_is_recovered_at_the_true_stiffness() {
        let o = objective();
        let t = truth();
        // Start with every damper at the file's nominal value; free three of
        // the four (three modes give three equations), the fourth at truth.
        let mut x = t.clone();
        let nominal = o.nominal();
        x[4..7].copy_from_slice(&nominal[4..7]);
        let fit = identify_damping(&o, &x, &[4, 5, 6]).unwrap();
        assert_eq!(fit.equations, 3);
        for (j, tj) in t.iter().enumerate().take(7).skip(4) {
            let rel = (fit.x[j] - tj).abs() / tj;
            assert!(rel < 1e-6, "damper {j}: {} vs {tj} ({rel})", fit.x[j]);
        }
        assert!(fit.rms_residual < 1e-12);
        assert!(o.cost(&fit.x) < 1e-9);
    }
}
