//! Report sections for a GSA screening (PUB2): the significant/non-significant
//! split of each `gsa` stage, how stable the split is between stages (e.g.
//! two seeds of one study), and the Monte Carlo validation of each split.

use super::read_json;
use crate::report::document::Document;
use crate::stages::StageError;
use std::path::PathBuf;

/// One stage's split read from its `significant.csv`.
struct Split {
    stage: String,
    significant: Vec<String>,
    total: usize,
}

fn read_split(stage: &str, path: &PathBuf) -> Result<Split, StageError> {
    let text = std::fs::read_to_string(path)
        .map_err(|e| StageError::io("cannot read input `splits`", e))?;
    let mut lines = text.lines();
    if lines.next() != Some("parameter,score,significant") {
        return Err(StageError::InvalidInput {
            input: "splits".into(),
            message: format!(
                "{stage}: expected a significant.csv (parameter,score,significant) from a gsa stage"
            ),
        });
    }
    let mut significant = Vec::new();
    let mut total = 0;
    for line in lines.filter(|l| !l.trim().is_empty()) {
        total += 1;
        let f: Vec<&str> = line.split(',').collect();
        if f.get(2) == Some(&"true") {
            significant.push(f[0].to_string());
        }
    }
    Ok(Split {
        stage: stage.to_string(),
        significant,
        total,
    })
}

/// The split of every stage, and the agreement of every pair of splits
/// (Jaccard index of the significant sets, and what differs).
pub fn splits(doc: &mut Document, inputs: &[(String, PathBuf)]) -> Result<(), StageError> {
    if inputs.is_empty() {
        return Ok(());
    }
    let splits = inputs
        .iter()
        .map(|(s, p)| read_split(s, p))
        .collect::<Result<Vec<_>, _>>()?;
    doc.heading(2, "Significant parameters");
    doc.table(
        vec!["stage".into(), "significant".into(), "parameters".into()],
        splits
            .iter()
            .map(|s| {
                vec![
                    s.stage.clone(),
                    format!("{} of {}", s.significant.len(), s.total),
                    s.significant.join(" "),
                ]
            })
            .collect(),
    );
    if splits.len() < 2 {
        return Ok(());
    }
    let mut rows = Vec::new();
    for (i, a) in splits.iter().enumerate() {
        for b in &splits[i + 1..] {
            let common = a
                .significant
                .iter()
                .filter(|p| b.significant.contains(p))
                .count();
            let union = a.significant.len() + b.significant.len() - common;
            let only = |x: &Split, y: &Split| {
                x.significant
                    .iter()
                    .filter(|p| !y.significant.contains(p))
                    .cloned()
                    .collect::<Vec<_>>()
                    .join(" ")
            };
            rows.push(vec![
                format!("{} / {}", a.stage, b.stage),
                common.to_string(),
                if union == 0 {
                    "–".into()
                } else {
                    format!("{:.3}", common as f64 / union as f64)
                },
                only(a, b),
                only(b, a),
            ]);
        }
    }
    doc.heading(3, "Stability of the split");
    doc.table(
        [
            "pair",
            "in both",
            "Jaccard",
            "only in first",
            "only in second",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    );
    Ok(())
}

/// Min and mean conformity of each validation (PUB2: 89 % and 98.9 %).
pub fn validations(doc: &mut Document, inputs: &[(String, PathBuf)]) -> Result<(), StageError> {
    if inputs.is_empty() {
        return Ok(());
    }
    let rows = inputs
        .iter()
        .map(|(stage, path)| {
            let v = read_json(path, "validations")?;
            let pct = |x: &serde_json::Value| {
                x.as_f64()
                    .map_or("–".into(), |x| format!("{:.2}", 100.0 * x))
            };
            let count = |k: &str| v[k].as_array().map_or(0, Vec::len);
            Ok(vec![
                stage.clone(),
                v["samples"].to_string(),
                format!(
                    "{} of {}",
                    count("random"),
                    count("random") + count("fixed")
                ),
                v["headline"].as_str().unwrap_or("–").to_string(),
                pct(&v["min"]),
                pct(&v["mean"]),
                v["worst"].as_str().unwrap_or("–").to_string(),
            ])
        })
        .collect::<Result<Vec<_>, StageError>>()?;
    doc.heading(2, "Validation of the split");
    doc.paragraph(
        "Significant parameters at their true values, the others drawn at random within their bounds; conformity of every output with the all-true model.",
    );
    doc.table(
        [
            "stage",
            "samples",
            "random parameters",
            "outputs",
            "min conformity %",
            "mean conformity %",
            "worst output",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    );
    Ok(())
}
