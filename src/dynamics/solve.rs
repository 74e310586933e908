//! One model evaluation: assemble the joint terms at given parameter values
//! onto the prepared body matrices, solve K φ = λ M φ (eq. 2.30, shift-invert
//! Cholesky reduction, [`crate::dynamics::eigen`]), mass-normalized
//! shapes (eq. 2.35), modal damping
//! (section 2.3.1/2.3.2) and shapes at the sensors. Cheap, `&self`,
//! sequential inside (`Par::Seq`), so callers parallelise batches with rayon
//! and results are bit-identical for any thread count.
#![allow(non_snake_case)]

use super::assembly::PreparedModel;
use super::error::DynamicsError;
use super::modal_damping::{damping_ratios, modal_diagonal};
use super::shift_invert::Workspace;
use crate::modal::{ModalModel, Mode};
use faer::linalg::matmul::matmul;
use faer::{Accum, Mat, Par};
use num_complex::Complex64;

/// Modes of one evaluation, ascending frequency.
#[derive(Debug, Clone)]
pub struct ModalSolution {
    /// Configuration index.
    pub config: usize,
    /// ω_r², rad²/s² (rigid-body modes clamped to 0).
    pub eigenvalues: Vec<f64>,
    /// Mass-normalized shapes at all DOFs (n × modes), Φᵀ M Φ = I.
    pub Phi: Mat<f64>,
    /// Shapes at the sensor DOFs (sensors × modes).
    pub sensor_shapes: Mat<f64>,
    /// Shapes at the excitation DOFs (excitations × modes).
    pub excitation_shapes: Mat<f64>,
    /// Viscous modal damping ratios ζ_r.
    pub zeta: Vec<f64>,
    /// Hysteretic loss factors η_r.
    pub eta: Vec<f64>,
}

impl ModalSolution {
    /// Natural frequencies |λ_r| / 2π of the modes' poles, Hz — the
    /// frequency an EMA of this model's FRFs estimates (see [`mode_pole`]);
    /// ω_r/2π exactly for viscous damping, ω_r (1 + η_r²)^{1/4}/2π for
    /// hysteretic.
    pub fn frequencies_hz(&self) -> Vec<f64> {
        self.pole_parts()
            .map(|(w, _)| w / (2.0 * std::f64::consts::PI))
            .collect()
    }

    /// Damping ratios −Re λ_r / |λ_r| of the modes' poles: ζ_r for viscous
    /// damping, ≈ ζ_r + η_r/2 with both.
    pub fn damping_ratios(&self) -> Vec<f64> {
        self.pole_parts().map(|(_, z)| z).collect()
    }

    /// (|λ_r|, −Re λ_r/|λ_r|) of every mode, in a form exact for viscous
    /// damping (η = 0 gives ω_r and ζ_r to the last bit, so a damper never
    /// moves a frequency by rounding): with s = √(1 − ζ² + jη) = a + jb,
    /// |λ|² = ω_r² (1 + 2ζb + (|s|² − (1 − ζ²))) and
    /// |s|² − (1 − ζ²) = η² / (|s|² + 1 − ζ²).
    fn pole_parts(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        self.eigenvalues
            .iter()
            .zip(self.zeta.iter().zip(&self.eta))
            .map(|(&l, (&z, &e))| {
                let s = Complex64::new(1.0 - z * z, e).sqrt();
                let excess = e * e / (s.norm_sqr() + 1.0 - z * z);
                let factor = (1.0 + 2.0 * z * s.im + excess).sqrt();
                let ratio = if factor > 0.0 {
                    (z + s.im) / factor
                } else {
                    0.0
                };
                (l.sqrt() * factor, ratio)
            })
    }

    /// Undamped natural frequencies ω_r / 2π, Hz.
    pub fn undamped_frequencies_hz(&self) -> Vec<f64> {
        self.eigenvalues
            .iter()
            .map(|l| l.sqrt() / (2.0 * std::f64::consts::PI))
            .collect()
    }

    /// The pole of each mode ([`mode_pole`]).
    pub fn poles(&self) -> Vec<Complex64> {
        self.eigenvalues
            .iter()
            .zip(self.zeta.iter().zip(&self.eta))
            .map(|(&l, (&z, &e))| mode_pole(l.sqrt(), z, e))
            .collect()
    }
}

/// The pole λ (rad/s, upper half-plane) of one mode's FRF term with
/// combined viscous and hysteretic modal damping (eq. 2.42/2.45),
///
/// 1 / (ω_r² − ω² + j(2 ζ_r ω ω_r + η_r ω_r²)),
///
/// whose denominator vanishes at ω = jζ_r ω_r + ω_r √(1 − ζ_r² + jη_r), so
/// λ = jω = −ζ_r ω_r + jω_r √(1 − ζ_r² + jη_r).
///
/// This is the one pole convention of modalflow: every mode a model reports
/// (synthesized truth, GSA outputs, identification) is given as the natural
/// frequency |λ| and damping ratio −Re λ/|λ| of this pole, because that is
/// what an EMA estimates from the FRFs — the frequency-domain FRFs of
/// `synthesize` have exactly this pole, and its simulated impact test uses
/// viscous impulse responses with this pole. For viscous damping it is the
/// textbook λ = −ζω_r + jω_r√(1−ζ²) (|λ| = ω_r); a hysteretic loss factor
/// η moves |λ| up by (1 + η²)^{1/4} — 0.25 % for the test bench's
/// elastomer mounts (η ≈ 0.1), a bias that would otherwise separate a
/// measurement from its own truth.
pub fn mode_pole(omega_r: f64, zeta: f64, eta: f64) -> Complex64 {
    let root = Complex64::new(1.0 - zeta * zeta, eta).sqrt();
    Complex64::new(-zeta * omega_r, 0.0) + Complex64::new(0.0, omega_r) * root
}

/// Which modes to keep.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ModeSelection {
    /// The lowest n modes.
    Lowest(usize),
    /// All modes with f_r ≤ this frequency, Hz.
    Below(f64),
    /// As `Below(hz)` where about `expected` modes lie below `hz` (a count
    /// at another point of the same model): the first solve asks for
    /// `expected` + ¼ + 2 modes instead of 16, so a band holding 18 modes
    /// costs one Lanczos run of 24 modes instead of one of 16, thrown away,
    /// and one of 32 (the FRF fits of the test bench: 2·200 Hz). The
    /// modes returned are the same set; a wrong guess costs time only.
    BelowAbout { hz: f64, expected: usize },
}

/// A B with `Par::Seq` (the `*` operator would use faer's global parallelism).
pub(crate) fn product(A: &Mat<f64>, B: &Mat<f64>) -> Mat<f64> {
    let mut C = Mat::zeros(A.nrows(), B.ncols());
    matmul(
        C.as_mut(),
        Accum::Replace,
        A.as_ref(),
        B.as_ref(),
        1.0,
        Par::Seq,
    );
    C
}

impl PreparedModel {
    /// The stiffness matrix K = K₀ + Σ k_i g_i g_iᵀ of a configuration at
    /// `values` (rank-one springs, see [`crate::dynamics::assembly`]), dense.
    pub fn stiffness(&self, config: usize, values: &[f64]) -> Result<Mat<f64>, DynamicsError> {
        let [_, K, _, _] = self.matrices(config, values)?;
        Ok(K)
    }

    /// Lowest `n_modes` modes of configuration `config` at `values`.
    pub fn evaluate(
        &self,
        config: usize,
        values: &[f64],
        n_modes: usize,
    ) -> Result<ModalSolution, DynamicsError> {
        self.evaluate_modes(config, values, ModeSelection::Lowest(n_modes))
    }

    /// Modes of configuration `config` at `values`, selected by `selection`:
    /// factor K_σ into this thread's workspace, shift-invert Lanczos (or the
    /// full eigensolver for many modes of a small dense model), a residual
    /// check of every mode, modal damping and the shapes at the sensors.
    pub fn evaluate_modes(
        &self,
        config: usize,
        values: &[f64],
        selection: ModeSelection,
    ) -> Result<ModalSolution, DynamicsError> {
        self.check_values(values)?;
        let c = self.config(config)?;
        let mut ws = self.scratch.take();
        let modes = self
            .modes_in(&mut ws, config, values, selection)
            .and_then(|(lambda, Phi)| {
                self.check_residuals(c, values, &lambda, &Phi, &mut ws)?;
                Ok((lambda, Phi))
            });
        self.scratch.put(ws);
        let (lambda, Phi) = modes?;
        let b = modal_diagonal(&c.viscous, values, &Phi);
        let mut d = modal_diagonal(&c.hysteretic, values, &Phi);
        // Material damping: diag(Φᵀ D₀ Φ) added to the joints' d_r.
        if self.storage.has_material_damping() {
            for (dr, m) in d.iter_mut().zip(self.storage.material_diagonal(&Phi)) {
                *dr += m;
            }
        }
        let (zeta, eta) = damping_ratios(&lambda, &b, &d);
        Ok(ModalSolution {
            config,
            sensor_shapes: product(&c.S, &Phi),
            excitation_shapes: product(&c.E, &Phi),
            eigenvalues: lambda,
            Phi,
            zeta,
            eta,
        })
    }

    fn modes_in(
        &self,
        ws: &mut Workspace,
        config: usize,
        values: &[f64],
        selection: ModeSelection,
    ) -> Result<(Vec<f64>, Mat<f64>), DynamicsError> {
        let c = self.config(config)?;
        let shift = self.shift();
        self.storage
            .factor(config, &c.stiffness, values, shift, ws, &self.dof_labels)?;
        // Modes with a finite frequency (massless DOFs have none).
        let n = self.storage.finite_modes();
        let (f, first) = match selection {
            ModeSelection::Lowest(m) => return self.storage.lowest(m, shift, &self.lanczos, ws),
            ModeSelection::Below(f) => (f, 16),
            ModeSelection::BelowAbout { hz, expected } => (hz, expected + expected / 4 + 2),
        };
        let limit = (2.0 * std::f64::consts::PI * f).powi(2);
        // Grow the count until a mode lies above the limit.
        let mut nev = first.min(n);
        loop {
            let (mut lambda, Phi) = self.storage.lowest(nev, shift, &self.lanczos, ws)?;
            if nev >= n || lambda.iter().any(|&l| l > limit) {
                let m = lambda.iter().take_while(|&&l| l <= limit).count();
                lambda.truncate(m);
                return Ok((lambda, Phi.subcols(0, m).to_owned()));
            }
            nev = (2 * nev).min(n);
        }
    }

    /// The modes as a [`ModalModel`] at the sensor DOFs.
    pub fn modal_model(&self, sol: &ModalSolution) -> Result<ModalModel, DynamicsError> {
        let c = self.config(sol.config)?;
        let f = sol.frequencies_hz();
        let damping = sol.damping_ratios();
        Ok(ModalModel {
            position: c.position.clone(),
            dofs: self.sensors.iter().map(|s| s.1).collect(),
            modes: (0..f.len())
                .map(|r| Mode {
                    frequency_hz: f[r],
                    damping_ratio: damping[r],
                    shape: (0..sol.sensor_shapes.nrows())
                        .map(|i| Complex64::new(sol.sensor_shapes[(i, r)], 0.0))
                        .collect(),
                })
                .collect(),
        })
    }

    /// [`PreparedModel::evaluate_modes`] for every configuration, in order.
    pub fn evaluate_all(
        &self,
        values: &[f64],
        selection: ModeSelection,
    ) -> Result<Vec<ModalSolution>, DynamicsError> {
        (0..self.configurations.len())
            .map(|c| self.evaluate_modes(c, values, selection))
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pole_parts_agree_with_the_pole_and_are_exact_for_viscous_damping() {
        let sol = |z: f64, e: f64| ModalSolution {
            config: 0,
            eigenvalues: vec![(2.0 * std::f64::consts::PI * 83.7).powi(2)],
            Phi: Mat::zeros(1, 1),
            sensor_shapes: Mat::zeros(1, 1),
            excitation_shapes: Mat::zeros(1, 1),
            zeta: vec![z],
            eta: vec![e],
        };
        for (z, e) in [(0.0, 0.0), (0.013, 0.0), (0.0, 0.1), (0.02, 0.08)] {
            let s = sol(z, e);
            let l = s.poles()[0];
            let f = s.frequencies_hz()[0];
            assert!((f * 2.0 * std::f64::consts::PI / l.norm() - 1.0).abs() < 1e-14);
            assert!((s.damping_ratios()[0] + l.re / l.norm()).abs() < 1e-14);
            if e == 0.0 {
                assert_eq!(f, s.undamped_frequencies_hz()[0]);
                assert_eq!(s.damping_ratios()[0], z);
            }
        }
    }

    #[test]
    fn the_pole_is_a_root_of_the_frf_denominator() {
        for (w, z, e) in [
            (100.0, 0.0, 0.0),
            (100.0, 0.03, 0.0),
            (250.0, 0.0, 0.1),
            (60.0, 0.02, 0.08),
        ] {
            let l = mode_pole(w, z, e);
            // ω = λ / j must zero ω_r² − ω² + j(2ζωω_r + ηω_r²).
            let om = l / Complex64::new(0.0, 1.0);
            let d =
                Complex64::new(w * w, e * w * w) - om * om + Complex64::new(0.0, 2.0 * z * w) * om;
            assert!(d.norm() < 1e-9 * w * w, "{d}");
            assert!(l.re <= 0.0 && l.im > 0.0);
        }
        // Viscous: |λ| = ω_r and ratio ζ exactly.
        let l = mode_pole(100.0, 0.05, 0.0);
        assert!((l.norm() - 100.0).abs() < 1e-12 && (-l.re / l.norm() - 0.05).abs() < 1e-15);
        // Hysteretic: |λ| = ω_r (1 + η²)^¼, ratio ≈ η/2.
        let l = mode_pole(100.0, 0.0, 0.1);
        assert!((l.norm() - 100.0 * 1.01f64.powf(0.25)).abs() < 1e-10);
        assert!((-l.re / l.norm() - 0.05).abs() < 5e-4);
    }

    fn assert_send_sync<T: Send + Sync>() {}

    /// GSA and optimizers share one prepared model across rayon workers.
    #[test]
    fn prepared_model_is_thread_safe() {
        assert_send_sync::<PreparedModel>();
        assert_send_sync::<ModalSolution>();
    }
}
