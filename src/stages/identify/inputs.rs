//! What the `identify` kind reads from its inputs: the model (the `model`
//! input or param), the objective against the `reference` modes, the
//! `sensitivity` screening and the measured FRFs of the `frf` input.

use super::spec::Spec;
use crate::artifacts;
use crate::artifacts::model::ModelJson;
use crate::dynamics;
use crate::identify::frf_objective::{FrfNoise, FrfReference};
use crate::identify::{ModalObjective, NamedMode, SubproblemSpec};
use crate::stages::{StageContext, StageError};
use std::path::Path;
use std::sync::Arc;

/// The objective J over the `reference` modes: `model` paired with them
/// as the spec weighs and pairs, each mode's uncertainty raised to the
/// spread the reference states when `from_estimate` asks for it.
pub(super) fn modal_objective(
    ctx: &StageContext,
    model: &dynamics::Model,
    spec: &Spec,
) -> Result<ModalObjective, StageError> {
    let reference_dir = ctx.input("reference")?;
    let reference = artifacts::modes::read_damped_modes(reference_dir, "reference", "identify")?;
    let invalid_reference = |e: crate::identify::IdentifyError| StageError::InvalidInput {
        input: "reference".into(),
        message: e.to_string(),
    };
    let mut objective = ModalObjective::new(
        model,
        &reference,
        spec.positions.as_deref(),
        spec.weights,
        spec.pairing,
    )
    .map_err(invalid_reference)?;
    objective.set_uncertainty(spec.uncertainty);
    if spec.uncertainty.from_estimate {
        let spread = artifacts::modes::read_mode_spread(reference_dir, "reference")?;
        for m in spread.unwrap_or_default() {
            objective.raise_uncertainty(
                &spec.uncertainty,
                m.position,
                m.mode - 1,
                m.frequency,
                m.damping,
            );
        }
    }
    Ok(objective)
}

/// The screening of the bound `sensitivity` input, which the guided
/// strategy needs.
pub(super) fn screening(ctx: &StageContext) -> Result<ScreeningInput, StageError> {
    let Some(path) = ctx.inputs.get("sensitivity").and_then(|v| v.first()) else {
        return Err(StageError::InvalidInput {
            input: "sensitivity".into(),
            message: "strategy sensitivity_guided needs the `sensitivity` input: bind a gsa stage's `subproblems` output".into(),
        });
    };
    read_subproblems(path)
}

/// The measured FRFs of the `frf` input matched to the objective's model
/// (`None` without the input), for the FRF refinement.
pub(super) fn frf_reference(
    ctx: &StageContext,
    objective: &ModalObjective,
    spec: &Spec,
) -> Result<Option<FrfReference>, StageError> {
    ctx.inputs
        .get("frf")
        .and_then(|v| v.first())
        .map(|path| {
            let sets = artifacts::frf::read_calibrated(
                path,
                "frf",
                "identify",
                "FRF fit against the model",
            )?;
            let prepared = objective.prepared();
            let noise = FrfNoise {
                averages: spec.frf_averages,
                drift: spec.frf_drift,
                truncation: spec.frf_truncation,
            };
            FrfReference::new(
                prepared,
                &sets,
                spec.positions.as_deref(),
                spec.frf_band,
                noise,
            )
            .map_err(|e| StageError::InvalidInput {
                input: "frf".into(),
                message: e.to_string(),
            })
        })
        .transpose()
}

/// The screening an identify stage reads from a gsa subproblems.json.
pub(super) struct ScreeningInput {
    pub(super) specs: Vec<SubproblemSpec>,
    pub(super) significant: Option<Vec<String>>,
    pub(super) modes: Vec<NamedMode>,
}

/// The model from the `model` input (model.json) or the `model` param
/// (built once per process: validation of the same content shares it).
pub(super) fn load_model(
    ctx: &StageContext,
    param: Option<&str>,
) -> Result<Arc<dynamics::Model>, StageError> {
    if let Some(rel) = param {
        let (model, _) = super::super::params::model_files::load_model(ctx.pipeline_dir, rel)
            .map_err(|message| StageError::InvalidParam {
                param: "model".into(),
                message,
            })?;
        return Ok(model);
    }
    let Some(path) = ctx.inputs.get("model").and_then(|v| v.first()) else {
        return Err(StageError::InvalidInput {
            input: "model".into(),
            message: "no model: bind the `model` input to a synthesize stage's `model` output, or give the `model` param".into(),
        });
    };
    let json = ModelJson::read(path, "model")?;
    let resolve = json.resolver(ctx.pipeline_dir);
    let model = dynamics::Model::from_yaml(
        &json.yaml,
        json.file_name(crate::artifacts::model::FILE),
        &resolve,
    );
    model.map(Arc::new).map_err(|e| StageError::InvalidInput {
        input: "model".into(),
        message: e.to_string(),
    })
}

/// The `subproblems` of a gsa subproblems.json, its `significant` list and
/// the frequencies of the modes it names (both absent in hand-written files).
fn read_subproblems(path: &Path) -> Result<ScreeningInput, StageError> {
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
    let modes = match json.get("modes") {
        None => Vec::new(),
        Some(v) => serde_json::from_value(v.clone()).map_err(|e| bad(format!("modes: {e}")))?,
    };
    Ok(ScreeningInput {
        specs,
        significant,
        modes,
    })
}
