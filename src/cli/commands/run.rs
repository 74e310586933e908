//! `modalflow run`: run a pipeline, reusing every cached stage.

use crate::cli::exit;
use crate::cli::output::{print_json, print_text, Locations, Resolved};
use modalflow::pipeline::execute::Status;
use modalflow::pipeline::executor::ExecutorKind;
use modalflow::pipeline::plan;
use modalflow::pipeline::progress::ProgressMode;
use modalflow::pipeline::scheduler::{self, RunOptions, RunReport};
use std::path::PathBuf;

/// Run a pipeline: stages whose key is cached are reused, the rest run in
/// dependency order, independent ones in parallel.
#[derive(clap::Args)]
pub struct Args {
    /// The pipeline file.
    file: PathBuf,
    /// Run only these stages and what they need (a matrix stage by its base
    /// name for all expansions, or one expansion, e.g. `ema[measurement=noisy]`).
    stages: Vec<String>,
    /// Stages run at once, at least 1 (default: number of cores).
    #[arg(long, short)]
    jobs: Option<std::num::NonZeroUsize>,
    /// After a failure, still run the stages that do not depend on it.
    #[arg(long)]
    keep_going: bool,
    /// Recompute this stage even if cached (a matrix stage's base name forces all expansions).
    #[arg(long, value_name = "STAGE")]
    force: Vec<String>,
    /// Say what would run and why, without running anything.
    #[arg(long)]
    dry_run: bool,
    /// Print one JSON object on stdout instead of a summary.
    #[arg(long)]
    pub json: bool,
    /// Go on in the background (new process group, output in
    /// `results/<name>/run.log`) and return at once; `modalflow status`
    /// shows what is in flight.
    #[arg(long, conflicts_with = "dry_run")]
    detach: bool,
    /// Progress display on stderr.
    #[arg(long, value_enum, default_value_t = Progress::Auto)]
    progress: Progress,
    /// Where stages run (default: the pipeline's `executor:` block, else local).
    /// With slurm, `--jobs` defaults to 32 stages in the queue at once.
    #[arg(long, value_enum)]
    executor: Option<Executor>,
    #[command(flatten)]
    locations: Locations,
    #[command(flatten)]
    overrides: crate::cli::output::Overrides,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum Executor {
    /// In this process.
    Local,
    /// As Slurm batch jobs on a cache shared with the compute nodes.
    Slurm,
}

/// Stages in the queue at once on a cluster unless `--jobs` says otherwise.
const SLURM_JOBS: usize = 32;

#[derive(Clone, Copy, clap::ValueEnum)]
enum Progress {
    Auto,
    Bars,
    Lines,
    None,
}

pub fn options(
    locations: &Resolved,
    jobs: Option<usize>,
    keep_going: bool,
    force: Vec<String>,
    progress: ProgressMode,
) -> RunOptions {
    RunOptions {
        targets: Vec::new(),
        jobs: jobs.unwrap_or_else(|| std::thread::available_parallelism().map_or(2, |n| n.get())),
        keep_going,
        force,
        cache: locations.cache.clone(),
        results: locations.results.clone(),
        progress,
        heartbeat: heartbeat(),
        executor: None,
    }
}

/// The heartbeat interval of `--progress lines`: 10 s, or
/// `MODALFLOW_HEARTBEAT` seconds (tests).
fn heartbeat() -> std::time::Duration {
    std::env::var("MODALFLOW_HEARTBEAT")
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .filter(|s| *s > 0.0 && s.is_finite())
        .map_or(
            modalflow::pipeline::progress::HEARTBEAT,
            std::time::Duration::from_secs_f64,
        )
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    let locations = args.locations.resolve(Some(&args.file));
    locations.serve_model_facts();
    let plan = plan::load_with(&args.file, &args.overrides.set)?;
    if args.detach {
        return detach(&args, &locations, &plan.results_name);
    }
    let progress = match args.progress {
        Progress::Auto => ProgressMode::Auto,
        Progress::Bars => ProgressMode::Bars,
        Progress::Lines => ProgressMode::Lines,
        Progress::None => ProgressMode::Quiet,
    };
    let executor = match args.executor {
        Some(Executor::Local) => ExecutorKind::Local,
        Some(Executor::Slurm) => ExecutorKind::Slurm,
        None => plan.executor.kind,
    };
    let jobs = match (args.jobs, executor) {
        (None, ExecutorKind::Slurm) => Some(SLURM_JOBS),
        (jobs, _) => jobs.map(std::num::NonZeroUsize::get),
    };
    let mut opts = options(&locations, jobs, args.keep_going, args.force, progress);
    opts.executor = Some(executor);
    opts.targets = args.stages;
    let report = if args.dry_run {
        scheduler::status(&plan, &opts)?
    } else {
        scheduler::run(&plan, &opts)?
    };
    locations.keep_model_facts();
    if args.json {
        print_json(&report)?;
    } else {
        print_text(&summary(&report, args.dry_run))?;
    }
    Ok(if report.failed() {
        exit::STAGE_FAILED
    } else {
        exit::SUCCESS
    })
}

/// Start this same command without `--detach` in its own process group
/// (no terminal hang-up reaches it), its output in `results/<name>/run.log`.
fn detach(args: &Args, locations: &Resolved, pipeline: &str) -> anyhow::Result<u8> {
    use std::os::unix::process::CommandExt;
    let dir = locations.results.join(pipeline);
    std::fs::create_dir_all(&dir)
        .map_err(|e| anyhow::anyhow!("cannot create directory {}: {e}", dir.display()))?;
    let log = dir.join("run.log");
    let out = std::fs::File::create(&log)
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", log.display()))?;
    let err = out.try_clone()?;
    let exe = std::env::current_exe()?;
    let rest: Vec<std::ffi::OsString> = std::env::args_os()
        .skip(1)
        .filter(|a| a != "--detach")
        .collect();
    let child = std::process::Command::new(exe)
        .args(rest)
        .stdin(std::process::Stdio::null())
        .stdout(out)
        .stderr(err)
        .process_group(0)
        .spawn()
        .map_err(|e| anyhow::anyhow!("cannot start the background run: {e}"))?;
    let pid = child.id();
    if args.json {
        print_json(&serde_json::json!({"pipeline": pipeline, "detached": pid, "log": log}))?;
    } else {
        print_text(&format!(
            "{pipeline}: running in the background as pid {pid}; output in {}\n  \
             `modalflow status {}` shows what is cached and what is in flight\n",
            log.display(),
            args.file.display()
        ))?;
    }
    Ok(exit::SUCCESS)
}

/// The human summary printed after a run.
pub fn summary(report: &RunReport, dry: bool) -> String {
    let count = |s: Status| report.stages.iter().filter(|r| r.status == s).count();
    let mut out = String::new();
    if let Some(name) = report.results_name.as_ref().filter(|_| !dry) {
        out.push_str(&format!(
            "with --set {}: results in {name}/ (the file's own results are untouched)\n",
            report.overrides.join(" --set ")
        ));
    }
    for r in &report.stages {
        if r.status == Status::Failed {
            out.push_str(&format!(
                "stage {} failed: {}\n",
                r.name,
                r.error.as_deref().unwrap_or("")
            ));
        }
    }
    if dry {
        out.push_str(&crate::cli::commands::status::table(report));
    }
    out.push_str(&format!(
        "{}: {} ran, {} cached, {} failed, {} skipped{}\n",
        report.pipeline,
        count(Status::Ran),
        count(Status::Cached),
        count(Status::Failed),
        count(Status::Skipped),
        if dry {
            format!(", {} would run", count(Status::WillRun))
        } else {
            String::new()
        }
    ));
    if !dry {
        out.push_str(&warning_count(report));
    }
    out
}

/// Where the run's warnings are: `5 stage warning(s): ema 3, measured 2
/// (`warning:` lines on stderr unless --progress none; …)` — every stage's own
/// warnings, ran or cached alike (its run record's) — and for each report
/// stage how many it lists and where: `report: 27 warning(s) of the stages
/// upstream of it, collapsed and counted, in results/…/index.html#warnings`.
fn warning_count(report: &RunReport) -> String {
    let per_stage: Vec<(&str, usize)> = report
        .stages
        .iter()
        .filter(|r| !r.warnings.is_empty())
        .map(|r| (r.name.as_str(), r.warnings.len()))
        .collect();
    let total: usize = per_stage.iter().map(|(_, n)| n).sum();
    let mut out = String::new();
    if total > 0 {
        out.push_str(&format!(
            "{total} stage warning(s): {} (`warning:` lines on stderr unless --progress none; \
             each stage's `warnings` in --json)\n",
            per_stage
                .iter()
                .map(|(s, n)| format!("{s} {n}"))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let results = report.trace.as_ref().and_then(|t| t.parent());
    for r in &report.stages {
        if let Some(&n) = r.counters.get("warnings").filter(|n| **n > 0) {
            let place = results.map_or_else(
                || "its Warnings section".to_string(),
                |dir| {
                    let page = dir.join(&r.name).join("report").join("index.html");
                    format!("{}#warnings", page.display())
                },
            );
            out.push_str(&format!(
                "{}: {n} warning(s) of the stages upstream of it, collapsed and counted, in {place}\n",
                r.name
            ));
        }
    }
    out
}
