//! The `model` param of the `gsa` kind: a built-in test function, a
//! JSON-lines command, or a modalflow model file — its typed form as
//! written ([`ModelParam`]) and the model it names ([`ModelSpec`]), with
//! every problem located.

use super::spec::{problem, Params};
use crate::simulator::{
    CommandModel, CommandOptions, EvalError, Ishigami, Model, Parameter, Scale, SobolG,
};
use crate::stages::params::TypeName;
use crate::stages::ParamProblem;
use indexmap::IndexMap;
use serde::{Deserialize, Deserializer, Serialize};
use std::path::Path;
use std::time::Duration;

/// `model:` as written: a model file path or a mapping.
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
pub enum ModelParam {
    File(String),
    Table(ModelTable),
}

/// `model: {builtin: …}` or `model: {command: …}`.
#[derive(Clone, Debug, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ModelTable {
    #[serde(default)]
    pub builtin: Option<String>,
    #[serde(default)]
    pub a: Option<Vec<f64>>,
    #[serde(default)]
    pub command: Option<String>,
    #[serde(default)]
    pub parameters: Option<IndexMap<String, ParameterParam>>,
    #[serde(default)]
    pub outputs: Option<Vec<String>>,
    #[serde(default)]
    pub timeout: Option<f64>,
    #[serde(default)]
    pub batch: Option<usize>,
}

/// One parameter of a command model.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ParameterParam {
    pub lower: f64,
    pub upper: f64,
    #[serde(default)]
    pub scale: Option<Scale>,
    #[serde(default)]
    pub nominal: Option<f64>,
}

impl<'de> Deserialize<'de> for ModelParam {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct Visitor;
        impl<'de> serde::de::Visitor<'de> for Visitor {
            type Value = ModelParam;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a model file path, {builtin: ...} or {command: ...}")
            }
            fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<ModelParam, E> {
                Ok(ModelParam::File(v.to_string()))
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                map: A,
            ) -> Result<ModelParam, A::Error> {
                ModelTable::deserialize(serde::de::value::MapAccessDeserializer::new(map))
                    .map(ModelParam::Table)
            }
        }
        d.deserialize_any(Visitor)
    }
}

impl TypeName for ModelParam {
    fn type_name() -> String {
        "model file | {builtin: ishigami} | {builtin: sobol_g, a: [...]} | {command: CMD, parameters: {name: {lower, upper, scale, nominal}}, outputs: [...], timeout: s, batch: n}".into()
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum ModelSpec {
    Ishigami,
    SobolG {
        a: Vec<f64>,
    },
    Command {
        command: String,
        parameters: Vec<Parameter>,
        outputs: Vec<String>,
        timeout: Option<f64>,
        batch: usize,
    },
    /// A modalflow model file (relative to the pipeline file) with reference
    /// modes from the `reference` input or the model's own modes.
    File {
        path: String,
        window: f64,
        modes: usize,
        /// FRF bands (low, high) in Hz for FRAC/CSF outputs; empty: none.
        bands: Vec<(f64, f64)>,
        /// Line spacing (Hz) of the model's own reference FRFs.
        band_step: f64,
    },
}

impl ModelSpec {
    /// The model, with a command run in `dir`; `File` models are built by the
    /// stage, which reads the files.
    pub fn build(&self, dir: &Path) -> Result<Box<dyn Model>, EvalError> {
        Ok(match self {
            ModelSpec::File { path, .. } => {
                return Err(EvalError::Domain(format!(
                    "model file `{path}` is read by the stage"
                )))
            }
            ModelSpec::Ishigami => Box::new(Ishigami::new()),
            ModelSpec::SobolG { a } => Box::new(SobolG::new(a.clone())?),
            ModelSpec::Command {
                command,
                parameters,
                outputs,
                timeout,
                batch,
            } => Box::new(CommandModel::new(
                parameters.clone(),
                outputs.clone(),
                CommandOptions {
                    command: command.clone(),
                    dir: dir.to_path_buf(),
                    timeout: timeout.map(Duration::from_secs_f64),
                    batch: *batch,
                },
            )?),
        })
    }
}

/// A command model's parameter, checked.
fn parameter(name: &str, p: &ParameterParam) -> Result<Parameter, ParamProblem> {
    let at = |field: &str| ["model", "parameters", name, field].map(str::to_string);
    let at_str = |field: &'static str| -> Vec<String> { at(field).to_vec() };
    let located = |field: &'static str, message: String, help: &str| ParamProblem {
        path: at_str(field),
        message,
        help: Some(help.into()),
        class: crate::stages::params::Class::Check,
    };
    for (field, v) in [
        ("lower", Some(p.lower)),
        ("upper", Some(p.upper)),
        ("nominal", p.nominal),
    ] {
        if v.is_some_and(|x| !x.is_finite()) {
            return Err(located(
                field,
                format!("`model.parameters.{name}.{field}` must be a finite number"),
                "write a number such as 1.0e6",
            ));
        }
    }
    let scale = p.scale.unwrap_or_default();
    let invalid = |e: crate::simulator::ParameterError, field: &'static str| {
        located(field, e.to_string(), "fix the bounds")
    };
    let param = Parameter::new(name, p.lower, p.upper, scale).map_err(|e| invalid(e, "lower"))?;
    match p.nominal {
        None => Ok(param),
        Some(v) => param.with_nominal(v).map_err(|e| invalid(e, "nominal")),
    }
}

/// Params that only a model file takes.
pub const FILE_ONLY: &[&str] = &["window", "modes", "bands", "band_step"];

/// Most FRF bands: each is two outputs (FRAC, CSF) per position, every one
/// analyzed with bootstrap resamples.
pub const MAX_BANDS: usize = 1000;

/// The equal-width or listed bands of `bands` (Hz), checked.
fn bands(p: &Params) -> Result<Vec<(f64, f64)>, ParamProblem> {
    const HELP: &str = "bands: [[10, 50], [50, 120]] or bands: {min: 0, max: 500, count: 10} (Hz)";
    let bands: Vec<(f64, f64)> = match &p.bands {
        None => return Ok(Vec::new()),
        Some(super::spec::Bands::List(list)) if list.is_empty() || list.len() > MAX_BANDS => {
            return Err(problem(
                &["bands"],
                format!("give 1 to {MAX_BANDS} bands, not {}", list.len()),
                HELP,
            ))
        }
        Some(super::spec::Bands::List(list)) => list.clone(),
        Some(super::spec::Bands::Even { min, max, count }) => {
            if *count < 1 || *count > MAX_BANDS {
                return Err(problem(
                    &["bands", "count"],
                    format!("`count` must be a whole number of bands in 1..={MAX_BANDS}"),
                    HELP,
                ));
            }
            let width = (max - min) / *count as f64;
            (0..*count)
                .map(|i| (min + i as f64 * width, min + (i + 1) as f64 * width))
                .collect()
        }
    };
    for (i, &(lo, hi)) in bands.iter().enumerate() {
        if !(lo >= 0.0 && lo < hi && hi.is_finite()) {
            return Err(problem(
                &["bands", &i.to_string()],
                format!("band [{lo}, {hi}] Hz is empty or negative"),
                "give 0 <= low < high",
            ));
        }
    }
    // Each evaluation synthesizes the model's FRFs on the lines spanning
    // the bands: bound them like synthesize's frequency grid.
    let step = p.band_step.unwrap_or(0.5);
    let span = bands.iter().map(|b| b.1).fold(0.0, f64::max)
        - bands.iter().map(|b| b.0).fold(f64::INFINITY, f64::min);
    let lines = span / step + 1.0;
    if lines > MAX_BAND_LINES {
        return Err(problem(
            &["bands"],
            format!(
                "`bands` spans {lines:.3e} frequency lines at band_step {step} Hz, more than the \
                 limit of {MAX_BAND_LINES:.0e} (each model evaluation computes FRFs on all of them)"
            ),
            "narrow the bands or use a coarser band_step",
        ));
    }
    Ok(bands)
}

/// Most frequency lines the bands of one model may span (as synthesize's
/// grid): 2·10⁶ lines of complex FRFs per sensor and excitation.
pub const MAX_BAND_LINES: f64 = 2.0e6;

/// The forms `model:` takes, for problems with a command model or none.
const MODEL_HELP: &str = "model: {builtin: ishigami} | {builtin: sobol_g, a: [0, 1, 9]} | {command: \"./sim.sh\", parameters: {k: {lower: 1, upper: 10, scale: log}}, outputs: [f1]}";

/// The model `model:` names, checked; file-model settings come from the
/// other params.
pub fn model_spec(m: &ModelParam, p: &Params) -> Result<ModelSpec, ParamProblem> {
    let map = match m {
        ModelParam::File(path) => {
            return Ok(ModelSpec::File {
                path: path.clone(),
                window: p.window.unwrap_or(0.2),
                modes: p.modes.unwrap_or(0),
                bands: bands(p)?,
                band_step: p.band_step.unwrap_or(0.5),
            })
        }
        ModelParam::Table(t) => t,
    };
    if let Some(key) = FILE_ONLY.iter().find(|k| p.given(k)) {
        return Err(problem(
            &[key],
            format!("`{key}` applies to model files only"),
            "remove it for built-in and command models",
        ));
    }
    match &map.builtin {
        Some(b) => builtin_model(b, map),
        None => command_model(map),
    }
}

/// The built-in test function `builtin:` names (Ishigami or Sobol-G with
/// its `a`), checked: a built-in takes no command-model keys.
fn builtin_model(b: &str, map: &ModelTable) -> Result<ModelSpec, ParamProblem> {
    let extra = [
        ("command", map.command.is_some()),
        ("parameters", map.parameters.is_some()),
        ("outputs", map.outputs.is_some()),
        ("timeout", map.timeout.is_some()),
        ("batch", map.batch.is_some()),
    ];
    if let Some((k, _)) = extra.iter().find(|(_, given)| *given) {
        return Err(problem(
            &["model", k],
            format!("unknown key `{k}` in `model`"),
            "this model takes: builtin, a",
        ));
    }
    match b {
        "ishigami" if map.a.is_none() => Ok(ModelSpec::Ishigami),
        "ishigami" => Err(problem(
            &["model", "a"],
            "the Ishigami function has fixed a = 7, b = 0.1",
            "remove `a`",
        )),
        "sobol_g" => sobol_g(map.a.as_deref()),
        _ => Err(problem(
            &["model", "builtin"],
            "unknown built-in model",
            "built-ins: ishigami, sobol_g",
        )),
    }
}

/// The Sobol-G function with coefficients `a`: one per input, each ≥ 0.
fn sobol_g(a: Option<&[f64]>) -> Result<ModelSpec, ParamProblem> {
    let Some(a) = a else {
        return Err(problem(
            &["model"],
            "the Sobol-G function needs `a`, one coefficient per input",
            "e.g. a: [0, 1, 4.5, 9, 99]",
        ));
    };
    if let Some(i) = a.iter().position(|x| !(x.is_finite() && *x >= 0.0)) {
        return Err(problem(
            &["model", "a", &i.to_string()],
            "Sobol-G coefficients must be >= 0",
            "use a >= 0",
        ));
    }
    if a.is_empty() {
        return Err(problem(
            &["model", "a"],
            "`a` is empty",
            "give one coefficient per input",
        ));
    }
    Ok(ModelSpec::SobolG { a: a.to_vec() })
}

/// The JSON-lines command model `command:` names with its parameters and
/// outputs, checked, and built once (in `.`) so what the command model
/// itself refuses is a problem now.
fn command_model(map: &ModelTable) -> Result<ModelSpec, ParamProblem> {
    let Some(command) = &map.command else {
        return Err(problem(
            &["model"],
            "`model` needs `builtin` or `command`",
            MODEL_HELP,
        ));
    };
    if map.a.is_some() {
        return Err(problem(
            &["model", "a"],
            "unknown key `a` in `model`",
            "this model takes: command, parameters, outputs, timeout, batch",
        ));
    }
    if command.trim().is_empty() {
        return Err(problem(
            &["model", "command"],
            "`command` must be a non-empty shell command",
            MODEL_HELP,
        ));
    }
    let Some(pmap) = map.parameters.as_ref().filter(|m| !m.is_empty()) else {
        return Err(problem(
            &["model"],
            "a command model needs `parameters`: name → {lower, upper, scale}",
            MODEL_HELP,
        ));
    };
    let parameters = pmap
        .iter()
        .map(|(k, v)| parameter(k, v))
        .collect::<Result<Vec<_>, _>>()?;
    let Some(outputs) = map.outputs.clone().filter(|o| !o.is_empty()) else {
        return Err(problem(
            &["model"],
            "a command model needs `outputs`: the names in its answer lines",
            MODEL_HELP,
        ));
    };
    if let Some(t) = map.timeout.filter(|t| !(*t > 0.0 && t.is_finite())) {
        return Err(problem(
            &["model", "timeout"],
            format!("`timeout` must be positive (seconds), not {t}"),
            "e.g. timeout: 600",
        ));
    }
    let spec = ModelSpec::Command {
        command: command.clone(),
        parameters,
        outputs,
        timeout: map.timeout,
        batch: map.batch.unwrap_or(0),
    };
    spec.build(Path::new("."))
        .map_err(|e| problem(&["model"], e.to_string(), MODEL_HELP))?;
    Ok(spec)
}
