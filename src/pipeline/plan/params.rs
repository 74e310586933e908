//! Params of one stage against its kind's schema: names, types, finiteness,
//! then the kind's own checks.

use super::Ctx;
use crate::pipeline::diagnostic::closest;
use crate::pipeline::matrix;
use crate::stages::{ParamType, Stage};
use serde_yaml_ng::{Mapping, Value};

pub(super) fn check_params(cx: &mut Ctx, base: &str, kind: &dyn Stage, params: &Mapping) {
    let before = cx.diags.len();
    let schema = kind.params();
    for (k, v) in params {
        let key = matrix::scalar_text(k).unwrap_or_default();
        let Some(ps) = schema.iter().find(|p| p.name == key) else {
            let allowed: Vec<&str> = schema.iter().map(|p| p.name).collect();
            let mut help = format!("`{}` accepts: {}", kind.kind(), allowed.join(", "));
            if let Some(c) = closest(&key, allowed.iter().copied()) {
                help = format!("did you mean `{c}`? {help}");
            }
            let loc = cx.spans.key(&["stages", base, "params", &key]);
            cx.at(
                loc,
                format!(
                    "unknown param `{key}` for stage `{base}` (kind `{}`)",
                    kind.kind()
                ),
                Some(help),
            );
            continue;
        };
        if let Some(bad) = non_finite(v, &mut vec![key.clone()]) {
            let mut path = vec!["stages", base, "params"];
            path.extend(bad.iter().map(String::as_str));
            let loc = cx.spans.nearest(&path);
            cx.at(
                loc,
                format!(
                    "param `{}` of stage `{base}` is not a finite number",
                    bad.join(".")
                ),
                Some(
                    "use a finite number; NaN and infinity cannot be hashed or computed with"
                        .into(),
                ),
            );
            continue;
        }
        if !type_matches(ps.ty, v) {
            let loc = cx.spans.value(&["stages", base, "params", &key]);
            cx.at(
                loc,
                format!(
                    "param `{key}` of stage `{base}` must be {}",
                    ps.ty.describe()
                ),
                Some(ps.doc.to_string()),
            );
        }
    }
    for ps in schema.iter().filter(|p| p.required) {
        if !params.contains_key(ps.name) {
            let loc = cx.spans.key(&["stages", base]);
            cx.at(
                loc,
                format!(
                    "stage `{base}` (kind `{}`) needs param `{}`",
                    kind.kind(),
                    ps.name
                ),
                Some(format!("`{}`: {}", ps.name, ps.doc)),
            );
        }
    }
    if cx.diags.len() == before {
        if let Err(p) = kind.check(params) {
            let mut path = vec!["stages", base, "params"];
            path.extend(p.path.iter().map(String::as_str));
            let loc = cx.spans.nearest(&path);
            cx.at(loc, format!("stage `{base}`: {}", p.message), p.help);
        }
    }
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

fn type_matches(ty: ParamType, v: &Value) -> bool {
    let strings = |v: &Value| {
        v.as_sequence()
            .is_some_and(|s| s.iter().all(Value::is_string))
    };
    match ty {
        ParamType::Bool => v.is_bool(),
        ParamType::Integer => v.is_i64() || v.is_u64(),
        ParamType::Number => v.is_number(),
        ParamType::String => v.is_string(),
        ParamType::Path | ParamType::Glob => v.as_str().is_some_and(|s| !s.trim().is_empty()),
        ParamType::Paths | ParamType::Strings => strings(v),
        ParamType::Enum(opts) => v.as_str().is_some_and(|s| opts.contains(&s)),
        ParamType::Mapping => v.is_mapping(),
        ParamType::Any => true,
    }
}
