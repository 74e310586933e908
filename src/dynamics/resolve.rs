//! Name resolution of a model file: joints, axes, sensors and excitations
//! refer to bodies, points, joints and parameters by name; here each name
//! becomes an index (checked to exist, of the right kind), templates are
//! expanded, and every error names the file and the field
//! (`joints[3].a.point`) with the names that do exist.

use super::error::DynamicsError;
use super::model::{
    parameter_ref, Axis, Body, BodyKind, Connection, End, Joint, Parameter, PointDof, PointMass,
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

/// Lumped point masses: each named once, on an existing point of a body,
/// with a finite mass > 0 (kg) and distinct translational directions.
pub(crate) fn point_masses(
    list: &[model_file::PointMassSpec],
    names: &Names<'_>,
) -> Result<Vec<PointMass>, DynamicsError> {
    let mut out: Vec<PointMass> = Vec::new();
    for (i, m) in list.iter().enumerate() {
        let f = format!("masses[{i}]");
        if list[..i].iter().any(|o| o.name == m.name) {
            return Err(names.invalid(
                format!("{f}.name"),
                format!("mass `{}` defined twice", m.name),
            ));
        }
        if !(m.mass.is_finite() && m.mass > 0.0) {
            return Err(names.invalid(
                format!("{f}.mass"),
                format!(
                    "`{}`: a mass in kg, finite and > 0 (got {})",
                    m.name, m.mass
                ),
            ));
        }
        let end = model_file::JointEndSpec {
            body: m.body.clone(),
            point: Some(m.point.clone()),
        };
        let end = names.end(&end, f.clone())?.ok_or_else(|| {
            names.invalid(format!("{f}.body"), "ground does not move; choose a body")
        })?;
        let dirs = m.directions.clone().unwrap_or_else(|| {
            use model_file::Direction::{X, Y, Z};
            vec![X, Y, Z]
        });
        let mut axes: Vec<usize> = Vec::new();
        for (k, d) in dirs.iter().enumerate() {
            let a = d.index();
            if a > 2 || axes.contains(&a) {
                return Err(names.invalid(
                    format!("{f}.directions[{k}]"),
                    "list distinct translations x, y, z (a point mass has no rotary inertia: \
                     use a rigid body for that)",
                ));
            }
            axes.push(a);
        }
        if axes.is_empty() {
            return Err(names.invalid(format!("{f}.directions"), "list at least one of x, y, z"));
        }
        out.push(PointMass {
            end,
            mass: m.mass,
            axes,
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

#[cfg(test)]
mod tests {
    //! Point masses (`masses:`): known answers and located errors.
    use crate::dynamics::{DynamicsError, Model, PreparedModel};

    fn model(yaml: &str) -> Result<Model, DynamicsError> {
        let no_files = |p: &str| -> std::io::Result<Vec<u8>> { std::fs::read(p) };
        Model::from_yaml(yaml, "m.yaml", &no_files)
    }

    fn lowest_hz(m: &Model, n: usize) -> Vec<f64> {
        let p = PreparedModel::new(m).unwrap();
        p.evaluate(0, &m.true_values(), n).unwrap().frequencies_hz()
    }

    const TWO_DOF: &str = r#"
parameters:
  - {name: k, value: 8.0e+4, lower: 1.0, upper: 1.0e+9, scale: log, kind: stiffness}
  - {name: kr, value: 3.0e+3, lower: 1.0, upper: 1.0e+9, scale: log, kind: stiffness}
bodies:
  - name: m
    rigid: {mass: 2.0, inertia: [[1, 0, 0], [0, 0.05, 0], [0, 0, 1]], cg: [0, 0, 0],
            points: {c: [0, 0, 0], tip: [0.3, 0, 0]}, dofs: [z, ry]}
joints:
  - {name: s, a: {body: m, point: c}, connections: [{dir: z, stiffness: k}, {dir: ry, stiffness: kr}]}
MASSES
"#;

    /// Spring–mass known answers: a point mass m_a at the centre gives
    /// ω² = k/(m + m_a) exactly; at an offset r along x it couples
    /// bounce and pitch: det(K − ω² M) = 0 with M = [[m + m_a, −m_a r],
    /// [−m_a r, J + m_a r²]] (u_z,tip = u_z − r θ_y).
    #[test]
    fn spring_mass_with_added_point_masses() {
        let two_pi = 2.0 * std::f64::consts::PI;
        let bare = lowest_hz(&model(&TWO_DOF.replace("MASSES", "")).unwrap(), 2);
        let centre = TWO_DOF.replace(
            "MASSES",
            "masses: [{name: a, body: m, point: c, mass: 0.5, directions: [z]}]",
        );
        let f = lowest_hz(&model(&centre).unwrap(), 2);
        let (wz, wr) = ((8.0e4f64 / 2.5).sqrt(), (3.0e3f64 / 0.05).sqrt());
        let mut want = [wz / two_pi, wr / two_pi];
        want.sort_by(f64::total_cmp);
        for (g, w) in f.iter().zip(want) {
            assert!(
                (g / w - 1.0).abs() < 1e-10,
                "{f:?} vs {want:?} (bare {bare:?})"
            );
        }
        // Offset mass: the 2×2 generalized eigenproblem in closed form.
        let tip = TWO_DOF.replace(
            "MASSES",
            "masses: [{name: a, body: m, point: tip, mass: 0.4}]",
        );
        let f = lowest_hz(&model(&tip).unwrap(), 2);
        let (ma, r, m, j, k, kr): (f64, f64, f64, f64, f64, f64) =
            (0.4, 0.3, 2.0, 0.05, 8.0e4, 3.0e3);
        let (m11, m12, m22) = (m + ma, -ma * r, j + ma * r * r);
        // det([[k − λ m11, −λ m12], [−λ m12, kr − λ m22]]) = a λ² + b λ + c.
        let a = m11 * m22 - m12 * m12;
        let b = -(k * m22 + kr * m11);
        let c = k * kr;
        let d = (b * b - 4.0 * a * c).sqrt();
        let want = [(-b - d) / (2.0 * a), (-b + d) / (2.0 * a)].map(|l: f64| l.sqrt() / two_pi);
        for (g, w) in f.iter().zip(want) {
            assert!((g / w - 1.0).abs() < 1e-10, "{f:?} vs {want:?}");
        }
    }

    /// Cantilever with a tip mass μ ρAL: the exact Euler–Bernoulli
    /// frequency equation 1 + cos λ cosh λ + μ λ (cos λ sinh λ − sin λ cosh λ)
    /// = 0, ω = λ² √(EI/(ρ A L⁴)) (Blevins, table 8-8), for the lowest two
    /// bending modes in z; 40 elements, the clamp as 1e14 springs.
    #[test]
    fn cantilever_with_tip_mass_matches_the_exact_frequency_equation() {
        let (e, iy, rho, a, l) = (2.1e11, 1.0e-9, 7850.0, 1.2e-4, 0.6);
        let mu = 0.8;
        let tip = mu * rho * a * l;
        let yaml = format!(
            r#"
parameters:
  - {{name: clamp, value: 1.0e+14, lower: 1.0, upper: 1.0e+15, scale: log, kind: stiffness}}
bodies:
  - name: b
    beam:
      start: [0, 0, 0]
      end: [{l}, 0, 0]
      elements: 40
      orientation: [0, 1, 0]
      section: {{A: {a}, Iy: {iy}, Iz: 1.0e-6, J: 1.0e-6, E: {e}, G: 8.0e+10, rho: {rho}}}
      points: {{root: {{node: 0}}, tip: {{node: 40}}}}
joints:
  - name: clamp
    a: {{body: b, point: root}}
    connections:
      - {{dir: x, stiffness: clamp}}
      - {{dir: y, stiffness: clamp}}
      - {{dir: z, stiffness: clamp}}
      - {{dir: rx, stiffness: clamp}}
      - {{dir: ry, stiffness: clamp}}
      - {{dir: rz, stiffness: clamp}}
masses: [{{name: tip, body: b, point: tip, mass: {tip}, directions: [z]}}]
"#
        );
        let f = lowest_hz(&model(&yaml).unwrap(), 2);
        let g =
            |x: f64| 1.0 + x.cos() * x.cosh() + mu * x * (x.cos() * x.sinh() - x.sin() * x.cosh());
        let root = |mut lo: f64, mut hi: f64| {
            for _ in 0..200 {
                let mid = 0.5 * (lo + hi);
                if g(lo).signum() == g(mid).signum() {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            0.5 * (lo + hi)
        };
        let c = (e * iy / (rho * a * l.powi(4))).sqrt() / (2.0 * std::f64::consts::PI);
        // μ = 0.8: λ₁ ≈ 1.2, λ₂ ≈ 4.0 (between the clamped-free 1.875, 4.694
        // and the pinned-free values).
        let want = [root(0.5, 1.875), root(3.0, 4.694)].map(|x| x * x * c);
        for (got, w) in f.iter().zip(want) {
            assert!((got / w - 1.0).abs() < 1e-3, "{f:?} vs {want:?}");
        }
        // Without the mass the same beam is the clamped-free one (λ₁ 1.8751).
        let bare = lowest_hz(&model(&yaml.replace("masses: [", "#")).unwrap(), 1);
        assert!(
            (bare[0] / (1.875_104f64.powi(2) * c) - 1.0).abs() < 1e-3,
            "{bare:?}"
        );
    }

    /// Bad point masses fail with the file and the field, never a panic.
    #[test]
    fn bad_point_masses_are_located_errors() {
        for (masses, field) in [
            ("[{name: a, body: m, point: c, mass: -1.0}]", "masses[0].mass"),
            ("[{name: a, body: m, point: c, mass: .nan}]", "masses[0].mass"),
            ("[{name: a, body: m, point: nowhere, mass: 1.0}]", "masses[0].point"),
            ("[{name: a, body: w, point: c, mass: 1.0}]", "masses[0].body"),
            ("[{name: a, body: ground, point: c, mass: 1.0}]", "masses[0].body"),
            (
                "[{name: a, body: m, point: c, mass: 1.0, directions: [rx]}]",
                "masses[0].directions[0]",
            ),
            (
                "[{name: a, body: m, point: c, mass: 1.0, directions: [z, z]}]",
                "masses[0].directions[1]",
            ),
            ("[{name: a, body: m, point: c, mass: 1.0, directions: []}]", "masses[0].directions"),
            (
                "[{name: a, body: m, point: c, mass: 1.0}, {name: a, body: m, point: c, mass: 1.0}]",
                "masses[1].name",
            ),
        ] {
            let err = model(&TWO_DOF.replace("MASSES", &format!("masses: {masses}")))
                .unwrap_err()
                .to_string();
            assert!(err.contains("m.yaml") && err.contains(field), "{masses}: {err}");
        }
        let err = model(&TWO_DOF.replace("MASSES", "masses: [{name: a, body: m, mass: 1.0}]"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("m.yaml") && err.contains("line"), "{err}");
    }
}
