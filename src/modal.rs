//! Modal models: the identified or computed modes of one configuration, the
//! `modes` artifact (`modes.csv` + `mode_shapes.csv`) in memory.

use crate::frf::{Dof, Position};
use num_complex::Complex64;

/// One mode: natural frequency, damping and shape at the model's DOFs.
#[derive(Clone, Debug, PartialEq)]
pub struct Mode {
    /// Undamped natural frequency f_r = ω_r / 2π in Hz.
    pub frequency_hz: f64,
    /// Viscous modal damping ratio ζ_r (equivalent ratio η_r/2 for hysteretic damping).
    pub damping_ratio: f64,
    /// Shape coefficients in the order of [`ModalModel::dofs`]; mass-normalized
    /// for computed modes, arbitrary scale for identified ones.
    pub shape: Vec<Complex64>,
}

/// The modes of one configuration at a common list of DOFs.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ModalModel {
    pub position: Position,
    pub dofs: Vec<Dof>,
    pub modes: Vec<Mode>,
}
