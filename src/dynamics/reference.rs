//! Matching a reference modal model (measured or synthesized modes) to a
//! prepared model: which configuration its position is, and which sensor
//! row (with which sign) each of its DOFs corresponds to. GSA outputs and
//! the identification objective compare model and reference shapes on these
//! shared DOFs.

use super::PreparedModel;
use crate::frf::Dof;
use crate::modal::ModalModel;

/// How a reference's DOFs map onto a configuration's sensors.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceMatch {
    /// Configuration index of the reference's position.
    pub config: usize,
    /// Per shared DOF: the model's sensor row and the sign (−1 when the
    /// reference measured the opposite direction).
    pub rows: Vec<(usize, f64)>,
    /// Index into the reference's DOFs of each shared DOF, parallel to `rows`.
    pub keep: Vec<usize>,
}

/// The row of `d` among `dofs` (a model's sensors or excitations) by node and
/// axis, and the sign: −1 when `d` points the opposite way.
pub fn dof_row(dofs: &[(String, Dof)], d: Dof) -> Option<(usize, f64)> {
    let i = dofs
        .iter()
        .position(|(_, s)| s.node == d.node && s.direction.abs() == d.direction.abs())?;
    Some((
        i,
        if dofs[i].1.direction == d.direction {
            1.0
        } else {
            -1.0
        },
    ))
}

impl PreparedModel {
    /// The configuration whose position has index `index`.
    pub fn config_of_position(&self, index: u32) -> Option<usize> {
        self.configurations
            .iter()
            .position(|c| c.position.index == index)
    }

    /// Match `reference` to this model; an error says what does not fit.
    pub fn match_reference(&self, reference: &ModalModel) -> Result<ReferenceMatch, String> {
        let r = reference;
        let config = self.config_of_position(r.position.index).ok_or_else(|| {
            format!(
                "reference position {} ({}) is not a configuration of the model, which has {}",
                r.position.index,
                r.position.label,
                self.configurations.len()
            )
        })?;
        let mut rows = Vec::new();
        let mut keep = Vec::new();
        for (k, d) in r.dofs.iter().enumerate() {
            if let Some(row) = dof_row(&self.sensors, *d) {
                rows.push(row);
                keep.push(k);
            }
        }
        if rows.is_empty() {
            return Err(format!(
                "reference position {} shares no DOF with the model's sensors; check node numbers and directions",
                r.position.index
            ));
        }
        Ok(ReferenceMatch { config, rows, keep })
    }
}
