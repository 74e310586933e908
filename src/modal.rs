//! Modal models: the identified or computed modes of one configuration, the
//! `modes` artifact (`modes.csv` + `mode_shapes.csv`) in memory.

use crate::frf::{Dof, Position};
use num_complex::Complex64;

/// One mode: natural frequency, damping and shape at the model's DOFs.
#[derive(Clone, Debug, PartialEq)]
pub struct Mode {
    /// Undamped natural frequency f_r = ω_r / 2π in Hz.
    pub frequency_hz: f64,
    /// Viscous modal damping ratio ζ_r (equivalent ratio η_r/2 for hysteretic
    /// damping); NaN when not given (imported reference modes).
    pub damping_ratio: f64,
    /// Shape coefficients in the order of [`ModalModel::dofs`]; mass-normalized
    /// for computed modes, arbitrary scale for identified ones.
    pub shape: Vec<Complex64>,
}

/// How the shapes of a modal model are scaled: known mass-normalized
/// (φᵀMφ = 1 over the whole model, so modal mass 1 kg), as computed modes
/// are, or an arbitrary scale (identified shapes, unit-normalized).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ShapeScaling {
    #[default]
    Arbitrary,
    MassNormalized,
}

/// The modes of one configuration at a common list of DOFs.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ModalModel {
    pub position: Position,
    pub dofs: Vec<Dof>,
    pub modes: Vec<Mode>,
}

/// Mode shapes of two modal models on the DOFs both have.
pub struct SharedShapes {
    /// Per mode of the first model: its shape on the shared DOFs.
    pub first: Vec<Vec<Complex64>>,
    /// Per mode of the second model, likewise.
    pub second: Vec<Vec<Complex64>>,
    /// The shared DOFs, in the first model's order.
    pub dofs: Vec<Dof>,
}

impl ModalModel {
    /// Shapes of `self` and `other` restricted to the DOFs both have (the
    /// comparison space of MAC pairing, eq. 2.62).
    pub fn shared_shapes(&self, other: &ModalModel) -> SharedShapes {
        let idx: Vec<(usize, usize)> = self
            .dofs
            .iter()
            .enumerate()
            .filter_map(|(i, d)| other.dofs.iter().position(|x| x == d).map(|j| (i, j)))
            .collect();
        let pick = |m: &ModalModel, col: fn(&(usize, usize)) -> usize| -> Vec<Vec<Complex64>> {
            m.modes
                .iter()
                .map(|mode| idx.iter().map(|p| mode.shape[col(p)]).collect())
                .collect()
        };
        SharedShapes {
            first: pick(self, |p| p.0),
            second: pick(other, |p| p.1),
            dofs: idx.iter().map(|p| self.dofs[p.0]).collect(),
        }
    }
}
