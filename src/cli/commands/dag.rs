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
    /// Print one JSON object on stdout: stages (name, kind) and edges.
    #[arg(long, conflicts_with = "format")]
    pub json: bool,
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    let plan = plan::load(&args.file)?;
    let names: Vec<String> = plan.nodes.iter().map(|n| n.name.clone()).collect();
    let kinds: Vec<&str> = plan.nodes.iter().map(|n| n.kind.kind()).collect();
    if args.json {
        let stages: Vec<serde_json::Value> = plan
            .order
            .iter()
            .map(|&i| serde_json::json!({"name": names[i], "kind": kinds[i]}))
            .collect();
        let mut edges: Vec<[&str; 2]> = Vec::new();
        for &i in &plan.order {
            for &u in &plan.upstream[i] {
                edges.push([names[u].as_str(), names[i].as_str()]);
            }
        }
        crate::cli::output::print_json(
            &serde_json::json!({"pipeline": plan.name, "stages": stages, "edges": edges}),
        )?;
        return Ok(crate::cli::exit::SUCCESS);
    }
    print_text(&render(
        &names,
        &kinds,
        &plan.upstream,
        &plan.order,
        args.format,
    ))?;
    Ok(crate::cli::exit::SUCCESS)
}
