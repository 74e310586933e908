//! A validated model: the model file with every name resolved to an index,
//! every number checked, templates expanded and FE bodies assembled.
//! Errors name the file and the field (`joints[3].a.point`) and say how to fix it.
#![allow(non_snake_case)]

use super::bodies::{body_kind, finite};
pub(crate) use super::bodies::{Body, BodyKind};
use super::error::DynamicsError;
use super::model_file::{self, DampingModel, ModelFile, ParameterKind};
use super::superelement::Resolver;
use super::templates::{unit, ScalarConnection, Template};
use crate::frf::Dof;
use crate::parameter::{ParameterError, Scale};

/// An identifiable model parameter: a bounded [`crate::parameter::Parameter`]
/// with its physical kind and the true value synthesis uses.
#[derive(Debug, Clone, PartialEq)]
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

/// A validated, assembled model (before reduction and configuration set-up).
#[derive(Debug, Clone)]
pub struct Model {
    pub parameters: Vec<Parameter>,
    pub(crate) bodies: Vec<Body>,
    pub(crate) joints: Vec<Joint>,
    pub(crate) axes: Vec<Axis>,
    pub(crate) sensors: Vec<PointDof>,
    pub(crate) excitations: Vec<PointDof>,
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
    /// solver is (or will be chosen) dense, O(nnz) when it is sparse (the
    /// factor's fill, ~30× the bodies' non-zeros for beam-like bodies, and
    /// a Krylov basis of a few hundred vectors); a Craig–Bampton body is
    /// reduced with dense matrices of its full size.
    pub fn memory_estimate(&self) -> (f64, String) {
        let n = self.n_dofs() as f64;
        let mut nnz = 0.0;
        let mut reduced = 0.0f64;
        for b in &self.bodies {
            match &b.kind {
                BodyKind::Fe { fe, modes, .. } => {
                    if modes.is_some() {
                        reduced = reduced.max(fe.n() as f64);
                        nnz += (fe.n() as f64).powi(2);
                    } else {
                        nnz += (fe.K.nnz() + fe.M.nnz()) as f64;
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
            (
                8.0 * (30.0 * nnz + 300.0 * n),
                format!("{n} DOF, {nnz} non-zeros: sparse factor and Krylov basis"),
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

    /// Index of a parameter by name.
    pub fn parameter_index(&self, name: &str) -> Option<usize> {
        self.parameters.iter().position(|p| p.name == name)
    }

    /// The true parameter values in model order.
    pub fn true_values(&self) -> Vec<f64> {
        self.parameters.iter().map(|p| p.value).collect()
    }

    /// Validate a parsed model file.
    pub fn from_spec(
        spec: &ModelFile,
        file: &str,
        resolver: Resolver<'_>,
    ) -> Result<Model, DynamicsError> {
        let inv = |field: String, msg: String| DynamicsError::invalid(file, field, msg);
        let mut parameters = Vec::new();
        for (i, p) in spec.parameters.iter().enumerate() {
            let f = format!("parameters[{i}]");
            finite(
                file,
                &format!("{f} ({})", p.name),
                &[p.value, p.lower, p.upper],
            )?;
            if parameters.iter().any(|q: &Parameter| q.name == p.name) {
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
        let mut bodies: Vec<Body> = Vec::new();
        for (i, b) in spec.bodies.iter().enumerate() {
            let f = format!("bodies[{i}]");
            if b.name == "ground" || bodies.iter().any(|o| o.name == b.name) {
                return Err(inv(
                    format!("{f}.name"),
                    format!("`{}` is reserved or used twice", b.name),
                ));
            }
            let kind = body_kind(b, &f, file, resolver, &parameters)?;
            bodies.push(Body {
                name: b.name.clone(),
                kind,
            });
        }
        let body_index = |name: &str, field: String| -> Result<Option<usize>, DynamicsError> {
            if name == "ground" {
                return Ok(None);
            }
            bodies
                .iter()
                .position(|b| b.name == name)
                .map(Some)
                .ok_or_else(|| {
                    let known: Vec<&str> = bodies.iter().map(|b| b.name.as_str()).collect();
                    DynamicsError::invalid(
                        file,
                        field,
                        format!("unknown body `{name}`; bodies are {known:?} or `ground`"),
                    )
                })
        };
        let end = |e: &model_file::JointEndSpec, f: String| -> Result<Option<End>, DynamicsError> {
            let Some(body) = body_index(&e.body, format!("{f}.body"))? else {
                return Ok(None);
            };
            let point = e.point.clone().ok_or_else(|| {
                DynamicsError::invalid(
                    file,
                    format!("{f}.point"),
                    "missing: name a point of the body",
                )
            })?;
            let exists = match &bodies[body].kind {
                BodyKind::Rigid { points, .. } => points.contains_key(&point),
                BodyKind::Fe { points, .. } => points.contains_key(&point),
            };
            if !exists {
                return Err(DynamicsError::invalid(
                    file,
                    format!("{f}.point"),
                    format!("body `{}` has no point `{point}`", e.body),
                ));
            }
            Ok(Some(End { body, point }))
        };
        let param = |name: &str, kind: ParameterKind, f: String| {
            parameter_ref(&parameters, name, kind, file, &f)
        };
        let mut joints: Vec<Joint> = Vec::new();
        for (i, j) in spec.joints.iter().enumerate() {
            let f = format!("joints[{i}]");
            if joints.iter().any(|o| o.name == j.name) {
                return Err(inv(
                    format!("{f}.name"),
                    format!("joint `{}` defined twice", j.name),
                ));
            }
            let a = end(&j.a, format!("{f}.a"))?.ok_or_else(|| {
                inv(
                    format!("{f}.a.body"),
                    "end `a` must be a body, not ground".into(),
                )
            })?;
            let b = match &j.b {
                Some(e) => end(e, format!("{f}.b"))?,
                None => None,
            };
            let frame = j
                .frame
                .unwrap_or([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
            check_frame(&frame).map_err(|m| inv(format!("{f}.frame"), m))?;
            let mut specs = Vec::new();
            if let Some(t) = j.template {
                let prefix = j.parameters.clone().ok_or_else(|| {
                    inv(
                        format!("{f}.parameters"),
                        "a template needs a parameter-name prefix".into(),
                    )
                })?;
                let lead = match (t, j.lead) {
                    (Template::BallScrewNut, None) => {
                        return Err(inv(
                            format!("{f}.lead"),
                            "template ball_screw_nut needs the screw lead in m/rev".into(),
                        ))
                    }
                    (_, lead) => lead.unwrap_or(0.0),
                };
                finite(file, &format!("{f}.lead"), &[lead])?;
                specs.extend(t.expand(&prefix, j.damping.unwrap_or_default(), lead));
            }
            for (c_i, c) in j.connections.iter().enumerate() {
                specs.push(ScalarConnection {
                    label: format!("connections[{c_i}]"),
                    weights: unit(c.dir),
                    stiffness: c.stiffness.clone(),
                    damper: c.damper.clone(),
                    damping: c.damping.or(j.damping).unwrap_or(DampingModel::Viscous),
                });
            }
            if specs.is_empty() {
                return Err(inv(
                    f,
                    format!("joint `{}` has no template and no connections", j.name),
                ));
            }
            let mut connections = Vec::new();
            for s in specs {
                let field = if s.label.starts_with("connections[") {
                    format!("{f}.{}", s.label)
                } else {
                    format!("{f}.template ({})", s.label)
                };
                let stiffness = s
                    .stiffness
                    .as_deref()
                    .map(|n| param(n, ParameterKind::Stiffness, field.clone()))
                    .transpose()?;
                let damper = s
                    .damper
                    .as_deref()
                    .map(|n| param(n, ParameterKind::Damping, field.clone()))
                    .transpose()?;
                connections.push(Connection {
                    spec: s,
                    stiffness,
                    damper,
                });
            }
            joints.push(Joint {
                name: j.name.clone(),
                a,
                b,
                frame,
                connections,
            });
        }
        let mut axes = Vec::new();
        for (i, ax) in spec.axes.iter().enumerate() {
            let f = format!("axes[{i}]");
            let body = body_index(&ax.body, format!("{f}.body"))?
                .ok_or_else(|| inv(format!("{f}.body"), "ground cannot move".into()))?;
            finite(file, &format!("{f}.direction"), &ax.direction)?;
            finite(file, &format!("{f}.positions"), &ax.positions)?;
            let n = ax.direction.iter().map(|x| x * x).sum::<f64>().sqrt();
            if n < 1e-12 {
                return Err(inv(
                    format!("{f}.direction"),
                    "must be a non-zero vector".into(),
                ));
            }
            if ax.positions.is_empty() {
                return Err(inv(
                    format!("{f}.positions"),
                    "list at least one position".into(),
                ));
            }
            let mut sliding = Vec::new();
            for (s_i, s) in ax.sliding.iter().enumerate() {
                let fs = format!("{f}.sliding[{s_i}]");
                let ji = joints
                    .iter()
                    .position(|j| &j.name == s)
                    .ok_or_else(|| inv(fs.clone(), format!("unknown joint `{s}`")))?;
                if joints[ji].a.body != body || joints[ji].b.is_none() {
                    return Err(inv(fs, format!("joint `{s}` must have end `a` on the moving body `{}` and end `b` on a body", ax.body)));
                }
                sliding.push(ji);
            }
            axes.push(Axis {
                name: ax.name.clone(),
                body,
                direction: ax.direction.map(|x| x / n),
                positions: ax.positions.clone(),
                sliding,
            });
        }
        let point_dofs = |list: &[model_file::PointDofSpec],
                          what: &str|
         -> Result<Vec<PointDof>, DynamicsError> {
            let mut out = Vec::new();
            for (i, s) in list.iter().enumerate() {
                let f = format!("{what}[{i}]");
                if !(1..=6).contains(&s.direction.unsigned_abs()) {
                    return Err(DynamicsError::invalid(
                        file,
                        format!("{f}.direction"),
                        "UFF direction code must be ±1..±6 (X Y Z RX RY RZ)",
                    ));
                }
                let e = end(
                    &model_file::JointEndSpec {
                        body: s.body.clone(),
                        point: Some(s.point.clone()),
                    },
                    f.clone(),
                )?
                .ok_or_else(|| {
                    DynamicsError::invalid(
                        file,
                        format!("{f}.body"),
                        "ground does not move; choose a body",
                    )
                })?;
                out.push(PointDof {
                    name: s.name.clone(),
                    end: e,
                    dof: Dof::new(s.node, s.direction),
                });
            }
            Ok(out)
        };
        let sensors = point_dofs(&spec.sensors, "sensors")?;
        let excitations = point_dofs(&spec.excitations, "excitations")?;
        if let Some(b) = spec.solver.block {
            if !(1..=16).contains(&b) {
                return Err(inv(
                    "solver.block".into(),
                    format!("Lanczos block size {b}: give 1..=16 (default 4)"),
                ));
            }
        }
        if let Some(f) = spec.solver.shift {
            if !(f.is_finite() && f > 0.0) {
                return Err(inv(
                    "solver.shift".into(),
                    format!("shift {f} Hz: give a frequency > 0 below the first elastic mode, or leave it out to have it chosen"),
                ));
            }
        }
        Ok(Model {
            solver: spec.solver,
            parameters,
            bodies,
            joints,
            axes,
            sensors,
            excitations,
        })
    }
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

fn check_frame(r: &[[f64; 3]; 3]) -> Result<(), String> {
    for i in 0..3 {
        for j in 0..3 {
            let d: f64 = (0..3).map(|k| r[i][k] * r[j][k]).sum();
            let e = if i == j { 1.0 } else { 0.0 };
            if !d.is_finite() || (d - e).abs() > 1e-6 {
                return Err(
                    "rows must be orthonormal unit vectors (local x, y, z in global axes)".into(),
                );
            }
        }
    }
    Ok(())
}
