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
//! FRAC and CSF per frequency band ([`crate::simulator::structural`]).
//! Results are bit-identical for a seed whatever the thread count.

mod adequacy;
mod anova;
mod model_spec;
mod sobol;
mod spec;

use super::{
    Artifact, FileRef, InputSpec, Kind, Output, ParamProblem, StageContext, StageError,
    StageOutputs,
};
use crate::artifacts;
use crate::simulator::{BandOptions, FrfBands, Model, StructuralModel, StructuralOptions};
use model_spec::{ModelParam, ModelSpec};
pub use spec::Params;
use spec::{GsaSpec, Method};
use std::path::Path;

pub struct Gsa;

pub(super) fn write(path: &Path, text: &str) -> Result<(), StageError> {
    std::fs::write(path, text)
        .map_err(|e| StageError::io(format!("cannot write {}", path.display()), e))
}

/// Shortest round-trip text of a number, as every CSV of the project writes.
pub(super) fn num(v: f64) -> String {
    format!("{v}")
}

const INPUTS: &[InputSpec] = &[
    InputSpec {
        name: "reference",
        required: false,
        list: false,
        artifact: Artifact::Modes,
        doc: "model files: reference modes (a `modes` artifact); default: the model's own modes at its true values",
    },
    InputSpec {
        name: "modes",
        required: false,
        list: true,
        artifact: Artifact::Modes,
        doc: "anova of modal models: the `modes` of matrix runs (e.g. `ema[*].modes`); factor levels come from their matrix values, modes are paired with `reference`",
    },
    InputSpec {
        name: "reference_frf",
        required: false,
        list: false,
        artifact: Artifact::Frf,
        doc: "model files with `bands`: reference FRFs (an `frf` artifact); default: the model's own FRFs at its true values",
    },
];

impl Kind for Gsa {
    type Params = Params;
    const NAME: &'static str = "gsa";
    const FILE_PARAMS: &'static [(&'static str, bool)] =
        &[("model", false), ("data", false), ("deps", false)];

    /// 2: `significant` output, FRF bands, validation, ANOVA sources.
    /// 3: modes paired by frequency and MAC; one pole convention for
    /// frequencies and damping (hysteretic modes at |λ|); subproblems.json
    /// names its modes' frequencies.
    /// 4: model modes by shift-invert block Lanczos (issue 16).
    /// 5: log-scale samples through the one unit-box map of `parameter::Scale`
    ///    (log10 form; round-off different from the former `lower·(upper/lower)^u`).
    /// 6: eigenpairs from the faster Lanczos (one conditional DGKS pass,
    ///    Cholesky QR2, basis 2.5·nev, tolerance 1e-12; issue 16), last bits.
    /// 7: ANOVA of modal models pairs shapes by node and axis (an opposite
    ///    direction flips the sign), as `evaluate` does.
    /// 8: eigenpairs from the problem-chosen shift and range start of the
    ///    Lanczos (issue 32).
    /// 9: the split's bootstrap intervals (`significant.csv`: score_low,
    ///    score_high, undecided, samples_needed) and a warning when N cannot
    ///    decide it; `min_conformity` and `grow` (the validated threshold
    ///    rule, docs/screening.md); the
    ///    validation draws a coordinate for every parameter (common random
    ///    numbers), so its samples differ from version 7's.
    /// 10: sobol.svg shows the 24 parameters with the largest ST, sorted,
    ///    and the rest as one column (issue 29); the indices are unchanged.
    /// 11: the estimators' notes (an output constant over every sample) are
    ///    stage warnings too, not only in subproblems.json (issue 29); the
    ///    outputs are unchanged.
    /// 12: eigenpairs of sparse models from the sparse factor's own ordering
    ///    when it fills less than AMD, and of free-free or > 40-mode solves
    ///    from the faster shift choice and locking (issue 32): last bits.
    fn version(&self) -> u32 {
        12
    }

    fn summary(&self) -> &'static str {
        "global sensitivity analysis: Sobol indices of a model with the PUB2 split and its validation, or ANOVA of a table, a factorial design on a model, or modal models of matrix runs"
    }

    fn inputs(&self) -> Option<&'static [InputSpec]> {
        Some(INPUTS)
    }

    /// sobol: indices … heatmap, `second_order` with second_order: true,
    /// `validation*` with validation > 0; anova: anova, and `runs` and
    /// `heatmap` unless the data come from a table.
    const OUTPUTS: &'static [(&'static str, Artifact)] = &[
        ("indices", Artifact::Table),
        ("ranking", Artifact::Table),
        ("significant", Artifact::Significant),
        ("subproblems", Artifact::Subproblems),
        ("heatmap", Artifact::Figure),
        ("second_order", Artifact::Table),
        ("validation", Artifact::Table),
        ("validation_summary", Artifact::Validation),
        ("validation_plot", Artifact::Figure),
        ("anova", Artifact::Table),
        ("runs", Artifact::Table),
    ];

    fn outputs(&self, p: &Params) -> Vec<Output> {
        let names: &[&str] = match p.method {
            Method::Anova if p.data.is_some() => &["anova"],
            Method::Anova => &["anova", "runs", "heatmap"],
            Method::Sobol => &[
                "indices",
                "ranking",
                "significant",
                "subproblems",
                "heatmap",
            ],
        };
        let mut names = names.to_vec();
        if p.method == Method::Sobol && p.second_order {
            names.push("second_order");
        }
        if p.method == Method::Sobol && p.validation > 0 {
            names.extend(["validation", "validation_summary", "validation_plot"]);
        }
        names
            .into_iter()
            .filter_map(|n| Self::OUTPUTS.iter().find(|(o, _)| *o == n))
            .map(|(n, a)| Output::new(*n, *a))
            .collect()
    }

    fn check(&self, p: &Params) -> Vec<ParamProblem> {
        spec::spec(p).err().into_iter().collect()
    }

    fn uses_seed(&self) -> bool {
        true
    }

    fn seed(&self, p: &Params) -> Option<u64> {
        p.seed
    }

    fn files(&self, p: &Params) -> Vec<FileRef> {
        let mut out = Vec::new();
        let mut add = |param: String, path: &str| {
            out.push(FileRef {
                param,
                path: path.to_string(),
                glob: false,
            })
        };
        if let Some(ModelParam::File(path)) = &p.model {
            add("model".into(), path);
        }
        if let Some(data) = &p.data {
            add("data".into(), data);
        }
        for (i, d) in p.deps.iter().enumerate() {
            add(format!("deps[{i}]"), d);
        }
        out
    }

    fn check_inputs(&self, p: &Params, bound: &[&str]) -> Vec<ParamProblem> {
        let modal_anova = matches!(
            spec::spec(p),
            Ok(GsaSpec::Anova(spec::AnovaSpec {
                source: spec::AnovaSource::Modes { .. },
                ..
            }))
        );
        let has = |n: &str| bound.contains(&n);
        if modal_anova && !(has("modes") && has("reference")) {
            return vec![ParamProblem::new(
                &[],
                "an ANOVA without `data` or `model` analyzes modal models: bind the `modes` and `reference` inputs",
                "inputs: {modes: \"ema[*].modes\", reference: healthy.modes}, or give `data` (a CSV table) or `model` + `levels`",
            )];
        }
        if !modal_anova && has("modes") {
            return vec![ParamProblem::new(
                &[],
                "the `modes` input belongs to an ANOVA of modal models",
                "use `method: anova` without `data` and `model`, or remove the `modes` input",
            )];
        }
        Vec::new()
    }

    // Sharding hook (src/stages/shard.rs): a Sobol study's work is its design's batch.
    fn shardable(&self, p: &Params) -> bool {
        p.method == Method::Sobol
    }

    /// A model file named by `model` is hashed into the key with the files it
    /// references, so editing the model reruns the analysis.
    fn file_dependencies(&self, p: &Params, dir: &Path) -> Result<Vec<String>, ParamProblem> {
        let Some(ModelParam::File(path)) = &p.model else {
            return Ok(Vec::new());
        };
        super::params::model_files::model_file_dependencies(dir, path).map_err(|message| {
            ParamProblem::new(
                &["model"],
                message,
                "paths are relative to the pipeline file; see pipelines/models/ for model files",
            )
        })
    }

    fn run(&self, p: &Params, ctx: &StageContext) -> Result<StageOutputs, StageError> {
        let spec = spec::spec(p).map_err(|p| StageError::InvalidParam {
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
    // Built once per process: validation of the same content shares it.
    let (model, _) =
        super::params::model_files::load_model(ctx.pipeline_dir, path).map_err(invalid)?;
    let reference = match ctx.inputs.get("reference") {
        Some(_) => Some(artifacts::modes::read_modes(
            ctx.input("reference")?,
            "reference",
        )?),
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
            let sets = artifacts::frf::read_calibrated(
                ctx.input("reference_frf")?,
                "reference_frf",
                "gsa",
                "FRAC/CSF of model FRFs against the reference",
            )?;
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
