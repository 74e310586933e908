//! `modalflow kinds`: the stage kinds and their params.

use crate::cli::output::{print_json, print_text};
use modalflow::stages::registry;

/// List stage kinds with their params, inputs and version.
#[derive(clap::Args)]
pub struct Args {
    /// Print one JSON object on stdout.
    #[arg(long)]
    json: bool,
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    if args.json {
        let kinds: Vec<_> = registry()
            .iter()
            .map(|k| {
                serde_json::json!({
                    "kind": k.kind(),
                    "version": k.version(),
                    "summary": k.summary(),
                    "params": k.params().iter().map(|p| serde_json::json!({
                        "name": p.name, "type": p.ty.describe(), "required": p.required, "doc": p.doc,
                    })).collect::<Vec<_>>(),
                    "inputs": k.inputs().map(|ins| ins.iter().map(|i| i.name).collect::<Vec<_>>()),
                })
            })
            .collect();
        print_json(&serde_json::json!({ "kinds": kinds }))?;
        return Ok(crate::cli::exit::SUCCESS);
    }
    let mut out = String::new();
    for k in registry() {
        out.push_str(&format!(
            "{} (version {}): {}\n",
            k.kind(),
            k.version(),
            k.summary()
        ));
        for p in k.params() {
            let req = if p.required { " (required)" } else { "" };
            out.push_str(&format!(
                "    {}{req}: {} — {}\n",
                p.name,
                p.ty.describe(),
                p.doc
            ));
        }
        match k.inputs() {
            Some(ins) => {
                for i in ins {
                    out.push_str(&format!("    input {}: {}\n", i.name, i.doc));
                }
            }
            None => out.push_str("    inputs: any names\n"),
        }
    }
    print_text(&out)?;
    Ok(crate::cli::exit::SUCCESS)
}
