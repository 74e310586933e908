//! The `identify` kind: model updating against reference modes (seed section
//! 2.2; PUB3 section 5.2.3, PUB4 section 5.3) — see [`crate::identify`].
//!
//! The model is a synthesize `model` artifact (model.json, the model file's
//! text embedded) or a model file named by the `model` param (hashed with the
//! files it references); the reference is a `modes` artifact; the guided
//! strategy also reads a gsa `subproblems` artifact (subproblems.json).
//!
//! Outputs: `parameters` (parameters.csv: `parameter,value,lower,upper,
//! initial`), `history` (history.csv: `evaluation,best_objective`),
//! `updated_modes` (the model's modes at the identified values, at the
//! reference DOFs), `cost` (cost.json), and for `sensitivity_guided` also
//! `subproblems` (per subproblem: repeats, values, CV, chosen source).

use super::artifacts;
use super::{
    InputSpec, ParamProblem, ParamSpec, ParamType, Stage, StageContext, StageError, StageOutputs,
};
use crate::dynamics::{self, directory_resolver};
use crate::identify::{self, ModalObjective, SubproblemSpec, Weights};
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
    ParamSpec { name: "repeats", ty: ParamType::Integer, required: false, doc: "sensitivity_guided: random starts per subproblem (default 5)" },
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
    repeats: usize,
    weights: Weights,
    window: f64,
    positions: Option<Vec<u32>>,
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
                    "e.g. 2000 for budget, 5 for repeats",
                )),
            },
        }
    };
    let budget = int("budget", 2000)?;
    let repeats = int("repeats", 5)?;
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
        repeats,
        weights,
        window,
        positions,
    })
}

impl Stage for Identify {
    fn kind(&self) -> &'static str {
        "identify"
    }
    fn version(&self) -> u32 {
        1
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
        .map_err(|e| StageError::InvalidInput {
            input: "reference".into(),
            message: e.to_string(),
        })?;
        let failed = |e: identify::IdentifyError| StageError::Failed(e.to_string());
        ctx.progress.set_length(spec.budget as u64);
        let progress = |n: u64| ctx.progress.inc(n);
        let initial = objective.nominal();
        let mut files = Vec::new();
        let (x, history, evaluations, best, optimizer_name) = if spec.guided {
            let Some(path) = ctx.inputs.get("sensitivity").and_then(|v| v.first()) else {
                return Err(StageError::InvalidInput {
                    input: "sensitivity".into(),
                    message: "strategy sensitivity_guided needs the `sensitivity` input: bind a gsa stage's `subproblems` output".into(),
                });
            };
            let subproblems = read_subproblems(path)?;
            let settings = match &spec.optimizer {
                Optimizer::Slsqp(p) => p.clone(),
                _ => Default::default(),
            };
            let r = identify::guided(
                &objective,
                &subproblems,
                &settings,
                spec.budget,
                spec.repeats,
                ctx.seed,
                &progress,
            )
            .map_err(failed)?;
            let detail = ctx.scratch.join("subproblems.json");
            let json = serde_json::json!({
                "subproblems": r.subproblems,
                "chosen_from": r.chosen_from.iter().map(|(p, o)| serde_json::json!({"parameter": p, "output": o})).collect::<Vec<_>>(),
                "damping_equations": r.damping_equations,
                "damping_rms_residual": r.damping_rms_residual,
            });
            write(
                &detail,
                &(serde_json::to_string_pretty(&json).unwrap_or_default() + "\n"),
            )?;
            files.push(("subproblems".to_string(), detail));
            (r.x, r.history, r.evaluations, r.objective, "slsqp")
        } else {
            let r = identify::black_box(
                &objective,
                &spec.optimizer,
                spec.budget,
                ctx.seed,
                &progress,
            )
            .map_err(failed)?;
            let h = r.history.iter().map(|h| (h.evaluation, h.f_best)).collect();
            (r.x_best, h, r.evaluations, r.f_best, spec.optimizer.name())
        };
        let mut csv = String::from("parameter,value,lower,upper,initial\n");
        for ((p, v), x0) in objective.parameters().iter().zip(&x).zip(&initial) {
            let _ = writeln!(csv, "{},{v:?},{:?},{:?},{x0:?}", p.name, p.lower, p.upper);
        }
        let parameters = ctx.scratch.join("parameters.csv");
        write(&parameters, &csv)?;
        let mut csv = String::from("evaluation,best_objective\n");
        for (e, f) in &history {
            let _ = writeln!(csv, "{e},{f:?}");
        }
        let hist = ctx.scratch.join("history.csv");
        write(&hist, &csv)?;
        let modes = objective.model_modes(&x).map_err(failed)?;
        let updated = ctx.scratch.join(artifacts::MODES_DIR);
        artifacts::write_modes(&updated, &modes)?;
        let cost = ctx.scratch.join("cost.json");
        let json = serde_json::json!({
            "evaluations": evaluations,
            "seconds": started.elapsed().as_secs_f64(),
            "best_objective": best,
            "strategy": if spec.guided { "sensitivity_guided" } else { "black_box" },
            "optimizer": optimizer_name,
        });
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

/// The `subproblems` of a gsa subproblems.json.
fn read_subproblems(path: &Path) -> Result<Vec<SubproblemSpec>, StageError> {
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
    serde_json::from_value(list).map_err(|e| bad(format!("subproblems: {e}")))
}
