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

impl FrfQuantity {
    /// `receptance`, `mobility` or `accelerance`.
    pub fn name(self) -> &'static str {
        match self {
            FrfQuantity::Receptance => "receptance",
            FrfQuantity::Mobility => "mobility",
            FrfQuantity::Accelerance => "accelerance",
        }
    }

    /// n of the factor (jω)ⁿ that turns receptance into this quantity.
    pub fn order(self) -> i32 {
        match self {
            FrfQuantity::Receptance => 0,
            FrfQuantity::Mobility => 1,
            FrfQuantity::Accelerance => 2,
        }
    }

    /// The SI unit of an FRF of this quantity.
    pub fn si_unit(self) -> &'static str {
        match self {
            FrfQuantity::Receptance => "m/N",
            FrfQuantity::Mobility => "m/s/N",
            FrfQuantity::Accelerance => "m/s²/N",
        }
    }
}

/// An FRF set converted to quantity `to` by (jω)ⁿ, n = order(to) − order(from)
/// (eq. 2.42 and its derivatives). Dividing by jω is undefined at 0 Hz: such
/// lines are dropped, and their count returned.
pub fn convert_quantity(set: &FrfSet, to: FrfQuantity) -> (FrfSet, usize) {
    let n = to.order() - set.quantity.order();
    if n == 0 {
        return (set.clone(), 0);
    }
    let keep: Vec<usize> = (0..set.frequencies_hz.len())
        .filter(|&i| n > 0 || set.frequencies_hz[i] != 0.0)
        .collect();
    let factor = |f: f64| Complex64::new(0.0, 2.0 * std::f64::consts::PI * f).powi(n);
    let out = FrfSet {
        position: set.position.clone(),
        quantity: to,
        frequencies_hz: keep.iter().map(|&i| set.frequencies_hz[i]).collect(),
        channels: set
            .channels
            .iter()
            .map(|c| FrfChannel {
                response: c.response,
                reference: c.reference,
                values: keep
                    .iter()
                    .map(|&i| c.values[i] * factor(set.frequencies_hz[i]))
                    .collect(),
                coherence: c
                    .coherence
                    .as_ref()
                    .map(|g| keep.iter().map(|&i| g[i]).collect()),
            })
            .collect(),
    };
    (out, set.frequencies_hz.len() - keep.len())
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

    /// The channel measuring the same physical FRF as response/reference:
    /// the exact channel, else the one at the same nodes and axes with
    /// directions of opposite sign on either side, with the factor (±1)
    /// that turns its values into the asked directions (a −Z transducer's
    /// FRF is −1 times the +Z one's; both flipped cancel).
    pub fn channel_signed(&self, response: Dof, reference: Dof) -> Option<(&FrfChannel, f64)> {
        if let Some(c) = self.channel(response, reference) {
            return Some((c, 1.0));
        }
        let flip = |asked: Dof, have: Dof| -> Option<f64> {
            if asked.node != have.node
                || asked.direction.unsigned_abs() != have.direction.unsigned_abs()
            {
                return None;
            }
            Some(if asked.direction == have.direction {
                1.0
            } else {
                -1.0
            })
        };
        self.channels.iter().find_map(|c| {
            let a = flip(response, c.response)?;
            let b = flip(reference, c.reference)?;
            Some((c, a * b))
        })
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantities_convert_by_powers_of_j_omega_and_back() {
        let set = FrfSet {
            quantity: FrfQuantity::Receptance,
            frequencies_hz: vec![0.0, 10.0, 25.0],
            channels: vec![FrfChannel {
                response: Dof::new(1, 1),
                reference: Dof::new(1, 1),
                values: vec![
                    Complex64::new(1e-6, 0.0),
                    Complex64::new(2e-6, -1e-6),
                    Complex64::new(-3e-7, 4e-7),
                ],
                coherence: Some(vec![1.0, 0.9, 0.8]),
            }],
            ..FrfSet::default()
        };
        let (acc, dropped) = convert_quantity(&set, FrfQuantity::Accelerance);
        assert_eq!(dropped, 0);
        let w = 2.0 * std::f64::consts::PI * 10.0;
        assert_eq!(
            acc.channels[0].values[1],
            set.channels[0].values[1] * (-w * w)
        );
        assert_eq!(acc.channels[0].values[0], Complex64::new(0.0, 0.0) * 1e-6);
        let (back, dropped) = convert_quantity(&acc, FrfQuantity::Receptance);
        assert_eq!(dropped, 1, "0 Hz cannot be divided by jω");
        assert_eq!(back.frequencies_hz, vec![10.0, 25.0]);
        for (a, b) in back.channels[0]
            .values
            .iter()
            .zip(&set.channels[0].values[1..])
        {
            assert!((a - b).norm() <= 1e-15 * b.norm());
        }
        assert_eq!(back.channels[0].coherence, Some(vec![0.9, 0.8]));
        let (mob, _) = convert_quantity(&set, FrfQuantity::Mobility);
        let expect =
            set.channels[0].values[2] * Complex64::new(0.0, 2.0 * std::f64::consts::PI * 25.0);
        assert_eq!(mob.channels[0].values[2], expect);
        assert_eq!(FrfQuantity::Mobility.si_unit(), "m/s/N");
    }

    /// The −Z response of a −Z excitation is the +Z/+Z FRF (signs cancel);
    /// one flipped side negates it; another node or axis is no match.
    #[test]
    fn signed_channels_match_by_node_and_axis() {
        let ch = |r: (u32, i8), q: (u32, i8)| FrfChannel {
            response: Dof::new(r.0, r.1),
            reference: Dof::new(q.0, q.1),
            values: vec![Complex64::new(2.0, 1.0)],
            coherence: None,
        };
        let set = FrfSet {
            channels: vec![ch((3, -3), (5, -3)), ch((2, -3), (2, 3))],
            ..FrfSet::default()
        };
        let (c, s) = set.channel_signed(Dof::new(3, 3), Dof::new(5, 3)).unwrap();
        assert_eq!((c.response, s), (Dof::new(3, -3), 1.0));
        let (_, s) = set.channel_signed(Dof::new(2, 3), Dof::new(2, 3)).unwrap();
        assert_eq!(s, -1.0);
        let (_, s) = set
            .channel_signed(Dof::new(3, -3), Dof::new(5, -3))
            .unwrap();
        assert_eq!(s, 1.0);
        assert!(set.channel_signed(Dof::new(3, 1), Dof::new(5, 3)).is_none());
        assert!(set.channel_signed(Dof::new(4, 3), Dof::new(5, 3)).is_none());
    }
}
