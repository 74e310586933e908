//! Input references (`stage.output`, `stage[*].output`,
//! `stage[k=v].output`) bound to upstream nodes and outputs.

use super::{Binding, Ctx, Node};
use crate::pipeline::diagnostic::closest;
use crate::pipeline::diagnostic::Location;
use crate::pipeline::matrix;
use crate::pipeline::spec::{InputRef, InputValue, PipelineSpec, Selector, StageSpec};
use crate::stages::Artifact;
use serde_yaml_ng::Value;
use std::collections::HashMap;

/// Bind every input reference to upstream nodes and outputs.
pub(super) fn resolve_inputs(cx: &mut Ctx, spec: &PipelineSpec, nodes: &mut [Node]) {
    let mut by_base: HashMap<&str, Vec<usize>> = HashMap::new();
    for (i, n) in nodes.iter().enumerate() {
        by_base.entry(n.base.as_str()).or_default().push(i);
    }
    let mut bindings: Vec<Vec<Binding>> = Vec::with_capacity(nodes.len());
    for node in nodes.iter() {
        let st = &spec.stages[&node.base];
        let mut out = Vec::new();
        for (input, value) in &st.inputs {
            if let Some(binding) = bind_input(cx, node, input, value, &by_base, nodes) {
                out.push(binding);
            }
        }
        check_stage_inputs(cx, node, st);
        bindings.push(out);
    }
    for (node, b) in nodes.iter_mut().zip(bindings) {
        node.inputs = b;
    }
}

/// The binding of input `input` of `node` to the upstream outputs its
/// references (`value`) name, reporting each reference that names none or
/// the wrong artifact, and a list bound to an input that takes one artifact.
/// `None` for an input the kind does not take.
fn bind_input(
    cx: &mut Ctx,
    node: &Node,
    input: &String,
    value: &InputValue,
    by_base: &HashMap<&str, Vec<usize>>,
    nodes: &[Node],
) -> Option<Binding> {
    let declared = node.kind.inputs();
    let loc_key = cx.spans.key(&["stages", &node.base, "inputs", input]);
    let spec_in = declared.map(|d| d.iter().find(|s| s.name == input));
    if let Some(None) = spec_in {
        let allowed: Vec<&str> = declared.unwrap_or(&[]).iter().map(|s| s.name).collect();
        cx.at(
            loc_key,
            format!(
                "unknown input `{input}` for stage `{}` (kind `{}`)",
                node.base,
                node.kind.kind()
            ),
            Some(format!(
                "`{}` takes inputs: {}",
                node.kind.kind(),
                allowed.join(", ")
            )),
        );
        return None;
    }
    let mut sources = Vec::new();
    for (ri, raw) in value.refs().into_iter().enumerate() {
        let text = match matrix::substitute_str(raw, &node.matrix, &[]) {
            Ok(Value::String(s)) => s,
            Ok(other) => matrix::scalar_text(&other).unwrap_or_default(),
            Err(e) => {
                cx.at(
                    loc_key,
                    format!(
                        "`${{matrix.{}}}` in input `{input}` names no matrix key",
                        e.key
                    ),
                    None,
                );
                continue;
            }
        };
        let loc = match value {
            InputValue::One(_) => cx.spans.value(&["stages", &node.base, "inputs", input]),
            InputValue::Many(_) => {
                cx.spans
                    .value(&["stages", &node.base, "inputs", input, &ri.to_string()])
            }
        };
        // A stage with problems of its own was reported already.
        let target = InputRef::parse(&text).map(|r| r.stage);
        if target.as_ref().is_some_and(|t| cx.invalid.contains(t)) {
            continue;
        }
        match resolve_ref(&text, by_base, nodes) {
            Ok(found) => {
                if let Some(want) = spec_in.flatten().map(|s| s.artifact) {
                    check_artifact(cx, loc, node, input, want, &found, nodes);
                }
                sources.extend(found)
            }
            Err((msg, help)) => cx.at(
                loc,
                format!("input `{input}` of stage `{}`: {msg}", node.name),
                Some(help),
            ),
        }
    }
    let list_ok = spec_in.flatten().is_none_or(|s| s.list);
    if sources.len() > 1 && !list_ok {
        let loc = cx.spans.value(&["stages", &node.base, "inputs", input]);
        cx.at(
            loc,
            format!(
                "input `{input}` of stage `{}` takes one artifact but the reference matches {}",
                node.name,
                sources.len()
            ),
            Some("select one expansion, e.g. `stage[key=value].output`".into()),
        );
    }
    Some(Binding {
        name: input.clone(),
        sources,
    })
}

/// Report what the stage's kind says about the set of inputs bound (its own
/// checks, for valid params) and every required input left unbound.
fn check_stage_inputs(cx: &mut Ctx, node: &Node, st: &StageSpec) {
    let declared = node.kind.inputs();
    let bound: Vec<&str> = st.inputs.keys().map(String::as_str).collect();
    let own = if node.parsed.is_valid() {
        node.kind.check_inputs(&node.parsed, &bound)
    } else {
        Vec::new()
    };
    for p in own {
        let loc = cx
            .spans
            .key(&["stages", &node.base, "inputs"])
            .or_else(|| cx.spans.key(&["stages", &node.base]));
        cx.at(loc, format!("stage `{}`: {}", node.base, p.message), p.help);
    }
    for s in declared.unwrap_or(&[]).iter().filter(|s| s.required) {
        if !st.inputs.contains_key(s.name) {
            let loc = cx.spans.key(&["stages", &node.base]);
            cx.at(
                loc,
                format!(
                    "stage `{}` (kind `{}`) needs input `{}`",
                    node.base,
                    node.kind.kind(),
                    s.name
                ),
                Some(format!("`{}`: {}", s.name, s.doc)),
            );
        }
    }
}

type RefError = (String, String);

fn resolve_ref(
    text: &str,
    by_base: &HashMap<&str, Vec<usize>>,
    nodes: &[Node],
) -> Result<Vec<(usize, String)>, RefError> {
    let Some(r) = InputRef::parse(text) else {
        return Err((
            format!("`{text}` is not a reference"),
            "write `stage.output`, `stage[*].output` or `stage[key=value].output`".into(),
        ));
    };
    let Some(candidates) = by_base.get(r.stage.as_str()) else {
        let mut names: Vec<&str> = by_base.keys().copied().collect();
        names.sort();
        let mut help = format!("stages: {}", names.join(", "));
        if let Some(c) = closest(&r.stage, names.iter().copied()) {
            help = format!("did you mean `{c}`? {help}");
        }
        return Err((format!("no stage named `{}`", r.stage), help));
    };
    let chosen: Vec<usize> = match &r.selector {
        Selector::All => candidates.clone(),
        Selector::None if candidates.len() == 1 && nodes[candidates[0]].matrix.is_empty() => {
            candidates.clone()
        }
        Selector::None => {
            return Err((
                format!("`{}` is a matrix of {} stages", r.stage, candidates.len()),
                format!(
                    "use `{}[*].{}` for all of them, or one of: {}",
                    r.stage,
                    r.output,
                    names_of(candidates, nodes)
                ),
            ))
        }
        Selector::Exact(pairs) => {
            let hit: Vec<usize> = candidates
                .iter()
                .copied()
                .filter(|&i| {
                    let mine: Vec<(String, String)> = nodes[i]
                        .matrix
                        .iter()
                        .map(|(k, v)| (k.clone(), matrix::scalar_text(v).unwrap_or_default()))
                        .collect();
                    // Every given key must match; keys left out select
                    // all their values (`ema[lgs=1.0].modes`: every bsd).
                    pairs.iter().all(|p| mine.contains(p))
                })
                .collect();
            if hit.is_empty() {
                return Err((
                    format!("no expansion of `{}` matches `{text}`", r.stage),
                    format!("expansions: {}", names_of(candidates, nodes)),
                ));
            }
            hit
        }
    };
    let mut out = Vec::new();
    for i in chosen {
        // Bad params may hide outputs they would declare (a command's
        // `outs`); those were reported already.
        if !nodes[i].parsed.is_valid() && !nodes[i].has_output(&r.output) {
            continue;
        }
        if !nodes[i].has_output(&r.output) {
            return Err((
                format!("stage `{}` has no output `{}`", nodes[i].name, r.output),
                format!(
                    "outputs of `{}`: {}",
                    nodes[i].name,
                    nodes[i].output_names().join(", ")
                ),
            ));
        }
        out.push((i, r.output.clone()));
    }
    Ok(out)
}

fn names_of(ix: &[usize], nodes: &[Node]) -> String {
    ix.iter()
        .map(|&i| nodes[i].name.as_str())
        .collect::<Vec<_>>()
        .join(", ")
}

/// An input that takes `want` bound to outputs of another type.
fn check_artifact(
    cx: &mut Ctx,
    loc: Option<Location>,
    node: &Node,
    input: &str,
    want: Artifact,
    found: &[(usize, String)],
    nodes: &[Node],
) {
    for (src, out) in found {
        let Some(o) = nodes[*src].outputs.iter().find(|o| &o.name == out) else {
            continue;
        };
        if !want.accepts(o.artifact) {
            let fitting: Vec<String> = nodes[*src]
                .outputs
                .iter()
                .filter(|x| want.accepts(x.artifact))
                .map(|x| format!("{}.{}", nodes[*src].base, x.name))
                .collect();
            let help = if fitting.is_empty() {
                format!(
                    "bind an output that holds {} (`modalflow kinds` lists each kind's outputs)",
                    want.as_str()
                )
            } else {
                format!("did you mean {}?", fitting.join(" or "))
            };
            cx.at(
                loc,
                format!(
                    "input `{input}` of stage `{}` takes a `{}` artifact, but `{}.{out}` is a `{}` artifact",
                    node.name,
                    want.as_str(),
                    nodes[*src].name,
                    o.artifact.as_str()
                ),
                Some(help),
            );
            return;
        }
    }
}
