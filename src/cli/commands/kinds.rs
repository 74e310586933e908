//! `modalflow kinds`: the stage kinds with their params, inputs and
//! outputs — all read from the kinds' typed declarations.

use crate::cli::output::{print_json, print_text};
use modalflow::stages::{registry, Field, Stage};

/// List stage kinds with their params (type, default, range), inputs,
/// outputs and version.
#[derive(clap::Args)]
pub struct Args {
    /// Only this kind.
    kind: Option<String>,
    /// Print one JSON object on stdout.
    #[arg(long)]
    pub json: bool,
}

/// One kind in `--json` output.
#[derive(serde::Serialize)]
struct KindDoc {
    kind: &'static str,
    version: u32,
    summary: &'static str,
    params: Vec<Field>,
    /// `None`: any input names (the `command` kind).
    inputs: Option<Vec<InputDoc>>,
    outputs: Vec<OutputDoc>,
}

#[derive(serde::Serialize)]
struct InputDoc {
    name: &'static str,
    required: bool,
    list: bool,
    artifact: &'static str,
    doc: &'static str,
}

#[derive(serde::Serialize)]
struct OutputDoc {
    name: &'static str,
    artifact: &'static str,
}

fn doc(k: &dyn Stage) -> KindDoc {
    KindDoc {
        kind: k.kind(),
        version: k.version(),
        summary: k.summary(),
        params: k.params(),
        inputs: k.inputs().map(|ins| {
            ins.iter()
                .map(|i| InputDoc {
                    name: i.name,
                    required: i.required,
                    list: i.list,
                    artifact: i.artifact.as_str(),
                    doc: i.doc,
                })
                .collect()
        }),
        outputs: k
            .all_outputs()
            .iter()
            .map(|(name, a)| OutputDoc {
                name,
                artifact: a.as_str(),
            })
            .collect(),
    }
}

/// The human listing of one kind.
fn text(k: &KindDoc) -> String {
    let mut out = format!("{} (version {}): {}\n", k.kind, k.version, k.summary);
    for p in &k.params {
        let mut tags = vec![p.ty.clone()];
        if p.required {
            tags.push("required".into());
        }
        if let Some(d) = &p.default {
            tags.push(format!("default {d}"));
        }
        if let Some(r) = &p.range {
            tags.push(format!("range {r}"));
        }
        out.push_str(&format!(
            "    {} ({}) — {}\n",
            p.name,
            tags.join("; "),
            p.doc
        ));
    }
    match &k.inputs {
        Some(ins) => {
            for i in ins {
                let req = if i.required { ", required" } else { "" };
                let list = if i.list { ", list" } else { "" };
                out.push_str(&format!(
                    "    input {} ({}{req}{list}): {}\n",
                    i.name, i.artifact, i.doc
                ));
            }
        }
        None => out.push_str("    inputs: any names\n"),
    }
    if k.outputs.is_empty() {
        out.push_str("    outputs: the paths in `outs`\n");
    }
    for o in &k.outputs {
        out.push_str(&format!("    output {} ({})\n", o.name, o.artifact));
    }
    out
}

pub fn exec(args: Args) -> anyhow::Result<u8> {
    let kinds: Vec<KindDoc> = registry()
        .iter()
        .filter(|k| args.kind.as_deref().is_none_or(|want| k.kind() == want))
        .map(|k| doc(*k))
        .collect();
    if kinds.is_empty() {
        let known: Vec<&str> = registry().iter().map(|k| k.kind()).collect();
        return Err(crate::cli::exit::Invalid(format!(
            "no stage kind `{}`; kinds: {}",
            args.kind.unwrap_or_default(),
            known.join(", ")
        ))
        .into());
    }
    if args.json {
        print_json(&serde_json::json!({ "kinds": kinds }))?;
    } else {
        print_text(&kinds.iter().map(text).collect::<Vec<_>>().join(""))?;
    }
    Ok(crate::cli::exit::SUCCESS)
}
