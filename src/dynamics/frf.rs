//! Frequency-response functions at sensor × excitation DOFs.
//!
//! * [`PreparedModel::frf_superposition`]: modal superposition with combined
//!   viscous and hysteretic modal damping (eq. 2.42 and 2.45 combined):
//!   α_jk(ω) = Σ_r φ_jr φ_kr / (ω_r² − ω² + j(2 ζ_r ω ω_r + η_r ω_r²)).
//!   Exact for proportional damping when all modes are kept.
//! * [`PreparedModel::frf_direct`]: (K + jD + jωB − ω²M) x = f solved per
//!   frequency line (eq. 2.27 harmonic), the reference for checks.
//!
//! Mobility and accelerance follow by multiplying with jω and −ω².
#![allow(non_snake_case)]

use super::assembly::PreparedModel;
use super::error::DynamicsError;
use super::solve::{mode_pole, ModalSolution};
use super::truncation::Truncation;
use crate::frf::{FrfChannel, FrfQuantity, FrfSet};
use faer::linalg::solvers::Solve;
use faer::Mat;
use num_complex::Complex64;

fn convert(alpha: Complex64, w: f64, q: FrfQuantity) -> Complex64 {
    match q {
        FrfQuantity::Receptance => alpha,
        FrfQuantity::Mobility => alpha * Complex64::new(0.0, w),
        FrfQuantity::Accelerance => alpha * (-w * w),
    }
}

fn check_grid(f: &[f64]) -> Result<(), DynamicsError> {
    let ok = f.iter().all(|x| x.is_finite() && *x >= 0.0) && f.windows(2).all(|w| w[0] < w[1]);
    if ok {
        Ok(())
    } else {
        Err(DynamicsError::Parameters {
            message: "frequency lines must be finite, ≥ 0 and strictly increasing".into(),
        })
    }
}

impl PreparedModel {
    fn empty_set(&self, config: usize, q: FrfQuantity, f: &[f64]) -> Result<FrfSet, DynamicsError> {
        let c = self.config(config)?;
        let mut channels = Vec::new();
        for (_, r) in &self.sensors {
            for (_, e) in &self.excitations {
                channels.push(FrfChannel {
                    response: *r,
                    reference: *e,
                    values: Vec::with_capacity(f.len()),
                    coherence: None,
                });
            }
        }
        Ok(FrfSet {
            position: c.position.clone(),
            quantity: q,
            frequencies_hz: f.to_vec(),
            channels,
        })
    }

    /// FRFs by modal superposition of `sol`'s modes (all sensor × excitation
    /// pairs, sensor-major). A rigid-body mode contributes nothing at 0 Hz.
    pub fn frf_superposition(
        &self,
        sol: &ModalSolution,
        quantity: FrfQuantity,
        frequencies_hz: &[f64],
    ) -> Result<FrfSet, DynamicsError> {
        check_grid(frequencies_hz)?;
        let mut set = self.empty_set(sol.config, quantity, frequencies_hz)?;
        let ne = self.excitations.len().max(1);
        let pairs: Vec<(usize, usize)> =
            (0..set.channels.len()).map(|c| (c / ne, c % ne)).collect();
        let values = superposition(sol, quantity, frequencies_hz, &pairs, None);
        for (ch, v) in set.channels.iter_mut().zip(values) {
            ch.values = v;
        }
        Ok(set)
    }

    /// FRFs by direct solution of (K + jD + jωB − ω²M) x = f (dense LU per line).
    pub fn frf_direct(
        &self,
        config: usize,
        values: &[f64],
        quantity: FrfQuantity,
        frequencies_hz: &[f64],
    ) -> Result<FrfSet, DynamicsError> {
        check_grid(frequencies_hz)?;
        let [M, K, B, D] = self.matrices(config, values)?;
        let c = self.config(config)?;
        let mut set = self.empty_set(config, quantity, frequencies_hz)?;
        let n = self.n_dofs();
        let ne = self.excitations.len();
        let F = Mat::<Complex64>::from_fn(n, ne, |i, j| Complex64::new(c.E[(j, i)], 0.0));
        for &fhz in frequencies_hz {
            let w = 2.0 * std::f64::consts::PI * fhz;
            let Z = Mat::<Complex64>::from_fn(n, n, |i, j| {
                Complex64::new(K[(i, j)] - w * w * M[(i, j)], D[(i, j)] + w * B[(i, j)])
            });
            let X = Z.partial_piv_lu().solve(&F);
            for (ch_i, ch) in set.channels.iter_mut().enumerate() {
                let (j, k) = (ch_i / ne.max(1), ch_i % ne.max(1));
                let a: Complex64 = (0..n).map(|i| X[(i, k)] * c.S[(j, i)]).sum();
                ch.values.push(convert(a, w, quantity));
            }
        }
        Ok(set)
    }
}

/// Modal superposition (eq. 2.42 with 2.45) of `sol` at `frequencies_hz` for
/// the (sensor row, excitation row) `pairs`: one value vector per pair.
/// α_jk(ω) = Σ_r φ_jr φ_kr / (ω_r² − ω² + j(2 ζ_r ω ω_r + η_r ω_r²)); a mode
/// whose denominator vanishes (a rigid-body mode at 0 Hz) contributes nothing.
/// With `cut_after_s`, each mode's impulse response is cut that many
/// seconds after the hit, as an impact test's record without an exponential
/// window cuts it ([`super::truncation`]).
pub fn superposition(
    sol: &ModalSolution,
    quantity: FrfQuantity,
    frequencies_hz: &[f64],
    pairs: &[(usize, usize)],
    cut_after_s: Option<f64>,
) -> Vec<Vec<Complex64>> {
    superpose(sol, quantity, frequencies_hz, pairs, false, cut_after_s).0
}

/// [`superposition`] and, per pair and line, how far the value moves when
/// every natural frequency drifts by its own small relative amount δ_r
/// (independent, unit standard deviation): s(ω) = √(Σ_r |∂H_r/∂δ_r|²), so
/// a drift of relative standard deviation δ moves H by about δ·s(ω).
/// With D_r = ω_r² − ω² + j(2ζ_r ω ω_r + η_r ω_r²) and ω_r → ω_r(1 + δ_r),
/// ∂D_r/∂δ_r = 2ω_r² + j(2ζ_r ω ω_r + 2η_r ω_r²) and ∂H_r/∂δ_r =
/// −φ_jr φ_kr (∂D_r/∂δ_r)/D_r² (in the quantity's units). At a lightly damped
/// resonance s ≈ |H|/ζ_r: a drift of 10⁻⁴ moves a ζ = 0.06 % peak by a sixth.
pub fn superposition_with_drift(
    sol: &ModalSolution,
    quantity: FrfQuantity,
    frequencies_hz: &[f64],
    pairs: &[(usize, usize)],
    cut_after_s: Option<f64>,
) -> (Vec<Vec<Complex64>>, Vec<Vec<f64>>) {
    superpose(sol, quantity, frequencies_hz, pairs, true, cut_after_s)
}

/// The truncation of `sol`'s modes cut `after_s` seconds after the hit, in
/// `quantity` ([`super::truncation`]); `None` where no mode outlasts it.
fn truncation(sol: &ModalSolution, quantity: FrfQuantity, after_s: f64) -> Option<Truncation> {
    let poles: Vec<Option<Complex64>> = sol
        .eigenvalues
        .iter()
        .zip(sol.zeta.iter().zip(&sol.eta))
        .map(|(&l, (&z, &e))| (l > 0.0).then(|| mode_pole(l.sqrt(), z, e)))
        .collect();
    Some(Truncation::new(&poles, after_s, quantity.order())).filter(|t| !t.is_negligible())
}

fn superpose(
    sol: &ModalSolution,
    quantity: FrfQuantity,
    frequencies_hz: &[f64],
    pairs: &[(usize, usize)],
    drift: bool,
    cut_after_s: Option<f64>,
) -> (Vec<Vec<Complex64>>, Vec<Vec<f64>>) {
    let truncation = cut_after_s.and_then(|t| truncation(sol, quantity, t));
    let cut_modes: Vec<usize> = truncation.iter().flat_map(|t| t.modes()).collect();
    let mut cut = vec![Complex64::new(0.0, 0.0); cut_modes.len()];
    let mut out: Vec<Vec<Complex64>> = pairs
        .iter()
        .map(|_| Vec::with_capacity(frequencies_hz.len()))
        .collect();
    let mut spread: Vec<Vec<f64>> = pairs
        .iter()
        .map(|_| Vec::with_capacity(if drift { frequencies_hz.len() } else { 0 }))
        .collect();
    // φ_jr φ_kr per pair and mode, reused on every line.
    let residues: Vec<Vec<f64>> = pairs
        .iter()
        .map(|&(j, k)| {
            (0..sol.eigenvalues.len())
                .map(|r| sol.sensor_shapes[(j, r)] * sol.excitation_shapes[(k, r)])
                .collect()
        })
        .collect();
    let zero = Complex64::new(0.0, 0.0);
    let mut poles = vec![zero; sol.eigenvalues.len()];
    // ∂(1/D_r)/∂δ_r per mode (zero where 1/D_r is).
    let mut slopes = vec![zero; if drift { sol.eigenvalues.len() } else { 0 }];
    for &fhz in frequencies_hz {
        let w = 2.0 * std::f64::consts::PI * fhz;
        for (r, (&l, (&z, &e))) in sol
            .eigenvalues
            .iter()
            .zip(sol.zeta.iter().zip(&sol.eta))
            .enumerate()
        {
            let den = Complex64::new(l - w * w, 2.0 * z * w * l.sqrt() + e * l);
            poles[r] = if den.norm() == 0.0 { zero } else { den.inv() };
            if drift {
                let dden = Complex64::new(2.0 * l, 2.0 * z * w * l.sqrt() + 2.0 * e * l);
                slopes[r] = -dden * poles[r] * poles[r];
            }
        }
        if let Some(t) = &truncation {
            t.terms(w, &mut cut);
        }
        for (c, res) in residues.iter().enumerate() {
            let a: Complex64 = poles.iter().zip(res).map(|(p, r)| p * r).sum();
            // Only the few modes that outlast the record carry a term.
            let cut_a: Complex64 = cut.iter().zip(&cut_modes).map(|(t, &r)| t * res[r]).sum();
            out[c].push(convert(a, w, quantity) + cut_a);
            if drift {
                let s2: f64 = slopes
                    .iter()
                    .zip(res)
                    .map(|(d, r)| convert(d * r, w, quantity).norm_sqr())
                    .sum();
                spread[c].push(s2.sqrt());
            }
        }
    }
    (out, spread)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two modes (10 and 12 Hz; ζ 0.5 %, η 0.4 %) at one sensor and
    /// excitation.
    fn two_modes(w1: f64, w2: f64) -> ModalSolution {
        ModalSolution {
            config: 0,
            eigenvalues: vec![w1 * w1, w2 * w2],
            Phi: Mat::zeros(1, 2),
            sensor_shapes: Mat::from_fn(1, 2, |_, r| [0.8, -0.5][r]),
            excitation_shapes: Mat::from_fn(1, 2, |_, r| [0.3, 0.9][r]),
            zeta: vec![0.005, 0.005],
            eta: vec![0.004, 0.004],
        }
    }

    #[test]
    fn drift_spread_is_the_root_sum_square_of_each_modes_frequency_derivative() {
        let tau = 2.0 * std::f64::consts::PI;
        let (w1, w2) = (tau * 10.0, tau * 12.0);
        let lines = [9.0, 9.97, 10.0, 11.0, 12.02, 14.0];
        for q in [
            FrfQuantity::Receptance,
            FrfQuantity::Mobility,
            FrfQuantity::Accelerance,
        ] {
            let (h, s) = superposition_with_drift(&two_modes(w1, w2), q, &lines, &[(0, 0)], None);
            assert_eq!(
                h,
                superposition(&two_modes(w1, w2), q, &lines, &[(0, 0)], None)
            );
            // Central differences of H in each mode's relative frequency.
            let d = 1e-6;
            let diff = |a: &ModalSolution, b: &ModalSolution| -> Vec<Complex64> {
                let (ha, hb) = (
                    superposition(a, q, &lines, &[(0, 0)], None),
                    superposition(b, q, &lines, &[(0, 0)], None),
                );
                ha[0]
                    .iter()
                    .zip(&hb[0])
                    .map(|(x, y)| (x - y) / (2.0 * d))
                    .collect()
            };
            let d1 = diff(
                &two_modes(w1 * (1.0 + d), w2),
                &two_modes(w1 * (1.0 - d), w2),
            );
            let d2 = diff(
                &two_modes(w1, w2 * (1.0 + d)),
                &two_modes(w1, w2 * (1.0 - d)),
            );
            for k in 0..lines.len() {
                let want = (d1[k].norm_sqr() + d2[k].norm_sqr()).sqrt();
                assert!(
                    (s[0][k] - want).abs() <= 1e-6 * want,
                    "{q:?} line {}: {} vs {want}",
                    lines[k],
                    s[0][k]
                );
            }
            // At a lightly damped resonance the spread is about |H|/ζ.
            let ratio = s[0][2] / h[0][2].norm();
            assert!((60.0..300.0).contains(&ratio), "{q:?}: s/|H| = {ratio}");
        }
    }
}
