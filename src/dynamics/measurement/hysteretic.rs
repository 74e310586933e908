//! Hysteretic (structural) modal damping in a time-domain simulation.
//!
//! A mode with loss factor η has the receptance term
//! φ_jr φ_kr / (ω_r² − ω² + j(2ζ_r ω ω_r + η_r ω_r²)) (eq. 2.45 with
//! structural damping). Its impulse response is not causal, so an impact
//! test simulated in the time domain ([`super::simulate_impact_test`])
//! represents each mode by its complex pole λ_r = −ζ_p ω_p ± jω_p√(1 − ζ_p²)
//! instead: the viscous term φφ / (ω_p² − ω² + 2jζ_p ω_p ω), the same at
//! resonance but not beside it. With the test bench's elastomer mounts
//! (η ≈ 0.1) the two differ by 1–4 % over most lines and rotate the phase
//! at the peaks by up to 0.04 rad: a simulated "measurement" from outside
//! the model class it claims to test, which biased every stiffness of an
//! update on it by the same sign (identify 22's impact-test family).
//!
//! [`HystereticExcess`] is the difference of the two, per mode: the
//! simulation adds its product with the force spectrum to each response
//! (circular convolution on the internal block; the difference decays as
//! fast as the mode, well inside a record that holds the mode's own decay),
//! so H1 of the simulated test estimates the structure's receptance, not
//! its poles' viscous stand-in.

use crate::modal::ModalModel;
use num_complex::Complex64;
use std::f64::consts::PI;

/// Per mode of a [`ModalModel`], the structure's own damping terms: ω_r²
/// (the undamped eigenvalue), ζ_r and η_r.
#[derive(Clone, Debug, PartialEq)]
pub struct HystereticExcess {
    eigenvalues: Vec<f64>,
    zeta: Vec<f64>,
    eta: Vec<f64>,
}

impl HystereticExcess {
    /// From the eigenvalues ω_r² (rad²/s²), viscous ratios ζ_r and loss
    /// factors η_r of the modes, in the modal model's order; `None` when no
    /// mode has a loss factor (the pole is then the structure's, exactly),
    /// or the lengths differ.
    pub fn new(eigenvalues: &[f64], zeta: &[f64], eta: &[f64]) -> Option<Self> {
        let same = eigenvalues.len() == zeta.len() && zeta.len() == eta.len();
        (same && eta.iter().any(|&e| e != 0.0)).then(|| HystereticExcess {
            eigenvalues: eigenvalues.to_vec(),
            zeta: zeta.to_vec(),
            eta: eta.to_vec(),
        })
    }

    /// Number of modes.
    pub fn len(&self) -> usize {
        self.eta.len()
    }

    /// True without modes.
    pub fn is_empty(&self) -> bool {
        self.eta.is_empty()
    }

    /// The receptance of the structure minus that of `model`'s poles at
    /// `f_hz` for (`response`, `reference`) indices of `model.dofs`:
    /// Σ_r φ_jr φ_kr (1/D_r^struct − 1/D_r^pole) over the modes with η_r ≠ 0.
    pub fn receptance(
        &self,
        model: &ModalModel,
        response: usize,
        reference: usize,
        f_hz: f64,
    ) -> Complex64 {
        let w = 2.0 * PI * f_hz;
        let zero = Complex64::new(0.0, 0.0);
        model
            .modes
            .iter()
            .enumerate()
            .filter(|&(r, _)| self.eta.get(r).is_some_and(|&e| e != 0.0))
            .map(|(r, mode)| {
                let l = self.eigenvalues[r];
                let structure = Complex64::new(
                    l - w * w,
                    2.0 * self.zeta[r] * w * l.max(0.0).sqrt() + self.eta[r] * l,
                );
                let wp = 2.0 * PI * mode.frequency_hz;
                let pole = Complex64::new(wp * wp - w * w, 2.0 * mode.damping_ratio * wp * w);
                if structure.norm() == 0.0 || pole.norm() == 0.0 {
                    return zero;
                }
                mode.shape[response].re * mode.shape[reference].re * (structure.inv() - pole.inv())
            })
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frf::{Dof, Position};
    use crate::modal::Mode;

    /// One mode, ω_r = 2π·50, η = 0.1: the pole of the structural term is
    /// ω_r√(1 + jη) (ζ = 0), so its viscous stand-in has ω_p = ω_r(1 + η²)^¼
    /// and ζ_p = sin(atan(η)/2); the excess is the difference of the two
    /// terms written out by hand, zero for a viscous mode, and at resonance
    /// small against the term itself.
    #[test]
    fn the_excess_of_one_mode_by_hand() {
        let wr = 2.0 * PI * 50.0;
        let eta = 0.1f64;
        let wp = wr * (1.0 + eta * eta).powf(0.25);
        let zp = (eta.atan() / 2.0).sin();
        let model = ModalModel {
            position: Position::default(),
            dofs: vec![Dof::new(1, 3)],
            modes: vec![Mode {
                frequency_hz: wp / (2.0 * PI),
                damping_ratio: zp,
                shape: vec![Complex64::new(0.5, 0.0)],
            }],
        };
        let x = HystereticExcess::new(&[wr * wr], &[0.0], &[eta]).unwrap();
        for f in [10.0, 45.0, 50.0, 55.0, 120.0] {
            let w = 2.0 * PI * f;
            let structure = 0.25 / Complex64::new(wr * wr - w * w, eta * wr * wr);
            let pole = 0.25 / Complex64::new(wp * wp - w * w, 2.0 * zp * wp * w);
            let got = x.receptance(&model, 0, 0, f);
            assert!((got - (structure - pole)).norm() <= 1e-12 * structure.norm());
            if f == 10.0 {
                // Far below resonance the viscous stand-in loses the
                // structural term's constant phase: a few % of |H|.
                assert!(got.norm() > 0.02 * structure.norm(), "{got} {structure}");
            }
        }
        assert!(HystereticExcess::new(&[wr * wr], &[0.05], &[0.0]).is_none());
        assert!(HystereticExcess::new(&[wr * wr], &[0.05, 0.0], &[0.1]).is_none());
    }
}
