//! The params of the `gsa` kind, parsed and validated into typed settings;
//! every problem is located by its path below `params` for the validator.

use super::model_spec::{parse_model, ModelSpec};
use crate::stages::ParamProblem;
use serde_yaml_ng::{Mapping, Value};
use std::path::Path;

#[derive(Clone, Debug, PartialEq)]
pub struct SobolSpec {
    pub model: ModelSpec,
    pub samples: usize,
    pub bootstrap: usize,
    pub confidence: f64,
    pub second_order: bool,
    /// Outputs to analyze (empty: all).
    pub outputs: Vec<String>,
    /// Parameters to vary (empty: all).
    pub parameters: Vec<String>,
    /// Weights given per output name (unlisted outputs weigh 1).
    pub weights: Vec<(String, f64)>,
    pub threshold: f64,
    /// How total indices combine over outputs for the split.
    pub combine: crate::sensitivity::Combine,
    /// Monte Carlo validation samples of the split (0: none).
    pub validation: usize,
}

/// Where the ANOVA's observations come from.
#[derive(Clone, Debug, PartialEq)]
pub enum AnovaSource {
    /// A CSV table of factor levels and one response column.
    Table {
        data: String,
        response: String,
        factors: Option<Vec<String>>,
    },
    /// A full factorial design run on a model: levels per parameter (the
    /// others at their nominal values); one ANOVA per model output.
    Model {
        model: ModelSpec,
        levels: Vec<(String, Vec<f64>)>,
        outputs: Vec<String>,
    },
    /// Modal models of matrix runs (the `modes` input, e.g. AutoEMA of each
    /// wear state): factor levels from the runs' matrix values, responses
    /// the frequency and damping of each reference mode paired by MAC.
    Modes {
        /// Matrix keys that are factors (empty: every key with more than one
        /// value); other keys count as replicates.
        factors: Vec<String>,
        window: f64,
        min_mac: f64,
        outputs: Vec<String>,
    },
}

#[derive(Clone, Debug, PartialEq)]
pub struct AnovaSpec {
    pub source: AnovaSource,
    pub interactions: u8,
}

#[derive(Clone, Debug, PartialEq)]
pub enum GsaSpec {
    Sobol(SobolSpec),
    Anova(AnovaSpec),
}

pub const SOBOL_ONLY: &[&str] = &[
    "samples",
    "bootstrap",
    "confidence",
    "second_order",
    "parameters",
    "weights",
    "threshold",
    "combine",
    "validation",
];
pub const ANOVA_ONLY: &[&str] = &[
    "data",
    "response",
    "interactions",
    "factors",
    "levels",
    "min_mac",
];

pub fn problem(path: &[&str], message: impl Into<String>, help: impl Into<String>) -> ParamProblem {
    ParamProblem {
        path: path.iter().map(|s| s.to_string()).collect(),
        message: message.into(),
        help: Some(help.into()),
    }
}

pub fn int(
    params: &Mapping,
    key: &str,
    default: u64,
    min: u64,
    max: u64,
) -> Result<u64, ParamProblem> {
    match params.get(key) {
        None => Ok(default),
        Some(v) => match v.as_u64() {
            Some(n) if (min..=max).contains(&n) => Ok(n),
            _ => Err(problem(
                &[key],
                format!("`{key}` must be an integer in {min}..={max}"),
                format!("e.g. `{key}: {default}`"),
            )),
        },
    }
}

pub fn number(v: &Value, path: &[&str]) -> Result<f64, ParamProblem> {
    v.as_f64().filter(|x| x.is_finite()).ok_or_else(|| {
        problem(
            path,
            format!("`{}` must be a finite number", path.join(".")),
            "write a number such as 1.0e6",
        )
    })
}

fn strings(params: &Mapping, key: &str) -> Result<Vec<String>, ParamProblem> {
    match params.get(key) {
        None => Ok(Vec::new()),
        Some(Value::Sequence(items)) => items
            .iter()
            .enumerate()
            .map(|(i, v)| {
                v.as_str().map(str::to_string).ok_or_else(|| {
                    problem(
                        &[key, &i.to_string()],
                        format!("`{key}` must list names"),
                        "write names as strings",
                    )
                })
            })
            .collect(),
        Some(_) => Err(problem(
            &[key],
            format!("`{key}` must be a list of names"),
            "e.g. [f1, f2]",
        )),
    }
}

fn sobol(params: &Mapping) -> Result<SobolSpec, ParamProblem> {
    let Some(m) = params.get("model") else {
        return Err(problem(
            &[],
            "method `sobol` needs param `model`",
            "e.g. model: {builtin: ishigami}",
        ));
    };
    let model = parse_model(m, params)?;
    let outputs = strings(params, "outputs")?;
    let subset = strings(params, "parameters")?;
    let mut weights = Vec::new();
    match params.get("weights") {
        None => {}
        Some(Value::Mapping(w)) => {
            for (k, v) in w {
                let k = k.as_str().unwrap_or_default();
                let x = number(v, &["weights", k])?;
                if x < 0.0 {
                    return Err(problem(
                        &["weights", k],
                        "weights must be >= 0",
                        "use 0 to ignore an output",
                    ));
                }
                weights.push((k.to_string(), x));
            }
        }
        Some(_) => {
            return Err(problem(
                &["weights"],
                "`weights` must map output names to weights",
                "e.g. weights: {f1: 2, f2: 1}; unlisted outputs weigh 1",
            ))
        }
    }
    // Names are known before running except for model files (checked at run time).
    let mut d = subset.len();
    if !matches!(model, ModelSpec::File { .. }) {
        let built = model
            .build(Path::new("."))
            .map_err(|e| problem(&["model"], e.to_string(), "check the model definition"))?;
        let names: Vec<String> = built.parameters().iter().map(|p| p.name.clone()).collect();
        check_names(&names, built.outputs(), &outputs, &subset, &weights)?;
        if d == 0 {
            d = names.len();
        }
    }
    let threshold = match params.get("threshold") {
        None => 0.05,
        Some(v) => number(v, &["threshold"])?,
    };
    let confidence = match params.get("confidence") {
        None => 0.95,
        Some(v) => {
            let c = number(v, &["confidence"])?;
            if !(c > 0.0 && c < 1.0) {
                return Err(problem(
                    &["confidence"],
                    "`confidence` must lie strictly between 0 and 1",
                    "e.g. confidence: 0.95",
                ));
            }
            c
        }
    };
    let second_order = params
        .get("second_order")
        .and_then(Value::as_bool)
        .unwrap_or(false);
    if d > crate::sensitivity::sobol::MAX_VARIED {
        return Err(problem(
            &["model"],
            format!(
                "{d} varied parameters exceed {}",
                crate::sensitivity::sobol::MAX_VARIED
            ),
            "analyze a subset with `parameters`",
        ));
    }
    Ok(SobolSpec {
        model,
        samples: int(
            params,
            "samples",
            1024,
            2,
            crate::sensitivity::sobol::MAX_SAMPLES as u64,
        )? as usize,
        bootstrap: int(params, "bootstrap", 100, 0, 100_000)? as usize,
        confidence,
        second_order,
        outputs,
        parameters: subset,
        weights,
        threshold,
        combine: match params.get("combine").and_then(Value::as_str) {
            None | Some("mean") => crate::sensitivity::Combine::Mean,
            Some("max") => crate::sensitivity::Combine::Max,
            Some(other) => {
                return Err(problem(
                    &["combine"],
                    format!("unknown rule `{other}`"),
                    "combine: mean (weighted mean, PUB2) | max (significant for any output)",
                ))
            }
        },
        validation: int(params, "validation", 0, 0, 10_000_000)? as usize,
    })
}

/// Check output, parameter and weight names against the model's; `Err` names
/// the offending entry.
pub fn check_names(
    names: &[String],
    all_outputs: &[String],
    outputs: &[String],
    subset: &[String],
    weights: &[(String, f64)],
) -> Result<(), ParamProblem> {
    for (i, o) in outputs.iter().enumerate() {
        if !all_outputs.contains(o) || outputs[..i].contains(o) {
            return Err(problem(
                &["outputs", &i.to_string()],
                format!("output `{o}` is unknown or repeated"),
                format!("the model's outputs: {}", all_outputs.join(", ")),
            ));
        }
    }
    for (i, p) in subset.iter().enumerate() {
        if !names.contains(p) || subset[..i].contains(p) {
            return Err(problem(
                &["parameters", &i.to_string()],
                format!("parameter `{p}` is unknown or repeated"),
                format!("the model's parameters: {}", names.join(", ")),
            ));
        }
    }
    let analyzed = if outputs.is_empty() {
        all_outputs
    } else {
        outputs
    };
    for (k, _) in weights {
        if !analyzed.contains(k) {
            return Err(problem(
                &["weights", k],
                format!("weight for `{k}`, which is not an analyzed output"),
                format!("analyzed outputs: {}", analyzed.join(", ")),
            ));
        }
    }
    if !weights.is_empty()
        && analyzed
            .iter()
            .all(|o| weights.iter().any(|(k, w)| k == o && *w == 0.0))
    {
        return Err(problem(
            &["weights"],
            "all weights are 0",
            "give at least one output a positive weight",
        ));
    }
    Ok(())
}

/// Weight of every analyzed output: as given, else 1.
pub fn resolve_weights(analyzed: &[String], weights: &[(String, f64)]) -> Vec<f64> {
    analyzed
        .iter()
        .map(|o| {
            weights
                .iter()
                .find(|(k, _)| k == o)
                .map_or(1.0, |(_, w)| *w)
        })
        .collect()
}

fn anova(params: &Mapping) -> Result<AnovaSpec, ParamProblem> {
    let interactions = int(params, "interactions", 2, 1, 2)? as u8;
    if let Some(m) = params.get("model") {
        if let Some(k) = ["data", "response", "factors"]
            .iter()
            .find(|k| params.contains_key(**k))
        {
            return Err(problem(
                &[k],
                format!("`{k}` belongs to an ANOVA of a data table, but `model` is given"),
                "give either `data` + `response` or `model` + `levels`",
            ));
        }
        let model = parse_model(m, params)?;
        let outputs = strings(params, "outputs")?;
        return Ok(AnovaSpec {
            source: AnovaSource::Model {
                model,
                levels: levels(params)?,
                outputs,
            },
            interactions,
        });
    }
    if params.contains_key("levels") {
        return Err(problem(
            &["levels"],
            "`levels` needs a `model` to run the factorial design on",
            "add `model:` or remove `levels`",
        ));
    }
    if !params.contains_key("data") && !params.contains_key("response") {
        return modes_source(params, interactions);
    }
    if params.contains_key("min_mac") {
        return Err(problem(
            &["min_mac"],
            "`min_mac` applies to an ANOVA of modal models (the `modes` input)",
            "remove it for a data table",
        ));
    }
    let text = |key: &str, help: &str| match params.get(key).and_then(Value::as_str) {
        Some(s) if !s.trim().is_empty() => Ok(s.to_string()),
        _ => Err(problem(
            &[],
            format!(
                "method `anova` needs param `{key}` (or `model` + `levels`, or a `modes` input)"
            ),
            help.to_string(),
        )),
    };
    if let Some(k) = super::model_spec::FILE_ONLY
        .iter()
        .chain(&["outputs", "deps"])
        .find(|k| params.contains_key(**k))
    {
        return Err(problem(
            &[k],
            format!("`{k}` applies to an ANOVA on a model, not to a data table"),
            format!("remove `{k}` or give `model` + `levels`"),
        ));
    }
    let factors = strings(params, "factors")?;
    Ok(AnovaSpec {
        source: AnovaSource::Table {
            data: text(
                "data",
                "data: a CSV file of factor levels and the response, relative to the pipeline file",
            )?,
            response: text("response", "response: the name of the response column")?,
            factors: (!factors.is_empty()).then_some(factors),
        },
        interactions,
    })
}

/// An ANOVA of the modal models bound to the `modes` input.
fn modes_source(params: &Mapping, interactions: u8) -> Result<AnovaSpec, ParamProblem> {
    if let Some(k) = ["modes", "bands", "band_step", "deps"]
        .iter()
        .find(|k| params.contains_key(**k))
    {
        return Err(problem(
            &[k],
            format!("`{k}` does not apply to an ANOVA of modal models"),
            format!("remove `{k}`"),
        ));
    }
    let fraction = |key: &str, default: f64, max: f64| match params.get(key) {
        None => Ok(default),
        Some(v) => {
            let x = number(v, &[key])?;
            if x > 0.0 && x <= max {
                Ok(x)
            } else {
                Err(problem(
                    &[key],
                    format!("`{key}` must lie in (0, {max}]"),
                    format!("e.g. {key}: {default}"),
                ))
            }
        }
    };
    Ok(AnovaSpec {
        source: AnovaSource::Modes {
            factors: strings(params, "factors")?,
            window: fraction("window", 0.2, 10.0)?,
            min_mac: fraction("min_mac", 0.5, 1.0)?,
            outputs: strings(params, "outputs")?,
        },
        interactions,
    })
}

/// `levels: {parameter: [v1, v2, ...]}`, each parameter with at least two
/// distinct finite levels (factors in the order written).
fn levels(params: &Mapping) -> Result<Vec<(String, Vec<f64>)>, ParamProblem> {
    const HELP: &str = "levels: {bsd_preload: [0.5e8, 1.0e8, 2.0e8], lgs_preload: [1e8, 3e8]}";
    let Some(Value::Mapping(m)) = params.get("levels") else {
        return Err(problem(
            &[],
            "an ANOVA on a model needs `levels`: the factor levels per parameter",
            HELP,
        ));
    };
    let mut out = Vec::new();
    for (k, v) in m {
        let name = k.as_str().unwrap_or_default().to_string();
        let Some(items) = v.as_sequence() else {
            return Err(problem(
                &["levels", &name],
                "levels must be a list of values",
                HELP,
            ));
        };
        let values = items
            .iter()
            .enumerate()
            .map(|(i, x)| number(x, &["levels", &name, &i.to_string()]))
            .collect::<Result<Vec<f64>, _>>()?;
        let distinct = values
            .iter()
            .enumerate()
            .all(|(i, x)| !values[..i].contains(x));
        if values.len() < 2 || !distinct {
            return Err(problem(
                &["levels", &name],
                format!("`{name}` needs at least two distinct levels"),
                HELP,
            ));
        }
        out.push((name, values));
    }
    if out.is_empty() {
        return Err(problem(&["levels"], "`levels` lists no parameter", HELP));
    }
    Ok(out)
}

/// Parse and validate the params of a `gsa` stage.
pub fn parse(params: &Mapping) -> Result<GsaSpec, ParamProblem> {
    let method = params
        .get("method")
        .and_then(Value::as_str)
        .unwrap_or("sobol");
    let (foreign, other) = if method == "anova" {
        (SOBOL_ONLY, "sobol")
    } else {
        (ANOVA_ONLY, "anova")
    };
    if let Some(k) = foreign.iter().find(|k| params.contains_key(**k)) {
        return Err(problem(
            &[k],
            format!("param `{k}` belongs to method `{other}`, not `{method}`"),
            format!("remove `{k}` or set `method: {other}`"),
        ));
    }
    if method == "anova" {
        anova(params).map(GsaSpec::Anova)
    } else {
        sobol(params).map(GsaSpec::Sobol)
    }
}
