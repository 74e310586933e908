//! The `updated_model` output of `identify`: a directory with the updated
//! model file (`model.yaml`, see [`crate::dynamics::model_writer`]), the
//! files it references (super-element matrices, same relative paths) and
//! `changes.csv` (`parameter,kind,initial,identified,change,identifiable,
//! std_error,ci_low,ci_high,lower,upper`: the table of the update).
//!
//! Built from what identify already wrote (its parameters.csv) and the
//! model it read (the `model` param or the model.json input), so the
//! identification itself is untouched.

use super::identify::tables::{read_rows, ParameterRow};
use super::{StageContext, StageError};
use crate::dynamics::model_writer::{updated_model_file, ParameterUpdate};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Component, Path};

/// The model file's text, name and referenced files, as identify read them.
fn model_source(
    ctx: &StageContext,
    param: Option<&str>,
) -> Result<(String, String, BTreeMap<String, String>), StageError> {
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
            external.insert(f, String::from_utf8_lossy(&bytes).into_owned());
        }
        return Ok((text, rel.to_string(), external));
    }
    let path = ctx.input("model")?;
    let bytes = std::fs::read(path).map_err(|e| StageError::io("cannot read input `model`", e))?;
    let json: serde_json::Value =
        serde_json::from_slice(&bytes).map_err(|e| StageError::InvalidInput {
            input: "model".into(),
            message: format!("not a model.json: {e}"),
        })?;
    let text = json["yaml"].as_str().unwrap_or_default().to_string();
    let name = json["file"].as_str().unwrap_or("model.yaml").to_string();
    let external = json["external"]
        .as_object()
        .map(|m| {
            m.iter()
                .filter_map(|(k, v)| Some((k.clone(), v.as_str()?.to_string())))
                .collect()
        })
        .unwrap_or_default();
    Ok((text, name, external))
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
    let rows: Vec<ParameterRow> = read_rows(parameters, "parameters.csv").map_err(failed)?;
    let (text, name, external) = model_source(ctx, model_param)?;
    let updates: Vec<ParameterUpdate> = rows
        .iter()
        .map(|r| ParameterUpdate {
            name: r.parameter.clone(),
            initial: r.initial,
            identified: r.value,
            moved: r.identified,
            identifiable: r.identifiable,
            std_error: r.std_error,
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
    let put = |rel: &str, content: &str| -> Result<(), StageError> {
        let p = dir.join(rel);
        if let Some(parent) = p.parent() {
            std::fs::create_dir_all(parent)
                .map_err(|e| StageError::io(format!("cannot create {}", parent.display()), e))?;
        }
        std::fs::write(&p, content).map_err(|e| StageError::io(format!("cannot write {rel}"), e))
    };
    put("model.yaml", &yaml)?;
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
    let mut csv = String::from(
        "parameter,kind,initial,identified,change,identifiable,std_error,ci_low,ci_high,lower,upper\n",
    );
    let opt = |v: Option<f64>| v.map_or(String::new(), |x| format!("{x:e}"));
    for r in &rows {
        let _ = writeln!(
            csv,
            "{},{},{:e},{:e},{},{},{},{},{},{:e},{:e}",
            r.parameter,
            kinds.get(&r.parameter).map_or("", String::as_str),
            r.initial,
            r.value,
            if r.initial != 0.0 {
                format!("{:e}", r.value / r.initial - 1.0)
            } else {
                String::new()
            },
            match (r.identified, r.identifiable) {
                (false, _) => "not identified".to_string(),
                (true, Some(b)) => b.to_string(),
                (true, None) => String::new(),
            },
            opt(r.std_error),
            opt(r.ci_low),
            opt(r.ci_high),
            r.lower,
            r.upper
        );
    }
    put("changes.csv", &csv)
}
