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
    /// comparison space of MAC pairing, eq. 2.62): the same node and axis;
    /// where the two give the axis opposite signs (a test's −Z transducer
    /// against a model's +Z sensor) the second model's coefficient is
    /// negated, so the shapes compare in the first model's directions. An
    /// exact match wins over an opposite one.
    pub fn shared_shapes(&self, other: &ModalModel) -> SharedShapes {
        let idx: Vec<(usize, usize, f64)> = self
            .dofs
            .iter()
            .enumerate()
            .filter_map(|(i, d)| {
                let exact = other.dofs.iter().position(|x| x == d);
                let opposite = || {
                    other.dofs.iter().position(|x| {
                        x.node == d.node && d.direction != 0 && x.direction == -d.direction
                    })
                };
                match exact {
                    Some(j) => Some((i, j, 1.0)),
                    None => opposite().map(|j| (i, j, -1.0)),
                }
            })
            .collect();
        let pick = |m: &ModalModel, first: bool| -> Vec<Vec<Complex64>> {
            m.modes
                .iter()
                .map(|mode| {
                    idx.iter()
                        .map(|&(i, j, sign)| {
                            if first {
                                mode.shape[i]
                            } else {
                                mode.shape[j] * sign
                            }
                        })
                        .collect()
                })
                .collect()
        };
        SharedShapes {
            first: pick(self, true),
            second: pick(other, false),
            dofs: idx.iter().map(|p| self.dofs[p.0]).collect(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(dofs: &[(u32, i8)], shape: &[f64]) -> ModalModel {
        ModalModel {
            position: Position::default(),
            dofs: dofs.iter().map(|&(n, d)| Dof::new(n, d)).collect(),
            modes: vec![Mode {
                frequency_hz: 10.0,
                damping_ratio: 0.01,
                shape: shape.iter().map(|&x| Complex64::new(x, 0.0)).collect(),
            }],
        }
    }

    /// A −Z test DOF pairs with the model's +Z sensor at the same node with
    /// its sign flipped (MAC 1 for the same physical motion); other nodes
    /// and axes do not pair.
    #[test]
    fn opposite_directions_pair_with_a_sign_flip() {
        let test = model(&[(3, -3), (4, -3), (5, 1)], &[1.0, -2.0, 7.0]);
        let fe = model(&[(4, 3), (3, 3), (6, 1)], &[2.0, -1.0, 7.0]);
        let s = test.shared_shapes(&fe);
        assert_eq!(s.dofs, vec![Dof::new(3, -3), Dof::new(4, -3)]);
        assert_eq!(
            s.first[0],
            vec![Complex64::new(1.0, 0.0), Complex64::new(-2.0, 0.0)]
        );
        assert_eq!(
            s.second[0],
            vec![Complex64::new(1.0, 0.0), Complex64::new(-2.0, 0.0)]
        );
        // Exact matches win over opposite ones.
        let both = model(&[(3, 3), (3, -3)], &[5.0, 9.0]);
        let s = model(&[(3, 3)], &[1.0]).shared_shapes(&both);
        assert_eq!(s.second[0], vec![Complex64::new(5.0, 0.0)]);
    }
}
