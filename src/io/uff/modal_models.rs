//! Conversion between datasets 55 (one per mode) and [`ModalModel`]s.
//!
//! **Import.** Mode datasets (analysis type 2 normal, 3/7 complex) are grouped
//! into models by load case id (record 7, first integer) and the
//! `position=<label>` ID line 4, as for the `frf` artifact; modes keep file
//! order. A node's values map to DOFs by the data characteristic: 1 scalar →
//! direction 0; 2 → +X, +Y, +Z; 3 → +X … +RZ. Normal modes give
//! `f = record 8 field 1` and `ζ` = viscous damping ratio (or hysteretic
//! loss factor / 2 when only that is given, η = 2ζ matching eq. 2.42 to
//! eq. 2.45 at resonance); complex modes give, from the pole λ in rad/s (a
//! root of the denominator of eq. 2.45, λ = −ζω̄ + jω̄√(1−ζ²)),
//! `f = |λ|/2π` and `ζ = −Re λ/|λ|`. Every mode of a model must cover the
//! same nodes.
//!
//! The exact frequency and damping ratio of ID line 5, when modalflow wrote
//! it, win over record 8's 6 digits ([`Uff55::exact_mode`]).
//!
//! **Export.** Each mode becomes a dataset 55: real shapes as normal modes,
//! complex shapes as complex modes with λ = −ζω + jω√(1−ζ²), ω = 2πf. DOFs
//! are gathered per node into 3 (or 6 if any rotation is present) values;
//! missing directions are 0 and a negative direction contributes its
//! negated value. With [`ShapeScaling::MassNormalized`] shapes (computed
//! modes, φᵀMφ = 1) the modal mass of a normal mode is 1 and the modal A of
//! a complex mode is 2jω_d (ω_d = Im λ): the first-order form
//! H = ψψᵀ/(A(jω − λ)) + c.c. of the receptance term
//! φφᵀ/(ω_r² − ω² + 2jζω_rω) (eq. 2.42) with ψ = φ, and modal B = −λA.
//! Shapes of arbitrary scale get 0 (not given), as the dataset defines.

use super::artifact::{escape_label, unescape_label, LABEL_KEY};
use super::ds55::{Uff55, Uff55Mode};
use super::ds58::{Ordinate, Precision};
use super::{UffDataset, UffFile, UffWarning};
use crate::frf::{Dof, Position};
use crate::io::error::{IoError, Location};
use crate::modal::{ModalModel, Mode, ShapeScaling};
use num_complex::Complex64;
use std::f64::consts::PI;

/// Modal models read from a file, with what was left out.
#[derive(Clone, Debug, PartialEq)]
pub struct ModalImport {
    pub models: Vec<ModalModel>,
    pub warnings: Vec<UffWarning>,
}

fn directions(data_characteristic: i64) -> Option<&'static [i8]> {
    match data_characteristic {
        1 => Some(&[0]),
        2 => Some(&[1, 2, 3]),
        3 => Some(&[1, 2, 3, 4, 5, 6]),
        _ => None,
    }
}

/// Builds modal models from the datasets 55 of `file`.
pub fn modal_models_from_uff(file: &UffFile, source: &str) -> Result<ModalImport, IoError> {
    let mut models: Vec<ModalModel> = Vec::new();
    let mut warnings: Vec<UffWarning> = Vec::new();
    for block in &file.blocks {
        let UffDataset::DataAtNodes(d) = &block.dataset else {
            continue;
        };
        let at = Location::new(source, block.at);
        let head = Location::new(source, block.record1);
        let (Some(mode), Some(dirs)) = (d.mode(), directions(d.data_characteristic)) else {
            note_unused(&mut warnings, d);
            continue;
        };
        if d.values_per_node != dirs.len() {
            return Err(IoError::InvalidField {
                at: head.record(6),
                field: "dataset 55 values per node (record 6 field 6)".into(),
                value: d.values_per_node.to_string(),
                expected: format!(
                    "{} for data characteristic {}",
                    dirs.len(),
                    d.data_characteristic
                ),
            });
        }
        let index = u32::try_from(d.load_case()).map_err(|_| IoError::InvalidField {
            at: head.record(7),
            field: "dataset 55 load case (record 7)".into(),
            value: d.load_case().to_string(),
            expected: "0 to 4294967295 (it numbers the position)".into(),
        })?;
        let label = d.id_lines[3]
            .strip_prefix(LABEL_KEY)
            .map(unescape_label)
            .unwrap_or_default();
        let position = Position { index, label };
        let (dofs, values) = shape_of(d, dirs, &at)?;
        let (frequency_hz, damping_ratio) = match mode {
            Uff55Mode::Normal {
                frequency_hz,
                viscous_damping_ratio,
                hysteretic_damping_ratio,
                ..
            } => {
                let zeta = if viscous_damping_ratio == 0.0 {
                    hysteretic_damping_ratio / 2.0
                } else {
                    viscous_damping_ratio
                };
                (frequency_hz, zeta)
            }
            Uff55Mode::Complex { eigenvalue, .. } => {
                let w = eigenvalue.norm();
                (
                    w / (2.0 * PI),
                    if w > 0.0 { -eigenvalue.re / w } else { 0.0 },
                )
            }
        };
        let (frequency_hz, damping_ratio) = d
            .exact_mode(frequency_hz, damping_ratio)
            .unwrap_or((frequency_hz, damping_ratio));
        let i = match models.iter().position(|m| m.position == position) {
            Some(i) => i,
            None => {
                models.push(ModalModel {
                    position,
                    dofs: dofs.clone(),
                    modes: Vec::new(),
                });
                models.len() - 1
            }
        };
        let model = &mut models[i];
        let mut shape = Vec::with_capacity(model.dofs.len());
        for dof in &model.dofs {
            let i = dofs
                .iter()
                .position(|d| d == dof)
                .ok_or_else(|| mismatch(&at, *dof, "lacks"))?;
            shape.push(values[i]);
        }
        if let Some(extra) = dofs.iter().find(|d| !model.dofs.contains(d)) {
            return Err(mismatch(&at, *extra, "adds"));
        }
        model.modes.push(Mode {
            frequency_hz,
            damping_ratio,
            shape,
        });
    }
    Ok(ModalImport { models, warnings })
}

fn mismatch(at: &Location, dof: Dof, verb: &str) -> IoError {
    IoError::InvalidField {
        at: at.clone(),
        field: "dataset 55 nodes".into(),
        value: format!("this mode {verb} DOF {dof}"),
        expected: "every mode of one position at the same nodes".into(),
    }
}

fn note_unused(warnings: &mut Vec<UffWarning>, d: &Uff55) {
    for w in warnings.iter_mut() {
        if let UffWarning::UnusedDataAtNodes {
            analysis_type,
            data_characteristic,
            count,
        } = w
        {
            if *analysis_type == d.analysis_type && *data_characteristic == d.data_characteristic {
                *count += 1;
                return;
            }
        }
    }
    warnings.push(UffWarning::UnusedDataAtNodes {
        analysis_type: d.analysis_type,
        data_characteristic: d.data_characteristic,
        count: 1,
    });
}

fn shape_of(d: &Uff55, dirs: &[i8], at: &Location) -> Result<(Vec<Dof>, Vec<Complex64>), IoError> {
    let values: Vec<Complex64> = match &d.values {
        Ordinate::Real(v) => v.iter().map(|&x| x.into()).collect(),
        Ordinate::Complex(v) => v.clone(),
    };
    let mut dofs = Vec::with_capacity(values.len());
    for &n in &d.nodes {
        let node = u32::try_from(n).map_err(|_| IoError::InvalidField {
            at: at.clone(),
            field: "dataset 55 node number".into(),
            value: n.to_string(),
            expected: "0 to 4294967295".into(),
        })?;
        dofs.extend(dirs.iter().map(|&dir| Dof::new(node, dir)));
    }
    Ok((dofs, values))
}

/// Datasets 55 for modal models whose shapes are scaled as `scaling` says
/// (module docs); fails for DOF lists a dataset 55 cannot hold.
pub fn uff55_from_modal_models(
    models: &[ModalModel],
    scaling: ShapeScaling,
) -> Result<Vec<Uff55>, IoError> {
    let known = scaling == ShapeScaling::MassNormalized;
    let mut out = Vec::new();
    for m in models {
        let (characteristic, per_node, nodes) = node_layout(m)?;
        for (k, mode) in m.modes.iter().enumerate() {
            let block = node_values(m, mode, k, &nodes, per_node)?;
            let (analysis_type, reals, values) = mode_records(mode, k, block, known)?;
            out.push(Uff55 {
                id_lines: [
                    format!("Mode {}", k + 1),
                    "modalflow".into(),
                    "NONE".into(),
                    format!("{LABEL_KEY}{}", escape_label(&m.position.label)),
                    super::ds55::exact_line(mode.frequency_hz, mode.damping_ratio),
                ],
                model_type: 1,
                analysis_type,
                data_characteristic: characteristic,
                specific_data_type: 8,
                precision: Precision::Double,
                values_per_node: per_node,
                integers: vec![i64::from(m.position.index), k as i64 + 1],
                reals,
                nodes: nodes.iter().map(|&n| i64::from(n)).collect(),
                values,
            });
        }
    }
    Ok(out)
}

/// How model `m`'s DOFs go into datasets 55: the data characteristic (1
/// scalar, 2 translations, 3 with rotations), the values per node and the
/// nodes in first-appearance order; scalar and directional DOFs mixed, or a
/// direction code beyond ±6, cannot be written.
fn node_layout(m: &ModalModel) -> Result<(i64, usize, Vec<u32>), IoError> {
    let scalar = m.dofs.iter().any(|d| d.direction == 0);
    let vector = m.dofs.iter().any(|d| d.direction != 0);
    if scalar && vector {
        return Err(IoError::Unwritable {
            what: format!(
                "position {}: scalar (direction 0) and directional DOFs in one dataset 55",
                m.position.index
            ),
        });
    }
    if let Some(d) = m.dofs.iter().find(|d| d.direction.unsigned_abs() > 6) {
        return Err(IoError::Unwritable {
            what: format!("DOF {d}: direction code beyond ±6"),
        });
    }
    let rotations = m.dofs.iter().any(|d| d.direction.unsigned_abs() > 3);
    let (characteristic, per_node) = match (scalar, rotations) {
        (true, _) => (1, 1),
        (false, false) => (2, 3),
        (false, true) => (3, 6),
    };
    let mut nodes: Vec<u32> = Vec::new();
    for d in &m.dofs {
        if !nodes.contains(&d.node) {
            nodes.push(d.node);
        }
    }
    Ok((characteristic, per_node, nodes))
}

/// Mode `k`'s shape gathered per node into `per_node` values: missing
/// directions are 0, a negative direction gives its negated value, and two
/// different values for one axis cannot be written.
fn node_values(
    m: &ModalModel,
    mode: &Mode,
    k: usize,
    nodes: &[u32],
    per_node: usize,
) -> Result<Vec<Complex64>, IoError> {
    let mut block = vec![Complex64::new(0.0, 0.0); nodes.len() * per_node];
    let mut set = vec![false; block.len()];
    for (dof, v) in m.dofs.iter().zip(&mode.shape) {
        let slot = nodes.iter().position(|&n| n == dof.node).unwrap_or(0) * per_node
            + usize::from(dof.direction.unsigned_abs().max(1))
            - 1;
        let v = if dof.direction < 0 { -v } else { *v };
        if set[slot] && block[slot] != v {
            return Err(IoError::Unwritable {
                what: format!(
                    "mode {} at DOF {dof}: two different values for one axis",
                    k + 1
                ),
            });
        }
        block[slot] = v;
        set[slot] = true;
    }
    Ok(block)
}

/// The analysis type, record 8 reals and values of mode `k` (node values
/// `block`): a normal mode (2) with f, modal mass and ζ, or a complex mode
/// (3) with λ, modal A and B (module docs); `known`: mass-normalized shapes.
fn mode_records(
    mode: &Mode,
    k: usize,
    block: Vec<Complex64>,
    known: bool,
) -> Result<(i64, Vec<f64>, Ordinate), IoError> {
    let complex = mode.shape.iter().any(|c| c.im != 0.0);
    Ok(if complex {
        let (w, z) = (2.0 * PI * mode.frequency_hz, mode.damping_ratio);
        if !(0.0..1.0).contains(&z) {
            return Err(IoError::Unwritable {
                what: format!(
                    "complex mode {} with damping ratio {z} outside [0, 1)",
                    k + 1
                ),
            });
        }
        let lambda = Complex64::new(-z * w, w * (1.0 - z * z).sqrt());
        let a = if known {
            Complex64::new(0.0, 2.0 * lambda.im)
        } else {
            Complex64::new(0.0, 0.0)
        };
        let b = -lambda * a;
        (
            3,
            vec![lambda.re, lambda.im, a.re, a.im, b.re, b.im],
            Ordinate::Complex(block),
        )
    } else {
        let mass = if known { 1.0 } else { 0.0 };
        let reals = vec![mode.frequency_hz, mass, mode.damping_ratio, 0.0];
        (
            2,
            reals,
            Ordinate::Real(block.iter().map(|c| c.re).collect()),
        )
    })
}
