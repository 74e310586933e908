//! Choosing an optimizer by name: the YAML pair `optimizer: pso` plus
//! `optimizer_settings: {...}` maps onto [`Optimizer`], whose variants hold
//! the `*Params` of each algorithm (unknown keys are errors).

use super::error::OptimizeError;
use super::ga::{self, GaParams};
use super::multistart::multistart;
use super::problem::{combine, OptimizeResult, Problem};
use super::pso::{self, PsoParams};
use super::slsqp::{self, SlsqpParams};
use serde::de::DeserializeOwned;

/// An optimizer with its settings.
#[derive(Debug, Clone, PartialEq)]
pub enum Optimizer {
    Slsqp(SlsqpParams),
    Pso(PsoParams),
    Ga(GaParams),
}

impl Optimizer {
    /// Names accepted by [`Optimizer::from_settings`].
    pub const NAMES: [&'static str; 3] = ["slsqp", "pso", "ga"];

    /// The optimizer `name` with `settings` (a YAML mapping; `None` or null
    /// for the defaults). Errors name the unknown optimizer or say which
    /// setting is wrong.
    pub fn from_settings(
        name: &str,
        settings: Option<&serde_yaml_ng::Value>,
    ) -> Result<Self, OptimizeError> {
        let optimizer = match name {
            "slsqp" => Optimizer::Slsqp(parse(name, settings)?),
            "pso" => Optimizer::Pso(parse(name, settings)?),
            "ga" => Optimizer::Ga(parse(name, settings)?),
            _ => {
                return Err(OptimizeError::UnknownOptimizer {
                    name: name.to_string(),
                })
            }
        };
        let checked = match &optimizer {
            Optimizer::Slsqp(p) => p.check(),
            Optimizer::Pso(p) => p.check(),
            Optimizer::Ga(p) => p.check(),
        };
        checked.map_err(|message| OptimizeError::Settings {
            optimizer: name.to_string(),
            message,
        })?;
        Ok(optimizer)
    }

    pub fn name(&self) -> &'static str {
        match self {
            Optimizer::Slsqp(_) => "slsqp",
            Optimizer::Pso(_) => "pso",
            Optimizer::Ga(_) => "ga",
        }
    }

    /// Runs the optimizer. SLSQP with one start begins at `x0` or the centre
    /// of the unit box and ignores the seed; with `starts > 1` it runs
    /// [`multistart`] (seeded) and returns the combined best run.
    pub fn minimize(&self, problem: &Problem, seed: u64) -> Result<OptimizeResult, OptimizeError> {
        match self {
            Optimizer::Slsqp(p) if p.starts > 1 => {
                let runs = multistart(problem, p, p.starts, seed)?;
                combine(&runs).ok_or_else(|| OptimizeError::Budget {
                    message: format!(
                        "a budget of {} leaves no evaluations for any of {} starts",
                        problem.budget, p.starts
                    ),
                })
            }
            Optimizer::Slsqp(p) => {
                let x0 = match &p.x0 {
                    Some(x0) => x0.clone(),
                    None => problem.bounds.to_physical(&vec![0.5; problem.bounds.dim()]),
                };
                slsqp::minimize(problem, p, &x0)
            }
            Optimizer::Pso(p) => pso::minimize(problem, p, seed),
            Optimizer::Ga(p) => ga::minimize(problem, p, seed),
        }
    }
}

fn parse<T: DeserializeOwned + Default>(
    name: &str,
    settings: Option<&serde_yaml_ng::Value>,
) -> Result<T, OptimizeError> {
    match settings {
        None | Some(serde_yaml_ng::Value::Null) => Ok(T::default()),
        Some(v) => serde_yaml_ng::from_value(v.clone()).map_err(|e| OptimizeError::Settings {
            optimizer: name.to_string(),
            message: e.to_string(),
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn settings_map_onto_params() {
        let v: serde_yaml_ng::Value =
            serde_yaml_ng::from_str("swarm_size: 12\nbound_handling: clamp").unwrap();
        let o = Optimizer::from_settings("pso", Some(&v)).unwrap();
        let Optimizer::Pso(p) = o else {
            panic!("not pso")
        };
        assert_eq!(p.swarm_size, 12);
        assert_eq!(p.inertia, PsoParams::default().inertia);
        assert_eq!(Optimizer::from_settings("ga", None).unwrap().name(), "ga");
    }

    #[test]
    fn bad_settings_say_what_is_wrong() {
        let v: serde_yaml_ng::Value = serde_yaml_ng::from_str("swarmsize: 12").unwrap();
        let e = Optimizer::from_settings("pso", Some(&v))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("unknown field `swarmsize`") && e.contains("swarm_size"),
            "{e}"
        );
        let v: serde_yaml_ng::Value = serde_yaml_ng::from_str("step: -1").unwrap();
        let e = Optimizer::from_settings("slsqp", Some(&v))
            .unwrap_err()
            .to_string();
        assert!(e.contains("step"), "{e}");
        let e = Optimizer::from_settings("nelder-mead", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("slsqp, pso, ga"), "{e}");
    }
}
