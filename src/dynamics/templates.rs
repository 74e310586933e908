//! Component patterns of table 3.1 (seed section 3.1.1, after REBELEIN 2019
//! and OERTLI 2008): which local directions of a joint carry a spring and
//! which a damper. `template: guide_shoe` with `parameters: lgs1` expands to
//! the connections `lgs1.k_y`, `lgs1.k_z`, `lgs1.c_y`, `lgs1.c_z`.
//!
//! Local x is the component's axis: the bearing/screw/coupling axis, the
//! rail (moving) direction of a guide shoe, and any direction for a mounting
//! element.
//!
//! The ball-screw nut uses a reduced form of Oertli's ten-spring model: the
//! axial spring acts on the coordinate δ = Δu_x + (lead/2π)·Δθ_x that couples
//! nut translation and screw rotation (the "screw DOF" itself stays free),
//! plus radial (y, z) and tilting (ry, rz) springs, and dampers in all
//! translations (the axial one on the same coupled coordinate), 5 springs and
//! 3 dampers.

use super::model_file::{DampingModel, Direction};
use serde::Deserialize;

/// A named component pattern of table 3.1.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Template {
    /// Machine mount: springs and dampers in all translations.
    MountingElement,
    /// Fixed bearing: springs and dampers in all translations.
    FixedBearing,
    /// Loose bearing: lateral springs (y, z), dampers in all translations.
    LooseBearing,
    /// Elastic coupling: springs and dampers in all six directions.
    Coupling,
    /// Linear guide shoe: springs and dampers in the lateral translations.
    GuideShoe,
    /// Ball-screw nut (see module docs).
    BallScrewNut,
    /// Energy chain: axial damper only.
    EnergyChain,
}

/// One scalar connection after template expansion: the relative coordinate
/// δ = Σ_i w_i (w_a,i − w_b,i) over the six local DOFs (x, y, z, rx, ry, rz)
/// of the two joint points, with optional spring and damper parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct ScalarConnection {
    /// Label for messages, e.g. `guide_shoe.y`.
    pub label: String,
    pub weights: [f64; 6],
    pub stiffness: Option<String>,
    pub damper: Option<String>,
    pub damping: DampingModel,
}

/// A unit weight vector in one local direction.
pub fn unit(dir: Direction) -> [f64; 6] {
    let mut w = [0.0; 6];
    w[dir.index()] = 1.0;
    w
}

fn name(d: Direction) -> &'static str {
    match d {
        Direction::X => "x",
        Direction::Y => "y",
        Direction::Z => "z",
        Direction::Rx => "rx",
        Direction::Ry => "ry",
        Direction::Rz => "rz",
    }
}

impl Template {
    /// Local directions with a spring and with a damper (table 3.1).
    pub fn pattern(self) -> (&'static [Direction], &'static [Direction]) {
        use Direction::*;
        const T: &[Direction] = &[X, Y, Z];
        const ALL: &[Direction] = &[X, Y, Z, Rx, Ry, Rz];
        const LAT: &[Direction] = &[Y, Z];
        match self {
            Template::MountingElement | Template::FixedBearing => (T, T),
            Template::LooseBearing => (LAT, T),
            Template::Coupling => (ALL, ALL),
            Template::GuideShoe => (LAT, LAT),
            Template::BallScrewNut => (&[X, Y, Z, Ry, Rz], T),
            Template::EnergyChain => (&[], &[X]),
        }
    }

    /// Expand into scalar connections with parameter names `<prefix>.k_<dir>`
    /// and `<prefix>.c_<dir>`. `lead` (m/rev) is used by `ball_screw_nut` only.
    pub fn expand(self, prefix: &str, damping: DampingModel, lead: f64) -> Vec<ScalarConnection> {
        let (springs, dampers) = self.pattern();
        let mut out = Vec::new();
        for d in [
            Direction::X,
            Direction::Y,
            Direction::Z,
            Direction::Rx,
            Direction::Ry,
            Direction::Rz,
        ] {
            let k = springs.contains(&d);
            let c = dampers.contains(&d);
            if !k && !c {
                continue;
            }
            let mut weights = unit(d);
            if self == Template::BallScrewNut && d == Direction::X {
                // Axial nut deflection includes the screw's rotation times lead/2π.
                weights[3] = lead / (2.0 * std::f64::consts::PI);
            }
            out.push(ScalarConnection {
                label: format!("{prefix}.{}", name(d)),
                weights,
                stiffness: k.then(|| format!("{prefix}.k_{}", name(d))),
                damper: c.then(|| format!("{prefix}.c_{}", name(d))),
                damping,
            });
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_3_1_counts() {
        // (springs, dampers) per component as listed in table 3.1.
        let expect = [
            (Template::LooseBearing, 2, 3),
            (Template::FixedBearing, 3, 3),
            (Template::Coupling, 6, 6),
            (Template::GuideShoe, 2, 2),
            (Template::MountingElement, 3, 3),
            (Template::EnergyChain, 0, 1),
        ];
        for (t, k, c) in expect {
            let e = t.expand("p", DampingModel::Viscous, 0.0);
            assert_eq!(
                e.iter().filter(|s| s.stiffness.is_some()).count(),
                k,
                "{t:?}"
            );
            assert_eq!(e.iter().filter(|s| s.damper.is_some()).count(), c, "{t:?}");
        }
    }

    #[test]
    fn nut_couples_axial_and_rotation() {
        let e = Template::BallScrewNut.expand("nut", DampingModel::Viscous, 0.02);
        let x = &e[0];
        assert_eq!(x.stiffness.as_deref(), Some("nut.k_x"));
        assert!((x.weights[3] - 0.02 / (2.0 * std::f64::consts::PI)).abs() < 1e-15);
    }
}
