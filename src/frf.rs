//! Frequency-response data as every stage sees it: one [`FrfSet`] per model
//! configuration (axis position), each a list of response/reference channels on
//! a common frequency axis.
//!
//! This is the in-memory form of the `frf` artifact. The `synthesize` and
//! `import` stages produce it (serialized as UFF 58b by `crate::io`), `autoema`
//! and `evaluate` consume it. Degrees of freedom use the UFF convention (node
//! number plus a signed direction code) so imported measurements and synthetic
//! data are addressed the same way.

use num_complex::Complex64;

/// A measurement degree of freedom: a node and a UFF direction code.
///
/// Direction codes follow UFF record 6: 0 scalar, ±1 X, ±2 Y, ±3 Z,
/// ±4 RX, ±5 RY, ±6 RZ (sign = orientation of the transducer).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Dof {
    pub node: u32,
    pub direction: i8,
}

impl Dof {
    pub fn new(node: u32, direction: i8) -> Self {
        Dof { node, direction }
    }

    /// Axis label for tables and plots, e.g. `+X`, `-RZ`, `S` for scalar.
    pub fn direction_label(&self) -> String {
        let axis = match self.direction.unsigned_abs() {
            0 => return "S".to_string(),
            1 => "X",
            2 => "Y",
            3 => "Z",
            4 => "RX",
            5 => "RY",
            6 => "RZ",
            _ => "?",
        };
        let sign = if self.direction < 0 { '-' } else { '+' };
        format!("{sign}{axis}")
    }
}

impl std::fmt::Display for Dof {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}{}", self.node, self.direction_label())
    }
}

/// What the FRF relates to force: displacement (receptance), velocity
/// (mobility) or acceleration (accelerance/inertance). Eq. 2.42 gives
/// receptance; the others follow by multiplying with jω and −ω².
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub enum FrfQuantity {
    #[default]
    Receptance,
    Mobility,
    Accelerance,
}

/// One FRF H_jk(ω): response DOF j over reference (excitation) DOF k.
#[derive(Clone, Debug, PartialEq)]
pub struct FrfChannel {
    pub response: Dof,
    pub reference: Dof,
    /// Complex FRF values, one per frequency line of the owning set, SI units
    /// (m/N for receptance).
    pub values: Vec<Complex64>,
    /// Ordinary coherence γ² ∈ [0, 1] per frequency line (eq. 2.58), when the
    /// data come from a measured or simulated test.
    pub coherence: Option<Vec<f64>>,
}

/// An axis position (model configuration) that an FRF set or modal model
/// belongs to.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Position {
    /// 0-based configuration index, stable across stages.
    pub index: u32,
    /// Human-readable label, e.g. `wpt=0.250`; empty for single-configuration data.
    pub label: String,
}

/// All FRF channels of one configuration on one frequency axis.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct FrfSet {
    pub position: Position,
    pub quantity: FrfQuantity,
    /// Frequency lines in Hz, strictly increasing.
    pub frequencies_hz: Vec<f64>,
    pub channels: Vec<FrfChannel>,
}

impl FrfSet {
    /// Distinct response DOFs in first-appearance order.
    pub fn responses(&self) -> Vec<Dof> {
        distinct(self.channels.iter().map(|c| c.response))
    }

    /// Distinct reference DOFs in first-appearance order.
    pub fn references(&self) -> Vec<Dof> {
        distinct(self.channels.iter().map(|c| c.reference))
    }

    /// The channel for a response/reference pair, if measured.
    pub fn channel(&self, response: Dof, reference: Dof) -> Option<&FrfChannel> {
        self.channels
            .iter()
            .find(|c| c.response == response && c.reference == reference)
    }
}

fn distinct(it: impl Iterator<Item = Dof>) -> Vec<Dof> {
    let mut out: Vec<Dof> = Vec::new();
    for d in it {
        if !out.contains(&d) {
            out.push(d);
        }
    }
    out
}
