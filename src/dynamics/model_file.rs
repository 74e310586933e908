//! The model-file schema (YAML, parsed from `&str` with serde,
//! `deny_unknown_fields` everywhere): parameters, bodies, joints, axes,
//! sensors and excitations exactly as a user writes them. Checking names and
//! values is the job of [`crate::dynamics::model`]; this file only says what
//! may be written.

use super::error::DynamicsError;
use super::templates::Template;
use crate::parameter::Scale;
use serde::Deserialize;
use std::collections::BTreeMap;

/// Top level of a model file.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelFile {
    /// Identifiable stiffness and damping parameters (name, truth, bounds).
    pub parameters: Vec<ParameterSpec>,
    pub bodies: Vec<BodySpec>,
    #[serde(default)]
    pub joints: Vec<JointSpec>,
    #[serde(default)]
    pub axes: Vec<AxisSpec>,
    #[serde(default)]
    pub sensors: Vec<PointDofSpec>,
    #[serde(default)]
    pub excitations: Vec<PointDofSpec>,
    /// Lumped point masses added to a body at one of its points.
    #[serde(default)]
    pub masses: Vec<PointMassSpec>,
    /// Eigensolver settings (default: chosen by size and fill).
    #[serde(default)]
    pub solver: SolverSpec,
    /// The model's vertical (upward) global axis, if stated: evaluate names
    /// the mode-shape views top, front and side from it. Presentation only;
    /// the assembly never reads it.
    #[serde(default)]
    pub vertical: Option<Axis>,
}

/// A global axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    /// 0, 1 or 2 for x, y or z.
    pub fn index(self) -> usize {
        self as usize
    }
}

/// Which eigensolver path a model uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum SolverMethod {
    /// Dense below 1,500 DOF or above 5 % fill, sparse otherwise.
    #[default]
    Auto,
    /// Dense Cholesky of K + σM (reduced models).
    Dense,
    /// Sparse Cholesky of K + σM, symbolic analysis once (unreduced FE).
    Sparse,
}

/// `solver:` block of a model file.
#[derive(Debug, Clone, Copy, PartialEq, Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct SolverSpec {
    #[serde(default)]
    pub method: SolverMethod,
    /// Lanczos block size, 1..=16 (default 4): eigenvalues of multiplicity
    /// up to the block size are found.
    pub block: Option<usize>,
    /// Shift of the shift-invert eigensolver as a frequency f > 0, Hz: the
    /// solver factors K + (2πf)² M. Default: chosen from the problem
    /// (rigid-body modes detected, f below the first elastic mode;
    /// [`crate::dynamics::shift`]).
    pub shift: Option<f64>,
}

impl ModelFile {
    /// Files the model reads besides itself (super-element matrices), as
    /// written, relative to the model file. Pipelines hash them by content.
    pub fn external_files(&self) -> Vec<String> {
        self.bodies
            .iter()
            .filter_map(|b| b.superelement.as_ref())
            .flat_map(|s| {
                [
                    Some(s.mass.clone()),
                    Some(s.stiffness.clone()),
                    s.mapping.clone(),
                ]
            })
            .flatten()
            .collect()
    }
}

/// Physical meaning of a parameter.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ParameterKind {
    /// Spring stiffness, N/m (translation) or N·m/rad (rotation).
    Stiffness,
    /// Viscous coefficient b (N·s/m) or hysteretic coefficient d (N/m),
    /// depending on the damper that uses it.
    Damping,
}

#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterSpec {
    pub name: String,
    /// The true (reference) value, used for synthesis.
    pub value: f64,
    pub lower: f64,
    pub upper: f64,
    pub scale: Scale,
    pub kind: ParameterKind,
}

/// One body: exactly one of `rigid`, `beam`, `superelement`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    pub name: String,
    pub rigid: Option<RigidSpec>,
    pub beam: Option<BeamSpec>,
    pub superelement: Option<SuperelementSpec>,
}

/// A rigid body with 6 DOF at its centre of gravity.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RigidSpec {
    /// kg.
    pub mass: f64,
    /// Inertia tensor about the centre of gravity, kg·m², 3×3 rows in global axes.
    pub inertia: [[f64; 3]; 3],
    /// Centre of gravity, m, global coordinates (at axis position 0).
    pub cg: [f64; 3],
    /// Named points, global coordinates in m.
    #[serde(default)]
    pub points: BTreeMap<String, [f64; 3]>,
    /// Active DOFs (default all six); the others are held rigidly, e.g.
    /// `dofs: [x]` for a lumped mass moving along x only.
    pub dofs: Option<Vec<Direction>>,
}

/// Straight 3D beam of equal 12-DOF Euler-Bernoulli elements.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BeamSpec {
    /// First and last node, m.
    pub start: [f64; 3],
    pub end: [f64; 3],
    /// Number of elements (nodes = elements + 1, numbered 0..=elements).
    pub elements: usize,
    /// A vector in the local x-y plane fixing the section's y axis.
    pub orientation: [f64; 3],
    pub section: SectionSpec,
    /// Named points: a node plus an optional rigid offset (m).
    #[serde(default)]
    pub points: BTreeMap<String, NodePointSpec>,
    /// Optional Craig-Bampton reduction (eq. 3.1–3.4).
    pub reduction: Option<ReductionSpec>,
    /// Material (hysteretic) loss factor η of the body: D_body = η K_body
    /// (eq. 2.51, structural damping); default 0. Steel ~0.001–0.002, cast
    /// iron ~0.002–0.005. A number or the name of a `damping` parameter.
    #[serde(default)]
    pub loss_factor: SectionValue,
}

/// A section or material value: a number, or the name of a model parameter
/// (`E: beam.E`), which then varies with that parameter like a joint's
/// stiffness does.
#[derive(Debug, Clone, PartialEq, Deserialize)]
#[serde(untagged)]
pub enum SectionValue {
    Number(f64),
    Parameter(String),
}

impl Default for SectionValue {
    fn default() -> Self {
        SectionValue::Number(0.0)
    }
}

/// Beam cross-section and material, SI units.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
#[allow(non_snake_case)]
pub struct SectionSpec {
    /// Area, m².
    pub A: f64,
    /// Second moment about local y (bending in the local x-z plane), m⁴.
    pub Iy: f64,
    /// Second moment about local z (bending in the local x-y plane), m⁴.
    pub Iz: f64,
    /// Torsion constant, m⁴.
    pub J: f64,
    /// Young's modulus, Pa, or a `stiffness` parameter's name.
    pub E: SectionValue,
    /// Shear modulus, Pa, or a `stiffness` parameter's name.
    pub G: SectionValue,
    /// Density, kg/m³.
    pub rho: f64,
}

/// A point of a flexible body: a node and a rigid offset from it.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NodePointSpec {
    pub node: u64,
    #[serde(default)]
    pub offset: [f64; 3],
}

/// Craig-Bampton settings: boundary DOFs are all nodes used by joints,
/// sensors and excitations; `modes` fixed-interface modes are kept.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ReductionSpec {
    pub modes: usize,
}

/// An FE body exported from other software: mass and stiffness matrices
/// (Matrix Market, Harwell–Boeing/ANSYS HBMAT, Abaqus coordinate `.mtx`,
/// Nastran DMIG punch) plus node positions; the DOF rows of each node come
/// from the files' node/DOF labels where the format carries them.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuperelementSpec {
    /// Paths relative to the model file.
    pub mass: String,
    pub stiffness: String,
    /// File format (default: recognized from the content).
    pub format: Option<FeFormat>,
    /// DMIG matrix names in a punch file (default `MAAX`, `KAAX`).
    pub mass_matrix: Option<String>,
    pub stiffness_matrix: Option<String>,
    /// ANSYS `.MAPPING` file of a Harwell–Boeing export (equation → node,
    /// DOF), relative to the model file.
    pub mapping: Option<String>,
    pub nodes: Vec<SuperNodeSpec>,
    #[serde(default)]
    pub points: BTreeMap<String, NodePointSpec>,
    pub reduction: Option<ReductionSpec>,
    /// Material (hysteretic) loss factor η of the body: D_body = η K_body
    /// (eq. 2.51, structural damping); default 0. Steel ~0.001–0.002, cast
    /// iron ~0.002–0.005.
    #[serde(default)]
    pub loss_factor: f64,
    /// DOFs held fixed (clamped node sets), removed from M and K before
    /// anything else ([`crate::dynamics::constraints`]); node rows are
    /// given in the files' numbering, before the constraint.
    #[serde(default)]
    pub constraints: Vec<ConstraintSpec>,
}

/// One constraint of a super-element: the listed directions of every
/// selected node are fixed (u = 0). The selection is the union of `nodes`,
/// `plane` and `box`; at least one must be given and it must select a node.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConstraintSpec {
    /// A name for messages (optional).
    pub name: Option<String>,
    /// Fixed directions (default: every DOF the node has, a clamp).
    pub dofs: Option<Vec<Direction>>,
    /// Node ids: listed in `nodes:`, or labelled in the matrix files.
    #[serde(default)]
    pub nodes: Vec<u64>,
    /// Every node of `nodes:` on a coordinate plane.
    pub plane: Option<PlaneSpec>,
    /// Every node of `nodes:` inside an axis-aligned box.
    #[serde(rename = "box")]
    pub inside: Option<BoxSpec>,
}

/// The nodes with |x_axis − value| ≤ tol (m).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PlaneSpec {
    pub axis: Axis,
    /// m.
    pub value: f64,
    /// m, ≥ 0 (default 1e-6: a micrometre, far below any element size and
    /// far above the rounding of exported coordinates).
    #[serde(default = "default_plane_tol")]
    pub tol: f64,
}

fn default_plane_tol() -> f64 {
    1e-6
}

/// The nodes with min ≤ x ≤ max in every coordinate (m, bounds included).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct BoxSpec {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

/// Formats of FE matrix exports ([`crate::io::fe`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FeFormat {
    MatrixMarket,
    HarwellBoeing,
    Abaqus,
    NastranDmig,
}

/// One node of a super-element: its id, position and the 0-based matrix
/// rows of its DOFs, either 6 (x, y, z, rx, ry, rz) or 3 translational;
/// `dofs` may be left out when the files label rows by node and DOF
/// (Abaqus, DMIG, Harwell–Boeing with a mapping file).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SuperNodeSpec {
    pub id: u64,
    #[serde(default)]
    pub dofs: Vec<usize>,
    /// Node position, m.
    pub position: [f64; 3],
}

/// One end of a joint: a named point of a body, or `ground`.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointEndSpec {
    pub body: String,
    /// Required unless `body` is `ground`.
    pub point: Option<String>,
}

/// Local direction of a scalar connection in the joint frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    X,
    Y,
    Z,
    Rx,
    Ry,
    Rz,
}

impl Direction {
    pub fn index(self) -> usize {
        self as usize
    }
}

/// Damper law: viscous (eq. 2.50, matrix B) or hysteretic (eq. 2.51, matrix D).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum DampingModel {
    #[default]
    Viscous,
    Hysteretic,
}

/// One explicit scalar connection.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ConnectionSpec {
    pub dir: Direction,
    /// Stiffness parameter name (optional: damper only).
    pub stiffness: Option<String>,
    /// Damping parameter name (optional: spring only).
    pub damper: Option<String>,
    pub damping: Option<DampingModel>,
}

/// A joint: a set of scalar spring-damper connections between two points.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointSpec {
    pub name: String,
    pub a: JointEndSpec,
    /// Second end; absent means ground.
    pub b: Option<JointEndSpec>,
    /// Rows are the joint frame's local x, y, z axes in global coordinates
    /// (orthonormal, right-handed). Default: global axes.
    pub frame: Option<[[f64; 3]; 3]>,
    /// A component pattern of table 3.1; needs `parameters`.
    pub template: Option<Template>,
    /// Parameter-name prefix for a template: `<prefix>.k_<dir>`, `<prefix>.c_<dir>`.
    pub parameters: Option<String>,
    /// Damper law for a template's dampers (default viscous).
    pub damping: Option<DampingModel>,
    /// Screw lead in m/rev for the `ball_screw_nut` template.
    pub lead: Option<f64>,
    /// Explicit connections (instead of, or in addition to, a template).
    #[serde(default)]
    pub connections: Vec<ConnectionSpec>,
}

/// A linear axis: moving `body` along `direction` makes one configuration
/// per listed position; the `b` ends of the `sliding` joints follow.
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisSpec {
    pub name: String,
    pub body: String,
    pub direction: [f64; 3],
    /// Positions in m along `direction`.
    pub positions: Vec<f64>,
    #[serde(default)]
    pub sliding: Vec<String>,
}

/// A sensor or excitation: a point of a body, a UFF node number and a UFF
/// direction code (±1..±3 translations, ±4..±6 rotations, global axes).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointDofSpec {
    pub name: String,
    pub body: String,
    pub point: String,
    pub node: u32,
    pub direction: i8,
}

/// A lumped point mass (an accelerometer, a force gauge, a clamp) fixed to
/// a named point of a body: kg, moving with the point in the listed global
/// translations (default all three), no rotary inertia and no DOF of its
/// own (M += m Pᵀ P over the point's translation rows P).
#[derive(Debug, Clone, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct PointMassSpec {
    pub name: String,
    pub body: String,
    pub point: String,
    /// kg, > 0.
    pub mass: f64,
    /// Global translations the mass follows (`[z]`: it adds inertia in z only).
    pub directions: Option<Vec<Direction>>,
}

/// Parse a model file from text; `file` names it in error messages.
pub fn parse(text: &str, file: &str) -> Result<ModelFile, DynamicsError> {
    if let Err(deep) = crate::yaml::check_depth(text) {
        return Err(DynamicsError::Syntax {
            file: file.to_string(),
            location: format!("line {} column {}", deep.line, deep.column),
            message: deep.to_string(),
        });
    }
    serde_yaml_ng::from_str(text).map_err(|e| DynamicsError::Syntax {
        file: file.to_string(),
        location: match e.location() {
            Some(l) => format!("line {} column {}", l.line(), l.column()),
            None => "at top level".to_string(),
        },
        message: e.to_string(),
    })
}

#[cfg(test)]
mod tests {
    use super::{parse, Axis};

    const BARE: &str = "parameters: []\nbodies: [{name: b, rigid: {mass: 1, inertia: [[1, 0, 0], [0, 1, 0], [0, 0, 1]], cg: [0, 0, 0]}}]\n";

    #[test]
    fn vertical_is_optional_and_an_axis() {
        assert_eq!(parse(BARE, "m.yaml").unwrap().vertical, None);
        let y = parse(&format!("{BARE}vertical: y\n"), "m.yaml").unwrap();
        assert_eq!(y.vertical.map(Axis::index), Some(1));
        let bad = parse(&format!("{BARE}vertical: up\n"), "m.yaml").unwrap_err();
        let message = bad.to_string();
        assert!(
            message.contains("m.yaml") && message.contains("line 3"),
            "{message}"
        );
    }
}
