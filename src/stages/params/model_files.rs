//! Model files named by a stage's `model` param (synthesize, gsa, identify):
//! loading one below the pipeline directory, the files it references (for
//! cache keys) and its eigenproblem against the memory limit. Shared by the
//! kinds that read model files, so none of them imports another.

use super::ParamProblem;
use crate::dynamics::model_file;
use crate::dynamics::Model;
use std::path::Path;

/// Load and validate the model file named by `params.model` below `dir`.
pub fn load_model(dir: &Path, rel: &str) -> Result<(Model, String), String> {
    let path = dir.join(rel);
    let text =
        std::fs::read_to_string(&path).map_err(|e| format!("cannot read model file {rel}: {e}"))?;
    let base = path.parent().unwrap_or(dir).to_path_buf();
    let resolver = crate::paths::confined_reader(base.clone(), vec![dir.to_path_buf(), base]);
    let model = Model::from_yaml(&text, rel, &resolver).map_err(|e| e.to_string())?;
    Ok((model, text))
}

/// Files a model file references, relative to the pipeline directory
/// (`rel` is the model file's path relative to it).
pub fn external_files(spec: &model_file::ModelFile, rel: &str) -> Vec<String> {
    let model_dir = Path::new(rel).parent().unwrap_or(Path::new(""));
    spec.external_files()
        .iter()
        .map(|f| model_dir.join(f).to_string_lossy().into_owned())
        .collect()
}

/// Validate the model file `rel` (relative to the pipeline directory `dir`)
/// and list the files it references, for cache keys of other kinds that
/// read model files.
pub fn model_file_dependencies(dir: &Path, rel: &str) -> Result<Vec<String>, String> {
    Ok(checked_model_file(dir, rel)?.1)
}

/// [`model_file_dependencies`] and the model itself, for checks that need
/// it at validation (e.g. a budget against its parameter count).
pub fn checked_model_file(dir: &Path, rel: &str) -> Result<(Model, Vec<String>), String> {
    let (model, text) = load_model(dir, rel)?;
    if let Some(p) = model_memory(&model) {
        return Err(p.message);
    }
    let spec = model_file::parse(&text, rel).map_err(|e| e.to_string())?;
    Ok((model, external_files(&spec, rel)))
}

/// The eigenproblem of a model against the memory limit
/// ([`Model::memory_estimate`]: dense n × n matrices or a sparse factor).
pub fn model_memory(model: &Model) -> Option<ParamProblem> {
    let (bytes, what) = model.memory_estimate();
    super::limits::memory_problem(&["model"], &what, bytes)
}
