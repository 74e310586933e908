//! `modalflow dag`: the stage graph as text, Graphviz dot or Mermaid.

use crate::cli::output::print_text;
use modalflow::pipeline::graph::{render, DagFormat};
use modalflow::pipeline::plan;
use std::path::PathBuf;

/// Print the stage graph (after matrix expansion).
#[derive(clap::Args)]
pub struct Args {
    /// The pipeline file.
    file: PathBuf,
    #[arg(long, value_enum, default_value_t = DagFormat::Text)]
    format: DagFormat,
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    let plan = plan::load(&args.file)?;
    let names: Vec<String> = plan.nodes.iter().map(|n| n.name.clone()).collect();
    let kinds: Vec<&str> = plan.nodes.iter().map(|n| n.kind.kind()).collect();
    print_text(&render(
        &names,
        &kinds,
        &plan.upstream,
        &plan.order,
        args.format,
    ))?;
    Ok(crate::cli::exit::SUCCESS)
}
