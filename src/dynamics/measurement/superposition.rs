//! Exact FRFs of a modal model by modal superposition: the continuous-time
//! receptance of eq. 2.45 (viscous modal damping), its conversion to
//! mobility/accelerance, and whole FRF sets on a frequency grid. The sampled
//! (discrete-time) counterparts are in [`super::sampled`].
//!
//! Shapes are taken as real mass-normalized vectors (`shape[i].re`), the
//! proportional-damping case of seed section 2.3.1.

use super::impact_params::dof_index;
use super::MeasurementError;
use crate::frf::{Dof, FrfChannel, FrfQuantity, FrfSet};
use crate::modal::ModalModel;
use num_complex::Complex64;
use std::f64::consts::PI;

/// Receptance α_jk(jω) at `f_hz` by modal superposition, eq. 2.45:
/// α_jk = Σ_r φ_jr φ_kr / (ω_r² − ω² + 2jζ_r ω_r ω), in m/N.
///
/// `response` and `reference` index `model.dofs`; panics if either is out of
/// range for a mode's shape (internal contract: callers resolve DOFs first).
pub fn receptance(model: &ModalModel, response: usize, reference: usize, f_hz: f64) -> Complex64 {
    let w = 2.0 * PI * f_hz;
    model
        .modes
        .iter()
        .map(|mode| {
            let wr = 2.0 * PI * mode.frequency_hz;
            let a = mode.shape[response].re * mode.shape[reference].re;
            let den = Complex64::new(wr * wr - w * w, 2.0 * mode.damping_ratio * wr * w);
            a / den
        })
        .sum()
}

/// Converts a receptance value at `f_hz` to `quantity`: mobility = jω·α,
/// accelerance = −ω²·α (FrfQuantity docs, eq. 2.42 derivatives).
pub fn convert_quantity(receptance: Complex64, f_hz: f64, quantity: FrfQuantity) -> Complex64 {
    let w = 2.0 * PI * f_hz;
    match quantity {
        FrfQuantity::Receptance => receptance,
        FrfQuantity::Mobility => receptance * Complex64::new(0.0, w),
        FrfQuantity::Accelerance => receptance * (-w * w),
    }
}

/// Exact FRFs of `model` on `frequencies_hz` by eq. 2.45 for every
/// (response, reference) pair, response-major, converted to `quantity`; no
/// coherence. Errors if a DOF is not in `model.dofs` or a shape is shorter
/// than the DOF list.
pub fn modal_frf_set(
    model: &ModalModel,
    references: &[Dof],
    responses: &[Dof],
    frequencies_hz: &[f64],
    quantity: FrfQuantity,
) -> Result<FrfSet, MeasurementError> {
    for (mode, m) in model.modes.iter().enumerate() {
        if m.shape.len() != model.dofs.len() {
            let reason = format!(
                "shape has {} entries for {} DOFs",
                m.shape.len(),
                model.dofs.len()
            );
            return Err(MeasurementError::InvalidMode { mode, reason });
        }
    }
    let mut channels = Vec::with_capacity(references.len() * responses.len());
    for &response in responses {
        let j = dof_index(model, response, "response")?;
        for &reference in references {
            let k = dof_index(model, reference, "reference")?;
            let values = frequencies_hz
                .iter()
                .map(|&f| convert_quantity(receptance(model, j, k, f), f, quantity))
                .collect();
            channels.push(FrfChannel {
                response,
                reference,
                values,
                coherence: None,
            });
        }
    }
    Ok(FrfSet {
        position: model.position.clone(),
        quantity,
        frequencies_hz: frequencies_hz.to_vec(),
        channels,
    })
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::frf::Dof;
    use crate::modal::Mode;

    /// Three modes at three DOFs with an orthonormal (mass-normalized for
    /// M = I) shape matrix, used by the measurement tests.
    pub(crate) fn three_mode_model() -> ModalModel {
        let s = |v: [f64; 3]| {
            v.iter()
                .map(|&x| Complex64::new(x, 0.0))
                .collect::<Vec<_>>()
        };
        let r2 = 0.5_f64.sqrt();
        let r3 = (1.0_f64 / 3.0).sqrt();
        let r6 = (1.0_f64 / 6.0).sqrt();
        ModalModel {
            dofs: (1..=3).map(|n| Dof::new(n, 3)).collect(),
            modes: vec![
                Mode {
                    frequency_hz: 62.0,
                    damping_ratio: 0.02,
                    shape: s([r3, r3, r3]),
                },
                Mode {
                    frequency_hz: 151.0,
                    damping_ratio: 0.015,
                    shape: s([r2, 0.0, -r2]),
                },
                Mode {
                    frequency_hz: 287.0,
                    damping_ratio: 0.025,
                    shape: s([r6, -2.0 * r6, r6]),
                },
            ],
            ..Default::default()
        }
    }

    #[test]
    fn receptance_sdof_known_values() {
        // One mode, unit residue: α(0) = 1/ω_r², α(f_r) = 1/(2jζω_r²).
        let m = ModalModel {
            dofs: vec![Dof::new(1, 1)],
            modes: vec![Mode {
                frequency_hz: 10.0,
                damping_ratio: 0.05,
                shape: vec![Complex64::new(1.0, 0.0)],
            }],
            ..Default::default()
        };
        let wr = 2.0 * PI * 10.0;
        let static_ = receptance(&m, 0, 0, 0.0);
        assert!((static_.re * wr * wr - 1.0).abs() < 1e-14 && static_.im == 0.0);
        let peak = receptance(&m, 0, 0, 10.0);
        let expected = Complex64::new(0.0, -1.0 / (2.0 * 0.05 * wr * wr));
        assert!((peak - expected).norm() < 1e-14 * expected.norm());
    }

    #[test]
    fn receptance_is_reciprocal() {
        let m = three_mode_model();
        for f in [0.0, 50.0, 151.0, 333.3] {
            assert_eq!(receptance(&m, 0, 2, f), receptance(&m, 2, 0, f));
        }
    }

    #[test]
    fn frf_set_matches_receptance() {
        let m = three_mode_model();
        let freqs = [0.0, 62.0, 100.0];
        let set = modal_frf_set(&m, &[m.dofs[0]], &m.dofs, &freqs, FrfQuantity::Mobility).unwrap();
        assert_eq!(set.channels.len(), 3);
        assert_eq!(set.channels[2].response, m.dofs[2]);
        let expected = convert_quantity(receptance(&m, 2, 0, 62.0), 62.0, FrfQuantity::Mobility);
        assert_eq!(set.channels[2].values[1], expected);
        let missing = modal_frf_set(
            &m,
            &[Dof::new(7, 1)],
            &m.dofs,
            &freqs,
            FrfQuantity::Receptance,
        );
        assert!(matches!(
            missing,
            Err(MeasurementError::UnknownDof {
                role: "reference",
                ..
            })
        ));
    }

    #[test]
    fn quantity_conversion() {
        let a = Complex64::new(1.0, 2.0);
        let w = 2.0 * PI * 5.0;
        assert_eq!(convert_quantity(a, 5.0, FrfQuantity::Receptance), a);
        assert!(
            (convert_quantity(a, 5.0, FrfQuantity::Mobility) - Complex64::new(-2.0 * w, w)).norm()
                < 1e-12
        );
        assert!((convert_quantity(a, 5.0, FrfQuantity::Accelerance) + a * w * w).norm() < 1e-12);
    }
}
