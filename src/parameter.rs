//! Bounded parameters, their scale, and the one map between a parameter's
//! range and the unit interval.
//!
//! Samplers (Sobol, Latin hypercube) and optimizers (PSO, GA, SLSQP,
//! Levenberg–Marquardt) work on the unit hypercube; a [`Scale`] maps a unit
//! coordinate `u ∈ [0, 1]` to its physical value, linearly or in decades:
//!
//! - linear: `x = lower + u (upper − lower)`
//! - log:    `log10 x = log10 lower + u (log10 upper − log10 lower)`, so every
//!   decade of a stiffness range gets the same share of the samples
//!   (`lower > 0` required).
//!
//! Every user of a scale — model files, the GSA's command models, the
//! optimizers' [`crate::optimize::Bounds`], the simulators' [`Parameter`] —
//! goes through [`Scale::from_unit`] / [`Scale::to_unit`], so a point means
//! the same physical value in a GSA sample and in an identification.

use serde::{Deserialize, Serialize};

/// How a parameter's range maps onto the unit interval.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Scale {
    /// `x = lower + u (upper − lower)`.
    #[default]
    Linear,
    /// Uniform in log10(x); needs `0 < lower`.
    Log,
}

impl Scale {
    /// Every scale, in the order pipeline and model files list them.
    pub const ALL: [Scale; 2] = [Scale::Linear, Scale::Log];

    /// The name as written in model and pipeline files.
    pub fn as_str(self) -> &'static str {
        match self {
            Scale::Linear => "linear",
            Scale::Log => "log",
        }
    }

    /// Physical value of the unit coordinate `u` on `[lower, upper]` (not
    /// clamped: `u` outside [0, 1] extrapolates in the scale).
    pub fn from_unit(self, u: f64, lower: f64, upper: f64) -> f64 {
        match self {
            Scale::Linear => lower + u * (upper - lower),
            Scale::Log => 10f64.powf(lower.log10() + u * (upper.log10() - lower.log10())),
        }
    }

    /// Unit coordinate of the physical value `x` on `[lower, upper]`
    /// (inverse of [`Scale::from_unit`], not clamped).
    pub fn to_unit(self, x: f64, lower: f64, upper: f64) -> f64 {
        match self {
            Scale::Linear => (x - lower) / (upper - lower),
            Scale::Log => (x.log10() - lower.log10()) / (upper.log10() - lower.log10()),
        }
    }

    /// `du / d ln x` at `x`: turns a sensitivity in unit coordinates into
    /// one per relative change of the parameter (∂r/∂ln x = ∂r/∂u · du/d ln x).
    pub fn du_dln_x(self, x: f64, lower: f64, upper: f64) -> f64 {
        match self {
            Scale::Linear => x / (upper - lower),
            Scale::Log => 1.0 / (std::f64::consts::LN_10 * (upper.log10() - lower.log10())),
        }
    }
}

/// A named parameter with bounds, scale and the nominal value it takes when it
/// is not varied (parameter subsets in GSA, fixed parameters in identification).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Parameter {
    pub name: String,
    pub lower: f64,
    pub upper: f64,
    pub scale: Scale,
    /// Value when the parameter is held fixed; the midpoint of the range in
    /// its scale (geometric mean for log) unless given.
    pub nominal: f64,
}

/// Why a parameter definition is unusable.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ParameterError {
    /// A bound or the nominal value is NaN or infinite.
    #[error("parameter `{name}`: {field} is not a finite number")]
    NotFinite { name: String, field: &'static str },
    /// `lower >= upper`.
    #[error("parameter `{name}`: lower bound {lower} is not below upper bound {upper}; give lower < upper")]
    EmptyRange {
        name: String,
        lower: f64,
        upper: f64,
    },
    /// Log scale with a non-positive lower bound.
    #[error("parameter `{name}`: log scale needs lower > 0 (got {lower}); use `scale: linear` or a positive lower bound")]
    LogNonPositive { name: String, lower: f64 },
    /// Nominal value outside the bounds.
    #[error("parameter `{name}`: nominal value {nominal} lies outside [{lower}, {upper}]")]
    NominalOutside {
        name: String,
        nominal: f64,
        lower: f64,
        upper: f64,
    },
    /// Empty name.
    #[error("a parameter has an empty name; give every parameter a name")]
    EmptyName,
}

impl Parameter {
    /// A parameter with its nominal value at the middle of the range (in its scale).
    pub fn new(
        name: impl Into<String>,
        lower: f64,
        upper: f64,
        scale: Scale,
    ) -> Result<Parameter, ParameterError> {
        let mut p = Parameter {
            name: name.into(),
            lower,
            upper,
            scale,
            nominal: f64::NAN,
        };
        p.check_bounds()?;
        p.nominal = p.from_unit(0.5);
        Ok(p)
    }

    /// The same parameter with another nominal value (checked against the bounds).
    pub fn with_nominal(mut self, nominal: f64) -> Result<Parameter, ParameterError> {
        self.nominal = nominal;
        self.validate()?;
        Ok(self)
    }

    fn check_bounds(&self) -> Result<(), ParameterError> {
        let name = || self.name.clone();
        if self.name.trim().is_empty() {
            return Err(ParameterError::EmptyName);
        }
        for (field, v) in [("lower", self.lower), ("upper", self.upper)] {
            if !v.is_finite() {
                return Err(ParameterError::NotFinite {
                    name: name(),
                    field,
                });
            }
        }
        if self.lower >= self.upper {
            return Err(ParameterError::EmptyRange {
                name: name(),
                lower: self.lower,
                upper: self.upper,
            });
        }
        if self.scale == Scale::Log && self.lower <= 0.0 {
            return Err(ParameterError::LogNonPositive {
                name: name(),
                lower: self.lower,
            });
        }
        Ok(())
    }

    /// Check bounds, scale and nominal value (for parameters built as struct literals
    /// or deserialized).
    pub fn validate(&self) -> Result<(), ParameterError> {
        self.check_bounds()?;
        if !self.nominal.is_finite() {
            return Err(ParameterError::NotFinite {
                name: self.name.clone(),
                field: "nominal",
            });
        }
        if !self.contains(self.nominal) {
            return Err(ParameterError::NominalOutside {
                name: self.name.clone(),
                nominal: self.nominal,
                lower: self.lower,
                upper: self.upper,
            });
        }
        Ok(())
    }

    /// Whether `x` lies within the closed bounds.
    pub fn contains(&self, x: f64) -> bool {
        x >= self.lower && x <= self.upper
    }

    /// Physical value of the unit coordinate `u` (not clamped: `u` outside
    /// [0, 1] extrapolates in the parameter's scale).
    pub fn from_unit(&self, u: f64) -> f64 {
        self.scale.from_unit(u, self.lower, self.upper)
    }

    /// Unit coordinate of the physical value `x` (inverse of [`Parameter::from_unit`]).
    pub fn to_unit(&self, x: f64) -> f64 {
        self.scale.to_unit(x, self.lower, self.upper)
    }

    /// `x` clamped into the bounds.
    pub fn clamp(&self, x: f64) -> f64 {
        x.clamp(self.lower, self.upper)
    }
}

/// Physical values of a point of the unit hypercube, one coordinate per parameter.
pub fn from_unit(parameters: &[Parameter], u: &[f64]) -> Vec<f64> {
    parameters
        .iter()
        .zip(u)
        .map(|(p, &u)| p.from_unit(u))
        .collect()
}

/// Unit-hypercube coordinates of physical values.
pub fn to_unit(parameters: &[Parameter], x: &[f64]) -> Vec<f64> {
    parameters
        .iter()
        .zip(x)
        .map(|(p, &x)| p.to_unit(x))
        .collect()
}

/// The nominal values of all parameters.
pub fn nominal(parameters: &[Parameter]) -> Vec<f64> {
    parameters.iter().map(|p| p.nominal).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn linear_mapping_round_trips() {
        let p = Parameter::new("k", -2.0, 6.0, Scale::Linear).unwrap();
        assert_eq!(p.from_unit(0.0), -2.0);
        assert_eq!(p.from_unit(1.0), 6.0);
        assert_eq!(p.nominal, 2.0);
        for u in [0.0, 0.1, 0.37, 0.5, 0.99, 1.0] {
            assert!((p.to_unit(p.from_unit(u)) - u).abs() < 1e-15);
        }
    }

    #[test]
    fn log_mapping_spreads_decades_evenly() {
        let p = Parameter::new("k", 1e6, 1e9, Scale::Log).unwrap();
        assert!((p.from_unit(1.0 / 3.0) - 1e7).abs() < 1e-6);
        assert!((p.from_unit(2.0 / 3.0) - 1e8).abs() < 1e-4);
        assert!((p.nominal - 10f64.powf(7.5)).abs() < 1e-3);
        for u in [0.0, 0.25, 0.5, 1.0] {
            assert!((p.to_unit(p.from_unit(u)) - u).abs() < 1e-12);
        }
    }

    #[test]
    fn scale_maps_are_inverse_and_their_derivative_matches_a_difference() {
        for (scale, lo, hi) in [(Scale::Linear, -3.0, 5.0), (Scale::Log, 2e5, 7e8)] {
            for u in [0.0, 0.2, 0.5, 0.9, 1.0] {
                let x = scale.from_unit(u, lo, hi);
                assert!(
                    (scale.to_unit(x, lo, hi) - u).abs() < 1e-12,
                    "{scale:?} {u}"
                );
                // d u / d ln x by a central difference in ln x.
                if x > 0.0 {
                    let h: f64 = 1e-6;
                    let up = scale.to_unit(x * h.exp(), lo, hi);
                    let down = scale.to_unit(x * (-h).exp(), lo, hi);
                    let fd = (up - down) / (2.0 * h);
                    let exact = scale.du_dln_x(x, lo, hi);
                    assert!(
                        (fd - exact).abs() < 1e-6 * exact.abs(),
                        "{scale:?} {fd} {exact}"
                    );
                }
            }
        }
        assert_eq!(Scale::Log.from_unit(0.0, 1e3, 1e6), 1e3);
        assert!((Scale::Log.from_unit(2.0 / 3.0, 1e3, 1e6) - 1e5).abs() < 1e-9);
        let names: Vec<&str> = Scale::ALL.iter().map(|s| s.as_str()).collect();
        assert_eq!(names, ["linear", "log"]);
        assert_eq!(serde_json::to_string(&Scale::Log).unwrap(), "\"log\"");
    }

    #[test]
    fn invalid_definitions_are_rejected() {
        assert!(matches!(
            Parameter::new("a", 1.0, 1.0, Scale::Linear),
            Err(ParameterError::EmptyRange { .. })
        ));
        assert!(matches!(
            Parameter::new("a", 0.0, 1.0, Scale::Log),
            Err(ParameterError::LogNonPositive { .. })
        ));
        assert!(matches!(
            Parameter::new("a", f64::NAN, 1.0, Scale::Linear),
            Err(ParameterError::NotFinite { .. })
        ));
        let p = Parameter::new("a", 0.0, 1.0, Scale::Linear).unwrap();
        assert!(matches!(
            p.with_nominal(2.0),
            Err(ParameterError::NominalOutside { .. })
        ));
        assert_eq!(
            Parameter::new(" ", 0.0, 1.0, Scale::Linear),
            Err(ParameterError::EmptyName)
        );
    }
}
