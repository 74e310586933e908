//! `modalflow show`: a stage's manifest (provenance of its results).

use crate::cli::output::{print_json, print_text, Resolved};
use modalflow::pipeline::results::{read_manifest, Manifest};
use modalflow::pipeline::{plan, provenance, store::Store};
use std::path::PathBuf;

/// Show where a stage's results came from: key, inputs, params, output
/// hashes, seconds, counters.
#[derive(clap::Args)]
pub struct Args {
    /// The pipeline file.
    file: PathBuf,
    /// Stage name (expanded, e.g. `ident[method=pso,seed=2]`).
    stage: String,
    /// Print the manifest JSON on stdout.
    #[arg(long)]
    pub json: bool,
    #[command(flatten)]
    locations: crate::cli::output::Locations,
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    let locations = args.locations.resolve(Some(&args.file));
    locations.serve_model_facts();
    let plan = plan::load(&args.file)?;
    let Some(node) = plan.nodes.iter().find(|n| n.name == args.stage) else {
        let names: Vec<&str> = plan.nodes.iter().map(|n| n.name.as_str()).collect();
        return Err(crate::cli::exit::Invalid(format!(
            "no stage `{}` in {}; stages: {}",
            args.stage,
            plan.file.display(),
            names.join(", ")
        ))
        .into());
    };
    let dir = locations.results.join(&plan.name).join(&node.name);
    let manifest = match read_manifest(&dir) {
        Some(m) => m,
        None => from_cache(&locations, &plan.name, &node.name).ok_or_else(|| {
            anyhow::anyhow!(
                "stage `{}` has no results yet; run `modalflow run {}`",
                node.name,
                args.file.display()
            )
        })?,
    };
    if args.json {
        print_json(&manifest)?;
        return Ok(crate::cli::exit::SUCCESS);
    }
    let mut out = format!(
        "stage    {}\nkind     {} (version {})\nkey      {}\nseconds  {:.3}\n",
        manifest.stage, manifest.kind, manifest.kind_version, manifest.key, manifest.seconds
    );
    for (name, origins) in &manifest.inputs {
        for o in origins {
            out.push_str(&format!(
                "input    {name} <- {} ({})\n",
                o.from,
                &o.hash[..o.hash.len().min(12)]
            ));
        }
    }
    for (file, hash) in &manifest.files {
        out.push_str(&format!(
            "file     {file} ({})\n",
            &hash[..hash.len().min(12)]
        ));
    }
    out.push_str(&format!("params   {}\n", manifest.params));
    for (name, o) in &manifest.outputs {
        out.push_str(&format!(
            "output   {name} -> {} ({} bytes, {})\n",
            o.file,
            o.artifact.bytes,
            &o.artifact.hash[..12.min(o.artifact.hash.len())]
        ));
    }
    for (c, v) in &manifest.counters {
        out.push_str(&format!("counter  {c} = {v}\n"));
    }
    for w in &manifest.warnings {
        out.push_str(&format!("warning  {w}\n"));
    }
    out.push_str(&trace_lines(
        &locations.results.join(&plan.name),
        &node.name,
    ));
    print_text(&out)?;
    Ok(crate::cli::exit::SUCCESS)
}

fn from_cache(loc: &Resolved, pipeline: &str, stage: &str) -> Option<Manifest> {
    let store = Store::open(&loc.cache).ok()?;
    let last = provenance::load(&store, pipeline);
    let p = last.stages.get(stage)?;
    let rec = store.record(&p.key)?;
    Some(Manifest::new(
        stage,
        &p.material,
        &p.key,
        Default::default(),
        &rec,
    ))
}

/// The stage's rows of the last run's trace, and where the trace is.
fn trace_lines(results: &std::path::Path, stage: &str) -> String {
    let Some(rows) = modalflow::pipeline::trace::read(results) else {
        return String::new();
    };
    let mut out = String::new();
    for r in rows.iter().filter(|r| r.stage == stage) {
        let mut line = format!("trace    {}", r.status);
        if !r.job_id.is_empty() {
            line.push_str(&format!(
                ": slurm job {} attempt {} {}",
                r.job_id,
                r.attempt.unwrap_or(1),
                r.state
            ));
        } else if !r.executor.is_empty() {
            line.push_str(&format!(" ({})", r.executor));
        }
        for (label, v) in [
            ("node", &r.node),
            ("elapsed", &r.elapsed),
            ("cpu", &r.cpu_time),
            ("MaxRSS", &r.max_rss),
        ] {
            if !v.is_empty() {
                line.push_str(&format!(", {label} {v}"));
            }
        }
        out.push_str(&line);
        out.push('\n');
    }
    out.push_str(&format!(
        "trace    {} (last run)\n",
        results.join("trace.csv").display()
    ));
    out
}
