//! The params of the `gsa` kind ([`Params`], declared once) and the
//! analysis they describe ([`GsaSpec`]): which method, which model, which
//! settings; [`spec`] checks what the types cannot say, locating the problem
//! by its path below `params`.

use super::model_spec::{model_spec, ModelParam, ModelSpec, FILE_ONLY};
use crate::sensitivity::Combine;
use crate::stages::params::{Numbers, TypeName};
use crate::stages::{ParamProblem, Range};
use indexmap::IndexMap;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

crate::string_enum! {
    /// What the gsa stage computes.
    pub enum Method {
        Sobol = "sobol",
        Anova = "anova",
    }
}

crate::string_enum! {
    /// How total indices combine over outputs for the split.
    pub enum CombineName {
        Mean = "mean",
        Max = "max",
    }
}

crate::string_enum! {
    /// How `min_conformity` grows the kept set.
    pub enum Grow {
        Ranking = "ranking",
        WorstOutput = "worst_output",
    }
}

/// FRF bands in Hz: listed pairs or `count` equal bands.
#[derive(Clone, Debug, Deserialize, Serialize)]
#[serde(untagged, expecting = "[[low, high], ...] or {min, max, count}")]
pub enum Bands {
    List(Vec<(f64, f64)>),
    Even { min: f64, max: f64, count: usize },
}

impl TypeName for Bands {
    fn type_name() -> String {
        "[[low, high], ...] | {min, max, count}".into()
    }
}

impl Numbers for Bands {
    fn numbers(&self) -> Vec<f64> {
        match self {
            Bands::List(l) => l.numbers(),
            Bands::Even { min, max, .. } => vec![*min, *max],
        }
    }
}

crate::params! {
    /// The `gsa` kind's params.
    pub struct Params {
        /// sobol: Sobol indices of a model; anova: ANOVA table of a
        /// factorial data set, a factorial design on a model, or modal models
        /// of matrix runs
        pub method: Method = Method::Sobol,
        /// a modalflow model file (hashed with the files it references) |
        /// {builtin: ishigami} | {builtin: sobol_g, a: [...]} | {command: CMD,
        /// parameters: {name: {lower, upper, scale, nominal}}, outputs: [...],
        /// timeout: seconds per process, batch: samples per process (parallel;
        /// default all of a 256-sample chunk)}
        pub model: Option<ModelParam> = None,
        /// model files and modal ANOVA: relative frequency window for pairing
        /// model and reference modes (default 0.2)
        pub window: Option<f64> = None; range Range::above(0.0)
            => "`window` must be a positive fraction", "e.g. window: 0.2 for ±20 %",
        /// model files: modes computed per position (default: as many as the
        /// reference has; required without `reference`)
        pub modes: Option<usize> = None; range Range::closed(0.0, 10_000.0),
        /// model files: frequency bands for FRAC/CSF outputs
        /// p{i}.band{b}.frac|csf, [[lo, hi], ...] or {min, max, count} in Hz;
        /// against the `reference_frf` input or the model's own FRFs at its
        /// true values
        pub bands: Option<Bands> = None; range Range::at_least(0.0),
        /// model files: line spacing in Hz of the model's own reference FRFs
        /// (default 0.5)
        pub band_step: Option<f64> = None; range Range::above(0.0)
            => "`band_step` must be a positive spacing in Hz", "e.g. band_step: 0.5",
        /// files the model command reads (hashed into the cache key)
        pub deps: Vec<String> = Vec::new(),
        /// sobol: base sample size N, a power of two; N(d+2) evaluations,
        /// N(2d+2) with second order
        pub samples: usize = 1024; range Range::closed(2.0, crate::sensitivity::sobol::MAX_SAMPLES as f64),
        /// sobol: bootstrap resamples for the confidence intervals
        pub bootstrap: usize = 100; range Range::closed(1.0, 100_000.0),
        /// sobol: confidence level of S1_conf/ST_conf
        pub confidence: f64 = 0.95; range Range::open(0.0, 1.0)
            => "`confidence` must lie strictly between 0 and 1", "e.g. confidence: 0.95",
        /// sobol: also compute second-order indices (second_order.csv)
        pub second_order: bool = false,
        /// model outputs to analyze (default all)
        pub outputs: Vec<String> = Vec::new(),
        /// sobol: parameters to vary (default all; the others stay at their
        /// nominal values)
        pub parameters: Vec<String> = Vec::new(),
        /// sobol: output → weight for combining total indices (unlisted
        /// outputs weigh 1)
        pub weights: BTreeMap<String, f64> = BTreeMap::new(); range Range::at_least(0.0)
            => "weights must be >= 0", "use 0 to ignore an output",
        /// sobol: total-index threshold for significant parameters
        pub threshold: f64 = 0.05; range Range::open(0.0, 1.0)
            => "`threshold` must lie strictly between 0 and 1", "e.g. threshold: 0.05 (a total index)",
        /// sobol: how total indices combine over outputs for the split: mean
        /// (weighted mean, PUB2) or max (significant for any output)
        pub combine: CombineName = CombineName::Mean,
        /// sobol: Monte Carlo samples validating the split (significant at
        /// nominal values, the others random; PUB2 used ≥ 1000); 0 = none
        pub validation: usize = 0; range Range::closed(0.0, 10_000_000.0),
        /// sobol: target minimum conformity of the validation (PUB2: 0.89):
        /// the kept set grows from the threshold's set in ranking order until
        /// the Monte Carlo validation reaches it (needs `validation`)
        pub min_conformity: Option<f64> = None; range Range::open_closed(0.0, 1.0),
        /// sobol with `min_conformity`: ranking (shortest prefix of the
        /// ranking, by doubling and bisection) or worst_output (add the
        /// parameter the least conforming output depends on most, one per
        /// probe)
        pub grow: Grow = Grow::Ranking,
        /// seed of the scrambled Sobol sequence and the bootstrap (default:
        /// the pipeline's seed)
        pub seed: Option<u64> = None,
        /// anova: CSV table of factor levels and the response, relative to
        /// the pipeline file
        pub data: Option<String> = None,
        /// anova: name of the response column
        pub response: Option<String> = None,
        /// anova: factor columns in order (default every column but the
        /// response), or the matrix keys that are factors
        pub factors: Vec<String> = Vec::new(),
        /// anova: 1 = main effects, 2 = with two-factor interactions
        pub interactions: u8 = 2; range Range::closed(1.0, 2.0),
        /// anova of modal models: least MAC for pairing a run's mode with a
        /// reference mode (default 0.5)
        pub min_mac: Option<f64> = None; range Range::open_closed(0.0, 1.0),
        /// anova on a model: parameter → list of levels; the full factorial
        /// is run (others at nominal), one ANOVA per output
        pub levels: Option<IndexMap<String, Vec<f64>>> = None,
    }
}

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
    /// Target minimum conformity that the kept set is grown to reach.
    pub min_conformity: Option<f64>,
    /// How the kept set grows towards `min_conformity`.
    pub grow: Grow,
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
    "min_conformity",
    "grow",
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
    ParamProblem::new(path, message, help)
}

fn sobol(p: &Params) -> Result<SobolSpec, ParamProblem> {
    let Some(m) = &p.model else {
        return Err(problem(
            &[],
            "method `sobol` needs param `model`",
            "e.g. model: {builtin: ishigami}",
        ));
    };
    let model = model_spec(m, p)?;
    let weights: Vec<(String, f64)> = p.weights.iter().map(|(k, w)| (k.clone(), *w)).collect();
    // Names are known before running except for model files (checked at run time).
    let mut d = p.parameters.len();
    if !matches!(model, ModelSpec::File { .. }) {
        let built = model
            .build(Path::new("."))
            .map_err(|e| problem(&["model"], e.to_string(), "check the model definition"))?;
        let names: Vec<String> = built.parameters().iter().map(|p| p.name.clone()).collect();
        check_names(&names, built.outputs(), &p.outputs, &p.parameters, &weights)?;
        if d == 0 {
            d = names.len();
        }
    }
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
    if let Some(problem) = sobol_memory(p, d.max(1), 1) {
        return Err(problem);
    }
    if !p.samples.is_power_of_two() {
        return Err(problem(
            &["samples"],
            format!("`samples` = {} is not a power of two", p.samples),
            format!(
                "Sobol sequences balance at powers of two: use {} or {}",
                p.samples.next_power_of_two() / 2,
                p.samples.next_power_of_two()
            ),
        ));
    }
    if p.min_conformity.is_some() && p.validation == 0 {
        return Err(problem(
            &["min_conformity"],
            "`min_conformity` grows the kept set until the validation reaches it, but `validation` is 0",
            "give the validation's sample size, e.g. validation: 1000",
        ));
    }
    Ok(SobolSpec {
        model,
        samples: p.samples,
        bootstrap: p.bootstrap,
        confidence: p.confidence,
        second_order: p.second_order,
        outputs: p.outputs.clone(),
        parameters: p.parameters.clone(),
        weights,
        threshold: p.threshold,
        combine: match p.combine {
            CombineName::Mean => Combine::Mean,
            CombineName::Max => Combine::Max,
        },
        validation: p.validation,
        min_conformity: p.min_conformity,
        grow: p.grow,
    })
}

/// The memory of a Sobol analysis against [`crate::resources`]: every
/// evaluation's outputs are kept for the estimators, N(d+2) evaluations
/// (N(2d+2) with second order, plus the validation samples) of 8 bytes per
/// output. Outputs per position: 3 per mode (frequency, damping, MAC) and 2
/// per band (FRAC, CSF); `d` and `positions` are lower bounds until the
/// model file is read.
pub fn sobol_memory(p: &Params, d: usize, positions: usize) -> Option<ParamProblem> {
    let n = p.samples as f64;
    let d = d as f64;
    let evaluations = n * if p.second_order {
        2.0 * d + 2.0
    } else {
        d + 2.0
    } + p.validation as f64;
    let bands = match &p.bands {
        Some(Bands::List(l)) => l.len(),
        Some(Bands::Even { count, .. }) => *count,
        None => 0,
    } as f64;
    let per_position = (3 * p.modes.unwrap_or(1)) as f64 + 2.0 * bands;
    let outputs = if p.outputs.is_empty() {
        per_position.max(1.0) * positions as f64
    } else {
        p.outputs.len() as f64
    };
    crate::stages::params::limits::memory_problem(
        &["samples"],
        "samples × (parameters + 2) evaluations × outputs (modes, bands)",
        8.0 * evaluations * outputs,
    )
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

fn anova(params: &Params) -> Result<AnovaSpec, ParamProblem> {
    let interactions = params.interactions;
    if let Some(m) = &params.model {
        if let Some(k) = ["data", "response", "factors"]
            .iter()
            .find(|k| params.given(k))
        {
            return Err(problem(
                &[k],
                format!("`{k}` belongs to an ANOVA of a data table, but `model` is given"),
                "give either `data` + `response` or `model` + `levels`",
            ));
        }
        let model = model_spec(m, params)?;
        return Ok(AnovaSpec {
            source: AnovaSource::Model {
                model,
                levels: levels(params)?,
                outputs: params.outputs.clone(),
            },
            interactions,
        });
    }
    if params.given("levels") {
        return Err(problem(
            &["levels"],
            "`levels` needs a `model` to run the factorial design on",
            "add `model:` or remove `levels`",
        ));
    }
    if !params.given("data") && !params.given("response") {
        return modes_source(params, interactions);
    }
    if params.given("min_mac") {
        return Err(problem(
            &["min_mac"],
            "`min_mac` applies to an ANOVA of modal models (the `modes` input)",
            "remove it for a data table",
        ));
    }
    let text = |key: &str, value: &Option<String>, help: &str| match value {
        Some(s) if !s.trim().is_empty() => Ok(s.to_string()),
        _ => Err(problem(
            &[],
            format!(
                "method `anova` needs param `{key}` (or `model` + `levels`, or a `modes` input)"
            ),
            help.to_string(),
        )),
    };
    if let Some(k) = FILE_ONLY
        .iter()
        .chain(&["outputs", "deps"])
        .find(|k| params.given(k))
    {
        return Err(problem(
            &[k],
            format!("`{k}` applies to an ANOVA on a model, not to a data table"),
            format!("remove `{k}` or give `model` + `levels`"),
        ));
    }
    let factors = params.factors.clone();
    Ok(AnovaSpec {
        source: AnovaSource::Table {
            data: text(
                "data",
                &params.data,
                "data: a CSV file of factor levels and the response, relative to the pipeline file",
            )?,
            response: text(
                "response",
                &params.response,
                "response: the name of the response column",
            )?,
            factors: (!factors.is_empty()).then_some(factors),
        },
        interactions,
    })
}

/// An ANOVA of the modal models bound to the `modes` input.
fn modes_source(params: &Params, interactions: u8) -> Result<AnovaSpec, ParamProblem> {
    if let Some(k) = ["modes", "bands", "band_step", "deps"]
        .iter()
        .find(|k| params.given(k))
    {
        return Err(problem(
            &[k],
            format!("`{k}` does not apply to an ANOVA of modal models"),
            format!("remove `{k}`"),
        ));
    }
    let window = params.window.unwrap_or(0.2);
    if window > 10.0 {
        return Err(problem(
            &["window"],
            "`window` must lie in (0, 10]",
            "e.g. window: 0.2",
        ));
    }
    Ok(AnovaSpec {
        source: AnovaSource::Modes {
            factors: params.factors.clone(),
            window,
            min_mac: params.min_mac.unwrap_or(0.5),
            outputs: params.outputs.clone(),
        },
        interactions,
    })
}

/// `levels: {parameter: [v1, v2, ...]}`, each parameter with at least two
/// distinct finite levels (factors in the order written).
fn levels(params: &Params) -> Result<Vec<(String, Vec<f64>)>, ParamProblem> {
    const HELP: &str = "levels: {bsd_preload: [0.5e8, 1.0e8, 2.0e8], lgs_preload: [1e8, 3e8]}";
    let Some(m) = &params.levels else {
        return Err(problem(
            &[],
            "an ANOVA on a model needs `levels`: the factor levels per parameter",
            HELP,
        ));
    };
    for (name, values) in m {
        if let Some(i) = values.iter().position(|x| !x.is_finite()) {
            return Err(problem(
                &["levels", name, &i.to_string()],
                format!("`levels.{name}.{i}` must be a finite number"),
                "write a number such as 1.0e6",
            ));
        }
        let distinct = values
            .iter()
            .enumerate()
            .all(|(i, x)| !values[..i].contains(x));
        if values.len() < 2 || !distinct {
            return Err(problem(
                &["levels", name],
                format!("`{name}` needs at least two distinct levels"),
                HELP,
            ));
        }
    }
    if m.is_empty() {
        return Err(problem(&["levels"], "`levels` lists no parameter", HELP));
    }
    Ok(m.iter().map(|(k, v)| (k.clone(), v.clone())).collect())
}

/// The analysis the params describe, or the first problem with them.
pub fn spec(params: &Params) -> Result<GsaSpec, ParamProblem> {
    let method = params.method.as_str();
    let (foreign, other) = if params.method == Method::Anova {
        (SOBOL_ONLY, "sobol")
    } else {
        (ANOVA_ONLY, "anova")
    };
    if let Some(k) = foreign.iter().find(|k| params.given(k)) {
        return Err(problem(
            &[k],
            format!("param `{k}` belongs to method `{other}`, not `{method}`"),
            format!("remove `{k}` or set `method: {other}`"),
        ));
    }
    if params.method == Method::Anova {
        anova(params).map(GsaSpec::Anova)
    } else {
        sobol(params).map(GsaSpec::Sobol)
    }
}
