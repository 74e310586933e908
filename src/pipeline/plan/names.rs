//! Names that become folder names: stage, pipeline and matrix keys, and
//! matrix values (through [`crate::paths::name`]).

use super::Ctx;
use crate::paths::{self, MAX_NAME_BYTES};
use crate::pipeline::matrix;
use crate::pipeline::spec::StageSpec;

pub(super) fn valid_stage_name(name: &str) -> bool {
    !name.is_empty()
        && name.len() <= MAX_NAME_BYTES
        && name
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-')
}

pub(super) fn check_matrix(cx: &mut Ctx, base: &str, st: &StageSpec) -> bool {
    let mut ok = true;
    for (key, values) in &st.matrix {
        let loc = cx.spans.value(&["stages", base, "matrix", key]);
        if values.is_empty() {
            cx.at(
                loc,
                format!("matrix key `{key}` of stage `{base}` has no values"),
                Some("give at least one value".into()),
            );
            ok = false;
        }
        if !valid_stage_name(key) {
            let loc = cx.spans.key(&["stages", base, "matrix", key]);
            cx.at(
                loc,
                format!("invalid matrix key `{key}` in stage `{base}`"),
                Some("use letters, digits, `_` and `-` (keys appear in `${matrix.KEY}` and in the results folder name)".into()),
            );
            ok = false;
        }
        let texts: Vec<Option<String>> = values.iter().map(matrix::scalar_text).collect();
        if texts.iter().any(Option::is_none) {
            cx.at(
                loc,
                format!("matrix key `{key}` of stage `{base}` has a non-scalar value"),
                Some("matrix values must be strings, numbers or booleans".into()),
            );
            ok = false;
        }
        for text in texts.into_iter().flatten() {
            if let Err(problem) = paths::name(&text) {
                cx.at(
                    loc,
                    format!("matrix value `{}` of key `{key}` in stage `{base}` {problem}", text.escape_debug()),
                    Some("matrix values become part of the results folder name: use plain words or numbers, and \
                          build paths in params instead, e.g. `model: models/${matrix.variant}.yaml`".into()),
                );
                ok = false;
            }
        }
    }
    ok
}
