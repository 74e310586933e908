//! `modalflow verify`: report results that drifted from their manifests.

use crate::cli::exit;
use crate::cli::output::{print_json, print_text, Locations};
use modalflow::pipeline::results::{out_of_step, Drift};
use modalflow::pipeline::store::Store;
use modalflow::pipeline::verify::{self, VerifyReport};
use modalflow::pipeline::{plan, provenance};
use std::path::PathBuf;

/// Check materialized results against their manifests without running
/// anything: every output file, and every file inside directory outputs,
/// is hashed and compared with the manifest (and the manifest with the
/// cache's run record). With FILE, results of another run than the file
/// gives (e.g. of an older `--set` run) are `stale`. Exit 0 when everything
/// matches, 1 when something drifted (`modalflow run FILE` restores it
/// from the cache).
#[derive(clap::Args)]
pub struct Args {
    /// The pipeline file; without it, every pipeline under the results
    /// root.
    file: Option<PathBuf>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    locations: Locations,
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    let locations = args.locations.resolve(args.file.as_deref());
    locations.serve_model_facts();
    // Verification only reads; a cache that is not there is not created.
    let store = if locations.cache.join("runs").is_dir() {
        Some(Store::open(&locations.cache)?)
    } else {
        None
    };
    let root = &locations.results;
    let checks = match &args.file {
        Some(file) => {
            let plan = plan::load(file)?;
            let ran: Option<Vec<String>> = store.as_ref().map(|s| {
                let last = provenance::load(s, &plan.name);
                plan.nodes
                    .iter()
                    .map(|n| n.name.clone())
                    .filter(|n| last.stages.contains_key(n))
                    .collect()
            });
            let dir = root.join(&plan.name);
            let mut checks =
                verify::check_pipeline(store.as_ref(), &plan.name, &dir, ran.as_deref());
            if store.is_some() {
                mark_stale(&plan, &locations, &dir, &mut checks);
            }
            checks
        }
        None => {
            let mut pipelines: Vec<String> = std::fs::read_dir(root)
                .into_iter()
                .flatten()
                .flatten()
                .filter(|e| e.path().is_dir())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect();
            pipelines.sort();
            pipelines
                .iter()
                .flat_map(|p| verify::check_pipeline(store.as_ref(), p, &root.join(p), None))
                .collect()
        }
    };
    let report = verify::report(root, checks);
    if args.json {
        print_json(&report)?;
    } else {
        print_text(&text(&report))?;
    }
    Ok(if report.drifted == 0 {
        exit::SUCCESS
    } else {
        exit::STAGE_FAILED
    })
}

/// Results whose manifest names another key than the file gives the stage
/// now are `stale`: they are not what the file says (an older version's
/// `--set` run, an edit of the file not yet run).
fn mark_stale(
    plan: &plan::Plan,
    locations: &crate::cli::output::Resolved,
    dir: &std::path::Path,
    checks: &mut [verify::StageCheck],
) {
    let opts = super::run::options(
        locations,
        Some(1),
        false,
        Vec::new(),
        modalflow::pipeline::progress::ProgressMode::Quiet,
    );
    let Ok(status) = modalflow::pipeline::scheduler::status(plan, &opts) else {
        return;
    };
    for check in checks.iter_mut().filter(|c| c.status == "ok") {
        let key = status
            .stages
            .iter()
            .find(|s| s.name == check.stage)
            .and_then(|s| s.key.as_deref());
        let stale = key.and_then(|k| out_of_step(&dir.join(&check.stage), k));
        if stale.is_some() {
            check.status = "stale";
            check.problems.push(Drift {
                path: "manifest.json".into(),
                problem: "stale",
            });
        }
    }
}

fn text(report: &VerifyReport) -> String {
    let mut out = String::new();
    for s in &report.stages {
        let problems: Vec<String> = s
            .problems
            .iter()
            .map(|d| format!("{} {}", d.path, d.problem))
            .collect();
        let line = format!(
            "{:<8} {}/{}  {}",
            s.status,
            s.pipeline,
            s.stage,
            problems.join(", ")
        );
        out.push_str(line.trim_end());
        out.push('\n');
    }
    out.push_str(&format!(
        "{} stages checked, {} drifted{}\n",
        report.stages.len(),
        report.drifted,
        if report.drifted > 0 {
            "; `modalflow run FILE` restores them from the cache"
        } else {
            ""
        }
    ));
    out
}
