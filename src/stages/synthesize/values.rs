//! The parameter values `synthesize` solves a model at: the `values` param
//! (the truth, overrides by name, a seeded log-normal perturbation, factors
//! by glob), the `significant` input (which parameters a perturbation moves)
//! and the `values` input (a parameter table applied last).

use super::params::{Params, Values};
use crate::dynamics::measurement::GaussianStream;
use crate::dynamics::{Model, Parameter};
use crate::stages::StageError;
use std::path::Path;

/// Override `x` with the `value` column of a parameter table (rows named by
/// `parameter`); every named parameter must exist and lie within its bounds.
pub(super) fn override_from_table(
    model: &Model,
    x: &mut [f64],
    path: &Path,
) -> Result<(), StageError> {
    let invalid = |message: String| StageError::InvalidInput {
        input: "values".into(),
        message,
    };
    for (name, v) in crate::artifacts::parameters::read_values(path, "values")? {
        let k = model
            .parameter_index(&name)
            .ok_or_else(|| invalid(format!("the model has no parameter `{name}`")))?;
        let p = &model.parameters[k];
        if !(v.is_finite() && p.lower <= v && v <= p.upper) {
            return Err(invalid(format!(
                "`{name}` = {v} is outside its bounds [{}, {}]",
                p.lower, p.upper
            )));
        }
        x[k] = v;
    }
    Ok(())
}

/// The significant parameters of a gsa significant.csv
/// (`parameter,score,significant`), for `values.perturb`.
pub(super) fn significant_parameters(path: &Path, p: &Params) -> Result<Vec<String>, StageError> {
    let bad = |message: String| StageError::InvalidInput {
        input: "significant".into(),
        message,
    };
    match &p.values {
        Some(Values::Perturb { perturb }) if perturb.parameters.is_none() => {}
        Some(Values::Perturb { .. }) => {
            return Err(bad(
                "`values.perturb.parameters` and the `significant` input both name the parameters to move; keep one".into(),
            ))
        }
        _ => {
            return Err(bad(
                "the `significant` input names the parameters `values.perturb` moves; give `values: {perturb: {relative, seed}}`".into(),
            ))
        }
    }
    let out: Vec<String> = crate::artifacts::significant::read(path, "significant")?
        .into_iter()
        .filter(|r| r.significant)
        .map(|r| r.parameter)
        .collect();
    if out.is_empty() {
        return Err(bad("the screening found no significant parameter".into()));
    }
    Ok(out)
}

/// Parameter values to use, in model order; `only` (from the `significant`
/// input) names the parameters a `perturb` moves.
pub(super) fn values(
    parameters: &[Parameter],
    spec: Option<&Values>,
    only: Option<&[String]>,
) -> Result<Vec<f64>, String> {
    let mut v: Vec<f64> = parameters.iter().map(|p| p.value).collect();
    match spec {
        None | Some(Values::Named(_)) => {}
        Some(Values::Overrides(map)) => {
            for (name, &x) in map {
                let i = parameters
                    .iter()
                    .position(|p| &p.name == name)
                    .ok_or_else(|| {
                        let names: Vec<&str> = parameters.iter().map(|p| p.name.as_str()).collect();
                        format!(
                            "values: the model has no parameter `{name}` (parameters: {})",
                            names.join(", ")
                        )
                    })?;
                let p = &parameters[i];
                if !(x.is_finite() && p.lower <= x && x <= p.upper) {
                    return Err(format!(
                        "values: `{name}` = {x} is outside its bounds [{}, {}]",
                        p.lower, p.upper
                    ));
                }
                v[i] = x;
            }
        }
        Some(Values::Scale { scale }) => {
            for (pattern, &f) in scale {
                let glob = glob::Pattern::new(pattern)
                    .map_err(|e| format!("values.scale: `{pattern}`: {e}"))?;
                let mut matched = false;
                for (i, p) in parameters.iter().enumerate() {
                    if glob.matches(&p.name) {
                        matched = true;
                        let x = v[i] * f;
                        if !(p.lower <= x && x <= p.upper) {
                            return Err(format!(
                                "values.scale: `{}` × {f} = {x} is outside its bounds [{}, {}]",
                                p.name, p.lower, p.upper
                            ));
                        }
                        v[i] = x;
                    }
                }
                if !matched {
                    return Err(format!(
                        "values.scale: `{pattern}` matches no parameter of the model"
                    ));
                }
            }
        }
        Some(Values::Perturb { perturb }) => {
            let only = only.or(perturb.parameters.as_deref());
            if let Some(only) = only {
                let names: Vec<&str> = parameters.iter().map(|p| p.name.as_str()).collect();
                if let Some(name) = only.iter().find(|n| !names.contains(&n.as_str())) {
                    return Err(format!(
                        "values.perturb.parameters: the model has no parameter `{name}` (parameters: {})",
                        names.join(", ")
                    ));
                }
            }
            // One Gaussian stream per parameter index: adding a parameter
            // leaves the others' perturbations unchanged.
            for (i, p) in parameters.iter().enumerate() {
                if only.is_some_and(|only| !only.contains(&p.name)) {
                    continue;
                }
                let g = GaussianStream::new(perturb.seed, i as u64).standard();
                v[i] = (p.value * (perturb.relative * g).exp()).clamp(p.lower, p.upper);
            }
        }
    }
    Ok(v)
}
