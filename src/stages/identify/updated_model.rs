//! The `updated_model` output of `identify`: a directory with the updated
//! model file (`model.yaml`, see [`crate::dynamics::model_writer`]), the
//! files it references (super-element matrices, same relative paths) and
//! `changes.csv` ([`ChangeRow`]: `parameter,kind,initial,value,change_rel,
//! identified,identifiable,std_error_rel,ci_low,ci_high,lower,upper`, the
//! table of the update).
//!
//! Built from what identify already wrote (its parameters.csv) and the
//! model it read (the `model` param or the model.json input), so the
//! identification itself is untouched.

use crate::artifacts::model::ModelJson;
use crate::artifacts::parameters::{read_identified, ParameterRow};
use crate::dynamics::model_writer::{updated_model_file, ParameterUpdate};
use crate::stages::{StageContext, StageError};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::{Component, Path};

/// One row of changes.csv: a parameter's start and identified value, in
/// its unit; the relative change; whether it moved and whether the data
/// determine it (empty when it did not move); its relative standard error
/// and absolute 95 % interval (as in parameters.csv).
#[derive(Serialize)]
struct ChangeRow<'a> {
    parameter: &'a str,
    kind: &'a str,
    initial: f64,
    value: f64,
    change_rel: Option<f64>,
    identified: bool,
    identifiable: Option<bool>,
    std_error_rel: Option<f64>,
    ci_low: Option<f64>,
    ci_high: Option<f64>,
    lower: f64,
    upper: f64,
}

/// Referenced files by path as the model file writes them: their bytes.
type Referenced = BTreeMap<String, Vec<u8>>;

/// The model file's text, name and referenced files, as identify read them.
fn model_source(
    ctx: &StageContext,
    param: Option<&str>,
) -> Result<(String, String, Referenced), StageError> {
    if let Some(rel) = param {
        let file = ctx.pipeline_dir.join(rel);
        let text = std::fs::read_to_string(&file)
            .map_err(|e| StageError::io(format!("cannot read model file `{rel}`"), e))?;
        let spec = crate::dynamics::model_file::parse(&text, rel).map_err(|e| {
            StageError::InvalidParam {
                param: "model".into(),
                message: e.to_string(),
            }
        })?;
        let base = file.parent().unwrap_or(ctx.pipeline_dir).to_path_buf();
        let read =
            crate::paths::confined_reader(base.clone(), vec![ctx.pipeline_dir.to_path_buf(), base]);
        let mut external = BTreeMap::new();
        for f in spec.external_files() {
            let bytes = read(&f).map_err(|e| StageError::io(format!("cannot read {f}"), e))?;
            external.insert(f, bytes);
        }
        return Ok((text, rel.to_string(), external));
    }
    // model.json refers to the files (version 3) or embeds them (1–2);
    // referenced ones are read beside the model file and hash-checked.
    let json = ModelJson::read(ctx.input("model")?, "model")?;
    let name = json.file_name("model.yaml").to_string();
    let external = json.referenced(ctx.pipeline_dir, "model")?;
    Ok((json.yaml, name, external))
}

/// Write the `updated_model` directory `dir` from identify's
/// parameters.csv at `parameters`.
pub fn write(
    ctx: &StageContext,
    model_param: Option<&str>,
    parameters: &Path,
    dir: &Path,
) -> Result<(), StageError> {
    let failed = |m: String| StageError::Failed(format!("updated model: {m}"));
    let rows: Vec<ParameterRow> = read_identified(parameters).map_err(|e| failed(e.to_string()))?;
    let (text, name, external) = model_source(ctx, model_param)?;
    let updates: Vec<ParameterUpdate> = rows
        .iter()
        .map(|r| ParameterUpdate {
            name: r.parameter.clone(),
            initial: r.initial,
            identified: r.value,
            moved: r.identified,
            identifiable: r.identifiable,
            std_error: r.std_error_rel,
            interval: r.ci_low.zip(r.ci_high),
        })
        .collect();
    let moved = rows.iter().filter(|r| r.identified).count();
    let header = [
        format!(
            "Updated model: {name} with the values identified by stage `{}` ({moved} of {} parameters moved).",
            ctx.stage,
            rows.len()
        ),
        "Bounds and everything else as in the input; a comment above each parameter gives its start value, identified value and confidence.".into(),
    ];
    let yaml = updated_model_file(&text, &updates, &header).map_err(failed)?;
    std::fs::create_dir_all(dir).map_err(|e| StageError::io("cannot create updated_model", e))?;
    let put = |rel: &str, content: &[u8]| -> Result<(), StageError> {
        let p = dir.join(rel);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent)
                .map_err(|e| StageError::io(format!("cannot create {}", parent.display()), e))?;
        }
        std::fs::write(&p, content).map_err(|e| StageError::io(format!("cannot write {rel}"), e))
    };
    put("model.yaml", yaml.as_bytes())?;
    for (rel, content) in &external {
        // Only paths inside the directory; others are named in the error.
        if Path::new(rel)
            .components()
            .any(|c| !matches!(c, Component::Normal(_)))
        {
            return Err(failed(format!(
                "the model references `{rel}` outside its directory; copy it beside model.yaml by hand"
            )));
        }
        put(rel, content)?;
    }
    let kinds: BTreeMap<String, String> = crate::dynamics::model_file::parse(&text, &name)
        .map(|spec| {
            spec.parameters
                .iter()
                .map(|p| (p.name.clone(), format!("{:?}", p.kind).to_lowercase()))
                .collect()
        })
        .unwrap_or_default();
    let changes: Vec<ChangeRow> = rows
        .iter()
        .map(|r| ChangeRow {
            parameter: &r.parameter,
            kind: kinds.get(&r.parameter).map_or("", String::as_str),
            initial: r.initial,
            value: r.value,
            change_rel: (r.initial != 0.0).then(|| r.value / r.initial - 1.0),
            identified: r.identified,
            identifiable: r.identifiable.filter(|_| r.identified),
            std_error_rel: r.std_error_rel,
            ci_low: r.ci_low,
            ci_high: r.ci_high,
            lower: r.lower,
            upper: r.upper,
        })
        .collect();
    let csv = crate::artifacts::to_csv(&changes, "changes.csv")?;
    put("changes.csv", csv.as_bytes())
}
