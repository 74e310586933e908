//! Running one stage: compute its key from upstream output hashes, reuse a
//! verified cache entry or run the kind in a scratch directory, commit the
//! outputs (objects first, record last), and materialize results.

use super::key::{canonical_params, KeyMaterial};
use super::plan::{Node, Plan};
use super::progress::Progress;
use super::provenance::{self, LastRun, StageProvenance};
use super::results::{self, InputOrigin, Manifest};
use super::store::{self, OutputRecord, RunRecord, Store};
use crate::stages::{InputSource, StageContext, StageError};
use serde_yaml_ng::Value;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// A finished (ran or cached) stage: its key and outputs.
#[derive(Clone, Debug)]
pub struct Done {
    pub key: String,
    pub outputs: BTreeMap<String, OutputRecord>,
}

/// How one stage ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Status {
    Ran,
    Cached,
    Failed,
    Skipped,
    WillRun,
}

/// One line of a run or status report.
#[derive(Clone, Debug, serde::Serialize)]
pub struct StageReport {
    pub name: String,
    pub kind: String,
    pub status: Status,
    pub key: Option<String>,
    pub seconds: f64,
    pub reason: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    pub counters: BTreeMap<String, u64>,
}

/// What finishing a stage yields for the scheduler.
pub struct Outcome {
    pub report: StageReport,
    pub done: Option<Done>,
    pub provenance: Option<StageProvenance>,
    /// Problems worth a warning line that did not fail the stage.
    pub warnings: Vec<String>,
}

/// Shared, read-only context of one run.
pub struct Engine<'a> {
    pub plan: &'a Plan,
    pub store: Store,
    pub last: LastRun,
    /// `results/<pipeline>/`.
    pub results: PathBuf,
    pub forced: Vec<bool>,
}

impl Engine<'_> {
    /// The key material of node `i`, given finished upstream stages.
    pub fn material(
        &self,
        i: usize,
        done: &dyn Fn(usize) -> Option<Done>,
    ) -> Result<KeyMaterial, String> {
        let node = &self.plan.nodes[i];
        let mut inputs = BTreeMap::new();
        for b in &node.inputs {
            let mut hashes = Vec::new();
            for (src, out) in &b.sources {
                let d = done(*src).ok_or_else(|| {
                    format!("upstream `{}` has no result", self.plan.nodes[*src].name)
                })?;
                let rec = d.outputs.get(out).ok_or_else(|| {
                    format!(
                        "upstream `{}` has no output `{out}`",
                        self.plan.nodes[*src].name
                    )
                })?;
                hashes.push(rec.artifact.hash.clone());
            }
            inputs.insert(b.name.clone(), hashes);
        }
        let mut files = BTreeMap::new();
        for f in &node.files {
            let hash = match &f.producer {
                Some((src, out)) => done(*src)
                    .and_then(|d| d.outputs.get(out).map(|o| o.artifact.hash.clone()))
                    .ok_or_else(|| {
                        format!(
                            "`{}` is produced by `{}`, which has no result",
                            f.path, self.plan.nodes[*src].name
                        )
                    })?,
                None => store::hash_path(&self.plan.dir.join(&f.path))
                    .map_err(|e| format!("cannot read `{}` (param `{}`): {e}", f.path, f.param))?,
            };
            files.insert(f.path.clone(), hash);
        }
        Ok(KeyMaterial {
            kind: node.kind.kind().to_string(),
            version: node.kind.version(),
            params: canonical_params(&Value::Mapping(node.params.clone())),
            seed: node.kind.uses_seed().then_some(node.seed),
            inputs,
            files,
        })
    }

    /// Reference text per input (`truth.frf`, `ident[*].result`) for messages.
    pub fn input_refs(&self, node: &Node) -> BTreeMap<String, String> {
        node.inputs
            .iter()
            .map(|b| {
                let refs: Vec<String> = b
                    .sources
                    .iter()
                    .map(|(s, o)| format!("{}.{o}", self.plan.nodes[*s].name))
                    .collect();
                (b.name.clone(), refs.join(", "))
            })
            .collect()
    }

    /// Verified cache entry for `key`, or why there is none usable.
    pub fn cached(&self, key: &str) -> Result<RunRecord, Option<String>> {
        let rec = self.store.record(key).ok_or(None)?;
        for out in rec.outputs.values() {
            self.store.verify(&out.artifact).map_err(Some)?;
        }
        Ok(rec)
    }

    /// Run or reuse node `i`. Never panics on stage failure; a failed stage
    /// leaves no cache entry.
    pub fn execute(
        &self,
        i: usize,
        done: &dyn Fn(usize) -> Option<Done>,
        progress: &Progress,
    ) -> Outcome {
        let node = &self.plan.nodes[i];
        let mut report = StageReport {
            name: node.name.clone(),
            kind: node.kind.kind().to_string(),
            status: Status::Failed,
            key: None,
            seconds: 0.0,
            reason: String::new(),
            error: None,
            counters: BTreeMap::new(),
        };
        let fail = |mut report: StageReport, msg: String, warnings| {
            report.status = Status::Failed;
            report.error = Some(msg);
            Outcome {
                report,
                done: None,
                provenance: None,
                warnings,
            }
        };
        let material = match self.material(i, done) {
            Ok(m) => m,
            Err(e) => return fail(report, e, vec![]),
        };
        let key = material.key();
        report.key = Some(key.clone());
        let previous = self.last.stages.get(&node.name);
        report.reason = if self.forced[i] {
            "forced".into()
        } else {
            provenance::explain(previous, &material, &[], &self.input_refs(node))
        };
        let mut warnings = Vec::new();
        let _lock = match self.store.lock_key(&key) {
            Ok(l) => l,
            Err(e) => return fail(report, e.to_string(), warnings),
        };
        let record = match (self.forced[i], self.cached(&key)) {
            (false, Ok(rec)) => {
                report.status = Status::Cached;
                report.reason = "up to date".into();
                rec
            }
            (_, cached) => {
                if let Err(Some(problem)) = cached {
                    warnings.push(format!(
                        "stage {}: cache entry unusable: {problem}; recomputing",
                        node.name
                    ));
                    report.reason = format!("cache entry corrupt ({problem})");
                }
                match self.compute(node, &key, done, progress) {
                    Ok(rec) => {
                        report.status = Status::Ran;
                        rec
                    }
                    Err(e) => return fail(report, e, warnings),
                }
            }
        };
        report.seconds = record.seconds;
        report.counters = record.counters.clone();
        if let Err(e) = self.place(node, &material, &key, &record, done) {
            return fail(report, e, warnings);
        }
        let outputs = record
            .outputs
            .iter()
            .map(|(k, o)| (k.clone(), o.artifact.hash.clone()))
            .collect();
        Outcome {
            provenance: Some(StageProvenance {
                key: key.clone(),
                material,
                outputs,
            }),
            done: Some(Done {
                key,
                outputs: record.outputs,
            }),
            report,
            warnings,
        }
    }

    /// Run the stage kind and commit its outputs to the cache.
    fn compute(
        &self,
        node: &Node,
        key: &str,
        done: &dyn Fn(usize) -> Option<Done>,
        progress: &Progress,
    ) -> Result<RunRecord, String> {
        let inputs_dir = self.store.temp_path("in");
        let scratch = self.store.temp_path("stage");
        let result = self.compute_in(node, key, done, progress, &inputs_dir, &scratch);
        let _ = std::fs::remove_dir_all(&scratch);
        let _ = std::fs::remove_dir_all(&inputs_dir);
        result
    }

    fn compute_in(
        &self,
        node: &Node,
        key: &str,
        done: &dyn Fn(usize) -> Option<Done>,
        progress: &Progress,
        inputs_dir: &Path,
        scratch: &Path,
    ) -> Result<RunRecord, String> {
        std::fs::create_dir_all(scratch)
            .map_err(|e| format!("cannot create scratch directory: {e}"))?;
        let mut inputs: BTreeMap<String, Vec<PathBuf>> = BTreeMap::new();
        for b in &node.inputs {
            let mut paths = Vec::new();
            for (k, (src, out)) in b.sources.iter().enumerate() {
                let rec = done(*src)
                    .and_then(|d| d.outputs.get(out).cloned())
                    .ok_or("upstream result vanished")?;
                let path = match rec.artifact.kind {
                    store::ArtifactKind::File => self.store.object_path(&rec.artifact.hash),
                    store::ArtifactKind::Dir => {
                        let p = inputs_dir.join(&b.name).join(k.to_string()).join(&rec.file);
                        self.store
                            .checkout(&rec.artifact, &p)
                            .map_err(|e| e.to_string())?;
                        p
                    }
                };
                paths.push(path);
            }
            inputs.insert(b.name.clone(), paths);
        }
        self.restore_workspace_deps(node, done)?;
        let sources: BTreeMap<String, Vec<InputSource>> = node
            .inputs
            .iter()
            .map(|b| {
                let list = b.sources.iter().map(|(s, o)| InputSource {
                    stage: self.plan.nodes[*s].name.clone(),
                    output: o.clone(),
                });
                (b.name.clone(), list.collect())
            })
            .collect();
        let ctx = StageContext {
            stage: &node.name,
            params: &node.params,
            seed: node.seed,
            inputs: &inputs,
            sources: &sources,
            pipeline: &self.plan.name,
            pipeline_dir: &self.plan.dir,
            scratch,
            progress,
        };
        let start = Instant::now();
        let run = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| node.kind.run(&ctx)));
        let produced = match run {
            Ok(Ok(p)) => p,
            Ok(Err(e)) => return Err(stage_error_text(&e)),
            Err(panic) => {
                let what = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                return Err(format!(
                    "internal error in kind `{}` (a bug, please report): {what}",
                    node.kind.kind()
                ));
            }
        };
        let seconds = start.elapsed().as_secs_f64();
        let mut outputs = BTreeMap::new();
        for name in &node.outputs {
            let Some((_, path)) = produced.files.iter().find(|(n, _)| n == name) else {
                return Err(format!(
                    "kind `{}` did not produce its output `{name}`",
                    node.kind.kind()
                ));
            };
            let full = if path.is_absolute() {
                path.clone()
            } else {
                scratch.join(path)
            };
            let file = if node.workspace_outputs.is_empty() {
                path.file_name()
                    .map(|f| f.to_string_lossy().into_owned())
                    .unwrap_or_else(|| name.clone())
            } else {
                name.clone()
            };
            let artifact = self
                .store
                .put(&full)
                .map_err(|e| format!("output `{name}`: {e}"))?;
            outputs.insert(name.clone(), OutputRecord { file, artifact });
        }
        let record = RunRecord {
            key: key.to_string(),
            kind: node.kind.kind().to_string(),
            version: node.kind.version(),
            stage: node.name.clone(),
            outputs,
            seconds,
            counters: produced.counters,
            modalflow_version: env!("CARGO_PKG_VERSION").to_string(),
        };
        self.store
            .write_record(&record)
            .map_err(|e| e.to_string())?;
        Ok(record)
    }

    /// DVC semantics: a dep that another stage writes into the workspace is
    /// put back from the cache when it is missing or differs.
    fn restore_workspace_deps(
        &self,
        node: &Node,
        done: &dyn Fn(usize) -> Option<Done>,
    ) -> Result<(), String> {
        for f in &node.files {
            let Some((src, out)) = &f.producer else {
                continue;
            };
            let rec = done(*src)
                .and_then(|d| d.outputs.get(out).cloned())
                .ok_or("upstream result vanished")?;
            let dest = self.plan.dir.join(&f.path);
            if store::hash_path(&dest).ok().as_deref() != Some(rec.artifact.hash.as_str()) {
                self.store
                    .checkout(&rec.artifact, &dest)
                    .map_err(|e| e.to_string())?;
            }
        }
        Ok(())
    }

    /// Materialize results and, for stages that write into the workspace,
    /// put their outputs in place.
    fn place(
        &self,
        node: &Node,
        material: &KeyMaterial,
        key: &str,
        record: &RunRecord,
        done: &dyn Fn(usize) -> Option<Done>,
    ) -> Result<(), String> {
        for (name, out) in &record.outputs {
            if node.workspace_outputs.is_empty() {
                break;
            }
            let dest = self.plan.dir.join(super::plan::normalize(name));
            if store::hash_path(&dest).ok().as_deref() != Some(out.artifact.hash.as_str()) {
                self.store
                    .checkout(&out.artifact, &dest)
                    .map_err(|e| e.to_string())?;
            }
        }
        let origins = node
            .inputs
            .iter()
            .map(|b| {
                let list = b
                    .sources
                    .iter()
                    .map(|(s, o)| InputOrigin {
                        from: format!("{}.{o}", self.plan.nodes[*s].name),
                        hash: done(*s)
                            .and_then(|d| d.outputs.get(o).map(|r| r.artifact.hash.clone()))
                            .unwrap_or_default(),
                    })
                    .collect();
                (b.name.clone(), list)
            })
            .collect();
        let manifest = Manifest::new(
            &node.name,
            material,
            key,
            origins,
            record.outputs.clone(),
            record.seconds,
            record.counters.clone(),
        );
        results::materialize(&self.store, &self.results.join(&node.name), &manifest)
            .map_err(|e| e.to_string())
    }
}

fn stage_error_text(e: &StageError) -> String {
    let mut s = e.to_string();
    let mut src = std::error::Error::source(e);
    while let Some(inner) = src {
        let t = inner.to_string();
        if !s.contains(&t) {
            s.push_str(": ");
            s.push_str(&t);
        }
        src = inner.source();
    }
    s
}
