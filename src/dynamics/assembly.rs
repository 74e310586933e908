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

mod blocks;

use super::configuration::{axis_states, locate, locate_b};
use super::error::DynamicsError;
use super::lanczos::LanczosOptions;
use super::model::{BodyKind, Model, Parameter};
use super::model_file::DampingModel;
use super::model_file::{SolverMethod, SolverSpec};
use super::points::{point_masses, point_rows};
use super::shift::{sigma_from_hz, Shift};
use super::shift_invert::WorkspacePool;
use super::sparse::Csc;
use super::storage::{choose, Storage};
use crate::frf::{Dof, Position};
use blocks::{body_blocks, body_triplets, boundary_nodes, BodyBlocks};
use faer::Mat;
use std::sync::Arc;

/// One body in the global DOF vector.
#[derive(Debug, Clone)]
pub(super) struct PreparedBody {
    pub(super) offset: usize,
    pub(super) n: usize,
    /// Full → reduced map of an FE body (`None`: rigid, or FE without reduction).
    pub(super) T: Option<Mat<f64>>,
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

/// A model ready for fast evaluation: reductions, the body matrices (dense
/// or sparse, [`Storage`]), the symbolic factorization and configurations
/// computed once; see [`PreparedModel::evaluate`].
#[derive(Debug, Clone)]
pub struct PreparedModel {
    pub parameters: Vec<Parameter>,
    pub sensors: Vec<(String, Dof)>,
    pub excitations: Vec<(String, Dof)>,
    pub configurations: Vec<Configuration>,
    /// Human-readable label of every DOF (`bed.node3.y`, `bed.cb2`).
    pub dof_labels: Vec<String>,
    /// Assembled body mass, stiffness and material damping (no joints),
    /// and the eigensolver path.
    pub storage: Arc<Storage>,
    /// Shift σ of the shift-invert eigensolver, rad²/s²
    /// ([`crate::dynamics::shift`]).
    pub(crate) shift: Shift,
    pub(crate) lanczos: LanczosOptions,
    pub(crate) scratch: WorkspacePool,
}

impl PreparedModel {
    /// Reduce bodies, assemble and set up all configurations, with the
    /// model file's `solver:` settings: the eigensolver shift
    /// `solver.shift` (Hz) or, by default, one chosen from the problem on
    /// the first evaluation ([`crate::dynamics::shift`]).
    pub fn new(model: &Model) -> Result<PreparedModel, DynamicsError> {
        let shift = match model.solver.shift {
            Some(f) => Shift::Fixed(sigma_from_hz(f)),
            None => Shift::Auto(Default::default()),
        };
        PreparedModel::prepare(model, shift, model.solver)
    }

    /// As [`PreparedModel::new`] with a fixed shift σ > 0 (rad²/s²): choose
    /// σ below the lowest elastic eigenvalue of interest.
    pub fn with_shift(model: &Model, shift: f64) -> Result<PreparedModel, DynamicsError> {
        PreparedModel::with_solver(model, shift, model.solver)
    }

    /// As [`PreparedModel::with_shift`] with the solver settings given
    /// (instead of the model file's `solver:`).
    pub fn with_solver(
        model: &Model,
        shift: f64,
        solver: SolverSpec,
    ) -> Result<PreparedModel, DynamicsError> {
        if !(shift.is_finite() && shift > 0.0) {
            return Err(DynamicsError::Parameters {
                message: format!("eigensolver shift must be finite and > 0, got {shift}"),
            });
        }
        PreparedModel::prepare(model, Shift::Fixed(shift), solver)
    }

    /// The work of the constructors: bodies reduced and assembled, point
    /// masses added, configurations set up and the eigensolver path chosen.
    fn prepare(
        model: &Model,
        shift: Shift,
        solver: SolverSpec,
    ) -> Result<PreparedModel, DynamicsError> {
        let states = axis_states(model);
        let used = boundary_nodes(model, &states);
        let BodyBlocks {
            bodies,
            blocks,
            dof_labels,
            n,
        } = body_blocks(model, &used)?;
        let [mut tm, tk, td] = body_triplets(&bodies, &blocks);
        let any_damping = blocks.iter().any(|b| b.1 > 0.0);
        drop(blocks);
        point_masses(model, &bodies, n, &states[0], &mut tm);
        let M = Csc::from_triplets(n, tm);
        let K0 = Csc::from_triplets(n, tk);
        let D0 = any_damping.then(|| Csc::from_triplets(n, td));
        let configurations = states
            .iter()
            .enumerate()
            .map(|(index, st)| configuration(model, &bodies, n, st, index))
            .collect::<Result<Vec<_>, _>>()?;
        let method = eigensolver_path(solver, n, &M, &K0, &configurations)?;
        let storage = Storage::new(method, M, K0, D0, &configurations, &dof_labels)?;
        Ok(PreparedModel {
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
            configurations,
            dof_labels,
            storage: Arc::new(storage),
            shift,
            lanczos: LanczosOptions {
                block: solver.block.unwrap_or(LanczosOptions::default().block),
                ..LanczosOptions::default()
            },
            scratch: WorkspacePool::default(),
        })
    }

    /// Number of DOFs of the assembled (reduced) model.
    pub fn n_dofs(&self) -> usize {
        self.storage.n()
    }

    /// Dense or sparse eigensolver path.
    pub fn solver_method(&self) -> SolverMethod {
        self.storage.method()
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

    /// Frobenius inner products of the system matrices' derivatives with
    /// respect to ln p, for the parameters `params` at `values`: G_ab = Σ
    /// over configurations and over K, B and D of ⟨x_a ∂A/∂x_a, x_b
    /// ∂A/∂x_b⟩_F. Joint terms are rank one, g gᵀ (eq. 2.47), so
    /// ⟨g gᵀ, h hᵀ⟩_F = (gᵀh)². A direction v with vᵀ G v = 0 changes no
    /// matrix, hence nothing the model predicts: two springs on one line of
    /// action, whose ratio is free. A parameter that enters no joint term
    /// has a zero row and column.
    pub fn matrix_derivative_gram(&self, params: &[usize], values: &[f64]) -> Mat<f64> {
        let n = params.len();
        let mut G = Mat::<f64>::zeros(n, n);
        let dot = |g: &[(usize, f64)], h: &[(usize, f64)]| -> f64 {
            g.iter()
                .map(|&(i, a)| h.iter().filter(|e| e.0 == i).map(|e| a * e.1).sum::<f64>())
                .sum()
        };
        for c in &self.configurations {
            for terms in [&c.stiffness, &c.viscous, &c.hysteretic] {
                // (index in `params`, x·g) of the terms of those parameters.
                let mine: Vec<(usize, &[(usize, f64)])> = terms
                    .columns
                    .iter()
                    .zip(&terms.params)
                    .filter_map(|(g, p)| Some((params.iter().position(|q| q == p)?, g.as_slice())))
                    .collect();
                for &(a, g) in &mine {
                    for &(b, h) in &mine {
                        let d = dot(g, h);
                        G[(a, b)] += values[params[a]] * values[params[b]] * d * d;
                    }
                }
            }
        }
        G
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
        let bytes = 4.0 * 8.0 * (n as f64).powi(2);
        if bytes > crate::resources::memory_limit() as f64 {
            return Err(DynamicsError::Parameters {
                message: format!(
                    "dense matrices of {n} DOF need {}, more than the memory limit (--max-memory)",
                    crate::resources::human(bytes)
                ),
            });
        }
        let (M, K0, D0) = self.storage.dense();
        Ok([
            M,
            add(K0, &c.stiffness),
            add(Mat::zeros(n, n), &c.viscous),
            add(D0.unwrap_or_else(|| Mat::zeros(n, n)), &c.hysteretic),
        ])
    }

    /// Sparse matrices (M, K, B, D) of a configuration at the given
    /// parameter values, for exports and peer comparisons.
    pub fn sparse_matrices(
        &self,
        config: usize,
        values: &[f64],
    ) -> Result<[Csc; 4], DynamicsError> {
        self.check_values(values)?;
        let c = self.config(config)?;
        let n = self.n_dofs();
        let (M, K0, D0) = match &*self.storage {
            Storage::Dense(d) => (
                dense_csc(&d.M),
                dense_csc(&d.K0),
                d.D0.as_ref().map(dense_csc),
            ),
            Storage::Sparse(s) => (s.M.clone(), s.K0.clone(), s.D0.clone()),
        };
        let with = |base: Option<Csc>, t: &JointTerms| {
            let mut tr = Vec::new();
            if let Some(b) = base {
                b.triplets(0, 1.0, &mut tr);
            }
            for (g, &p) in t.columns.iter().zip(&t.params) {
                for &(i, gi) in g {
                    for &(j, gj) in g {
                        tr.push((i, j, values[p] * gi * gj));
                    }
                }
            }
            Csc::from_triplets(n, tr)
        };
        Ok([
            M,
            with(Some(K0), &c.stiffness),
            with(None, &c.viscous),
            with(D0, &c.hysteretic),
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

/// The eigensolver path for `n` DOF ([`choose`] on the non-zeros of the
/// body matrices and the joints' columns), refused when the dense path
/// would exceed the memory limit.
fn eigensolver_path(
    solver: SolverSpec,
    n: usize,
    M: &Csc,
    K0: &Csc,
    configurations: &[Configuration],
) -> Result<SolverMethod, DynamicsError> {
    let joint_nnz: usize = configurations
        .iter()
        .flat_map(|c| c.stiffness.columns.iter().map(|g| g.len() * g.len()))
        .sum();
    let method = choose(solver.method, n, M.nnz().max(K0.nnz()) + joint_nnz);
    if method == SolverMethod::Dense {
        let bytes = 8.0 * 6.0 * (n as f64).powi(2);
        let limit = crate::resources::memory_limit() as f64;
        if bytes > limit {
            return Err(DynamicsError::Parameters {
                message: format!(
                    "the dense eigenproblem of {n} DOF needs an estimated {}, more than the \
                     limit of {} (--max-memory); use `solver: {{method: sparse}}` or a reduction",
                    crate::resources::human(bytes),
                    crate::resources::human(limit)
                ),
            });
        }
    }
    Ok(method)
}

fn configuration(
    model: &Model,
    bodies: &[PreparedBody],
    n: usize,
    st: &super::configuration::AxisState,
    index: usize,
) -> Result<Configuration, DynamicsError> {
    let mut cols: [(Vec<Vec<f64>>, Vec<usize>); 3] = Default::default();
    for (ji, j) in model.joints.iter().enumerate() {
        let Pa = point_rows(model, bodies, n, j.a.body, locate(model, st, &j.a));
        let Pb =
            j.b.as_ref()
                .map(|b| point_rows(model, bodies, n, b.body, locate_b(model, st, ji, b)));
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
    let (mut k, b, mut d) = (terms(k), terms(b), terms(d));
    // Parameter-valued body stiffness and material damping (a beam whose E
    // or G is a parameter), shifted to the body's place in the DOF vector.
    for (bi, body) in model.bodies.iter().enumerate() {
        if let BodyKind::Fe { terms: t, .. } = &body.kind {
            let o = bodies[bi].offset;
            let shift = |c: &Vec<(usize, f64)>| c.iter().map(|&(i, v)| (o + i, v)).collect();
            for (c, p) in &t.stiffness {
                k.columns.push(shift(c));
                k.params.push(*p);
            }
            for (c, p) in &t.hysteretic {
                d.columns.push(shift(c));
                d.params.push(*p);
            }
        }
    }
    let rows = |list: &[super::model::PointDof]| {
        let mut R = Mat::<f64>::zeros(list.len(), n);
        for (i, p) in list.iter().enumerate() {
            let P = point_rows(model, bodies, n, p.end.body, locate(model, st, &p.end));
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
        stiffness: k,
        viscous: b,
        hysteretic: d,
        S: rows(&model.sensors),
        E: rows(&model.excitations),
    })
}

fn dense_csc(A: &Mat<f64>) -> Csc {
    let mut t = Vec::new();
    Csc::dense_triplets(A, 0, &mut t);
    Csc::from_triplets(A.nrows(), t)
}
