//! `modalflow verify`: report results that drifted from their manifests.

use crate::cli::exit;
use crate::cli::output::{print_json, print_text, Locations};
use modalflow::pipeline::store::Store;
use modalflow::pipeline::verify::{self, VerifyReport};
use modalflow::pipeline::{plan, provenance};
use std::path::PathBuf;

/// Check materialized results against their manifests without running
/// anything: every output file, and every file inside directory outputs,
/// is hashed and compared with the manifest (and the manifest with the
/// cache's run record). Exit 0 when everything matches, 1 when something
/// drifted (`modalflow run FILE` restores it from the cache).
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
    // Verification only reads; a cache that is not there is not created.
    let store = if args.locations.cache.join("runs").is_dir() {
        Some(Store::open(&args.locations.cache)?)
    } else {
        None
    };
    let root = &args.locations.results;
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
            verify::check_pipeline(store.as_ref(), &plan.name, &dir, ran.as_deref())
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
