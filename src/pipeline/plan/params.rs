//! Params of one stage: finiteness (nothing else can hash NaN), then the
//! kind's typed parse, every problem located in the file.

use super::Ctx;
use crate::pipeline::matrix;
use crate::stages::params::Class;
use crate::stages::{ParamProblem, Parsed, Stage};
use serde_yaml_ng::{Mapping, Value};

/// The stage's typed params, or `None` after reporting every problem.
pub(super) fn parse_params(
    cx: &mut Ctx,
    base: &str,
    name: &str,
    kind: &dyn Stage,
    params: &Mapping,
) -> Option<Parsed> {
    // Params holding NaN or infinity (nothing can hash them) are reported
    // here; the kind's problems with them would only repeat it.
    let mut non_finite_keys = Vec::new();
    for (k, v) in params {
        let key = matrix::scalar_text(k).unwrap_or_default();
        if let Some(bad) = non_finite(v, &mut vec![key.clone()]) {
            let mut path = vec!["stages", base, "params"];
            path.extend(bad.iter().map(String::as_str));
            let loc = cx.spans.nearest(&path);
            cx.at(
                loc,
                format!(
                    "param `{}` of stage `{name}` is not a finite number",
                    bad.join(".")
                ),
                Some(
                    "use a finite number; NaN and infinity cannot be hashed or computed with"
                        .into(),
                ),
            );
            non_finite_keys.push(key);
        }
    }
    let parsed = kind.parse(params);
    let problems = match parsed {
        Ok(p) if non_finite_keys.is_empty() => return Some(p),
        Ok(_) => Vec::new(),
        Err(problems) => problems,
    };
    for p in problems {
        let repeats = p.class != Class::Unknown
            && p.path.first().is_some_and(|k| non_finite_keys.contains(k));
        if !repeats {
            report(cx, base, name, kind, p);
        }
    }
    None
}

/// Report one param problem of stage `name` (entry `base`) at its place,
/// worded with the stage and kind names the kind itself does not know.
pub(super) fn report(cx: &mut Ctx, base: &str, name: &str, kind: &dyn Stage, p: ParamProblem) {
    let mut path = vec!["stages", base, "params"];
    path.extend(p.path.iter().map(String::as_str));
    let kind = kind.kind();
    let param = p.path.join(".");
    let (loc, message) = match p.class {
        // Point at the stage: the param is not there.
        Class::Missing => (
            cx.spans.key(&["stages", base]),
            format!("stage `{name}` (kind `{kind}`) needs param `{param}`"),
        ),
        // Point at the key itself.
        Class::Unknown => (
            cx.spans.key(&path).or_else(|| cx.spans.nearest(&path)),
            format!("unknown param `{param}` for stage `{name}` (kind `{kind}`)"),
        ),
        // A nested unknown key: point at the key; a bad value: at the value.
        Class::Invalid if p.message.contains("unknown field") => (
            cx.spans.key(&path).or_else(|| cx.spans.nearest(&path)),
            format!("param `{param}` of stage `{name}` {}", p.message),
        ),
        Class::Invalid => (
            cx.spans.nearest(&path),
            format!("param `{param}` of stage `{name}` {}", p.message),
        ),
        Class::Check => (
            cx.spans.nearest(&path),
            format!("stage `{name}`: {}", p.message),
        ),
    };
    cx.at(loc, message, p.help);
}

fn non_finite(v: &Value, path: &mut Vec<String>) -> Option<Vec<String>> {
    match v {
        Value::Number(n) if n.as_f64().is_some_and(|f| !f.is_finite()) => Some(path.clone()),
        Value::Sequence(items) => items.iter().enumerate().find_map(|(i, x)| {
            path.push(i.to_string());
            let r = non_finite(x, path);
            path.pop();
            r
        }),
        Value::Mapping(m) => m.iter().find_map(|(k, x)| {
            path.push(matrix::scalar_text(k).unwrap_or_default());
            let r = non_finite(x, path);
            path.pop();
            r
        }),
        _ => None,
    }
}
