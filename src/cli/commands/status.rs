//! `modalflow status`: what is cached and why the rest would run.

use crate::cli::output::{print_json, print_text, Locations};
use modalflow::pipeline::execute::Status;
use modalflow::pipeline::plan;
use modalflow::pipeline::progress::ProgressMode;
use modalflow::pipeline::scheduler::{self, RunReport};
use std::path::PathBuf;

/// Show each stage as cached or will-run, with the reason (which param,
/// input or file changed, kind version bumped, never ran).
#[derive(clap::Args)]
pub struct Args {
    /// The pipeline file.
    file: PathBuf,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    locations: Locations,
    #[command(flatten)]
    overrides: crate::cli::output::Overrides,
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    let locations = args.locations.resolve(Some(&args.file));
    locations.serve_model_facts();
    let plan = plan::load_with(&args.file, &args.overrides.set)?;
    let opts = super::run::options(&locations, Some(1), false, Vec::new(), ProgressMode::Quiet);
    let report = scheduler::status(&plan, &opts)?;
    locations.keep_model_facts();
    if args.json {
        print_json(&report)?;
    } else {
        print_text(&table(&report))?;
    }
    Ok(crate::cli::exit::SUCCESS)
}

/// One line per stage: status, name, reason.
pub fn table(report: &RunReport) -> String {
    let width = report
        .stages
        .iter()
        .map(|s| s.name.len())
        .max()
        .unwrap_or(0);
    let mut out = String::new();
    for s in &report.stages {
        let status = match s.status {
            Status::Cached => "cached",
            _ => "will-run",
        };
        let reason = if s.status == Status::Cached && s.reason == "up to date" {
            ""
        } else {
            s.reason.as_str()
        };
        out.push_str(format!("{status:<9} {:<width$}  {reason}", s.name).trim_end());
        out.push('\n');
    }
    if let Some(name) = &report.results_name {
        out.push_str(&format!(
            "with --set {}: results in {name}/, apart from the file's own\n",
            report.overrides.join(" --set ")
        ));
    }
    for run in &report.set_runs {
        out.push_str(&format!(
            "results of a --set run (not the file's): {}/ (--set {})\n",
            run.results,
            run.overrides.join(" --set ")
        ));
    }
    out
}
