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
use super::solve::ModalSolution;
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
        let values = superposition(sol, quantity, frequencies_hz, &pairs);
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
pub fn superposition(
    sol: &ModalSolution,
    quantity: FrfQuantity,
    frequencies_hz: &[f64],
    pairs: &[(usize, usize)],
) -> Vec<Vec<Complex64>> {
    let mut out: Vec<Vec<Complex64>> = pairs
        .iter()
        .map(|_| Vec::with_capacity(frequencies_hz.len()))
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
    let mut poles = vec![Complex64::new(0.0, 0.0); sol.eigenvalues.len()];
    for &fhz in frequencies_hz {
        let w = 2.0 * std::f64::consts::PI * fhz;
        for (p, (&l, (&z, &e))) in poles
            .iter_mut()
            .zip(sol.eigenvalues.iter().zip(sol.zeta.iter().zip(&sol.eta)))
        {
            let den = Complex64::new(l - w * w, 2.0 * z * w * l.sqrt() + e * l);
            *p = if den.norm() == 0.0 {
                Complex64::new(0.0, 0.0)
            } else {
                den.inv()
            };
        }
        for (values, res) in out.iter_mut().zip(&residues) {
            let a: Complex64 = poles.iter().zip(res).map(|(p, r)| p * r).sum();
            values.push(convert(a, w, quantity));
        }
    }
    out
}
