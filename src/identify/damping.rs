//! Damping parameters by bounded linear least squares (PUB3, second step).
//!
//! For fixed stiffness the mode shapes and frequencies do not depend on the
//! damping, and the modal damping is linear in the damping parameters
//! (seed section 2.3.2, eq. 2.43/2.46 with mass-normalized shapes):
//! 2 ζ_r ω_r = Σ_j c_j (g_jᵀφ_r)² for viscous dampers, η_r ω_r² = Σ_j d_j
//! (g_jᵀφ_r)² for hysteretic ones. The damping ratio a model reports is
//! that of its pole ([`crate::dynamics::solve::mode_pole`]): ζ_r exactly
//! for viscous damping, and for hysteretic damping a function of η_r that
//! bends away from η_r/2 by up to 5 % at η = 0.4. So the fit is Gauss–Newton
//! on a linear model ζ(t) ≈ ζ(t₀) + A (t − t₀) in the unit box t of the free
//! parameters, solved within the bounds ([`bvls`]):
//!
//! 1. t₀ = 0 (every free parameter at its lower bound), column j of A the
//!    secant to its upper bound — exact for viscous damping;
//! 2. t₀ = the first solution, columns from steps of 5 % of the range —
//!    the correction for the pole's curvature.
//!
//! Each paired mode is one equation, weighted by 1/ζ_ref so the misfit is
//! relative (NDD, eq. 2.65), as the reference's damping uncertainty is.
//! Cost: 2 × (1 + number of free parameters) evaluations.

use super::{IdentifyError, ModalObjective};

/// Model evaluations a fit of `free` damping parameters costs: two
/// Gauss–Newton passes of 1 + `free` each (the budget reserves this).
pub fn evaluations(free: usize) -> usize {
    2 * (1 + free)
}

/// The fitted damping values and the fit's bookkeeping.
#[derive(Clone, Debug)]
pub struct DampingFit {
    /// All parameter values: `x` with the free damping parameters replaced.
    pub x: Vec<f64>,
    /// Model evaluations used.
    pub evaluations: usize,
    /// Paired modes used as equations.
    pub equations: usize,
    /// Root-mean-square relative damping-ratio residual at the solution.
    pub rms_residual: f64,
}

/// Model and reference damping ratios of every usable reference mode
/// (`None`: unpaired).
fn ratios(o: &ModalObjective, x: &[f64]) -> Result<Vec<Option<(f64, f64)>>, IdentifyError> {
    let all = o.matches(x)?;
    let mut out = Vec::new();
    for (p, ms) in all.iter().enumerate() {
        for (r, m) in ms.iter().enumerate() {
            out.push(m.map(|m| (m.damping_ratio, o.reference_damping(p, r))));
        }
    }
    Ok(out)
}

/// One Gauss–Newton step from the unit-box point `t0` of the free
/// parameters with steps `h` (signed, per parameter): the new `t` and the
/// weighted residual of the linear model at it.
fn step(
    o: &ModalObjective,
    x: &[f64],
    free: &[usize],
    t0: &[f64],
    h: &[f64],
) -> Result<(Vec<f64>, f64, usize), IdentifyError> {
    let params = o.parameters();
    let at = |t: &[f64]| -> Vec<f64> {
        let mut p = x.to_vec();
        for (k, &j) in free.iter().enumerate() {
            p[j] = params[j].lower + t[k].clamp(0.0, 1.0) * (params[j].upper - params[j].lower);
        }
        p
    };
    let z0 = ratios(o, &at(t0))?;
    let rows: Vec<usize> = (0..z0.len())
        .filter(|&i| z0[i].is_some_and(|(_, zr)| zr > 0.0))
        .collect();
    if rows.is_empty() {
        return Err(IdentifyError::Invalid(
            "no reference mode with a damping ratio pairs with a model mode at the identified stiffness; widen the pairing window".into(),
        ));
    }
    let weight = |i: usize| z0[i].map_or(0.0, |(_, zr)| 1.0 / zr);
    let mut a = vec![vec![0.0; free.len()]; rows.len()];
    for k in 0..free.len() {
        let mut t = t0.to_vec();
        t[k] += h[k];
        let z1 = ratios(o, &at(&t))?;
        for (row, &i) in rows.iter().enumerate() {
            // Pairing does not depend on damping; a lost pair contributes 0.
            if let (Some(p), Some(q)) = (z1[i], z0[i]) {
                a[row][k] = weight(i) * (p.0 - q.0) / h[k];
            }
        }
    }
    // A (t − t0) ≈ w (ζ_ref − ζ(t0))  ⇔  A t ≈ b with b = w(ζ_ref − ζ) + A t0.
    let b: Vec<f64> = rows
        .iter()
        .zip(&a)
        .map(|(&i, row)| {
            let (z, zr) = z0[i].unwrap_or((0.0, 0.0));
            weight(i) * (zr - z) + row.iter().zip(t0).map(|(x, y)| x * y).sum::<f64>()
        })
        .collect();
    let t = bvls(&a, &b, 1e-13, 20_000);
    let res: f64 = a
        .iter()
        .zip(&b)
        .map(|(row, bi)| {
            let r: f64 = row.iter().zip(&t).map(|(x, y)| x * y).sum::<f64>() - bi;
            r * r
        })
        .sum();
    Ok((t, (res / rows.len() as f64).sqrt(), rows.len()))
}

/// Fit the damping parameters `free` (indices into the model's parameters)
/// with all other values taken from `x`.
pub fn identify_damping(
    objective: &ModalObjective,
    x: &[f64],
    free: &[usize],
) -> Result<DampingFit, IdentifyError> {
    let params = objective.parameters();
    let n = free.len();
    let (t1, _, _) = step(objective, x, free, &vec![0.0; n], &vec![1.0; n])?;
    // Steps of 5 % of the range, inward from a bound.
    let h: Vec<f64> = t1
        .iter()
        .map(|&t| if t + 0.05 <= 1.0 { 0.05 } else { -0.05 })
        .collect();
    let (t, rms, equations) = step(objective, x, free, &t1, &h)?;
    let mut out = x.to_vec();
    for (k, &j) in free.iter().enumerate() {
        out[j] = params[j].lower + t[k] * (params[j].upper - params[j].lower);
    }
    Ok(DampingFit {
        x: out,
        evaluations: evaluations(n),
        equations,
        rms_residual: rms,
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
        assert!(fit.rms_residual < 1e-9);
        assert!(o.cost(&fit.x) < 1e-9);
        assert_eq!(fit.evaluations, 8);
        assert_eq!(evaluations(3), 8);
    }
}
