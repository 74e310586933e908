//! Params of the `synthesize` kind: their serde schema and the checks that
//! run during validation, before anything is computed.

use crate::dynamics::measurement::{Estimator, ImpactTestParams};
use crate::frf::FrfQuantity;
use crate::stages::params::TypeName;
use crate::stages::ParamProblem;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

crate::string_enum! {
    /// The FRF quantity synthesized.
    pub enum Quantity {
        Receptance = "receptance",
        Mobility = "mobility",
        Accelerance = "accelerance",
    }
}

/// A position by index or by label.
#[derive(Clone, Debug, Deserialize, Serialize, PartialEq)]
#[serde(untagged, expecting = "a position index (integer) or label (string)")]
pub enum PositionRef {
    Index(usize),
    Label(String),
}

crate::params! {
    /// The `synthesize` kind's params.
    pub struct Params {
        /// model file (YAML), relative to the pipeline file
        pub model: String,
        /// `truth` (default), {name: value} overrides, {perturb: {relative,
        /// seed, parameters: [names] (default all)}}, or {scale: {glob: factor}}
        pub values: Option<Values> = None,
        /// axis positions to synthesize, by index or label (default all)
        pub positions: Option<Vec<PositionRef>> = None,
        /// subset of the model's sensors by name (default all)
        pub sensors: Option<Vec<String>> = None,
        /// subset of the model's excitations by name (default all)
        pub excitations: Option<Vec<String>> = None,
        /// frequency grid {min, max, step} in Hz
        pub frequency: Grid,
        /// {relative: r}: complex Gaussian noise, r times each FRF's RMS
        pub noise: Option<Noise> = None,
        /// simulated hammer test (H1/H2, coherence): sample_rate_hz,
        /// block_size, averages, force_noise, response_noise,
        /// exponential_window_end, estimator, …
        pub impact_test: Option<ImpactSpec> = None; check check_impact,
        /// modes in the superposition: a count or {below: Hz} (default all
        /// below 2·max frequency)
        pub modes: Option<Modes> = None,
        /// FRF quantity
        pub quantity: Quantity = Quantity::Receptance,
        /// noise seed (default: the pipeline's seed)
        pub seed: Option<u64> = None,
    }
}

/// Parameter values to synthesize with: `truth` (default), overrides by
/// name, a seeded random perturbation of the truth (a disturbed model), or
/// factors on the true values of every parameter a glob pattern matches
/// (a worn component: `{scale: {"lgs_*.k_*": 0.6}}`).
#[derive(Debug, Deserialize, Serialize)]
#[serde(
    untagged,
    expecting = "`truth`, {name: value}, {perturb: {relative, seed, parameters}} or {scale: {pattern: factor}}"
)]
pub enum Values {
    Perturb { perturb: Perturb },
    Scale { scale: BTreeMap<String, f64> },
    Overrides(BTreeMap<String, f64>),
    Named(String),
}

#[derive(Debug, Deserialize, Serialize)]
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

#[derive(Debug, Deserialize, Serialize, Clone, Copy)]
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

#[derive(Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Noise {
    /// Complex Gaussian noise, standard deviation relative to each FRF's RMS.
    pub relative: f64,
}

/// Modes used for synthesis: a count, or all below a frequency.
#[derive(Debug, Deserialize, Serialize)]
#[serde(untagged, expecting = "a mode count or {below: Hz}")]
pub enum Modes {
    Count(usize),
    Below { below: f64 },
}

/// A partial [`ImpactTestParams`]: what is not given keeps its default.
#[derive(Debug, Deserialize, Serialize, Default)]
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

/// Largest impact-test sizes: a record of `block_size · oversampling`
/// samples is simulated per average, excitation and position, so these bound
/// the memory and time a typo can ask for (defaults: 8192, 4, 5).
pub const MAX_BLOCK_SIZE: usize = 1 << 20;
pub const MAX_OVERSAMPLING: usize = 64;
pub const MAX_AVERAGES: usize = 10_000;

/// The impact-test sizes within their bounds (the physics is checked with
/// the whole params, in [`check`]).
pub fn check_impact(spec: &Option<ImpactSpec>) -> Vec<ParamProblem> {
    let Some(s) = spec else { return Vec::new() };
    let bounds = [
        ("block_size", s.block_size, 16, MAX_BLOCK_SIZE),
        ("oversampling", s.oversampling, 1, MAX_OVERSAMPLING),
        ("averages", s.averages, 1, MAX_AVERAGES),
    ];
    bounds
        .into_iter()
        .filter_map(|(name, v, lo, hi)| {
            let v = v.filter(|v| !(lo..=hi).contains(v))?;
            Some(ParamProblem::new(
                &[name],
                format!("impact_test `{name}` = {v} is out of range [{lo}, {hi}]"),
                format!("give `{name}` a value in [{lo}, {hi}]"),
            ))
        })
        .collect()
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

impl TypeName for PositionRef {
    fn type_name() -> String {
        "index or label".into()
    }
}

impl TypeName for Values {
    fn type_name() -> String {
        "`truth` | {name: value} | {perturb: {…}} | {scale: {…}}".into()
    }
}

impl TypeName for Grid {
    fn type_name() -> String {
        "mapping {min, max, step}".into()
    }
}

impl TypeName for Noise {
    fn type_name() -> String {
        "mapping {relative}".into()
    }
}

impl TypeName for Modes {
    fn type_name() -> String {
        "count | {below: Hz}".into()
    }
}

impl TypeName for ImpactSpec {
    fn type_name() -> String {
        "mapping (impact-test settings)".into()
    }
}

impl From<Quantity> for FrfQuantity {
    fn from(q: Quantity) -> FrfQuantity {
        match q {
            Quantity::Receptance => FrfQuantity::Receptance,
            Quantity::Mobility => FrfQuantity::Mobility,
            Quantity::Accelerance => FrfQuantity::Accelerance,
        }
    }
}

/// The memory and work an impact test asks for, against the bounds of
/// [`crate::resources`]: the modal responses at the oversampled rate
/// (modes × block_size × oversampling), the response records and their
/// spectra, and averages × block_size × channels samples drawn and
/// transformed. `model`: the model's (DOF, sensors) once its file is read;
/// before that, modes and channels are lower bounds (a mode count given in
/// `modes`, else 1; the sensors named, else 1).
pub fn impact_resources(
    p: &Params,
    imp: &ImpactSpec,
    model: Option<(usize, usize)>,
) -> Vec<ParamProblem> {
    let d = ImpactTestParams::default();
    let n = imp.block_size.unwrap_or(d.block_size) as f64;
    let r = imp.oversampling.unwrap_or(d.oversampling) as f64;
    let averages = imp.averages.unwrap_or(d.averages) as f64;
    let (dofs, all_sensors) = model.unwrap_or((usize::MAX, 1));
    let modes = match p.modes {
        Some(Modes::Count(k)) => k.min(dofs),
        _ if model.is_some() => dofs,
        _ => 1,
    } as f64;
    let sensors = p.sensors.as_ref().map_or(all_sensors, Vec::len).max(1);
    let channels = sensors as f64 + 1.0;
    let bytes = 8.0 * n * r * (modes + 3.0) + 48.0 * n * channels;
    let samples = averages * n * channels + modes * n * r;
    let what = format!("block_size × oversampling × {modes} modes, per excitation");
    let memory =
        crate::stages::params::limits::memory_problem(&["impact_test", "block_size"], &what, bytes);
    let work = crate::stages::params::limits::work_problem(
        &["impact_test", "averages"],
        &format!("averages × block_size × {channels} channels, per excitation"),
        samples,
    );
    memory.into_iter().chain(work).collect()
}

/// Checks across params, every problem at once; the model file is checked
/// by the kind when the files are looked at.
pub fn check(p: &Params) -> Vec<ParamProblem> {
    let mut out = Vec::new();
    check_frequency(p.frequency, &mut out);
    check_noise(p, &mut out);
    if let Some(imp) = &p.impact_test {
        check_impact_test(p, imp, &mut out);
    }
    check_values(p.values.as_ref(), &mut out);
    if let Some(Modes::Count(0)) = p.modes {
        out.push(ParamProblem::new(
            &["modes"],
            "zero modes".to_string(),
            "a mode count >= 1 or {below: Hz}",
        ));
    }
    out
}

/// Check the frequency grid: non-empty and at most 2 million lines.
fn check_frequency(g: Grid, out: &mut Vec<ParamProblem>) {
    let mut problem = |path: &[&str], message: String, help: &str| {
        out.push(ParamProblem::new(path, message, help))
    };
    if !(g.min >= 0.0 && g.max > g.min && g.step > 0.0) {
        problem(
            &["frequency"],
            format!(
                "frequency grid {{min: {}, max: {}, step: {}}} is empty",
                g.min, g.max, g.step
            ),
            "need 0 <= min < max and step > 0 (Hz)",
        );
    } else if (g.max - g.min) / g.step > 2.0e6 {
        problem(
            &["frequency", "step"],
            "more than 2 million frequency lines".into(),
            "use a coarser step",
        );
    }
}

/// Check the added noise: a level ≥ 0, and not with an impact test (which
/// brings its own).
fn check_noise(p: &Params, out: &mut Vec<ParamProblem>) {
    let mut problem = |path: &[&str], message: String, help: &str| {
        out.push(ParamProblem::new(path, message, help))
    };
    if let Some(n) = &p.noise {
        if !(n.relative.is_finite() && n.relative >= 0.0) {
            problem(
                &["noise", "relative"],
                format!("noise level {} must be >= 0", n.relative),
                "a fraction of each FRF's RMS, e.g. 0.01",
            );
        }
    }
    if p.noise.is_some() && p.impact_test.is_some() {
        problem(
            &["impact_test"],
            "`noise` and `impact_test` exclude each other".into(),
            "an impact test brings its own noise (force_noise, response_noise)",
        );
    }
}

/// Check the simulated impact test `imp`: the memory and work it asks for
/// (before the model is read), its settings on the grid, its estimator.
fn check_impact_test(p: &Params, imp: &ImpactSpec, out: &mut Vec<ParamProblem>) {
    let mut problem = |path: &[&str], message: String, help: &str| {
        out.push(ParamProblem::new(path, message, help))
    };
    for extra in impact_resources(p, imp, None) {
        let path: Vec<&str> = extra.path.iter().map(String::as_str).collect();
        problem(&path, extra.message, extra.help.as_deref().unwrap_or(""));
    }
    if let Err(e) = imp.resolve(&p.frequency, p.quantity.into()).validate() {
        problem(
            &["impact_test"],
            e.to_string(),
            "see the impact_test fields in docs/stage-kinds.md (`synthesize`)",
        );
    }
    if let Some(est) = &imp.estimator {
        if !["h1", "h2", "H1", "H2"].contains(&est.as_str()) {
            problem(
                &["impact_test", "estimator"],
                format!("unknown estimator `{est}`"),
                "h1 or h2",
            );
        }
    }
}

/// Check the parameter values to synthesize with: a positive perturbation,
/// valid patterns with positive factors, or `truth`.
fn check_values(values: Option<&Values>, out: &mut Vec<ParamProblem>) {
    let mut problem = |path: &[&str], message: String, help: &str| {
        out.push(ParamProblem::new(path, message, help))
    };
    match values {
        Some(Values::Perturb { perturb })
            if !(perturb.relative.is_finite() && perturb.relative > 0.0) =>
        {
            problem(
                &["values", "perturb", "relative"],
                "perturbation must be > 0".into(),
                "e.g. 0.3 for about ±30 %",
            )
        }
        Some(Values::Scale { scale }) => {
            for (pattern, f) in scale {
                if let Err(e) = glob::Pattern::new(pattern) {
                    problem(
                        &["values", "scale", pattern],
                        format!("`{pattern}` is not a valid pattern: {e}"),
                        "use * and ? as in lgs_*.k_*",
                    );
                }
                if !(f.is_finite() && *f > 0.0) {
                    problem(
                        &["values", "scale", pattern],
                        format!("factor {f} must be a positive number"),
                        "e.g. 0.6 for 60 % of the true value",
                    );
                }
            }
        }
        Some(Values::Named(n)) if n != "truth" => problem(
            &["values"],
            format!("unknown values `{n}`"),
            "`truth`, a map of parameter overrides, {perturb: {relative, seed}} or {scale: {pattern: factor}}",
        ),
        _ => {}
    }
}
