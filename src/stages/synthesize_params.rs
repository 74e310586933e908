//! Params of the `synthesize` kind: their serde schema and the checks that
//! run during validation, before anything is computed.

use super::ParamProblem;
use crate::dynamics::measurement::{Estimator, ImpactTestParams};
use crate::frf::FrfQuantity;
use serde::Deserialize;
use serde_yaml_ng::{Mapping, Value};
use std::collections::BTreeMap;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Params {
    pub model: String,
    #[serde(default)]
    pub values: Option<Values>,
    #[serde(default)]
    pub positions: Option<Vec<Value>>,
    #[serde(default)]
    pub sensors: Option<Vec<String>>,
    #[serde(default)]
    pub excitations: Option<Vec<String>>,
    pub frequency: Grid,
    #[serde(default)]
    pub noise: Option<Noise>,
    #[serde(default)]
    pub impact_test: Option<ImpactSpec>,
    #[serde(default)]
    pub modes: Option<Modes>,
    #[serde(default)]
    pub quantity: Option<String>,
    #[serde(default)]
    pub seed: Option<u64>,
}

/// Parameter values to synthesize with: `truth` (default), overrides by
/// name, a seeded random perturbation of the truth (a disturbed model), or
/// factors on the true values of every parameter a glob pattern matches
/// (a worn component: `{scale: {"lgs_*.k_*": 0.6}}`).
#[derive(Deserialize)]
#[serde(untagged)]
pub enum Values {
    Perturb { perturb: Perturb },
    Scale { scale: BTreeMap<String, f64> },
    Overrides(BTreeMap<String, f64>),
    Named(String),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Perturb {
    /// Log-normal spread: each value is multiplied by exp(relative · g),
    /// g ~ N(0, 1), then clamped to its bounds.
    pub relative: f64,
    #[serde(default)]
    pub seed: u64,
    /// Only these parameters are perturbed (default all); the others keep
    /// the model file's values. A model that differs from the truth only in
    /// the parameters an identification updates (PUB3 scenario 1).
    #[serde(default)]
    pub parameters: Option<Vec<String>>,
}

#[derive(Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
pub struct Grid {
    pub min: f64,
    pub max: f64,
    pub step: f64,
}

impl Grid {
    /// Lines min, min + step, … ≤ max (computed as min + k·step, no drift).
    pub fn lines(&self) -> Vec<f64> {
        let n = ((self.max - self.min) / self.step + 1e-9).floor() as usize + 1;
        (0..n).map(|k| self.min + k as f64 * self.step).collect()
    }
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Noise {
    /// Complex Gaussian noise, standard deviation relative to each FRF's RMS.
    pub relative: f64,
}

/// Modes used for synthesis: a count, or all below a frequency.
#[derive(Deserialize)]
#[serde(untagged)]
pub enum Modes {
    Count(usize),
    Below { below: f64 },
}

/// A partial [`ImpactTestParams`]: what is not given keeps its default.
#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
pub struct ImpactSpec {
    sample_rate_hz: Option<f64>,
    block_size: Option<usize>,
    oversampling: Option<usize>,
    pre_trigger_s: Option<f64>,
    pulse_duration_s: Option<f64>,
    peak_force_n: Option<f64>,
    averages: Option<usize>,
    force_noise: Option<f64>,
    response_noise: Option<f64>,
    force_variation: Option<f64>,
    force_window_s: Option<f64>,
    exponential_window_end: Option<f64>,
    estimator: Option<String>,
}

impl ImpactSpec {
    pub fn resolve(&self, grid: &Grid, quantity: FrfQuantity) -> ImpactTestParams {
        let d = ImpactTestParams::default();
        ImpactTestParams {
            sample_rate_hz: self.sample_rate_hz.unwrap_or(d.sample_rate_hz),
            block_size: self.block_size.unwrap_or(d.block_size),
            oversampling: self.oversampling.unwrap_or(d.oversampling),
            pre_trigger_s: self.pre_trigger_s.unwrap_or(d.pre_trigger_s),
            pulse_duration_s: self.pulse_duration_s.unwrap_or(d.pulse_duration_s),
            peak_force_n: self.peak_force_n.unwrap_or(d.peak_force_n),
            averages: self.averages.unwrap_or(d.averages),
            force_noise: self.force_noise.unwrap_or(d.force_noise),
            response_noise: self.response_noise.unwrap_or(d.response_noise),
            force_variation: self.force_variation.unwrap_or(d.force_variation),
            force_window_s: self.force_window_s.or(d.force_window_s),
            exponential_window_end: self.exponential_window_end.or(d.exponential_window_end),
            band_hz: Some((grid.min, grid.max)),
            estimator: match self.estimator.as_deref() {
                Some("h2") | Some("H2") => Estimator::H2,
                _ => Estimator::H1,
            },
            quantity,
        }
    }
}

fn problem(path: &[&str], message: String, help: &str) -> ParamProblem {
    ParamProblem {
        path: path.iter().map(|s| s.to_string()).collect(),
        message,
        help: Some(help.into()),
    }
}

pub fn quantity(p: &Params) -> FrfQuantity {
    match p.quantity.as_deref() {
        Some("mobility") => FrfQuantity::Mobility,
        Some("accelerance") => FrfQuantity::Accelerance,
        _ => FrfQuantity::Receptance,
    }
}

/// Deserialize and check everything that does not need the model file.
pub fn parse(params: &Mapping) -> Result<Params, ParamProblem> {
    let p: Params = serde_yaml_ng::from_value(Value::Mapping(params.clone())).map_err(|e| {
        problem(
            &[],
            format!("invalid synthesize params: {e}"),
            "see `modalflow kinds` for the params of `synthesize`",
        )
    })?;
    let g = p.frequency;
    if !(g.min >= 0.0 && g.max > g.min && g.step > 0.0) {
        return Err(problem(
            &["frequency"],
            format!(
                "frequency grid {{min: {}, max: {}, step: {}}} is empty",
                g.min, g.max, g.step
            ),
            "need 0 <= min < max and step > 0 (Hz)",
        ));
    }
    if (g.max - g.min) / g.step > 2.0e6 {
        return Err(problem(
            &["frequency", "step"],
            "more than 2 million frequency lines".into(),
            "use a coarser step",
        ));
    }
    if let Some(n) = &p.noise {
        if !(n.relative.is_finite() && n.relative >= 0.0) {
            return Err(problem(
                &["noise", "relative"],
                format!("noise level {} must be >= 0", n.relative),
                "a fraction of each FRF's RMS, e.g. 0.01",
            ));
        }
    }
    if p.noise.is_some() && p.impact_test.is_some() {
        return Err(problem(
            &["impact_test"],
            "`noise` and `impact_test` exclude each other".into(),
            "an impact test brings its own noise (force_noise, response_noise)",
        ));
    }
    if let Some(imp) = &p.impact_test {
        let params = imp.resolve(&g, quantity(&p));
        params.validate().map_err(|e| {
            problem(
                &["impact_test"],
                e.to_string(),
                "see the impact_test fields in the README",
            )
        })?;
        if let Some(est) = &imp.estimator {
            if !["h1", "h2", "H1", "H2"].contains(&est.as_str()) {
                return Err(problem(
                    &["impact_test", "estimator"],
                    format!("unknown estimator `{est}`"),
                    "h1 or h2",
                ));
            }
        }
    }
    if let Some(Values::Perturb { perturb }) = &p.values {
        if !(perturb.relative.is_finite() && perturb.relative > 0.0) {
            return Err(problem(
                &["values", "perturb", "relative"],
                "perturbation must be > 0".into(),
                "e.g. 0.3 for about ±30 %",
            ));
        }
    }
    if let Some(Values::Scale { scale }) = &p.values {
        for (pattern, f) in scale {
            if let Err(e) = glob::Pattern::new(pattern) {
                return Err(problem(
                    &["values", "scale", pattern],
                    format!("`{pattern}` is not a valid pattern: {e}"),
                    "use * and ? as in lgs_*.k_*",
                ));
            }
            if !(f.is_finite() && *f > 0.0) {
                return Err(problem(
                    &["values", "scale", pattern],
                    format!("factor {f} must be a positive number"),
                    "e.g. 0.6 for 60 % of the true value",
                ));
            }
        }
    }
    if let Some(Values::Named(n)) = &p.values {
        if n != "truth" {
            return Err(problem(
                &["values"],
                format!("unknown values `{n}`"),
                "`truth`, a map of parameter overrides, {perturb: {relative, seed}} or {scale: {pattern: factor}}",
            ));
        }
    }
    if let Some(Modes::Count(0)) = p.modes {
        return Err(problem(
            &["modes"],
            "zero modes".into(),
            "a mode count >= 1 or {below: Hz}",
        ));
    }
    if let Some(q) = &p.quantity {
        if !["receptance", "mobility", "accelerance"].contains(&q.as_str()) {
            return Err(problem(
                &["quantity"],
                format!("unknown quantity `{q}`"),
                "receptance, mobility or accelerance",
            ));
        }
    }
    Ok(p)
}
