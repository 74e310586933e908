//! The `gsa` kind: global sensitivity analysis (seed section 2.1; PUB1, PUB2).
//!
//! `method: sobol` ([`sobol`]) samples a model on a Saltelli design,
//! evaluates it in parallel and writes first-order and total Sobol indices
//! with bootstrap confidence intervals (`indices.csv`), the PUB2 screening —
//! weighted combination of total indices, threshold, per-output subproblems
//! — (`ranking.csv`, `significant.csv`, `subproblems.json`), an ST heatmap
//! (`sobol.svg`), with `second_order: true` also `second_order.csv`, and with
//! `validation: N` the Monte Carlo check of the split (PUB2: significant
//! parameters at their true values, the others random).
//! `method: anova` ([`anova`]) writes the ANOVA table (`anova.csv`) of a
//! factorial data set (CSV) or of a full factorial design run on a model.
//!
//! The model is a built-in test function, a user's simulator (JSON-lines
//! command) or a modalflow model file whose outputs are eigenfrequency,
//! damping ratio and MAC per position and reference mode, and optionally
//! FRAC and CSF per frequency band ([`crate::evaluation::structural`]).
//! Results are bit-identical for a seed whatever the thread count.

mod anova;
mod model_spec;
mod sobol;
mod spec;

use super::artifacts;
use super::{
    InputSpec, ParamProblem, ParamSpec, ParamType, Stage, StageContext, StageError, StageOutputs,
};
use crate::dynamics::{self, directory_resolver};
use crate::evaluation::{BandOptions, FrfBands, Model, StructuralModel, StructuralOptions};
use model_spec::ModelSpec;
use serde_yaml_ng::{Mapping, Value};
use spec::GsaSpec;
use std::path::Path;

pub struct Gsa;

const PARAMS: &[ParamSpec] = &[
    ParamSpec { name: "method", ty: ParamType::Enum(&["sobol", "anova"]), required: false, doc: "sobol (default): Sobol indices of a model; anova: ANOVA table of a factorial data set" },
    ParamSpec { name: "model", ty: ParamType::Any, required: false, doc: "a modalflow model file (hashed with the files it references) | {builtin: ishigami} | {builtin: sobol_g, a: [...]} | {command: CMD, parameters: {name: {lower, upper, scale, nominal}}, outputs: [...], timeout: seconds per process, batch: samples per process (parallel; default all of a 256-sample chunk)}" },
    ParamSpec { name: "window", ty: ParamType::Number, required: false, doc: "model files: relative frequency window for pairing model and reference modes (default 0.2)" },
    ParamSpec { name: "modes", ty: ParamType::Integer, required: false, doc: "model files: modes computed per position (default: as many as the reference has; required without `reference`)" },
    ParamSpec { name: "bands", ty: ParamType::Any, required: false, doc: "model files: frequency bands for FRAC/CSF outputs p{i}.band{b}.frac|csf, [[lo, hi], ...] or {min, max, count} in Hz; against the `reference_frf` input or the model's own FRFs at its true values" },
    ParamSpec { name: "band_step", ty: ParamType::Number, required: false, doc: "model files: line spacing in Hz of the model's own reference FRFs (default 0.5)" },
    ParamSpec { name: "deps", ty: ParamType::Paths, required: false, doc: "files the model command reads (hashed into the cache key)" },
    ParamSpec { name: "samples", ty: ParamType::Integer, required: false, doc: "base sample size N (default 1024, a power of two); N(d+2) evaluations, N(2d+2) with second order" },
    ParamSpec { name: "bootstrap", ty: ParamType::Integer, required: false, doc: "bootstrap resamples for the confidence intervals (default 100)" },
    ParamSpec { name: "confidence", ty: ParamType::Number, required: false, doc: "confidence level of S1_conf/ST_conf (default 0.95)" },
    ParamSpec { name: "second_order", ty: ParamType::Bool, required: false, doc: "also compute second-order indices (second_order.csv)" },
    ParamSpec { name: "outputs", ty: ParamType::Strings, required: false, doc: "model outputs to analyze (default all)" },
    ParamSpec { name: "parameters", ty: ParamType::Strings, required: false, doc: "parameters to vary (default all; the others stay at their nominal values)" },
    ParamSpec { name: "weights", ty: ParamType::Mapping, required: false, doc: "output → weight for combining total indices (unlisted outputs weigh 1)" },
    ParamSpec { name: "threshold", ty: ParamType::Number, required: false, doc: "total-index threshold for significant parameters (default 0.05)" },
    ParamSpec { name: "combine", ty: ParamType::Enum(&["mean", "max"]), required: false, doc: "sobol: how total indices combine over outputs for the split: mean (weighted mean, PUB2; default) or max (significant for any output)" },
    ParamSpec { name: "validation", ty: ParamType::Integer, required: false, doc: "sobol: Monte Carlo samples validating the split (significant at nominal values, the others random; PUB2 used ≥ 1000); 0 = none" },
    ParamSpec { name: "seed", ty: ParamType::Integer, required: false, doc: "seed of the scrambled Sobol sequence and the bootstrap (default: the pipeline's seed)" },
    ParamSpec { name: "data", ty: ParamType::Path, required: false, doc: "anova: CSV table of factor levels and the response, relative to the pipeline file" },
    ParamSpec { name: "response", ty: ParamType::String, required: false, doc: "anova: name of the response column" },
    ParamSpec { name: "factors", ty: ParamType::Strings, required: false, doc: "anova: factor columns in order (default every column but the response)" },
    ParamSpec { name: "interactions", ty: ParamType::Integer, required: false, doc: "anova: 1 = main effects, 2 = with two-factor interactions (default 2)" },
    ParamSpec { name: "min_mac", ty: ParamType::Number, required: false, doc: "anova of modal models: least MAC for pairing a run's mode with a reference mode (default 0.5)" },
    ParamSpec { name: "levels", ty: ParamType::Mapping, required: false, doc: "anova on a model: parameter → list of levels; the full factorial is run (others at nominal), one ANOVA per output" },
];

pub(super) fn write(path: &Path, text: &str) -> Result<(), StageError> {
    std::fs::write(path, text)
        .map_err(|e| StageError::io(format!("cannot write {}", path.display()), e))
}

fn is_anova(params: &Mapping) -> bool {
    params.get("method").and_then(Value::as_str) == Some("anova")
}

/// Shortest round-trip text of a number, as every CSV of the project writes.
pub(super) fn num(v: f64) -> String {
    format!("{v}")
}

impl Stage for Gsa {
    fn kind(&self) -> &'static str {
        "gsa"
    }

    /// 2: `significant` output, FRF bands, validation, ANOVA sources.
    /// 3: modes paired by frequency and MAC; one pole convention for
    /// frequencies and damping (hysteretic modes at |λ|); subproblems.json
    /// names its modes' frequencies.
    fn version(&self) -> u32 {
        3
    }

    fn summary(&self) -> &'static str {
        "global sensitivity analysis: Sobol indices of a model with the PUB2 split and its validation, or ANOVA of a table, a factorial design on a model, or modal models of matrix runs"
    }

    fn params(&self) -> &'static [ParamSpec] {
        PARAMS
    }

    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Some(&[
            InputSpec {
                name: "reference",
                required: false,
                list: false,
                doc: "model files: reference modes (a `modes` artifact); default: the model's own modes at its true values",
            },
            InputSpec {
                name: "modes",
                required: false,
                list: true,
                doc: "anova of modal models: the `modes` of matrix runs (e.g. `ema[*].modes`); factor levels come from their matrix values, modes are paired with `reference`",
            },
            InputSpec {
                name: "reference_frf",
                required: false,
                list: false,
                doc: "model files with `bands`: reference FRFs (an `frf` artifact); default: the model's own FRFs at its true values",
            },
        ])
    }

    fn outputs(&self, params: &Mapping) -> Vec<String> {
        if is_anova(params) {
            let mut out = vec!["anova".into()];
            if !params.contains_key("data") {
                out.extend(["runs".into(), "heatmap".into()]);
            }
            return out;
        }
        let mut out = vec![
            "indices".into(),
            "ranking".into(),
            "significant".into(),
            "subproblems".into(),
            "heatmap".into(),
        ];
        if params.get("second_order").and_then(Value::as_bool) == Some(true) {
            out.push("second_order".into());
        }
        if params
            .get("validation")
            .and_then(Value::as_u64)
            .unwrap_or(0)
            > 0
        {
            out.extend([
                "validation".into(),
                "validation_summary".into(),
                "validation_plot".into(),
            ]);
        }
        out
    }

    fn check(&self, params: &Mapping) -> Result<(), ParamProblem> {
        spec::parse(params).map(|_| ())
    }

    fn uses_seed(&self) -> bool {
        true
    }

    fn check_inputs(&self, params: &Mapping, bound: &[&str]) -> Result<(), ParamProblem> {
        let modal_anova = matches!(
            spec::parse(params),
            Ok(GsaSpec::Anova(spec::AnovaSpec {
                source: spec::AnovaSource::Modes { .. },
                ..
            }))
        );
        let has = |n: &str| bound.contains(&n);
        let problem = |message: &str, help: &str| ParamProblem {
            path: Vec::new(),
            message: message.into(),
            help: Some(help.into()),
        };
        if modal_anova && !(has("modes") && has("reference")) {
            return Err(problem(
                "an ANOVA without `data` or `model` analyzes modal models: bind the `modes` and `reference` inputs",
                "inputs: {modes: \"ema[*].modes\", reference: healthy.modes}, or give `data` (a CSV table) or `model` + `levels`",
            ));
        }
        if !modal_anova && has("modes") {
            return Err(problem(
                "the `modes` input belongs to an ANOVA of modal models",
                "use `method: anova` without `data` and `model`, or remove the `modes` input",
            ));
        }
        Ok(())
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
            GsaSpec::Sobol(s) => sobol::run(ctx, &s),
            GsaSpec::Anova(a) => anova::run(ctx, &a),
        }
    }
}

/// The model a spec names; model files are read here, with the reference
/// modes bound to the `reference` input.
pub(super) fn build_model(
    ctx: &StageContext,
    spec: &ModelSpec,
) -> Result<Box<dyn Model>, StageError> {
    let invalid = |message: String| StageError::InvalidParam {
        param: "model".into(),
        message,
    };
    let ModelSpec::File {
        path,
        window,
        modes,
        bands,
        band_step,
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
    if bands.is_empty() {
        return Ok(Box::new(m));
    }
    let options = BandOptions {
        bands: bands.clone(),
        step: *band_step,
    };
    let frf_bands = match ctx.inputs.get("reference_frf") {
        Some(_) => {
            let sets = artifacts::read_frf(ctx.input("reference_frf")?, "reference_frf")?;
            FrfBands::from_reference(m.prepared(), &sets, &options)
        }
        None => FrfBands::from_model(
            m.prepared(),
            &model.true_values(),
            &m.reference_configs(),
            m.modes(),
            &options,
        ),
    }
    .map_err(|e| StageError::InvalidParam {
        param: "bands".into(),
        message: e.to_string(),
    })?;
    Ok(Box::new(m.with_frf_bands(frf_bands)))
}
