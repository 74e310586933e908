//! Name resolution of a model file: joints, axes, sensors and excitations
//! refer to bodies, points, joints and parameters by name; here each name
//! becomes an index (checked to exist, of the right kind), templates are
//! expanded, and every error names the file and the field
//! (`joints[3].a.point`) with the names that do exist.

use super::error::DynamicsError;
use super::model::{
    parameter_ref, Axis, Body, BodyKind, Connection, End, Joint, Parameter, PointDof,
};
use super::model_file::{self, DampingModel, ModelFile, ParameterKind};
use super::templates::{unit, ScalarConnection, Template};
use crate::dynamics::bodies::finite;
use crate::frf::Dof;

/// The validated bodies, for looking names up, and the file for messages.
pub(crate) struct Names<'a> {
    pub bodies: &'a [Body],
    pub file: &'a str,
}

impl Names<'_> {
    fn invalid(&self, field: impl Into<String>, message: impl Into<String>) -> DynamicsError {
        DynamicsError::invalid(self.file, field, message)
    }

    /// Index of body `name`, `None` for `ground`.
    fn body(&self, name: &str, field: String) -> Result<Option<usize>, DynamicsError> {
        if name == "ground" {
            return Ok(None);
        }
        self.bodies
            .iter()
            .position(|b| b.name == name)
            .map(Some)
            .ok_or_else(|| {
                let known: Vec<&str> = self.bodies.iter().map(|b| b.name.as_str()).collect();
                self.invalid(
                    field,
                    format!("unknown body `{name}`; bodies are {known:?} or `ground`"),
                )
            })
    }

    /// A joint end (or a sensor's point): an existing point of a body,
    /// `None` for ground.
    fn end(&self, e: &model_file::JointEndSpec, f: String) -> Result<Option<End>, DynamicsError> {
        let Some(body) = self.body(&e.body, format!("{f}.body"))? else {
            return Ok(None);
        };
        let point = e.point.clone().ok_or_else(|| {
            self.invalid(format!("{f}.point"), "missing: name a point of the body")
        })?;
        let exists = match &self.bodies[body].kind {
            BodyKind::Rigid { points, .. } => points.contains_key(&point),
            BodyKind::Fe { points, .. } => points.contains_key(&point),
        };
        if !exists {
            return Err(self.invalid(
                format!("{f}.point"),
                format!("body `{}` has no point `{point}`", e.body),
            ));
        }
        Ok(Some(End { body, point }))
    }
}

/// Every joint, each named once.
pub(crate) fn joints(
    spec: &ModelFile,
    names: &Names<'_>,
    parameters: &[Parameter],
) -> Result<Vec<Joint>, DynamicsError> {
    let mut joints: Vec<Joint> = Vec::new();
    for (i, j) in spec.joints.iter().enumerate() {
        let f = format!("joints[{i}]");
        if joints.iter().any(|o| o.name == j.name) {
            return Err(names.invalid(
                format!("{f}.name"),
                format!("joint `{}` defined twice", j.name),
            ));
        }
        joints.push(joint(j, &f, names, parameters)?);
    }
    Ok(joints)
}

/// One joint: its ends (`a` on a body, `b` on a body or ground), an
/// orthonormal frame, and its scalar connections (template expanded, then
/// the listed ones) with parameter indices of the right kind.
fn joint(
    j: &model_file::JointSpec,
    f: &str,
    names: &Names<'_>,
    parameters: &[Parameter],
) -> Result<Joint, DynamicsError> {
    let a = names.end(&j.a, format!("{f}.a"))?.ok_or_else(|| {
        names.invalid(format!("{f}.a.body"), "end `a` must be a body, not ground")
    })?;
    let b = match &j.b {
        Some(e) => names.end(e, format!("{f}.b"))?,
        None => None,
    };
    let frame = j
        .frame
        .unwrap_or([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]]);
    check_frame(&frame).map_err(|m| names.invalid(format!("{f}.frame"), m))?;
    let mut specs = Vec::new();
    if let Some(t) = j.template {
        let prefix = j.parameters.clone().ok_or_else(|| {
            names.invalid(
                format!("{f}.parameters"),
                "a template needs a parameter-name prefix",
            )
        })?;
        let lead = match (t, j.lead) {
            (Template::BallScrewNut, None) => {
                return Err(names.invalid(
                    format!("{f}.lead"),
                    "template ball_screw_nut needs the screw lead in m/rev",
                ))
            }
            (_, lead) => lead.unwrap_or(0.0),
        };
        finite(names.file, &format!("{f}.lead"), &[lead])?;
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
        return Err(names.invalid(
            f,
            format!("joint `{}` has no template and no connections", j.name),
        ));
    }
    let param = |name: &str, kind: ParameterKind, field: &str| {
        parameter_ref(parameters, name, kind, names.file, field)
    };
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
            .map(|n| param(n, ParameterKind::Stiffness, &field))
            .transpose()?;
        let damper = s
            .damper
            .as_deref()
            .map(|n| param(n, ParameterKind::Damping, &field))
            .transpose()?;
        connections.push(Connection {
            spec: s,
            stiffness,
            damper,
        });
    }
    Ok(Joint {
        name: j.name.clone(),
        a,
        b,
        frame,
        connections,
    })
}

/// The axes: a body (not ground) moving along a non-zero direction through
/// at least one position, with sliding joints from it to another body.
pub(crate) fn axes(
    spec: &ModelFile,
    names: &Names<'_>,
    joints: &[Joint],
) -> Result<Vec<Axis>, DynamicsError> {
    let mut axes = Vec::new();
    for (i, ax) in spec.axes.iter().enumerate() {
        let f = format!("axes[{i}]");
        let body = names
            .body(&ax.body, format!("{f}.body"))?
            .ok_or_else(|| names.invalid(format!("{f}.body"), "ground cannot move"))?;
        finite(names.file, &format!("{f}.direction"), &ax.direction)?;
        finite(names.file, &format!("{f}.positions"), &ax.positions)?;
        let n = ax.direction.iter().map(|x| x * x).sum::<f64>().sqrt();
        if n < 1e-12 {
            return Err(names.invalid(format!("{f}.direction"), "must be a non-zero vector"));
        }
        if ax.positions.is_empty() {
            return Err(names.invalid(format!("{f}.positions"), "list at least one position"));
        }
        let mut sliding = Vec::new();
        for (s_i, s) in ax.sliding.iter().enumerate() {
            let fs = format!("{f}.sliding[{s_i}]");
            let ji = joints
                .iter()
                .position(|j| &j.name == s)
                .ok_or_else(|| names.invalid(fs.clone(), format!("unknown joint `{s}`")))?;
            if joints[ji].a.body != body || joints[ji].b.is_none() {
                return Err(names.invalid(fs, format!("joint `{s}` must have end `a` on the moving body `{}` and end `b` on a body", ax.body)));
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
    Ok(axes)
}

/// Sensors or excitations (`what` names the list): a point of a body and a
/// UFF direction code ±1..±6.
pub(crate) fn point_dofs(
    list: &[model_file::PointDofSpec],
    what: &str,
    names: &Names<'_>,
) -> Result<Vec<PointDof>, DynamicsError> {
    let mut out = Vec::new();
    for (i, s) in list.iter().enumerate() {
        let f = format!("{what}[{i}]");
        if !(1..=6).contains(&s.direction.unsigned_abs()) {
            return Err(names.invalid(
                format!("{f}.direction"),
                "UFF direction code must be ±1..±6 (X Y Z RX RY RZ)",
            ));
        }
        let end = model_file::JointEndSpec {
            body: s.body.clone(),
            point: Some(s.point.clone()),
        };
        let e = names.end(&end, f.clone())?.ok_or_else(|| {
            names.invalid(format!("{f}.body"), "ground does not move; choose a body")
        })?;
        out.push(PointDof {
            name: s.name.clone(),
            end: e,
            dof: Dof::new(s.node, s.direction),
        });
    }
    Ok(out)
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
