//! `modalflow verify`: whether materialized results still hold what their
//! manifests say, without running anything. Every output file (and every
//! file inside a directory output) is hashed and compared with the
//! manifest; where the cache holds the stage's run record, the manifest
//! itself is checked against it, so an edited manifest is drift too.

use super::results::{drift, read_manifest, Drift};
use super::store::Store;
use serde::Serialize;
use std::fs;
use std::path::{Path, PathBuf};

/// One stage's results directory, checked.
#[derive(Clone, Debug, Serialize)]
pub struct StageCheck {
    pub pipeline: String,
    pub stage: String,
    /// `ok`, `drift` (outputs or manifest differ), `missing` (the
    /// directory or its manifest is gone although the stage ran) or, with
    /// a pipeline file, `stale` (the results are of another run than the
    /// file gives now).
    pub status: &'static str,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub problems: Vec<Drift>,
}

/// What `verify` found.
#[derive(Clone, Debug, Serialize)]
pub struct VerifyReport {
    pub results: PathBuf,
    pub stages: Vec<StageCheck>,
    /// Stages whose status is not `ok`.
    pub drifted: usize,
}

/// Check one stage directory (`dir` = `results/<pipeline>/<stage>`).
pub fn check_stage(store: Option<&Store>, pipeline: &str, stage: &str, dir: &Path) -> StageCheck {
    let mut check = StageCheck {
        pipeline: pipeline.to_string(),
        stage: stage.to_string(),
        status: "ok",
        problems: Vec::new(),
    };
    let Some(manifest) = read_manifest(dir) else {
        check.status = "missing";
        check.problems.push(Drift {
            path: "manifest.json".into(),
            problem: "missing",
        });
        return check;
    };
    check.problems = drift(dir, &manifest);
    let record = store.and_then(|s| s.record(&manifest.key));
    if let Some(rec) = record {
        let same = rec.outputs.len() == manifest.outputs.len()
            && rec.outputs.iter().all(|(name, o)| {
                manifest
                    .outputs
                    .get(name)
                    .is_some_and(|m| m.file == o.file && m.artifact == o.artifact)
            });
        if !same {
            check.problems.push(Drift {
                path: "manifest.json".into(),
                problem: "modified",
            });
        }
    }
    if !check.problems.is_empty() {
        check.status = "drift";
    }
    check
}

/// Check the stage directories of one pipeline's results (`results` =
/// `RESULTS/<pipeline>`). `stages`: the stages that should have results
/// (those of the pipeline file that ran, per the cache); `None`: whatever
/// directories are there.
pub fn check_pipeline(
    store: Option<&Store>,
    pipeline: &str,
    results: &Path,
    stages: Option<&[String]>,
) -> Vec<StageCheck> {
    let names: Vec<String> = match stages {
        Some(s) => s.to_vec(),
        None => {
            let mut names: Vec<String> = fs::read_dir(results)
                .into_iter()
                .flatten()
                .flatten()
                .filter(|e| e.path().is_dir())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                // Stage names have no dots: `.x.staging-…` folders of a
                // run and `trace.d/` are not stages.
                .filter(|n| !n.contains('.'))
                .collect();
            names.sort();
            names
        }
    };
    names
        .iter()
        .map(|stage| check_stage(store, pipeline, stage, &results.join(stage)))
        .collect()
}

/// The report of a list of checks.
pub fn report(results: &Path, stages: Vec<StageCheck>) -> VerifyReport {
    VerifyReport {
        results: results.to_path_buf(),
        drifted: stages.iter().filter(|s| s.status != "ok").count(),
        stages,
    }
}
