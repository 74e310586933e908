//! The `gsa` kind: global sensitivity analysis (seed section 2.1; PUB1, PUB2).
//!
//! `method: sobol` samples a model (built-in test function or the user's own
//! simulator as a JSON-lines command) on a Saltelli design, evaluates it in
//! parallel and writes first-order and total Sobol indices with bootstrap
//! confidence intervals (`indices.csv`), the PUB2 screening — weighted
//! combination of total indices, threshold, per-output subproblems —
//! (`subproblems.json`) and an ST heatmap (`sobol.svg`); with
//! `second_order: true` also `second_order.csv`.
//! The model is a built-in test function, a user's simulator (JSON-lines
//! command) or a modalflow model file whose outputs are eigenfrequency,
//! damping ratio and MAC per position and reference mode
//! ([`crate::evaluation::structural`]).
//! `method: anova` reads a factorial table (CSV) and writes the ANOVA table
//! (`anova.csv`: `source,SSB,dof,MS,F,p`).
//!
//! Results are bit-identical for a seed whatever the thread count.

mod model_spec;
mod spec;

use super::artifacts;
use super::{
    InputSpec, ParamProblem, ParamSpec, ParamType, Stage, StageContext, StageError, StageOutputs,
};
use crate::dynamics::{self, directory_resolver};
use crate::evaluation::{Model, StructuralModel, StructuralOptions};
use crate::sensitivity::{self, sobol};
use model_spec::ModelSpec;
use serde_yaml_ng::{Mapping, Value};
use spec::{AnovaSpec, GsaSpec, SobolSpec};
use std::fmt::Write;
use std::path::{Path, PathBuf};

pub struct Gsa;

const PARAMS: &[ParamSpec] = &[
    ParamSpec { name: "method", ty: ParamType::Enum(&["sobol", "anova"]), required: false, doc: "sobol (default): Sobol indices of a model; anova: ANOVA table of a factorial data set" },
    ParamSpec { name: "model", ty: ParamType::Any, required: false, doc: "a modalflow model file (hashed with the files it references) | {builtin: ishigami} | {builtin: sobol_g, a: [...]} | {command: CMD, parameters: {name: {lower, upper, scale, nominal}}, outputs: [...], timeout: seconds per process, batch: samples per process (parallel; default all of a 256-sample chunk)}" },
    ParamSpec { name: "window", ty: ParamType::Number, required: false, doc: "model files: relative frequency window for pairing model and reference modes (default 0.2)" },
    ParamSpec { name: "modes", ty: ParamType::Integer, required: false, doc: "model files: modes computed per position (default: as many as the reference has; required without `reference`)" },
    ParamSpec { name: "deps", ty: ParamType::Paths, required: false, doc: "files the model command reads (hashed into the cache key)" },
    ParamSpec { name: "samples", ty: ParamType::Integer, required: false, doc: "base sample size N (default 1024, a power of two); N(d+2) evaluations, N(2d+2) with second order" },
    ParamSpec { name: "bootstrap", ty: ParamType::Integer, required: false, doc: "bootstrap resamples for the confidence intervals (default 100)" },
    ParamSpec { name: "confidence", ty: ParamType::Number, required: false, doc: "confidence level of S1_conf/ST_conf (default 0.95)" },
    ParamSpec { name: "second_order", ty: ParamType::Bool, required: false, doc: "also compute second-order indices (second_order.csv)" },
    ParamSpec { name: "outputs", ty: ParamType::Strings, required: false, doc: "model outputs to analyze (default all)" },
    ParamSpec { name: "parameters", ty: ParamType::Strings, required: false, doc: "parameters to vary (default all; the others stay at their nominal values)" },
    ParamSpec { name: "weights", ty: ParamType::Mapping, required: false, doc: "output → weight for combining total indices (unlisted outputs weigh 1)" },
    ParamSpec { name: "threshold", ty: ParamType::Number, required: false, doc: "total-index threshold for significant parameters (default 0.05)" },
    ParamSpec { name: "seed", ty: ParamType::Integer, required: false, doc: "seed of the scrambled Sobol sequence and the bootstrap (default: the pipeline's seed)" },
    ParamSpec { name: "data", ty: ParamType::Path, required: false, doc: "anova: CSV table of factor levels and the response, relative to the pipeline file" },
    ParamSpec { name: "response", ty: ParamType::String, required: false, doc: "anova: name of the response column" },
    ParamSpec { name: "factors", ty: ParamType::Strings, required: false, doc: "anova: factor columns in order (default every column but the response)" },
    ParamSpec { name: "interactions", ty: ParamType::Integer, required: false, doc: "anova: 1 = main effects, 2 = with two-factor interactions (default 2)" },
];

fn write(path: &Path, text: &str) -> Result<(), StageError> {
    std::fs::write(path, text)
        .map_err(|e| StageError::io(format!("cannot write {}", path.display()), e))
}

fn is_anova(params: &Mapping) -> bool {
    params.get("method").and_then(Value::as_str) == Some("anova")
}

impl Stage for Gsa {
    fn kind(&self) -> &'static str {
        "gsa"
    }

    fn version(&self) -> u32 {
        1
    }

    fn summary(&self) -> &'static str {
        "global sensitivity analysis: Sobol indices of a model, or ANOVA of a factorial data set"
    }

    fn params(&self) -> &'static [ParamSpec] {
        PARAMS
    }

    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Some(&[InputSpec {
            name: "reference",
            required: false,
            list: false,
            doc: "model files: reference modes (a `modes` artifact); default: the model's own modes at its true values",
        }])
    }

    fn outputs(&self, params: &Mapping) -> Vec<String> {
        if is_anova(params) {
            return vec!["anova".into()];
        }
        let mut out = vec![
            "indices".into(),
            "ranking".into(),
            "subproblems".into(),
            "heatmap".into(),
        ];
        if params.get("second_order").and_then(Value::as_bool) == Some(true) {
            out.push("second_order".into());
        }
        out
    }

    fn check(&self, params: &Mapping) -> Result<(), ParamProblem> {
        spec::parse(params).map(|_| ())
    }

    fn uses_seed(&self) -> bool {
        true
    }

    // Sharding hook (src/stages/shard.rs): a Sobol study's work is its design's batch.
    fn shardable(&self, params: &Mapping) -> bool {
        !is_anova(params)
    }

    /// A model file named by `model` is hashed into the key with the files it
    /// references, so editing the model reruns the analysis.
    fn file_dependencies(
        &self,
        params: &Mapping,
        dir: &std::path::Path,
    ) -> Result<Vec<String>, ParamProblem> {
        let Some(path) = params.get("model").and_then(Value::as_str) else {
            return Ok(Vec::new());
        };
        let referenced = super::synthesize::model_file_dependencies(dir, path).map_err(|message| ParamProblem {
            path: vec!["model".into()],
            message,
            help: Some("paths are relative to the pipeline file; see pipelines/models/ for model files".into()),
        })?;
        Ok(std::iter::once(path.to_string())
            .chain(referenced)
            .collect())
    }

    fn run(&self, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        let spec = spec::parse(ctx.params).map_err(|p| StageError::InvalidParam {
            param: p.path.join("."),
            message: p.message,
        })?;
        match spec {
            GsaSpec::Sobol(s) => run_sobol(ctx, &s),
            GsaSpec::Anova(a) => run_anova(ctx, &a),
        }
    }
}

/// Shortest round-trip text of a number, as every CSV of the project writes.
fn num(v: f64) -> String {
    format!("{v}")
}

/// The model a spec names; model files are read here, with the reference
/// modes bound to the `reference` input.
fn build_model(ctx: &StageContext, spec: &ModelSpec) -> Result<Box<dyn Model>, StageError> {
    let invalid = |message: String| StageError::InvalidParam {
        param: "model".into(),
        message,
    };
    let ModelSpec::File {
        path,
        window,
        modes,
    } = spec
    else {
        return spec
            .build(ctx.pipeline_dir)
            .map_err(|e| invalid(e.to_string()));
    };
    let file = ctx.pipeline_dir.join(path);
    let text = std::fs::read_to_string(&file)
        .map_err(|e| StageError::io(format!("cannot read model file `{path}`"), e))?;
    let base = file.parent().unwrap_or(ctx.pipeline_dir).to_path_buf();
    let resolver = directory_resolver(&base);
    let model =
        dynamics::Model::from_yaml(&text, path, &resolver).map_err(|e| invalid(e.to_string()))?;
    let reference = match ctx.inputs.get("reference") {
        Some(_) => Some(artifacts::read_modes(ctx.input("reference")?, "reference")?),
        None => None,
    };
    let options = StructuralOptions {
        window: *window,
        modes: *modes,
    };
    let m = StructuralModel::new(&model, reference.as_deref(), options)
        .map_err(|e| invalid(e.to_string()))?;
    Ok(Box::new(m))
}

fn run_sobol(ctx: &StageContext, s: &SobolSpec) -> Result<StageOutputs, StageError> {
    let model = build_model(ctx, &s.model)?;
    let names: Vec<String> = model.parameters().iter().map(|p| p.name.clone()).collect();
    spec::check_names(
        &names,
        model.outputs(),
        &s.outputs,
        &s.parameters,
        &s.weights,
    )
    .map_err(|p| StageError::InvalidParam {
        param: p.path.join("."),
        message: format!("{}; {}", p.message, p.help.unwrap_or_default()),
    })?;
    let params = sobol::SobolParams {
        n: s.samples,
        second_order: s.second_order,
        bootstrap: s.bootstrap,
        confidence: s.confidence,
        seed: ctx.seed,
        subset: s.parameters.clone(),
        outputs: s.outputs.clone(),
        chunk: 256,
    };
    let d = if s.parameters.is_empty() {
        model.parameters().len()
    } else {
        s.parameters.len()
    };
    let layout = sobol::Layout {
        n: s.samples,
        d,
        second_order: s.second_order,
    };
    ctx.progress.set_length(layout.len() as u64);
    ctx.progress
        .set_message(format!("{} evaluations", layout.len()));
    // Sharding hook: the design's batch is evaluated through the context
    // (here, as one shard of a job array, or from the shards' partials).
    let evaluate = |xs: &[Vec<f64>]| ctx.evaluate_batch(model.as_ref(), xs, params.chunk);
    let report = sobol::run_with(model.as_ref(), &params, &evaluate)
        .map_err(|e| StageError::Failed(e.to_string()))?;

    let mut csv = String::from("output,parameter,S1,S1_conf,ST,ST_conf\n");
    for (o, idx) in &report.outputs {
        for (i, p) in report.parameters.iter().enumerate() {
            let _ = writeln!(
                csv,
                "{o},{p},{},{},{},{}",
                num(idx.S1[i]),
                num(idx.S1_conf[i]),
                num(idx.ST[i]),
                num(idx.ST_conf[i])
            );
        }
    }
    let indices = ctx.scratch.join("indices.csv");
    write(&indices, &csv)?;

    let names: Vec<String> = report.outputs.iter().map(|(o, _)| o.clone()).collect();
    let st: Vec<Vec<f64>> = report.outputs.iter().map(|(_, i)| i.ST.clone()).collect();
    let weights = spec::resolve_weights(&names, &s.weights);
    let screening = sensitivity::aggregate(&report.parameters, &names, &st, &weights, s.threshold)
        .map_err(|e| StageError::Failed(e.to_string()))?;
    let json = serde_json::json!({
        "method": "sobol",
        "samples": s.samples,
        "evaluations": report.evaluations,
        "parameters": report.parameters,
        "subproblems": screening.subproblems,
        "significant": screening.significant,
        "non_significant": screening.non_significant,
        "combined_ST": screening.combined_ST.iter().map(|(p, v)| serde_json::json!({"parameter": p, "ST": v})).collect::<Vec<_>>(),
        "weights": screening.weights.iter().map(|(o, w)| serde_json::json!({"output": o, "weight": w})).collect::<Vec<_>>(),
        "threshold": screening.threshold,
        "warnings": report.warnings,
    });
    let subproblems = ctx.scratch.join("subproblems.json");
    let text =
        serde_json::to_string_pretty(&json).map_err(|e| StageError::Failed(e.to_string()))?;
    write(&subproblems, &(text + "\n"))?;

    let heatmap = ctx.scratch.join("sobol.svg");
    let svg = crate::report::svg::heatmap(
        &format!("Total Sobol indices ST ({})", ctx.stage),
        &names,
        &report.parameters,
        &st,
        0.0,
        1.0,
    );
    write(&heatmap, &svg)?;

    // The PUB2 split: parameters ranked by their weighted total index.
    let mut ranked = screening.combined_ST.clone();
    ranked.sort_by(|a, b| b.1.total_cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
    let mut csv = String::from("rank,parameter,score,significant\n");
    for (k, (p, v)) in ranked.iter().enumerate() {
        let _ = writeln!(
            csv,
            "{},{p},{},{}",
            k + 1,
            num(*v),
            screening.significant.contains(p)
        );
    }
    let ranking = ctx.scratch.join("ranking.csv");
    write(&ranking, &csv)?;

    let mut files: Vec<(String, PathBuf)> = vec![
        ("indices".into(), indices),
        ("ranking".into(), ranking),
        ("subproblems".into(), subproblems),
        ("heatmap".into(), heatmap),
    ];
    if s.second_order {
        let mut csv = String::from("output,parameter_1,parameter_2,S2,S2_conf\n");
        for (o, idx) in &report.outputs {
            if let (Some(s2), Some(c2)) = (&idx.S2, &idx.S2_conf) {
                for i in 0..d {
                    for k in i + 1..d {
                        let (pi, pk) = (&report.parameters[i], &report.parameters[k]);
                        let _ = writeln!(csv, "{o},{pi},{pk},{},{}", num(s2[i][k]), num(c2[i][k]));
                    }
                }
            }
        }
        let path = ctx.scratch.join("second_order.csv");
        write(&path, &csv)?;
        files.push(("second_order".into(), path));
    }
    Ok(StageOutputs {
        files,
        counters: [("evaluations".to_string(), report.evaluations as u64)].into(),
    })
}

fn run_anova(ctx: &StageContext, a: &AnovaSpec) -> Result<StageOutputs, StageError> {
    let path = ctx.pipeline_dir.join(&a.data);
    let text = std::fs::read_to_string(&path)
        .map_err(|e| StageError::io(format!("cannot read `{}`", a.data), e))?;
    let invalid = |e: sensitivity::SensitivityError| StageError::InvalidParam {
        param: "data".into(),
        message: e.to_string(),
    };
    let design = sensitivity::Design::from_csv(&text, &a.data, &a.response, a.factors.as_deref())
        .map_err(invalid)?;
    let rows = sensitivity::anova(&design, a.interactions).map_err(invalid)?;
    let mut csv = String::from("source,SSB,dof,MS,F,p\n");
    for r in &rows {
        let opt = |v: Option<f64>| v.map(num).unwrap_or_default();
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{}",
            r.source,
            num(r.SS),
            r.DOF,
            num(r.MS),
            opt(r.F),
            opt(r.p)
        );
    }
    let out = ctx.scratch.join("anova.csv");
    write(&out, &csv)?;
    Ok(StageOutputs {
        files: vec![("anova".into(), out)],
        counters: [("observations".to_string(), design.response.len() as u64)].into(),
    })
}
