//! Running one stage: compute its key from upstream output hashes, reuse a
//! verified cache entry or have the [`Executor`] run the kind (which commits
//! the outputs, objects first, record last), and materialize results.

use super::executor::exec::JobError;
use super::executor::job::{Job, JobInput, Restore, Typed, FORMAT};
use super::executor::Executor;
use super::key::{canonical_params, KeyMaterial};
use super::plan::{Node, Plan};
use super::provenance::{self, LastRun, StageProvenance};
use super::results::{self, InputOrigin, Manifest};
use super::scheduler::RunError;
use super::store::{self, OutputRecord, RunRecord, Store, StoreError};
use crate::stages::{Progress, UpstreamWarnings};
use serde_yaml_ng::Value;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// A finished (ran or cached) stage: its key and outputs.
#[derive(Clone, Debug)]
pub struct Done {
    pub key: String,
    pub outputs: BTreeMap<String, OutputRecord>,
    /// The stage's warnings (its run record's).
    pub warnings: Vec<String>,
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
    /// The stage's own warnings (from its run record), also printed as
    /// `warning:` lines.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<String>,
}

/// What finishing a stage yields for the scheduler.
pub struct Outcome {
    pub report: StageReport,
    pub done: Option<Done>,
    pub provenance: Option<StageProvenance>,
    /// Problems worth a warning line that did not fail the stage.
    pub warnings: Vec<String>,
    /// A cache or file-system failure: the run stops and exits with 3.
    pub fatal: Option<RunError>,
}

/// Shared, read-only context of one run.
pub struct Engine<'a> {
    pub plan: &'a Plan,
    pub store: Store,
    pub last: LastRun,
    /// `results/<pipeline>/`.
    pub results: PathBuf,
    pub forced: Vec<bool>,
    /// Where stages that have to be computed run.
    pub executor: Executor,
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
        let upstream_warnings = if node.kind.reads_upstream_warnings() {
            self.upstream_warnings(i, done)
        } else {
            Vec::new()
        };
        Ok(KeyMaterial {
            kind: node.kind.kind().to_string(),
            version: node.kind.version(),
            params: canonical_params(&Value::Mapping(node.params.clone())),
            seed: node.kind.uses_seed().then_some(node.seed),
            inputs,
            files,
            upstream_warnings,
        })
    }

    /// The warnings of every stage node `i` depends on (directly or not)
    /// that has any, in plan order.
    fn upstream_warnings(
        &self,
        i: usize,
        done: &dyn Fn(usize) -> Option<Done>,
    ) -> Vec<UpstreamWarnings> {
        self.plan
            .ancestors(i)
            .into_iter()
            .filter_map(|u| {
                let warnings = done(u)?.warnings;
                (!warnings.is_empty()).then(|| UpstreamWarnings {
                    stage: self.plan.nodes[u].name.clone(),
                    warnings,
                })
            })
            .collect()
    }

    /// `up to date`, or, when the stage's results folder holds another
    /// run's results (an older version's `--set` run, a copy) or one of its
    /// declared outputs in the workspace holds another run's (a `--set`
    /// run's), says so: `status` never calls results that contradict the
    /// file up to date.
    pub fn results_note(&self, node: &Node, key: &str, record: &RunRecord) -> String {
        let dir = self.results.join(&node.name);
        let rerun = format!(
            "`modalflow run {}` puts this one's back",
            self.plan.file.display()
        );
        if let Some(other) = results::out_of_step(&dir, key) {
            return format!(
                "up to date in the cache, but {} holds another run's results (key {}); {rerun}",
                dir.display(),
                &other[..other.len().min(12)],
            );
        }
        if !node.workspace_outputs.is_empty() {
            for (name, out) in &record.outputs {
                let path = self.plan.dir.join(name);
                let seen = store::hash_path(&path).ok();
                if path.exists() && seen.as_deref() != Some(out.artifact.hash.as_str()) {
                    return format!(
                        "up to date in the cache, but `{name}` in the workspace holds another \
                         run's output; {rerun}"
                    );
                }
            }
        }
        "up to date".into()
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

    /// Verified cache entry for `key`, or why there is none usable
    /// (`None`: no entry; `Some`: an entry that is corrupt).
    pub fn cached(&self, node: &Node, key: &str) -> Result<RunRecord, Option<String>> {
        let rec = self.store.read_record(key).map_err(Some)?.ok_or(None)?;
        check_outputs(node, &rec).map_err(Some)?;
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
        progress: &dyn Progress,
    ) -> Outcome {
        let node = &self.plan.nodes[i];
        let mut attempt = Attempt {
            report: StageReport {
                name: node.name.clone(),
                kind: node.kind.kind().to_string(),
                status: Status::Failed,
                key: None,
                seconds: 0.0,
                reason: String::new(),
                error: None,
                counters: BTreeMap::new(),
                warnings: Vec::new(),
            },
            warnings: Vec::new(),
        };
        let material = match self.material(i, done) {
            Ok(m) => m,
            Err(e) => return attempt.fail(e),
        };
        let key = material.key();
        attempt.report.key = Some(key.clone());
        let previous = self.last.stages.get(&node.name);
        attempt.report.reason = if self.forced[i] {
            "forced".into()
        } else {
            provenance::explain(previous, &material, &[], &self.input_refs(node))
        };
        let _lock = match self.store.lock_key(&key) {
            Ok(l) => l,
            Err(e) => return attempt.fatal(e.into()),
        };
        let record = match self.obtain_record(i, &key, &material, done, progress, &mut attempt) {
            Ok(rec) => rec,
            Err(failure) => return attempt.end(failure),
        };
        attempt.report.seconds = record.seconds;
        attempt.report.counters = record.counters.clone();
        attempt.report.warnings = record.warnings.clone();
        attempt.warnings.extend(
            record
                .warnings
                .iter()
                .map(|w| format!("stage {}: {w}", node.name)),
        );
        if let Err(e) = self.place(node, &material, &key, &record, done) {
            return attempt.fatal(e.into());
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
                warnings: record.warnings,
            }),
            report: attempt.report,
            warnings: attempt.warnings,
            fatal: None,
        }
    }

    /// The run record of node `i` under `key`: its verified cache entry, or
    /// (forced, no entry, a corrupt one) the record the executor commits
    /// after computing the stage. Sets the report's status, and its reason
    /// and a warning for a corrupt entry; a read-only cache that would have
    /// to compute fails the run.
    fn obtain_record(
        &self,
        i: usize,
        key: &str,
        material: &KeyMaterial,
        done: &dyn Fn(usize) -> Option<Done>,
        progress: &dyn Progress,
        attempt: &mut Attempt,
    ) -> Result<RunRecord, Failure> {
        let node = &self.plan.nodes[i];
        let report = &mut attempt.report;
        match (self.forced[i], self.cached(node, key)) {
            (false, Ok(rec)) => {
                report.status = Status::Cached;
                report.reason = "up to date".into();
                Ok(rec)
            }
            (_, cached) => {
                if let Err(Some(problem)) = cached {
                    attempt.warnings.push(format!(
                        "stage {}: cache entry unusable: {problem}; recomputing",
                        node.name
                    ));
                    report.reason = format!("cache entry corrupt ({problem})");
                }
                if self.store.read_only() {
                    return Err(Failure::Fatal(RunError::ReadOnly {
                        stage: node.name.clone(),
                        cache: self.store.root().to_path_buf(),
                        reason: report.reason.clone(),
                    }));
                }
                match self.compute(node, key, material, done, progress) {
                    Ok(rec) => {
                        report.status = Status::Ran;
                        Ok(rec)
                    }
                    Err(JobError::Stage(e)) => Err(Failure::Stage(e)),
                    Err(JobError::Store(e)) => Err(Failure::Fatal(e.into())),
                    Err(JobError::Storage(message)) => Err(Failure::Fatal(RunError::Storage {
                        stage: node.name.clone(),
                        message,
                    })),
                }
            }
        }
    }

    /// Have the executor run the stage kind and commit its outputs.
    fn compute(
        &self,
        node: &Node,
        key: &str,
        material: &KeyMaterial,
        done: &dyn Fn(usize) -> Option<Done>,
        progress: &dyn Progress,
    ) -> Result<RunRecord, JobError> {
        let job = self.job(node, key, material, done)?;
        self.executor.compute(&self.store, job, progress)
    }

    /// The job description of `node` with key `key`, given finished
    /// upstream stages; it carries the parsed params for a local run.
    pub fn job(
        &self,
        node: &Node,
        key: &str,
        material: &KeyMaterial,
        done: &dyn Fn(usize) -> Option<Done>,
    ) -> Result<Job, String> {
        let plan = self.plan;
        let output = |src: usize, out: &str| {
            done(src)
                .and_then(|d| d.outputs.get(out).cloned())
                .ok_or_else(|| format!("upstream `{}` has no output `{out}`", plan.nodes[src].name))
        };
        let mut inputs = BTreeMap::new();
        for b in &node.inputs {
            let mut list = Vec::new();
            for (src, out) in &b.sources {
                let rec = output(*src, out)?;
                list.push(JobInput {
                    stage: plan.nodes[*src].name.clone(),
                    output: out.clone(),
                    matrix: plan.nodes[*src].matrix.clone(),
                    file: rec.file,
                    artifact: rec.artifact,
                });
            }
            inputs.insert(b.name.clone(), list);
        }
        let mut restore = Vec::new();
        for f in &node.files {
            if let Some((src, out)) = &f.producer {
                restore.push(Restore {
                    path: f.path.clone(),
                    artifact: output(*src, out)?.artifact,
                });
            }
        }
        Ok(Job {
            format: FORMAT,
            key: key.to_string(),
            stage: node.name.clone(),
            material: material.clone(),
            params: Job::params_text(&node.params)?,
            seed: node.seed,
            pipeline: plan.name.clone(),
            pipeline_dir: plan.dir.clone(),
            inputs,
            restore,
            outputs: node.output_names(),
            workspace_outputs: !node.workspace_outputs.is_empty(),
            shards: 1,
            partials: Vec::new(),
            partial_seconds: 0.0,
            typed: Some(Typed {
                kind: node.kind,
                params: node.parsed.clone(),
            }),
        })
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
    ) -> Result<(), StoreError> {
        if !node.workspace_outputs.is_empty() {
            for (name, out) in &record.outputs {
                let dest = workspace_path(&self.plan.dir, name)?;
                if store::hash_path(&dest).ok().as_deref() != Some(out.artifact.hash.as_str()) {
                    self.store.checkout(&out.artifact, &dest)?;
                }
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
        let manifest = Manifest::new(&node.name, material, key, origins, record);
        results::materialize(&self.store, &self.results.join(&node.name), &manifest)
    }
}

/// A stage's report and warning lines while it is run or reused, until
/// they become its [`Outcome`].
struct Attempt {
    report: StageReport,
    warnings: Vec<String>,
}

/// Why a stage ended without a record.
enum Failure {
    /// The stage itself failed; the run goes on with independent stages.
    Stage(String),
    /// The cache or the file system failed: the run stops.
    Fatal(RunError),
}

impl Attempt {
    /// The outcome of a stage that failed with `msg`: no result, no
    /// provenance, the run goes on.
    fn fail(self, msg: String) -> Outcome {
        let Attempt {
            mut report,
            warnings,
        } = self;
        report.status = Status::Failed;
        report.error = Some(msg);
        Outcome {
            report,
            done: None,
            provenance: None,
            warnings,
            fatal: None,
        }
    }

    /// The outcome of a stage the cache or file system failed: the stage
    /// fails with the error's text and the run stops with `e`.
    fn fatal(self, e: RunError) -> Outcome {
        let message = e.to_string();
        Outcome {
            fatal: Some(e),
            ..self.fail(message)
        }
    }

    /// The outcome of a stage that ended with `failure`.
    fn end(self, failure: Failure) -> Outcome {
        match failure {
            Failure::Stage(msg) => self.fail(msg),
            Failure::Fatal(e) => self.fatal(e),
        }
    }
}

/// A record names exactly the outputs the stage declares, and a stage that
/// writes into the workspace stores each output under its declared path:
/// what a record (a shared cache's, possibly forged) says is compared with
/// what the pipeline file says, never trusted for where to write.
fn check_outputs(node: &Node, rec: &RunRecord) -> Result<(), String> {
    let declared = node.output_names();
    let same_names =
        declared.len() == rec.outputs.len() && declared.iter().all(|n| rec.outputs.contains_key(n));
    if !same_names {
        return Err(format!(
            "run record lists outputs {:?}, the stage declares {declared:?}",
            rec.outputs.keys().collect::<Vec<_>>()
        ));
    }
    if !node.workspace_outputs.is_empty() {
        if let Some((name, _)) = rec.outputs.iter().find(|(n, o)| *n != &o.file) {
            return Err(format!(
                "run record stores workspace output `{name}` under another name"
            ));
        }
    }
    Ok(())
}

/// Where a workspace output goes: its declared path below the pipeline
/// directory, never through a symbolic link ([`crate::paths`]).
pub fn workspace_path(dir: &std::path::Path, name: &str) -> Result<PathBuf, StoreError> {
    let invalid = |message: String| StoreError {
        op: "write workspace output",
        path: dir.join(name),
        cause: std::io::Error::new(std::io::ErrorKind::InvalidInput, message),
    };
    let rel = crate::paths::relative(name).map_err(|p| invalid(p.to_string()))?;
    crate::paths::no_symlink_below(dir, &rel).map_err(|e| invalid(e.to_string()))?;
    Ok(dir.join(rel))
}
