//! Finite-difference Jacobians of residual vectors in the unit box, each
//! evaluated as ONE batch (so a caller evaluates the stencil in parallel and
//! the result does not depend on the thread count).
//!
//! - [`forward`]: n points, error O(h) — Levenberg–Marquardt's per-step
//!   Jacobian, where a rough slope suffices.
//! - [`central`]: 2n points, error O(h²) and a roundoff floor of ε/h instead
//!   of √ε-scale truncation — for the identifiability analysis, which must
//!   tell an exactly parallel pair of parameters (singular value 0) from a
//!   weakly determined one (Nocedal & Wright, "Numerical Optimization",
//!   section 8.1).
//!
//! A step that would leave the box goes the other way (forward) or becomes
//! one-sided (central); a failed point gives a zero column.

/// Residual vectors of a batch of unit-box points (`None`: failed).
pub type Batch<'a> = dyn Fn(&[Vec<f64>]) -> Vec<Option<Vec<f64>>> + 'a;

/// Forward differences at `u` with residuals `r`: columns ∂r/∂u_j.
pub fn forward(residuals: &Batch, u: &[f64], r: &[f64], step: f64) -> Vec<Vec<f64>> {
    let (stencil, steps): (Vec<Vec<f64>>, Vec<f64>) =
        (0..u.len()).map(|j| forward_point(u, j, step)).unzip();
    residuals(&stencil)
        .into_iter()
        .zip(&steps)
        .map(|(rp, h)| difference(rp.as_deref(), Some(r), *h, r.len()))
        .collect()
}

/// Central differences at `u` (residuals `r` there, used where a side is
/// cut by the box): columns ∂r/∂u_j.
pub fn central(residuals: &Batch, u: &[f64], r: &[f64], step: f64) -> Vec<Vec<f64>> {
    let n = u.len();
    let (up, down): (Vec<f64>, Vec<f64>) = (0..n)
        .map(|j| ((1.0 - u[j]).min(step), u[j].min(step)))
        .unzip();
    let mut stencil: Vec<Vec<f64>> = (0..n).map(|j| shifted(u, j, up[j])).collect();
    stencil.extend((0..n).map(|j| shifted(u, j, -down[j])));
    let mut values = residuals(&stencil).into_iter();
    let plus: Vec<Option<Vec<f64>>> = values.by_ref().take(n).collect();
    let minus: Vec<Option<Vec<f64>>> = values.collect();
    (0..n)
        .map(|j| {
            let (a, b) = (plus[j].as_deref(), minus[j].as_deref());
            match (up[j] > 0.0, down[j] > 0.0) {
                (true, true) => {
                    let (a, b) = (a.unwrap_or(r), b.unwrap_or(r));
                    difference(Some(a), Some(b), up[j] + down[j], r.len())
                }
                (true, false) => difference(a, Some(r), up[j], r.len()),
                (false, true) => difference(Some(r), b, down[j], r.len()),
                (false, false) => vec![0.0; r.len()],
            }
        })
        .collect()
}

/// The forward-difference stencil point of column `j` at `u` and its
/// signed step (the other way where `u_j + step` would leave the box), for
/// a caller that evaluates it in a batch of its own.
pub fn forward_point(u: &[f64], j: usize, step: f64) -> (Vec<f64>, f64) {
    let h = if u[j] + step <= 1.0 { step } else { -step };
    (shifted(u, j, h), h)
}

/// Column ∂r/∂u_j from the residuals `rp` at [`forward_point`] (step `h`)
/// and `r` at `u`; zeros where the point failed.
pub fn forward_column(rp: Option<&[f64]>, r: &[f64], h: f64) -> Vec<f64> {
    difference(rp, Some(r), h, r.len())
}

fn shifted(u: &[f64], j: usize, h: f64) -> Vec<f64> {
    let mut p = u.to_vec();
    p[j] += h;
    p
}

/// (a − b)/h per component; zeros when a side failed or has the wrong size.
fn difference(a: Option<&[f64]>, b: Option<&[f64]>, h: f64, m: usize) -> Vec<f64> {
    match (a, b) {
        (Some(a), Some(b)) if a.len() == m && b.len() == m => a
            .iter()
            .zip(b)
            .map(|(x, y)| {
                let d = (x - y) / h;
                if d.is_finite() {
                    d
                } else {
                    0.0
                }
            })
            .collect(),
        _ => vec![0.0; m],
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn differences_of_a_known_map() {
        // r(u) = (u0², u0·u1, sin u1): J = [[2u0, 0], [u1, u0], [0, cos u1]].
        let f = |u: &[f64]| vec![u[0] * u[0], u[0] * u[1], u[1].sin()];
        let batch = |p: &[Vec<f64>]| p.iter().map(|u| Some(f(u))).collect::<Vec<_>>();
        let u = [0.3, 0.6];
        let r = f(&u);
        let exact = [vec![0.6, 0.6, 0.0], vec![0.0, 0.3, 0.6f64.cos()]];
        let fwd = forward(&batch, &u, &r, 1e-6);
        let cen = central(&batch, &u, &r, 1e-4);
        for j in 0..2 {
            for i in 0..3 {
                assert!((fwd[j][i] - exact[j][i]).abs() < 1e-5, "{fwd:?}");
                assert!((cen[j][i] - exact[j][i]).abs() < 1e-8, "{cen:?}");
            }
        }
        // At the upper bound the central stencil becomes one-sided (down).
        let u = [1.0, 0.6];
        let cen = central(&batch, &u, &f(&u), 1e-6);
        assert!((cen[0][0] - 2.0).abs() < 1e-5, "{cen:?}");
        // A failed point gives a zero column, not a NaN.
        let failing = |p: &[Vec<f64>]| {
            p.iter()
                .map(|u| (u[0] < 0.35).then(|| f(u)))
                .collect::<Vec<_>>()
        };
        let fwd = forward(&failing, &[0.349_999_9, 0.6], &f(&[0.349_999_9, 0.6]), 1e-6);
        assert_eq!(fwd[0], vec![0.0; 3]);
    }
}
