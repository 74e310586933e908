//! The `updated_model` output of `identify`: a directory with the updated
//! model file (`model.yaml`, see [`crate::dynamics::model_writer`]) and
//! `changes.csv` ([`ChangeRow`]: `parameter,kind,initial,value,change_rel,
//! identified,identifiable,std_error_rel,ci_low,ci_high,lower,upper`, the
//! table of the update).
//!
//! Files the model references (super-element matrices) are **not copied**:
//! no parameter changes them, and an FE export is up to ~0.5 GB of text
//! (issue 32: no stage artifact holds matrix text). model.yaml names them
//! as the input model file does (relative to its directory) and its header
//! lists each with size and blake3, where it is and how to run the updated
//! model (beside the input model file, or the input model synthesized with
//! `inputs: {values: <stage>.parameters}`).
//!
//! Built from what identify already wrote (its parameters.csv) and the
//! model it read (the `model` param or the model.json input), so the
//! identification itself is untouched.

use crate::artifacts::model::{ModelJson, ReferencedFile};
use crate::artifacts::parameters::{read_identified, ParameterRow};
use crate::dynamics::model_writer::{updated_model_file, ParameterUpdate};
use crate::stages::params::model_files;
use crate::stages::{StageContext, StageError};
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::Path;

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

/// The input model as identify read it: the model file's text, its name,
/// its path below the pipeline directory and the files it references.
struct Source {
    text: String,
    name: String,
    path: Option<String>,
    files: Vec<ReferencedFile>,
}

/// The model file's text, name, path and referenced files, as identify read them.
fn model_source(ctx: &StageContext, param: Option<&str>) -> Result<Source, StageError> {
    if let Some(rel) = param {
        let file = ctx.pipeline_dir.join(rel);
        let text = std::fs::read_to_string(&file)
            .map_err(|e| StageError::io(format!("cannot read model file `{rel}`"), e))?;
        let files = model_files::referenced_files(ctx.pipeline_dir, rel).map_err(|m| {
            StageError::InvalidParam {
                param: "model".into(),
                message: m,
            }
        })?;
        return Ok(Source {
            text,
            name: rel.to_string(),
            path: Some(rel.to_string()),
            files,
        });
    }
    // model.json refers to the files (version 3) or embedded them (1–2,
    // written by builds before the references: hashed from the text).
    let json = ModelJson::read(ctx.input("model")?, "model")?;
    let mut files = json.files.clone();
    files.extend(
        json.external
            .iter()
            .map(|(p, text)| ReferencedFile::of(p, text.as_bytes())),
    );
    Ok(Source {
        name: json.file_name("model.yaml").to_string(),
        path: json.path.clone(),
        text: json.yaml,
        files,
    })
}

/// Header lines naming the referenced files the updated model uses from
/// where the input model file names them, and how to run it.
fn reference_lines(source: &Source, stage: &str) -> Vec<String> {
    if source.files.is_empty() {
        return Vec::new();
    }
    let input = source.path.as_deref().unwrap_or(&source.name);
    let mut out = vec![format!(
        "Referenced files are the input's, by reference (not copied), relative to the directory of {input}:"
    )];
    out.extend(source.files.iter().map(|f| {
        format!(
            "  {} ({} bytes, blake3 {})",
            f.path,
            f.bytes,
            &f.blake3[..f.blake3.len().min(16)]
        )
    }));
    out.push(format!(
        "To run this model, place it beside {input}, or synthesize {input} with `inputs: {{values: {stage}.parameters}}`."
    ));
    out
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
    let source = model_source(ctx, model_param)?;
    let (text, name) = (&source.text, &source.name);
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
    let mut header = vec![
        format!(
            "Updated model: {name} with the values identified by stage `{}` ({moved} of {} parameters moved).",
            ctx.stage,
            rows.len()
        ),
        "Bounds and everything else as in the input; a comment above each parameter gives its start value, identified value and confidence.".into(),
    ];
    header.extend(reference_lines(&source, ctx.stage));
    let yaml = updated_model_file(text, &updates, &header).map_err(failed)?;
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
    let kinds: BTreeMap<String, String> = crate::dynamics::model_file::parse(text, name)
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
