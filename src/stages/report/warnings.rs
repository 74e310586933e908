//! Every warning of every stage the report sees — every upstream stage's
//! own warnings (the engine's, [`crate::stages::UpstreamWarnings`]), the
//! identifications' verdict warnings (`costs`) and the summaries bound to
//! `warnings` (gsa's subproblems.json with its estimators' notes, …) —
//! collapsed and counted: warnings of one stage that differ only in
//! their numbers (one per position or mode) become one row with a count
//! and the first of them in full. A box near the top gives the totals.

use crate::report::document::{Document, Tone};

/// One row: a stage's warnings of one form.
#[derive(Debug, PartialEq)]
pub struct Collapsed {
    pub stage: String,
    pub count: usize,
    /// The first warning of this form, numbers to significant digits.
    pub example: String,
}

/// The form of a warning: each number (digits with a sign, point or
/// exponent) replaced by `#`.
fn form(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut in_number = false;
    for c in text.chars() {
        let digitish =
            c.is_ascii_digit() || (in_number && matches!(c, '.' | 'e' | 'E' | '-' | '+'));
        if digitish {
            if !in_number {
                out.push('#');
            }
            in_number = true;
        } else {
            in_number = false;
            out.push(c);
        }
    }
    out
}

/// Add `warnings` to `stage`'s entry of `per_stage` (appended when it has
/// none): a warning already there is not added again, so a stage's record
/// warnings and the same warnings in its summary count once (each text as
/// often as the list with more of it has it).
pub fn merge(per_stage: &mut Vec<(String, Vec<String>)>, stage: &str, warnings: &[String]) {
    let Some(i) = per_stage.iter().position(|(s, _)| s == stage) else {
        per_stage.push((stage.to_string(), warnings.to_vec()));
        return;
    };
    let mut unmatched = per_stage[i].1.clone();
    for w in warnings {
        match unmatched.iter().position(|u| u == w) {
            Some(k) => {
                unmatched.remove(k);
            }
            None => per_stage[i].1.push(w.clone()),
        }
    }
}

/// Collapse `(stage, warnings)` into rows, in the stages' order and each
/// form at its first occurrence.
pub fn collapse(per_stage: &[(String, Vec<String>)]) -> Vec<Collapsed> {
    let mut rows: Vec<(Collapsed, String)> = Vec::new();
    for (stage, warnings) in per_stage {
        for w in warnings {
            let f = form(w);
            match rows.iter_mut().find(|(r, g)| r.stage == *stage && *g == f) {
                Some((r, _)) => r.count += 1,
                None => rows.push((
                    Collapsed {
                        stage: stage.clone(),
                        count: 1,
                        example: crate::report::format::tidy(w),
                    },
                    f,
                )),
            }
        }
    }
    rows.into_iter().map(|(r, _)| r).collect()
}

/// The box with the totals (near the top of the report).
pub fn summary(doc: &mut Document, per_stage: &[(String, Vec<String>)]) {
    let total: usize = per_stage.iter().map(|(_, w)| w.len()).sum();
    if total == 0 {
        return;
    }
    let lines = per_stage
        .iter()
        .filter(|(_, w)| !w.is_empty())
        .map(|(s, w)| {
            let kinds = collapse(&[(s.clone(), w.clone())]).len();
            format!("{s}: {} warning(s) of {kinds} kind(s)", w.len())
        })
        .collect();
    let stages = per_stage.iter().filter(|(_, w)| !w.is_empty()).count();
    doc.callout(
        Tone::Warning,
        format!("{total} warning(s) from {stages} stage(s) — see Warnings below"),
        lines,
    );
}

/// The section: one row per stage and form.
pub fn section(doc: &mut Document, per_stage: &[(String, Vec<String>)]) {
    let rows = collapse(per_stage);
    if rows.is_empty() {
        return;
    }
    doc.heading(2, "Warnings");
    doc.paragraph(
        "Every warning of the stages upstream of this report (each stage's own, the \
         identifications' verdict warnings, the summaries bound to it); warnings of one stage \
         that differ only in their numbers are one row, counted, with the first of them in full.",
    );
    doc.table(
        ["stage", "count", "warning (first of its kind)"]
            .map(String::from)
            .to_vec(),
        rows.into_iter()
            .map(|r| vec![r.stage, format!("{}×", r.count), r.example])
            .collect(),
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warnings_differing_in_numbers_collapse() {
        let w = |s: &str| s.to_string();
        let per_stage = vec![
            (
                w("ema"),
                vec![
                    w("position 0: mode at 45.1 Hz missed (98× the noise)"),
                    w("position 2: mode at 51.25 Hz missed (12× the noise)"),
                    w("position 0: max_order at its bound 40"),
                ],
            ),
            (
                w("guided"),
                vec![w("position 0: mode at 45.1 Hz missed (98× the noise)")],
            ),
        ];
        let rows = collapse(&per_stage);
        assert_eq!(rows.len(), 3, "{rows:?}");
        assert_eq!((rows[0].stage.as_str(), rows[0].count), ("ema", 2));
        assert!(rows[0].example.starts_with("position 0: mode at 45.1 Hz"));
        assert_eq!((rows[2].stage.as_str(), rows[2].count), ("guided", 1));
        assert_eq!(form("k = 1.5e6, -3"), "k = #, -#");
    }

    #[test]
    fn a_warning_in_record_and_summary_counts_once() {
        let w = |s: &str| s.to_string();
        let mut per_stage = vec![(w("gsa"), vec![w("a"), w("b"), w("b")])];
        merge(&mut per_stage, "gsa", &[w("note"), w("b"), w("a")]);
        assert_eq!(per_stage[0].1, ["a", "b", "b", "note"]);
        merge(&mut per_stage, "gsa", &[w("b"), w("b"), w("b")]);
        assert_eq!(per_stage[0].1, ["a", "b", "b", "note", "b"]);
        merge(&mut per_stage, "guided", &[]);
        assert_eq!(per_stage[1], (w("guided"), vec![]));
    }
}
