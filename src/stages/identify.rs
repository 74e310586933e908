//! The `identify` kind: model updating against reference modes (seed section
//! 2.2; PUB3 section 5.2.3, PUB4 section 5.3) — see [`crate::identify`].
//!
//! The model is a synthesize `model` artifact (model.json, the model file's
//! text embedded) or a model file named by the `model` param (hashed with the
//! files it references); the reference is a `modes` artifact; the guided
//! strategy also reads a gsa `subproblems` artifact (subproblems.json).
//!
//! Outputs: `parameters` (parameters.csv: `parameter,value,lower,upper,
//! initial`), `history` (history.csv: `evaluation,best_objective,mean_mac`),
//! `updated_modes` (the model's modes at the identified values, at the
//! reference DOFs), `cost` (cost.json), and for `sensitivity_guided` also
//! `subproblems` (per subproblem: repeats, values, spread; per parameter the
//! subproblem it came from; refinement and damping fit).

use super::artifacts;
use super::{
    InputSpec, ParamProblem, ParamSpec, ParamType, Stage, StageContext, StageError, StageOutputs,
};
use crate::dynamics::{self, directory_resolver};
use crate::identify::{self, GuidedParams, ModalObjective, SubproblemSpec, Weights};
use crate::optimize::Optimizer;
use serde_yaml_ng::{Mapping, Value};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Instant;

pub struct Identify;

const STRATEGIES: &[&str] = &["sensitivity_guided", "black_box"];

const PARAMS: &[ParamSpec] = &[
    ParamSpec { name: "model", ty: ParamType::Path, required: false, doc: "a model file (relative to the pipeline file), instead of the `model` input" },
    ParamSpec { name: "strategy", ty: ParamType::Enum(STRATEGIES), required: false, doc: "black_box (default): one optimizer over all parameters; sensitivity_guided: per-GSA-subproblem SLSQP + damping least squares (needs the `sensitivity` input)" },
    ParamSpec { name: "optimizer", ty: ParamType::Enum(&Optimizer::NAMES), required: false, doc: "black_box: slsqp (default), pso or ga" },
    ParamSpec { name: "optimizer_settings", ty: ParamType::Mapping, required: false, doc: "settings of the optimizer (e.g. {swarm_size: 20} for pso, {starts: 4} for slsqp)" },
    ParamSpec { name: "budget", ty: ParamType::Integer, required: false, doc: "maximum objective evaluations (default 2000)" },
    ParamSpec { name: "repeats", ty: ParamType::Integer, required: false, doc: "sensitivity_guided: SLSQP runs per subproblem (default 3; 0 skips the subproblem step)" },
    ParamSpec { name: "guided", ty: ParamType::Mapping, required: false, doc: "sensitivity_guided settings: {subproblem_budget: 200, spread_limit: 0.05, refine: true, smoothing: 1e-3, others: random|fixed}" },
    ParamSpec { name: "exclude_modes", ty: ParamType::Strings, required: false, doc: "reference modes left out, e.g. [p0.mode7] (modes the sensors barely see); numbers as in the reference" },
    ParamSpec { name: "weights", ty: ParamType::Mapping, required: false, doc: "weights of the criteria {mac, nfd, ndd} (default 1 each)" },
    ParamSpec { name: "window", ty: ParamType::Number, required: false, doc: "relative frequency window for pairing modes (default 0.2)" },
    ParamSpec { name: "seed", ty: ParamType::Integer, required: false, doc: "seed of the random starts (default: the pipeline's seed)" },
    ParamSpec { name: "positions", ty: ParamType::Any, required: false, doc: "reference position indices to use, e.g. [0, 2] (default all)" },
];

const INPUTS: &[InputSpec] = &[
    InputSpec {
        name: "model",
        required: false,
        list: false,
        doc: "a synthesize `model` artifact (model.json); or give the `model` param",
    },
    InputSpec {
        name: "reference",
        required: true,
        list: false,
        doc: "reference modes (a `modes` artifact)",
    },
    InputSpec {
        name: "sensitivity",
        required: false,
        list: false,
        doc: "sensitivity_guided: a gsa `subproblems` artifact",
    },
];

/// The params, typed and checked.
struct Spec {
    guided: bool,
    optimizer: Optimizer,
    budget: usize,
    settings: GuidedParams,
    weights: Weights,
    window: f64,
    positions: Option<Vec<u32>>,
    exclude: Vec<(u32, usize)>,
}

fn problem(path: &[&str], message: impl Into<String>, help: &str) -> ParamProblem {
    ParamProblem {
        path: path.iter().map(|s| s.to_string()).collect(),
        message: message.into(),
        help: Some(help.into()),
    }
}

fn parse(params: &Mapping) -> Result<Spec, ParamProblem> {
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
    let int = |key: &str, default: u64| -> Result<usize, ParamProblem> {
        match params.get(key) {
            None => Ok(default as usize),
            Some(v) => match v.as_u64() {
                Some(n) if n >= 1 => Ok(n as usize),
                _ => Err(problem(
                    &[key],
                    format!("`{key}` must be an integer ≥ 1"),
                    "e.g. budget: 2000",
                )),
            },
        }
    };
    let budget = int("budget", 2000)?;
    let mut settings: GuidedParams = match params.get("guided") {
        None => GuidedParams::default(),
        Some(v) => serde_yaml_ng::from_value(v.clone()).map_err(|e| {
            problem(
                &["guided"],
                format!("guided: {e}"),
                "guided: {subproblem_budget: 200, spread_limit: 0.05, refine: true, smoothing: 0.001, others: random}",
            )
        })?,
    };
    if params
        .get("guided")
        .and_then(|g| g.get("repeats"))
        .is_some()
        && params.contains_key("repeats")
    {
        return Err(problem(
            &["guided", "repeats"],
            "`repeats` is given twice",
            "give it once, as `repeats` or as `guided.repeats`",
        ));
    }
    if let Some(v) = params.get("repeats") {
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
    let weights: Weights = match params.get("weights") {
        None => Weights::default(),
        Some(v) => serde_yaml_ng::from_value(v.clone()).map_err(|e| {
            problem(
                &["weights"],
                format!("weights: {e}"),
                "weights: {mac: 1, nfd: 1, ndd: 0.5}",
            )
        })?,
    };
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
    let window = match params.get("window") {
        None => 0.2,
        Some(v) => match v.as_f64() {
            Some(w) if w > 0.0 => w,
            _ => {
                return Err(problem(
                    &["window"],
                    "`window` must be a positive fraction",
                    "e.g. window: 0.2 for ±20 %",
                ))
            }
        },
    };
    let positions = match params.get("positions") {
        None => None,
        Some(v) => {
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
            Some(out)
        }
    };
    Ok(Spec {
        guided,
        optimizer,
        budget,
        settings,
        weights,
        window,
        positions,
        exclude,
    })
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

impl Stage for Identify {
    fn kind(&self) -> &'static str {
        "identify"
    }
    fn version(&self) -> u32 {
        2
    }
    fn summary(&self) -> &'static str {
        "update model parameters so its modes match reference modes (black-box optimizer or sensitivity-guided subproblems)"
    }
    fn params(&self) -> &'static [ParamSpec] {
        PARAMS
    }
    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Some(INPUTS)
    }
    fn outputs(&self, params: &Mapping) -> Vec<String> {
        let mut out: Vec<String> = ["parameters", "history", "updated_modes", "cost"]
            .map(String::from)
            .to_vec();
        if params.get("strategy").and_then(Value::as_str) == Some("sensitivity_guided") {
            out.push("subproblems".into());
        }
        out
    }
    fn check(&self, params: &Mapping) -> Result<(), ParamProblem> {
        parse(params).map(|_| ())
    }
    fn uses_seed(&self) -> bool {
        true
    }
    fn file_dependencies(&self, params: &Mapping, dir: &Path) -> Result<Vec<String>, ParamProblem> {
        let Some(path) = params.get("model").and_then(Value::as_str) else {
            return Ok(Vec::new());
        };
        super::synthesize::model_file_dependencies(dir, path).map_err(|m| {
            problem(
                &["model"],
                m,
                "paths are relative to the pipeline file; see pipelines/models/",
            )
        })
    }

    fn check_inputs(&self, params: &Mapping, bound: &[&str]) -> Result<(), ParamProblem> {
        let guided = params.get("strategy").and_then(Value::as_str) == Some("sensitivity_guided");
        if guided && !bound.contains(&"sensitivity") {
            return Err(ParamProblem {
                path: vec!["strategy".into()],
                message: "strategy sensitivity_guided needs the `sensitivity` input".into(),
                help: Some(
                    "bind a gsa stage's subproblems: `inputs: {sensitivity: gsa.subproblems}`"
                        .into(),
                ),
            });
        }
        if !bound.contains(&"model") && !params.contains_key("model") {
            return Err(ParamProblem {
                path: vec![],
                message: "no model: bind the `model` input (a synthesize `model` output) or give the `model` param (a model file)".into(),
                help: None,
            });
        }
        Ok(())
    }

    fn run(&self, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        let started = Instant::now();
        let spec = parse(ctx.params).map_err(|p| StageError::InvalidParam {
            param: p.path.join("."),
            message: p.message,
        })?;
        let model = load_model(ctx)?;
        let reference = artifacts::read_modes(ctx.input("reference")?, "reference")?;
        let objective = ModalObjective::new(
            &model,
            &reference,
            spec.positions.as_deref(),
            spec.weights,
            spec.window,
        )
        .and_then(|o| o.without_modes(&spec.exclude))
        .map_err(|e| StageError::InvalidInput {
            input: "reference".into(),
            message: e.to_string(),
        })?;
        let failed = |e: identify::IdentifyError| StageError::Failed(e.to_string());
        ctx.progress.set_length(spec.budget as u64);
        let progress = |n: u64| ctx.progress.inc(n);
        let initial = objective.nominal();
        let mut files = Vec::new();
        let mut extra = serde_json::Map::new();
        let (x, history, evaluations, best, optimizer_name) = if spec.guided {
            let Some(path) = ctx.inputs.get("sensitivity").and_then(|v| v.first()) else {
                return Err(StageError::InvalidInput {
                    input: "sensitivity".into(),
                    message: "strategy sensitivity_guided needs the `sensitivity` input: bind a gsa stage's `subproblems` output".into(),
                });
            };
            let (subproblems, significant) = read_subproblems(path)?;
            let slsqp = match &spec.optimizer {
                Optimizer::Slsqp(p) => p.clone(),
                _ => Default::default(),
            };
            let r = identify::guided(
                &objective,
                &subproblems,
                significant.as_deref(),
                &spec.settings,
                &slsqp,
                &initial,
                spec.budget,
                ctx.seed,
                &progress,
            )
            .map_err(failed)?;
            let detail = ctx.scratch.join("subproblems.json");
            let json = serde_json::json!({
                "settings": spec.settings,
                "subproblems": r.subproblems,
                "skipped": r.skipped.iter().map(|(o, why)| serde_json::json!({"output": o, "reason": why})).collect::<Vec<_>>(),
                "chosen": r.chosen,
                "refine": {"start": finite_or_null(r.refine_start), "end": finite_or_null(r.refine_end)},
                "damping_parameters": r.damping_parameters,
                "damping_equations": r.damping_equations,
                "damping_rms_residual": r.damping_rms_residual,
            });
            write(
                &detail,
                &(serde_json::to_string_pretty(&json).unwrap_or_default() + "\n"),
            )?;
            files.push(("subproblems".to_string(), detail));
            let [s1, s2, s3] = r.phase_evaluations;
            extra.insert(
                "phase_evaluations".into(),
                serde_json::json!({"subproblems": s1, "refine": s2, "damping": s3}),
            );
            (r.x, r.history, r.evaluations, r.objective, "slsqp")
        } else {
            let r = identify::black_box(
                &objective,
                &spec.optimizer,
                &initial,
                spec.budget,
                ctx.seed,
                &progress,
            )
            .map_err(failed)?;
            let o = r.result;
            (
                o.x_best,
                r.history,
                o.evaluations,
                o.f_best,
                spec.optimizer.name(),
            )
        };
        let mut csv = String::from("parameter,value,lower,upper,initial\n");
        for ((p, v), x0) in objective.parameters().iter().zip(&x).zip(&initial) {
            let _ = writeln!(csv, "{},{v:?},{:?},{:?},{x0:?}", p.name, p.lower, p.upper);
        }
        let parameters = ctx.scratch.join("parameters.csv");
        write(&parameters, &csv)?;
        let mut csv = String::from("evaluation,best_objective,mean_mac\n");
        for h in &history {
            let _ = writeln!(csv, "{},{:?},{:?}", h.evaluation, h.objective, h.mean_mac);
        }
        let hist = ctx.scratch.join("history.csv");
        write(&hist, &csv)?;
        let modes = objective.model_modes(&x).map_err(failed)?;
        let updated = ctx.scratch.join(artifacts::MODES_DIR);
        artifacts::write_modes(&updated, &modes)?;
        let cost = ctx.scratch.join("cost.json");
        let modes = objective.summary(&x).map_err(failed)?;
        let mut json = serde_json::json!({
            "evaluations": evaluations,
            "seconds": started.elapsed().as_secs_f64(),
            "best_objective": best,
            "modes": modes,
            "strategy": if spec.guided { "sensitivity_guided" } else { "black_box" },
            "optimizer": optimizer_name,
        });
        if let Some(map) = json.as_object_mut() {
            map.extend(extra);
        }
        write(
            &cost,
            &(serde_json::to_string_pretty(&json).unwrap_or_default() + "\n"),
        )?;
        files.extend([
            ("parameters".to_string(), parameters),
            ("history".to_string(), hist),
            ("updated_modes".to_string(), updated),
            ("cost".to_string(), cost),
        ]);
        Ok(StageOutputs {
            files,
            counters: [("evaluations".to_string(), evaluations as u64)].into(),
        })
    }
}

/// A JSON number, or null for NaN/±∞ (JSON has no such numbers).
fn finite_or_null(v: f64) -> serde_json::Value {
    if v.is_finite() {
        serde_json::json!(v)
    } else {
        serde_json::Value::Null
    }
}

fn write(path: &Path, text: &str) -> Result<(), StageError> {
    std::fs::write(path, text)
        .map_err(|e| StageError::io(format!("cannot write {}", path.display()), e))
}

/// The model from the `model` input (model.json) or the `model` param.
fn load_model(ctx: &StageContext) -> Result<dynamics::Model, StageError> {
    if let Some(file) = ctx.path_param("model") {
        let rel = ctx
            .params
            .get("model")
            .and_then(Value::as_str)
            .unwrap_or_default();
        let text = std::fs::read_to_string(&file)
            .map_err(|e| StageError::io(format!("cannot read model file `{rel}`"), e))?;
        let base = file.parent().unwrap_or(ctx.pipeline_dir).to_path_buf();
        let resolver = directory_resolver(&base);
        return dynamics::Model::from_yaml(&text, rel, &resolver).map_err(|e| {
            StageError::InvalidParam {
                param: "model".into(),
                message: e.to_string(),
            }
        });
    }
    let Some(path) = ctx.inputs.get("model").and_then(|v| v.first()) else {
        return Err(StageError::InvalidInput {
            input: "model".into(),
            message: "no model: bind the `model` input to a synthesize stage's `model` output, or give the `model` param".into(),
        });
    };
    let bad = |message: String| StageError::InvalidInput {
        input: "model".into(),
        message,
    };
    let bytes = std::fs::read(path).map_err(|e| StageError::io("cannot read input `model`", e))?;
    let json: serde_json::Value =
        serde_json::from_slice(&bytes).map_err(|e| bad(format!("not a model.json: {e}")))?;
    let yaml = json["yaml"].as_str().ok_or_else(|| {
        bad("model.json has no `yaml` text; bind a synthesize stage's `model` output".into())
    })?;
    let name = json["file"].as_str().unwrap_or("model.json").to_string();
    let external: BTreeMap<String, String> = json["external"]
        .as_object()
        .map(|m| {
            m.iter()
                .filter_map(|(k, v)| v.as_str().map(|s| (k.clone(), s.to_string())))
                .collect()
        })
        .unwrap_or_default();
    let resolver = |p: &str| -> std::io::Result<Vec<u8>> {
        external
            .get(p)
            .map(|s| s.as_bytes().to_vec())
            .ok_or_else(|| {
                std::io::Error::new(
                    std::io::ErrorKind::NotFound,
                    format!("`{p}` is not embedded in model.json"),
                )
            })
    };
    dynamics::Model::from_yaml(yaml, &name, &resolver).map_err(|e| bad(e.to_string()))
}

/// The `subproblems` of a gsa subproblems.json and its `significant` list
/// (absent in hand-written files).
#[allow(clippy::type_complexity)]
fn read_subproblems(path: &Path) -> Result<(Vec<SubproblemSpec>, Option<Vec<String>>), StageError> {
    let bad = |message: String| StageError::InvalidInput {
        input: "sensitivity".into(),
        message,
    };
    let bytes =
        std::fs::read(path).map_err(|e| StageError::io("cannot read input `sensitivity`", e))?;
    let json: serde_json::Value =
        serde_json::from_slice(&bytes).map_err(|e| bad(format!("not a subproblems.json: {e}")))?;
    let list = json.get("subproblems").cloned().ok_or_else(|| {
        bad("no `subproblems` list; bind a gsa stage's `subproblems` output".into())
    })?;
    let specs = serde_json::from_value(list).map_err(|e| bad(format!("subproblems: {e}")))?;
    let significant = match json.get("significant") {
        None => None,
        Some(v) => {
            Some(serde_json::from_value(v.clone()).map_err(|e| bad(format!("significant: {e}")))?)
        }
    };
    Ok((specs, significant))
}
