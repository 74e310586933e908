//! The `model` param of the `gsa` kind: a built-in test function, a
//! JSON-lines command, or a modalflow model file, parsed with located problems.

use super::spec::{int, number, problem};
use crate::evaluation::{
    CommandModel, CommandOptions, EvalError, Ishigami, Model, Parameter, Scale, SobolG,
};
use crate::stages::ParamProblem;
use serde_yaml_ng::{Mapping, Value};
use std::path::Path;
use std::time::Duration;

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

fn parameter(name: &str, v: &Value) -> Result<Parameter, ParamProblem> {
    fn at<'a>(name: &'a str, field: &'a str) -> Vec<&'a str> {
        vec!["model", "parameters", name, field]
    }
    let Some(map) = v.as_mapping() else {
        return Err(problem(
            &["model", "parameters", name],
            format!("parameter `{name}` must be a mapping"),
            "write {lower: 1.0e6, upper: 1.0e8, scale: log}",
        ));
    };
    for (k, _) in map {
        let k = k.as_str().unwrap_or_default();
        if !["lower", "upper", "scale", "nominal"].contains(&k) {
            return Err(problem(
                &at(name, k),
                format!("unknown key `{k}` in parameter `{name}`"),
                "a parameter takes lower, upper, scale (linear|log) and nominal",
            ));
        }
    }
    let bound = |field: &str| match map.get(field) {
        Some(v) => number(v, &at(name, field)),
        None => Err(problem(
            &["model", "parameters", name],
            format!("parameter `{name}` needs `{field}`"),
            "write {lower: 1.0e6, upper: 1.0e8, scale: log}",
        )),
    };
    let (lower, upper) = (bound("lower")?, bound("upper")?);
    let scale = match map.get("scale").map(|s| s.as_str()) {
        None | Some(Some("linear")) => Scale::Linear,
        Some(Some("log")) => Scale::Log,
        Some(_) => {
            return Err(problem(
                &at(name, "scale"),
                format!("scale of `{name}` must be `linear` or `log`"),
                "scale: linear | log",
            ))
        }
    };
    let invalid = |e: crate::evaluation::ParameterError, field: &str| {
        problem(&at(name, field), e.to_string(), "fix the bounds")
    };
    let p = Parameter::new(name, lower, upper, scale).map_err(|e| invalid(e, "lower"))?;
    match map.get("nominal") {
        None => Ok(p),
        Some(v) => p
            .with_nominal(number(v, &at(name, "nominal"))?)
            .map_err(|e| invalid(e, "nominal")),
    }
}

/// Params that only a model file takes.
pub const FILE_ONLY: &[&str] = &["window", "modes", "bands", "band_step"];

/// `bands: [[lo, hi], ...]` or `bands: {min, max, count}` (equal bands).
fn parse_bands(params: &Mapping) -> Result<Vec<(f64, f64)>, ParamProblem> {
    const HELP: &str = "bands: [[10, 50], [50, 120]] or bands: {min: 0, max: 500, count: 10} (Hz)";
    let bands = match params.get("bands") {
        None => return Ok(Vec::new()),
        Some(Value::Sequence(items)) => items
            .iter()
            .enumerate()
            .map(|(i, b)| {
                let at = ["bands".to_string(), i.to_string()];
                let at: Vec<&str> = at.iter().map(String::as_str).collect();
                match b.as_sequence().map(Vec::as_slice) {
                    Some([lo, hi]) => Ok((number(lo, &at)?, number(hi, &at)?)),
                    _ => Err(problem(&at, "a band is a pair [low, high] in Hz", HELP)),
                }
            })
            .collect::<Result<Vec<_>, _>>()?,
        Some(Value::Mapping(m)) => {
            let get = |k: &str| {
                m.get(k)
                    .ok_or_else(|| problem(&["bands"], format!("`bands` needs `{k}`"), HELP))
                    .and_then(|v| number(v, &["bands", k]))
            };
            let (lo, hi, count) = (get("min")?, get("max")?, get("count")?);
            if count < 1.0 || count.fract() != 0.0 || count > 1000.0 {
                return Err(problem(
                    &["bands", "count"],
                    "`count` must be a whole number of bands in 1..=1000",
                    HELP,
                ));
            }
            let n = count as usize;
            let width = (hi - lo) / count;
            (0..n)
                .map(|i| (lo + i as f64 * width, lo + (i + 1) as f64 * width))
                .collect()
        }
        Some(_) => {
            return Err(problem(
                &["bands"],
                "`bands` must be a list or a mapping",
                HELP,
            ))
        }
    };
    for (i, &(lo, hi)) in bands.iter().enumerate() {
        if !(lo >= 0.0 && lo < hi) {
            return Err(problem(
                &["bands", &i.to_string()],
                format!("band [{lo}, {hi}] Hz is empty or negative"),
                "give 0 <= low < high",
            ));
        }
    }
    Ok(bands)
}

pub fn parse_model(v: &Value, params: &Mapping) -> Result<ModelSpec, ParamProblem> {
    const HELP: &str = "model: {builtin: ishigami} | {builtin: sobol_g, a: [0, 1, 9]} | {command: \"./sim.sh\", parameters: {k: {lower: 1, upper: 10, scale: log}}, outputs: [f1]}";
    if let Some(path) = v.as_str() {
        let window = match params.get("window") {
            None => 0.2,
            Some(v) => {
                let w = number(v, &["window"])?;
                if w <= 0.0 {
                    return Err(problem(
                        &["window"],
                        "`window` must be a positive fraction",
                        "e.g. window: 0.2 for ±20 %",
                    ));
                }
                w
            }
        };
        let modes = int(params, "modes", 0, 0, 10_000)? as usize;
        let band_step = match params.get("band_step") {
            None => 0.5,
            Some(v) => {
                let s = number(v, &["band_step"])?;
                if s <= 0.0 {
                    return Err(problem(
                        &["band_step"],
                        "`band_step` must be a positive spacing in Hz",
                        "e.g. band_step: 0.5",
                    ));
                }
                s
            }
        };
        return Ok(ModelSpec::File {
            path: path.to_string(),
            window,
            modes,
            bands: parse_bands(params)?,
            band_step,
        });
    }
    for key in FILE_ONLY {
        if params.contains_key(key) {
            return Err(problem(
                &[key],
                format!("`{key}` applies to model files only"),
                "remove it for built-in and command models",
            ));
        }
    }
    let Some(map) = v.as_mapping() else {
        return Err(problem(&["model"], "`model` must be a mapping", HELP));
    };
    let allowed: &[&str] = if map.contains_key("builtin") {
        &["builtin", "a"]
    } else if map.contains_key("command") {
        &["command", "parameters", "outputs", "timeout", "batch"]
    } else {
        return Err(problem(
            &["model"],
            "`model` needs `builtin` or `command`",
            HELP,
        ));
    };
    for (k, _) in map {
        let k = k.as_str().unwrap_or_default();
        if !allowed.contains(&k) {
            return Err(problem(
                &["model", k],
                format!("unknown key `{k}` in `model`"),
                format!("this model takes: {}", allowed.join(", ")),
            ));
        }
    }
    if let Some(b) = map.get("builtin") {
        return match b.as_str() {
            Some("ishigami") if !map.contains_key("a") => Ok(ModelSpec::Ishigami),
            Some("ishigami") => Err(problem(
                &["model", "a"],
                "the Ishigami function has fixed a = 7, b = 0.1",
                "remove `a`",
            )),
            Some("sobol_g") => {
                let Some(items) = map.get("a").and_then(Value::as_sequence) else {
                    return Err(problem(
                        &["model"],
                        "the Sobol-G function needs `a`, one coefficient per input",
                        "e.g. a: [0, 1, 4.5, 9, 99]",
                    ));
                };
                let a = items
                    .iter()
                    .enumerate()
                    .map(|(i, x)| {
                        let path = ["model", "a", &i.to_string()];
                        number(x, &path).and_then(|x| {
                            if x >= 0.0 {
                                Ok(x)
                            } else {
                                Err(problem(
                                    &path,
                                    "Sobol-G coefficients must be >= 0",
                                    "use a >= 0",
                                ))
                            }
                        })
                    })
                    .collect::<Result<Vec<f64>, _>>()?;
                if a.is_empty() {
                    return Err(problem(
                        &["model", "a"],
                        "`a` is empty",
                        "give one coefficient per input",
                    ));
                }
                Ok(ModelSpec::SobolG { a })
            }
            _ => Err(problem(
                &["model", "builtin"],
                "unknown built-in model",
                "built-ins: ishigami, sobol_g",
            )),
        };
    }
    let command = map
        .get("command")
        .and_then(Value::as_str)
        .unwrap_or_default()
        .to_string();
    if command.trim().is_empty() {
        return Err(problem(
            &["model", "command"],
            "`command` must be a non-empty shell command",
            HELP,
        ));
    }
    let Some(pmap) = map
        .get("parameters")
        .and_then(Value::as_mapping)
        .filter(|m| !m.is_empty())
    else {
        return Err(problem(
            &["model"],
            "a command model needs `parameters`: name → {lower, upper, scale}",
            HELP,
        ));
    };
    let parameters = pmap
        .iter()
        .map(|(k, v)| parameter(k.as_str().unwrap_or_default(), v))
        .collect::<Result<Vec<_>, _>>()?;
    let outputs = match map.get("outputs").and_then(Value::as_sequence) {
        Some(items) if !items.is_empty() => items
            .iter()
            .enumerate()
            .map(|(i, v)| {
                v.as_str().map(str::to_string).ok_or_else(|| {
                    problem(
                        &["model", "outputs", &i.to_string()],
                        "output names must be strings",
                        "e.g. outputs: [f1, zeta1]",
                    )
                })
            })
            .collect::<Result<Vec<_>, _>>()?,
        _ => {
            return Err(problem(
                &["model"],
                "a command model needs `outputs`: the names in its answer lines",
                HELP,
            ))
        }
    };
    let timeout = match map.get("timeout") {
        None => None,
        Some(v) => Some(number(v, &["model", "timeout"]).and_then(|t| {
            if t > 0.0 {
                Ok(t)
            } else {
                Err(problem(
                    &["model", "timeout"],
                    "`timeout` must be positive (seconds)",
                    "e.g. timeout: 600",
                ))
            }
        })?),
    };
    let batch = match map.get("batch") {
        None => 0,
        Some(v) => v.as_u64().ok_or_else(|| {
            problem(
                &["model", "batch"],
                "`batch` must be an integer >= 0",
                "samples per process; 0 = all in one process",
            )
        })? as usize,
    };
    let spec = ModelSpec::Command {
        command,
        parameters,
        outputs,
        timeout,
        batch,
    };
    spec.build(Path::new("."))
        .map_err(|e| problem(&["model"], e.to_string(), HELP))?;
    Ok(spec)
}
