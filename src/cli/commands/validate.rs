//! `modalflow validate`: check a pipeline file without running anything.

use crate::cli::output::{print_json, print_text, Locations};
use modalflow::pipeline::plan;
use std::path::PathBuf;

/// Check a pipeline file: schema, kinds, params, references, files, cycles.
#[derive(clap::Args)]
pub struct Args {
    /// The pipeline file.
    file: PathBuf,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
    /// Accepted like on every command that takes them, so one command line
    /// works for `validate`, `status` and `run`; validation reads only the
    /// facts of model files that built before from the cache, and refuses
    /// locations that overlap the project or each other.
    #[command(flatten)]
    locations: Locations,
    #[command(flatten)]
    overrides: crate::cli::output::Overrides,
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    let locations = args.locations.resolve(Some(&args.file));
    locations.serve_model_facts();
    let plan = plan::load_with(&args.file, &args.overrides.set)?;
    modalflow::pipeline::roots::check(&plan, &locations.cache, &locations.results)
        .map_err(modalflow::pipeline::scheduler::RunError::from)?;
    locations.keep_model_facts();
    let edges: usize = plan.upstream.iter().map(Vec::len).sum();
    if args.json {
        print_json(&serde_json::json!({
            "pipeline": plan.name,
            "valid": true,
            "stages": plan.nodes.len(),
            "edges": edges,
        }))?;
    } else {
        print_text(&format!(
            "{}: valid ({} stages, {} edges)\n",
            plan.name,
            plan.nodes.len(),
            edges
        ))?;
    }
    Ok(crate::cli::exit::SUCCESS)
}
