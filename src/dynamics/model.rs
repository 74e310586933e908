//! A validated model: the model file with every name resolved to an index,
//! every number checked, templates expanded and FE bodies assembled.
//! Errors name the file and the field (`joints[3].a.point`) and say how to fix it.
#![allow(non_snake_case)]

use super::bodies::{body_kind, finite};
pub(crate) use super::bodies::{Body, BodyKind};
use super::error::DynamicsError;
use super::model_file::{self, ModelFile, ParameterKind};
use super::resolve::{self, Names};
use super::superelement::Resolver;
use super::templates::ScalarConnection;
use crate::frf::Dof;
use crate::parameter::{ParameterError, Scale};

/// An identifiable model parameter: a bounded [`crate::parameter::Parameter`]
/// with its physical kind and the true value synthesis uses.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Parameter {
    pub name: String,
    /// True value (used for synthesis).
    pub value: f64,
    pub lower: f64,
    pub upper: f64,
    pub scale: Scale,
    pub kind: ParameterKind,
}

impl Parameter {
    /// The bounded parameter samplers and optimizers see, its nominal value
    /// the true value (clamped into the bounds).
    pub fn bounded(&self) -> Result<crate::parameter::Parameter, ParameterError> {
        crate::parameter::Parameter::new(self.name.clone(), self.lower, self.upper, self.scale)?
            .with_nominal(self.value.clamp(self.lower, self.upper))
    }
}

/// A joint end after validation: body index and point name (checked to exist).
#[derive(Debug, Clone)]
pub(crate) struct End {
    pub body: usize,
    pub point: String,
}

/// A scalar connection with resolved parameter indices.
#[derive(Debug, Clone)]
pub(crate) struct Connection {
    pub spec: ScalarConnection,
    pub stiffness: Option<usize>,
    pub damper: Option<usize>,
}

#[derive(Debug, Clone)]
pub(crate) struct Joint {
    pub name: String,
    pub a: End,
    /// `None` = ground.
    pub b: Option<End>,
    /// Rows: local x, y, z in global axes.
    pub frame: [[f64; 3]; 3],
    pub connections: Vec<Connection>,
}

#[derive(Debug, Clone)]
pub(crate) struct Axis {
    pub name: String,
    pub body: usize,
    pub direction: [f64; 3],
    pub positions: Vec<f64>,
    pub sliding: Vec<usize>,
}

#[derive(Debug, Clone)]
pub(crate) struct PointDof {
    pub name: String,
    pub end: End,
    pub dof: Dof,
}

/// A lumped mass at a body's point: kg, and the global translations
/// (0 = x, 1 = y, 2 = z) it follows.
#[derive(Debug, Clone)]
pub(crate) struct PointMass {
    pub end: End,
    pub mass: f64,
    pub axes: Vec<usize>,
}

/// A validated, assembled model (before reduction and configuration set-up).
#[derive(Debug, Clone)]
pub struct Model {
    pub parameters: Vec<Parameter>,
    pub(crate) bodies: Vec<Body>,
    pub(crate) joints: Vec<Joint>,
    pub(crate) axes: Vec<Axis>,
    pub(crate) sensors: Vec<PointDof>,
    pub(crate) excitations: Vec<PointDof>,
    pub(crate) masses: Vec<PointMass>,
    /// Eigensolver settings of the model file.
    pub solver: model_file::SolverSpec,
}

impl Model {
    /// Parse and validate a model file. `file` names it in messages;
    /// `resolver` reads files the model references (super-element matrices).
    pub fn from_yaml(
        text: &str,
        file: &str,
        resolver: Resolver<'_>,
    ) -> Result<Model, DynamicsError> {
        let spec = model_file::parse(text, file)?;
        Model::from_spec(&spec, file, resolver)
    }

    /// Degrees of freedom before any reduction: 6 (or fewer) per rigid
    /// body, every node DOF of flexible bodies. Bounds the size of the
    /// dense eigenproblem, for the resource checks at validation.
    pub fn n_dofs(&self) -> usize {
        self.bodies
            .iter()
            .map(|b| match &b.kind {
                super::bodies::BodyKind::Rigid { dofs, .. } => dofs.len(),
                super::bodies::BodyKind::Fe { fe, .. } => fe.n(),
            })
            .sum()
    }

    /// DOFs with mass: the most modes with a finite frequency. A DOF whose
    /// mass row is zero (rotations of a lumped-mass export, constraint
    /// nodes) has none; the eigensolver handles such a semi-definite M
    /// (K + σM stays definite), but cannot return more modes than this.
    pub fn finite_modes(&self) -> usize {
        let massless: usize = self
            .bodies
            .iter()
            .map(|b| match &b.kind {
                BodyKind::Fe { fe, .. } => super::storage::massless_dofs(&fe.M),
                BodyKind::Rigid { .. } => 0,
            })
            .sum();
        self.n_dofs().saturating_sub(massless)
    }

    /// Estimated peak memory of preparing and evaluating the model, bytes,
    /// and what dominates it: about six dense n × n matrices when the
    /// solver is (or will be chosen) dense; on the sparse path the factor
    /// L of K_σ counted by a symbolic analysis of the bodies' patterns
    /// ([`Model::sparse_factor_nnz`], 8 bytes per non-zero), the matrices
    /// (the model's M and K, the solver's copies on the union pattern and
    /// its K_σ values: ~48 bytes per stored non-zero of M and K) and a
    /// Krylov basis and locked modes of ~300 vectors of n (8 bytes each),
    /// for one evaluation thread; a Craig–Bampton body is reduced with
    /// dense matrices of its full size.
    pub fn memory_estimate(&self) -> (f64, String) {
        let n = self.n_dofs() as f64;
        let mut nnz = 0.0;
        let mut stored = 0.0;
        let mut reduced = 0.0f64;
        for b in &self.bodies {
            match &b.kind {
                BodyKind::Fe { fe, modes, .. } => {
                    if modes.is_some() {
                        reduced = reduced.max(fe.n() as f64);
                        nnz += (fe.n() as f64).powi(2);
                    } else {
                        nnz += (fe.K.nnz() + fe.M.nnz()) as f64;
                        stored += (fe.K.nnz() + fe.M.nnz()) as f64;
                    }
                }
                BodyKind::Rigid { dofs, .. } => nnz += (dofs.len() * dofs.len()) as f64,
            }
        }
        let method = super::storage::choose(self.solver.method, n as usize, nnz as usize);
        let solve = if method == model_file::SolverMethod::Dense {
            (
                8.0 * 6.0 * n * n,
                format!("{n} DOF: the dense eigenproblem (6 n × n matrices)"),
            )
        } else {
            let factor = self.sparse_factor_nnz() as f64;
            let bytes = 8.0 * factor + 48.0 * stored + 8.0 * 300.0 * n;
            let limit = crate::resources::memory_limit() as f64;
            let stiffness: f64 = self.fe_bodies().map(|fe| fe.K.nnz() as f64).sum();
            (
                bytes,
                format!(
                    "{n} DOF, {nnz} non-zeros, a sparse factor of {factor} non-zeros \
                     (fill nnz(L)/nnz(K) {:.2}), the matrices and a Krylov basis; the limit \
                     of {} admits about {:.0} DOF at this model's {:.1} kB per DOF (a finer \
                     solid mesh fills more per DOF)",
                    factor / stiffness.max(1.0),
                    crate::resources::human(limit),
                    (limit / (bytes / n.max(1.0))).floor(),
                    bytes / n.max(1.0) / 1e3,
                ),
            )
        };
        let cb = 8.0 * 4.0 * reduced * reduced;
        if cb > solve.0 {
            (
                cb,
                format!("Craig–Bampton reduction of a {reduced}-DOF body (dense)"),
            )
        } else {
            solve
        }
    }

    /// The unreduced FE bodies' full matrices.
    fn fe_bodies(&self) -> impl Iterator<Item = &super::fe_body::FeBody> {
        self.bodies.iter().filter_map(|b| match &b.kind {
            BodyKind::Fe {
                fe, modes: None, ..
            } => Some(fe),
            _ => None,
        })
    }

    /// Non-zeros of the sparse solver's Cholesky factor of K_σ, without
    /// factoring: per unreduced FE body the symbolic analysis of its M and
    /// K pattern ([`super::fill::factor_nnz`]: exact up to 4e6 non-zeros,
    /// on the graph of its nodes beyond, within 2 % and 0.2 CPU-s at 190k
    /// DOF), per rigid body a dense d × d block, per
    /// Craig–Bampton body a dense block of its modes plus every DOF of its
    /// listed nodes (the boundary is at most those). Joints add a few
    /// couplings between bodies, whose fill is neglected.
    pub fn sparse_factor_nnz(&self) -> usize {
        let triangle = |d: usize| d * (d + 1) / 2;
        self.bodies
            .iter()
            .map(|b| match &b.kind {
                BodyKind::Rigid { dofs, .. } => triangle(dofs.len()),
                BodyKind::Fe {
                    fe, modes: None, ..
                } => super::fill::factor_nnz(&fe.K, &fe.M)
                    // Only an index overflow fails: the old bound, 15 nnz.
                    .unwrap_or(15 * (fe.K.nnz() + fe.M.nnz())),
                BodyKind::Fe {
                    fe, modes: Some(m), ..
                } => {
                    let boundary: usize = fe
                        .nodes
                        .iter()
                        .map(|x| x.dofs.iter().flatten().count())
                        .sum();
                    triangle((m + boundary).min(fe.n()))
                }
            })
            .sum()
    }

    /// Index of a parameter by name.
    pub fn parameter_index(&self, name: &str) -> Option<usize> {
        self.parameters.iter().position(|p| p.name == name)
    }

    /// The true parameter values in model order.
    pub fn true_values(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.value).collect()
    }

    /// Validate a parsed model file: parameters, then bodies (which may
    /// name parameters), then what refers to bodies by name (joints, axes,
    /// sensors, excitations; `resolve.rs`), then the solver settings.
    pub fn from_spec(
        spec: &ModelFile,
        file: &str,
        resolver: Resolver<'_>,
    ) -> Result<Model, DynamicsError> {
        let parameters = parameters_from_spec(spec, file)?;
        let bodies = bodies_from_spec(spec, file, resolver, &parameters)?;
        let names = Names {
            bodies: &bodies,
            file,
        };
        let joints = resolve::joints(spec, &names, &parameters)?;
        let axes = resolve::axes(spec, &names, &joints)?;
        let sensors = resolve::point_dofs(&spec.sensors, "sensors", &names)?;
        let excitations = resolve::point_dofs(&spec.excitations, "excitations", &names)?;
        let masses = resolve::point_masses(&spec.masses, &names)?;
        check_solver(&spec.solver, file)?;
        Ok(Model {
            solver: spec.solver,
            parameters,
            bodies,
            joints,
            axes,
            sensors,
            excitations,
            masses,
        })
    }
}

/// The model file's parameters, each finite, named once, with its value
/// inside lower < upper, non-negative, and positive bounds on a log scale.
fn parameters_from_spec(spec: &ModelFile, file: &str) -> Result<Vec<Parameter>, DynamicsError> {
    let inv = |field: String, msg: String| DynamicsError::invalid(file, field, msg);
    let mut parameters: Vec<Parameter> = Vec::new();
    for (i, p) in spec.parameters.iter().enumerate() {
        let f = format!("parameters[{i}]");
        finite(
            file,
            &format!("{f} ({})", p.name),
            &[p.value, p.lower, p.upper],
        )?;
        if parameters.iter().any(|q| q.name == p.name) {
            return Err(inv(
                format!("{f}.name"),
                format!("`{}` is defined twice", p.name),
            ));
        }
        if !(p.lower < p.upper && p.lower <= p.value && p.value <= p.upper) {
            return Err(inv(
                f,
                format!(
                    "`{}`: need lower < upper and lower <= value <= upper (got {} <= {} <= {})",
                    p.name, p.lower, p.value, p.upper
                ),
            ));
        }
        if p.scale == Scale::Log && p.lower <= 0.0 {
            return Err(inv(
                format!("{f}.lower"),
                format!("`{}`: log scale needs positive bounds", p.name),
            ));
        }
        if p.lower < 0.0 {
            return Err(inv(
                format!("{f}.lower"),
                format!("`{}`: stiffness and damping must be non-negative", p.name),
            ));
        }
        parameters.push(Parameter {
            name: p.name.clone(),
            value: p.value,
            lower: p.lower,
            upper: p.upper,
            scale: p.scale,
            kind: p.kind,
        });
    }
    Ok(parameters)
}

/// The bodies, each named once (never `ground`) and built by
/// [`body_kind`].
fn bodies_from_spec(
    spec: &ModelFile,
    file: &str,
    resolver: Resolver<'_>,
    parameters: &[Parameter],
) -> Result<Vec<Body>, DynamicsError> {
    let mut bodies: Vec<Body> = Vec::new();
    for (i, b) in spec.bodies.iter().enumerate() {
        let f = format!("bodies[{i}]");
        if b.name == "ground" || bodies.iter().any(|o| o.name == b.name) {
            return Err(DynamicsError::invalid(
                file,
                format!("{f}.name"),
                format!("`{}` is reserved or used twice", b.name),
            ));
        }
        let kind = body_kind(b, &f, file, resolver, parameters)?;
        bodies.push(Body {
            name: b.name.clone(),
            kind,
        });
    }
    Ok(bodies)
}

/// The Lanczos block size (1..=16) and the shift (> 0 Hz), when given.
fn check_solver(solver: &model_file::SolverSpec, file: &str) -> Result<(), DynamicsError> {
    if let Some(b) = solver.block {
        if !(1..=16).contains(&b) {
            return Err(DynamicsError::invalid(
                file,
                "solver.block",
                format!("Lanczos block size {b}: give 1..=16 (default 4)"),
            ));
        }
    }
    if let Some(f) = solver.shift {
        if !(f.is_finite() && f > 0.0) {
            return Err(DynamicsError::invalid(
                file,
                "solver.shift",
                format!("shift {f} Hz: give a frequency > 0 below the first elastic mode, or leave it out to have it chosen"),
            ));
        }
    }
    Ok(())
}

/// Index of the parameter `name`, which must exist and be of `kind`; the
/// error names the file and the field that refers to it.
pub(crate) fn parameter_ref(
    parameters: &[Parameter],
    name: &str,
    kind: ParameterKind,
    file: &str,
    field: &str,
) -> Result<usize, DynamicsError> {
    let i = parameters
        .iter()
        .position(|p| p.name == name)
        .ok_or_else(|| {
            DynamicsError::invalid(
                file,
                field,
                format!("unknown parameter `{name}`; add it to `parameters`"),
            )
        })?;
    if parameters[i].kind != kind {
        return Err(DynamicsError::invalid(
            file,
            field,
            format!(
                "parameter `{name}` has kind {:?}, expected {kind:?}",
                parameters[i].kind
            ),
        ));
    }
    Ok(i)
}
