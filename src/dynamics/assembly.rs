//! Assembly of the equation of motion M ü + B u̇ + (K + jD) u = f (eq. 2.27)
//! in the (reduced) body DOFs, split for cheap re-evaluation:
//!
//! * bodies (rigid mass matrices, beams, super-elements, Craig-Bampton
//!   reductions) give block-diagonal M and K₀ that do not depend on any
//!   parameter; they are reduced and assembled once in [`PreparedModel::new`];
//! * every scalar joint connection is rank one, K_j = k g gᵀ with the
//!   connection vector g = P_aᵀ c − P_bᵀ c (P = rigid point rows, c = the
//!   connection's weights in global axes); per configuration we store the
//!   columns G, so an evaluation only forms K₀ + G diag(k) Gᵀ (and the modal
//!   damping needs only Gᵀ Φ).
#![allow(non_snake_case)]

use super::configuration::{axis_states, locate, locate_b, Location};
use super::craig_bampton::craig_bampton;
use super::eigen::{cholesky, DEFAULT_SHIFT};
use super::error::DynamicsError;
use super::model::{BodyKind, End, Model, Parameter};
use super::model_file::DampingModel;
use super::rigid::{offset_map, rigid_mass};
use crate::frf::{Dof, Position};
use faer::Mat;
use std::collections::BTreeSet;

/// One body in the global DOF vector.
#[derive(Debug, Clone)]
struct PreparedBody {
    offset: usize,
    n: usize,
    /// Full → reduced map of an FE body (`None`: rigid, or FE without reduction).
    T: Option<Mat<f64>>,
}

/// Rank-one joint terms of one damping/stiffness kind: sparse columns g_i
/// as (row, value) lists (the matrix is Σ_i p_i g_i g_iᵀ; a g has at most
/// 12 non-zeros when its ends are rigid bodies or boundary nodes) and the
/// parameter index p of each column.
#[derive(Debug, Clone)]
pub struct JointTerms {
    pub columns: Vec<Vec<(usize, f64)>>,
    pub params: Vec<usize>,
}

impl JointTerms {
    /// Add Σ_i values[p_i] g_i g_iᵀ to `A`.
    pub fn add_to(&self, A: &mut Mat<f64>, values: &[f64]) {
        for (g, &p) in self.columns.iter().zip(&self.params) {
            let v = values[p];
            for &(i, gi) in g {
                for &(j, gj) in g {
                    A[(i, j)] += v * gi * gj;
                }
            }
        }
    }

    /// Gᵀ Φ (columns × modes).
    pub fn project(&self, Phi: &Mat<f64>) -> Mat<f64> {
        Mat::from_fn(self.columns.len(), Phi.ncols(), |c, r| {
            self.columns[c].iter().map(|&(i, g)| g * Phi[(i, r)]).sum()
        })
    }
}

/// One model configuration (axis position): its joint terms and output rows.
#[derive(Debug, Clone)]
pub struct Configuration {
    pub position: Position,
    /// Springs (K).
    pub stiffness: JointTerms,
    /// Viscous dampers (B, eq. 2.50).
    pub viscous: JointTerms,
    /// Hysteretic dampers (D, eq. 2.51).
    pub hysteretic: JointTerms,
    /// Sensor rows (n_sensors × n): response = S u.
    pub S: Mat<f64>,
    /// Excitation rows (n_excitations × n): generalized force = Eᵀ f.
    pub E: Mat<f64>,
}

/// A model ready for fast evaluation: reductions, factorization and
/// configurations computed once; see [`PreparedModel::evaluate`].
#[derive(Debug, Clone)]
pub struct PreparedModel {
    pub parameters: Vec<Parameter>,
    pub sensors: Vec<(String, Dof)>,
    pub excitations: Vec<(String, Dof)>,
    pub configurations: Vec<Configuration>,
    /// Human-readable label of every DOF (`bed.node3.y`, `bed.cb2`).
    pub dof_labels: Vec<String>,
    /// Assembled body mass and stiffness (no joints).
    pub M: Mat<f64>,
    pub K0: Mat<f64>,
    /// Material hysteretic damping of the bodies, Σ η_b K_b (eq. 2.51);
    /// `None` when every loss factor is zero.
    pub D0: Option<Mat<f64>>,
    /// Cholesky factor C of M = C Cᵀ.
    pub M_chol: Mat<f64>,
    /// K₀ + σ M.
    K0_shifted: Mat<f64>,
    /// Shift σ of the shift-invert eigensolver, rad²/s²
    /// ([`crate::dynamics::eigen`]).
    shift: f64,
    bodies: Vec<PreparedBody>,
}

const AXES: [&str; 6] = ["x", "y", "z", "rx", "ry", "rz"];

impl PreparedModel {
    /// Reduce bodies, assemble, factor M and set up all configurations,
    /// with the default eigensolver shift σ = (2π · 1 Hz)².
    pub fn new(model: &Model) -> Result<PreparedModel, DynamicsError> {
        PreparedModel::with_shift(model, DEFAULT_SHIFT)
    }

    /// As [`PreparedModel::new`] with shift σ > 0 (rad²/s²): choose σ below
    /// the lowest elastic eigenvalue of interest.
    pub fn with_shift(model: &Model, shift: f64) -> Result<PreparedModel, DynamicsError> {
        if !(shift.is_finite() && shift > 0.0) {
            return Err(DynamicsError::Parameters {
                message: format!("eigensolver shift must be finite and > 0, got {shift}"),
            });
        }
        let states = axis_states(model);
        // Nodes of each FE body used anywhere → Craig-Bampton boundary.
        let mut used: Vec<BTreeSet<usize>> = vec![BTreeSet::new(); model.bodies.len()];
        let mut mark = |end: &End, loc: Location| {
            if let Location::Node(n, _) = loc {
                used[end.body].insert(n);
            }
        };
        for st in &states {
            for (ji, j) in model.joints.iter().enumerate() {
                mark(&j.a, locate(model, st, &j.a));
                if let Some(b) = &j.b {
                    mark(b, locate_b(model, st, ji, b));
                }
            }
            for p in model.sensors.iter().chain(&model.excitations) {
                mark(&p.end, locate(model, st, &p.end));
            }
        }
        let mut bodies = Vec::new();
        let mut blocks: Vec<(Mat<f64>, Mat<f64>, f64)> = Vec::new();
        let mut dof_labels = Vec::new();
        let mut offset = 0;
        for (bi, body) in model.bodies.iter().enumerate() {
            let eta = match &body.kind {
                BodyKind::Fe { loss_factor, .. } => *loss_factor,
                BodyKind::Rigid { .. } => 0.0,
            };
            let (M, K, T) = match &body.kind {
                BodyKind::Rigid {
                    mass,
                    inertia,
                    dofs,
                    ..
                } => {
                    dof_labels.extend(dofs.iter().map(|&a| format!("{}.{}", body.name, AXES[a])));
                    let full = rigid_mass(*mass, inertia);
                    let n = dofs.len();
                    (
                        Mat::from_fn(n, n, |i, j| full[(dofs[i], dofs[j])]),
                        Mat::zeros(n, n),
                        None,
                    )
                }
                BodyKind::Fe {
                    fe, modes: Some(q), ..
                } => {
                    let boundary: Vec<usize> =
                        used[bi].iter().flat_map(|&n| fe.node_dofs(n)).collect();
                    for &n in &used[bi] {
                        let id = fe.nodes[n].id;
                        for (j, d) in fe.nodes[n].dofs.iter().enumerate() {
                            if d.is_some() {
                                dof_labels.push(format!("{}.node{id}.{}", body.name, AXES[j]));
                            }
                        }
                    }
                    let r = craig_bampton(&fe.K, &fe.M, &boundary, *q, &body.name)?;
                    let nq = r.M.nrows() - boundary.len();
                    dof_labels.extend((0..nq).map(|i| format!("{}.cb{i}", body.name)));
                    (r.M, r.K, Some(r.T))
                }
                BodyKind::Fe {
                    fe, modes: None, ..
                } => {
                    let mut labels = vec![String::new(); fe.M.nrows()];
                    for (i, l) in labels.iter_mut().enumerate() {
                        *l = format!("{}.row{i}", body.name);
                    }
                    for node in &fe.nodes {
                        for (j, d) in node.dofs.iter().enumerate() {
                            if let Some(d) = d {
                                labels[*d] = format!("{}.node{}.{}", body.name, node.id, AXES[j]);
                            }
                        }
                    }
                    dof_labels.extend(labels);
                    (fe.M.clone(), fe.K.clone(), None)
                }
            };
            let n = M.nrows();
            bodies.push(PreparedBody { offset, n, T });
            blocks.push((M, K, eta));
            offset += n;
        }
        let n = offset;
        let mut M = Mat::<f64>::zeros(n, n);
        let mut K0 = Mat::<f64>::zeros(n, n);
        let mut D0 = blocks
            .iter()
            .any(|b| b.2 > 0.0)
            .then(|| Mat::<f64>::zeros(n, n));
        for (b, (Mb, Kb, eta)) in bodies.iter().zip(&blocks) {
            M.submatrix_mut(b.offset, b.offset, b.n, b.n).copy_from(Mb);
            K0.submatrix_mut(b.offset, b.offset, b.n, b.n).copy_from(Kb);
            if let Some(D0) = D0.as_mut() {
                D0.submatrix_mut(b.offset, b.offset, b.n, b.n)
                    .copy_from(Kb * faer::Scale(*eta));
            }
        }
        let M_chol = cholesky(&M).map_err(|pivot| DynamicsError::MassNotPositiveDefinite {
            pivot,
            dof: dof_labels.get(pivot).cloned().unwrap_or_default(),
        })?;
        let K0_shifted = &K0 + &M * faer::Scale(shift);
        let mut prepared = PreparedModel {
            parameters: model.parameters.clone(),
            sensors: model
                .sensors
                .iter()
                .map(|s| (s.name.clone(), s.dof))
                .collect(),
            excitations: model
                .excitations
                .iter()
                .map(|s| (s.name.clone(), s.dof))
                .collect(),
            configurations: Vec::new(),
            dof_labels,
            M,
            K0,
            D0,
            M_chol,
            K0_shifted,
            shift,
            bodies,
        };
        for (index, st) in states.iter().enumerate() {
            let c = prepared.configuration(model, st, index)?;
            prepared.configurations.push(c);
        }
        Ok(prepared)
    }

    /// The eigensolver shift σ, rad²/s².
    pub fn shift(&self) -> f64 {
        self.shift
    }

    /// K₀ + σ M (body stiffness plus shift), the base of every evaluation.
    pub fn shifted_body_stiffness(&self) -> &Mat<f64> {
        &self.K0_shifted
    }

    /// Number of DOFs of the assembled (reduced) model.
    pub fn n_dofs(&self) -> usize {
        self.M.nrows()
    }

    /// 6 × n rows of a point's (u, θ) in global DOFs.
    fn point_rows(&self, model: &Model, body: usize, loc: Location) -> Mat<f64> {
        let pb = &self.bodies[body];
        let mut P = Mat::<f64>::zeros(6, self.n_dofs());
        let local: Mat<f64> = match (&model.bodies[body].kind, loc) {
            (BodyKind::Rigid { dofs, .. }, Location::Rigid(r)) => {
                let T = offset_map(r);
                Mat::from_fn(6, dofs.len(), |i, j| T[i][dofs[j]])
            }
            (BodyKind::Fe { fe, .. }, Location::Node(node, off)) => {
                let full = fe.point_rows(node, off);
                match &pb.T {
                    Some(T) => full * T,
                    None => full,
                }
            }
            // Locations are produced from the body's own kind.
            _ => Mat::zeros(6, pb.n),
        };
        P.submatrix_mut(0, pb.offset, 6, pb.n).copy_from(&local);
        P
    }

    fn configuration(
        &self,
        model: &Model,
        st: &super::configuration::AxisState,
        index: usize,
    ) -> Result<Configuration, DynamicsError> {
        let n = self.n_dofs();
        let mut cols: [(Vec<Vec<f64>>, Vec<usize>); 3] = Default::default();
        for (ji, j) in model.joints.iter().enumerate() {
            let Pa = self.point_rows(model, j.a.body, locate(model, st, &j.a));
            let Pb =
                j.b.as_ref()
                    .map(|b| self.point_rows(model, b.body, locate_b(model, st, ji, b)));
            for c in &j.connections {
                // Weights in global axes: c_t = Rᵀ w_t, c_r = Rᵀ w_r.
                let w = c.spec.weights;
                let cg: [f64; 6] = std::array::from_fn(|i| {
                    let (o, k) = (3 * (i / 3), i % 3);
                    (0..3).map(|q| j.frame[q][k] * w[o + q]).sum()
                });
                let g: Vec<f64> = (0..n)
                    .map(|col| {
                        let a: f64 = (0..6).map(|i| Pa[(i, col)] * cg[i]).sum();
                        let b: f64 = Pb
                            .as_ref()
                            .map_or(0.0, |Pb| (0..6).map(|i| Pb[(i, col)] * cg[i]).sum());
                        a - b
                    })
                    .collect();
                if let Some(k) = c.stiffness {
                    cols[0].0.push(g.clone());
                    cols[0].1.push(k);
                }
                if let Some(d) = c.damper {
                    let slot = if c.spec.damping == DampingModel::Viscous {
                        1
                    } else {
                        2
                    };
                    cols[slot].0.push(g);
                    cols[slot].1.push(d);
                }
            }
        }
        let terms = |(g, params): (Vec<Vec<f64>>, Vec<usize>)| {
            let columns = g
                .into_iter()
                .map(|col| {
                    col.into_iter()
                        .enumerate()
                        .filter(|(_, v)| *v != 0.0)
                        .collect()
                })
                .collect();
            JointTerms { columns, params }
        };
        let [k, b, d] = cols;
        let rows = |list: &[super::model::PointDof]| {
            let mut R = Mat::<f64>::zeros(list.len(), n);
            for (i, p) in list.iter().enumerate() {
                let P = self.point_rows(model, p.end.body, locate(model, st, &p.end));
                let axis = p.dof.direction.unsigned_abs() as usize - 1;
                let sign = p.dof.direction.signum() as f64;
                for col in 0..n {
                    R[(i, col)] = sign * P[(axis, col)];
                }
            }
            R
        };
        Ok(Configuration {
            position: Position {
                index: index as u32,
                label: st.label.clone(),
            },
            stiffness: terms(k),
            viscous: terms(b),
            hysteretic: terms(d),
            S: rows(&model.sensors),
            E: rows(&model.excitations),
        })
    }

    /// The configuration with this index, or an error.
    pub fn config(&self, index: usize) -> Result<&Configuration, DynamicsError> {
        self.configurations
            .get(index)
            .ok_or(DynamicsError::Configuration {
                index,
                count: self.configurations.len(),
            })
    }

    /// Full matrices (M, K, B, D) of a configuration at the given parameter
    /// values, for direct solutions and checks.
    pub fn matrices(&self, config: usize, values: &[f64]) -> Result<[Mat<f64>; 4], DynamicsError> {
        self.check_values(values)?;
        let c = self.config(config)?;
        let add = |mut base: Mat<f64>, t: &JointTerms| {
            t.add_to(&mut base, values);
            base
        };
        let n = self.n_dofs();
        Ok([
            self.M.clone(),
            add(self.K0.clone(), &c.stiffness),
            add(Mat::zeros(n, n), &c.viscous),
            add(
                self.D0.clone().unwrap_or_else(|| Mat::zeros(n, n)),
                &c.hysteretic,
            ),
        ])
    }

    /// Parameter vectors must match the model and be finite and ≥ 0.
    pub fn check_values(&self, values: &[f64]) -> Result<(), DynamicsError> {
        if values.len() != self.parameters.len() {
            return Err(DynamicsError::Parameters {
                message: format!(
                    "got {} values, the model has {} parameters",
                    values.len(),
                    self.parameters.len()
                ),
            });
        }
        if let Some((i, v)) = values
            .iter()
            .enumerate()
            .find(|(_, v)| !v.is_finite() || **v < 0.0)
        {
            return Err(DynamicsError::Parameters {
                message: format!(
                    "`{}` = {v}: stiffness and damping values must be finite and non-negative",
                    self.parameters[i].name
                ),
            });
        }
        Ok(())
    }
}
