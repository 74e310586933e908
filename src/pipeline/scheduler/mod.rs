//! The scheduler: runs a [`Plan`]'s stages in dependency order, independent
//! stages concurrently (`--jobs`), and the dry variant behind `status` and
//! `run --dry-run` that says what would run and why.

mod dispatch;

use super::execute::{Done, Engine, StageReport, Status};
use super::executor::{Executor, ExecutorKind};
use super::plan::Plan;
use super::progress::{ProgressMode, Reporter};
use super::provenance::{self, StageProvenance};
use super::store::{Store, StoreError};
use dispatch::Tally;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// Options of `modalflow run`.
#[derive(Clone, Debug)]
pub struct RunOptions {
    pub jobs: usize,
    pub keep_going: bool,
    /// Stage names (expanded, or a matrix stage's base name for all of its
    /// expansions) to recompute even when cached.
    pub force: Vec<String>,
    /// Run only these stages (expanded names, or a matrix stage's base name
    /// for all of its expansions) and what they need; empty: all.
    pub targets: Vec<String>,
    pub cache: PathBuf,
    /// Results root; the pipeline's results go to `<results>/<name>/`
    /// unless `results_exact` is set.
    pub results: PathBuf,
    pub progress: ProgressMode,
    /// Longest silence of a running stage with `ProgressMode::Lines`.
    pub heartbeat: std::time::Duration,
    /// Executor chosen on the command line; `None`: the pipeline's block.
    pub executor: Option<ExecutorKind>,
}

/// Result of a run or a status query.
#[derive(Debug, serde::Serialize)]
pub struct RunReport {
    pub pipeline: String,
    pub stages: Vec<StageReport>,
    /// The run's trace (`results/<name>/trace.csv`), after a run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub trace: Option<PathBuf>,
    /// The `--set` overrides of this run or query.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub overrides: Vec<String>,
    /// The results folder's name when it is not the pipeline's (a `--set`
    /// run: `<name>--set-<hash>`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub results_name: Option<String>,
    /// For the file without overrides (`status`): the results folders of
    /// earlier `--set` runs, apart from the file's own.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub set_runs: Vec<super::results::SetRun>,
}

impl RunReport {
    pub fn failed(&self) -> bool {
        self.stages.iter().any(|s| s.status == Status::Failed)
    }
}

/// Errors that stop a run as a whole (stage failures are reported per stage).
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    #[error(transparent)]
    Store(#[from] StoreError),
    #[error("--force {name}: no such stage\n  = help: stages: {known}")]
    UnknownForce { name: String, known: String },
    #[error("no stage `{name}` to run\n  = help: stages: {known}")]
    UnknownTarget { name: String, known: String },
    /// The executor could not be set up (its message in the text, not as
    /// a source, so a printed chain does not repeat it).
    #[error("executor: {0}")]
    Executor(crate::pipeline::executor::ExecutorError),
    /// Another pipeline file of this cache has the same `name:`.
    #[error(
        "pipeline name `{name}` belongs to {} in this cache, not to {}: their results \
         (results/{name}/) and last-run records would overwrite each other and `gc` would drop \
         the other's objects\n  = help: give this file another `name:`, or run it with its own \
         --cache and --results",
        owner.display(), file.display()
    )]
    NameTaken {
        name: String,
        owner: PathBuf,
        file: PathBuf,
    },
    /// A stage's own writes failed for lack of storage.
    #[error("stage {stage}: {message}")]
    Storage { stage: String, message: String },
    /// Cache, results folder, project and outputs overlap.
    #[error(transparent)]
    Roots(#[from] super::roots::RootsOverlap),
    /// A stage has to be computed but the cache is read-only.
    #[error(
        "stage {stage} is not in the read-only cache {} ({reason}); computing it needs a \
         writable cache\n  = help: run with --cache on writable storage (e.g. a copy of this cache)",
        cache.display()
    )]
    ReadOnly {
        stage: String,
        cache: PathBuf,
        reason: String,
    },
}

impl RunError {
    /// Whether the command line asked for something that does not exist
    /// (exit code 2), rather than the cache failing.
    pub fn is_usage(&self) -> bool {
        matches!(
            self,
            RunError::UnknownForce { .. }
                | RunError::UnknownTarget { .. }
                | RunError::NameTaken { .. }
                | RunError::Roots(_)
        )
    }
}

fn engine<'a>(
    plan: &'a Plan,
    opts: &RunOptions,
    executor: Executor,
) -> Result<Engine<'a>, RunError> {
    super::roots::check(plan, &opts.cache, &opts.results)?;
    let store = Store::open(&opts.cache)?;
    let mut last = provenance::load(&store, &plan.results_name);
    if last.stages.is_empty() && plan.results_name != plan.name {
        // A first run with these overrides: reasons compare with the file's.
        last = provenance::load(&store, &plan.name);
    }
    if let Some(owner) = last.owned_by_another(&plan.path()) {
        return Err(RunError::NameTaken {
            name: plan.results_name.clone(),
            owner: owner.to_path_buf(),
            file: plan.path(),
        });
    }
    let mut forced = vec![false; plan.nodes.len()];
    for f in &opts.force {
        let mut hit = false;
        for (i, n) in plan.nodes.iter().enumerate() {
            if &n.name == f || &n.base == f {
                forced[i] = true;
                hit = true;
            }
        }
        if !hit {
            let known: Vec<&str> = plan.nodes.iter().map(|n| n.name.as_str()).collect();
            return Err(RunError::UnknownForce {
                name: f.clone(),
                known: known.join(", "),
            });
        }
    }
    Ok(Engine {
        plan,
        store,
        last,
        results: opts.results.join(&plan.results_name),
        forced,
        executor,
    })
}

/// The stages `targets` name and everything upstream of them (DVC's
/// `repro target`, Snakemake's targets); every stage when `targets` is empty.
pub fn wanted(plan: &Plan, targets: &[String]) -> Result<Vec<bool>, RunError> {
    if targets.is_empty() {
        return Ok(vec![true; plan.nodes.len()]);
    }
    let mut wanted = vec![false; plan.nodes.len()];
    let mut todo = Vec::new();
    for t in targets {
        let hits: Vec<usize> = (0..plan.nodes.len())
            .filter(|&i| selects(t, &plan.nodes[i].name, &plan.nodes[i].base))
            .collect();
        if hits.is_empty() {
            let known: Vec<&str> = plan.nodes.iter().map(|n| n.name.as_str()).collect();
            return Err(RunError::UnknownTarget {
                name: t.clone(),
                known: known.join(", "),
            });
        }
        todo.extend(hits);
    }
    while let Some(i) = todo.pop() {
        if !std::mem::replace(&mut wanted[i], true) {
            todo.extend(plan.upstream[i].iter().copied());
        }
    }
    Ok(wanted)
}

/// Whether target `t` names the stage `name` (expansion of `base`): the
/// name itself, the base name (every expansion), or the base with some of
/// the matrix values (`ema[measurement=noisy]`: every `s`).
fn selects(t: &str, name: &str, base: &str) -> bool {
    if t == name || t == base {
        return true;
    }
    let inside = |s: &str, b: &str| -> Option<Vec<String>> {
        let rest = s.strip_prefix(b)?.strip_prefix('[')?.strip_suffix(']')?;
        Some(rest.split(',').map(|p| p.trim().to_string()).collect())
    };
    match (inside(t, base), inside(name, base)) {
        (Some(wanted), Some(has)) => wanted.iter().all(|w| has.contains(w)),
        _ => false,
    }
}

/// Run the pipeline.
pub fn run(plan: &Plan, opts: &RunOptions) -> Result<RunReport, RunError> {
    let kind = opts.executor.unwrap_or(plan.executor.kind);
    let executor = Executor::new(kind, &plan.executor).map_err(RunError::Executor)?;
    let wanted = wanted(plan, &opts.targets)?;
    let engine = engine(plan, opts, executor)?;
    let _cache_lock = engine.store.lock_cache(false)?;
    if !engine.store.read_only() {
        super::leftovers::clean(&engine.store.root().join("tmp"), &engine.results, &plan.dir);
    }
    let started = super::executor::inflight::now();
    let mut reporter_lines: Vec<String> = Vec::new();
    let to_run = wanted.iter().filter(|w| **w).count();
    let mut reporter = Reporter::new(to_run, opts.progress, opts.heartbeat);
    let Tally {
        mut reports,
        updates,
        stop_reason,
        fatal,
    } = dispatch::dispatch(plan, &engine, &wanted, &reporter, opts);
    reporter.finish();
    for &i in &plan.order {
        if reports[i].is_none() && wanted[i] {
            let why = stop_reason.clone().unwrap_or_else(|| "not started".into());
            reports[i] = Some(skipped(plan, i, why));
        }
    }
    if !engine.store.read_only() {
        let saved = record_run(&engine, opts, updates, fatal.is_none(), &mut reporter_lines);
        // The first failure is the one to report; a full disk fails this too.
        if fatal.is_none() {
            saved?;
        }
    }
    let mut report = in_plan_order(plan, reports);
    // After a storage failure the error says it once; no trace is tried.
    if fatal.is_none() {
        report.trace = write_trace(&engine, &report, started, &mut reporter_lines);
    }
    for l in reporter_lines {
        eprintln!("{l}");
    }
    match fatal {
        Some(e) => Err(e),
        None => Ok(report),
    }
}

/// Record a finished run in a writable cache: the last-run provenance, the
/// `--set` overrides of the results folder and, after a whole clean run, the
/// removal of results of stages the file no longer has. Returns the
/// provenance update's result, for `run` to report unless an earlier
/// failure comes first; a failure to record the overrides is a warning.
fn record_run(
    engine: &Engine,
    opts: &RunOptions,
    updates: Vec<(String, StageProvenance)>,
    clean: bool,
    warnings: &mut Vec<String>,
) -> Result<(), StoreError> {
    let plan = engine.plan;
    let keep: Vec<&str> = plan.nodes.iter().map(|n| n.name.as_str()).collect();
    let saved = provenance::update(
        &engine.store,
        &plan.results_name,
        &plan.path(),
        updates,
        &keep,
    );
    if !plan.overrides.is_empty() {
        let run = super::results::SetRun {
            results: plan.results_name.clone(),
            overrides: plan.overrides.clone(),
        };
        if let Err(e) = super::results::write_set_run(&engine.results, &run) {
            warnings.push(format!(
                "warning: cannot record the overrides in {}: {e}",
                engine.results.display()
            ));
        }
    }
    if opts.targets.is_empty() && clean {
        super::results::remove_stale(&engine.results, &keep);
    }
    saved
}

/// Write the run's trace; a failure to write it is a warning, not an error.
fn write_trace(
    engine: &Engine,
    report: &RunReport,
    started: u64,
    warnings: &mut Vec<String>,
) -> Option<PathBuf> {
    let jobs = engine.executor.jobs();
    let mut ids: Vec<String> = jobs.iter().map(|j| j.id.clone()).collect();
    ids.sort();
    ids.dedup();
    let acct = super::trace::accounting(&ids);
    let local = |kind: &str, name: &str| engine.executor.is_local(kind, name);
    let rows = super::trace::rows(&report.stages, &jobs, &acct, &local);
    match super::trace::write(&engine.results, &rows, started) {
        Ok(p) => Some(p),
        Err(e) => {
            warnings.push(format!(
                "warning: cannot write the trace in {}: {e}",
                engine.results.display()
            ));
            None
        }
    }
}

fn in_plan_order(plan: &Plan, mut reports: Vec<Option<StageReport>>) -> RunReport {
    RunReport {
        trace: None,
        overrides: plan.overrides.clone(),
        results_name: (plan.results_name != plan.name).then(|| plan.results_name.clone()),
        set_runs: Vec::new(),
        pipeline: plan.name.clone(),
        stages: plan
            .order
            .iter()
            .filter_map(|&i| reports[i].take())
            .collect(),
    }
}

fn skipped(plan: &Plan, i: usize, reason: String) -> StageReport {
    StageReport {
        name: plan.nodes[i].name.clone(),
        kind: plan.nodes[i].kind.kind().to_string(),
        status: Status::Skipped,
        key: None,
        seconds: 0.0,
        reason,
        error: None,
        counters: BTreeMap::new(),
        warnings: Vec::new(),
    }
}

fn line(r: &StageReport) -> String {
    match r.status {
        Status::Ran => format!("  ran     {} ({:.2} s) — {}", r.name, r.seconds, r.reason),
        Status::Cached => format!("  cached  {}", r.name),
        Status::Failed => format!("  FAILED  {}: {}", r.name, r.error.as_deref().unwrap_or("")),
        Status::Skipped => format!("  skipped {} — {}", r.name, r.reason),
        Status::WillRun => format!("  will run {} — {}", r.name, r.reason),
    }
}

/// What `run` would do, without running anything: each stage is `cached`
/// (verified entry for its key) or `will-run` with the reason.
pub fn status(plan: &Plan, opts: &RunOptions) -> Result<RunReport, RunError> {
    let wanted = wanted(plan, &opts.targets)?;
    let engine = engine(plan, opts, Executor::Local)?;
    let mut done: Vec<Option<Done>> = vec![None; plan.nodes.len()];
    let mut reports: Vec<Option<StageReport>> = vec![None; plan.nodes.len()];
    let mut in_flight = Vec::new();
    for &i in plan.order.iter().filter(|&&i| wanted[i]) {
        let node = &plan.nodes[i];
        let mut report = skipped(plan, i, String::new());
        report.status = Status::WillRun;
        let running: Vec<String> = plan.upstream[i]
            .iter()
            .filter(|&&u| done[u].is_none())
            .map(|&u| plan.nodes[u].name.clone())
            .collect();
        let previous = engine.last.stages.get(&node.name);
        let refs = engine.input_refs(node);
        if !running.is_empty() {
            // Inputs are unknown until upstream runs; still name own changes.
            let material =
                engine.material(i, &|u| done[u].clone().or_else(|| placeholder(plan, u)));
            report.reason = match material {
                Ok(mut m) => {
                    m.files.retain(|_, h| h != PENDING);
                    provenance::explain(previous, &m, &running, &refs)
                }
                Err(e) => e,
            };
        } else {
            match engine.material(i, &|u| done[u].clone()) {
                Err(e) => report.reason = e,
                Ok(m) => {
                    let key = m.key();
                    report.key = Some(key.clone());
                    match (engine.forced[i], engine.cached(node, &key)) {
                        (false, Ok(rec)) => {
                            report.status = Status::Cached;
                            report.reason = engine.results_note(node, &key, &rec);
                            report.seconds = rec.seconds;
                            report.counters = rec.counters.clone();
                            done[i] = Some(Done {
                                key: key.clone(),
                                outputs: rec.outputs,
                                warnings: rec.warnings,
                            });
                        }
                        (true, _) => report.reason = "forced".into(),
                        (false, Err(Some(problem))) => {
                            report.reason = format!("cache entry corrupt ({problem})")
                        }
                        (false, Err(None)) => {
                            report.reason = provenance::explain(previous, &m, &[], &refs)
                        }
                    }
                    if report.status == Status::WillRun {
                        let subs = super::executor::inflight::of_key(&engine.store, &key);
                        if !subs.is_empty() {
                            in_flight.push((i, subs));
                        }
                    }
                }
            }
        }
        reports[i] = Some(report);
    }
    annotate_in_flight(&mut reports, in_flight);
    let mut report = in_plan_order(plan, reports);
    if plan.overrides.is_empty() {
        report.set_runs = super::results::set_runs(&opts.results, &plan.name);
    }
    Ok(report)
}

/// Stages whose jobs an earlier (killed, disconnected or detached) run
/// submitted: the reason names the jobs and their states, from one
/// scheduler query for all of them.
fn annotate_in_flight(
    reports: &mut [Option<StageReport>],
    in_flight: Vec<(usize, Vec<super::executor::inflight::Submission>)>,
) {
    if in_flight.is_empty() {
        return;
    }
    let mut ids: Vec<String> = in_flight
        .iter()
        .flat_map(|(_, subs)| subs.iter().map(|s| s.id.clone()))
        .collect();
    ids.sort();
    ids.dedup();
    let states = super::executor::queue::Queries::default()
        .query(&ids)
        .unwrap_or_default();
    for (i, subs) in in_flight {
        let Some(report) = reports[i].as_mut() else {
            continue;
        };
        let parts: Vec<String> = subs
            .iter()
            .map(|s| {
                let mine: Vec<_> = states
                    .iter()
                    .filter(|t| t.job() == s.id)
                    .filter(|t| match &s.tasks {
                        Some(tasks) => tasks.iter().any(|&k| t.covers(k)),
                        None => true,
                    })
                    .cloned()
                    .collect();
                let what = if mine.is_empty() {
                    format!("slurm job {}: not in the queue", s.id)
                } else {
                    super::executor::queue::summary(&s.id, &mine)
                };
                format!(
                    "{what} (attempt {}, submitted {} by {})",
                    s.attempt,
                    super::trace::utc(s.submitted),
                    s.by
                )
            })
            .collect();
        report.reason = format!("in flight: {}", parts.join("; "));
    }
}

const PENDING: &str = "pending";

/// Stand-in outputs for an upstream stage that will run, so a downstream
/// stage's own param and file changes can still be explained.
fn placeholder(plan: &Plan, u: usize) -> Option<Done> {
    let outputs = plan.nodes[u]
        .output_names()
        .iter()
        .map(|o| {
            let rec = super::store::OutputRecord {
                file: o.clone(),
                artifact: super::store::Artifact {
                    kind: super::store::ArtifactKind::File,
                    hash: PENDING.into(),
                    bytes: 0,
                },
            };
            (o.clone(), rec)
        })
        .collect();
    Some(Done {
        key: PENDING.into(),
        outputs,
        warnings: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::selects;

    #[test]
    fn a_target_selects_by_name_base_or_some_matrix_values() {
        let (name, base) = ("ema[measurement=noisy,s=12]", "ema");
        assert!(selects(name, name, base));
        assert!(selects("ema", name, base));
        assert!(selects("ema[measurement=noisy]", name, base));
        assert!(selects("ema[s=12]", name, base));
        assert!(selects("ema[s=12, measurement=noisy]", name, base));
        assert!(!selects("ema[measurement=hammer]", name, base));
        assert!(!selects("ema[s=1]", name, base));
        assert!(!selects("em[s=12]", name, base));
        assert!(!selects("ema[measurement=noisy", name, base));
    }
}
