//! The `identify` kind's params: declared for validation and parsed into a
//! typed [`Spec`], every problem located by its param path.

use crate::identify::{GuidedParams, Uncertainty, Weights};
use crate::optimize::Optimizer;
use crate::pairing::Pairing;
use crate::stages::{ParamProblem, ParamSpec, ParamType};
use serde_yaml_ng::{Mapping, Value};

const STRATEGIES: &[&str] = &["sensitivity_guided", "black_box"];

pub const PARAMS: &[ParamSpec] = &[
    ParamSpec { name: "model", ty: ParamType::Path, required: false, doc: "a model file (relative to the pipeline file), instead of the `model` input" },
    ParamSpec { name: "strategy", ty: ParamType::Enum(STRATEGIES), required: false, doc: "black_box (default): one optimizer over all parameters; sensitivity_guided: GSA subproblems, continuation refinement, damping least squares (needs the `sensitivity` input)" },
    ParamSpec { name: "optimizer", ty: ParamType::Enum(&Optimizer::NAMES), required: false, doc: "black_box: slsqp (default), pso or ga" },
    ParamSpec { name: "optimizer_settings", ty: ParamType::Mapping, required: false, doc: "settings of the optimizer (e.g. {swarm_size: 20} for pso, {starts: 4} for slsqp)" },
    ParamSpec { name: "budget", ty: ParamType::Integer, required: false, doc: "maximum model evaluations, the assessment of the result included (default 2000)" },
    ParamSpec { name: "repeats", ty: ParamType::Integer, required: false, doc: "sensitivity_guided: SLSQP runs per subproblem (default 3; 0 skips the subproblem step)" },
    ParamSpec { name: "guided", ty: ParamType::Mapping, required: false, doc: "sensitivity_guided settings: {subproblem_budget: 200, subproblem_share: 0.25, spread_limit: 0.05, refine: true, restarts: 3, smoothing: 1e-3, others: random|fixed, continuation: {first: 2, step: 1, stage_tolerance: 1e-3, max_step: 0.05}}" },
    ParamSpec { name: "exclude_modes", ty: ParamType::Strings, required: false, doc: "modes of the model at its start values to leave out, e.g. [p0.mode7] (numbered as the GSA numbers them); their reference partners are not used" },
    ParamSpec { name: "observability", ty: ParamType::Number, required: false, doc: "leave out modes whose sensor amplitude is below this fraction of the median mode's (default 0.25; 0 keeps all)" },
    ParamSpec { name: "weights", ty: ParamType::Mapping, required: false, doc: "weights of the criteria {mac, nfd, ndd} (default 1 each)" },
    ParamSpec { name: "window", ty: ParamType::Number, required: false, doc: "relative frequency window for pairing modes (default 0.3); short for pairing.window" },
    ParamSpec { name: "pairing", ty: ParamType::Mapping, required: false, doc: "mode pairing (cost (1 − MAC) + NFD/frequency_scale): {window: 0.3, min_mac: 0.5, frequency_scale: 0.1, ambiguity: 0.1}" },
    ParamSpec { name: "uncertainty", ty: ParamType::Mapping, required: false, doc: "standard deviations of the reference modes: {frequency: 0.002 (relative), shape: 0.02 (per unit-shape component), damping: 0.1 (relative), from_complexity: true (raise a mode's by its shape's complexity)}" },
    ParamSpec { name: "max_std_error", ty: ParamType::Number, required: false, doc: "largest a-priori relative standard error of a parameter the data determine (default 0.1)" },
    ParamSpec { name: "seed", ty: ParamType::Integer, required: false, doc: "seed of the random starts (default: the pipeline's seed)" },
    ParamSpec { name: "positions", ty: ParamType::Any, required: false, doc: "reference position indices to use, e.g. [0, 2] (default all)" },
];

/// The params, typed and checked.
pub struct Spec {
    pub guided: bool,
    pub optimizer: Optimizer,
    pub budget: usize,
    pub settings: GuidedParams,
    pub weights: Weights,
    pub pairing: Pairing,
    pub uncertainty: Uncertainty,
    pub observability: f64,
    pub max_std_error: f64,
    pub positions: Option<Vec<u32>>,
    /// Nominal-model modes to leave out: (position, number).
    pub exclude: Vec<(u32, usize)>,
}

pub fn problem(path: &[&str], message: impl Into<String>, help: &str) -> ParamProblem {
    ParamProblem {
        path: path.iter().map(|s| s.to_string()).collect(),
        message: message.into(),
        help: Some(help.into()),
    }
}

/// A mapping param deserialized into `T` (its defaults where absent).
fn mapping<T: serde::de::DeserializeOwned + Default>(
    params: &Mapping,
    key: &str,
    example: &str,
) -> Result<T, ParamProblem> {
    match params.get(key) {
        None => Ok(T::default()),
        Some(v) => serde_yaml_ng::from_value(v.clone())
            .map_err(|e| problem(&[key], format!("{key}: {e}"), example)),
    }
}

/// A non-negative finite number param, or its default.
fn number(params: &Mapping, key: &str, default: f64, example: &str) -> Result<f64, ParamProblem> {
    match params.get(key) {
        None => Ok(default),
        Some(v) => v
            .as_f64()
            .filter(|x| x.is_finite() && *x >= 0.0)
            .ok_or_else(|| problem(&[key], format!("`{key}` must be a number ≥ 0"), example)),
    }
}

pub fn parse(params: &Mapping) -> Result<Spec, ParamProblem> {
    let guided = params.get("strategy").and_then(Value::as_str) == Some("sensitivity_guided");
    let name = params
        .get("optimizer")
        .and_then(Value::as_str)
        .unwrap_or("slsqp");
    if guided && name != "slsqp" {
        return Err(problem(
            &["optimizer"],
            format!("sensitivity_guided uses slsqp per subproblem, not {name}"),
            "remove `optimizer` or use strategy: black_box",
        ));
    }
    let optimizer =
        Optimizer::from_settings(name, params.get("optimizer_settings")).map_err(|e| {
            problem(
                &["optimizer_settings"],
                e.to_string(),
                "see the optimizer's settings in the README",
            )
        })?;
    let budget = match params.get("budget") {
        None => 2000,
        Some(v) => v.as_u64().filter(|&n| n >= 1).ok_or_else(|| {
            problem(
                &["budget"],
                "`budget` must be an integer ≥ 1",
                "e.g. budget: 2000",
            )
        })? as usize,
    };
    let mut settings: GuidedParams = mapping(
        params,
        "guided",
        "guided: {subproblem_budget: 200, spread_limit: 0.05, refine: true, restarts: 3}",
    )?;
    if let Some(v) = params.get("repeats") {
        if params
            .get("guided")
            .and_then(|g| g.get("repeats"))
            .is_some()
        {
            return Err(problem(
                &["guided", "repeats"],
                "`repeats` is given twice",
                "give it once, as `repeats` or as `guided.repeats`",
            ));
        }
        settings.repeats = v.as_u64().map(|n| n as usize).ok_or_else(|| {
            problem(
                &["repeats"],
                "`repeats` must be an integer ≥ 0",
                "e.g. 3 (0 skips the subproblem step)",
            )
        })?;
    }
    settings
        .check()
        .map_err(|m| problem(&["guided"], m, "see the guided settings in the README"))?;
    let exclude = match params.get("exclude_modes") {
        None => Vec::new(),
        Some(v) => parse_modes(v)?,
    };
    let weights: Weights = mapping(params, "weights", "weights: {mac: 1, nfd: 1, ndd: 0.5}")?;
    for (k, w) in [
        ("mac", weights.mac),
        ("nfd", weights.nfd),
        ("ndd", weights.ndd),
    ] {
        if !(w >= 0.0 && w.is_finite()) {
            return Err(problem(
                &["weights", k],
                format!("weight {k} = {w} must be ≥ 0"),
                "weights are non-negative",
            ));
        }
    }
    if weights.mac + weights.nfd + weights.ndd == 0.0 {
        return Err(problem(
            &["weights"],
            "all weights are 0",
            "give at least one positive weight",
        ));
    }
    let mut pairing: Pairing = mapping(
        params,
        "pairing",
        "pairing: {window: 0.3, min_mac: 0.5, frequency_scale: 0.1, ambiguity: 0.1}",
    )?;
    // Identification's own defaults: a model 30 % off moves modes by up to
    // 20 %, and a pair below MAC 0.5 is no evidence of one physical mode.
    let given = |key: &str| params.get("pairing").and_then(|p| p.get(key)).is_some();
    if !given("window") {
        pairing.window = 0.3;
    }
    if !given("min_mac") {
        pairing.min_mac = 0.5;
    }
    if let Some(v) = params.get("window") {
        if params
            .get("pairing")
            .and_then(|p| p.get("window"))
            .is_some()
        {
            return Err(problem(
                &["window"],
                "the pairing window is given twice",
                "give it once, as `window` or as `pairing.window`",
            ));
        }
        pairing.window = v.as_f64().filter(|w| *w > 0.0).ok_or_else(|| {
            problem(
                &["window"],
                "`window` must be a positive fraction",
                "e.g. window: 0.2 for ±20 %",
            )
        })?;
    }
    pairing.check().map_err(|m| {
        problem(
            &["pairing"],
            m,
            "e.g. pairing: {window: 0.2, frequency_scale: 0.1}",
        )
    })?;
    let uncertainty: Uncertainty = mapping(
        params,
        "uncertainty",
        "uncertainty: {frequency: 0.002, shape: 0.02, damping: 0.1}",
    )?;
    uncertainty
        .check()
        .map_err(|m| problem(&["uncertainty"], m, "standard deviations are positive"))?;
    let observability = number(params, "observability", 0.25, "e.g. observability: 0.25")?;
    let max_std_error = number(params, "max_std_error", 0.1, "e.g. max_std_error: 0.1")?;
    if max_std_error == 0.0 {
        return Err(problem(
            &["max_std_error"],
            "`max_std_error` must be > 0",
            "e.g. max_std_error: 0.1 (10 %)",
        ));
    }
    Ok(Spec {
        guided,
        optimizer,
        budget,
        settings,
        weights,
        pairing,
        uncertainty,
        observability,
        max_std_error,
        positions: positions(params)?,
        exclude,
    })
}

/// `positions`: a non-empty list of position indices.
fn positions(params: &Mapping) -> Result<Option<Vec<u32>>, ParamProblem> {
    let Some(v) = params.get("positions") else {
        return Ok(None);
    };
    let items = v.as_sequence().filter(|s| !s.is_empty()).ok_or_else(|| {
        problem(
            &["positions"],
            "`positions` must be a non-empty list of position indices",
            "e.g. positions: [0, 2]",
        )
    })?;
    let mut out = Vec::new();
    for (i, x) in items.iter().enumerate() {
        let n = x
            .as_u64()
            .filter(|n| *n <= u32::MAX as u64)
            .ok_or_else(|| {
                problem(
                    &["positions", &i.to_string()],
                    "a position index is an integer ≥ 0",
                    "e.g. positions: [0, 2]",
                )
            })?;
        out.push(n as u32);
    }
    Ok(Some(out))
}

/// `exclude_modes`: names `p{position}.mode{r}` → (position, r).
fn parse_modes(v: &Value) -> Result<Vec<(u32, usize)>, ParamProblem> {
    let items = v.as_sequence().ok_or_else(|| {
        problem(
            &["exclude_modes"],
            "`exclude_modes` must be a list of mode names",
            "e.g. exclude_modes: [p0.mode7, p3.mode8]",
        )
    })?;
    let mut out = Vec::new();
    for (i, item) in items.iter().enumerate() {
        let parsed = item.as_str().and_then(|s| {
            let (p, m) = s.split_once('.')?;
            let p: u32 = p.strip_prefix('p')?.parse().ok()?;
            let m: usize = m.strip_prefix("mode")?.parse().ok().filter(|&m| m >= 1)?;
            Some((p, m))
        });
        match parsed {
            Some(pm) => out.push(pm),
            None => {
                return Err(problem(
                    &["exclude_modes", &i.to_string()],
                    format!(
                        "`{}` is not a mode name p<position>.mode<r>",
                        item.as_str().unwrap_or("?")
                    ),
                    "e.g. exclude_modes: [p0.mode7] (the GSA output names without the quantity)",
                ))
            }
        }
    }
    Ok(out)
}
